"""Round trips through every download format and the JSON mesh shape.

The 2D mesh used throughout (points numbered, q = quad, t = triangles)::

           6
          / \\
         / t \\
    3---4-----5
    | q | t  /|        lines: 0-1 and 1-2 (the bottom side)
    |   |  / t|
    0---1-----2

Cell sets: ``left`` = the quad, ``right`` = the three triangles. Variant with
sets across dimensions: the line 0-1 joins ``left`` and the line 1-2 joins
``right`` (kept apart, because a MSH 4.1 physical group has one dimension).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from meshcore.errors import InputError
from meshcore.mesh import CellBlock, Mesh, io

EMPTY = np.array([], dtype=np.int64)


def mesh_2d(cross_dimension_set: bool = False) -> Mesh:
    points = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [1.5, 2]], dtype=float)
    cells = (
        CellBlock("quad", [[0, 1, 4, 3]]),
        CellBlock("triangle", [[1, 2, 5], [1, 5, 4], [4, 5, 6]]),
        CellBlock("line", [[0, 1], [1, 2]]),
    )
    sets = {"left": [np.array([0]), EMPTY, EMPTY], "right": [EMPTY, np.array([0, 1, 2]), EMPTY]}
    if cross_dimension_set:
        sets = {"left": [[0], EMPTY, [0]], "right": [EMPTY, [0, 1, 2], [1]]}
    return Mesh(points, cells, cell_sets=sets).check()


def mesh_3d() -> Mesh:
    """A unit cube, a pyramid on its top, a wedge and a tetrahedron on its right side."""
    cube = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
    extra = [[0.5, 0.5, 1.7], [2, 0, 0], [2, 1, 0], [2, 0, 1], [2, 1, 1], [1.5, 0.5, -1]]
    cells = (
        CellBlock("hexahedron", [list(range(8))]),
        CellBlock("pyramid", [[4, 5, 6, 7, 8]]),
        CellBlock("wedge", [[1, 9, 2, 5, 11, 6]]),
        CellBlock("tetra", [[1, 2, 9, 13]]),
    )
    sets = {"box": [np.array([0]), EMPTY, EMPTY, EMPTY], "rest": [EMPTY, [0], [0], [0]]}
    return Mesh(np.array(cube + extra, dtype=float), cells, cell_sets=sets).check()


def canonical(mesh: Mesh) -> dict[str, list]:
    """Cells by type as sorted lists of their nodes' coordinates (node numbering forgotten)."""
    out: dict[str, list] = {}
    for block in mesh.cells:
        rows = [tuple(map(tuple, np.round(mesh.points[c], 12))) for c in block.data]
        out.setdefault(block.type, []).extend(rows)
    return {t: sorted(v) for t, v in out.items()}


def canonical_sets(mesh: Mesh) -> dict[str, list]:
    """Each cell set as a sorted list of its cells in coordinates (numbering forgotten)."""
    out = {}
    for name, ids in mesh.cell_sets.items():
        rows = []
        for block, a in zip(mesh.cells, ids, strict=True):
            rows += [(block.type, tuple(map(tuple, mesh.points[c]))) for c in block.data[a]]
        out[name] = sorted(rows)
    return out


def restricted(mesh: Mesh, fmt: str) -> Mesh:
    """The blocks of ``mesh`` that ``fmt`` can hold (Abaqus has no pyramid), with their sets."""
    types = io.FORMATS[fmt].cell_types
    keep = [i for i, b in enumerate(mesh.cells) if types is None or b.type in types]
    return Mesh(
        mesh.points,
        tuple(mesh.cells[i] for i in keep),
        cell_sets={k: [v[i] for i in keep] for k, v in mesh.cell_sets.items()},
    )


def fits(mesh: Mesh, fmt: str) -> bool:
    types = io.FORMATS[fmt].cell_types
    return types is None or {b.type for b in mesh.cells} <= types


@pytest.mark.parametrize("fmt", [f for f in io.FORMATS if f != "glb"])  # glb: test_glb.py
@pytest.mark.parametrize("make", [mesh_2d, mesh_3d], ids=["2d", "3d"])
def test_round_trip_keeps_points_and_cells(fmt: str, make) -> None:
    mesh = make()
    if not fits(mesh, fmt):
        with pytest.raises(InputError) as err:
            io.to_bytes(mesh, fmt)
        assert err.value.code == "format_mismatch"
        return
    back = io.from_bytes(io.to_bytes(mesh, fmt), fmt).check()
    assert back.points.shape == mesh.points.shape  # 2D stays 2D (z = 0 is cut)
    assert canonical(back) == canonical(mesh)
    if fmt != "gmsh":  # MSH 4.1 regroups cells by physical group; the others keep the numbering
        np.testing.assert_array_equal(back.points, mesh.points)
        assert [(b.type, b.data.tolist()) for b in back.cells] == [
            (b.type, b.data.tolist()) for b in mesh.cells
        ]


