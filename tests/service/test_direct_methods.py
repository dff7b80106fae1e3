"""``paving`` and ``recursive_partition`` through the API of a live server.

Failure cases first (422 problems naming the field or vertex, before the job
is queued), then results with only quads (paving) or the cells asked for,
valid and downloadable.
"""

from __future__ import annotations

import pytest

from meshcore.mesh import io
from service.methods.partition import RECURSIVE_PARTITION_3D_EXAMPLE, RECURSIVE_PARTITION_EXAMPLE
from service.methods.quads import PAVING_EXAMPLE
from service.methods.surface_schema import UNIT_CUBE
from tests.service.test_jobs import assert_problem, submit

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
BOWTIE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1]]]}


def finished(c, method: str, params: dict) -> dict:
    r = submit(c, method, params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json() | {"_id": job["id"]}


@pytest.mark.parametrize("method", ["paving", "recursive_partition"])
class TestRefused:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"domain": BOWTIE, "size": 0.1}, ["domain", "coordinates", 0]),
            ({"domain": SQUARE}, []),
            ({"domain": SQUARE, "size": 0}, ["size"]),
            ({"domain": SQUARE, "size": 1e-5}, ["size"]),
            (
                {"domain": SQUARE, "size_field": {"points": [[0, 0]], "values": [-1]}},
                ["size_field"],
            ),
            ({"domain": SQUARE, "size": 0.1, "unknown": 1}, ["unknown"]),
        ],
    )
    def test_bad_params_are_422_naming_the_field(self, client, method, params, loc):
        assert_problem(submit(client, method, params), 422, ["body", "params", *loc])


class TestRefusedOptions:
    def test_element(self, client):
        r = submit(client, "recursive_partition", {"domain": SQUARE, "size": 0.1, "element": "hex"})
        assert_problem(r, 422, ["body", "params", "element"])

    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"surface": UNIT_CUBE, "size": 0.5, "element": "quad"}, ["element"]),
            ({"surface": UNIT_CUBE, "domain": SQUARE, "size": 0.5}, []),
            ({"surface": UNIT_CUBE, "size": 1e-4}, ["size"]),
        ],
    )
    def test_surface(self, client, params, loc):
        r = submit(client, "recursive_partition", params)
        assert_problem(r, 422, ["body", "params", *loc])

    def test_max_rows(self, client):
        r = submit(client, "paving", {"domain": SQUARE, "size": 0.1, "max_rows": -1})
        assert_problem(r, 422, ["body", "params", "max_rows"])


class TestResults:
    def test_paving_example_only_quads(self, client):
        out = finished(client, "paving", PAVING_EXAMPLE)
        assert [b["type"] for b in out["mesh"]["cells"]] == ["quad"]
        assert out["quality"]["quad"]["invalid"] == 0
        assert out["quality"]["conformity"] == {"nonmanifold": 0, "boundary_edges": 0}
        assert out["stats"]["rows"] >= 1
        r = client.get(f"/v1/jobs/{out['_id']}/result", params={"format": "vtu"})
        assert r.status_code == 200
        assert len(io.from_bytes(r.content, "vtu").points) == len(out["mesh"]["points"])

    @pytest.mark.parametrize("element", ["triangle", "quad"])
    def test_recursive_partition(self, client, element):
        out = finished(
            client, "recursive_partition", {**RECURSIVE_PARTITION_EXAMPLE, "element": element}
        )
        assert [b["type"] for b in out["mesh"]["cells"]] == [element]
        assert out["quality"][element]["invalid"] == 0
        assert out["stats"]["bridges"] == 1

    def test_recursive_partition_of_a_surface(self, client):
        out = finished(client, "recursive_partition", RECURSIVE_PARTITION_3D_EXAMPLE)
        assert [b["type"] for b in out["mesh"]["cells"]] == ["tetra"]
        assert out["quality"]["tetra"]["invalid"] == 0
        assert out["stats"]["volume"] == 1.0
        assert len(out["mesh"]["points"]) == 8 and out["stats"]["steiner_points"] == 0
