"""POST /v1/convert (a mesh file in, the JSON mesh out), the glb download, and the page's files."""

from __future__ import annotations

import json
import struct

import meshio
import numpy as np
import pytest

from meshcore.mesh import CellBlock, Mesh, io

TWO_QUADS = Mesh(
    np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]], dtype=float),
    (CellBlock("quad", [[0, 1, 4, 3], [1, 2, 5, 4]]),),
).check()


def convert(client, data: bytes, filename: str):
    return client.post("/v1/convert", params={"filename": filename}, content=data)


class TestConvert:
    def test_unknown_suffix_is_415(self, client):
        r = convert(client, b"solid x", "mesh.xyz")
        assert r.status_code == 415
        assert r.headers["content-type"] == "application/problem+json"
        assert ".vtu" in r.json()["detail"]

    @pytest.mark.parametrize(
        ("data", "name", "code"),
        [(b"garbage", "mesh.msh", "unreadable-file"), (b"v 0 0 0\n", "mesh.obj", "no-cells")],
    )
    def test_unreadable_file_is_422(self, client, data, name, code):
        r = convert(client, data, name)
        assert r.status_code == 422
        assert r.headers["content-type"] == "application/problem+json"
        assert r.json()["type"] == f"/problems/{code}"

    def test_missing_filename_is_422(self, client):
        r = client.post("/v1/convert", content=b"x")
        assert r.status_code == 422
        assert r.json()["errors"][0]["loc"] == ["query", "filename"]

    def test_too_many_points_is_413(self, start_server):
        server = start_server(MESHSERVICE_MAX_POINTS="5")
        with server.client() as c:
            r = convert(c, io.to_bytes(TWO_QUADS, "vtu"), "two.vtu")  # 6 points
        assert r.status_code == 413
        assert "MESHSERVICE_MAX_POINTS" in r.json()["detail"]

    @pytest.mark.parametrize("fmt", ["vtu", "gmsh", "abaqus", "ply", "obj"])
    def test_file_becomes_the_json_mesh(self, client, fmt):
        r = convert(client, io.to_bytes(TWO_QUADS, fmt), "two" + io.FORMATS[fmt].suffix)
        assert r.status_code == 200, r.text
        mesh = r.json()
        assert len(mesh["points"]) == 6
        assert [(c["type"], len(c["data"])) for c in mesh["cells"]] == [("quad", 2)]
        # and it is a method's mesh param as it stands
        job = client.post(
            "/v1/jobs", params={"wait": 10}, json={"method": "quality", "params": {"mesh": mesh}}
        ).json()
        assert job["status"] == "succeeded"

    def test_a_3d_file_keeps_z(self, client, tmp_path):
        m = meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))])
        m.write(tmp_path / "t.vtk")
        r = convert(client, (tmp_path / "t.vtk").read_bytes(), "t.vtk")
        assert r.status_code == 200
        assert r.json()["points"][1] == [0.0, 1.0, 0.0]


class TestGlbDownload:
    def test_glb_carries_quality_and_the_report(self, client):
        mesh = io.to_json(TWO_QUADS)
        job = client.post(
            "/v1/jobs", params={"wait": 10}, json={"method": "echo_mesh", "params": {"mesh": mesh}}
        ).json()
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": "glb"})
        assert r.status_code == 200
        assert r.headers["content-type"] == "model/gltf-binary"
        assert r.headers["content-disposition"].endswith('.glb"')
        magic, version, length, json_len = struct.unpack_from("<IIII", r.content)
        assert (magic, version, length) == (0x46546C67, 2, len(r.content))
        gltf = json.loads(r.content[20 : 20 + json_len])
        assert gltf["extras"] == {"stats": {"points": 6}}
        cells = gltf["meshes"][0]["primitives"][0]
        assert cells["extras"]["layer"] == "cells"
        assert gltf["accessors"][cells["attributes"]["_QUALITY"]]["count"] == 2 * 2 * 3


class TestPage:
    def test_index_and_static_files(self, client):
        r = client.get("/")
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
        assert 'src="static/app.js"' in r.text
        for name in ["app.js", "api.js", "editor.js", "form.js", "viewer.js", "style.css"]:
            assert client.get(f"/static/{name}").status_code == 200, name
        assert client.get("/static/nope.js").status_code == 404

    def test_page_is_not_in_the_api_schema(self, client):
        paths = client.get("/openapi.json").json()["paths"]
        assert "/" not in paths and not any(p.startswith("/static") for p in paths)
        assert "/v1/convert" in paths
