"""Facts about :func:`meshcore.optimize.optimize` (Coupez's method, §8.3).

Generation: every triangle positive by the exact orient2d, a mesh topology
whose boundary edges are exactly the input segments, the area exact.
Correction: a tangled mesh back to valid with the same boundary and area, Sur
non-increasing. Optimization: the least quality never decreases, an optimal
mesh comes back unchanged. Bad input: InputError naming the entity; no valid
mesh reached: AlgorithmError saying how many cells and where.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from meshcore.domain.planar import parse_domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates import orient2d
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import boundary
from meshcore.optimize import check_topology, optimize
from meshcore.optimize.kernel2d import check_mesh
from meshcore.product import Translate, extrude
from meshcore.triangulation import triangulate

SUR_SLACK = 1e-12  # float rounding of a sum of areas that is equal in exact arithmetic
UNIT_SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}


@pytest.fixture(scope="module")
def cube_tets() -> tuple[np.ndarray, np.ndarray]:
    """The unit cube's tetrahedra: the square's triangles (size 0.25) extruded by 4 layers."""
    m = extrude(triangulate(UNIT_SQUARE, size=0.25).mesh, Translate([0, 0, 1], layers=4),
                simplices=True).mesh  # fmt: skip
    return m.points, m.cells_by_type["tetra"]


def _tri(res) -> tuple[np.ndarray, np.ndarray]:
    return res.mesh.points, res.mesh.cells[0].data


def assert_valid_2d(P, T, segments=None, area=None):
    assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) > 0).all()
    bnd = check_topology(Mesh(P, (CellBlock("triangle", T),)), T)
    if segments is not None:
        assert sorted(map(tuple, bnd.tolist())) == sorted(map(tuple, segments.tolist()))
    if area is not None:
        assert math.fsum(quality.signed_area(P, T)) == pytest.approx(area, rel=1e-12)


def assert_monotone(sur):
    s = np.asarray(sur)
    assert (s[1:] <= s[:-1] * (1 + SUR_SLACK)).all(), s


def star(radii, phase=0.0, scale=1.0):
    n = len(radii)
    a = phase + 2 * np.pi * np.arange(n) / n
    return (scale * np.column_stack([radii * np.cos(a), radii * np.sin(a)])).tolist()


radii = st.lists(st.floats(0.35, 1.0), min_size=5, max_size=30).map(np.array)


class TestGeneration:
    @settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(radii)
    def test_polygon_without_insertion_is_valid_with_the_input_segments(self, r):
        dom = parse_domain({"type": "Polygon", "coordinates": [star(r)]})
        res = optimize(domain=dom, insert_points=False)
        P, T = _tri(res)
        assert len(P) == len(dom.points)
        assert_valid_2d(P, T, dom.segments, dom.area)
        assert len(T) == len(P) - 2
        assert_monotone(res.stats["sur"])
        assert res.stats["use"] == "generation"

    @settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(radii, st.lists(st.floats(0.08, 0.25), min_size=3, max_size=9).map(np.array))
    def test_polygon_with_a_hole_is_valid_or_refused_never_wrong(self, r, rh):
        dom = parse_domain({"type": "Polygon", "coordinates": [star(r), star(rh, 0.1)]})
        try:
            res = optimize(domain=dom, insert_points=False)
        except AlgorithmError as exc:
            assert "inverted" in exc.message
            return
        P, T = _tri(res)
        assert_valid_2d(P, T, dom.segments, dom.area)
        # Euler: an annulus with only boundary vertices has as many triangles as vertices
        assert len(T) == len(P)

    def test_stuck_first_topology_restarts_from_the_next_vertex(self):
        # a star with a triangular hole (seed 7, draw 29) stuck from the vertex nearest the
        # centroid with one inverted triangle; valid from the next one
        r = [
            0.5798477166732823, 0.9883605268743287, 0.83796939524952, 0.4256238414976024,
            0.8753359662453435, 0.5521022015879642, 0.8579077133723816, 0.3582689419767504,
            0.9163256001108893, 0.45550171047342397, 0.6462378871775067, 0.7801411388890489,
            0.6801152193590072, 0.4575085489123072, 0.440427033585564, 0.534947355400576,
            0.3840546420615104, 0.4907540986215251, 0.4345682605789154, 0.652118059433205,
            0.5817314540727383, 0.7314409616553064, 0.5325712620110198,
        ]  # fmt: skip
        rh = [0.0857648782490004, 0.13628872746463597, 0.2083807197020417]
        rings = [star(np.array(r)), star(np.array(rh), 0.1)]
        dom = parse_domain({"type": "Polygon", "coordinates": rings})
        res = optimize(domain=dom, insert_points=False)
        P, T = _tri(res)
        assert_valid_2d(P, T, dom.segments, dom.area)
        assert len(T) == len(P)
        assert res.stats["restarts"] and res.stats["restarts"][0]["inverted"] > 0
        assert_monotone(res.stats["sur"])

    @pytest.mark.parametrize("holes", [1, 2])
    def test_square_with_holes(self, holes):
        rings = [[[0, 0], [4, 0], [4, 4], [0, 4]]]
        rings += [[[1, 1], [1, 2], [2, 2], [2, 1]], [[2.5, 2.5], [2.5, 3.5], [3.5, 3.5]]][:holes]
        dom = parse_domain({"type": "Polygon", "coordinates": rings})
        res = optimize(domain=dom, insert_points=False)
        assert_valid_2d(*_tri(res), dom.segments, dom.area)
        # with insertion (segments split to size): least angle at least 20 around the holes too
        res = optimize(domain=dom, size=0.4, keep_boundary=False)
        P, T = _tri(res)
        assert_valid_2d(P, T, area=dom.area)
        assert quality.triangle_angles(P, T).min() >= 20
        assert res.stats["points_inserted"] > 0
        assert_monotone(res.stats["sur"])

    @settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(st.lists(st.floats(0.8, 1.0), min_size=6, max_size=12).map(np.array))
    def test_with_insertion_least_angle_at_least_20(self, r):
        dom = parse_domain({"type": "Polygon", "coordinates": [star(r)]})
        # input corners of at least 60 degrees, so that 20 is reachable
        P, S = dom.points, dom.segments
        u = P[S[:, 1]] - P[S[:, 0]]
        w = np.roll(u, -1, axis=0)
        corner = np.degrees(
            np.pi
            - np.arccos(
                np.einsum("ij,ij->i", u, w)
                / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
            )
        )
        assume(corner.min() >= 60)
        res = optimize(domain=dom, size=0.12, keep_boundary=False)
        P, T = _tri(res)
        assert_valid_2d(P, T, area=dom.area)
        assert quality.triangle_angles(P, T).min() >= 20
        assert res.stats["points_inserted"] > 0

    @pytest.mark.parametrize("spacing", [1, 4])
    def test_with_insertion_on_a_kept_boundary_least_angle_at_least_25(self, spacing):
        # a 120-gon: the interior at the boundary's spacing, or graded from it to 4x
        m = 120
        dom = parse_domain({"type": "Polygon", "coordinates": [star(np.ones(m))]})
        size = spacing * 2 * np.sin(np.pi / m)
        res = optimize(domain=dom, size=size)
        P, T = _tri(res)
        assert_valid_2d(P, T, segments=dom.segments, area=dom.area)
        assert np.array_equal(P[:m], dom.points)
        assert quality.triangle_angles(P, T).min() >= 25
        assert res.stats["insertion"]["given_up"] == 0
        assert_monotone(res.stats["sur"])
        # the size bound: circumradius at most 0.8 size
        e = [np.linalg.norm(P[T[:, (j + 1) % 3]] - P[T[:, (j + 2) % 3]], axis=1) for j in range(3)]
        radius = e[0] * e[1] * e[2] / (4 * np.abs(quality.signed_area(P, T)))
        assert radius.max() <= 0.8 * size * (1 + 1e-12)

    def test_with_insertion_a_kept_coarse_boundary_still_gets_its_interior_refined(self):
        # segments 10-20x the size, kept: the interior goes to size, thin triangles stay
        # along the segments (given up, counted), never a point on a segment
        L = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]]}
        dom = parse_domain(L)
        res = optimize(domain=L, size=0.1)
        P, T = _tri(res)
        assert_valid_2d(P, T, segments=dom.segments, area=3.0)
        assert len(P) > 200
        assert res.stats["insertion"]["given_up"] > 0
        # away from the segments (centroid over 3 sizes from each), every angle at least 25
        c = P[T].mean(axis=1)
        a, b = dom.points[dom.segments[:, 0]], dom.points[dom.segments[:, 1]]
        t = np.clip(np.einsum("ksi,si->ks", c[:, None] - a, b - a) / np.sum((b - a) ** 2, 1), 0, 1)
        dist = np.linalg.norm(c[:, None] - (a + t[..., None] * (b - a)), axis=2).min(axis=1)
        assert (dist > 0.3).sum() > 100
        assert quality.triangle_angles(P, T[dist > 0.3]).min() >= 25

    def test_l_shape_example(self):
        L = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]]}
        res = optimize(domain=L, size=0.1, keep_boundary=False)
        P, T = _tri(res)
        assert_valid_2d(P, T, area=3.0)
        assert res.quality["triangle"]["angle"]["min"] >= 25
        assert_monotone(res.stats["sur"])
        assert res.stats["sur"][-1] == pytest.approx(3.0, rel=1e-12)


def _tangled(nx=30, noise=1.5, seed=0):
    """A triangulate mesh of the unit square, interior nodes moved up to ``noise`` local edges."""
    sq = UNIT_SQUARE
    mesh = triangulate(sq, size=1.0 / nx).mesh
    P, T = mesh.points.copy(), mesh.cells[0].data
    bnd = check_topology(mesh, T)
    free = np.setdiff1d(np.arange(len(P)), bnd.ravel())
    e = np.vstack([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    length = np.linalg.norm(P[e[:, 0]] - P[e[:, 1]], axis=1)
    h = np.zeros(len(P))
    np.add.at(h, e[:, 0], length)
    h /= np.maximum(np.bincount(e[:, 0], minlength=len(P)), 1)
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(len(free), 2))
    d /= np.linalg.norm(d, axis=1)[:, None]
    P[free] += d * (rng.uniform(0, noise, len(free)) * h[free])[:, None]
    return P, T, bnd


class TestCorrection:
    def test_tangled_triangle_mesh_is_made_valid_with_the_same_boundary(self):
        P, T, bnd = _tangled(nx=67)
        assert len(T) >= 10_000  # the 10k triangles
        inverted = np.mean(orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) <= 0)
        assert 0.05 <= inverted <= 0.30
        res = optimize(Mesh(P, (CellBlock("triangle", T),)))
        Pn, Tn = _tri(res)
        assert_valid_2d(Pn, Tn, bnd, 1.0)
        on_bnd = np.unique(bnd)
        assert (Pn[on_bnd] == P[on_bnd]).all()
        assert len(Pn) == len(P)  # insert_points=false keeps the point set
        assert res.stats["use"] == "correction"
        assert res.stats["inverted_before"] == int(round(inverted * len(T)))
        assert_monotone(res.stats["sur"])
        assert res.stats["sur"][0] > 1.0

    @pytest.mark.parametrize("shift, scale", [(1e6, 1.0), (0.0, 1e-6)])
    def test_translation_and_scaling_change_nothing_but_rounding(self, shift, scale):
        P, T, bnd = _tangled(nx=12, seed=3)
        a = optimize(Mesh(P, (CellBlock("triangle", T),)))
        b = optimize(Mesh(P * scale + shift, (CellBlock("triangle", T),)))
        assert_valid_2d(*_tri(b), bnd)
        assert math.fsum(quality.signed_area(*_tri(b))) == pytest.approx(scale**2, rel=1e-9)
        assert a.stats["least_quality_after"] == pytest.approx(
            b.stats["least_quality_after"], abs=0.05
        )

    @pytest.mark.parametrize("tangle", ["noise", "random"])
    def test_tetrahedral_mesh_is_made_valid_with_the_same_volume(self, tangle, cube_tets):
        P, T = cube_tets[0].copy(), cube_tets[1]
        tets = Mesh(P, (CellBlock("tetra", T),))
        faces = boundary(tets).cells[0].data
        free = np.setdiff1d(np.arange(len(P)), faces.ravel())
        rng = np.random.default_rng(2)
        if tangle == "noise":
            P[free] += rng.uniform(-1, 1, (len(free), 3)) * np.array([0.25, 0.25, 1 / 4])
        else:  # anywhere in the cube
            P[free] = rng.uniform(0, 1, (len(free), 3))
        sign = -orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], P[T[:, 3]])
        assert (sign <= 0).sum() > 0.05 * len(T)
        res = optimize(Mesh(P, (CellBlock("tetra", T),)))
        Pn, Tn = res.mesh.points, res.mesh.cells[0].data
        assert (-orient3d(Pn[Tn[:, 0]], Pn[Tn[:, 1]], Pn[Tn[:, 2]], Pn[Tn[:, 3]]) > 0).all()
        assert math.fsum(quality.signed_volume(Pn, Tn)) == pytest.approx(1.0, rel=1e-12)
        got = boundary(Mesh(Pn, (CellBlock("tetra", Tn),))).cells[0].data
        assert sorted(map(tuple, np.sort(got, 1).tolist())) == sorted(
            map(tuple, np.sort(faces, 1).tolist())
        )
        assert_monotone(res.stats["sur"])

    def test_no_valid_mesh_fails_saying_how_many_and_where(self):
        # a boundary vertex pulled across the opposite side: the boundary crosses itself, so
        # no positive triangulation of it exists
        P, T = _hexagon()
        P[1] = [-2.0, 0.2]
        with pytest.raises(AlgorithmError, match=r"4 element\(s\) still inverted") as exc:
            optimize(Mesh(P, (CellBlock("triangle", T),)))
        assert exc.value.code == "not_converged"
        assert "cell " in exc.value.message and " at (" in exc.value.message

    @pytest.mark.parametrize("shape", ["square", "star"])
    def test_random_interior_positions_are_untangled(self, shape):
        # every free node anywhere in the box: the barycentric fixed point of the G moves first
        if shape == "square":
            sq = UNIT_SQUARE
            mesh = triangulate(sq, size=0.05).mesh
        else:
            a = np.pi / 2 + np.pi * np.arange(14) / 7
            r = np.where(np.arange(14) % 2 == 0, 1.0, 0.3)
            ring = np.column_stack([r * np.cos(a), r * np.sin(a)])
            mesh = triangulate({"type": "Polygon", "coordinates": [ring.tolist()]}, size=0.06).mesh
        P, T = mesh.points.copy(), mesh.cells[0].data
        bnd = check_topology(mesh, T)
        area = math.fsum(quality.signed_area(P, T))
        free = np.setdiff1d(np.arange(len(P)), bnd.ravel())
        lo, hi = P.min(axis=0), P.max(axis=0)
        P[free] = np.random.default_rng(5).uniform(lo, hi, (len(free), 2))
        assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) <= 0).mean() > 0.3
        res = optimize(Mesh(P, (CellBlock("triangle", T),)))
        Pn, Tn = _tri(res)
        assert_valid_2d(Pn, Tn, bnd, area)
        assert (Pn[bnd.ravel()] == P[bnd.ravel()]).all()
        assert res.stats["operators"]["barycentric_move"] == 1
        assert_monotone(res.stats["sur"])


def _hexagon():
    a = np.pi / 3 * np.arange(6)
    P = np.vstack([[0.0, 0.0], np.column_stack([np.cos(a), np.sin(a)])])
    T = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    return P, T


def test_check_mesh_refuses_a_non_manifold_edge_a_flipped_cell_and_a_wrong_boundary():
    P, T = _hexagon()

    def edges(rows):
        return np.array(rows, dtype=np.int64)

    bnd = [[1 + i, 1 + (i + 1) % 6] for i in range(6)]  # as in the triangles
    assert check_mesh(P, T, edges(bnd))
    flipped = T.copy()
    flipped[2] = flipped[2, [0, 2, 1]]
    assert not check_mesh(P, flipped, edges(bnd))
    # edge 1 -> 0 in a seventh triangle too (positive, outside the hexagon)
    Q = np.vstack([P, [[0.5, -2.0]]])
    assert not check_mesh(Q, np.vstack([T, [[1, 0, 7]]]), edges(bnd))
    assert not check_mesh(P, T, edges(bnd[:-1]))  # a boundary edge missing from bnd
    assert not check_mesh(P, T, edges([e[::-1] for e in bnd]))  # against the triangles
    assert not check_mesh(P, T, edges([[0, 1], *bnd[1:]]))  # an inner edge for a boundary one


class TestOptimization:
    def test_an_optimal_mesh_comes_back_unchanged(self):
        P, T = _hexagon()
        res = optimize(Mesh(P, (CellBlock("triangle", T),)))
        Pn, Tn = _tri(res)
        assert (Pn == P).all()
        assert sorted(map(tuple, np.sort(Tn, 1).tolist())) == sorted(
            map(tuple, np.sort(T, 1).tolist())
        )
        assert res.stats["use"] == "optimization"

    @settings(max_examples=15, deadline=None)
    @given(st.integers(0, 10_000), st.sampled_from(["shape", "radius_ratio"]))
    def test_least_quality_never_decreases(self, seed, measure):
        sq = UNIT_SQUARE
        mesh = triangulate(sq, size=0.2).mesh
        P, T = mesh.points.copy(), mesh.cells[0].data
        bnd = np.unique(check_topology(mesh, T))
        free = np.setdiff1d(np.arange(len(P)), bnd)
        rng = np.random.default_rng(seed)
        for _ in range(20):  # a valid perturbation: a random move kept only if all stay positive
            Q = P.copy()
            Q[free] += rng.uniform(-0.05, 0.05, (len(free), 2))
            if (orient2d(Q[T[:, 0]], Q[T[:, 1]], Q[T[:, 2]]) > 0).all():
                P = Q
        res = optimize(Mesh(P, (CellBlock("triangle", T),)), quality=measure)
        assert res.stats["least_quality_after"] >= res.stats["least_quality_before"]
        assert_valid_2d(*_tri(res), area=1.0)


SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)


class TestBadInput:
    def test_non_manifold_edge_is_named(self):
        P = np.vstack([SQUARE, [[0.5, -1.0]]])
        T = np.array([[0, 1, 2], [0, 2, 3], [1, 0, 4], [0, 1, 3]])
        with pytest.raises(InputError) as exc:
            optimize(Mesh(P, (CellBlock("triangle", T),)))
        assert exc.value.code == "nonmanifold_edge"
        assert exc.value.errors[0]["loc"][:4] == ["mesh", "cells", 0, "data"]

    def test_inconsistent_orientation_is_named(self):
        T = np.array([[0, 1, 2], [0, 3, 2]])
        with pytest.raises(InputError) as exc:
            optimize(Mesh(SQUARE, (CellBlock("triangle", T),)))
        assert exc.value.code == "inconsistent_orientation"
        assert {tuple(e["loc"]) for e in exc.value.errors} == {
            ("mesh", "cells", 0, "data", 0),
            ("mesh", "cells", 0, "data", 1),
        }

    def test_nan_is_named(self):
        P = SQUARE.copy()
        P[2, 1] = np.nan
        with pytest.raises(InputError) as exc:
            optimize(Mesh(P, (CellBlock("triangle", [[0, 1, 2], [0, 2, 3]]),)))
        assert exc.value.errors[0]["loc"] == ["mesh", "points", 2, 1]

    def test_exactly_one_input(self):
        with pytest.raises(InputError):
            optimize()
        with pytest.raises(InputError):
            optimize(
                Mesh(SQUARE, (CellBlock("triangle", [[0, 1, 2], [0, 2, 3]]),)),
                domain={"type": "Polygon", "coordinates": [SQUARE.tolist()]},
            )

    def test_bad_choices(self):
        m = Mesh(SQUARE, (CellBlock("triangle", [[0, 1, 2], [0, 2, 3]]),))
        with pytest.raises(InputError, match="quality"):
            optimize(m, quality="jacobian")
        with pytest.raises(InputError, match="max_sweeps"):
            optimize(m, max_sweeps=0)
        with pytest.raises(InputError, match="keep_boundary"):
            optimize(m, keep_boundary=False)


class TestTetrahedra:
    #: two tets on the face 1 2 3, apexes 0 (below) and 4 (above): positive as numbered
    P = np.array([[0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 0], [0.2, 0.2, 1]], float)

    def test_a_face_held_the_same_way_twice_is_named(self):
        T = np.array([[0, 1, 2, 3], [4, 1, 2, 3]])  # the second one is numbered the other way
        with pytest.raises(InputError) as exc:
            optimize(Mesh(self.P, (CellBlock("tetra", T),)))
        assert exc.value.code == "inconsistent_orientation"
        assert {tuple(e["loc"]) for e in exc.value.errors} == {
            ("mesh", "cells", 0, "data", 0),
            ("mesh", "cells", 0, "data", 1),
        }

    def test_a_face_in_three_tets_is_named(self):
        P = np.vstack([self.P, [[0.3, 0.3, 2]]])
        T = np.array([[0, 1, 2, 3], [4, 1, 3, 2], [5, 1, 3, 2]])
        with pytest.raises(InputError) as exc:
            optimize(Mesh(P, (CellBlock("tetra", T),)))
        assert exc.value.code == "nonmanifold_face"

    def test_optimization_never_lowers_the_least_quality(self, cube_tets):
        P, T = cube_tets
        res = optimize(Mesh(P, (CellBlock("tetra", T),)), quality="radius_ratio")
        assert res.stats["use"] == "optimization"
        assert res.stats["least_quality_after"] >= res.stats["least_quality_before"]
        Pn, Tn = res.mesh.points, res.mesh.cells[0].data
        assert math.fsum(quality.signed_volume(Pn, Tn)) == pytest.approx(1.0, rel=1e-12)

    def test_a_thin_valid_mesh_is_not_refused(self):
        """The flat rule is generation's: a given mesh is judged by the exact orient3d."""
        P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1e-10]], float)
        far = np.vstack([P, [[1e9, 0, 0]]])  # an unused point far away
        T = np.array([[0, 1, 2, 3]])  # numbered the other way: the method turns it round
        for Q in (P, far):
            res = optimize(Mesh(Q, (CellBlock("tetra", T),)))
            assert res.stats["use"] == "optimization" and res.stats["inverted_before"] == 0

    def test_an_optimal_mesh_comes_back_unchanged(self, cube_tets):
        cube = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
        kuhn = np.array([[0, 1, 3, 7], [0, 1, 7, 5], [0, 5, 7, 4], [0, 3, 2, 7], [0, 2, 6, 7]])
        kuhn = np.vstack([kuhn, [[0, 6, 4, 7]]])
        flip = quality.signed_volume(cube, kuhn) < 0
        kuhn[flip] = kuhn[flip][:, [1, 0, 2, 3]]
        once = optimize(Mesh(cube_tets[0], (CellBlock("tetra", cube_tets[1]),)))
        # the cube's six Kuhn tetrahedra, and a mesh this method has already optimized
        for P, T in ((cube, kuhn), (once.mesh.points, once.mesh.cells[0].data)):
            res = optimize(Mesh(P, (CellBlock("tetra", T),)))
            assert res.stats["use"] == "optimization"
            assert (res.mesh.points == P).all()
            rows = np.sort(res.mesh.cells[0].data, 1)
            assert sorted(map(tuple, rows.tolist())) == sorted(map(tuple, np.sort(T, 1).tolist()))


def test_generation_does_not_depend_on_translation_or_scale():
    ring = star(np.array([1.0, 0.5, 0.9, 0.45, 0.95, 0.5, 1.0, 0.55]))
    a = optimize(domain={"type": "Polygon", "coordinates": [ring]}, insert_points=False)
    for shift, scale in ((1e6, 1.0), (0.0, 1e-6)):
        moved = (np.asarray(ring) * scale + shift).tolist()
        b = optimize(domain={"type": "Polygon", "coordinates": [moved]}, insert_points=False)
        assert len(b.mesh.cells[0].data) == len(a.mesh.cells[0].data)
        P, T = _tri(b)
        assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) > 0).all()
