"""Product meshes (§8.1): facts a reader can check by hand.

The canonical base is the unit square in two triangles::

    3-----2
    |   / |
    |  /  |
    | /   |
    0-----1
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.mesh import Mesh, io, quality, topology
from meshcore.product.extrusion import (
    Helix,
    Rotate,
    Sections,
    Transforms,
    Translate,
    extrude,
    sweep,
    sweep_boundary,
)

SOLID = ("tetra", "pyramid", "wedge", "hexahedron")


def square() -> Mesh:
    return Mesh([[0, 0], [1, 0], [1, 1], [0, 1]], [("triangle", [[0, 1, 2], [0, 2, 3]])])


def grid(nx, ny, x0=0.0, x1=1.0, y0=0.0, y1=1.0, tri=False, perm=None) -> Mesh:
    """A structured grid of quads (or of triangles, each quad cut along 0-2)."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    idx = np.arange(len(pts)).reshape(ny + 1, nx + 1)
    q = np.column_stack(
        [idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()]
    )
    cells = ("triangle", np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])) if tri else ("quad", q)
    if perm is not None:  # renumber the points
        inv = np.argsort(perm)
        pts, cells = pts[perm], (cells[0], inv[cells[1]])
    return Mesh(pts, [cells])


def volumes(mesh: Mesh) -> dict[str, np.ndarray]:
    return {
        b.type: quality.signed_volume(mesh.points, b.data, b.type)
        for b in mesh.cells
        if b.type in SOLID
    }


def total_volume(mesh: Mesh) -> float:
    return float(sum(v.sum() for v in volumes(mesh).values()))


def solid(mesh: Mesh) -> Mesh:
    return Mesh(mesh.points, tuple(b for b in mesh.cells if b.type in SOLID))


def set_size(mesh: Mesh, name: str) -> int:
    return sum(len(a) for a in mesh.cell_sets[name])


def assert_valid_solid(mesh: Mesh) -> None:
    """Positive volumes, conforming, boundary facets = bottom + top + side, no duplicate points."""
    for v in volumes(mesh).values():
        assert (v > 0).all()
    conf = topology.conformity(solid(mesh))
    assert conf["nonmanifold"] == 0
    assert conf["boundary_edges"] == sum(set_size(mesh, s) for s in ("bottom", "top", "side"))
    assert len(np.unique(np.round(mesh.points, 12), axis=0)) == len(mesh.points)
    mesh.check()


class TestCounts:
    """A point gives lines, a line quads, a triangle wedges, a quad hexahedra (Figure 8.1)."""

    def test_two_triangles_ten_layers_give_20_wedges_on_44_points(self):
        r = extrude(square(), Translate([0, 0, 1], layers=10))
        assert len(r.mesh.points) == 44
        assert (r.mesh.cells[0].type, len(r.mesh.cells[0])) == ("wedge", 20)
        assert set_size(r.mesh, "bottom") == set_size(r.mesh, "top") == 2
        assert set_size(r.mesh, "side") == 4 * 10  # 4 boundary edges, 10 layers
        assert_valid_solid(r.mesh)

    def test_quads_give_hexahedra(self):
        r = extrude(grid(3, 2), Translate([0, 0, 2], layers=4))
        assert [(b.type, len(b)) for b in r.mesh.cells][0] == ("hexahedron", 24)
        assert len(r.mesh.points) == 12 * 5
        assert_valid_solid(r.mesh)

    def test_lines_give_quads_and_points_give_lines(self):
        base = Mesh([[0, 0], [1, 0], [2, 0]], [("line", [[0, 1], [1, 2]]), ("vertex", [[0]])])
        r = extrude(base, Translate([0, 1, 0], layers=3))
        types = [(b.type, len(b)) for b in r.mesh.cells]
        assert types[:2] == [("quad", 6), ("line", 3)]
        assert set_size(r.mesh, "bottom") == set_size(r.mesh, "top") == 2  # lines
        assert set_size(r.mesh, "side") == 2 * 3  # two end points, three layers
        assert len(r.mesh.points) == 12
        area = quality.signed_area(r.mesh.points, r.mesh.cells[0].data, "quad")
        np.testing.assert_allclose(area, 1 / 3)

    def test_layer_and_source_cell_data(self):
        r = extrude(square(), Translate([0, 0, 1], layers=3))
        wedges = 0
        assert r.mesh.cell_data["layer"][wedges].tolist() == [0, 0, 1, 1, 2, 2]
        assert r.mesh.cell_data["source_cell"][wedges].tolist() == [0, 1] * 3
        # the top facets bound cells of the last layer
        top = [i for i, a in enumerate(r.mesh.cell_sets["top"]) if len(a)][0]
        assert r.mesh.cell_data["layer"][top].tolist() == [2, 2]

    def test_base_data_and_sets_are_carried(self):
        base = Mesh(
            square().points,
            square().cells,
            point_data={"T": np.array([1.0, 2.0, 3.0, 4.0])},
            cell_data={"material": [np.array([7, 8])]},
            cell_sets={"left": [np.array([1])]},
        )
        m = extrude(base, Translate([0, 0, 1], layers=2)).mesh
        assert m.point_data["T"].tolist() == [1, 2, 3, 4] * 3
        assert m.cell_data["material"][0].tolist() == [7, 8, 7, 8]
        assert m.cell_sets["left"][0].tolist() == [1, 3]


