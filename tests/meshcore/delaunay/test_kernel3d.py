"""The 3D Delaunay kernel: exact facts on random and degenerate point sets.

Every tetrahedron positively oriented (exact orient3d), every interior face
locally Delaunay (exact insphere), volumes adding up to the convex hull's,
the same tetrahedra as Qhull in general position, and on co-spherical input
(lattices, integer points of a sphere) a result that depends only on the
point set.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull
from scipy.spatial import Delaunay as QhullDelaunay

from meshcore.delaunay import IncrementalDelaunay3d, delaunay3d
from meshcore.delaunay.cone3d import TABLE_MIN, glue_cone
from meshcore.delaunay.kernel3d import SKIP_CHANGED, SKIP_DUPLICATE, SKIP_OUTSIDE, SKIP_STALE
from meshcore.delaunay.order3d import _brio_hilbert_keys, _grid_bits, insertion_order
from meshcore.errors import InputError
from meshcore.geometry import insphere, orient3d


def canon(tetra: np.ndarray) -> np.ndarray:
    """Tetrahedra as sorted rows in lexicographic order: comparable sets."""
    t = np.sort(np.asarray(tetra), axis=1)
    return t[np.lexsort(t.T[::-1])]


def check_delaunay(tz) -> None:
    """The facts every result must show, checked exactly."""
    p, t, nb = tz.points, tz.tetra, tz.neighbors
    # positive orientation, exactly
    assert (orient3d(p[t[:, 0]], p[t[:, 1]], p[t[:, 2]], p[t[:, 3]]) == 1).all()
    # every point is a vertex
    assert np.array_equal(np.unique(t), np.arange(len(p)))
    # neighbours are mutual and share the face
    rows, faces = np.nonzero(nb >= 0)
    other = nb[rows, faces]
    back = (nb[other] == rows[:, None]).sum(axis=1)
    assert (back == 1).all()
    shared = np.array(
        [len(set(t[r]) & set(t[o])) for r, o in zip(rows[:200], other[:200], strict=True)]
    )
    assert (shared == 3).all()
    # locally Delaunay: the vertex across each interior face is not inside
    # (the vertex of the neighbour across from it: the one whose own neighbour is this row)
    opp = t[other, np.argmax(nb[other] == rows[:, None], axis=1)]
    s = insphere(p[t[rows, 0]], p[t[rows, 1]], p[t[rows, 2]], p[t[rows, 3]], p[opp])
    assert (s <= 0).all()
    # volumes add up to the hull's; hull facets outward and closed
    a, b, c, d = (p[t[:, i]] for i in range(4))
    vol = np.abs(np.einsum("ij,ij->i", a - d, np.cross(b - d, c - d))).sum() / 6
    assert vol == pytest.approx(ConvexHull(p).volume, rel=1e-12)
    hf = tz.hull_facets
    centre = p.mean(axis=0)
    assert (orient3d(p[hf[:, 0]], p[hf[:, 1]], p[hf[:, 2]], centre) == 1).all()
    edges = np.sort(np.concatenate([hf[:, [0, 1]], hf[:, [1, 2]], hf[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()


def lattice(k: int) -> np.ndarray:
    g = np.arange(k, dtype=float)
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)


def sphere_integer_points(r2: int) -> np.ndarray:
    """Every integer point at squared distance r2 from the origin (exactly co-spherical)."""
    r = int(np.ceil(np.sqrt(r2)))
    g = np.arange(-r, r + 1)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    keep = x**2 + y**2 + z**2 == r2
    return np.stack([x[keep], y[keep], z[keep]], axis=1).astype(float)


def assert_order_independent(points: np.ndarray, seed: int = 0) -> None:
    ref = canon(delaunay3d(points).tetra)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        perm = rng.permutation(len(points))
        tz = delaunay3d(points[perm])
        assert np.array_equal(canon(perm[tz.tetra]), ref)


class TestInput:
    def test_too_few_points(self):
        with pytest.raises(InputError) as err:
            delaunay3d(np.eye(3))
        assert err.value.code == "too_few_points"

    def test_bad_shape(self):
        with pytest.raises(InputError) as err:
            delaunay3d(np.zeros((5, 2)))
        assert err.value.code == "bad_shape"

    def test_non_finite_names_the_point(self):
        p = np.random.default_rng(0).random((10, 3))
        p[7, 1] = np.nan
        with pytest.raises(InputError) as err:
            delaunay3d(p)
        assert err.value.code == "non_finite"
        assert err.value.errors[0]["loc"] == ["points", 7]

    def test_coplanar(self):
        p = np.random.default_rng(0).random((20, 3))
        p[:, 2] = 0.5
        with pytest.raises(InputError) as err:
            delaunay3d(p)
        assert err.value.code == "coplanar_points"

    @pytest.mark.parametrize("dup", [1, 2, 9])
    def test_duplicates_named(self, dup):
        p = np.random.default_rng(0).random((10, 3))
        p[dup] = p[0]
        with pytest.raises(InputError) as err:
            delaunay3d(p)
        assert err.value.code == "duplicate_points"
        assert err.value.errors[0]["loc"] == ["points", dup]


class TestGeneralPosition:
    @pytest.mark.parametrize("n", [4, 5, 30, 2000])
    def test_same_tetrahedra_as_qhull(self, n):
        p = np.random.default_rng(n).random((n, 3))
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert np.array_equal(canon(tz.tetra), canon(QhullDelaunay(p).simplices))

    def test_ball(self):
        rng = np.random.default_rng(3)
        p = rng.normal(size=(1500, 3))
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert np.array_equal(canon(tz.tetra), canon(QhullDelaunay(p).simplices))

    def test_translation_and_scaling(self):
        p = np.random.default_rng(5).random((500, 3))
        ref = canon(delaunay3d(p).tetra)
        assert np.array_equal(canon(delaunay3d(p + 1e6).tetra), ref)
        assert np.array_equal(canon(delaunay3d(p * 1e-6).tetra), ref)

    def test_progress(self):
        calls = []
        delaunay3d(np.random.default_rng(0).random((100, 3)), progress=lambda f, m: calls.append(f))
        assert calls and calls[-1] == 1.0

    def test_insertion_order_is_the_stable_sort_of_the_brio_hilbert_keys(self):
        p = np.random.default_rng(6).random((3000, 3))
        order, curve = insertion_order(p, 7)
        keys, curve_ref = _brio_hilbert_keys(p, _grid_bits(len(p)), 7)
        assert np.array_equal(order, np.argsort(keys, kind="stable"))
        assert np.array_equal(curve, curve_ref)


class TestCoSpherical:
    def test_cube_corners(self):
        p = lattice(2)
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert len(tz.tetra) in (5, 6)
        assert_order_independent(p)

    @pytest.mark.parametrize("k", [3, 4])
    def test_lattice(self, k):
        p = lattice(k)
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert_order_independent(p)

    def test_lattice_translated_and_scaled_exactly(self):
        p = lattice(3)
        ref = canon(delaunay3d(p).tetra)
        assert np.array_equal(canon(delaunay3d(p + 1e6).tetra), ref)
        assert np.array_equal(canon(delaunay3d(p * 2.0**-20).tetra), ref)

    @pytest.mark.parametrize("r2", [9, 50, 75])
    def test_integer_points_of_a_sphere(self, r2):
        p = sphere_integer_points(r2)
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert_order_independent(p)

    def test_sphere_with_centre(self):
        p = np.vstack([sphere_integer_points(50), [[0.0, 0.0, 0.0]]])
        tz = delaunay3d(p)
        check_delaunay(tz)
        assert_order_independent(p)


class TestIncremental:
    def test_insertions_give_the_delaunay_tetrahedralization(self):
        p = np.random.default_rng(7).random((400, 3))
        dt = IncrementalDelaunay3d(p[:50])
        for k, q in enumerate(p[50:200]):
            res = dt.insert(q)
            assert res.vertex == 50 + k and not res.duplicate
            assert len(res.created) >= 4 and len(res.removed) >= 1
        assert np.array_equal(dt.insert_many(p[200:]), np.arange(200, 400))
        tz = dt.tetrahedralization()
        assert np.array_equal(tz.points, p)
        check_delaunay(tz)
        assert np.array_equal(canon(tz.tetra), canon(QhullDelaunay(p).simplices))

    def test_created_tetrahedra_hold_the_new_vertex(self):
        p = np.random.default_rng(8).random((60, 3))
        dt = IncrementalDelaunay3d(p)
        res = dt.insert([0.5, 0.5, 0.5])
        cells = dt.tets(res.created)
        assert (cells == res.vertex).any(axis=1).all()
        alive = set(dt.alive().tolist())
        real = (cells >= 0).all(axis=1)
        assert set(res.created[real].tolist()) <= alive
        assert len(alive) == len(dt.tetrahedralization().tetra)

    def test_outside_points_and_duplicates(self):
        p = lattice(2)
        dt = IncrementalDelaunay3d(p)
        res = dt.insert([3.0, 0.5, 0.5])
        assert res.vertex == 8
        dup = dt.insert(p[3])
        assert dup.duplicate and dup.vertex == 3 and len(dup.created) == 0
        assert np.array_equal(dt.insert_many([[0.5, 0.5, 0.5], p[0], [0.5, 0.5, 0.5]]), [9, 0, 9])
        assert np.array_equal(dt.insert_many([p[2], [3.0, 0.5, 0.5]]), [2, 8])  # nothing new
        check_delaunay(dt.tetrahedralization())

    def test_locate(self):
        p = lattice(2)
        dt = IncrementalDelaunay3d(p)
        assert dt.locate(p[5]).kind == "vertex" and dt.locate(p[5]).vertex == 5
        assert dt.locate([2.0, 2.0, 2.0]).tet == -1
        assert dt.locate([0.5, 0.0, 0.0]).kind == "edge"
        loc = dt.locate([0.2, 0.3, 0.4])
        assert loc.kind in ("inside", "face")
        assert loc.tet in set(dt.alive().tolist())

    def test_a_cavity_of_every_tetrahedron(self):
        # The centre of 192 co-spherical points is in every circumsphere: the
        # cavity (905 tetrahedra) outgrows the initial buffers.
        dt = IncrementalDelaunay3d(sphere_integer_points(146))
        before = dt.alive()
        res = dt.insert([0.0, 0.0, 0.0])
        assert set(before.tolist()) <= set(res.removed.tolist())
        tz = dt.tetrahedralization()
        assert len(tz.tetra) == len(res.created) == len(tz.hull_facets)
        check_delaunay(tz)

    @pytest.mark.parametrize("n", [31, 32])
    def test_cone_glued_at_and_past_the_dense_table(self, n):
        # The centre of n points on a sphere is in every circumsphere: its cone
        # has 2 n - 4 faces, 58 (the dense table's most, cone3d) and 60 (hashed).
        x = np.random.default_rng(n).normal(size=(n, 3))
        p = x / np.linalg.norm(x, axis=1)[:, None]
        dt = IncrementalDelaunay3d(p)
        res = dt.insert([0.0, 0.0, 0.0])
        assert len(res.created) == 2 * n - 4
        check_delaunay(dt.tetrahedralization())

    def test_cone_of_a_boundary_not_one_sphere(self):
        # 14 disjoint tetrahedra's surfaces: 56 faces (within the dense table's
        # count) but 56 vertices, past its 31 local numbers: glued through the
        # hash instead of written past the table's end.
        faces = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
        tri = np.concatenate([faces + 4 * i for i in range(14)]).astype(np.int32)
        nb = len(tri)
        p = 4 * 14
        newv = np.concatenate([tri, np.full((nb, 1), p, np.int32)], axis=1).ravel()
        A = np.full(4 * nb, -1, np.int32)
        vt = np.zeros(p + 1, np.int32)
        bnd = np.full(nb, 3, np.int32)
        newslot = np.arange(nb, dtype=np.int32)
        past = np.full(4 * TABLE_MIN, -7, np.int32)  # hval, then what numba would not guard
        hkey, hval = np.empty(1024, np.int64), past[:TABLE_MIN]
        glue_cone(A, vt, newslot, bnd, newv, nb, hkey, hval)
        assert (past[TABLE_MIN:] == -7).all()
        a = A.reshape(nb, 4)[:, :3]
        assert np.array_equal(A[a], np.arange(4 * nb).reshape(nb, 4)[:, :3])  # mutual
        edge = np.sort(np.stack([np.delete(tri, g, axis=1) for g in range(3)], 1), axis=2)
        assert np.array_equal(edge.reshape(-1, 2)[(a >> 2) * 3 + (a & 3)], edge)

    def test_guarded_batch(self):
        # The compiled lazy queue: a point whose origin tetrahedron an earlier one
        # removed is skipped, as is a point outside the allowed slots or the hull,
        # and the rest give the Delaunay tetrahedralization of the points inserted.
        rng = np.random.default_rng(9)
        p = rng.random((80, 3))
        dt = IncrementalDelaunay3d(p)
        q = rng.random((60, 3))
        origin = np.array([dt.locate(x).tet for x in q])
        q, origin = q[origin >= 0], origin[origin >= 0]  # inside the hull
        with pytest.raises(InputError):
            dt.insert_guarded(q[:1], [-1], np.ones(1, bool))
        slots = dt.alive()
        allowed = np.ones(int(slots.max()) + 1, dtype=bool)
        allowed[origin[5]] = False  # the slot point 5 lies in (kept unless removed first)
        out = dt.insert_guarded(q, origin, allowed)
        assert out[0] == 80
        assert out[5] in (SKIP_STALE, SKIP_CHANGED, SKIP_OUTSIDE)
        new = out[out >= 0]
        assert np.array_equal(new, 80 + np.arange(len(new)))
        assert set(out[out < 0].tolist()) <= {SKIP_STALE, SKIP_CHANGED, SKIP_OUTSIDE}
        assert (out == SKIP_STALE).sum() > 0
        start = dt.alive()[:2]
        more = dt.insert_guarded([[5.0, 5.0, 5.0], p[0]], start, np.ones(1 << 16, bool))
        assert more.tolist() == [SKIP_OUTSIDE, SKIP_DUPLICATE]
        tz = dt.tetrahedralization()
        assert np.array_equal(tz.points, np.concatenate([p, q[out >= 0]]))
        check_delaunay(tz)

    def test_bad_points(self):
        dt = IncrementalDelaunay3d(lattice(2))
        with pytest.raises(InputError):
            dt.insert([np.nan, 0, 0])
        with pytest.raises(InputError):
            dt.insert([1e30, 0, 0])

    def test_non_integral_near(self):
        dt = IncrementalDelaunay3d(lattice(2))
        for near in (1.5, "1", float("nan"), float("inf"), [1]):
            with pytest.raises(InputError) as err:
                dt.insert([0.25, 0.25, 0.25], near=near)
            assert (err.value.code, err.value.errors[0]["loc"]) == ("bad_parameter", ["near"])


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.tuples(*[st.integers(-3, 3)] * 3), min_size=5, max_size=40, unique=True).filter(
        lambda pts: np.linalg.matrix_rank(np.diff(np.array(pts, float), axis=0)) == 3
    )
)
def test_hypothesis_integer_points(pts):
    """Small integer coordinates: dense with coplanar and co-spherical subsets."""
    p = np.array(pts, dtype=float)
    tz = delaunay3d(p)
    check_delaunay(tz)
    perm = np.random.default_rng(len(p)).permutation(len(p))
    assert np.array_equal(canon(perm[delaunay3d(p[perm]).tetra]), canon(tz.tetra))


def test_more_tetrahedra_than_the_slot_tables_hold_is_an_input_error(monkeypatch):
    # Points on the moment curve have a quadratic number of tetrahedra: 60 of them
    # outgrow their first 7 n + 64 slots, here also the most allowed.
    t = np.linspace(1.0, 2.0, 60)
    pts = np.column_stack([t, t * t, t * t * t])
    assert len(delaunay3d(pts).tetra) > 7 * 60 + 64
    monkeypatch.setattr("meshcore.delaunay.kernel3d._MAX_SLOTS", 7 * 60 + 64)
    with pytest.raises(InputError) as err:
        delaunay3d(pts)
    assert err.value.code == "too_many_points"
