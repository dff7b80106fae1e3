"""The ``quad_combine`` method through the API of a live server.

Failure cases first: each bad parameter or bad mesh is a 422 problem naming
the field, block, cell or point (before the job is queued); then results
that come back with only quads where asked, valid and downloadable.
"""

from __future__ import annotations

import numpy as np
import pytest

from meshcore.domain.planar import parse_domain
from meshcore.geometry.predicates import orient2d
from meshcore.mesh import io, quality
from service.methods.quads import QUAD_COMBINE_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

SQUARE_MESH = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}
SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
STRIP = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1e-6], [0, 1e-6], [0, 0]]]}


def finished(c, params: dict) -> dict:
    r = submit(c, "quad_combine", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json() | {"_id": job["id"]}


class TestQuadCombine:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"mesh": SQUARE_MESH, "algorithm": "blossom"}, ["algorithm"]),
            ({"mesh": SQUARE_MESH, "quality": "jacobian"}, ["quality"]),
            ({"mesh": SQUARE_MESH, "min_quality": 1.5}, ["min_quality"]),
            ({"mesh": SQUARE_MESH, "domain": SQUARE}, []),
            ({"mesh": SQUARE_MESH, "size": 0.1}, []),
            ({"domain": SQUARE, "size": 0.1, "twice_size": True}, []),
            ({"domain": SQUARE, "size": -1}, ["size"]),
            ({"domain": SQUARE, "size": 1e-5}, ["size"]),
            # about 2M triangles forced by a 1 x 1e-6 strip whatever the size
            ({"domain": STRIP, "size": 0.05, "all_quad": True}, ["domain"]),
            ({"mesh": SQUARE_MESH, "metric": [[1, 2], [2, 1]]}, ["metric"]),
            ({"mesh": SQUARE_MESH, "metric": [[[1, 0], [0, 1]]]}, ["metric"]),
            ({"domain": SQUARE, "metric": [[[1, 0], [0, 1]]] * 4}, ["metric"]),
            ({"mesh": SQUARE_MESH, "unknown": 1}, ["unknown"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, params, loc):
        r = submit(client, "quad_combine", params)
        assert_problem(r, 422, ["body", "params", *loc])

    def test_non_triangle_cells_are_named(self, client):
        mesh = {
            "points": SQUARE_MESH["points"],
            "cells": [
                {"type": "triangle", "data": [[0, 1, 2]]},
                {"type": "quad", "data": [[0, 1, 2, 3]]},
            ],
        }
        doc = assert_problem(
            submit(client, "quad_combine", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 1, "type"],
        )
        assert "quad" in doc["detail"]

    def test_index_out_of_range_is_named(self, client):
        mesh = {**SQUARE_MESH, "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 9]]}]}
        assert_problem(
            submit(client, "quad_combine", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 0, "data", 1, 2],
        )

    def test_inverted_triangles_are_named(self, client):
        mesh = {**SQUARE_MESH, "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 3, 2]]}]}
        doc = assert_problem(
            submit(client, "quad_combine", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 0, "data", 1],
        )
        assert "inverted" in doc["detail"]

    def test_square_is_one_quad(self, client):
        res = finished(client, {"mesh": SQUARE_MESH, "algorithm": "heap"})
        mesh = io.from_json(res["mesh"])
        assert [b.type for b in mesh.cells] == ["quad"] and len(mesh.cells[0].data) == 1
        assert res["quality"]["quad"]["quality"]["min"] == pytest.approx(1.0)
        assert res["stats"]["triangles_left"] == 0 and res["stats"]["pairs"] == 1

    def test_example_only_quads_valid_and_vtu(self, client):
        res = finished(client, QUAD_COMBINE_EXAMPLE)
        mesh = io.from_json(res["mesh"])
        assert [b.type for b in mesh.cells] == ["quad"]
        P, Q = mesh.points, mesh.cells[0].data
        for j in range(4):
            assert (orient2d(P[Q[:, j - 1]], P[Q[:, j]], P[Q[:, (j + 1) % 4]]) == 1).all()
        domain_area = parse_domain(QUAD_COMBINE_EXAMPLE["domain"]).area
        assert quality.signed_area(P, Q, "quad").sum() == pytest.approx(domain_area, rel=1e-12)
        assert res["quality"]["quad"]["invalid"] == 0
        assert res["quality"]["conformity"] == {"nonmanifold": 0, "boundary_edges": 0}
        stats = res["stats"]
        assert set(stats["operators"]) >= {"valence2", "valence3", "collapse", "swap", "smooth"}
        assert (
            stats["quality_before"]["quad"]["quality"]["min"]
            <= (res["quality"]["quad"]["quality"]["min"])
        )
        r = client.get(f"/v1/jobs/{res['_id']}/result", params={"format": "vtu"})
        assert r.status_code == 200, r.text
        back = io.from_bytes(r.content, "vtu")
        assert len(back.cells[0].data) == len(Q)

    def test_surface_reports_warp(self, client):
        x, y = np.meshgrid(np.linspace(0, 1, 4), np.linspace(0, 1, 4))
        P = np.column_stack([x.ravel(), y.ravel(), (0.2 * x * y).ravel()])
        T = []
        for j in range(3):
            for i in range(3):
                v = 4 * j + i
                T += [[v, v + 1, v + 5], [v, v + 5, v + 4]]
        mesh = {"points": P.tolist(), "cells": [{"type": "triangle", "data": T}]}
        res = finished(client, {"mesh": mesh, "algorithm": "matching"})
        assert res["stats"]["triangles_left"] == 0
        assert res["stats"]["warp"]["max"] > 0

    def test_listed_with_its_schema(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        m = methods["quad_combine"]
        assert "§8.4" in m["section"]
        props = m["params_schema"]["properties"]
        assert {"mesh", "domain", "algorithm", "quality", "metric", "all_quad"} <= set(props)
