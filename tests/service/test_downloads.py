"""Downloads and previews as a client sees them: headers, ranges, caching, the job's own files."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from io import BytesIO

import numpy as np
import pytest
from PIL import Image

from meshcore.mesh import io
from tests.service.test_jobs import assert_problem, submit

MESH = {
    "points": [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]}],
    "cell_sets": {"left": [[0, 1]]},
}


@pytest.fixture
def job(client) -> dict:
    return submit(client, "echo_mesh", {"mesh": MESH}, wait=10).json()


class TestDownloadHeaders:
    def test_job_writes_its_default_format_and_arrays(self, live, job):
        files = {p.name for p in (live.data_dir / "jobs" / job["id"]).iterdir()}
        assert {"result.json", "result.npz", "result.meta.json", "result.vtu"} <= files
        assert "result.stl" not in files  # written on its first request only

    @pytest.mark.parametrize("fmt", sorted(io.FORMATS))
    def test_disposition_length_etag(self, client, job, fmt):
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": fmt})
        assert r.status_code == 200, r.text
        suffix = io.FORMATS[fmt].suffix
        assert r.headers["content-disposition"] == (
            f'attachment; filename="{job["id"]}-{fmt}{suffix}"'
        )
        assert int(r.headers["content-length"]) == len(r.content)
        assert r.headers["content-type"].startswith(io.FORMATS[fmt].media_type)
        assert r.headers["accept-ranges"] == "bytes"
        assert r.headers["etag"] == f'"{job["id"]}-{fmt}"'
        again = client.get(f"/v1/jobs/{job['id']}/result", params={"format": fmt})
        assert again.content == r.content and again.headers["etag"] == r.headers["etag"]

    def test_if_none_match_answers_304(self, client, job):
        url = f"/v1/jobs/{job['id']}/result"
        tag = client.get(url, params={"format": "gmsh"}).headers["etag"]
        r = client.get(url, params={"format": "gmsh"}, headers={"If-None-Match": f"W/{tag}"})
        assert r.status_code == 304 and r.headers["etag"] == tag and not r.content
        other = client.get(url, params={"format": "gmsh"}, headers={"If-None-Match": '"x"'})
        assert other.status_code == 200

    def test_range_request(self, client, job):
        url = f"/v1/jobs/{job['id']}/result"
        whole = client.get(url, params={"format": "vtu"}).content
        r = client.get(url, params={"format": "vtu"}, headers={"Range": "bytes=10-29"})
        assert r.status_code == 206
        assert r.content == whole[10:30]
        assert r.headers["content-range"] == f"bytes 10-29/{len(whole)}"

    def test_json_result_is_inline_with_an_etag(self, client, job):
        r = client.get(f"/v1/jobs/{job['id']}/result")
        assert r.status_code == 200 and r.headers["content-type"] == "application/json"
        assert r.headers["content-disposition"].startswith("inline;")
        assert r.headers["etag"] == f'"{job["id"]}-json"'
        tail = client.get(f"/v1/jobs/{job['id']}/result", headers={"Range": "bytes=-5"})
        assert tail.status_code == 206 and tail.content == r.content[-5:]

    def test_xdmf_is_an_archive_meshio_reads(self, client, job):
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": "xdmf"})
        back = io.from_bytes(r.content, "xdmf")
        assert back.cells[0].data.tolist() == MESH["cells"][0]["data"]


class TestPreviews:
    def test_png_draws_the_mesh(self, client, job):
        r = client.get(f"/v1/jobs/{job['id']}/preview.png")
        assert r.status_code == 200 and r.headers["content-type"] == "image/png"
        image = Image.open(BytesIO(r.content))
        assert max(image.size) == 800
        assert np.asarray(image.convert("L")).min() < 100  # something dark is drawn

    def test_svg_says_what_it_left_out(self, client):
        n = 200  # a 200 x 200 grid of triangles: edges far below a pixel
        points = [[i / n, j / n] for j in range(n + 1) for i in range(n + 1)]
        cells = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                cells += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
        mesh = {"points": points, "cells": [{"type": "triangle", "data": cells}]}
        job = submit(client, "echo_mesh", {"mesh": mesh}, wait=30).json()
        r = client.get(f"/v1/jobs/{job['id']}/preview.svg")
        assert r.status_code == 200
        root = ET.fromstring(r.content)
        desc = root.find("{http://www.w3.org/2000/svg}desc").text
        assert "shorter than 1 px left out" in desc
        assert len(r.content) < 2_000_000

    def test_3d_result_is_drawn_as_its_surface(self, client):
        cube = [[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)]
        mesh = {
            "points": cube,
            "cells": [{"type": "hexahedron", "data": [[0, 1, 3, 2, 4, 5, 7, 6]]}],
        }
        job = submit(client, "echo_mesh", {"mesh": mesh}, wait=10).json()
        png = client.get(f"/v1/jobs/{job['id']}/preview.png")
        assert png.status_code == 200
        svg = client.get(f"/v1/jobs/{job['id']}/preview.svg")
        assert b"boundary surface" in svg.content

    def test_nothing_to_draw_is_422(self, client):
        job = submit(client, "quality", {"mesh": MESH}, wait=10).json()
        assert_problem(client.get(f"/v1/jobs/{job['id']}/preview.png"), 422)