class TestTranslation:
    def test_volume_is_area_times_height(self):
        r = extrude(grid(4, 3, 0, 2, 0, 1.5, tri=True), Translate([0.3, -0.2, 2.5], layers=7))
        assert total_volume(r.mesh) == pytest.approx(2 * 1.5 * 2.5, rel=1e-13)
        assert_valid_solid(r.mesh)

    def test_variable_steps(self):
        r = extrude(square(), Translate([0, 0, 6], steps=[1, 2, 3]))
        z = np.unique(r.mesh.points[:, 2])
        np.testing.assert_allclose(z, [0, 1, 3, 6])
        assert r.layers == 3

    def test_downward_sweep_is_reoriented(self):
        r = extrude(square(), Translate([0, 0, -1], layers=2))
        assert_valid_solid(r.mesh)
        assert total_volume(r.mesh) == pytest.approx(1.0)

    def test_clockwise_base_cells_are_reoriented(self):
        base = Mesh(square().points, [("triangle", [[0, 2, 1], [0, 2, 3]])])
        assert_valid_solid(extrude(base, Translate([0, 0, 1], layers=2)).mesh)

    @settings(max_examples=25, deadline=None)
    @given(
        vz=st.floats(0.05, 5) | st.floats(-5, -0.05),
        vx=st.floats(-2, 2),
        steps=st.lists(st.floats(0.1, 10), min_size=1, max_size=5),
        tri=st.booleans(),
        simplices=st.booleans(),
        seed=st.integers(0, 2**16),
    )
    def test_random_translations_preserve_volume(self, vz, vx, steps, tri, simplices, seed):
        rng = np.random.default_rng(seed)
        base = grid(3, 2, 0, 3, 0, 2, tri=tri, perm=rng.permutation(12))
        r = extrude(base, Translate([vx, 0, vz], steps=steps), simplices=simplices)
        assert total_volume(r.mesh) == pytest.approx(6 * abs(vz), rel=1e-12)
        assert_valid_solid(r.mesh)
        if simplices:
            assert {b.type for b in r.mesh.cells} == {"tetra", "triangle"}


