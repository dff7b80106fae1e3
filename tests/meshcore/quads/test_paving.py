"""Paving (§8.5.1): only quads on every domain drawn, valid, conforming, exact area.

The valence share and least quality against Gmsh are in ``benchmarks/paving.py``,
not asserted here.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from scipy.spatial import cKDTree

from meshcore import InputError, parse_domain
from meshcore.mesh.quality import quad_quality
from meshcore.partition import boundary_points, size_map, smooth_quads, square_corners
from meshcore.partition.kernel import strictly_convex_rows
from meshcore.quads import advancing_front, paving, paving_fronts, paving_kernel
from tests.meshcore.partition.test_recursive import (
    L_SHAPE,
    SQUARE,
    SQUARE_HOLE,
    check_mesh,
    star_with_hole,
)


def quad_partition_stuck(real):
    """``partition_polygon`` that gives no cells in quad mode (as when it is stuck)."""

    def stuck(points, loops, ring_polygon, sizes, *, quad, strategy="balanced", **kw):
        if quad:
            return points, None, None
        return real(points, loops, ring_polygon, sizes, quad=quad, strategy=strategy)

    return stuck


class TestBadInput:
    @pytest.mark.parametrize("size", [0, -1, float("inf")])
    def test_size_is_named(self, size):
        with pytest.raises(InputError) as ei:
            paving(SQUARE, size=size)
        assert ei.value.errors[0]["loc"] == ["size"]

    def test_max_rows_is_named(self):
        with pytest.raises(InputError) as ei:
            paving(SQUARE, size=0.1, max_rows=-1)
        assert ei.value.errors[0]["loc"] == ["max_rows"]

    def test_dense_boundary_refused_before_any_work(self):
        # a 6,000-vertex circle at size 0.2: every vertex stays, so the rows' neighbour
        # searches would hold about 3e7 pairs (a 100,000-vertex one at size 0.05, 2e9,
        # ran out of 8 GB)
        t = 2 * np.pi * np.arange(6_000) / 6_000
        ring = np.column_stack([np.cos(t), np.sin(t)]) / 2
        with pytest.raises(InputError) as ei:
            paving({"type": "Polygon", "coordinates": [ring.tolist()]}, size=0.2)
        assert ei.value.code == "boundary_denser_than_size"
        assert ei.value.errors[0]["loc"] == ["domain"]

    def test_constraints_refused(self):
        dom = parse_domain(SQUARE, segments=[[[0.2, 0.2], [0.8, 0.8]]])
        with pytest.raises(InputError) as ei:
            paving(dom, size=0.1)
        assert ei.value.code == "unsupported"


class TestCanonical:
    def test_square_is_a_grid(self):
        # rows from the four sides meet in the middle: a 10 x 10 grid of unit squares
        res = paving(SQUARE, size=0.1)
        check_mesh(SQUARE, res, 0.1, "quad")
        q = quad_quality(res.mesh.points, res.mesh.cells[0].data)
        assert len(q) == 100
        assert q.min() > 0.999
        assert res.stats["valence"] == {"4": 81}

    @pytest.mark.parametrize("geometry", [L_SHAPE, SQUARE_HOLE])
    def test_valid_only_quads(self, geometry):
        res = paving(geometry, size=0.05)
        check_mesh(geometry, res, 0.05, "quad")
        assert res.quality["quad"]["invalid"] == 0
        assert res.stats["rows"] >= 2
        # translated by 1e6 or scaled by 1e-6: the same cells and the same points moved
        # back (translated, the input itself is rounded at 1e-10)
        cells = res.mesh.cells[0].data
        for shift, scale in ((1e6, 1.0), (0.0, 1e-6)):
            moved = {
                "type": "Polygon",
                "coordinates": [
                    (np.array(r) * scale + shift).tolist() for r in geometry["coordinates"]
                ],
            }
            other = paving(moved, size=0.05 * scale)
            check_mesh(moved, other, 0.05 * scale, "quad")
            assert np.array_equal(other.mesh.cells[0].data, cells)
            back = (other.mesh.points - shift) / scale
            assert np.allclose(back, res.mesh.points, rtol=0, atol=1e-8 if shift else 1e-9)

    def test_a_front_meeting_itself_splits(self):
        # two rooms joined by a neck one size wide: the rows from both sides of the
        # neck snap together and the front splits in two, one per room; every quad a
        # unit square
        rooms = {
            "type": "Polygon",
            "coordinates": [
                [[0, 0], [1, 0], [1, 0.4], [1.1, 0.4], [1.1, 0], [2.1, 0], [2.1, 1]]
                + [[1.1, 1], [1.1, 0.6], [1, 0.6], [1, 1], [0, 1]]
            ],
        }
        res = paving(rooms, size=0.1)
        check_mesh(rooms, res, 0.1, "quad")
        assert res.stats["splits"] >= 1 and res.stats["snaps"] >= 2
        assert quad_quality(res.mesh.points, res.mesh.cells[0].data).min() > 0.999

    def test_reversal(self):
        # a slit-like notch: its tip is a reversal (five new nodes, four quads)
        notch = {
            "type": "Polygon",
            "coordinates": [[[0, 0], [0.47, 0], [0.5, 0.5], [0.53, 0], [1, 0], [1, 1], [0, 1]]],
        }
        res = paving(notch, size=0.1)
        check_mesh(notch, res, 0.1, "quad", median=False)
        assert res.stats["node_classes"]["reversal"] >= 1

    def test_odd_ring_repaired_and_reported(self):
        tri = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1]]]}
        res = paving(tri, size=0.3)
        check_mesh(tri, res, 0.3, "quad", median=False)
        assert res.stats["parity_repairs"]

    def test_smoothing_never_lowers_least_quality(self):
        raw = paving(SQUARE_HOLE, size=0.05, smooth=False)
        check_mesh(SQUARE_HOLE, raw, 0.05, "quad")
        assert raw.stats["node_classes"]["wedge"] >= 1  # rows growing out of the hole
        P, C = raw.mesh.points, raw.mesh.cells[0].data
        q0 = quad_quality(P, C)
        P1, _ = smooth_quads(P, C, boundary_points(P, C))
        q1 = quad_quality(P1, C)
        assert q1.min() >= q0.min()
        assert q1.mean() > q0.mean()
        assert strictly_convex_rows(P1, C).all()
        # the corners squared: valid, the least kept, the mean up, the boundary still
        fixed = boundary_points(P1, C)
        P2, moved = square_corners(P1, C, fixed)
        q3 = quad_quality(P2, C)
        assert moved > 0 and strictly_convex_rows(P2, C).all()
        assert q3.min() >= q1.min() and q3.mean() > q1.mean()
        assert np.array_equal(P2[fixed], P1[fixed])
        # then the clean-up: still only quads, valid, and better still
        smooth = paving(SQUARE_HOLE, size=0.05)
        check_mesh(SQUARE_HOLE, smooth, 0.05, "quad")
        q2 = quad_quality(smooth.mesh.points, smooth.mesh.cells[0].data)
        assert q2.min() >= q1.min()
        assert smooth.stats["clean_up"]["region"] > 0
        assert smooth.stats["smoothing"]["squared"] > 0

    def test_zero_rows_is_the_closure_alone(self):
        res = paving(L_SHAPE, size=0.1, max_rows=0)
        check_mesh(L_SHAPE, res, 0.1, "quad", median=False)
        assert res.stats["rows"] == 0


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=star_with_hole())
def test_random_polygons_with_holes_only_quads(case):
    geometry, size = case
    res = paving(geometry, size=size)
    check_mesh(geometry, res, size, "quad", median=False)


def test_guaranteed_route_when_the_closure_is_stuck(monkeypatch):
    # rows that stop early: laid again with every new front evened out, only quads
    pave = advancing_front._pave

    def early(bnd, sizes, max_rows, quad_closure, strategy, even):
        if quad_closure and not even:
            return None
        return pave(bnd, sizes, max_rows, quad_closure, strategy, even)

    monkeypatch.setattr(advancing_front, "_pave", early)
    res = paving(SQUARE_HOLE, size=0.05)
    assert res.stats["evened"] == 1 and res.stats["fallback"] == 0
    check_mesh(SQUARE_HOLE, res, 0.05, "quad")
    monkeypatch.setattr(advancing_front, "_pave", pave)
    # force the even closure to fail: the rows are taken back (the evened rows too),
    # then the whole mesh is made at 2.5 h with a triangle closure and split into quads
    stuck = quad_partition_stuck(advancing_front.partition_polygon)
    monkeypatch.setattr(advancing_front, "partition_polygon", stuck)
    monkeypatch.setattr(paving_fronts, "partition_polygon", stuck)
    # the closure's templates and local rescues of stuck polygons are stuck too
    monkeypatch.setattr(paving_fronts, "template", lambda *args: None)
    monkeypatch.setattr(paving_fronts, "_ring", lambda *args: None)
    monkeypatch.setattr(paving_fronts, "_coarse_split", lambda *args: None)
    res = paving(SQUARE_HOLE, size=0.05)
    assert res.stats["fallback"] == 1 and res.stats["evened"] == 0
    check_mesh(SQUARE_HOLE, res, 0.05, "quad")


def test_near_pairs_are_the_kd_tree_pairs():
    # the rows' fixed-radius neighbour search: the same pairs and distances as scipy's
    # KD-tree, points of A outside B's box and a radius wider than B included
    rng = np.random.default_rng(7)
    A = rng.uniform(-0.2, 1.2, (300, 2))
    B = rng.uniform(0, 1, (500, 2))
    for a, r in ((A, 0.0), (A, 0.013), (A, 0.1), (A[:5], 3.0)):
        i, j, d = paving_kernel.near_pairs(a, B, r)
        ref = cKDTree(a).sparse_distance_matrix(cKDTree(B), r, output_type="ndarray")
        got = np.unique(np.column_stack([i, j]), axis=0)
        assert len(got) == len(i)
        assert np.array_equal(got, np.unique(np.column_stack([ref["i"], ref["j"]]), axis=0))
        assert np.allclose(d, np.hypot(*(a[i] - B[j]).T))
    i, _, _ = paving_kernel.near_pairs(A, B[:0], 0.1)
    assert len(i) == 0


def test_cycles_start_at_their_largest_index():
    # the fronts' tracing: each cycle of the permutation from its largest index along
    # succ, the cycles by their largest index descending
    order, cuts = paving_kernel.cycles(np.array([2, 0, 1, 4, 3, 5], np.int64))
    assert [c.tolist() for c in np.split(order, cuts)] == [[5], [4, 3], [2, 1, 0]]
    succ = np.random.default_rng(3).permutation(200).astype(np.int64)
    loops = np.split(*paving_kernel.cycles(succ))
    assert sorted(np.concatenate(loops).tolist()) == list(range(200))
    assert [c[0] for c in loops] == sorted((c.max() for c in loops), reverse=True)
    for c in loops:
        assert np.array_equal(succ[c], np.roll(c, -1))


def _area(P, ring):
    """Signed area of the polygon P[ring] (shoelace)."""
    x, y = P[ring, 0], P[ring, 1]
    return 0.5 * float((x * np.roll(y, -1) - y * np.roll(x, -1)).sum())


def _closes(P, loop, cells):
    """The cells tile the polygon ``loop`` exactly: strictly convex, their area the
    polygon's, their boundary edges the polygon's edges."""
    assert strictly_convex_rows(P, cells).all()
    assert np.isclose(sum(_area(P, c) for c in cells), _area(P, loop))
    e = np.sort(np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    u, cnt = np.unique(e, axis=0, return_counts=True)
    ring = np.sort(np.column_stack([loop, np.roll(loop, -1)]), axis=1)
    assert cnt.max() <= 2
    assert {tuple(x) for x in u[cnt == 1]} == {tuple(x) for x in ring}


class TestFrontsMeeting:
    def _rectangle_front(self, h, width, height):
        nx, ny = round(width / h), round(height / h)
        bottom = [(i * h, 0.0) for i in range(nx)]
        right = [(width, j * h) for j in range(ny)]
        top = [(width - i * h, height) for i in range(nx)]
        left = [(0.0, height - j * h) for j in range(ny)]
        return np.array(bottom + right + top + left)

    def test_a_thin_band_is_closed_by_a_strip(self):
        # a front 1 x 0.3 at h = 0.1: bottom and top nodes face each other 3 h apart,
        # the strip is a 3-wide grid between them; what is left is two even end pieces
        P = self._rectangle_front(0.1, 1.0, 0.3)
        loop = np.arange(len(P))
        sizes = size_map(parse_domain(SQUARE), 0.1, None)
        banned = np.zeros(len(P), bool)
        P1, left, quads, strips = advancing_front._ladders(P, [loop], sizes, banned, 6.5)
        assert strips == 1 and len(quads) == 8 * 3
        assert np.array_equal(P1[: len(P)], P)
        assert all(len(g) % 2 == 0 for g in left) and len(left) == 2
        assert strictly_convex_rows(P1, quads).all()
        covered = sum(_area(P1, q) for q in quads) + sum(_area(P1, g) for g in left)
        assert np.isclose(covered, 0.3)
        # the end rungs are bowed into the strip: the pieces left turn at their points
        for g in left:
            assert (np.degrees(advancing_front._angles(P1, g))[g >= len(P)] < 179).all()

    def test_a_small_stuck_polygon_is_closed_by_a_ring(self):
        # a triangle with one side split (4 segments, a flat corner): no quad fits it,
        # a ring of four quads around a shrunk copy (one quad) does
        P = np.array([[0.5, 0.0], [1.0, 0.0], [0.35, 0.8], [0.0, 0.0]])
        loop = np.arange(4)
        sizes = size_map(parse_domain(SQUARE), 0.3, None)
        Q, cells = paving_fronts._ring(P, loop, sizes, "balanced")
        assert len(cells) == 5
        _closes(Q, loop, cells)

    def test_a_ring_gives_way_to_a_cavity_the_partition_closes(self):
        # the ring test's stuck polygon inside four quads: rather than a ring (valence-3
        # corners), the polygon grown by those quads, a convex quadrilateral, one quad
        P = np.array([[0.5, 0], [1, 0], [0.35, 0.8], [0, 0], [0.6, -0.6], [1.6, -0.2]])
        P = np.concatenate([P, [[0.4, 1.4], [-0.6, -0.4]]])
        loop = np.arange(4)
        around = np.array([[4 + i, 4 + (i + 1) % 4, (i + 1) % 4, i] for i in range(4)])
        sizes = size_map(parse_domain(SQUARE), 0.3, None)
        Q, cells, stats, gone = paving_fronts._close(P, [loop], sizes, "balanced", around)
        assert stats["cavities"] == 1 and stats["rings"] == 0 and gone.all()
        assert np.array_equal(cells, [[7, 4, 5, 6]])

    @pytest.mark.parametrize("tail", [4096, 0])
    def test_a_cavity_takes_the_live_quads_at_its_polygon_listed_or_added(self, monkeypatch, tail):
        # a 3 x 3 grid of unit quads, the centre one the stuck polygon: two of its edge
        # neighbours in the pool from the start (with the corners), two added after
        # (rows at each point listed again on every addition when tail is 0)
        monkeypatch.setattr(paving_fronts._Pool, "_TAIL", tail)

        def cell(i, j):
            return [4 * i + j, 4 * i + j + 1, 4 * i + j + 5, 4 * i + j + 4]

        first = [cell(0, 0), cell(0, 2), cell(2, 0), cell(2, 2), cell(0, 1), cell(1, 0)]
        pool = paving_fronts._Pool(np.array(first, np.int64), 16)
        pool.add(np.array([cell(1, 2), cell(2, 1)], np.int64), 16)
        loop = np.array(cell(1, 1))
        grown, take = pool.cavity(loop, pool.live, 16)
        assert take.tolist() == [4, 5, 6, 7] and len(grown) == 12  # the plus shape
        live = pool.live.copy()
        live[4] = False
        grown, take = pool.cavity(loop, live, 16)
        assert take.tolist() == [5, 6, 7] and len(grown) == 10  # a T

    def test_coarse_split_keeps_the_polygon_edges(self, monkeypatch):
        # a hexagon with every side split: every other vertex is the hexagon, its
        # triangles cut in three quads through the skipped vertices
        t = np.radians(np.arange(6) * 60.0)
        hexagon = np.column_stack([np.cos(t), np.sin(t)])
        mid = (hexagon + np.roll(hexagon, -1, axis=0)) / 2
        P = np.stack([hexagon, mid], axis=1).reshape(-1, 2)
        loop = np.arange(12)
        sizes = size_map(parse_domain(SQUARE), 1.0, None)
        Q, cells = paving_fronts._coarse_split(P, loop, sizes, "balanced")
        assert np.array_equal(Q[:12], P)
        _closes(Q, loop, cells)
        # the closure with every quad partition and local rescue stuck: stuck as a
        # whole, then the polygon's own coarse split (the local guaranteed route)
        stuck = quad_partition_stuck(paving_fronts.partition_polygon)
        monkeypatch.setattr(paving_fronts, "partition_polygon", stuck)
        monkeypatch.setattr(paving_fronts, "template", lambda *args: None)
        monkeypatch.setattr(paving_fronts, "_ring", lambda *args: None)
        none = np.zeros((0, 4), np.int64)
        assert paving_fronts._close(P, [loop], sizes, "balanced", none)[1] is None
        Q, cells, stats, gone = paving_fronts._close(P, [loop], sizes, "balanced", none, True)
        assert stats["polygon_splits"] == 1 and len(gone) == 0
        assert np.array_equal(Q[:12], P)
        _closes(Q, loop, cells)

    @pytest.mark.parametrize("name", ["plate", "gear"])
    def test_meeting_fronts_only_quads(self, name):
        # the benchmark's plate and gear, coarse: strips join the fronts, only quads
        from benchmarks.paving import geometry

        geo = geometry(name, 0.06)
        res = paving(geo, size=0.06)
        check_mesh(geo, res, 0.06, "quad", median=False)
        assert res.stats["strips"] + res.stats["ladders"] >= 1

    def test_a_row_failing_only_the_gap_stops_short_there(self):
        # the benchmark's square with a hole at about 2,000 quads: a row of the outer
        # front meets the hole's front at a few nodes only; it is committed without
        # those quads (a partial row) instead of freezing the whole front, only quads
        from benchmarks.paving import geometry

        geo = geometry("hole", 0.02)
        res = paving(geo, size=0.02)
        check_mesh(geo, res, 0.02, "quad", median=False)
        assert res.stats["partial_rows"] >= 1

    def test_a_row_failing_on_a_few_quads_is_laid_without_them(self, monkeypatch):
        # the square with a hole at about 3,000 quads: a row fails on a few quads (at
        # most _FEW_BAD of it) not only on the gap; it is laid without them instead of
        # freezing its front, only quads
        from benchmarks.paving import geometry

        geo = geometry("hole", 0.0164)
        res = paving(geo, size=0.0164, smooth=False)
        check_mesh(geo, res, 0.0164, "quad", median=False)
        monkeypatch.setattr(advancing_front, "_FEW_BAD", 0.0)
        fewer = paving(geo, size=0.0164, smooth=False).stats["partial_rows"]
        assert res.stats["partial_rows"] > fewer
