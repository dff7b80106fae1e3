"""The glb writer (glTF 2.0 binary) and reading uploaded files (io.from_file).

The glb is read back here with ``struct`` and numpy, as a web viewer reads it:
a 12-byte header, a JSON chunk, a BIN chunk; accessors over buffer views.
"""

from __future__ import annotations

import json
import struct

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.mesh import CellBlock, Mesh, io
from meshcore.mesh.quality import reported_quality
from tests.meshcore.mesh.test_io import mesh_2d, mesh_3d

COMPONENTS = {"SCALAR": 1, "VEC3": 3}
DTYPES = {5126: np.float32, 5125: np.uint32}


def read_glb(data: bytes) -> tuple[dict, dict]:
    """(glTF JSON, {layer: {attribute or "indices": array}}) of a glb."""
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(data))
    json_len, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A and json_len % 4 == 0
    gltf = json.loads(data[20 : 20 + json_len])
    bin_len, bin_type = struct.unpack_from("<II", data, 20 + json_len)
    assert bin_type == 0x004E4942 and bin_len == gltf["buffers"][0]["byteLength"]
    body = data[28 + json_len :]
    assert len(body) == bin_len

    def accessor(i: int) -> np.ndarray:
        a = gltf["accessors"][i]
        view = gltf["bufferViews"][a["bufferView"]]
        assert view["byteOffset"] % 4 == 0
        n = a["count"] * COMPONENTS[a["type"]]
        arr = np.frombuffer(body, DTYPES[a["componentType"]], n, view["byteOffset"])
        return arr.reshape(a["count"], -1) if a["type"] == "VEC3" else arr

    layers = {}
    for p in gltf["meshes"][0]["primitives"]:
        arrays = {name: accessor(i) for name, i in p["attributes"].items()}
        if "indices" in p:
            arrays["indices"] = accessor(p["indices"])
        layers[p["extras"]["layer"]] = arrays
        pos = gltf["accessors"][p["attributes"]["POSITION"]]
        np.testing.assert_allclose(pos["min"], arrays["POSITION"].min(axis=0))
        np.testing.assert_allclose(pos["max"], arrays["POSITION"].max(axis=0))
    return gltf, layers


def world(gltf: dict, local: np.ndarray) -> np.ndarray:
    return local.astype(np.float64) + np.asarray(gltf["nodes"][0]["translation"])


def test_2d_mesh_triangles_quads_edges_and_lines() -> None:
    mesh = mesh_2d()  # 1 quad, 3 triangles, 2 lines
    gltf, layers = read_glb(io.to_bytes(mesh, "glb"))
    cells = layers["cells"]
    assert cells["POSITION"].shape == (3 * (2 + 3), 3)  # the quad as 2 triangles
    tri = world(gltf, cells["POSITION"]).reshape(-1, 3, 3)
    area = 0.5 * np.abs(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2])
    assert area.sum() == pytest.approx(1 + 1 + 0.5)  # quad 1, triangles 0.5 + 0.5 + 0.5
    assert np.all(tri[:, :, 2] == 0)
    q_quad = reported_quality(mesh.points, mesh.cells[0].data, "quad")
    q_tri = reported_quality(mesh.points, mesh.cells[1].data, "triangle")
    expected = np.concatenate([np.repeat(q_quad, 6), np.repeat(q_tri, 3)])
    np.testing.assert_allclose(cells["_QUALITY"], expected, rtol=1e-6)
    assert [t for t, _ in gltf["meshes"][0]["primitives"][0]["extras"]["cell_types"]] == [
        "quad",
        "triangle",
    ]
    # the edges: 4 of the quad + 3 * 3 of the triangles, less the 3 shared (1-4, 1-5, 4-5)
    edges = layers["edges"]["indices"].reshape(-1, 2)
    assert len(edges) == 4 + 9 - 3
    ends = world(gltf, cells["POSITION"])[edges]
    lengths = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    assert not np.any(np.isclose(lengths, np.sqrt(2)) & np.isclose(ends[:, 0, 0], 0))  # no diagonal
    lines = layers["lines"]
    np.testing.assert_allclose(world(gltf, lines["POSITION"])[:, :2], mesh.points, atol=1e-6)
    assert lines["indices"].tolist() == [0, 1, 1, 2]


def test_3d_mesh_draws_its_boundary_with_the_cells_quality() -> None:
    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    points = np.vstack([cube, cube + [0, 0, 1]])
    mesh = Mesh(points, (CellBlock("hexahedron", [list(range(8))]),)).check()
    _, layers = read_glb(io.to_bytes(mesh, "glb"))
    assert len(layers["cells"]["POSITION"]) == 6 * 2 * 3  # 6 quad faces, 2 triangles each
    np.testing.assert_allclose(layers["cells"]["_QUALITY"], 1.0)
    assert len(layers["edges"]["indices"]) == 2 * 12  # the cube's 12 edges
    gltf, layers = read_glb(io.to_bytes(mesh_3d(), "glb"))
    kinds = [t for t, _ in gltf["meshes"][0]["primitives"][0]["extras"]["cell_types"]]
    assert set(kinds) == {"hexahedron", "pyramid", "wedge", "tetra"}


