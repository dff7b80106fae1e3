"""The fast writers read back by meshio and by Gmsh itself: points, cells, cell sets, data.

Meshes as in ``test_io.py`` (a 2D mesh of a quad, three triangles and two
lines; a 3D mesh of a hexahedron, a pyramid, a wedge and a tetrahedron).
"""

from __future__ import annotations

import io as bytesio
import xml.etree.ElementTree as ET
import zipfile

import gmsh
import numpy as np
import pytest

from meshcore.mesh import CellBlock, Mesh, io, writers
from tests.meshcore.mesh.test_io import canonical, canonical_sets, mesh_2d, mesh_3d


def _with_data(mesh: Mesh) -> Mesh:
    n = len(mesh.points)
    return Mesh(
        mesh.points,
        mesh.cells,
        point_data={
            "h": np.arange(n, dtype=float),
            "v": np.arange(3 * n, dtype=float).reshape(n, 3),
        },
        cell_data={
            "q": [np.arange(len(b), dtype=float) + 10 * i for i, b in enumerate(mesh.cells)]
        },
        cell_sets=mesh.cell_sets,
    )


def _gmsh_read(data: bytes, tmp_path) -> dict:
    """What Gmsh reads: node count, element count by type name, elements per physical name."""
    path = tmp_path / "mesh.msh"
    path.write_bytes(data)
    gmsh.initialize(["-nt", "1"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tags, _, _ = gmsh.model.mesh.getNodes()
        counts: dict[str, int] = {}
        types, elements, _ = gmsh.model.mesh.getElements()
        for t, e in zip(types, elements, strict=True):
            name = gmsh.model.mesh.getElementProperties(t)[0].split(" ")[0]
            counts[name] = counts.get(name, 0) + len(e)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, tag)
            total = 0
            for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                _, els, _ = gmsh.model.mesh.getElements(dim, entity)
                total += sum(len(e) for e in els)
            groups[name] = groups.get(name, 0) + total
        return {"nodes": len(tags), "elements": counts, "groups": groups}
    finally:
        gmsh.finalize()


GMSH_NAMES = {
    "line": "Line",
    "triangle": "Triangle",
    "quad": "Quadrilateral",
    "tetra": "Tetrahedron",
    "pyramid": "Pyramid",
    "wedge": "Prism",
    "hexahedron": "Hexahedron",
}


@pytest.mark.parametrize("fmt", ["gmsh", "gmsh22"])
@pytest.mark.parametrize("make", [mesh_2d, mesh_3d], ids=["2d", "3d"])
def test_gmsh_reads_what_we_write(fmt: str, make, tmp_path) -> None:
    mesh = make()
    got = _gmsh_read(io.to_bytes(mesh, fmt), tmp_path)
    used = len(np.unique(np.concatenate([b.data.ravel() for b in mesh.cells])))
    # MSH 4.1 keeps a node no cell holds on a point entity of its own; Gmsh drops it from 2.2
    assert got["nodes"] == (len(mesh.points) if fmt == "gmsh" else used)
    assert got["elements"] == {GMSH_NAMES[b.type]: len(b) for b in mesh.cells}
    # cells in no set carry the unnamed physical tag 0 in MSH 4.1 (meshio's reader wants a
    # physical tag on every entity once one has one); Gmsh lists it as a group named ""
    groups = {k: v for k, v in got["groups"].items() if k}
    assert groups == {k: sum(len(a) for a in v) for k, v in mesh.cell_sets.items()}


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
@pytest.mark.parametrize("make", [mesh_2d, mesh_3d], ids=["2d", "3d"])
def test_point_and_cell_data_round_trip(fmt: str, make) -> None:
    mesh = _with_data(make())
    back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
    assert canonical(back) == canonical(mesh)
    np.testing.assert_array_equal(back.point_data["h"], mesh.point_data["h"])
    np.testing.assert_array_equal(back.point_data["v"], mesh.point_data["v"])
    assert [a.tolist() for a in back.cell_data["q"]] == [a.tolist() for a in mesh.cell_data["q"]]


@pytest.mark.parametrize("fmt", ["gmsh", "gmsh22"])
def test_gmsh_point_data_round_trips(fmt: str) -> None:
    mesh = _with_data(mesh_2d())
    back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
    assert canonical_sets(back) == canonical_sets(mesh)
    order = np.lexsort(back.points.T[::-1])
    expect = np.lexsort(mesh.points.T[::-1])
    np.testing.assert_array_equal(back.point_data["h"][order], mesh.point_data["h"][expect])


def test_ply_keeps_scalar_point_data() -> None:
    tri = Mesh(np.array([[0, 0], [1, 0], [0, 1.0]]), (CellBlock("triangle", [[0, 1, 2]]),))
    mesh = Mesh(tri.points, tri.cells, point_data={"h": np.array([1.0, 2.0, 3.5])})
    back = io.from_bytes(io.to_bytes(mesh, "ply"), "ply")
    assert back.point_data["h"].tolist() == [1.0, 2.0, 3.5]


@pytest.mark.parametrize("make", [mesh_2d, mesh_3d], ids=["2d", "3d"])
def test_vtu_zlib_reads_back_as_raw(make) -> None:
    mesh = _with_data(make())
    buf = bytesio.BytesIO()
    writers.write_vtu(mesh, buf, compression="zlib")
    back = io.from_bytes(buf.getvalue(), "vtu")
    raw = io.from_bytes(io.to_bytes(mesh, "vtu"), "vtu")
    assert canonical(back) == canonical(raw) == canonical(mesh)
    np.testing.assert_array_equal(back.point_data["v"], mesh.point_data["v"])


def test_xdmf_of_one_block_is_a_typed_grid_named_mesh() -> None:
    """What dolfinx's ``XDMFFile.read_mesh(name="mesh")`` expects: one topology type."""
    mesh = Mesh(
        np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]),
        (CellBlock("triangle", [[0, 1, 2], [0, 2, 3]]),),
    )
    with zipfile.ZipFile(bytesio.BytesIO(io.to_bytes(mesh, "xdmf"))) as z:
        assert sorted(z.namelist()) == ["mesh.h5", "mesh.xdmf"]
        root = ET.fromstring(z.read("mesh.xdmf"))
    grid = root.find("Domain/Grid")
    assert grid.get("Name") == "mesh"
    assert grid.find("Topology").get("TopologyType") == "Triangle"
    assert grid.find("Geometry").get("GeometryType") == "XY"
    assert grid.find("Topology/DataItem").text == "mesh.h5:/cells"


def test_text_formats_keep_every_digit() -> None:
    points = np.array([[0.1, 1 / 3], [1e-300, 2.0], [np.pi, -1e17]])
    mesh = Mesh(points, (CellBlock("triangle", [[0, 1, 2]]),))
    for fmt in ("obj", "abaqus"):
        back = io.from_bytes(io.to_bytes(mesh, fmt), fmt)
        np.testing.assert_array_equal(back.points[:, :2], points)


def test_large_indices_are_written_whole() -> None:
    """The compiled integer formatting: ids of many digits, rows of any width."""
    n = 1_234_567
    points = np.zeros((n, 2))
    points[-3:] = [[0, 0], [1, 0], [0, 1]]
    mesh = Mesh(points, (CellBlock("triangle", [[n - 3, n - 2, n - 1], [0, 9, 10]]),))
    text = io.to_bytes(mesh, "obj").decode()
    assert text.endswith(f"f {n - 2} {n - 1} {n}\nf 1 10 11\n")
