"""The ``optimize`` method (Coupez, §8.3) through the API of a live server.

Failure cases first: bad parameters and bad meshes are 422 problems naming
the field or cells before the job is queued; a run that cannot reach a
valid mesh is a failed job whose problem says how many cells are inverted
and where; then a generated mesh and a corrected one, valid.
"""

from __future__ import annotations

import numpy as np
import pytest

from meshcore.geometry.predicates import orient2d
from meshcore.mesh import io, quality
from service.methods.optimize import OPTIMIZE_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

SQUARE_MESH = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}
SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
# the square with its centre dragged outside: two triangles inverted
TANGLED = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1], [1.5, 0.5]],
    "cells": [{"type": "triangle", "data": [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]}],
}


def finished(c, params: dict) -> dict:
    r = submit(c, "optimize", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json() | {"_id": job["id"]}


class TestOptimize:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"mesh": SQUARE_MESH, "quality": "jacobian"}, ["quality"]),
            ({"mesh": SQUARE_MESH, "max_sweeps": 0}, ["max_sweeps"]),
            ({"mesh": SQUARE_MESH, "domain": SQUARE}, []),
            ({}, []),
            ({"mesh": SQUARE_MESH, "size": 0.1}, []),
            ({"mesh": SQUARE_MESH, "keep_boundary": False}, []),
            ({"domain": SQUARE, "size": -1}, ["size"]),
            ({"domain": SQUARE, "size": 1e-5}, ["size"]),
            ({"mesh": SQUARE_MESH, "unknown": 1}, ["unknown"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, params, loc):
        assert_problem(submit(client, "optimize", params), 422, ["body", "params", *loc])

    def test_non_manifold_edge_is_named(self, client):
        mesh = {
            "points": [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, -1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3], [1, 0, 4], [0, 1, 3]]}],
        }
        doc = assert_problem(
            submit(client, "optimize", {"mesh": mesh}), 422, ["body", "params", "mesh", "cells"]
        )
        assert "Definition 8.1" in doc["detail"]

    def test_inconsistent_orientation_is_named(self, client):
        mesh = {**SQUARE_MESH, "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 3, 2]]}]}
        doc = assert_problem(
            submit(client, "optimize", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 0, "data", 1],
        )
        assert "oriented" in doc["detail"]

    def test_nan_is_named(self, client):
        body = '{"method": "optimize", "params": {"mesh": {"points": [[0, 0], [1, 0], [NaN, 1]],'
        body += ' "cells": [{"type": "triangle", "data": [[0, 1, 2]]}]}}}'
        r = client.post("/v1/jobs", content=body, headers={"Content-Type": "application/json"})
        assert_problem(r, 422, ["body", "params", "mesh", "points", 2])

    def test_no_valid_mesh_is_a_failed_job_saying_where(self, client):
        # a hexagon fan with a boundary vertex pulled across the opposite side: the boundary
        # crosses itself, so no positive triangulation of it exists
        a = np.pi / 3 * np.arange(6)
        P = np.vstack([[0.0, 0.0], np.column_stack([np.cos(a), np.sin(a)])])
        P[1] = [-2.0, 0.2]
        T = [[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)]
        crossed = {"points": P.tolist(), "cells": [{"type": "triangle", "data": T}]}
        r = submit(client, "optimize", {"mesh": crossed}, wait=30)
        job = r.json()
        assert job["status"] == "failed", job
        assert job["error"]["status"] == 422
        assert "still inverted" in job["error"]["detail"] and "cell " in job["error"]["detail"]

    def test_tangled_mesh_is_corrected(self, client):
        res = finished(client, {"mesh": TANGLED})
        mesh = io.from_json(res["mesh"])
        P, T = mesh.points, mesh.cells[0].data
        assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) > 0).all()
        assert quality.signed_area(P, T).sum() == pytest.approx(1.0, rel=1e-12)
        assert res["stats"]["inverted_before"] == 1 and res["stats"]["inverted_after"] == 0
        sur = np.array(res["stats"]["sur"])
        assert (sur[1:] <= sur[:-1] * (1 + 1e-12)).all() and sur[-1] == pytest.approx(1.0)

    def test_example_is_generated_valid_and_downloadable(self, client):
        res = finished(client, OPTIMIZE_EXAMPLE)
        mesh = io.from_json(res["mesh"])
        P, T = mesh.points, mesh.cells[0].data
        assert (orient2d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]) > 0).all()
        assert quality.signed_area(P, T).sum() == pytest.approx(3.0, rel=1e-12)
        assert res["quality"]["triangle"]["invalid"] == 0
        assert res["quality"]["conformity"]["nonmanifold"] == 0
        assert res["stats"]["use"] == "generation" and res["stats"]["points_inserted"] > 0
        r = client.get(f"/v1/jobs/{res['_id']}/result", params={"format": "vtu"})
        assert r.status_code == 200, r.text

    def test_listed_with_its_schema(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        m = methods["optimize"]
        assert "§8.3" in m["section"]
        props = m["params_schema"]["properties"]
        assert {"mesh", "domain", "insert_points", "size", "quality", "max_sweeps"} <= set(props)

    def test_open_surface_is_named(self, client):
        from service.methods.surface_schema import UNIT_CUBE

        surface = {**UNIT_CUBE, "triangles": UNIT_CUBE["triangles"][1:]}
        doc = assert_problem(
            submit(client, "optimize", {"surface": surface}),
            422,
            ["body", "params", "surface", "triangles"],
        )
        assert "open" in doc["detail"] or "edge" in doc["detail"]

    def test_two_shells_are_refused(self, client):
        from service.methods.surface_schema import UNIT_CUBE

        far = [[x + 5, y, z] for x, y, z in UNIT_CUBE["points"]]
        tris = UNIT_CUBE["triangles"] + [
            [i + 8, j + 8, k + 8] for i, j, k in UNIT_CUBE["triangles"]
        ]
        surface = {"points": UNIT_CUBE["points"] + far, "triangles": tris}
        assert_problem(
            submit(client, "optimize", {"surface": surface}),
            422,
            ["body", "params", "surface", "triangles"],
        )

    def test_cube_surface_gives_tetrahedra_of_its_volume(self, client):
        from meshcore.geometry.predicates3d import orient3d
        from service.methods.surface_schema import UNIT_CUBE

        res = finished(client, {"surface": UNIT_CUBE, "size": 10})
        mesh = io.from_json(res["mesh"])
        P, T = mesh.points, mesh.cells[0].data
        assert (orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], P[T[:, 3]]) < 0).all()
        assert quality.signed_volume(P, T).sum() == pytest.approx(1.0, rel=1e-12)
        assert res["stats"]["use"] == "generation"
