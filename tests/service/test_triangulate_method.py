"""The ``triangulate`` method through the API of a live server.

Failure cases first: each bad parameter is a 422 problem naming the field
(before the job is queued), then meshes that come back, are valid, and
download as VTU.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from meshcore.geometry.predicates import orient2d
from meshcore.mesh import io
from service.methods.triangulation import TRIANGULATE_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}


def finished(c, params: dict) -> dict:
    r = submit(c, "triangulate", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return job


class TestTriangulate:
    @pytest.mark.parametrize(
        "extra, loc",
        [
            ({"min_angle": 0}, ["min_angle"]),
            ({"min_angle": 35}, ["min_angle"]),
            ({"max_area": 0}, ["max_area"]),
            ({"size": -0.1}, ["size"]),
            ({"size_field": {"points": [[0, 0]], "values": [0.1, 0.2]}}, ["size_field"]),
            ({"size_field": {"points": [[0, 0]], "values": [0]}}, ["size_field", "values", 0]),
            (
                {"size_field": {"points": [[0, 0], [0, 0]], "values": [1, 1]}},
                ["size_field", "points", 1],
            ),
            ({"empty": True, "size": 0.1}, ["size"]),
            ({"size": 1e-5}, ["size"]),  # ten billion triangles: refused up front
            ({"max_area": 1e-12}, ["max_area"]),
            # the size that binds is named, whichever others are given
            ({"size": 0.1, "max_area": 1e-12}, ["max_area"]),
            (
                {"size": 0.5, "size_field": {"points": [[0.5, 0.5]], "values": [1e-5]}},
                ["size_field"],
            ),
            ({"curves": [{"ring": 2, "center": [0.5, 0.5], "radius": 0.2}]}, ["curves", 0, "ring"]),
            (
                {"curves": [{"ring": 0, "center": [0.5, 0.5], "radius": 0.2}]},
                ["curves", 0, "radius"],
            ),
            ({"unknown": 1}, ["unknown"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, extra, loc):
        r = submit(client, "triangulate", {"domain": SQUARE, **extra})
        assert_problem(r, 422, ["body", "params", *loc])

    def test_runaway_size_names_the_numbers(self, client):
        r = submit(client, "triangulate", {"domain": SQUARE, "size": 1e-4})
        doc = assert_problem(r, 422, ["body", "params", "size"])
        # 2 * (area / (0.866 h**2) + 0.25 perimeter**2 / area) triangles, the service's cap,
        # the domain's area
        assert "230,940,11" in doc["detail"] and "20,000,000" in doc["detail"]
        assert "area 1" in doc["detail"]

    @pytest.mark.parametrize(
        "geometry, loc",
        [
            (
                {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1]]]},
                ["domain", "coordinates", 0],
            ),
            ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0]]]}, ["domain", "coordinates", 0]),
        ],
    )
    def test_bad_domains_are_422_with_the_location(self, client, geometry, loc):
        r = submit(client, "triangulate", {"domain": geometry})
        assert_problem(r, 422, ["body", "params", *loc])

    def test_nan_is_422_naming_the_coordinate(self, client):
        body = json.dumps({"method": "triangulate", "params": {"domain": SQUARE}}).replace(
            "[1, 1]", "[1, NaN]"
        )
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422, ["body", "params", "domain", "coordinates", 0, 2, 1])

    def test_example_mesh_result_and_vtu_download(self, client):
        job = finished(client, TRIANGULATE_EXAMPLE)
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert set(res) >= {"mesh", "quality", "stats"}
        mesh = io.from_json(res["mesh"])
        P, T = mesh.points, mesh.cells[0].data
        assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) == 1).all()
        q = res["quality"]["triangle"]
        assert q["count"] == len(T) and q["invalid"] == 0 and q["angle"]["min"] >= 30
        assert res["quality"]["conformity"] == {"nonmanifold": 0, "boundary_edges": 0}
        stats = res["stats"]
        assert stats["triangles"] == len(T) and stats["points"] == len(P)
        assert stats["boundary_points_added"] > 0 and stats["interior_points_added"] > 0
        assert stats["points"] == (
            stats["input_points"] + stats["boundary_points_added"] + stats["interior_points_added"]
        )
        # the hole's new points are on its circle (curves)
        r_hole = np.hypot(P[:, 0] - 0.5, P[:, 1] - 0.5)
        assert (r_hole >= 0.25 - 1e-9).all()
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": "vtu"})
        assert r.status_code == 200, r.text
        back = io.from_bytes(r.content, "vtu")
        assert len(back.cells[0].data) == len(T)
        assert np.allclose(back.points[:, :2], P)

    def test_keep_boundary_and_constraints(self, client):
        params = {
            "domain": SQUARE,
            "segments": [[[0.2, 0.5], [0.8, 0.5]]],
            "min_angle": 25,
            "size": 0.1,
            "keep_boundary": True,
        }
        job = finished(client, params)
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert res["stats"]["boundary_points_added"] == 0
        mesh = io.from_json(res["mesh"])
        edges = {
            tuple(sorted(e))
            for t in mesh.cells[0].data.tolist()
            for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))
        }
        assert (4, 5) in edges  # the constraint, whole

    def test_empty(self, client):
        job = finished(client, {"domain": SQUARE, "empty": True})
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert res["stats"]["triangles"] == 2 and res["stats"]["points"] == 4

    def test_listed_with_its_schema(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        m = methods["triangulate"]
        assert "§9.1" in m["section"]
        props = m["params_schema"]["properties"]
        assert {
            "domain",
            "segments",
            "curves",
            "empty",
            "min_angle",
            "max_area",
            "size",
            "size_field",
            "keep_boundary",
        } <= set(props)