class TestRotation:
    @pytest.mark.parametrize("n", [3, 8, 24])
    def test_rectangle_about_the_y_axis_gives_the_polygonal_volume(self, n):
        R, h = 2.0, 3.0
        r = extrude(grid(4, 3, 0, R, 0, h), Rotate([0, 0, 0], [0, 1, 0], 360, n))
        assert total_volume(r.mesh) == pytest.approx(n * math.sin(2 * math.pi / n) * R**2 * h / 2)
        assert_valid_solid(r.mesh)

    def test_cells_touching_the_axis_become_wedges_and_the_ring_closes(self):
        n = 12
        r = extrude(grid(4, 3, 0, 2, 0, 3), Rotate([0, 0, 0], [0, 1, 0], 360, n))
        types = {b.type: len(b) for b in r.mesh.cells if b.type in SOLID}
        assert types == {"hexahedron": 3 * 3 * n, "wedge": 3 * n}  # one column on the axis
        assert r.closed and r.fixed_vertices == 4
        # 20 base points: 4 on the axis once, 16 on each of the n sections (none repeated)
        assert len(r.mesh.points) == 4 + 16 * n
        assert set_size(r.mesh, "bottom") == set_size(r.mesh, "top") == 0
        for v in volumes(r.mesh).values():
            assert v.min() > 0
        for b in r.mesh.cells:  # no cell repeats a point
            s = np.sort(b.data, axis=1)
            assert not (s[:, 1:] == s[:, :-1]).any()
        assert_valid_solid(r.mesh)

    def test_triangles_touching_the_axis_become_pyramids_and_tetrahedra(self):
        # vertex 0 on the axis (x = 0); triangle 0 has one axis vertex, triangle 1 two
        base = Mesh([[0, 0], [1, 0], [1, 1], [0, 1]], [("triangle", [[0, 1, 2], [0, 2, 3]])])
        r = extrude(base, Rotate([0, 0, 0], [0, 1, 0], 90, 3))
        assert {b.type: len(b) for b in r.mesh.cells if b.type in SOLID} == {
            "pyramid": 3,
            "tetra": 3,
        }
        assert total_volume(r.mesh) == pytest.approx(3 * math.sin(math.pi / 6) / 2)
        assert_valid_solid(r.mesh)

    def test_simplices_keep_the_mesh_conforming(self):
        n = 10
        r = extrude(grid(3, 2, 0, 1, 0, 1), Rotate([0, 0, 0], [0, 1, 0], 360, n), simplices=True)
        assert {b.type for b in r.mesh.cells} == {"tetra", "triangle"}
        assert total_volume(r.mesh) == pytest.approx(n * math.sin(2 * math.pi / n) / 2)
        assert_valid_solid(r.mesh)

    def test_a_quad_touching_the_axis_at_one_vertex_is_an_error_naming_it(self):
        diamond = Mesh([[0, 0], [1, -1], [2, 0], [1, 1]], [("quad", [[0, 1, 2, 3]])])
        path = Rotate([0, 0, 0], [0, 1, 0], 360, 8)
        with pytest.raises(InputError) as err:
            extrude(diamond, path)
        assert err.value.code == "degenerate_cell"
        assert err.value.errors[0]["loc"] == ["mesh", "cells", 0, "data", 0]
        r = extrude(diamond, path, simplices=True)  # its tetrahedra are fine
        assert_valid_solid(r.mesh)

    def test_degenerate_cells_are_dropped_and_counted(self):
        base = Mesh(
            [[0, 0], [1, -1], [2, 0], [1, 1], [2, 1], [3, 1]],
            [("quad", [[0, 1, 2, 3]]), ("triangle", [[2, 5, 4]])],
        )
        r = extrude(base, Rotate([0, 0, 0], [0, 1, 0], 90, 4), on_degenerate="drop")
        assert r.dropped == 1
        assert {b.type: len(b) for b in r.mesh.cells if b.type in SOLID} == {"wedge": 4}

    def test_a_base_crossing_the_axis_is_invalid(self):
        with pytest.raises(InputError) as err:
            extrude(grid(2, 1, -1, 1, 0, 1), Rotate([0, 0, 0], [0, 1, 0], 90, 3))
        assert err.value.code == "inverted_cells"

    def test_a_rotation_past_360_degrees_is_invalid_with_the_cells_past_it(self):
        with pytest.raises(InputError) as err:
            extrude(grid(2, 2, 1, 2, 0, 1), Rotate([0, 0, 0], [0, 1, 0], 400, 10))
        assert err.value.code == "self_overlap"
        # the last layer (360 to 400 degrees) holds the 4 cells 36..39
        assert "cells 36, 37, 38, 39 of block 0 (hexahedron)" in err.value.message
        assert len(err.value.errors) == 4
        assert all(e["loc"] == ["path"] and "layer 9" in e["msg"] for e in err.value.errors)
        r = extrude(grid(2, 2, 1, 2, 0, 1), Rotate([0, 0, 0], [0, 1, 0], 400, 10), validate=False)
        assert len(r.mesh.cells[0]) == 40

    def test_affine_maps_past_360_degrees_are_caught_by_the_generic_check(self):
        def turn(deg):
            t = math.radians(deg)
            m = np.eye(4)
            m[0, 0], m[0, 2], m[2, 0], m[2, 2] = math.cos(t), math.sin(t), -math.sin(t), math.cos(t)
            return m

        base = grid(2, 2, 1, 2, 0, 1)
        ok = Transforms(np.array([turn(300 * k / 7) for k in range(8)]))
        assert_valid_solid(extrude(base, ok).mesh)
        bad = Transforms(np.array([turn(400 * k / 7) for k in range(8)]))
        with pytest.raises(InputError) as err:
            extrude(base, bad)
        assert err.value.code == "self_overlap"


