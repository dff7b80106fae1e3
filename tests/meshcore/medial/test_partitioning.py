"""Medial-axis partitions (§9.7.1) and quad meshes on them (§9.7.2, §8.5.3)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.errors import InputError
from meshcore.medial.partitioning import partition, quad_medial
from meshcore.mesh import quality, topology
from tests.meshcore.medial.test_axis import stars
from tests.meshcore.quads.stars import issue_star
from tests.meshcore.quads.test_curved_domains import _gear, _ring, _sampled


def circle(c, r, n, cw=False):
    t = 2 * np.pi * np.arange(n) / n
    ring = np.asarray(c) + np.c_[r * np.cos(t), r * np.sin(t)]
    return (ring[::-1] if cw else ring).tolist()


SHAPES = {
    "rectangle": [[[0, 0], [2, 0], [2, 1], [0, 1]]],
    "L": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]],
    "T": [[[0, 0], [3, 0], [3, 1], [2, 1], [2, 3], [1, 3], [1, 1], [0, 1]]],
    "strip": [[[0, 0], [6, 0], [6, 1], [0, 1]]],
    "annulus": [circle([0, 0], 1, 128), circle([0, 0], 0.5, 128, True)],
    "plate": [[[0, 0], [4, 0], [4, 2], [0, 2]], circle([2, 1], 0.5, 64, True)],
}
POLYGONAL = ("rectangle", "L", "T", "strip")


def domain(name):
    return parse_domain({"type": "Polygon", "coordinates": SHAPES[name]})


class TestPartition:
    @pytest.mark.parametrize("method", ["critical", "terminal"])
    @pytest.mark.parametrize("name", list(SHAPES))
    def test_regions_tile_the_domain_with_3_to_6_sides(self, name, method):
        dom = domain(name)
        part = partition(dom, method=method)
        polys = [shapely.Polygon(r["coordinates"][0]) for r in part.regions]
        assert all(p.is_valid and p.area > 0 for p in polys)
        areas = [r["area"] for r in part.regions]
        assert sum(areas) == pytest.approx(dom.area, rel=1e-12)
        # no overlap: the union has the area of the sum
        assert shapely.union_all(polys).area == pytest.approx(dom.area, rel=1e-9)
        assert all(3 <= r["sides"] <= 6 for r in part.regions)

    def test_critical_method_gives_triangles_and_quads(self):
        part = partition(domain("rectangle"), method="critical")
        assert sorted(r["sides"] for r in part.regions) == [3, 3, 3, 3, 4, 4]

    def test_terminal_method_sides_are_type0_nodes_plus_two(self):
        # the rectangle: two regions along the long sides pass both Type 0 nodes
        # (4 sides), the two at the short sides one (3 sides)
        part = partition(domain("rectangle"), method="terminal")
        assert sorted(r["sides"] for r in part.regions) == [3, 3, 4, 4]

    def test_a_loop_without_junction_is_cut(self):
        part = partition(domain("annulus"))
        assert len(part.regions) >= 8 and all(r["sides"] == 4 for r in part.regions)

    def test_a_crowded_junction_keeps_its_cuts_off_its_axis_edges(self):
        # an 11-tooth gear's centre is one node whose circle touches every tooth gap: its
        # 11 axis edges and 22 cuts made regions of 16 degrees there (quads of 16 degrees)
        ring = _ring(_sampled(_gear(11, 0.12), 0.1))
        part = partition(parse_domain({"type": "Polygon", "coordinates": [ring]}))
        p = len(part.axis.samples)
        hub = p + int(np.argmax(np.bincount(part.axis.edges.ravel())))
        angles = []
        for cyc in part.cycles:  # the regions' angles at the hub
            xy = part.points[cyc]
            a, b = np.roll(xy, 1, axis=0) - xy, np.roll(xy, -1, axis=0) - xy
            ang = np.degrees(np.arctan2(b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0], (a * b).sum(1)))
            angles += np.mod(ang, 360)[cyc == hub].tolist()
        assert len(angles) == 11 and min(angles) >= 30

    def test_bad_method(self):
        with pytest.raises(InputError) as exc:
            partition(domain("rectangle"), method="other")
        assert exc.value.errors[0]["loc"] == ["method"]


class TestRandomDomains:
    # 12 examples (were 20): the spiky stars of tests/meshcore/quads/test_curved_domains.py
    # cover quad_medial on random stars too
    @settings(max_examples=12, deadline=None)
    @given(stars(), st.sampled_from(["critical", "terminal"]))
    def test_partition_tiles_and_quads_are_valid(self, ring, method):
        dom = parse_domain({"type": "Polygon", "coordinates": [ring]})
        part = partition(dom, method=method)
        assert sum(r["area"] for r in part.regions) == pytest.approx(dom.area, rel=1e-12)
        assert min(r["sides"] for r in part.regions) >= 3
        res = quad_medial(dom, method=method, size=0.1)
        area = quality.signed_area(res.mesh.points, res.mesh.cells[0].data, "quad")
        assert (area > 0).all()
        assert area.sum() == pytest.approx(dom.area, rel=1e-12)


class TestQuadMedial:
    @pytest.mark.parametrize(
        "name, kwargs",
        [(n, {}) for n in SHAPES] + [(n, {"size": 0.1}) for n in SHAPES],
    )
    def test_only_valid_conforming_quads_covering_the_domain(self, name, kwargs):
        dom = domain(name)
        res = quad_medial(dom, **kwargs)
        mesh = res.mesh
        assert [b.type for b in mesh.cells] == ["quad"]
        quads = mesh.cells[0].data
        area = quality.signed_area(mesh.points, quads, "quad")
        assert (area > 0).all()
        conf = topology.conformity(mesh)
        assert conf["nonmanifold"] == 0
        # every edge of the mesh boundary lies on the input boundary
        edges = topology.boundary(mesh).cells[0].data
        segs = dom.points[dom.segments]
        mid = mesh.points[edges].mean(axis=1)
        a, b = segs[:, 0][None], segs[:, 1][None]
        ab = b - a
        t = np.clip(np.einsum("nmk,nmk->nm", mid[:, None] - a, ab) / (ab**2).sum(-1), 0, 1)
        off = np.hypot(*(mid[:, None] - a - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)
        if name in POLYGONAL:
            assert off.max() < 1e-12
            assert area.sum() == pytest.approx(dom.area, rel=1e-12)
        else:  # curved rings: the mesh's boundary points are on the rings, edges are chords
            assert area.sum() == pytest.approx(dom.area, rel=0.02)

    def test_terminal_region_with_a_slit_falls_back_to_critical(self):
        # a dead-end cut inside a terminal region (its cycle passes a vertex twice) gave a
        # fill with a sliver hole along it: boundary edges 0.11 off the input boundary,
        # the area short by 1e-6 of it
        dom = parse_domain(issue_star(22)[0])
        res = quad_medial(dom, method="terminal", size=0.5)
        assert "fallback" in res.stats and res.stats["slits"] == 0
        mesh = res.mesh
        area = quality.signed_area(mesh.points, mesh.cells[0].data, "quad")
        assert (area > 0).all() and area.sum() == pytest.approx(dom.area, rel=1e-12)
        assert topology.conformity(mesh)["nonmanifold"] == 0
        edges = mesh.points[topology.boundary(mesh).cells[0].data]
        segs = dom.points[dom.segments]
        length = np.hypot(*(edges[:, 1] - edges[:, 0]).T).sum()  # a hole's edges added
        assert length == pytest.approx(np.hypot(*(segs[:, 1] - segs[:, 0]).T).sum(), rel=1e-12)

    def test_levels_multiply_the_quads_by_four(self):
        dom = domain("rectangle")
        counts = [len(quad_medial(dom, levels=k).mesh.cells[0].data) for k in (0, 1, 2)]
        assert counts[1] == 4 * counts[0] and counts[2] == 16 * counts[0]

    def test_size_sets_the_edge_length(self):
        res = quad_medial(domain("strip"), size=0.1)
        q = res.mesh.cells[0].data
        p = res.mesh.points
        lengths = np.hypot(*(p[q] - p[np.roll(q, -1, axis=1)]).transpose(2, 0, 1))
        assert 0.03 < np.median(lengths) <= 0.1

    def test_size_and_levels_exclude_each_other(self):
        with pytest.raises(InputError):
            quad_medial(domain("rectangle"), size=0.1, levels=1)


def test_geojson_mapping_is_parsed_as_the_other_methods_do():
    # quad_medial (and medial_axis under it) took only a parsed Domain: a GeoJSON mapping,
    # as triangulate and combine take, failed with an AttributeError
    geo = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]}
    a, b = quad_medial(geo, size=0.1), quad_medial(parse_domain(geo), size=0.1)
    assert np.array_equal(a.mesh.points, b.mesh.points)
    assert np.array_equal(a.mesh.cells_by_type["quad"], b.mesh.cells_by_type["quad"])


def test_small_regions_merged_across_their_shared_chain():
    # a 2 x 1 rectangle cut in two squares: with one coarse quad allowed per unit of
    # area, the two merge into one region across their cut, whose ends are no longer
    # corners (two edges left each)
    from meshcore.medial.regions import small_merged

    P = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1]], dtype=float)
    cycles = [np.array([0, 1, 4, 5]), np.array([1, 2, 3, 4])]
    corners = [np.ones(4, bool), np.ones(4, bool)]
    kinds = [np.array([0, 2, 0, 0], np.int8), np.array([0, 0, 0, 2], np.int8)]
    got, flags, kinds2, merges = small_merged(P, 6, cycles, corners, kinds, 1.0, 2.0, 1.0)
    assert merges == 1 and len(got) == 1
    assert sorted(got[0].tolist()) == list(range(6))
    assert sorted(got[0][flags[0]].tolist()) == [0, 2, 3, 5]
    assert (kinds2[0] == 0).all()  # the cut is gone
    # the budget met already: nothing merged
    assert small_merged(P, 6, cycles, corners, kinds, 1.0, 2.0, 4.0)[3] == 0


def test_no_o_grid_where_it_would_split_a_sharp_border_corner():
    # ten quads around a vertex whose far corners are 41 degree spikes of the border: an
    # O-grid would give each spike two quads of 20 degrees; at 125 degrees it is made
    from meshcore.medial.fill import _flowered

    t = np.arange(20) * np.pi / 10
    Q = np.array([[0, 1 + 2 * i, 2 + 2 * i, 1 + (2 * i + 2) % 20] for i in range(10)])
    for spike, made in ((1.6, 0), (1.0, 1)):
        rim = np.c_[np.cos(t), np.sin(t)] * np.where(np.arange(20) % 2, spike, 0.9)[:, None]
        assert _flowered(np.vstack([[0.0, 0.0], rim]), Q)[2] == made


@pytest.mark.parametrize(("nb", "nl"), [(3, 2), (5, 2), (3, 4), (5, 4), (9, 2)])
def test_a_transition_conforms_with_convex_quads(nb, nl):
    # a coarse quad of the unit square, top 3 and right 2 pieces, its bottom (and left)
    # finer by 3-to-1 templates: conforming strictly convex quads covering it exactly
    from meshcore.medial.fill import _transition, folded

    def line(a, b, n):
        return np.linspace(a, b, n + 1)

    bottom, top = line([0.0, 0.0], [1.0, 0.0], nb), line([0.0, 1.0], [1.0, 1.0], 3)
    left, right = line([0.0, 0.0], [0.0, 1.0], nl), line([1.0, 0.0], [1.0, 1.0], 2)
    P, Q, corners = _transition(bottom, right, top, left)
    # points are merged by coordinates in the fill: check the copies the same way
    P, ids = np.unique(P, axis=0, return_inverse=True)
    Q, corners = ids.ravel()[Q], ids.ravel()[corners]
    assert len(Q) == 3 * 2 + 3 * (nb - 3) // 2 + 3 * (nl - 2) // 2
    assert np.isclose(quality.signed_area(P, Q, "quad").sum(), 1.0)
    assert not folded(P, Q).any()  # every corner strictly convex (exact)
    edges = np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], axis=-1).reshape(-1, 2), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert uses.max() == 2 and (uses == 1).sum() == nb + nl + 3 + 2  # conforming
    assert sorted(P[corners].tolist()) == [[0, 0], [0, 1], [1, 0], [1, 1]]


def test_no_fill_with_transitions_where_the_coarse_quads_pass_the_count():
    # issue star 17 at size 0.15: the regions' coarse quads (one per side) and its input
    # vertices' counts are over 1.5x area / size**2 (2.66x with its four-sided regions as
    # one patch), so no count of the sides brings the fill within: none is made
    from meshcore.medial.fill import MOST_COUNT, quads_on

    dom = parse_domain(issue_star(17)[0])
    part = partition(dom)
    assert sum(r["sides"] for r in part.regions) * 0.15**2 > MOST_COUNT * dom.area
    assert quads_on(part, 0.15, None, transitions=True) is None


def test_a_straight_border_point_of_four_quads_gives_one_up():
    # four quads of 45 degrees at a straight border point (four regions met there): the
    # edge between two of them is turned, three quads stay at the point, same area
    from meshcore.medial.fill import _closed

    t = np.arange(9) * np.pi / 8
    rim = np.c_[np.cos(t), np.sin(t)]
    P = np.vstack([[0.0, 0.0], rim, 2 * rim])  # v = 0, p_i = 1 + i, q_i = 10 + i
    Q = [[0, 1 + 2 * i, 2 + 2 * i, 3 + 2 * i] for i in range(4)]
    Q += [[1 + i, 10 + i, 11 + i, 2 + i] for i in range(8)]
    Q = np.array(Q)
    Q2, closed = _closed(P, Q)
    assert closed == 1 and (Q2 == 0).any(axis=1).sum() == 3
    area = quality.signed_area(P, Q2, "quad")
    assert (area > 0).all()
    assert area.sum() == pytest.approx(quality.signed_area(P, Q, "quad").sum(), rel=1e-12)


def test_a_turn_that_bends_a_corner_past_180_is_opened_by_the_smoothing():
    # four quads of 18, 25, 55 and 82 degrees at a straight border point, their far
    # corners pushed out: the best turn bends a corner to 221 degrees (gear 7 at size
    # 0.1 kept such a point, least quality 0.4997); the smoothing then opens it
    from meshcore.medial.fill import _closed, _smoothed, folded
    from meshcore.partition.smoothing import boundary_points

    stops = np.radians([0.0, 18.0, 43.0, 98.0, 180.0])
    t = np.sort(np.r_[stops, (stops[:-1] + stops[1:]) / 2])
    rim = np.c_[np.cos(t), np.sin(t)]
    rim[[1, 3, 5, 7]] *= 1.6
    P = np.vstack([[0.0, 0.0], rim, 2 * rim])
    Q = [[0, 1 + 2 * i, 2 + 2 * i, 3 + 2 * i] for i in range(4)]
    Q = np.array(Q + [[1 + i, 10 + i, 11 + i, 2 + i] for i in range(8)])
    assert not folded(P, Q).any()
    Q2, closed = _closed(P, Q)
    assert closed == 1 and 200 < quality.quad_angles(P, Q2).max() < 260
    P2 = _smoothed(P, Q2, boundary_points(P, Q2), 50)
    assert (
        not folded(P2, Q2).any() and (P2[boundary_points(P, Q2)] == P[boundary_points(P, Q2)]).all()
    )
    area = quality.signed_area(P2, Q2, "quad").sum()
    assert area == pytest.approx(quality.signed_area(P, Q, "quad").sum(), rel=1e-12)


def test_four_sided_regions_as_one_patch_keep_the_count():
    # issue star 12 at size 0.15: the midpoint subdivision of its 63 regions (41 of four
    # sides) passes 1.5x area / size**2 at every stretch (1.66x); with every four-sided
    # region of corners in [45, 135] degrees one patch (cut across where a neighbour
    # halves a side: 2 patches, or 4) it is within, conforming, convex and area-exact
    from meshcore.medial.fill import MOST_COUNT, quads_on
    from meshcore.medial.partitioning import BOUNDARY_SHARE, _reflex_merged

    dom = parse_domain(issue_star(12)[0])
    part = _reflex_merged(partition(dom), BOUNDARY_SHARE)
    mesh, stats = quads_on(part, 0.15, None)
    mesh4, stats4 = quads_on(part, 0.15, None, four=True)
    assert stats["quads"] * 0.15**2 > MOST_COUNT * dom.area
    assert stats4["quads"] * 0.15**2 <= MOST_COUNT * dom.area
    assert stats4["one_patch"] > 0 and stats4["coarse_quads"] < stats["coarse_quads"]
    assert stats4["invalid"] == stats4["not_convex"] == 0
    assert stats4["area"] == pytest.approx(dom.area, rel=1e-12)
    Q = mesh4.cells_by_type["quad"]
    edges = np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], axis=-1).reshape(-1, 2), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert uses.max() == 2  # conforming: no edge in three quads
    boundary = topology.boundary(mesh4).cells[0].data
    assert len(boundary) == (uses == 1).sum()


def test_a_spike_is_cut_at_its_base_where_the_corner_chord_crosses_it():
    # a spike of 5.7 degrees between two reflex corners, the region's corners before and
    # after it (A, B) on either side of its body: the chord A-B crosses the spike, so it
    # was left in the region (issue star 22 at size 0.1: a 4-degree spike, least quality
    # 0.31 in its quads). It is cut at its base instead, between the reflex corners
    from meshcore.medial.regions import spike_chords

    P = np.array([[-3, 0], [-1, -0.1], [-1.5, -1], [1, -1], [1, 1], [-1.5, 1], [-1, 0.1]])
    verts = np.arange(7)
    a, b = P[verts] - P[np.roll(verts, 1)], P[np.roll(verts, -1)] - P[verts]
    turn = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1))
    corner = np.array([0, 0, 1, 1, 1, 1, 0], bool)
    kinds = np.zeros(7, np.int8)
    cycles, corners, _, chords = spike_chords(P, [verts], [corner], [kinds], turn)
    assert chords == [(6, 1)]
    tip = [c for c in cycles if 0 in c]
    assert len(tip) == 1 and sorted(tip[0].tolist()) == [0, 1, 6]
    assert sorted(int(f.sum()) for f in corners) == [3, 6]
