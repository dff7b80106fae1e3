"""Quality measures on cells whose values can be worked out by hand, and the report's shape."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import Cancelled, InputError
from meshcore.mesh import CellBlock, Mesh, quality, topology

S3 = math.sqrt(3.0)

#   2
#   | \       equilateral: 0 (0, 0), 1 (1, 0), 2 (1/2, sqrt(3)/2)
#   0---1
EQUILATERAL = np.array([[0, 0], [1, 0], [0.5, S3 / 2]])

#   2
#   | \       right isosceles: legs 1, hypotenuse sqrt(2)
#   0---1
RIGHT = np.array([[0.0, 0], [1, 0], [0, 1]])

#   3---2
#   |   |     unit square, counterclockwise
#   0---1
SQUARE = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])

#     3-----2
#    /     /  rhombus of side 1: 60 degrees at 0 and 2, 120 at 1 and 3
#   0-----1
RHOMBUS = np.array([[0, 0], [1, 0], [1.5, S3 / 2], [0.5, S3 / 2]])

#       1
#      / \    the square turned by 45 degrees: corners on the axes
#     2   0
#      \ /
#       3
DIAMOND = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])

#   2
#   |\        arrowhead: 3 = (1, 1) is a reflex corner (270 degrees inside)
#   | 3
#   |/ \.
#   0---\1    0 (0, 0), 1 (2, 1), 2 (0, 2), 3 (1, 1)
ARROW = np.array([[0.0, 0], [2, 1], [0, 2], [1, 1]])

#       7-------6
#      /|      /|
#     4-------5 |    unit cube, meshio numbering
#     | 3-----|-2
#     |/      |/
#     0-------1
CUBE = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=float,
)

# regular tetrahedron of edge 2 sqrt(2) on alternate corners of the cube [-1, 1]^3,
# numbered so that 3 sees 0 1 2 counterclockwise (positive volume)
REGULAR_TET = np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1]], dtype=float)
UNIT_TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)


class TestTriangles:
    def test_equilateral(self) -> None:
        np.testing.assert_allclose(quality.triangle_angles(EQUILATERAL, [[0, 1, 2]]), [[60] * 3])
        np.testing.assert_allclose(quality.triangle_shape(EQUILATERAL, [[0, 1, 2]]), [1.0])

    def test_right_isosceles(self) -> None:
        np.testing.assert_allclose(quality.triangle_angles(RIGHT, [[0, 1, 2]]), [[90, 45, 45]])
        # area 1/2, squared sides 1 + 1 + 2 = 4: 4 sqrt(3) (1/2) / 4 = sqrt(3)/2 = 0.866
        np.testing.assert_allclose(quality.triangle_shape(RIGHT, [[0, 1, 2]]), [S3 / 2])
        np.testing.assert_allclose(quality.signed_area(RIGHT, [[0, 1, 2]]), [0.5])

    def test_clockwise_in_the_plane_is_negative(self) -> None:
        cells = [[0, 2, 1]]
        np.testing.assert_allclose(quality.signed_area(RIGHT, cells), [-0.5])
        np.testing.assert_allclose(quality.triangle_shape(RIGHT, cells), [-S3 / 2])
        np.testing.assert_allclose(quality.triangle_angles(RIGHT, cells), [[90, 45, 45]])
        r = quality.report(Mesh(RIGHT, (CellBlock("triangle", cells),)))
        assert r["triangle"]["invalid"] == 1
        assert r["triangle"]["quality"]["histogram"][0] == 1
        assert r["triangle"]["quality"]["max"] == 0.0

    def test_clockwise_on_a_surface_is_valid(self) -> None:
        """In 3D a triangle has no sign: the same triangle lifted to z = 1 is fine either way."""
        lifted = np.column_stack([RIGHT, np.ones(3)])
        np.testing.assert_allclose(quality.signed_area(lifted, [[0, 2, 1]]), [0.5])
        r = quality.report(Mesh(lifted, (CellBlock("triangle", [[0, 2, 1]]),)))
        assert r["triangle"]["invalid"] == 0
        assert r["triangle"]["quality"]["min"] == pytest.approx(S3 / 2)

    def test_flat_and_repeated_point_are_invalid_without_nan(self) -> None:
        """0 1 2 collinear; 0 0 1 repeats a point: area 0, quality 0, angles 0 or 180."""
        points = np.array([[0.0, 0], [1, 0], [2, 0]])
        cells = [[0, 1, 2], [0, 0, 1]]
        np.testing.assert_allclose(quality.triangle_shape(points, cells), [0, 0])
        np.testing.assert_allclose(quality.triangle_angles(points, cells)[0], [0, 180, 0])
        r = quality.report(Mesh(points, (CellBlock("triangle", cells),)))
        assert r["triangle"]["invalid"] == 2
        assert r["triangle"]["angle"] == {"min": 0.0, "max": 180.0}
        json.dumps(r, allow_nan=False)


class TestQuads:
    def test_unit_square(self) -> None:
        np.testing.assert_allclose(quality.quad_quality(SQUARE, [[0, 1, 2, 3]]), [1.0])
        np.testing.assert_allclose(quality.quad_angles(SQUARE, [[0, 1, 2, 3]]), [[90] * 4])
        np.testing.assert_allclose(quality.signed_area(SQUARE, [[0, 1, 2, 3]], "quad"), [1.0])

    def test_rhombus_60_120(self) -> None:
        # (8.3): Q = 2 theta / pi at 60 degrees = 2/3; 2 - 2 theta / pi at 120 = 2/3
        np.testing.assert_allclose(quality.quad_quality(RHOMBUS, [[0, 1, 2, 3]]), [2 / 3])
        np.testing.assert_allclose(quality.quad_angles(RHOMBUS, [[0, 1, 2, 3]]), [[60, 120] * 2])
        np.testing.assert_allclose(quality.signed_area(RHOMBUS, [[0, 1, 2, 3]], "quad"), [S3 / 2])

    def test_clockwise_square(self) -> None:
        cells = [[0, 3, 2, 1]]
        np.testing.assert_allclose(quality.quad_quality(SQUARE, cells), [0.0])
        np.testing.assert_allclose(quality.signed_area(SQUARE, cells, "quad"), [-1.0])
        np.testing.assert_allclose(quality.quad_angles(SQUARE, cells), [[90] * 4])

    def test_non_convex_quad(self) -> None:
        """Area 1 (shoelace 0 + 4 - 2 + 0 over 2), angles: at 0 and 2 between (2, 1) and
        (1, 1), arccos(3 / sqrt(10)) = 18.43; at 1, arccos(3/5) = 53.13; at 3, 270."""
        np.testing.assert_allclose(quality.signed_area(ARROW, [[0, 1, 2, 3]], "quad"), [1.0])
        np.testing.assert_allclose(quality.quad_quality(ARROW, [[0, 1, 2, 3]]), [0.0])
        a = quality.quad_angles(ARROW, [[0, 1, 2, 3]])[0]
        small = math.degrees(math.acos(3 / math.sqrt(10)))
        np.testing.assert_allclose(a, [small, math.degrees(math.acos(0.6)), small, 270])
        assert a.sum() == pytest.approx(360)
        r = quality.report(Mesh(ARROW, (CellBlock("quad", [[0, 1, 2, 3]]),)))
        assert r["quad"]["invalid"] == 0
        assert r["quad"]["angle"]["max"] == pytest.approx(270)
        assert r["quad"]["angle"]["min"] == pytest.approx(small)

    def test_metric_square_stays_a_rectangle(self) -> None:
        """Under M = diag(1, 4) lengths along y double: the unit square is a 1 x 2 rectangle."""
        q = quality.quad_quality(SQUARE, [[0, 1, 2, 3]], metric=np.diag([1.0, 4.0]))
        np.testing.assert_allclose(q, [1.0])

    def test_metric_diamond(self) -> None:
        """Under M = diag(1, 4), at corner 0 = (1, 0) the sides go to (-1, 1) and (-1, -1).

        <u, v>_M = 1 - 4 = -3 and |u|_M^2 = |v|_M^2 = 1 + 4 = 5, so cos = -3/5
        (126.87 degrees; Q = 2 - 2 theta / pi); at corner 1, cos = +3/5 (53.13
        degrees; Q = 2 theta / pi). Both give Q = 2 arccos(3/5) / pi = 0.5903,
        while without the metric the diamond is a square (Q = 1).
        """
        cells = [[0, 1, 2, 3]]
        np.testing.assert_allclose(quality.quad_quality(DIAMOND, cells), [1.0])
        q = quality.quad_quality(DIAMOND, cells, metric=[[1, 0], [0, 4]])
        np.testing.assert_allclose(q, [2 * math.acos(0.6) / math.pi])
        # a multiple of the identity changes nothing
        np.testing.assert_allclose(
            quality.quad_quality(RHOMBUS, cells, metric=3 * np.eye(2)), [2 / 3]
        )

    @pytest.mark.parametrize(
        "metric", [np.eye(3), [[1, 0], [0, -1]], [[1, 2], [0, 1]], [[1, math.nan], [math.nan, 1]]]
    )
    def test_bad_metric(self, metric) -> None:
        with pytest.raises(InputError) as err:
            quality.quad_quality(SQUARE, [[0, 1, 2, 3]], metric=metric)
        assert err.value.code == "bad_metric"

    @pytest.mark.parametrize("scale, shift", [(1.0, 0.0), (1e-6, 0.0), (1.0, 1e6), (1e150, 0.0)])
    def test_compiled_planar_measures_are_the_vectorized_ones(self, scale, shift) -> None:
        """Planar quads without a metric are measured by one compiled loop
        (``planar_quad_measures``); with the identity metric by the vectorized corners
        of the other cases: bit for bit the same, degenerate and overflowing quads too."""
        rng = np.random.default_rng(7)
        P = rng.normal(size=(300, 2)) * scale + shift
        P[:5] = P[5:10]  # coincident points
        Q = rng.integers(0, 300, (2000, 4))
        Q[:20, 1] = Q[:20, 0]  # zero-length edges, corners that do not turn
        for f in (quality.quad_quality, quality.quad_quality_simplified):
            assert np.array_equal(f(P, Q), f(P, Q, metric=np.eye(2)), equal_nan=True)

    def test_surface_quads_of_a_cube(self) -> None:
        """The six outward faces of the unit cube: closed, all squares."""
        faces = np.array(topology.CELL_FACES["hexahedron"]["quad"])
        np.testing.assert_allclose(quality.quad_quality(CUBE, faces), np.ones(6))
        np.testing.assert_allclose(quality.signed_area(CUBE, faces, "quad"), np.ones(6))
        r = quality.report(Mesh(CUBE, (CellBlock("quad", faces),)))
        assert r["quad"]["invalid"] == 0 and r["quad"]["quality"]["min"] == 1.0
        assert r["conformity"] == {"nonmanifold": 0, "boundary_edges": 0}


class TestVolumes:
    def test_unit_cube(self) -> None:
        cells = [list(range(8))]
        np.testing.assert_allclose(quality.signed_volume(CUBE, cells, "hexahedron"), [1.0])
        np.testing.assert_allclose(quality.scaled_jacobian(CUBE, cells, "hexahedron"), [1.0])
        np.testing.assert_allclose(quality.cell_angles(CUBE, cells, "hexahedron"), [[90] * 24])

    def test_sheared_cube(self) -> None:
        """Top face moved by (1, 0, 0): volume still 1; every corner has edges
        (1, 0, 0), (0, 1, 0) and (+-1, 0, +-1), so det / lengths = 1 / sqrt(2)."""
        sheared = CUBE + np.where(CUBE[:, 2:] == 1, [1.0, 0, 0], 0.0)
        cells = [list(range(8))]
        np.testing.assert_allclose(quality.signed_volume(sheared, cells, "hexahedron"), [1.0])
        np.testing.assert_allclose(
            quality.scaled_jacobian(sheared, cells, "hexahedron"), [1 / math.sqrt(2)]
        )

    def test_regular_tetrahedron(self) -> None:
        cells = [[0, 1, 2, 3]]
        # edge a = 2 sqrt(2): V = a^3 / (6 sqrt(2)) = 8/3
        np.testing.assert_allclose(quality.signed_volume(REGULAR_TET, cells), [8 / 3])
        np.testing.assert_allclose(quality.tetra_radius_ratio(REGULAR_TET, cells), [1.0])
        np.testing.assert_allclose(quality.scaled_jacobian(REGULAR_TET, cells, "tetra"), [1.0])
        np.testing.assert_allclose(quality.cell_angles(REGULAR_TET, cells, "tetra"), [[60] * 12])

    def test_unit_corner_tetrahedron(self) -> None:
        """Corner tet 0, e_x, e_y, e_z: r_in = 1 / (3 + sqrt(3)), r_circ = sqrt(3) / 2."""
        r_in, r_circ = 1 / (3 + S3), S3 / 2
        np.testing.assert_allclose(quality.signed_volume(UNIT_TET, [[0, 1, 2, 3]]), [1 / 6])
        np.testing.assert_allclose(
            quality.tetra_radius_ratio(UNIT_TET, [[0, 1, 2, 3]]), [3 * r_in / r_circ]
        )

    def test_inverted_tetrahedron(self) -> None:
        cells = [[0, 2, 1, 3]]
        np.testing.assert_allclose(quality.signed_volume(UNIT_TET, cells), [-1 / 6])
        assert quality.tetra_radius_ratio(UNIT_TET, cells)[0] < 0
        r = quality.report(Mesh(UNIT_TET, (CellBlock("tetra", cells),)))
        assert r["tetra"]["invalid"] == 1
        assert r["tetra"]["quality"] == {
            "min": 0.0, "mean": 0.0, "max": 0.0, "histogram": [1] + [0] * 9
        }  # fmt: skip

    def test_right_regular_wedge(self) -> None:
        """Equilateral triangle of side 1 extruded by 1: volume sqrt(3)/4, every corner
        det = sin 60 = sqrt(3)/2, scaled by 2/sqrt(3) to 1."""
        base = np.column_stack([EQUILATERAL, np.zeros(3)])
        points = np.concatenate([base, base + [0, 0, 1]])
        cells = [list(range(6))]
        np.testing.assert_allclose(quality.signed_volume(points, cells, "wedge"), [S3 / 4])
        np.testing.assert_allclose(quality.scaled_jacobian(points, cells, "wedge"), [1.0])
        a = quality.cell_angles(points, cells, "wedge")[0]
        assert sorted(set(np.round(a, 9))) == [60, 90]

    def test_right_isosceles_wedge(self) -> None:
        """Base 0, e_x, e_y: the 45 degree corners give sin 45 * 2/sqrt(3) = sqrt(2/3)."""
        base = np.column_stack([RIGHT, np.zeros(3)])
        points = np.concatenate([base, base + [0, 0, 1]])
        np.testing.assert_allclose(quality.signed_volume(points, [range(6)], "wedge"), [0.5])
        j = quality.scaled_jacobian(points, [range(6)], "wedge")
        np.testing.assert_allclose(j, [math.sqrt(2 / 3)])

    def test_equilateral_pyramid(self) -> None:
        """Unit square base, apex at height 1/sqrt(2): all 8 edges 1, volume sqrt(2)/6."""
        h = 1 / math.sqrt(2)
        points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, h]])
        cells = [list(range(5))]
        np.testing.assert_allclose(
            quality.signed_volume(points, cells, "pyramid"), [math.sqrt(2) / 6]
        )
        np.testing.assert_allclose(quality.scaled_jacobian(points, cells, "pyramid"), [1.0])
        below = points * [1, 1, -1]
        assert quality.scaled_jacobian(below, cells, "pyramid")[0] < 0
        assert quality.signed_volume(below, cells, "pyramid")[0] < 0

    def test_3d_cells_need_3d_points(self) -> None:
        with pytest.raises(InputError) as err:
            quality.signed_volume(np.zeros((4, 2)), [[0, 1, 2, 3]])
        assert err.value.code == "bad_dimension"


class TestReport:
    def test_shape_of_a_mixed_mesh(self) -> None:
        """A square split into a quad (left) and two triangles (right), with a boundary line
        and a marked vertex::

            3---4---5
            |   | / |
            0---1---2
        """
        points = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]], dtype=float)
        mesh = Mesh(
            points,
            (
                CellBlock("quad", [[0, 1, 4, 3]]),
                CellBlock("triangle", [[1, 2, 5]]),
                CellBlock("line", [[0, 1], [1, 2]]),
                CellBlock("triangle", [[1, 5, 4]]),
                CellBlock("vertex", [[0]]),
            ),
        )
        r = quality.report(mesh)
        assert list(r) == ["vertex", "line", "triangle", "quad", "conformity"]
        assert r["vertex"] == {"count": 1}
        assert r["line"] == {"count": 2, "length": {"min": 1.0, "max": 1.0}}
        tri = r["triangle"]
        assert set(tri) == {"count", "invalid", "quality", "angle"}
        assert tri["count"] == 2 and tri["invalid"] == 0
        assert tri["quality"]["min"] == pytest.approx(S3 / 2)
        assert tri["quality"]["histogram"] == [0] * 8 + [2, 0]
        assert tri["angle"]["min"] == pytest.approx(45) and tri["angle"]["max"] == pytest.approx(90)
        assert r["quad"]["quality"] == {
            "min": 1.0,
            "mean": 1.0,
            "max": 1.0,
            "histogram": [0] * 9 + [1],
        }
        assert r["conformity"] == {"nonmanifold": 0, "boundary_edges": 6}
        text = json.dumps(r, allow_nan=False)
        assert json.loads(text) == r
        # the bottom side 0-1-2 is input boundary: 4 boundary edges are left
        segs = np.array([[0, 1], [1, 2]])
        assert quality.report(mesh, segs)["conformity"]["boundary_edges"] == 4

    def test_values_are_plain_python(self) -> None:
        r = quality.report(Mesh(CUBE, (CellBlock("hexahedron", [range(8)]),)))

        def walk(x):
            if isinstance(x, dict):
                for v in x.values():
                    walk(v)
            elif isinstance(x, list):
                for v in x:
                    walk(v)
            else:
                assert type(x) in (int, float, type(None)), (x, type(x))

        walk(r)
        assert r["hexahedron"]["quality"]["max"] == 1.0
        assert r["conformity"] == {"nonmanifold": 0, "boundary_edges": 6}

    def test_nonmanifold_edge(self) -> None:
        """Three triangles on the edge 0-1, one in each of three half-planes."""
        points = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, 0, 1], [0.5, -1, 0]], float)
        mesh = Mesh(points, (CellBlock("triangle", [[0, 1, 2], [0, 1, 3], [0, 1, 4]]),))
        assert quality.report(mesh)["conformity"] == {"nonmanifold": 1, "boundary_edges": 6}

    def test_empty_block(self) -> None:
        r = quality.report(Mesh(SQUARE, (CellBlock("quad", np.zeros((0, 4), int)),)))
        assert r["quad"] == {
            "count": 0,
            "invalid": 0,
            "quality": {"min": None, "mean": None, "max": None, "histogram": [0] * 10},
            "angle": {"min": None, "max": None},
        }

    def test_progress_and_cancel(self) -> None:
        calls = []
        mesh = Mesh(SQUARE, (CellBlock("quad", [[0, 1, 2, 3]]), CellBlock("triangle", [[0, 1, 2]])))
        quality.report(mesh, progress=lambda f, m: calls.append((f, m)))
        fractions = [f for f, _ in calls]
        assert len(calls) >= 3 and fractions == sorted(fractions) and fractions[-1] == 1.0

        def cancel(fraction: float, message: str) -> None:
            raise Cancelled("stop")

        with pytest.raises(Cancelled):
            quality.report(mesh, progress=cancel)

    def test_bad_input(self) -> None:
        with pytest.raises(InputError) as err:
            quality.report(Mesh(SQUARE, (CellBlock("triangle", [[0, 1, 2], [0, 4, 1]]),)))
        assert err.value.errors[0]["loc"] == ["cells", 0, "data", 1, 1]
        points = SQUARE.copy()
        points[2, 0] = math.nan
        with pytest.raises(InputError) as err:
            quality.report(Mesh(points, (CellBlock("quad", [[0, 1, 2, 3]]),)))
        assert err.value.code == "non_finite"
        with pytest.raises(InputError) as err:
            quality.report(Mesh(SQUARE, (CellBlock("tetra", [[0, 1, 2, 3]]),)))
        assert err.value.code == "bad_dimension"
        with pytest.raises(InputError) as err:
            quality.report(Mesh(SQUARE, (CellBlock("polygon", [[0, 1, 2, 3]]),)))
        assert err.value.code == "unknown_cell_type"


@st.composite
def jittered_grids(draw):
    """A random triangulation of an nx x ny grid of unit squares.

    Each square is split along a random diagonal; interior points move by
    less than 0.2 in x and y (which keeps every triangle positive: the least
    height, 1/sqrt(2), shrinks by less than 2 * 0.2 * sqrt(2)); some
    triangles are then flipped (numbered clockwise).
    """
    nx, ny = draw(st.integers(1, 5)), draw(st.integers(1, 5))
    n = nx * ny
    diag = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    flip = np.array(draw(st.lists(st.booleans(), min_size=2 * n, max_size=2 * n)))
    seed = draw(st.integers(0, 2**32 - 1))
    ids = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    a, b = ids[:-1, :-1].ravel(), ids[:-1, 1:].ravel()
    c, d = ids[1:, 1:].ravel(), ids[1:, :-1].ravel()
    t1 = np.where(diag[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c]))
    t2 = np.where(diag[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))
    tri = np.concatenate([t1, t2])
    tri[flip] = tri[flip][:, [0, 2, 1]]
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0))
    points = np.column_stack([x.ravel(), y.ravel()])
    inner = (points[:, 0] > 0) & (points[:, 0] < nx) & (points[:, 1] > 0) & (points[:, 1] < ny)
    rng = np.random.default_rng(seed)
    points[inner] += rng.uniform(-0.2, 0.2, size=(int(inner.sum()), 2))
    boundary = topology.boundary(Mesh(points, (CellBlock("triangle", tri),))).cells[0].data
    return nx, ny, int(flip.sum()), boundary, Mesh(points, (CellBlock("triangle", tri),))


@settings(max_examples=30, deadline=None)
@given(jittered_grids())
def test_random_grid_triangulation(case) -> None:
    nx, ny, flipped, boundary, mesh = case
    tri = mesh.cells[0].data
    area = quality.signed_area(mesh.points, tri)
    assert np.abs(area).sum() == pytest.approx(nx * ny)
    assert int(np.count_nonzero(area < 0)) == flipped
    r = quality.report(mesh)
    t = r["triangle"]
    assert t["count"] == 2 * nx * ny
    assert t["invalid"] == flipped
    assert sum(t["quality"]["histogram"]) == t["count"]
    assert t["quality"]["histogram"][0] >= flipped
    assert 0 <= t["quality"]["min"] <= t["quality"]["mean"] <= t["quality"]["max"] <= 1
    assert 0 < t["angle"]["min"] <= 60 <= t["angle"]["max"] < 180
    assert r["conformity"] == {"nonmanifold": 0, "boundary_edges": 2 * (nx + ny)}
    assert quality.report(mesh, boundary)["conformity"]["boundary_edges"] == 0
    json.dumps(r, allow_nan=False)