class TestHelix:
    def test_a_helix_with_room_between_turns_is_valid(self):
        # the profile is 1 high; two turns rise 2.2, so each turn clears the last by 0.1
        r = extrude(grid(4, 4, 1, 2, 0, 1), Helix([0, 0, 0], [0, 1, 0], 720, [0, 2.2, 0], 48))
        assert_valid_solid(r.mesh)

    @pytest.mark.parametrize("rise", [1.0, 1.8])
    def test_a_helix_whose_turns_cross_is_invalid_with_cell_ids(self, rise):
        with pytest.raises(InputError) as err:
            extrude(grid(4, 4, 1, 2, 0, 1), Helix([0, 0, 0], [0, 1, 0], 720, [0, rise, 0], 48))
        assert err.value.code == "self_overlap"
        assert err.value.errors and all(
            "overlaps another cell" in e["msg"] for e in err.value.errors
        )

    def test_less_than_a_turn_never_overlaps(self):
        r = extrude(grid(2, 2, 1, 2, 0, 1), Helix([0, 0, 0], [0, 1, 0], 200, [0, 0.1, 0], 8))
        assert_valid_solid(r.mesh)


class TestExplicitSections:
    def test_transforms_and_sections_reproduce_a_translation(self):
        ref = extrude(square(), Translate([0, 0, 3], layers=3)).mesh
        shifts = [np.eye(4) for _ in range(4)]
        for k, m in enumerate(shifts):
            m[2, 3] = k
        via_maps = extrude(square(), Transforms(np.array(shifts))).mesh
        pts = np.column_stack([square().points, np.zeros(4)])
        via_points = extrude(square(), Sections(np.array([pts + [0, 0, k] for k in range(4)]))).mesh
        for m in (via_maps, via_points):
            np.testing.assert_allclose(m.points, ref.points)
            assert all((a.data == b.data).all() for a, b in zip(m.cells, ref.cells, strict=True))


class TestInputErrors:
    @pytest.mark.parametrize(
        "path, loc",
        [
            (Translate([0, 0, 0], layers=3), ["path", "vector"]),
            (Translate([0, 0, 1], layers=0), ["path", "layers"]),
            (Translate([0, 0, 1], steps=[1, -1]), ["path", "steps", 1]),
            (Translate([0, 0, math.nan], layers=2), ["path", "vector"]),
            (Rotate([0, 0, 0], [0, 0, 0], 90, 3), ["path", "axis_direction"]),
            (Rotate([0, 0, 0], [0, 1, 0], 0, 3), ["path", "angle"]),
            (Transforms(np.zeros((3, 3, 3))), ["path", "matrices"]),
            (Transforms(np.array([np.eye(4), np.ones((4, 4))])), ["path", "matrices", 1, 3]),
            (Sections(np.zeros((2, 3, 3))), ["path", "points", 0]),
        ],
    )
    def test_bad_paths_name_the_field(self, path, loc):
        with pytest.raises(InputError) as err:
            extrude(square(), path)
        assert err.value.errors[0]["loc"][: len(loc)] == loc

    @settings(max_examples=40, deadline=None)
    @given(
        kind=st.sampled_from(["translate", "rotate", "helix"]),
        vec=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=4),
        angle=st.floats(allow_nan=True, allow_infinity=True),
        layers=st.integers(-2, 4) | st.floats(0, 3) | st.none(),
    )
    def test_any_path_either_works_or_raises_input_error(self, kind, vec, angle, layers):
        path = {
            "translate": lambda: Translate(vec, layers=layers),
            "rotate": lambda: Rotate([0, 0, 0], vec, angle, layers),
            "helix": lambda: Helix(vec, [0, 1, 0], angle, vec, layers),
        }[kind]()
        try:
            r = extrude(square(), path, validate=False)
        except InputError as exc:
            assert exc.errors and exc.errors[0]["loc"][0] in ("path", "mesh")
        else:
            r.mesh.check()

    def test_a_volume_base_is_refused(self):
        tet = Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [("tetra", [[0, 1, 2, 3]])])
        with pytest.raises(InputError) as err:
            extrude(tet, Translate([0, 0, 1], layers=1))
        assert err.value.errors[0]["loc"] == ["mesh", "cells", 0, "type"]


