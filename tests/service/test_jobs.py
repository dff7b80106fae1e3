"""The jobs API through a real uvicorn, as a client sees it.

One class per operation; failure cases first.
"""

from __future__ import annotations

import json
import os
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime

import httpx
import pytest

from meshcore.mesh import io
from service.executors.child import NICE_AFTER
from tests.service.conftest import LiveServer, wait_status
from tests.service.testing_methods import SQUARE

PROBLEM = "application/problem+json"


def assert_problem(response: httpx.Response, status: int, loc: list | None = None) -> dict:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    doc = response.json()
    assert doc["status"] == status
    assert doc["title"] and doc["detail"] and doc["type"]
    if loc is not None:
        assert any(e["loc"][: len(loc)] == loc for e in doc["errors"]), doc
    return doc


def submit(c: httpx.Client, method: str, params: dict, wait: float = 0, **kwargs) -> httpx.Response:
    """POST the job; with ``wait``, wait for it to end (``?wait=``, then long-polls on the
    job, ``max(wait, 180)`` seconds in all: a loaded CI machine is slow) and answer with
    the finished job (200), or the submit's own answer when it was not a 202."""
    query = {"wait": min(wait, 30)} if wait else {}
    r = c.post("/v1/jobs", json={"method": method, "params": params}, params=query, **kwargs)
    if not wait or r.status_code != 202:
        return r
    deadline = time.monotonic() + max(wait, 180)
    while r.status_code in (200, 202) and not r.json()["finished_at"]:
        if time.monotonic() > deadline:
            break
        r = c.get(f"/v1/jobs/{r.json()['id']}", params={"wait": 30}, headers=kwargs.get("headers"))
    return r


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead for our purposes
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split()[2] != "Z"
    except (FileNotFoundError, ProcessLookupError):  # gone before the open, or the read
        return False


def _seconds(stamp: str) -> float:
    return datetime.fromisoformat(stamp).timestamp()


def wait_file(path, timeout: float = 20) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if os.path.exists(path) and open(path).read().strip():
            return open(path).read()
        time.sleep(0.02)
    raise AssertionError(f"{path} never appeared")


