"""The ``tetrahedralize`` method through the API of a live server.

Failure cases first: bad surfaces and parameters are 422 problems naming
the field (before the job is queued), never a 500; then a mesh that comes
back valid and downloads as Gmsh MSH and VTU.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import io
from service.methods.surface_schema import UNIT_CUBE
from service.methods.tets import TETRAHEDRALIZE_EXAMPLE
from tests.meshcore.domain.shapes import schonhardt
from tests.service.test_jobs import assert_problem, submit

CUBE = UNIT_CUBE


def finished(c, params: dict) -> dict:
    r = submit(c, "tetrahedralize", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return job


class TestTetrahedralize:
    def test_open_surface_is_422_naming_the_triangles(self, client):
        surface = {**CUBE, "triangles": CUBE["triangles"][1:]}
        doc = assert_problem(
            submit(client, "tetrahedralize", {"surface": surface}),
            422,
            ["body", "params", "surface", "triangles"],
        )
        assert "open edge" in doc["detail"] or "held by 1 triangle" in doc["detail"]

    def test_self_intersection_is_422_with_the_point(self, client):
        pts = [list(map(float, p)) for p in CUBE["points"]]
        pts[7] = [0.5, 0.5, -0.5]  # the corner (1, 1, 1) pushed through the bottom
        doc = assert_problem(
            submit(client, "tetrahedralize", {"surface": {**CUBE, "points": pts}}),
            422,
            ["body", "params", "surface", "triangles"],
        )
        assert "intersect at (" in doc["detail"]

    def test_two_cubes_overlapping(self, client):
        pts = CUBE["points"] + [[x + 0.5, y + 0.5, z + 0.5] for x, y, z in CUBE["points"]]
        tris = CUBE["triangles"] + [[i + 8, j + 8, k + 8] for i, j, k in CUBE["triangles"]]
        doc = assert_problem(
            submit(client, "tetrahedralize", {"surface": {"points": pts, "triangles": tris}}),
            422,
            ["body", "params", "surface", "triangles"],
        )
        assert any(e["type"] == "shell_intersection" for e in doc["errors"])

    def test_nan_is_422_naming_the_coordinate(self, client):
        body = json.dumps({"method": "tetrahedralize", "params": {"surface": CUBE}})
        body = body.replace("[1, 1, 1]", "[1, NaN, 1]")
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422, ["body", "params", "surface", "points", 7, 1])

    def test_two_points_is_422(self, client):
        surface = {"points": [[0, 0, 0], [1, 0, 0]], "triangles": [[0, 1, 1]] * 4}
        doc = assert_problem(
            submit(client, "tetrahedralize", {"surface": surface}),
            422,
            ["body", "params", "surface", "points"],
        )
        assert "at least 4 points" in doc["detail"]

    @pytest.mark.parametrize(
        "extra, loc",
        [
            ({"max_radius_edge": 1.0}, ["max_radius_edge"]),
            ({"min_dihedral": 90}, ["min_dihedral"]),
            ({"size": 0}, ["size"]),
            ({"max_volume": -1}, ["max_volume"]),
            ({"unknown": 1}, ["unknown"]),
            ({"size_field": {"points": [[0, 0, 0]], "values": [1, 2]}}, ["size_field"]),
            (
                {"surface": {**CUBE, "triangles": [[0, 2, 10**30], *CUBE["triangles"][1:]]}},
                ["surface", "triangles", 0, 2],
            ),
            (
                {"size_field": {"points": [[0, 0, 0], [0, 0, 0]], "values": [1, 1]}},
                ["size_field", "points", 1],
            ),
            ({"size": 0.005}, ["size"]),  # about 20M tetrahedra: refused before it runs
            ({"size": 1e-300}, ["size"]),
            ({"max_volume": 1e-9}, ["max_volume"]),
            ({"size": 0.5, "max_volume": 1e-9}, ["max_volume"]),
            ({"size_field": {"points": [[0.5, 0.5, 0.5]], "values": [1e-300]}}, ["size_field"]),
            (
                {
                    "size": 0.5,
                    "size_field": {"points": [[0, 0, 0], [1, 1, 1]], "values": [0.005] * 2},
                },
                ["size_field"],
            ),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, extra, loc):
        r = submit(client, "tetrahedralize", {"surface": CUBE, **extra})
        assert_problem(r, 422, ["body", "params", *loc])

    def test_example_mesh_result_and_downloads(self, client):
        job = finished(client, TETRAHEDRALIZE_EXAMPLE)
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert set(res) >= {"mesh", "quality", "stats"}
        mesh = io.from_json(res["mesh"])
        P, K = mesh.points, mesh.cells[0].data
        assert (orient3d(P[K[:, 0]], P[K[:, 1]], P[K[:, 2]], P[K[:, 3]]) < 0).all()
        a = P[K[:, 0]]
        vol = np.einsum("ij,ij->i", P[K[:, 1]] - a, np.cross(P[K[:, 2]] - a, P[K[:, 3]] - a)) / 6
        assert vol.sum() == pytest.approx(1.0, rel=1e-12)
        q = res["quality"]["tetra"]
        assert q["count"] == len(K) and q["invalid"] == 0
        assert 0 < q["dihedral"]["min"] < q["dihedral"]["max"] < 180
        stats = res["stats"]
        assert stats["tetrahedra"] == len(K) and stats["points"] == len(P)
        assert stats["points"] == (
            stats["input_points"] + stats["surface_points_added"] + stats["interior_points_added"]
        )
        assert stats["regions"] == {"region_0": len(K)}
        for fmt in ("gmsh", "gmsh22", "vtu"):
            r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": fmt})
            assert r.status_code == 200, r.text
            back = io.from_bytes(r.content, fmt)
            assert len(back.cells[0].data) == len(K)

    def test_size_field_grades_the_tetrahedra(self, client):
        field = {"points": [[0, 0, 0], [1, 1, 1]], "values": [0.15, 0.6]}
        job = finished(client, {"surface": CUBE, "size_field": field, "max_radius_edge": None})
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        mesh = io.from_json(res["mesh"])
        P, K = mesh.points, mesh.cells[0].data
        centre = P[K].mean(axis=1)
        lower = centre.sum(axis=1) < 1.5  # the half nearer the field's small value
        assert lower.sum() > 3 * (~lower).sum()
        assert res["stats"]["points"] > len(CUBE["points"])

    def test_keep_boundary_schonhardt(self, client):
        P, T = schonhardt()
        surface = {"points": P.tolist(), "triangles": T.tolist()}
        job = finished(client, {"surface": surface, "keep_boundary": True})
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert res["stats"]["interior_points_added"] == 1
        assert res["stats"]["surface_points_added"] == 0
        assert res["stats"]["tetrahedra"] == 8

    def test_listed_with_its_schema(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        m = methods["tetrahedralize"]
        assert "§9.3" in m["section"]
