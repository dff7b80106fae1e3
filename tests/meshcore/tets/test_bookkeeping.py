"""tetrahedralize's per-round bookkeeping: the compiled and kept-between-rounds forms
give exactly what the plain computations give."""

from __future__ import annotations

import numpy as np

import meshcore.delaunay.facets3d as facets3d
import meshcore.delaunay.hashgrid as hashgrid
import meshcore.delaunay.recovery3d as recovery3d
import meshcore.delaunay.regions3d as regions3d
from meshcore.delaunay import delaunay
from meshcore.delaunay.kernel3d import delaunay3d
from meshcore.domain import parse_surface
from meshcore.tets import refinement, tetra_dihedral_angles, tetrahedralize
from tests.meshcore.domain import shapes


def test_ball_pairs_are_the_brute_force_pairs():
    rng = np.random.default_rng(7)
    X = rng.random((400, 3)) * 2 - 1
    C = rng.normal(size=(300, 3))
    r = (0.5 + rng.random(300)) * 10.0 ** rng.integers(-3, 0, 300)
    r[:4] = [0.0, np.nan, np.inf, -1.0]  # no ball
    X[:3] = C[10:13]  # points at ball centres
    xi, ji = recovery3d.ball_pairs(X, C, r)
    d = np.linalg.norm(X[:, None] - C[None], axis=2)
    ok = np.isfinite(r) & (r > 0)
    want = set(zip(*np.nonzero((d < r[None]) & ok[None]), strict=True))
    got = set(zip(xi.tolist(), ji.tolist(), strict=True))
    assert got == {(int(i), int(j)) for i, j in want}
    assert len(xi) == len(got)


def test_ball_pairs_of_a_few_points_come_as_the_grid_gives_them(monkeypatch):
    """Up to ``FEW_POINTS`` points every ball is tested: the same pairs in the same order
    (point, power of two of the radius, ball decreasing) as through the grid."""
    rng = np.random.default_rng(8)
    C = rng.random((2000, 3))
    r = 0.05 * 2.0 ** rng.integers(-3, 3, 2000) * (0.5 + rng.random(2000))
    r[:3] = [np.nan, 0.0, np.inf]
    X = rng.random((hashgrid.FEW_POINTS, 3))
    X[1] = np.nan
    X[2] = C[5]
    few = recovery3d.ball_pairs(X, C, r)
    monkeypatch.setattr(hashgrid, "FEW_POINTS", 0)
    grid = recovery3d.ball_pairs(X, C, r)
    assert len(few[0]) > 50
    assert np.array_equal(few[0], grid[0]) and np.array_equal(few[1], grid[1])


def test_least_dihedral_is_the_least_of_the_six():
    rng = np.random.default_rng(3)
    P = rng.random((300, 3))
    T = delaunay3d(P).tetra.astype(np.int64)
    want = tetra_dihedral_angles(P, T).min(axis=1)
    assert np.array_equal(refinement._least_dihedral(P, T), want)


