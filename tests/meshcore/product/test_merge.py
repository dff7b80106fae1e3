"""Merging product meshes (Figure 8.5, right): shared points once, interfaces conforming.

Two extrusions of the same 2 x 2 quad grid, stacked::

    z = 3  +---+---+      mesh 1: 3 layers, z from 1 to 3
           |   |   |
    z = 1  +===+===+  <-  the interface: mesh 0's top, mesh 1's bottom (9 points)
           |   |   |
    z = 0  +---+---+      mesh 0: 2 layers, z from 0 to 1
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.mesh import Mesh, topology
from meshcore.product.extrusion import Translate, extrude
from meshcore.product.merge import merged
from tests.meshcore.product.test_extrusion import (
    assert_valid_solid,
    grid,
    set_size,
    solid,
    total_volume,
)


def moved(mesh: Mesh, shift) -> Mesh:
    return Mesh(mesh.points + shift, mesh.cells, mesh.point_data, mesh.cell_data, mesh.cell_sets)


def stacked(lower: Mesh, upper: Mesh):
    a = extrude(lower, Translate([0, 0, 1], layers=2)).mesh
    b = moved(extrude(upper, Translate([0, 0, 2], layers=3)).mesh, [0, 0, 1])
    return a, b


class TestConformingMerge:
    def test_two_extrusions_sharing_a_face_count_its_points_once(self):
        a, b = stacked(grid(2, 2), grid(2, 2))
        r = merged([a, b])
        assert len(r.mesh.points) == len(a.points) + len(b.points) - 9
        assert r.merged_points == 9
        # mesh 0's top and mesh 1's bottom (4 quads each) are interior now: dropped
        assert r.dropped_facets == 8
        assert set_size(r.mesh, "bottom") == set_size(r.mesh, "top") == 4
        assert set_size(r.mesh, "side") == 8 * 2 + 8 * 3
        assert total_volume(r.mesh) == pytest.approx(3.0)
        assert r.mesh.cell_data["mesh"][0].tolist() == [0] * 8 + [1] * 12
        assert_valid_solid(r.mesh)

    def test_three_parts_side_by_side(self):
        # Figure 8.5 (right): a domain in three parts, each translated, then merged
        parts = [
            moved(
                extrude(grid(2, 1, x, x + 1, 0, 1), Translate([0, 0, 1], layers=2)).mesh, [0, 0, 0]
            )
            for x in (0.0, 1.0, 2.0)
        ]
        r = merged(parts)
        whole = extrude(grid(6, 1, 0, 3, 0, 1), Translate([0, 0, 1], layers=2)).mesh
        assert len(r.mesh.points) == len(whole.points)
        assert topology.conformity(solid(r.mesh)) == topology.conformity(solid(whole))
        assert total_volume(r.mesh) == pytest.approx(3.0)

    def test_coincidence_within_the_tolerance(self):
        a, b = stacked(grid(2, 2), grid(2, 2))
        b = moved(b, [0, 0, 1e-7])
        # 1e-7 apart: two separate parts by default (1e-9 times the diameter), one with 1e-6
        assert merged([a, b]).merged_points == 0
        r = merged([a, b], tolerance=1e-6)
        assert r.merged_points == 9 and r.dropped_facets == 8

    @settings(max_examples=15, deadline=None)
    @given(cut=st.integers(1, 4), ny=st.integers(1, 3), layers=st.integers(1, 3))
    def test_any_cut_of_a_grid_merges_back_to_the_whole(self, cut, ny, layers):
        path = Translate([0, 0, 1], layers=layers)
        left = extrude(grid(cut, ny, 0, cut / 5, 0, 1, tri=True), path).mesh
        right = extrude(grid(5 - cut, ny, cut / 5, 1, 0, 1, tri=True), path).mesh
        whole = extrude(grid(5, ny, 0, 1, 0, 1, tri=True), path).mesh
        r = merged([left, right])
        assert len(r.mesh.points) == len(whole.points)
        assert topology.conformity(solid(r.mesh))["nonmanifold"] == 0
        assert total_volume(r.mesh) == pytest.approx(1.0)
        assert set_size(r.mesh, "side") == set_size(whole, "side")
        assert_valid_solid(r.mesh)


class TestNonConforming:
    def test_a_hanging_node_fails_with_its_location(self):
        a, b = stacked(grid(2, 2), grid(4, 2))  # the upper part is finer along x
        with pytest.raises(InputError) as err:
            merged([a, b])
        assert err.value.code == "nonconforming_interface"
        assert "hanging node" in err.value.message
        loc = err.value.errors[0]["loc"]
        assert loc[0] == "meshes" and loc[2] == "points"
        mesh_id, point = loc[1], loc[3]
        p = [a, b][mesh_id].points[point]
        assert p[2] == pytest.approx(1.0)  # on the interface
        assert f"({p[0]:.6g}, {p[1]:.6g}, 1)" in err.value.message

    def test_faces_split_by_different_diagonals_fail(self):
        one = Mesh([[0, 0], [1, 0], [1, 1], [0, 1]], [("triangle", [[0, 1, 2], [0, 2, 3]])])
        other = Mesh([[0, 0], [1, 0], [1, 1], [0, 1]], [("triangle", [[0, 1, 3], [1, 2, 3]])])
        a, b = stacked(one, other)
        with pytest.raises(InputError) as err:
            merged([a, b])
        assert err.value.code == "nonconforming_interface"
        assert err.value.errors[0]["loc"][:3] == ["meshes", 1, "cells"]

    def test_a_hanging_node_in_the_plane(self):
        left = grid(1, 1)
        right = moved(grid(1, 2), [1, 0])
        with pytest.raises(InputError) as err:
            merged([left, right])
        assert err.value.errors[0]["loc"] == ["meshes", 1, "points", 2]
        assert "(1, 0.5)" in err.value.message

    def test_overlapping_inputs_fail(self):
        a, _ = stacked(grid(2, 2), grid(2, 2))
        with pytest.raises(InputError) as err:
            merged([a, a])
        assert err.value.code == "duplicate_cells"

    def test_bad_input_is_located(self):
        bad = Mesh([[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 5]])])
        with pytest.raises(InputError) as err:
            merged([grid(1, 1), bad])
        assert err.value.errors[0]["loc"][:2] == ["meshes", 1]
