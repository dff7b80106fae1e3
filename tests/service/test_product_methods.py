"""The product methods (extrude, sweep, merge, radial) through the API of a live server.

One class per method, failure cases first.
"""

from __future__ import annotations

import json

import pytest

from meshcore.mesh import io, quality
from tests.service.test_jobs import assert_problem, submit
from tests.service.testing_methods import SQUARE

RECTANGLE = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1]]]}
SOLID_SQUARE = {"mesh": SQUARE, "path": {"type": "translate", "vector": [0, 0, 1], "layers": 10}}


def finished(c, method: str, params: dict) -> dict:
    r = submit(c, method, params, wait=20)
    assert r.status_code == 200, r.text
    return r.json()


def result(c, job: dict) -> dict:
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json()


class TestExtrude:
    @pytest.mark.parametrize(
        "path, loc",
        [
            ({"type": "translate", "vector": [0, 0, 0], "layers": 2}, ["translate", "vector"]),
            ({"type": "translate", "vector": [0, 0, 1], "layers": 0}, ["translate", "layers"]),
            ({"type": "translate", "vector": [0, 0, 1]}, ["translate"]),
            (
                {
                    "type": "rotate",
                    "axis_point": [0, 0, 0],
                    "axis_direction": [0, 0, 0],
                    "angle": 90,
                    "layers": 4,
                },
                ["rotate", "axis_direction"],
            ),
            (
                {
                    "type": "rotate",
                    "axis_point": [0, 0, 0],
                    "axis_direction": [0, 1, 0],
                    "angle": 0,
                    "layers": 4,
                },
                ["rotate", "angle"],
            ),
            (
                {"type": "transforms", "matrices": [[[1, 0, 0, 0]] * 4, [[1, 0, 0]] * 4]},
                ["transforms", "matrices", 1, 0],
            ),
            (
                {"type": "transforms", "matrices": [[[1, 0, 0, 0]] * 3] * 2},
                ["transforms", "matrices", 0],
            ),
            ({"type": "spiral", "layers": 3}, []),
        ],
    )
    def test_bad_paths_are_422_naming_the_field(self, client, path, loc):
        r = submit(client, "extrude", {"mesh": SQUARE, "path": path})
        assert_problem(r, 422, ["body", "params", "path", *loc])

    def test_nan_is_422_naming_the_component(self, client):
        body = json.dumps({"method": "extrude", "params": SOLID_SQUARE}).replace(
            "[0, 0, 1]", "[0, 0, NaN]"
        )
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422, ["body", "params", "path", "translate", "vector", 2])

    def test_sections_of_the_wrong_size_are_422_before_queueing(self, client):
        path = {"type": "sections", "points": [[[0, 0, 0]] * 3, [[0, 0, 1]] * 3]}
        r = submit(client, "extrude", {"mesh": SQUARE, "path": path})
        assert_problem(r, 422, ["body", "params", "path", "points", 0])

    def test_a_degenerate_cell_fails_the_job_naming_it(self, client):
        diamond = {
            "points": [[0, 0], [1, -1], [2, 0], [1, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3]]}],
        }
        path = {
            "type": "rotate",
            "axis_point": [0, 0, 0],
            "axis_direction": [0, 1, 0],
            "angle": 360,
            "layers": 8,
        }
        job = finished(client, "extrude", {"mesh": diamond, "path": path})
        assert job["status"] == "failed"
        assert job["error"]["status"] == 422
        assert job["error"]["errors"][0]["loc"] == ["params", "mesh", "cells", 0, "data", 0]
        again = finished(client, "extrude", {"mesh": diamond, "path": path, "simplices": True})
        assert result(client, again)["quality"]["tetra"]["invalid"] == 0

    def test_a_rotation_past_360_degrees_fails_with_the_cells(self, client):
        ring = {
            "points": [[1, 0], [2, 0], [2, 1], [1, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3]]}],
        }
        path = {
            "type": "rotate",
            "axis_point": [0, 0, 0],
            "axis_direction": [0, 1, 0],
            "angle": 400,
            "layers": 10,
        }
        job = finished(client, "extrude", {"mesh": ring, "path": path})
        assert job["status"] == "failed"
        assert job["error"]["type"] == "/problems/self-overlap"
        assert "cells 9 of block 0 (hexahedron)" in job["error"]["detail"]
        assert job["error"]["errors"][0]["loc"] == ["params", "path"]
        done = finished(client, "extrude", {"mesh": ring, "path": path, "validate": False})
        assert result(client, done)["stats"]["validated"] is False

    def test_extrusion_result_and_gmsh_download_with_physical_groups(self, client):
        job = finished(client, "extrude", SOLID_SQUARE)
        out = result(client, job)
        assert out["stats"]["points"] == 44
        assert out["stats"]["cells"] == {"wedge": 20, "triangle": 4, "quad": 40}
        assert out["quality"]["wedge"]["count"] == 20
        assert out["quality"]["wedge"]["invalid"] == 0
        assert set(out["mesh"]["cell_sets"]) == {"bottom", "top", "side"}
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": "gmsh"})
        assert r.status_code == 200
        mesh = io.from_bytes(r.content, "gmsh")
        sizes = {k: sum(len(a) for a in v) for k, v in mesh.cell_sets.items()}
        assert sizes == {"bottom": 2, "top": 2, "side": 40}
        assert sum(len(b) for b in mesh.cells if b.type == "wedge") == 20

    def test_a_domain_needs_a_size_and_excludes_a_mesh(self, client):
        path = SOLID_SQUARE["path"]
        assert_problem(
            submit(client, "extrude", {"domain": RECTANGLE, "path": path}), 422, ["body", "params"]
        )
        assert_problem(
            submit(
                client, "extrude", {"mesh": SQUARE, "domain": RECTANGLE, "size": 0.2, "path": path}
            ),
            422,
        )
        assert_problem(
            submit(client, "extrude", {"domain": RECTANGLE, "size": 1e-6, "path": path}),
            422,
            ["body", "params", "size"],
        )

    def test_a_domain_is_triangulated_then_extruded(self, client):
        """A 2 x 1 rectangle meshed at size 0.2, 3 layers of 0.5 / 3: wedges = 3 x triangles,
        volume = 2 x 0.5."""
        params = {
            "domain": RECTANGLE,
            "size": 0.2,
            "path": {"type": "translate", "vector": [0, 0, 0.5], "layers": 3},
        }
        out = result(client, finished(client, "extrude", params))
        mesh = io.from_json(out["mesh"])
        wedges = mesh.cells_by_type["wedge"]
        bottom = sum(len(a) for a in mesh.cell_sets["bottom"])
        assert len(wedges) == 3 * bottom
        volumes = quality.signed_volume(mesh.points, wedges, "wedge")
        assert (volumes > 0).all()
        assert volumes.sum() == pytest.approx(1.0, rel=1e-12)


