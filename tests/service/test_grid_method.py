"""The ``grid`` method through the API of a live server.

Failure cases first (422 problems naming the field), then a fitted mesh that
covers the domain exactly with positive cells, downloadable with its cell sets.
"""

from __future__ import annotations

import pytest

from meshcore.domain.planar import parse_domain
from meshcore.mesh import io, quality
from service.methods.grid import GRID_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
BOWTIE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}
#: No grid square fits it, and its fallback band would be about 2e5 triangles.
STRIP = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1e-5], [0, 1e-5], [0, 0]]]}


def finished(c, params: dict) -> dict:
    r = submit(c, "grid", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json() | {"_id": job["id"]}


class TestGrid:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"domain": SQUARE, "size": -1}, ["size"]),
            ({"domain": SQUARE, "size": 1e-5}, ["size"]),
            ({"domain": SQUARE, "boundary": "trim"}, ["boundary"]),
            ({"domain": SQUARE, "cells": "hex"}, ["cells"]),
            ({"domain": SQUARE, "origin": [0]}, ["origin"]),
            ({"domain": SQUARE, "max_cells": 0}, ["max_cells"]),
            ({"domain": BOWTIE, "size": 0.1}, ["domain", "coordinates", 0]),
            ({"domain": SQUARE, "segments": [[[0.5, 0.5], [2, 2]]]}, ["segments", 0]),
            ({"domain": SQUARE, "unknown": 1}, ["unknown"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, params, loc):
        assert_problem(submit(client, "grid", params), 422, ["body", "params", *loc])

    def test_example_covers_the_domain_and_downloads(self, client):
        res = finished(client, GRID_EXAMPLE)
        mesh = io.from_json(res["mesh"])
        area = sum(quality.signed_area(mesh.points, b.data, b.type).sum() for b in mesh.cells)
        assert area == pytest.approx(parse_domain(GRID_EXAMPLE["domain"]).area, rel=1e-12)
        for t in ("quad", "triangle"):
            assert res["quality"].get(t, {"invalid": 0})["invalid"] == 0
        assert res["quality"]["conformity"]["nonmanifold"] == 0
        assert set(res["stats"]["templates"]) >= {"whole", "quad", "triangle", "pentagon"}
        assert set(mesh.cell_sets) == {"interior", "boundary"}
        r = client.get(f"/v1/jobs/{res['_id']}/result", params={"format": "gmsh"})
        assert r.status_code == 200, r.text

    def test_keep_reports_errors(self, client):
        res = finished(client, {**GRID_EXAMPLE, "boundary": "keep"})
        assert res["stats"]["area_error"] > 0 and res["stats"]["hausdorff"] > 0

    def test_listed_with_its_schema(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        m = methods["grid"]
        assert "§8.2" in m["section"]
        props = m["params_schema"]["properties"]
        assert {"domain", "size", "origin", "angle", "boundary", "cells"} <= set(props)


class TestQuadGrid:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"domain": SQUARE, "size": 1e-5}, ["size"]),
            ({"domain": SQUARE, "layers": 0}, ["layers"]),
            ({"domain": BOWTIE}, ["domain", "coordinates", 0]),
            ({"domain": STRIP, "size": 0.025}, ["domain"]),  # refused at submit, not in the job
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, params, loc):
        assert_problem(submit(client, "quad_grid", params), 422, ["body", "params", *loc])

    def test_example_is_only_quads(self, client):
        from service.methods.grid import QUAD_GRID_EXAMPLE

        r = submit(client, "quad_grid", QUAD_GRID_EXAMPLE, wait=30)
        assert r.status_code == 200, r.text
        res = client.get(f"/v1/jobs/{r.json()['id']}/result").json()
        assert list(res["quality"]) == ["quad", "conformity"] or "triangle" not in res["quality"]
        assert res["quality"]["quad"]["invalid"] == 0
        mesh = io.from_json(res["mesh"])
        area = quality.signed_area(mesh.points, mesh.cells[0].data, "quad").sum()
        assert area == pytest.approx(parse_domain(QUAD_GRID_EXAMPLE["domain"]).area, rel=1e-12)


class TestPattern:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"pattern": {"type": "hexagon", "size": 0}}, ["pattern", "hexagon", "size"]),
            ({"pattern": {"type": "spiral"}}, ["pattern"]),
            (
                {"pattern": {"type": "parallelogram", "vectors": [[1, 0], [2, 0]]}},
                ["pattern", "vectors"],
            ),
            (
                {"pattern": {"type": "radial", "center": [0, 0], "radii": [0, 1], "segments": 8}},
                ["pattern", "radial", "radii", 0],
            ),
            ({"pattern": {"type": "hexagon", "size": 0.1}, "margin": 0}, ["margin"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, params, loc):
        r = submit(client, "pattern", {"domain": SQUARE, **params})
        assert_problem(r, 422, ["body", "params", *loc])

    def test_example_carries_cell_sets(self, client):
        from service.methods.grid import PATTERN_EXAMPLE

        r = submit(client, "pattern", PATTERN_EXAMPLE, wait=30)
        assert r.status_code == 200, r.text
        job = r.json()
        res = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert set(res["mesh"]["cell_sets"]) == {"pattern", "gap"}
        assert res["stats"]["steps"]["ii"] > 0
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": "gmsh"})
        assert r.status_code == 200, r.text