@pytest.mark.parametrize("fmt", ["gmsh", "gmsh22", "abaqus"])
@pytest.mark.parametrize("make", [mesh_2d, mesh_3d], ids=["2d", "3d"])
def test_round_trip_keeps_cell_sets(fmt: str, make) -> None:
    mesh = restricted(make(), fmt)
    back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
    assert canonical_sets(back) == canonical_sets(mesh)


@pytest.mark.parametrize("fmt", ["gmsh", "gmsh22", "abaqus"])
def test_cell_sets_across_dimensions(fmt: str) -> None:
    mesh = mesh_2d(cross_dimension_set=True)
    back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
    assert canonical_sets(back) == canonical_sets(mesh)


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_cell_sets_become_flag_arrays_elsewhere(fmt: str) -> None:
    back = io.from_bytes(io.to_bytes(mesh_2d(), fmt), fmt)
    assert [a.tolist() for a in back.cell_data["set:right"]] == [[0], [1, 1, 1], [0, 0]]


def test_triangle_only_mesh_fits_stl_obj_ply() -> None:
    mesh = Mesh(np.array([[0, 0], [1, 0], [0, 1]], float), (CellBlock("triangle", [[0, 1, 2]]),))
    for fmt in ("stl", "obj", "ply"):
        back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
        assert canonical(back) == canonical(mesh)


def test_unknown_format() -> None:
    with pytest.raises(InputError) as err:
        io.to_bytes(mesh_2d(), "dxf")
    assert err.value.code == "unknown_format"


class TestJson:
    def test_round_trip_through_json_text(self) -> None:
        mesh = Mesh(
            mesh_2d().points,
            mesh_2d().cells,
            point_data={"h": np.arange(7.0)},
            cell_data={"id": [np.array([7]), np.array([1, 2, 3]), np.array([4, 5])]},
            cell_sets=mesh_2d().cell_sets,
        )
        obj = json.loads(json.dumps(io.to_json(mesh)))
        back = io.from_json(obj)
        np.testing.assert_array_equal(back.points, mesh.points)
        assert [(b.type, b.data.tolist()) for b in back.cells] == [
            (b.type, b.data.tolist()) for b in mesh.cells
        ]
        assert back.point_data["h"].tolist() == list(range(7))
        assert [a.tolist() for a in back.cell_data["id"]] == [[7], [1, 2, 3], [4, 5]]
        assert {k: [a.tolist() for a in v] for k, v in back.cell_sets.items()} == {
            "left": [[0], [], []],
            "right": [[], [0, 1, 2], []],
        }
        assert io.to_json(back) == obj

    def test_index_out_of_range_names_block_cell_and_index(self) -> None:
        obj = io.to_json(mesh_2d())
        obj["cells"][1]["data"][2][1] = 7  # there are 7 points: 0..6
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.code == "index_out_of_range"
        assert err.value.errors[0]["loc"] == ["cells", 1, "data", 2, 1]

    def test_negative_index(self) -> None:
        obj = io.to_json(mesh_2d())
        obj["cells"][0]["data"][0][3] = -1
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.errors[0]["loc"] == ["cells", 0, "data", 0, 3]

    def test_nan_point(self) -> None:
        obj = io.to_json(mesh_2d())
        obj["points"][4][1] = math.nan
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.code == "non_finite"
        assert err.value.errors[0]["loc"] == ["points", 4, 1]

    @pytest.mark.parametrize(
        "obj",
        [
            {"points": [], "cells": []},
            {"points": [[0, 0], [1, 0], [0, 1]], "cells": []},
            {"points": [[0, 0], [1, 0], [0, 1]], "cells": [{"type": "triangle", "data": []}]},
        ],
        ids=["no points", "no cells", "empty block"],
    )
    def test_empty_mesh(self, obj: dict) -> None:
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.code == "empty_mesh"

    def test_unknown_cell_type(self) -> None:
        obj = {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "polygon", "data": [[0, 1, 2]]}],
        }
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.code == "unknown_cell_type"
        assert err.value.errors[0]["loc"] == ["cells", 0, "type"]

    def test_ragged_cells(self) -> None:
        obj = {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 1]]}],
        }
        with pytest.raises(InputError) as err:
            io.from_json(obj)
        assert err.value.errors[0]["loc"] == ["cells", 0, "data"]


@pytest.mark.parametrize("fmt", ["gmsh", "gmsh22", "xdmf"])
def test_data_a_format_cannot_store_is_an_input_error(fmt: str) -> None:
    """Gmsh stores 1, 3 or 9 components per point; five are refused, not crashed on."""
    five = [[1.0, 2.0, 3.0, 4.0, 5.0]] * 3
    mesh = io.from_json(
        {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 2]]}],
            "point_data": {"v": five},
        }
    )
    with pytest.raises(InputError) as err:
        io.to_bytes(mesh, fmt)
    assert err.value.code == "format_mismatch"