class TestSweep:
    def test_a_target_of_the_wrong_length_is_422(self, client):
        params = {"source": SQUARE, "target": [[0, 0, 1]] * 3, "layers": 2}
        assert_problem(submit(client, "sweep", params), 422, ["body", "params", "target"])

    def test_layers_or_sides_are_required(self, client):
        r = submit(client, "sweep", {"source": SQUARE, "target": [[0, 0, 1]] * 4})
        assert_problem(r, 422, ["body", "params"])

    def test_sweep_between_two_squares(self, client):
        target = [[0, 0, 2], [0.5, 0, 2], [0.5, 0.5, 2], [0, 0.5, 2]]
        out = result(
            client, finished(client, "sweep", {"source": SQUARE, "target": target, "layers": 4})
        )
        assert out["stats"]["cells"]["wedge"] == 8
        assert out["stats"]["boundary_vertices"] == [0, 1, 2, 3]
        assert out["quality"]["wedge"]["invalid"] == 0


class TestMerge:
    def test_a_hanging_node_fails_with_its_location(self, client):
        coarse = {
            "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3]]}],
        }
        fine = {
            "points": [[1, 0], [2, 0], [2, 0.5], [1, 0.5], [2, 1], [1, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3], [3, 2, 4, 5]]}],
        }
        job = finished(client, "merge", {"meshes": [coarse, fine]})
        assert job["status"] == "failed"
        assert job["error"]["type"] == "/problems/nonconforming-interface"
        assert job["error"]["errors"][0]["loc"] == ["params", "meshes", 1, "points", 3]
        assert "(1, 0.5)" in job["error"]["detail"]

    def test_a_bad_mesh_in_the_list_is_422_at_its_index(self, client):
        bad = {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 7]]}],
        }
        r = submit(client, "merge", {"meshes": [SQUARE, bad]})
        assert_problem(r, 422, ["body", "params", "meshes", 1, "cells", 0, "data", 0])

    def test_two_squares_share_an_edge(self, client):
        right = {
            "points": [[1, 0], [2, 0], [2, 1], [1, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3]]}],
        }
        out = result(client, finished(client, "merge", {"meshes": [SQUARE, right]}))
        assert out["stats"]["points"] == 6
        assert out["quality"]["conformity"] == {"nonmanifold": 0, "boundary_edges": 6}


class TestRadial:
    def test_outer_radius_inside_inner_radius_is_422(self, client):
        params = {"inner_radius": 2, "outer_radius": 1, "radial_layers": 2, "segments": 8}
        assert_problem(submit(client, "radial", params), 422, ["body", "params", "outer_radius"])

    def test_balanced_disk_reports_quality_before_and_after(self, client):
        params = {"outer_radius": 1, "radial_layers": 8, "segments": 32, "balance": True}
        out = result(client, finished(client, "radial", params))
        before = out["stats"]["quality_before"]
        after = out["quality"]
        assert after["triangle"]["quality"]["min"] > before["triangle"]["quality"]["min"]
        assert out["stats"]["ring_segments"][:2] == [0, 6]


def test_the_methods_are_listed(client):
    listed = {m["name"]: m for m in client.get("/v1/methods").json()}
    for name in ("extrude", "sweep", "merge", "radial"):
        assert listed[name]["section"].startswith("§8")
        assert listed[name]["example"]
