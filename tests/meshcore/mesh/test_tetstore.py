"""The tetrahedron store shared by the optimization method and the sliver removal
(:mod:`meshcore.mesh.tetstore`): corner lists, cavities, their boundary, star cavities."""

from __future__ import annotations

import numpy as np

from meshcore.mesh import tetstore as ts

# two positive tetrahedra glued on face (1, 2, 3): det[b - a, c - a, d - a] > 0
P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
T2 = np.array([[0, 1, 2, 3], [4, 1, 3, 2]], np.int64)


def store(cells=T2, points=P):
    return ts.CellStore(points, cells, np.zeros(len(points), np.uint8), spare_points=2)


def test_both_tets_positive_and_flat_is_not():
    assert ts.positive(P, 0, 1, 2, 3) and ts.positive(P, 4, 1, 3, 2)
    assert not ts.positive(P, 0, 2, 1, 3)
    Q = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float) + 1e6
    assert not ts.positive(Q, 0, 1, 2, 3)  # coplanar, far from the origin: exactly zero


def test_corner_lists_balls_and_shells():
    s = store()
    st = np.empty(ts.SMAX, np.int64)
    tmark = np.zeros(s.T.shape[0], np.int64)
    assert ts.gather(s.head, s.nxt, 1, -1, s.T, st, tmark, 1, 0) == 2  # ball of 1
    assert ts.gather(s.head, s.nxt, 0, -1, s.T, st, tmark, 2, 0) == 1
    assert st[0] == 0
    assert ts.gather(s.head, s.nxt, 1, 4, s.T, st, tmark, 3, 0) == 1  # shell of edge (1, 4)
    assert ts.across(s.T, s.head, s.nxt, 0, 0) == 1  # face 0 of tet 0 is (1, 2, 3)
    assert ts.across(s.T, s.head, s.nxt, 0, 1) == -1
    assert ts.holds(s.T, 1, 4) and not ts.holds(s.T, 1, 0)


def test_remove_and_add_reuse_rows():
    s = store()
    assert ts.room(s.T, s.cnt, s.T.shape[0] - 2) and not ts.room(s.T, s.cnt, s.T.shape[0] - 1)
    ts.remove_cell(s.T, s.alive, s.head, s.nxt, s.prv, s.free, s.cnt, 1)
    assert s.head[4] == -1 and s.cnt[ts.N_FREE] == 1
    t = ts.add_tet(s.T, s.alive, s.head, s.nxt, s.prv, s.free, s.cnt, 4, 1, 3, 2)
    assert t == 1 and s.cnt[ts.N_FREE] == 0 and s.cnt[ts.N_ROWS] == 2
    np.testing.assert_array_equal(s.cells(), T2)


def test_boundary_of_the_pair_and_face_keys():
    s = store()
    st = np.array([0, 1], np.int64)
    bf = np.empty((8, 3), np.int64)
    nb = ts.boundary(s.T, st, 2, 5, bf)
    assert nb == 6
    faces = {tuple(sorted(f)) for f in bf[:nb]}
    assert (1, 2, 3) not in faces and (0, 1, 2) in faces and (2, 3, 4) in faces
    for a, b, c in bf[:nb]:  # outward: the tet holding the face, from its fourth vertex
        (row,) = [r for r in T2 if {a, b, c} <= set(r)]
        (d,) = set(row) - {a, b, c}
        assert ts.positive(P, d, a, b, c)
    assert ts.face_key(3, 1, 2, 5) == ts.face_key(1, 2, 3, 5) != ts.face_key(1, 2, 4, 5)


def test_star_cavity_makes_every_new_tet_positive():
    """G at the centroid of the pair: its star cavity is both tets and Op(G, δ𝒮) is
    positive throughout; outside every face it fails."""
    s = store()
    g = 5
    s.P[g] = P.mean(axis=0)
    st = np.empty(ts.SMAX, np.int64)
    tmark = np.zeros(s.T.shape[0], np.int64)
    k = ts.star_cavity(s.P, s.T, s.head, s.nxt, 0, g, st, tmark, 1)
    assert k == 2
    bf = np.empty((8, 3), np.int64)
    nb = ts.boundary(s.T, st, k, 6, bf)
    assert all(ts.positive(s.P, g, a, b, c) for a, b, c in bf[:nb])
    s.P[g] = (-1.0, -1.0, -1.0)
    assert ts.star_cavity(s.P, s.T, s.head, s.nxt, 0, g, st, tmark, 2) == -1
    for c in range(ts.STARS):
        if ts.star_point(s.P, s.T, s.head, s.nxt, 0, c, g):
            assert np.isfinite(s.P[g]).all()


def test_growing_keeps_the_live_cells_in_order_and_links_them():
    s = ts.CellStore(P, T2, np.zeros(len(P), np.uint8), spare_points=0, spare_rows=1)
    assert s.T.shape[0] == 3
    ts.remove_cell(s.T, s.alive, s.head, s.nxt, s.prv, s.free, s.cnt, 0)
    T, nxt = s.T, s.nxt
    s.grow_points(2)  # rows compacted in place: the same arrays, the live cell first
    assert s.T is T and s.nxt is nxt and len(s.P) == len(P) + 2
    assert s.cells().tolist() == [[4, 1, 3, 2]] and s.cnt[ts.N_ROWS] == 1
    assert s.T[1:].tolist() == [[0, 0, 0, 0]] * 2 and (s.nxt[4:] == -1).all()
    s.grow_rows()
    assert s.T.shape[0] == 6 and s.cells().tolist() == [[4, 1, 3, 2]]
    for v in (4, 1, 3, 2):  # each vertex's corner list holds the live cell's corner
        assert s.head[v] >= 0 and s.T[s.head[v] // 4, s.head[v] % 4] == v
    assert (s.head[[0]] == -1).all()