@pytest.mark.parametrize(("shift", "scale"), [(1e6, 1.0), (0.0, 1e-6)])
def test_positions_keep_their_precision_when_moved_or_scaled(shift: float, scale: float) -> None:
    mesh = mesh_2d()
    moved = Mesh(mesh.points * scale + shift, mesh.cells).check()
    gltf, layers = read_glb(io.to_bytes(moved, "glb"))
    assert gltf["nodes"][0]["translation"][0] == pytest.approx(shift + scale)
    back = world(gltf, layers["lines"]["POSITION"])[:, :2]
    np.testing.assert_allclose(back, moved.points, rtol=0, atol=1e-6 * scale)
    _, plain = read_glb(io.to_bytes(mesh, "glb"))  # the same qualities
    np.testing.assert_allclose(layers["cells"]["_QUALITY"], plain["cells"]["_QUALITY"], atol=1e-6)


def test_reported_quality_is_what_the_report_summarizes() -> None:
    from meshcore.mesh.quality import report

    mesh = mesh_3d()
    rep = report(mesh)
    for block in mesh.cells:
        q = reported_quality(mesh.points, block.data, block.type)
        assert np.all((q >= 0) & (q <= 1))
        assert q.min() == pytest.approx(rep[block.type]["quality"]["min"])
        assert q.mean() == pytest.approx(rep[block.type]["quality"]["mean"])


def test_extras_and_radius() -> None:
    points = np.array([[0, 0], [1, 0], [2, 1]], dtype=float)
    mesh = Mesh(
        points, (CellBlock("line", [[0, 1], [1, 2]]),), point_data={"radius": [1, 2, 3]}
    ).check()
    gltf, layers = read_glb(io.to_glb(mesh, {"stats": {"nodes": 3}}))
    assert gltf["extras"] == {"stats": {"nodes": 3}}
    assert layers["lines"]["_RADIUS"].tolist() == [1, 2, 3]
    assert "cells" not in layers


# ----------------------------------------------------------------------------- from_file


@pytest.mark.parametrize("fmt", ["vtu", "gmsh22", "abaqus", "ply"])
def test_from_file_reads_what_to_bytes_writes(fmt: str) -> None:
    mesh = mesh_2d()
    if fmt == "ply":
        mesh = Mesh(mesh.points, mesh.cells[:2]).check()
    back = io.from_file(io.to_bytes(mesh, fmt), "upload" + io.FORMATS[fmt].suffix)
    counts = {b.type: len(b) for b in back.cells}
    assert counts == {b.type: len(b) for b in mesh.cells}


def test_from_file_picks_the_reader_by_suffix(tmp_path) -> None:
    m = meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))])
    m.write(tmp_path / "t.vtk")
    back = io.from_file((tmp_path / "t.vtk").read_bytes(), "My Mesh.VTK")
    assert back.cells[0].type == "tetra" and back.points.shape == (4, 3)


@pytest.mark.parametrize(
    ("data", "name", "code"),
    [
        (b"anything", "mesh.xyz", "unsupported_format"),
        (b"anything", "no-suffix", "unsupported_format"),
        (b"", "mesh.node", "unsupported_format"),  # TetGen: two files
        (b"garbage", "mesh.msh", "unreadable_file"),
        (b"<VTKFile", "mesh.vtu", "unreadable_file"),
        (b"", "mesh.stl", "unreadable_file"),
        (b"v 0 0 0\n", "mesh.obj", "no_cells"),
    ],
)
def test_from_file_refuses_with_a_code(data: bytes, name: str, code: str) -> None:
    with pytest.raises(InputError) as err:
        io.from_file(data, name)
    assert err.value.code == code


@settings(max_examples=60, deadline=None)
@given(
    data=st.one_of(
        st.binary(max_size=300),
        st.text(alphabet="0123456789 .-\nvfxyz$<>/=", max_size=300).map(str.encode),
    ),
    suffix=st.sampled_from(sorted(io.UPLOAD_SUFFIXES)),
)
def test_from_file_raises_only_input_errors(data: bytes, suffix: str) -> None:
    try:
        mesh = io.from_file(data, "upload" + suffix)
    except InputError as exc:
        assert exc.code
    else:
        assert mesh.check() is mesh


@settings(max_examples=30, deadline=None)
@given(
    nx=st.integers(1, 6),
    ny=st.integers(1, 6),
    seed=st.integers(0, 2**32 - 1),
    quads=st.booleans(),
)
def test_glb_of_a_jittered_grid_keeps_area_and_counts(nx, ny, seed, quads) -> None:
    """A grid of nx x ny cells, interior points jittered: the drawn area is the square's."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1))
    pts = np.column_stack([x.ravel(), y.ravel()])
    inner = (pts[:, 0] > 0) & (pts[:, 0] < 1) & (pts[:, 1] > 0) & (pts[:, 1] < 1)
    pts[inner] += rng.uniform(-0.2, 0.2, (inner.sum(), 2)) / max(nx, ny)
    i = (np.arange(ny)[:, None] * (nx + 1) + np.arange(nx)[None, :]).ravel()
    quad = np.stack([i, i + 1, i + nx + 2, i + nx + 1], -1)
    cells = quad if quads else np.concatenate([quad[:, [0, 1, 2]], quad[:, [0, 2, 3]]])
    mesh = Mesh(pts, (CellBlock("quad" if quads else "triangle", cells),)).check()
    gltf, layers = read_glb(io.to_bytes(mesh, "glb"))
    tri = world(gltf, layers["cells"]["POSITION"]).reshape(-1, 3, 3)
    area = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
    assert area.sum() == pytest.approx(1.0, rel=1e-6)
    assert len(tri) == 2 * nx * ny
    edges = nx * (ny + 1) + ny * (nx + 1) + (0 if quads else nx * ny)
    assert len(layers["edges"]["indices"]) == 2 * edges