class TestSubmit:
    def test_malformed_json_is_a_400_problem(self, client):
        r = client.post(
            "/v1/jobs",
            content=b'{"method": "quality", ',
            headers={"content-type": "application/json"},
        )
        assert_problem(r, 400, ["body"])

    def test_a_body_of_another_media_type_is_415(self, client):
        r = client.post("/v1/jobs", content=b"{}", headers={"content-type": "text/plain"})
        assert_problem(r, 415)

    def test_unknown_method_names_the_method_field(self, client):
        assert_problem(submit(client, "no_such_method", {}), 422, ["body"])
        doc = submit(client, "no_such_method", {}).json()
        assert any("method" in e["loc"] for e in doc["errors"])

    def test_wrong_types_name_the_field(self, client):
        r = submit(client, "quality", {"mesh": {"points": "abc", "cells": []}})
        doc = assert_problem(r, 422)
        assert any("points" in e["loc"] for e in doc["errors"])

    def test_nan_and_inf_coordinates_are_refused(self, client):
        body = (
            b'{"method": "quality", "params": {"mesh": {"points": [[0, 0], [NaN, 0], [0, 1]],'
            b' "cells": [{"type": "triangle", "data": [[0, 1, 2]]}]}}}'
        )
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        doc = assert_problem(r, 422)
        assert any(e["loc"][-3:-1] == ["points", 1] for e in doc["errors"]), doc
        body = body.replace(b"NaN", b"Infinity")
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422)

    def test_out_of_range_index_names_block_cell_and_index(self, client):
        mesh = {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 1, 7]]}],
        }
        doc = assert_problem(
            submit(client, "quality", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 0, "data", 1, 2],
        )
        assert "7" in doc["detail"]

    def test_empty_mesh_is_refused(self, client):
        assert_problem(
            submit(client, "quality", {"mesh": {"points": [], "cells": []}}),
            422,
            ["body", "params", "mesh"],
        )

    def test_wrong_nodes_per_cell(self, client):
        mesh = {
            "points": [[0, 0], [1, 0], [0, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2]]}],
        }
        assert_problem(
            submit(client, "quality", {"mesh": mesh}),
            422,
            ["body", "params", "mesh", "cells", 0, "data"],
        )

    def test_unknown_params_field(self, client):
        assert_problem(
            submit(client, "quality", {"mesh": SQUARE, "colour": "red"}),
            422,
            ["body", "params", "colour"],
        )

    def test_wait_answers_200_with_the_finished_job(self, client):
        r = submit(client, "quality", {"mesh": SQUARE}, wait=10)
        assert r.status_code == 200, r.text
        job = r.json()
        assert job["status"] == "succeeded"
        assert job["attempt"] == 1 and job["progress"]["fraction"] == 1
        assert r.headers["location"] == f"/v1/jobs/{job['id']}"
        assert job["links"]["result"] == f"/v1/jobs/{job['id']}/result"

    def test_without_wait_answers_202_with_location_and_retry_after(self, client):
        r = submit(client, "sleep", {"seconds": 0.3})
        assert r.status_code == 202
        assert r.headers["location"] == f"/v1/jobs/{r.json()['id']}"
        assert int(r.headers["retry-after"]) >= 1
        assert r.json()["status"] in ("queued", "running")

    def test_idempotency_key_returns_the_first_job(self, client):
        key = {"Idempotency-Key": f"k-{time.time()}"}
        first = submit(client, "quality", {"mesh": SQUARE}, headers=key)
        again = submit(client, "quality", {"mesh": SQUARE}, headers=key)
        assert first.json()["id"] == again.json()["id"]
        other = submit(client, "sleep", {"seconds": 0}, headers=key)
        assert_problem(other, 422, ["header", "Idempotency-Key"])

    def test_concurrent_retries_with_one_key_make_one_job(self, live):
        key = {"Idempotency-Key": f"race-{time.time()}"}

        def post(_):
            with live.client() as c:
                return submit(c, "sleep", {"seconds": 0}, headers=key).json()["id"]

        with ThreadPoolExecutor(8) as pool:
            ids = set(pool.map(post, range(8)))
        assert len(ids) == 1

    def test_unexpected_exception_fails_only_the_job(self, client):
        job = submit(client, "boom", {}, wait=10).json()
        assert job["status"] == "failed"
        assert job["error"]["status"] == 500
        assert "boom" in job["error"]["detail"]
        assert submit(client, "quality", {"mesh": SQUARE}, wait=10).json()["status"] == "succeeded"

    def test_mesh_error_found_in_the_job_is_a_422_problem_in_error(self, client):
        job = submit(client, "echo_mesh", {"mesh": SQUARE}, wait=10).json()
        assert job["status"] == "succeeded"


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A server taking bodies of at most 2000 bytes and jobs of at most 3 points."""
    server = LiveServer(
        tmp_path_factory.mktemp("limits") / "data",
        MESHSERVICE_MAX_BODY_BYTES="2000",
        MESHSERVICE_MAX_POINTS="3",
    ).start()
    yield server
    server.stop()


class TestLimits:
    def test_body_too_large_is_413(self, small):
        with small.client() as c:
            big = {
                "points": [[i, 0.5 * i] for i in range(300)],
                "cells": [{"type": "vertex", "data": [[i] for i in range(300)]}],
            }
            assert_problem(submit(c, "quality", {"mesh": big}), 413)

            def chunks():
                yield json.dumps({"method": "quality", "params": {"mesh": big}}).encode()

            r = c.post("/v1/jobs", content=chunks(), headers={"content-type": "application/json"})
            assert_problem(r, 413)

    def test_too_many_points_is_413(self, small):
        with small.client() as c:
            doc = assert_problem(submit(c, "quality", {"mesh": SQUARE}), 413)
            assert "MESHSERVICE_MAX_POINTS" in doc["detail"]

    def test_too_many_queued_is_429_with_retry_after(self, start_server):
        server = start_server(MESHSERVICE_MAX_QUEUED="2", MESHSERVICE_WORKERS="1")
        with server.client() as c:
            a = submit(c, "sleep", {"seconds": 5}).json()
            b = submit(c, "sleep", {"seconds": 5}).json()
            r = submit(c, "sleep", {"seconds": 5})
            assert_problem(r, 429)
            assert int(r.headers["retry-after"]) > 0
            c.post(f"/v1/jobs/{a['id']}/cancel")
            assert submit(c, "sleep", {"seconds": 0}).status_code == 202
            c.post(f"/v1/jobs/{b['id']}/cancel")

    def test_time_limit_kills_the_job(self, start_server, tmp_path):
        server = start_server(MESHSERVICE_JOB_TIME_LIMIT="1")
        marker = tmp_path / "pid"
        with server.client() as c:
            # the limit counts from the submit, and this server's fork server may still be
            # importing meshcore (seconds on a loaded machine): wait until a job gets through
            deadline = time.monotonic() + 120
            while submit(c, "sleep", {"seconds": 0}, wait=10).json()["status"] != "succeeded":
                assert time.monotonic() < deadline, "no job got through the 1 s limit in 120 s"
            job = submit(c, "sleep", {"seconds": 30, "marker": str(marker)}).json()
            pid = int(wait_file(marker))
            job = wait_status(c, job["id"], {"failed"})
            assert job["status"] == "failed"
            assert job["error"]["type"] == "/problems/time-limit"
            time.sleep(0.2)
            assert not pid_alive(pid)


class TestGet:
    def test_unknown_job_is_404(self, client):
        assert_problem(client.get("/v1/jobs/0123456789abcdef"), 404)

    def test_etag_and_304(self, client):
        job = submit(client, "quality", {"mesh": SQUARE}, wait=10).json()
        r = client.get(f"/v1/jobs/{job['id']}")
        etag = r.headers["etag"]
        assert (
            client.get(f"/v1/jobs/{job['id']}", headers={"If-None-Match": etag}).status_code == 304
        )

    def test_long_poll_returns_when_the_status_changes(self, client):
        job = submit(client, "sleep", {"seconds": 0.5}).json()
        job = wait_status(client, job["id"], {"running"})
        t0 = time.monotonic()
        r = client.get(f"/v1/jobs/{job['id']}", params={"wait": 20})
        assert r.json()["status"] == "succeeded"
        assert time.monotonic() - t0 < 10

    def test_long_poll_with_etag_returns_on_progress(self, client):
        job = submit(client, "sleep", {"seconds": 2}).json()
        job = wait_status(client, job["id"], {"running"})
        r = client.get(f"/v1/jobs/{job['id']}")
        r2 = client.get(
            f"/v1/jobs/{job['id']}",
            params={"wait": 10},
            headers={"If-None-Match": r.headers["etag"]},
        )
        assert r2.status_code == 200
        assert r2.headers["etag"] != r.headers["etag"]
        client.post(f"/v1/jobs/{job['id']}/cancel")


class TestEvents:
    def test_unknown_job_is_404(self, client):
        assert_problem(client.get("/v1/jobs/nope/events"), 404)

    def test_stream_reports_progress_then_ends(self, client):
        job = submit(client, "sleep", {"seconds": 1}).json()
        events = []
        with client.stream("GET", f"/v1/jobs/{job['id']}/events") as r:
            assert r.headers["content-type"].startswith("text/event-stream")
            event = None
            for line in r.iter_lines():
                if line.startswith("event:"):
                    event = line.split(":", 1)[1].strip()
                elif line.startswith("data:"):
                    events.append((event, json.loads(line.split(":", 1)[1])))
        kinds = [e for e, _ in events]
        assert kinds[-1] == "end" and kinds.count("end") == 1
        assert events[-1][1]["status"] == "succeeded"
        fractions = [d["progress"]["fraction"] for e, d in events if d["status"] == "running"]
        assert len(fractions) >= 3 and fractions == sorted(fractions)


class TestList:
    def test_bad_page_token_is_422(self, client):
        assert_problem(
            client.get("/v1/jobs", params={"page_token": "garbage"}), 422, ["query", "page_token"]
        )

    def test_pages_cover_every_job_once_newest_first(self, start_server):
        server = start_server()
        with server.client() as c:
            ids = [submit(c, "sleep", {"seconds": 0}).json()["id"] for _ in range(5)]
            seen, token = [], None
            while True:
                params = {"page_size": 2, **({"page_token": token} if token else {})}
                page = c.get("/v1/jobs", params=params).json()
                seen += [j["id"] for j in page["jobs"]]
                token = page["next_page_token"]
                if token is None:
                    break
            assert seen == ids[::-1]


class TestCancel:
    def test_unknown_job_is_404(self, client):
        assert_problem(client.post("/v1/jobs/nope/cancel"), 404)

    def test_queued_job_never_starts(self, start_server, tmp_path):
        server = start_server(MESHSERVICE_WORKERS="1")
        with server.client() as c:
            blocker = submit(c, "sleep", {"seconds": 1}).json()
            marker = tmp_path / "queued-started"
            queued = submit(c, "sleep", {"seconds": 0, "marker": str(marker)}).json()
            assert queued["status"] == "queued"
            r = c.post(f"/v1/jobs/{queued['id']}/cancel")
            assert r.status_code == 200 and r.json()["status"] == "cancelled"
            assert c.post(f"/v1/jobs/{queued['id']}/cancel").json()["status"] == "cancelled"
            assert wait_status(c, blocker["id"], {"succeeded"})["status"] == "succeeded"
            time.sleep(0.5)
            assert not marker.exists()
            assert c.get(f"/v1/jobs/{queued['id']}").json()["status"] == "cancelled"

    def test_running_job_process_is_killed(self, client, tmp_path):
        marker = tmp_path / "running"
        job = submit(client, "sleep", {"seconds": 30, "marker": str(marker)}).json()
        pid = int(wait_file(marker))
        r = client.post(f"/v1/jobs/{job['id']}/cancel")
        assert r.json()["status"] == "cancelled"
        deadline = time.monotonic() + 5
        while pid_alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not pid_alive(pid)
        assert client.get(f"/v1/jobs/{job['id']}").json()["status"] == "cancelled"
        assert_problem(client.get(f"/v1/jobs/{job['id']}/result"), 409)


class TestDelete:
    def test_unknown_job_is_404(self, client):
        assert_problem(client.delete("/v1/jobs/nope"), 404)

    def test_delete_removes_job_and_files(self, live, client, tmp_path):
        job = submit(client, "quality", {"mesh": SQUARE}, wait=10).json()
        folder = live.data_dir / "jobs" / job["id"]
        assert (folder / "result.json").exists()
        assert client.delete(f"/v1/jobs/{job['id']}").status_code == 204
        assert not folder.exists()
        assert_problem(client.get(f"/v1/jobs/{job['id']}"), 404)

    def test_delete_running_job_kills_it(self, client, tmp_path):
        marker = tmp_path / "deleted"
        job = submit(client, "sleep", {"seconds": 30, "marker": str(marker)}).json()
        pid = int(wait_file(marker))
        assert client.delete(f"/v1/jobs/{job['id']}").status_code == 204
        time.sleep(0.2)
        assert not pid_alive(pid)
        assert_problem(client.get(f"/v1/jobs/{job['id']}"), 404)


class TestResult:
    def test_running_job_result_is_409_with_retry_after(self, client):
        job = submit(client, "sleep", {"seconds": 2}).json()
        r = client.get(f"/v1/jobs/{job['id']}/result")
        assert_problem(r, 409)
        assert "retry-after" in r.headers
        client.post(f"/v1/jobs/{job['id']}/cancel")

    def test_unknown_format_is_422(self, client):
        job = submit(client, "echo_mesh", {"mesh": SQUARE}, wait=10).json()
        assert_problem(client.get(f"/v1/jobs/{job['id']}/result", params={"format": "dwg"}), 422)

    def test_result_without_mesh_cannot_be_downloaded(self, client):
        job = submit(client, "quality", {"mesh": SQUARE}, wait=10).json()
        assert_problem(client.get(f"/v1/jobs/{job['id']}/result", params={"format": "vtu"}), 422)

    def test_format_that_cannot_hold_the_cells_is_422(self, client):
        mesh = {"points": [[0, 0], [1, 0]], "cells": [{"type": "line", "data": [[0, 1]]}]}
        job = submit(client, "echo_mesh", {"mesh": mesh}, wait=10).json()
        assert_problem(client.get(f"/v1/jobs/{job['id']}/result", params={"format": "stl"}), 422)

    def test_quality_result_json(self, client):
        job = submit(client, "quality", {"mesh": SQUARE}, wait=10).json()
        r = client.get(f"/v1/jobs/{job['id']}/result")
        assert r.status_code == 200 and r.headers["content-type"] == "application/json"
        report = r.json()["quality"]
        assert report["triangle"]["count"] == 2 and report["triangle"]["invalid"] == 0
        assert report["triangle"]["angle"]["min"] == pytest.approx(45)
        assert report["triangle"]["angle"]["max"] == pytest.approx(90)

    @pytest.mark.parametrize("fmt", sorted(set(io.FORMATS) - {"glb"}))  # glb: test_convert.py
    def test_download_reads_back(self, client, fmt):
        mesh = {
            "points": [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]],
            "cells": [
                {"type": "triangle", "data": [[0, 1, 4], [0, 4, 3]]},
                {"type": "quad", "data": [[1, 2, 5, 4]]},
            ],
            "cell_sets": {"left": [[0, 1], []], "right": [[], [0]]},
        }
        if fmt == "stl":
            mesh["cells"] = mesh["cells"][:1]
            mesh["cell_sets"] = {}
        job = submit(client, "echo_mesh", {"mesh": mesh}, wait=10).json()
        r = client.get(f"/v1/jobs/{job['id']}/result", params={"format": fmt})
        assert r.status_code == 200, r.text
        assert "attachment" in r.headers["content-disposition"]
        back = io.from_bytes(r.content, fmt)
        counts = {}
        for block in back.cells:
            counts[block.type] = counts.get(block.type, 0) + len(block)
        expected = {b["type"]: len(b["data"]) for b in mesh["cells"]}
        assert counts == expected
        used = {i for block in mesh["cells"] for cell in block["data"] for i in cell}
        assert len(back.points) == (len(used) if fmt == "stl" else 6)  # STL keeps used points
        if fmt in ("gmsh", "gmsh22", "abaqus"):
            assert {k: sum(len(a) for a in v) for k, v in back.cell_sets.items()} == {
                "left": 2,
                "right": 1,
            }

    def test_preview_svg_is_xml(self, client):
        job = submit(client, "echo_mesh", {"mesh": SQUARE}, wait=10).json()
        r = client.get(f"/v1/jobs/{job['id']}/preview.svg")
        assert r.status_code == 200 and r.headers["content-type"].startswith("image/svg+xml")
        root = ET.fromstring(r.content)
        assert root.tag.endswith("svg")

    def test_preview_of_a_result_with_nothing_to_draw_is_422(self, client):
        job = submit(client, "quality", {"mesh": SQUARE}, wait=10).json()
        assert_problem(client.get(f"/v1/jobs/{job['id']}/preview.svg"), 422)

    def test_expired_result_is_410(self, start_server):
        server = start_server(MESHSERVICE_RETENTION="0.5")
        with server.client() as c:
            job = submit(c, "quality", {"mesh": SQUARE}, wait=10).json()
            deadline = time.monotonic() + 10
            while c.get(f"/v1/jobs/{job['id']}/result").status_code == 200:
                assert time.monotonic() < deadline
                time.sleep(0.1)
            r = c.get(f"/v1/jobs/{job['id']}/result")
            if r.status_code == 410:
                assert_problem(r, 410)
            else:  # past twice the retention the job itself is gone
                assert_problem(r, 404)


class TestCrashes:
    def test_sigkill_of_the_job_process_fails_only_that_job(self, client, tmp_path):
        marker = tmp_path / "killme"
        job = submit(client, "sleep", {"seconds": 30, "marker": str(marker)}).json()
        pid = int(wait_file(marker))
        os.kill(pid, 9)
        job = wait_status(client, job["id"], {"failed"})
        assert job["error"]["type"] == "/problems/worker-died"
        assert "SIGKILL" in job["error"]["detail"]
        assert submit(client, "quality", {"mesh": SQUARE}, wait=10).json()["status"] == "succeeded"

    def test_a_job_process_has_one_blas_thread(self, client, tmp_path):
        marker = tmp_path / "env"
        job = submit(client, "sleep", {"seconds": 30, "marker": str(marker)}).json()
        pid = int(wait_file(marker))
        with open(f"/proc/{pid}/environ", "rb") as f:
            env = dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
        client.post(f"/v1/jobs/{job['id']}/cancel")
        assert env[b"OPENBLAS_NUM_THREADS"] == env[b"OMP_NUM_THREADS"] == b"1"

    def test_a_small_jobs_process_takes_the_next_job_a_longer_ones_ends(self, client):
        def run(seconds: float) -> tuple[int, float]:
            job = submit(client, "sleep", {"seconds": seconds}, wait=10).json()
            assert job["status"] == "succeeded"
            stats = client.get(f"/v1/jobs/{job['id']}/result").json()["stats"]
            return stats["pid"], _seconds(job["finished_at"]) - _seconds(job["started_at"])

        run(0)  # a test server starts without the warm-up: its first job may wait for it
        first, took = run(0)
        second, _ = run(0)
        if took < NICE_AFTER:  # (a machine too busy may take longer for an empty job)
            assert second == first
        longer, _ = run(NICE_AFTER + 0.1)
        after, _ = run(0)
        assert after != longer
        deadline = time.monotonic() + 10
        while pid_alive(longer) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not pid_alive(longer)

    @pytest.mark.parametrize("how, words", [("exit", "status 3"), ("segfault", "SIGSEGV")])
    def test_crash_fails_only_that_job(self, client, how, words):
        job = submit(client, "crash", {"how": how}, wait=20).json()
        assert job["status"] == "failed"
        assert words in job["error"]["detail"]
        assert submit(client, "quality", {"mesh": SQUARE}, wait=10).json()["status"] == "succeeded"

    def test_memory_limit_fails_the_job(self, start_server):
        server = start_server(MESHSERVICE_JOB_MEMORY_LIMIT=str(1 << 30))
        with server.client() as c:
            job = submit(c, "crash", {"how": "memory"}, wait=30).json()
            assert job["status"] == "failed"
            assert job["error"]["type"] == "/problems/out-of-memory"
            assert submit(c, "quality", {"mesh": SQUARE}, wait=10).json()["status"] == "succeeded"