class TestSweep:
    """A square source at z = 0 and the same square turned 30°, halved, at z = 2.

    With straight sides, every vertex moves on the straight line from its
    source to its target position (the target is an affine image).
    """

    def setup_method(self):
        self.source = grid(4, 4, -1, 1, -1, 1)
        t = math.radians(30)
        rot = np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])
        self.P = np.column_stack([self.source.points, np.zeros(25)])
        self.target = 0.5 * self.P @ rot.T + [0, 0, 2]

    def test_planar_pair_reproduces_the_analytic_interpolation(self):
        r = sweep(self.source, self.target, layers=4)
        for k in range(5):
            expected = (1 - k / 4) * self.P + (k / 4) * self.target
            np.testing.assert_allclose(r.mesh.points[25 * k : 25 * (k + 1)], expected, atol=1e-13)
        assert len(r.mesh.cells[0]) == 16 * 4
        assert_valid_solid(r.mesh)

    def test_boundary_only_target_computes_the_interior(self):
        bv = sweep_boundary(self.source)
        assert len(bv) == 16 and (np.diff(bv) > 0).all()
        full = sweep(self.source, self.target, layers=4).mesh.points
        part = sweep(self.source, self.target[bv], layers=4).mesh.points
        np.testing.assert_allclose(part, full, atol=1e-13)

    def test_curved_target_is_reproduced_and_volumes_stay_positive(self):
        bump = self.target.copy()
        bump[:, 2] += 0.2 * (1 - bump[:, 0] ** 2 - bump[:, 1] ** 2)
        r = sweep(self.source, bump, layers=6, simplices=True)
        np.testing.assert_allclose(r.mesh.points[-25:], bump)
        assert_valid_solid(r.mesh)

    def test_sides_give_the_intermediate_boundary(self):
        bv = sweep_boundary(self.source)
        sides = [
            (1 - k / 3) * self.P[bv] + (k / 3) * self.target[bv] + [0.2 * math.sin(k), 0, 0]
            for k in (1, 2)
        ]
        r = sweep(self.source, self.target, sides=sides)
        assert r.layers == 3
        np.testing.assert_allclose(r.mesh.points[25 + bv], sides[0])
        assert_valid_solid(r.mesh)

    def test_bad_target_length_names_the_field(self):
        with pytest.raises(InputError) as err:
            sweep(self.source, self.target[:7], layers=2)
        assert err.value.errors[0]["loc"] == ["target"]


class TestGmshRoundTrip:
    @pytest.mark.parametrize("layers", [1, 3])
    def test_sets_become_physical_groups(self, layers):
        # one layer: no node inside the solid, so the wedges' Gmsh entity must borrow one
        m = extrude(square(), Translate([0, 0, 1], layers=layers)).mesh
        back = io.from_bytes(io.to_bytes(m, "gmsh"), "gmsh")
        for name in ("bottom", "top", "side"):
            assert sum(len(a) for a in back.cell_sets[name]) == set_size(m, name)
        assert sum(len(b) for b in back.cells if b.type == "wedge") == 2 * layers
