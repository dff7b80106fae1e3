"""Quads by triangle combination (§8.4): facts checkable by hand.

Areas are compared through signed (shoelace) areas, corners through the exact
orient2d, boundaries as sets of edges, conformity by counting the cells on
each edge.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.quads import combination
from meshcore.quads.boundary_layer import meets_targets
from meshcore.quads.combination import ALGORITHMS, combine
from meshcore.quads.optimization import optimize_quads
from meshcore.quads.splitting import split_all
from meshcore.triangulation.refinement import triangulate
from tests.meshcore.quads.stars import star

# 3 --- 2
# |   / |     two triangles of the unit square, sharing the diagonal 0-2
# |  /  |
# | /   |
# 0 --- 1
SQUARE_PTS = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQUARE_TRI = np.array([[0, 1, 2], [0, 2, 3]])


def tri_mesh(points, triangles) -> Mesh:
    return Mesh(np.asarray(points, float), (CellBlock("triangle", np.asarray(triangles)),))


def cells_of(mesh: Mesh) -> list[np.ndarray]:
    return [b.data for b in mesh.cells]


def area(mesh: Mesh) -> float:
    return math.fsum(
        math.fsum(quality.signed_area(mesh.points, b.data, b.type).tolist()) for b in mesh.cells
    )


def edge_counts(mesh: Mesh) -> dict[tuple[int, int], int]:
    counts: dict[tuple[int, int], int] = {}
    for b in mesh.cells:
        k = b.data.shape[1]
        for j in range(k):
            for a, c in zip(b.data[:, j].tolist(), b.data[:, (j + 1) % k].tolist(), strict=True):
                e = (min(a, c), max(a, c))
                counts[e] = counts.get(e, 0) + 1
    return counts


def boundary_edges(mesh: Mesh) -> set[tuple[int, int]]:
    return {e for e, c in edge_counts(mesh).items() if c == 1}


def boundary_segments(mesh: Mesh) -> set:
    """Boundary edges by their end coordinates (independent of the point numbering)."""
    P = mesh.points.tolist()
    return {tuple(sorted((tuple(P[a]), tuple(P[b])))) for a, b in boundary_edges(mesh)}


def assert_strictly_convex(mesh: Mesh) -> None:
    """Every quad corner turns left (exact): no corner of 180 degrees or more."""
    P = mesh.points
    for q in (b.data for b in mesh.cells if b.type == "quad"):
        for j in range(4):
            a, b, c = q[:, j - 1], q[:, j], q[:, (j + 1) % 4]
            assert (orient2d(P[a], P[b], P[c]) == 1).all()
        assert (quality.quad_angles(P, q) < 180).all()


def assert_conforming(mesh: Mesh) -> None:
    assert set(edge_counts(mesh).values()) <= {1, 2}


def star_domain(rng, n: int, holes: int) -> dict:
    th = np.sort((np.arange(n) + rng.uniform(-0.4, 0.4, n)) * 2 * np.pi / n)
    r = rng.uniform(0.55, 1.0, n)
    rings = [np.column_stack([r * np.cos(th), r * np.sin(th)]).tolist()]
    for k in range(holes):
        m = int(rng.integers(3, 9))
        ha = (np.arange(m) + rng.uniform(-0.2, 0.2, m)) * 2 * np.pi / m
        rr = rng.uniform(0.03, 0.12, (m, 1))
        c = 0.3 * np.array([math.cos(2 * math.pi * k / 3), math.sin(2 * math.pi * k / 3)])
        rings.append((c + rr * np.column_stack([np.cos(ha), np.sin(ha)])).tolist())
    return {"type": "Polygon", "coordinates": rings}


def random_mesh(seed: int, size: float = 0.12) -> Mesh:
    rng = np.random.default_rng(seed)
    dom = parse_domain(star_domain(rng, int(rng.integers(8, 20)), int(rng.integers(0, 3))))
    return triangulate(dom, size=size, min_angle=25).mesh


def perturbed_grid(n: int, amp: float, seed: int = 0) -> Mesh:
    """An n x n grid of the unit square, each cell split along a diagonal, interior jittered."""
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    P = np.column_stack([x.ravel(), y.ravel()])
    inner = (P > 0).all(axis=1) & (P < 1).all(axis=1)
    rng = np.random.default_rng(seed)
    P[inner] += rng.uniform(-amp, amp, (int(inner.sum()), 2)) / n
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    v = (j * (n + 1) + i).ravel()
    a, b, c, d = v, v + 1, v + n + 2, v + n + 1
    flip = rng.random(len(v)) < 0.5
    t1 = np.where(flip[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c]))
    t2 = np.where(flip[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))
    return tri_mesh(P, np.concatenate([t1, t2]))


class TestTwoTriangles:
    @pytest.mark.parametrize("algorithm", ALGORITHMS)
    def test_square_is_one_quad_of_quality_one(self, algorithm):
        res = combine(tri_mesh(SQUARE_PTS, SQUARE_TRI), algorithm=algorithm)
        (quads,) = cells_of(res.mesh)
        assert len(quads) == 1 and sorted(quads[0].tolist()) == [0, 1, 2, 3]
        assert quality.quad_quality(res.mesh.points, quads) == pytest.approx([1.0])
        assert res.triangles_left == 0 and res.pairs == 1
        assert res.quality_before["quad"]["quality"]["min"] == pytest.approx(1.0)

    @pytest.mark.parametrize("algorithm", ALGORITHMS)
    def test_non_convex_pair_is_rejected(self, algorithm):
        # 0 (0,0), 1 (2,0), 2 (0.5,0.5), 3 (0,2): the union is a dart, reflex at 2
        P = [[0, 0], [2, 0], [0.5, 0.5], [0, 2]]
        res = combine(tri_mesh(P, [[0, 1, 2], [0, 2, 3]]), algorithm=algorithm)
        assert res.pairs == 0 and res.triangles_left == 2
        assert [b.type for b in res.mesh.cells] == ["quad", "triangle"]
        assert len(res.mesh.cells[0].data) == 0

    def test_flat_corner_is_rejected(self):
        # 0, 1, 2 on a line (the drawback of §8.4.4: aligned edges): a quad flat at 1
        P = [[0, 0], [1, 0], [2, 0], [1, 1]]
        res = combine(tri_mesh(P, [[0, 1, 3], [1, 2, 3]]))
        assert res.pairs == 0 and res.triangles_left == 2

    def test_min_quality(self):
        # a rhombus of 60/120 degrees has quality 2/3
        s = math.sqrt(3) / 2
        P = [[0, 0], [1, 0], [1.5, s], [0.5, s]]
        T = [[0, 1, 2], [0, 2, 3]]
        assert combine(tri_mesh(P, T), min_quality=0.6).pairs == 1
        assert combine(tri_mesh(P, T), min_quality=0.7).pairs == 0


class TestPatterns:
    def test_triangle_with_three_neighbours_makes_three_quads(self):
        #        2
        #      /   \        the central triangle 0 1 2 and its three ears;
        #   5 - - - - 4     the stack path combines the four into three quads
        #      \   /        around the centroid (Figure 8.12, right)
        #        ...
        P = [[0, 0], [2, 0], [1, 1.6], [1, -1.0], [2.2, 1.3], [-0.2, 1.3]]
        T = [[0, 1, 2], [0, 3, 1], [1, 4, 2], [2, 5, 0]]
        mesh = tri_mesh(P, T)
        res = combine(mesh, algorithm="stack")
        assert res.triples == 1 and res.triangles_left == 0
        (quads,) = cells_of(res.mesh)
        assert len(quads) == 3 and len(res.mesh.points) == 7
        assert np.allclose(res.mesh.points[6], np.mean(P[:3], axis=0))
        assert area(res.mesh) == pytest.approx(area(mesh), rel=1e-14)
        assert_strictly_convex(res.mesh)
        assert boundary_edges(res.mesh) == boundary_edges(mesh)

    def test_split_all_figure_8_13(self):
        # one quad (0 1 2 3) and one triangle (1 4 2) sharing the edge 1-2
        P = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5]], float)
        Pn, Q, _ = split_all(P, np.array([[0, 1, 2, 3]]), np.array([[1, 4, 2]]))
        # 6 edges -> 6 midpoints, 2 centroids; 4 + 3 quads
        assert len(Pn) == 5 + 6 + 2 and len(Q) == 7
        out = Mesh(Pn, (CellBlock("quad", Q),))
        assert area(out) == pytest.approx(1.0 + 0.5, rel=1e-15)
        assert_strictly_convex(out)
        assert_conforming(out)
        # the shared edge's midpoint is one point, used by two quads on each side
        mid = np.flatnonzero(np.all(np.isclose(Pn, [1.0, 0.5]), axis=1))
        assert len(mid) == 1 and np.count_nonzero(Q == mid[0]) == 4


class TestRandomDomains:
    @settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1), algorithm=st.sampled_from(ALGORITHMS))
    def test_area_corners_boundary(self, seed, algorithm):
        mesh = random_mesh(seed)
        res = combine(mesh, algorithm=algorithm)
        assert area(res.mesh) == pytest.approx(area(mesh), rel=1e-13)
        assert_strictly_convex(res.mesh)
        assert boundary_edges(res.mesh) == boundary_edges(mesh)
        assert_conforming(res.mesh)
        n_tri = sum(len(b) for b in res.mesh.cells if b.type == "triangle")
        assert n_tri == res.triangles_left
        assert 2 * res.pairs + 4 * res.triples + res.triangles_left == len(mesh.cells[0].data)

    @settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1), algorithm=st.sampled_from(ALGORITHMS))
    def test_same_pairs_translated_by_1e6_or_scaled_by_1e_6(self, seed, algorithm):
        mesh = random_mesh(seed)
        pairs = {tuple(sorted(r)) for r in combine(mesh, algorithm=algorithm).mesh.cells[0].data}
        for moved in (mesh.points + 1e6, mesh.points * 1e-6):
            res = combine(tri_mesh(moved, mesh.cells[0].data), algorithm=algorithm)
            assert {tuple(sorted(r)) for r in res.mesh.cells[0].data} == pairs

    @settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1), amp=st.sampled_from([0.0, 0.25]))
    def test_compiled_candidate_measures_are_the_vectorized_ones(self, seed, amp):
        # the candidates' convexity, (8.7) corner and (8.4)/(8.7) weights from the compiled
        # loop (``quality.planar_quad_measures``) equal the vectorized corners' (mesh.quality
        # with the identity metric) bit for bit, moved or scaled too: the pairs a matching
        # takes must not depend on which computes them
        for mesh in (random_mesh(seed), perturbed_grid(12, amp, seed % 1000)):
            P, tri = combination._check_mesh(mesh)
            nb = combination._neighbours(mesh, P, tri)
            quads = combination._candidates(P, tri, nb, "angle", None, 0.0, 5.0)[0].reshape(-1, 4)
            quads = quads[quads[:, 0] != quads[:, 2]]
            I2 = np.eye(2)
            for Q in (P, P + 1e6, P * 1e-6):
                for measure in ("angle", "simplified"):
                    for flat in (5.0, 45.0):
                        ok, q = combination._allowed_measured(Q, quads, measure, None, flat)
                        assert np.array_equal(ok, combination._allowed(Q, quads, I2, flat))
                        assert np.array_equal(q, combination._measure(Q, quads, measure, I2))

    @settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1))
    def test_matching_leaves_no_more_than_heap(self, seed):
        mesh = random_mesh(seed)
        heap = combine(mesh, algorithm="heap")
        matching = combine(mesh, algorithm="matching")
        assert matching.triangles_left <= heap.triangles_left
        assert matching.triangles_left <= combine(mesh, algorithm="frontal").triangles_left

    @settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1), fine=st.booleans())
    def test_matching_is_a_maximum_matching_of_the_allowed_pairs(self, seed, fine):
        # the count an independent maximum-cardinality matching (networkx) reaches; the
        # fine meshes (about a thousand triangles) leave work for the forest search (it
        # gained 1-3 pairs after the bounded search on 10 of 12 seeds; networkx's blossom
        # took 1.4 s on the 2,500 triangles of size 0.04, 0.25 s here)
        import networkx as nx

        from meshcore.quads.combination import TOL, _candidates, _neighbours

        mesh = random_mesh(seed, 0.06 if fine else 0.12)
        P, tri = mesh.points, mesh.cells[0].data.astype(np.int64)
        nb = _neighbours(mesh, P, tri)
        _, w = _candidates(P, tri, nb, "angle", None, 0.0, TOL.flat_corner)
        t, k = np.nonzero((w >= 0) & (nb > np.arange(len(tri))[:, None]))
        g = nx.Graph()
        g.add_edges_from(zip(t.tolist(), nb[t, k].tolist(), strict=True))
        best = len(nx.max_weight_matching(g, maxcardinality=True))
        default = combination.TOL
        for cap in (default.search_cap, 0):  # 0: the forest search alone
            combination.TOL = dataclasses.replace(default, search_cap=cap)
            try:
                res = combine(mesh, algorithm="matching")
            finally:
                combination.TOL = default
            assert res.pairs == best
            assert res.triangles_left == len(tri) - 2 * best

    @settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**32 - 1), algorithm=st.sampled_from(ALGORITHMS))
    def test_all_quad_is_quads_only_valid_and_conforming(self, seed, algorithm):
        mesh = random_mesh(seed)
        res = combine(mesh, algorithm=algorithm, all_quad=True)
        assert [b.type for b in res.mesh.cells] == ["quad"]
        assert_strictly_convex(res.mesh)
        assert_conforming(res.mesh)
        assert area(res.mesh) == pytest.approx(area(mesh), rel=1e-13)
        # each boundary edge of the input is two edges of the output, end to end
        assert len(boundary_edges(res.mesh)) == 2 * len(boundary_edges(mesh))
        assert res.quality_before["quad"]["invalid"] == 0
        # the report follows the input boundary through the split
        assert res.quality_before["conformity"] == {"nonmanifold": 0, "boundary_edges": 0}


class TestDomainInput:
    HOLE = {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [1, 0], [1, 1], [0, 1]],
            [
                [0.5 + 0.25 * math.cos(t), 0.5 + 0.25 * math.sin(t)]
                for t in np.linspace(0, 2 * math.pi, 40, endpoint=False)
            ],
        ],
    }

    def test_squares_pattern_pairs_into_squares(self):
        res = combine(domain=self.HOLE, size=0.05, algorithm="heap")
        q = quality.quad_quality(res.mesh.points, res.mesh.cells[0].data)
        # the sheared lattice is a square grid cut by diagonals: most pairs are squares
        assert np.median(q) > 0.99
        assert res.stats["input_triangles"] % 2 == 0  # the odd parts were made even
        assert area(res.mesh) == pytest.approx(parse_domain(self.HOLE).area, rel=1e-12)

    def test_twice_size_all_quad_matches_the_size(self):
        res = combine(domain=self.HOLE, size=0.02, algorithm="heap", all_quad=True, twice_size=True)
        Q = res.mesh.cells[0].data
        P = res.mesh.points
        side = np.linalg.norm(P[Q[:, 1]] - P[Q[:, 0]], axis=1)
        assert np.median(side) == pytest.approx(0.02, rel=0.1)
        assert res.quality_before["quad"]["quality"]["mean"] > 0.85
        assert area(res.mesh) == pytest.approx(parse_domain(self.HOLE).area, rel=1e-12)

    def test_spiky_star_gets_the_corner_row_on_a_second_try(self):
        # 33 vertices, 43 % radial jitter: quads of the corner row fall under
        # CORNER_LEAST_QUALITY before the optimization and the row was refused (the
        # lattice then left least quality 0.39, corners 35-134 degrees); tried again
        # at 0 and optimized, it is kept because it meets the targets
        dom = parse_domain(star(np.random.default_rng(282266799), 33, 0.43))
        res = combine(domain=dom, size=0.1, all_quad=True, twice_size=True, optimize=True)
        assert "boundary_layer" in res.stats and set(res.mesh.cells_by_type) == {"quad"}
        assert meets_targets(res.mesh, dom, 0.1)
        assert area(res.mesh) == pytest.approx(dom.area, rel=1e-12)
        assert_strictly_convex(res.mesh)

    def test_twice_size_needs_domain_and_all_quad(self):
        with pytest.raises(InputError) as err:
            combine(domain=self.HOLE, size=0.1, twice_size=True)
        assert err.value.errors[0]["loc"] == ["twice_size"]
        with pytest.raises(InputError):
            combine(tri_mesh(SQUARE_PTS, SQUARE_TRI), twice_size=True, all_quad=True)

    @pytest.mark.parametrize("size", [math.nan, 0.0, 1e-300])
    def test_a_bad_size_is_refused_at_the_top(self, size):
        # NaN and 1e-300 with twice_size were a ValueError from boundary_layer's ring points
        with pytest.raises(InputError) as err:
            combine(domain=self.HOLE, size=size, all_quad=True, twice_size=True)
        assert err.value.errors[0]["loc"] == ["size"]

    @pytest.mark.parametrize("least", [math.nan, -0.1, 2.0, 10**400])
    def test_a_bad_corner_least_is_named(self, least):
        # a quality (8.4) bound: NaN and 2.0 were taken silently, 10**400 an OverflowError
        with pytest.raises(InputError) as err:
            combine(
                domain=self.HOLE,
                size=0.1,
                all_quad=True,
                twice_size=True,
                optimize=True,
                corner_least=least,
            )
        assert err.value.errors[0]["loc"] == ["corner_least"]

    def test_a_size_that_doubles_past_the_largest_float_is_named(self):
        # 1e308 with twice_size was refused by the triangulator as "got inf"
        with pytest.raises(InputError, match="twice_size") as err:
            combine(domain=self.HOLE, size=1e308, all_quad=True, twice_size=True)
        assert err.value.errors[0]["loc"] == ["size"]

    def test_a_size_field_without_values_is_named_under_twice_size(self):
        # the doubled field read size_field["values"] before any check: a KeyError
        with pytest.raises(InputError) as err:
            combine(
                domain=self.HOLE,
                size_field={"points": [[0, 0]]},
                all_quad=True,
                twice_size=True,
            )
        assert err.value.errors[0]["loc"][0] == "size_field"

    def test_a_domain_too_thin_for_its_size_is_refused_up_front(self):
        # a 1 x 1e-6 strip forces about 2M triangles whatever the size (1.54M made, 3.08M
        # quads in 52 CPU s): refused before triangulating, naming triangulate
        strip = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1e-6], [0, 1e-6], [0, 0]]]}
        with pytest.raises(InputError) as err:
            combine(domain=strip, size=0.05, all_quad=True, twice_size=True, optimize=True)
        assert err.value.code == "too_many_cells"
        assert err.value.errors[0]["loc"] == ["domain"]
        assert "2,000,004" in err.value.message and "triangulate" in err.value.message


class TestOptimize:
    def test_empty_quad_mesh_comes_back_empty(self):
        # the compiled smoothing took the least quality of no cells (a ValueError)
        res = optimize_quads(Mesh(np.zeros((0, 2)), (CellBlock("quad", np.zeros((0, 4), int)),)))
        assert len(res.mesh.cells_by_type["quad"]) == 0 and res.operators["smooth"] == 0

    def test_never_lowers_the_min_and_raises_the_mean(self):
        mesh = perturbed_grid(16, 0.3, seed=3)
        res = combine(mesh, algorithm="matching", optimize=True)
        before, after = res.quality_before["quad"], res.quality_after["quad"]
        assert after["quality"]["min"] >= before["quality"]["min"]
        assert after["quality"]["mean"] > before["quality"]["mean"]
        assert after["invalid"] == 0
        assert res.operators["smooth"] > 0
        assert area(res.mesh) == pytest.approx(1.0, rel=1e-12)
        assert_strictly_convex(res.mesh)
        assert_conforming(res.mesh)
        assert boundary_segments(res.mesh) == boundary_segments(mesh)
        # the compiled smoothing and lift (no metric) move the vertices as the
        # vectorized path does (taken with the identity metric); this star's pairs
        # get every kind of move (valence3 4, smooth 107, lift 20)
        pairs = combine(random_mesh(3), algorithm="matching").mesh
        fast, slow = optimize_quads(pairs), optimize_quads(pairs, metric=np.eye(2))
        assert fast.operators == slow.operators and fast.operators["lift"] > 0
        assert np.array_equal(fast.mesh.cells[0].data, slow.mesh.cells[0].data)
        np.testing.assert_allclose(fast.mesh.points, slow.mesh.points, rtol=0, atol=1e-12)

    def test_smoothing_passes_as_given(self):
        # combine without all_quad smooths 1 pass per sweep and 40 after the last on a
        # small mesh (combination.TOL.mixed_passes); no pass moves no vertex by smoothing
        mesh = perturbed_grid(10, 0.3, seed=5)
        pairs = combine(mesh, algorithm="matching").mesh
        res = combine(mesh, algorithm="matching", optimize=True)
        same = optimize_quads(pairs, passes=(1, 40))
        assert np.array_equal(res.mesh.points, same.mesh.points)
        assert res.operators == same.operators and res.operators["smooth"] > 0
        none = optimize_quads(pairs, passes=(0, 0))
        assert none.operators["smooth"] == 0
        assert_strictly_convex(none.mesh)

    def test_all_quad_optimized(self):
        mesh = perturbed_grid(10, 0.3, seed=5)
        res = combine(mesh, algorithm="heap", all_quad=True, optimize=True)
        before, after = res.quality_before["quad"], res.quality_after["quad"]
        assert after["quality"]["min"] >= before["quality"]["min"]
        assert after["quality"]["mean"] > before["quality"]["mean"]
        assert_strictly_convex(res.mesh)
        assert_conforming(res.mesh)

    def test_valence3_vertex_is_removed(self):
        #      4 ---- 3          three quads around the interior vertex 6, off the
        #     /  \    \         centre of the regular hexagon 0..5 (spokes to 0, 2, 4):
        #    5    6 -- 2        replaced by two quads of the hexagon, whose least
        #     \  /    /         quality (2/3) beats that of the three
        #      0 ---- 1
        ang = np.arange(6) * np.pi / 3
        P = np.vstack([np.column_stack([np.cos(ang), np.sin(ang)]), [[0.35, -0.25]]])
        Q = np.array([[6, 0, 1, 2], [6, 2, 3, 4], [6, 4, 5, 0]])
        mesh = Mesh(P, (CellBlock("quad", Q),))
        assert quality.quad_quality(P, Q).min() < 0.6
        out = optimize_quads(mesh)
        assert out.operators["valence3"] == 1
        (q,) = cells_of(out.mesh)
        assert len(q) == 2 and len(out.mesh.points) == 6
        assert quality.quad_quality(out.mesh.points, q) == pytest.approx([2 / 3, 2 / 3])
        assert area(out.mesh) == pytest.approx(area(mesh), rel=1e-14)
        assert_strictly_convex(out.mesh)

    def test_valence2_vertex_is_removed(self):
        # a quad 0 1 2 3 split into two by the interior vertex 4 near the diagonal 1-3
        # (one of the two is reflex at 4: two cells around a vertex cannot both be convex)
        P = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [0.8, 1.0]], float)
        Q = np.array([[0, 1, 4, 3], [1, 2, 3, 4]])
        mesh = Mesh(P, (CellBlock("quad", Q),))
        out = optimize_quads(mesh)
        assert out.operators["valence2"] == 1
        (q,) = cells_of(out.mesh)
        assert len(q) == 1 and sorted(q[0].tolist()) == [0, 1, 2, 3]


class TestMetricAndSurface:
    def test_stretched_mesh_with_metric_gives_the_same_pairs(self):
        mesh = perturbed_grid(12, 0.25, seed=7)
        stretched = tri_mesh(mesh.points * [10.0, 1.0], mesh.cells[0].data)
        plain = combine(mesh, algorithm="heap")
        metric = combine(stretched, algorithm="heap", metric=np.diag([1 / 100, 1.0]))
        a = {tuple(sorted(r)) for r in plain.mesh.cells[0].data.tolist()}
        b = {tuple(sorted(r)) for r in metric.mesh.cells[0].data.tolist()}
        assert a == b and len(a) > 100

    def test_metric_per_vertex(self):
        mesh = perturbed_grid(6, 0.2, seed=1)
        n = len(mesh.points)
        res = combine(mesh, metric=np.tile(np.eye(2), (n, 1, 1)))
        assert res.pairs == combine(mesh).pairs
        with pytest.raises(InputError) as err:
            bad = np.tile(np.eye(2), (n, 1, 1))
            bad[4] = [[1, 0], [0, -1]]
            combine(mesh, metric=bad)
        assert err.value.errors[0]["loc"] == ["metric", 4]

    def test_cylinder_corners_are_measured_in_3d(self):
        nt, nz = 24, 6
        th, z = np.meshgrid(np.arange(nt) * 2 * np.pi / nt, np.linspace(0, 1, nz + 1))
        P = np.column_stack([np.cos(th).ravel(), np.sin(th).ravel(), z.ravel()])
        i, j = np.meshgrid(np.arange(nt), np.arange(nz))
        a = (j * nt + i).ravel()
        b = (j * nt + (i + 1) % nt).ravel()
        c, d = b + nt, a + nt
        T = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
        res = combine(tri_mesh(P, T), algorithm="matching")
        assert res.triangles_left == 0 and res.pairs == nt * nz
        Q = res.mesh.cells[0].data
        # chord rectangles of the cylinder: right angles in 3D, planar
        assert quality.quad_angles(res.mesh.points, Q) == pytest.approx(np.full((len(Q), 4), 90))
        assert quality.quad_quality(res.mesh.points, Q) == pytest.approx(np.ones(len(Q)))
        assert res.stats["warp"]["max"] == pytest.approx(0.0, abs=1e-6)
        # the same mesh projected on the plane z = 0 folds onto itself: not a valid input
        with pytest.raises(InputError):
            combine(tri_mesh(P[:, :2], T))

    def test_twisted_surface_reports_warp(self):
        x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
        P = np.column_stack([x.ravel(), y.ravel(), (0.3 * x * y).ravel()])
        res = combine(tri_mesh(P, perturbed_grid(4, 0.0).cells[0].data))
        assert res.pairs > 0 and res.stats["warp"]["max"] > 0.5


class TestBadInput:
    def test_non_triangle_cells(self):
        mesh = Mesh(SQUARE_PTS, (CellBlock("quad", [[0, 1, 2, 3]]),))
        with pytest.raises(InputError) as err:
            combine(mesh)
        assert err.value.code == "unsupported_cell_type"
        assert err.value.errors[0]["loc"] == ["mesh", "cells", 0, "type"]

    def test_index_out_of_range(self):
        with pytest.raises(InputError) as err:
            combine(tri_mesh(SQUARE_PTS, [[0, 1, 2], [0, 2, 7]]))
        assert err.value.code == "index_out_of_range"
        assert err.value.errors[0]["loc"] == ["mesh", "cells", 0, "data", 1, 2]

    def test_inverted_triangles_are_named(self):
        with pytest.raises(InputError) as err:
            combine(tri_mesh(SQUARE_PTS, [[0, 1, 2], [0, 3, 2]]))
        assert err.value.code == "inverted_cell"
        assert err.value.errors[0]["loc"] == ["mesh", "cells", 0, "data", 1]
        assert "1" in err.value.message

    def test_non_manifold_edge(self):
        P = [[0, 0], [1, 0], [0.5, 1], [0.5, -1], [0.5, 2]]
        with pytest.raises(InputError) as err:
            combine(tri_mesh(P, [[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
        assert err.value.code == "nonmanifold_edge"

    @pytest.mark.parametrize(
        "kw, loc",
        [
            ({"algorithm": "blossom"}, ["algorithm"]),
            ({"measure": "jacobian"}, ["quality"]),
            ({"min_quality": 2.0}, ["min_quality"]),
            ({"metric": [[1, 2], [2, 1]]}, ["metric"]),
        ],
    )
    def test_bad_parameters(self, kw, loc):
        with pytest.raises(InputError) as err:
            combine(tri_mesh(SQUARE_PTS, SQUARE_TRI), **kw)
        assert err.value.errors[0]["loc"] == loc


class TestQuadMeasures:
    """The measures added to meshcore.mesh.quality for §8.4.4 and §8.4.5."""

    Q = [[0, 1, 2, 3]]

    def test_square(self):
        assert quality.quad_quality_simplified(SQUARE_PTS, self.Q) == pytest.approx([1.0])
        assert quality.quad_shape(SQUARE_PTS, self.Q) == pytest.approx([1.0])
        assert quality.quad_warp(SQUARE_PTS, self.Q) == pytest.approx([0.0])

    def test_rhombus_and_rectangle(self):
        s = math.sqrt(3) / 2
        rhombus = [[0, 0], [1, 0], [1.5, s], [0.5, s]]  # 60 degrees at nodes 0 and 2
        assert quality.quad_quality_simplified(rhombus, self.Q) == pytest.approx([2 / 3])
        assert quality.quad_quality(rhombus, self.Q) == pytest.approx([2 / 3])
        # (8.8) of a 2 x 1 rectangle: 2 r / (1 + r**2) = 0.8, while (8.4) is 1
        rect = [[0, 0], [2, 0], [2, 1], [0, 1]]
        assert quality.quad_shape(rect, self.Q) == pytest.approx([0.8])
        assert quality.quad_quality(rect, self.Q) == pytest.approx([1.0])
        # a non-convex quad scores <= 0
        dart = [[0, 0], [2, 0], [0.5, 0.5], [0, 2]]
        assert quality.quad_shape(dart, self.Q)[0] <= 0

    def test_warp_of_a_folded_square(self):
        # the unit square folded by 90 degrees along its diagonal 0-2
        P = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0.5, 0.5, math.sqrt(0.5)]]
        warp = quality.quad_warp(P, self.Q)[0]
        assert 45 < warp <= 180
        flat = [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
        assert quality.quad_warp(flat, self.Q) == pytest.approx([0.0], abs=1e-12)

    def test_metric_per_point_matches_a_constant_one(self):
        s = math.sqrt(3) / 2
        P = np.array([[0, 0], [1, 0], [1.5, s], [0.5, s]])
        M = np.array([[1.0, 0.2], [0.2, 2.0]])
        each = np.tile(M, (4, 1, 1))
        for f in (quality.quad_quality, quality.quad_quality_simplified):
            assert f(P, self.Q, each) == pytest.approx(f(P, self.Q, M))
        # the least over the corners' metrics (8.6)
        D = np.diag([1.0, 0.04])
        each[1] = D
        expect = min(quality.quad_quality(P, self.Q, M)[0], quality.quad_quality(P, self.Q, D)[0])
        assert quality.quad_quality(P, self.Q, each)[0] == pytest.approx(expect)
        assert quality.quad_quality(P, self.Q, D)[0] < quality.quad_quality(P, self.Q, M)[0]
        with pytest.raises(InputError):
            quality.quad_shape(P, self.Q, each)
