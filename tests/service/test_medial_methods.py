"""The medial-axis methods through the API of a live server (§9.4, §9.6, §9.7).

Failure cases first (422 problems naming the field or vertex, before the job
is queued), then results that come back with their fixed keys, the axis as a
VTU line mesh and the regions drawn by preview.svg.
"""

from __future__ import annotations

import pytest

from tests.service.test_jobs import assert_problem, submit

RECT = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]}
BOWTIE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1]]]}


def finished(c, method: str, params: dict) -> dict:
    r = submit(c, method, params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    result = c.get(f"/v1/jobs/{job['id']}/result")
    assert result.status_code == 200
    return {"job": job, **result.json()}


class TestRefused:
    @pytest.mark.parametrize(
        "method, params, loc",
        [
            ("medial_axis", {"domain": BOWTIE}, ["domain", "coordinates", 0]),
            ("medial_axis", {"points": [[0, 0], [1, 0]]}, ["points"]),
            ("medial_axis", {"domain": RECT, "points": [[0, 0], [1, 0], [0, 1]]}, []),
            ("medial_axis", {"domain": RECT, "h": 0}, ["h"]),
            ("medial_axis", {"domain": RECT, "prune": -1}, ["prune"]),
            ("medial_axis", {"domain": RECT, "approximation": "x"}, ["approximation"]),
            (
                "medial_transform",
                {"axis": {"nodes": [[0, 0]], "radius": [-1], "edges": []}},
                ["axis", "radius", 0],
            ),
            (
                "medial_transform",
                {"axis": {"nodes": [[0, 0], [1, 0]], "radius": [1, 1], "edges": [[0, 5]]}},
                ["axis", "edges", 0],
            ),
            ("partition", {"domain": RECT, "method": "other"}, ["method"]),
            ("partition", {"domain": BOWTIE}, ["domain", "coordinates", 0]),
            ("quad_medial", {"domain": RECT, "size": 0.1, "levels": 1}, []),
            ("quad_medial", {"domain": RECT, "size": 1e-5}, ["size"]),
            ("simplify", {"domain": RECT, "threshold": -1}, ["threshold"]),
        ],
    )
    def test_bad_input_is_422_with_the_location(self, client, method, params, loc):
        r = submit(client, method, params)
        assert_problem(r, 422, ["body", "params", *loc])


class TestResults:
    def test_medial_axis_of_the_rectangle(self, client):
        res = finished(client, "medial_axis", {"domain": RECT})
        axis = res["axis"]
        assert axis["kind"].count("critical") == 2 and axis["kind"].count("terminal") == 4
        assert len(axis["radius"]) == len(axis["nodes"])
        assert res["stats"]["triangle_types"]["type2"] == 4
        vtu = client.get(f"/v1/jobs/{res['job']['id']}/result", params={"format": "vtu"})
        assert vtu.status_code == 200 and b"radius" in vtu.content
        svg = client.get(f"/v1/jobs/{res['job']['id']}/preview.svg")
        assert svg.status_code == 200 and b"<svg" in svg.content

    def test_point_cloud(self, client):
        pts = [[x / 10, 0] for x in range(20)] + [[2, y / 10] for y in range(10)]
        pts += [[2 - x / 10, 1] for x in range(20)] + [[0, 1 - y / 10] for y in range(10)]
        res = finished(client, "medial_axis", {"points": pts})
        assert res["axis"]["kind"].count("terminal") == 4
        assert res["domain"]["type"] == "Polygon"  # the reconstructed ring
        assert len(res["domain"]["coordinates"][0]) == len(pts) + 1

    def test_medial_transform_of_the_axis_gives_the_rectangle_back(self, client):
        axis = finished(client, "medial_axis", {"domain": RECT})["axis"]
        res = finished(client, "medial_transform", {"axis": axis, "domain": RECT})
        assert res["domain"]["type"] == "Polygon"
        assert res["stats"]["hausdorff"] < 0.01

    def test_partition_regions(self, client):
        res = finished(client, "partition", {"domain": RECT, "method": "terminal"})
        assert sorted(r["sides"] for r in res["regions"]) == [3, 3, 4, 4]
        assert sum(r["area"] for r in res["regions"]) == pytest.approx(2.0)
        svg = client.get(f"/v1/jobs/{res['job']['id']}/preview.svg")
        assert svg.status_code == 200 and svg.content.count(b"<path") >= 5

    def test_quad_medial_mesh(self, client):
        res = finished(client, "quad_medial", {"domain": RECT, "size": 0.1})
        assert [b["type"] for b in res["mesh"]["cells"]] == ["quad"]
        assert res["quality"]["quad"]["invalid"] == 0
        assert res["stats"]["area"] == pytest.approx(2.0)

    def test_simplify_removes_a_small_hole(self, client):
        plate = {
            "type": "Polygon",
            "coordinates": [
                [[0, 0], [10, 0], [10, 4], [0, 4], [0, 0]],
                [[2, 2], [2, 2.1], [2.1, 2.1], [2.1, 2], [2, 2]],
            ],
        }
        res = finished(client, "simplify", {"domain": plate})
        assert len(res["domain"]["coordinates"]) == 1
        assert [f["kind"] for f in res["stats"]["removed"]] == ["hole"]

    @pytest.mark.parametrize(
        "method", ["medial_axis", "medial_transform", "partition", "quad_medial", "simplify"]
    )
    def test_the_examples_run(self, client, method):
        methods = client.get("/v1/methods").json()
        spec = next(m for m in methods if m["name"] == method)
        finished(client, method, spec["example"])