def test_region_labels_kept_between_rounds_equal_the_flood_fill(monkeypatch):
    """And the missing pieces found from their witnesses (``SurfaceRecovery.missing``) are
    those a pass over every tetrahedron finds; the facets triangulated in one compiled
    call get the rows ``delaunay`` gives each; the kept subface circles are those
    computed afresh."""
    call = regions3d.RegionLabels.__call__
    missing = recovery3d.SurfaceRecovery.missing
    triangulate = facets3d.triangulate_facets
    circles = recovery3d.SurfaceRecovery.sub_circles
    checked, pieces, facets = [], [], []

    def checked_triangulate(uv, ptr, plain):
        tri, tptr, status = triangulate(uv, ptr, plain)
        for k in np.flatnonzero(~plain):
            want = delaunay(uv[ptr[k] : ptr[k + 1]]).triangles
            assert status[k] == 0 and np.array_equal(tri[tptr[k] : tptr[k + 1]], want)
            facets.append(k)
        return tri, tptr, status

    def checked_circles(self, rows=None):
        o, r = circles(self, rows)
        want = recovery3d.tri_circumcenters(self.P, self.sub if rows is None else self.sub[rows])
        assert np.array_equal(o, want[0]) and np.array_equal(r, want[1])
        return o, r

    def checked_call(self, slots, T):
        labels = call(self, slots, T)
        assert np.array_equal(labels, regions3d.regions(self.b, slots, T))
        checked.append(len(T))
        return labels

    def checked_missing(self):
        seg, sub = missing(self)
        keys = recovery3d.packed_edge_keys(self.seg)
        seg_hit, sub_hit = self._present(keys, recovery3d.face_keys(self.sub))
        unsettled = list(self.unsettled.values())
        if unsettled:  # subsegments that are no edges of their facet's triangulation
            seg_hit &= ~np.isin(keys, np.concatenate(unsettled))
        assert np.array_equal(seg, np.flatnonzero(~seg_hit))
        assert np.array_equal(sub, np.flatnonzero(~sub_hit))
        pieces.append(len(seg) + len(sub))
        return seg, sub

    monkeypatch.setattr(regions3d.RegionLabels, "__call__", checked_call)
    monkeypatch.setattr(recovery3d.SurfaceRecovery, "missing", checked_missing)
    monkeypatch.setattr(facets3d, "triangulate_facets", checked_triangulate)
    monkeypatch.setattr(recovery3d.SurfaceRecovery, "sub_circles", checked_circles)
    surface = parse_surface(*shapes.torus(nu=10, nv=5))
    tetrahedralize(surface, size=0.4)
    assert len(checked) > 3
    assert len(pieces) > 3 and sum(pieces) > 0
    assert len(facets) > 10
    # A facet the 2D kernel refuses (two points coincide) is reported, not triangulated.
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 0.0], [2.0, 0.0]])
    uv.flags.writeable = False
    _, tptr, status = triangulate(uv, np.array([0, 3, 6]), np.zeros(2, dtype=bool))
    assert status.tolist() == [0, facets3d.FAILED] and tptr.tolist() == [0, 1, 1]


def _rows_rotated(tri: np.ndarray) -> np.ndarray:
    """The triangles as a set: each row rotated to start at its least corner, rows sorted."""
    r = np.argmin(tri, axis=1)[:, None]
    t = np.take_along_axis(tri, (r + np.arange(3)) % 3, axis=1)
    return t[np.lexsort(t.T[::-1])]


def test_kept_facet_triangulations_grow_to_the_triangles_of_delaunay():
    """A large facet's kept 2D triangulation, given its new points only, has the triangles
    ``delaunay`` gives its whole point set (co-circular lattice points included), the
    rows in the call's point order; a coinciding new point marks the facet failed."""
    rng = np.random.default_rng(5)
    g = np.stack(np.meshgrid(np.arange(48.0), np.arange(48.0)), -1).reshape(-1, 2)
    pts = np.concatenate([g, rng.random((1200, 2)) * 47])  # 2,304 lattice points first
    kept = facets3d.KeptTriangulations()
    for n in (facets3d.KEEP_FROM + 300, 3000, len(pts)):
        ids = np.arange(n)[::-1].copy()  # the call's point order is not the ids' order
        uv = pts[ids]
        uv.flags.writeable = False
        ptr = np.array([0, n])
        tri, tptr, status = kept.triangulate(np.array([0]), ptr, ids, uv, np.zeros(1, bool), n)
        assert status.tolist() == [0] and tptr.tolist() == [0, len(tri)]
        want = delaunay(uv).triangles
        assert np.array_equal(_rows_rotated(tri), _rows_rotated(want))
    ids = np.arange(len(pts) + 1)
    uv = np.concatenate([pts, pts[:1]])
    uv.flags.writeable = False
    _, _, status = kept.triangulate(
        np.array([0]), np.array([0, len(ids)]), ids, uv, np.zeros(1, bool), len(ids)
    )
    assert status.tolist() == [facets3d.FAILED]
