"""parse_surface: closed surfaces accepted and oriented, every refusal located."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain import Surface, parse_surface
from meshcore.domain.surface import _tri_tri, added_triangles_fit, shell_volume
from meshcore.errors import InputError
from tests.meshcore.domain import shapes
from tests.meshcore.domain.shapes import box_volume


def refusal(points, triangles) -> InputError:
    with pytest.raises(InputError) as info:
        parse_surface(points, triangles)
    return info.value


def signed_volume(P, T) -> float:
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


def two(P1, T1, P2, T2):
    return np.concatenate([P1, P2]), np.concatenate([T1, np.asarray(T2) + len(P1)])


# ---------------------------------------------------------------------------
# Accepted surfaces
# ---------------------------------------------------------------------------


class TestAccepted:
    def test_cube(self):
        P, T = shapes.box()
        s = parse_surface(P, T)
        assert isinstance(s, Surface)
        assert s.volume == 1.0
        assert s.shell_count == 1 and s.region_count == 1
        assert not s.triangle_reversed.any()
        assert s.diameter == pytest.approx(math.sqrt(3))
        assert len(s.edges()) == 18
        assert s.vertices.tolist() == list(range(8))

    def test_inward_orientation_is_normalized(self):
        P, T = shapes.box(n=2)
        s = parse_surface(P, T[:, ::-1])
        assert s.triangle_reversed.all()
        assert s.volume == 1.0
        assert signed_volume(s.points, s.triangles) == pytest.approx(1.0)

    @pytest.mark.parametrize(
        "build, volume",
        [
            (lambda: shapes.box(n=3), 1.0),
            (shapes.l_block, 3.0),
            (lambda: shapes.box((0, 0, 0), (1, 1, 0.01), n=2), 0.01),
            (shapes.schonhardt, None),
            (lambda: shapes.icosphere(3), None),
            (shapes.torus, None),
        ],
    )
    def test_volume_is_the_enclosed_volume(self, build, volume):
        P, T = build()
        s = parse_surface(P, T)
        expected = volume if volume is not None else signed_volume(P, T)
        assert s.volume == pytest.approx(expected, rel=1e-14)
        assert s.volume > 0

    def test_cavity_and_island(self):
        # A 3-box with a 1-box cavity, and in the cavity a small island body.
        P, T = two(*shapes.box((0, 0, 0), (3, 3, 3), 2), *shapes.box((1, 1, 1), (2, 2, 2)))
        P, T = two(P, T, *shapes.box((1.25, 1.25, 1.25), (1.75, 1.75, 1.75)))
        s = parse_surface(P, T)
        assert s.shell_depth.tolist() == [0, 1, 2]
        assert s.shell_parent.tolist() == [-1, 0, 1]
        assert s.shell_region.tolist() == [0, 0, 1]
        assert s.shell_volume.tolist() == [27.0, -1.0, 0.125]
        assert s.volume == 26.125
        assert s.region_volume.tolist() == [26.0, 0.125]
        # The cavity's normals point into the cavity: its triangles were reversed.
        cav = s.triangle_shell == 1
        assert s.triangle_reversed[cav].all() and not s.triangle_reversed[~cav].any()
        assert signed_volume(s.points, s.triangles) == pytest.approx(26.125)

    def test_bodies_side_by_side(self):
        P, T = two(*shapes.box(), *shapes.icosphere(1, 0.4))
        P[len(shapes.box()[0]) :] += 3.0
        s = parse_surface(P, T)
        assert s.shell_depth.tolist() == [0, 0]
        assert s.shell_region.tolist() == [0, 1]

    @pytest.mark.parametrize(
        "lo, hi", [((0, 0.5, 0.5), (1, 1.5, 1.5)), ((0, 0.25, 0.25), (1, 0.75, 0.75))]
    )
    def test_nesting_ray_through_vertices_and_edges(self, lo, hi):
        # Every vertex of the inner box is level (in y, z) with a vertex or a
        # diagonal edge of the outer box's faces x = -1 and x = 2: the
        # perturbed ray must still cross the outer shell once.
        P, T = two(*shapes.box((-1, 0, 0), (2, 2, 2), 4), *shapes.box(lo, hi))
        s = parse_surface(P, T)
        assert s.shell_depth.tolist() == [0, 1]
        assert s.volume == 12.0 - box_volume(lo, hi)

    def test_unused_points_are_ignored(self):
        P, T = shapes.box()
        P = np.concatenate([P, [[5.0, 5.0, 5.0]]])
        s = parse_surface(P, T)
        assert s.volume == 1.0 and len(s.points) == 9
        assert s.vertices.tolist() == list(range(8))

    def test_lists_and_float_indices(self):
        P, T = shapes.box()
        s = parse_surface(P.tolist(), T.astype(float).tolist())
        assert s.volume == 1.0

    def test_surface_is_immutable(self):
        s = parse_surface(*shapes.box())
        with pytest.raises(ValueError):
            s.triangles[0, 0] = 3

    def test_larger_surface(self):
        P, T = shapes.icosphere(5)
        s = parse_surface(P, T)
        assert s.volume == pytest.approx(signed_volume(P, T), rel=1e-13)


class TestInvariance:
    @pytest.mark.parametrize("build", [shapes.l_block, shapes.torus, shapes.schonhardt])
    def test_translation_and_scaling(self, build):
        P, T = build()
        base = parse_surface(P, T)
        for Q, factor in ((P + 1e6, 1.0), (P * 1e-6, 1e-18), (P * 1e-6 + 1e6, 1e-18)):
            s = parse_surface(Q, T)
            assert np.array_equal(s.triangles, base.triangles)
            assert np.array_equal(s.triangle_shell, base.triangle_shell)
            rel = 1e-9 if Q is not P * 1e-6 else 1e-14
            if factor == 1e-18 and np.abs(Q).max() > 1e5:
                continue  # a 1e-6 body at 1e6: coordinates keep ~5 digits, volume is noise
            assert s.volume == pytest.approx(base.volume * factor, rel=rel)

    def test_cavity_translated(self):
        P, T = two(*shapes.box((0, 0, 0), (3, 3, 3)), *shapes.box((1, 1, 1), (2, 2, 2)))
        for Q in (P + 1e6, P * 1e-6):
            s = parse_surface(Q, T)
            assert s.shell_depth.tolist() == [0, 1]


# ---------------------------------------------------------------------------
# Refusals
# ---------------------------------------------------------------------------


class TestRefusedArrays:
    def test_too_few_points(self):
        e = refusal([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
        assert e.code == "too_few_points"
        assert e.errors[0]["loc"] == ["points"]

    def test_non_finite(self):
        P, T = shapes.box()
        P[5, 2] = np.nan
        e = refusal(P, T)
        assert e.code == "non_finite"
        assert e.errors[0]["loc"] == ["points", 5, 2]

    def test_infinite_and_huge(self):
        P, T = shapes.box()
        P[1, 0] = np.inf
        assert refusal(P, T).code == "non_finite"
        P[1, 0] = 1e200
        e = refusal(P, T)
        assert e.code == "out_of_range" and e.errors[0]["loc"] == ["points", 1, 0]

    def test_bad_rows(self):
        P, T = shapes.box()
        rows = P.tolist()
        rows[3] = [1.0, 2.0]
        e = refusal(rows, T)
        assert e.code == "bad_geometry" and e.errors[0]["loc"] == ["points", 3]
        rows[3] = [1.0, "x", 0.0]
        assert refusal(rows, T).errors[0]["loc"] == ["points", 3, 1]
        rows[3] = [1.0, 0.5, True]  # numpy would read the row as floats
        assert refusal(rows, T).errors[0]["loc"] == ["points", 3, 2]
        e = refusal(P, T.astype(bool))
        assert e.code == "bad_geometry" and e.errors[0]["loc"] == ["triangles", 0, 0]
        tris = T.tolist()
        tris[2] = [0, 1]
        assert refusal(P, tris).errors[0]["loc"] == ["triangles", 2]
        tris[2] = [True, 2, 3]
        assert refusal(P, tris).errors[0]["loc"] == ["triangles", 2, 0]
        assert refusal(P, "abc").errors[0]["loc"] == ["triangles"]

    def test_non_integer_index(self):
        P, T = shapes.box()
        tris = T.astype(float)
        tris[4, 2] = 1.5
        e = refusal(P, tris)
        assert e.code == "bad_geometry" and e.errors[0]["loc"] == ["triangles", 4, 2]

    def test_index_out_of_range(self):
        P, T = shapes.box()
        T[7, 1] = 8
        T[9, 0] = -1
        e = refusal(P, T)
        assert e.code == "index_out_of_range"
        assert [x["loc"] for x in e.errors] == [["triangles", 7, 1], ["triangles", 9, 0]]

    def test_too_few_triangles(self):
        P, T = shapes.box()
        e = refusal(P, T[:3])
        assert e.code == "too_few_triangles"


class TestRefusedTopology:
    def test_repeated_index(self):
        P, T = shapes.box()
        T[3] = [1, 1, 2]
        e = refusal(P, T)
        assert e.code == "degenerate_triangle"
        assert e.errors[0]["loc"] == ["triangles", 3]
        assert "repeats a point" in e.message

    def test_collinear_corners(self):
        # A cube whose point 1 sits exactly on the segment between 0 and 3's
        # projection is too special; use an extra collinear point on an edge.
        P = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [1, 0, 0]], float)
        T = np.array([[0, 4, 1], [0, 2, 4], [4, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
        e = refusal(P, T)
        assert e.code == "degenerate_triangle"
        assert e.errors[0]["loc"] == ["triangles", 0]
        assert "collinear" in e.message

    def test_collinear_far_from_origin(self):
        P = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [1, 0, 0]], float) * 0.1 + 1e6
        T = np.array([[0, 4, 1], [0, 2, 4], [4, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
        assert refusal(P, T).code == "degenerate_triangle"

    @pytest.mark.parametrize("flip", [False, True])
    def test_duplicate_triangle(self, flip):
        P, T = shapes.box()
        extra = T[4][::-1] if flip else T[4]
        e = refusal(P, np.concatenate([T, [extra]]))
        assert e.code == "duplicate_triangle"
        assert e.errors[0]["loc"] == ["triangles", 12]
        assert "triangle 4" in e.message

    def test_open_edge(self):
        P, T = shapes.box()
        e = refusal(P, T[1:])
        assert e.code == "open_edge"
        assert len(e.errors) == 3  # the three edges of the missing triangle
        assert "held by 1 triangle" in e.message

    def test_nonmanifold_edge(self):
        # Two tetrahedra sharing the edge 0-1: it is held by four triangles.
        P = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.5]], float)
        tet = np.array([[0, 2, 3], [0, 1, 2], [0, 3, 1], [1, 3, 2]])
        tet2 = np.array([[0, 4, 5], [0, 5, 1], [0, 1, 4], [1, 5, 4]])
        e = refusal(P, np.concatenate([tet, tet2]))
        assert e.code == "nonmanifold_edge"
        assert "edge (0, 1) is held by 4 triangles" in e.message

    def test_nonmanifold_vertex(self):
        # Two tetrahedra touching at one point (a bowtie).
        P = np.array(
            [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]], float
        )
        t1 = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        t2 = np.array([[0, 4, 5], [0, 6, 4], [0, 5, 6], [4, 6, 5]])
        e = refusal(P, np.concatenate([t1, t2]))
        assert e.code == "nonmanifold_vertex"
        assert e.errors[0]["loc"] == ["points", 0]
        assert "2 separate fans" in e.message

    def test_inconsistent_orientation(self):
        P, T = shapes.box(n=2)
        T[5] = T[5][::-1]
        e = refusal(P, T)
        assert e.code == "inconsistent_orientation"
        assert all(5 in (int(s) for s in x["msg"].split() if s.isdigit()) for x in e.errors)
        assert len(e.errors) == 3


class TestRefusedIntersections:
    def test_overlapping_cubes(self):
        P, T = two(*shapes.box(), *shapes.box((0.5, 0.5, 0.5), (1.5, 1.5, 1.5)))
        e = refusal(P, T)
        assert e.code == "shell_intersection"
        assert "intersect at (" in e.message and "shells 0 and 1" in e.message
        assert e.errors[0]["loc"][0] == "triangles"

    def test_touching_faces(self):
        # Two unit cubes sharing the plane x = 1 (coplanar overlap).
        P, T = two(*shapes.box(), *shapes.box((1, 0.25, 0.25), (2, 0.75, 0.75)))
        assert refusal(P, T).code == "shell_intersection"

    def test_vertex_on_a_face(self):
        # A tetrahedron whose apex touches the cube's top face from above.
        P = np.array([[0.2, 0.2, 2], [0.8, 0.2, 2], [0.5, 0.8, 2], [0.5, 0.4, 1.0]])
        T = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])
        P, T = two(*shapes.box(), P, T)
        e = refusal(P, T)
        assert e.code == "shell_intersection"
        assert "(0.5, 0.4, 1.0)" in e.message

    def test_coincident_points_of_two_shells(self):
        P, T = two(*shapes.box(), *shapes.box((1, 1, 1), (2, 2, 2)))
        assert refusal(P, T).code == "shell_intersection"

    def test_self_intersection_point(self):
        # Push the cube's corner (1, 1, 1) down through the bottom face z = 0.
        P, T = shapes.box()
        top = int(np.flatnonzero((P == 1).all(axis=1))[0])
        P[top] = [0.5, 0.5, -0.5]
        e = refusal(P, T)
        assert e.code == "self_intersection"
        x, y, z = (float(v) for v in e.message.split("intersect at (")[1].split(")")[0].split(","))
        assert all(-0.5 - 1e-12 <= c <= 1 + 1e-12 for c in (x, y, z))

    def test_fold_on_common_edge(self):
        # Triangles (0, 1, 2) and (1, 0, 3) folded onto each other over edge 0-1.
        P = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.2, 0.5, 0]], float)
        w = np.empty(3)
        T = np.array([[0, 1, 2], [1, 0, 3]])
        assert _tri_tri(P, T, 0, 1, w) == 1
        P[3] = [0.2, -0.5, 0]  # unfolded: coplanar neighbours
        assert _tri_tri(P, T, 0, 1, w) == 0
        P[3] = [0.2, 0.5, 1e-300]  # nearly folded: exact sign says apart
        assert _tri_tri(P, T, 0, 1, w) == 0

    @pytest.mark.parametrize(
        "b, hit",
        [
            ([[0.2, 0.2, -1], [0.2, 0.2, 1], [3, 3, 3]], 1),  # crossing
            ([[0.2, 0.2, 0], [0.2, 0.2, 1], [3, 3, 3]], 1),  # vertex on the face
            ([[0.2, 0.2, 1e-300], [0.2, 0.2, 1], [3, 3, 3]], 0),  # just above
            ([[0.1, 0.1, 0], [0.3, 0.1, 0], [0.1, 0.3, 0]], 1),  # coplanar, inside
            ([[1, 0, 0], [2, 0, 0], [2, 1, 0]], 1),  # coplanar, touching a corner
            ([[2, 0, 0], [3, 0, 0], [3, 1, 0]], 0),  # coplanar, apart
        ],
    )
    def test_triangle_pairs(self, b, hit):
        P = np.concatenate([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], b]).astype(float)
        T = np.array([[0, 1, 2], [3, 4, 5]])
        assert _tri_tri(P, T, 0, 1, np.empty(3)) == hit
        assert _tri_tri(P, np.ascontiguousarray(T[::-1]), 0, 1, np.empty(3)) == hit

    def test_shared_vertex_pairs(self):
        P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [1, 1, 1]], float)
        w = np.empty(3)
        assert _tri_tri(P, np.array([[0, 1, 2], [0, 3, 4]]), 0, 1, w) == 1  # edge 0-3 in the plane
        P[3] = [-1, -1, 0]
        assert _tri_tri(P, np.array([[0, 1, 2], [0, 3, 4]]), 0, 1, w) == 0  # only vertex 0
        P[3] = [0.5, 0.0, 0.0]  # coplanar and collinear with edge 0-1
        assert _tri_tri(P, np.array([[0, 1, 2], [0, 3, 4]]), 0, 1, w) == 1


# ---------------------------------------------------------------------------
# Hypothesis: star-shaped polyhedra and damaged ones
# ---------------------------------------------------------------------------


@st.composite
def star_polyhedra(draw):
    n = draw(st.integers(8, 40))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    # The six axis directions keep the origin inside the hull of the directions.
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(n, 3))])
    n += 6
    radii = rng.uniform(0.5, 1.5, size=n)
    return shapes.star(radii, d)


def _planes_avoid_origin(P, T) -> bool:
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c))
    return bool((vol > 1e-9).all())


SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class TestHypothesis:
    @SETTINGS
    @given(star_polyhedra())
    def test_star_polyhedra_are_accepted(self, surf):
        P, T = surf
        if not _planes_avoid_origin(P, T):
            return
        s = parse_surface(P, T)
        assert s.volume == pytest.approx(signed_volume(P, T), rel=1e-12)
        t = parse_surface(P + [1e6, -2e6, 3e6], T[:, ::-1])
        assert t.triangle_reversed.all()
        assert t.volume == pytest.approx(s.volume, rel=1e-8)

    @SETTINGS
    @given(star_polyhedra(), st.data())
    def test_missing_triangle(self, surf, data):
        P, T = surf
        k = data.draw(st.integers(0, len(T) - 1))
        e = refusal(P, np.delete(T, k, axis=0))
        assert e.code == "open_edge"
        held = {tuple(sorted(x)) for x in (T[k, [0, 1]], T[k, [1, 2]], T[k, [2, 0]])}
        named = {
            tuple(int(v) for v in x["msg"].split("edge (")[1].split(")")[0].split(", "))
            for x in e.errors
        }
        assert named == held

    @SETTINGS
    @given(star_polyhedra(), st.data())
    def test_flipped_triangle(self, surf, data):
        P, T = surf
        k = data.draw(st.integers(0, len(T) - 1))
        T = T.copy()
        T[k] = T[k][::-1]
        e = refusal(P, T)
        assert e.code == "inconsistent_orientation"
        assert all(f" {k} " in x["msg"] or f"{k} and" in x["msg"] for x in e.errors)

    @SETTINGS
    @given(star_polyhedra(), st.data())
    def test_duplicated_triangle(self, surf, data):
        P, T = surf
        k = data.draw(st.integers(0, len(T) - 1))
        e = refusal(P, np.concatenate([T, T[k : k + 1, ::-1]]))
        assert e.code == "duplicate_triangle"
        assert e.errors[0]["loc"] == ["triangles", len(T)]

    @SETTINGS
    @given(star_polyhedra(), st.floats(0.01, 0.3), st.integers(0, 2))
    def test_shifted_copy_intersects(self, surf, shift, axis):
        P, T = surf
        if not _planes_avoid_origin(P, T):
            return
        Q = P.copy()
        Q[:, axis] += shift
        e = refusal(*two(P, T, Q, T))
        assert e.code == "shell_intersection"


# ---------------------------------------------------------------------------
# The wire model
# ---------------------------------------------------------------------------


class TestSurfaceIn:
    def test_example_parses(self):
        from service.methods.surface_schema import UNIT_CUBE, SurfaceIn

        model = SurfaceIn.model_validate(UNIT_CUBE)
        s = model.to_surface()
        assert s.volume == 1.0
        assert not s.triangle_reversed.any()
        assert model.point_count() == 8

    def test_nan_and_booleans_are_located(self):
        from pydantic import BaseModel, ValidationError

        from service.methods.surface_schema import SurfaceIn

        class Params(BaseModel):
            surface: SurfaceIn

        body = '{"surface": {"points": [[0, 0, 0], [1, NaN, 0]], "triangles": [[0, 1, 2]]}}'
        with pytest.raises(ValidationError) as info:
            Params.model_validate_json(body)
        (err,) = info.value.errors()
        assert err["loc"] == ("surface", "points", 1, 1)
        with pytest.raises(ValidationError) as info:
            SurfaceIn.model_validate({"points": [[0, 0, 0]], "triangles": [[0, True, 2]]})
        assert info.value.errors()[0]["loc"] == ("triangles", 0, 1)
        with pytest.raises(ValidationError) as info:
            SurfaceIn.model_validate({"points": [[0, 0]], "triangles": []})
        assert info.value.errors()[0]["loc"] == ("points", 0)

    def test_meshcore_errors_are_located_under_the_field(self):
        from service.methods.surface_schema import UNIT_CUBE, SurfaceIn

        open_cube = {**UNIT_CUBE, "triangles": UNIT_CUBE["triangles"][1:]}
        with pytest.raises(InputError) as info:
            SurfaceIn.model_validate(open_cube).to_surface()
        assert info.value.code == "open_edge"
        assert info.value.errors[0]["loc"][:2] == ["surface", "triangles"]
        two_points = {"points": [[0, 0, 0], [1, 0, 0]], "triangles": [[0, 1, 1]] * 4}
        with pytest.raises(InputError) as info:
            SurfaceIn.model_validate(two_points).to_surface(loc=("body",))
        assert info.value.code == "too_few_points"
        assert info.value.errors[0]["loc"] == ["body", "points"]


def test_added_triangles_are_tested_against_the_surface():
    """A triangle piercing a face of the cube does not fit; one inside it does; the
    cube's volume and its exact sign, and the reversed cube's."""
    P, T = shapes.box()
    inner = np.array([[0.2, 0.2, 0.5], [0.8, 0.2, 0.5], [0.5, 0.8, 0.5]])
    piercing = inner + [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # through z = 1
    for extra, fits in ((inner, True), (piercing, False)):
        X = np.concatenate([P, extra])
        tri = np.concatenate([T, [[len(P), len(P) + 1, len(P) + 2]]])
        assert added_triangles_fit(X, tri, len(T)) is fits
    s = parse_surface(P, T)
    assert shell_volume(s.points, s.triangles) == (pytest.approx(1.0), 1)
    assert shell_volume(s.points, s.triangles[:, ::-1])[1] == -1
