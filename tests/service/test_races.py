"""A race harness on a live server: DELETE, cancel, expiry and downloads against jobs
at the moment they finish, at stepped delays (issue 22, items 1-3).

The job is ``echo_mesh`` of a grid large enough that writing and converting
its result take a while; its run time on this machine is measured first and
the delays step across it. Invariants, whatever the timing: no answer is a
500; after a 204 no file of the job remains; a download answers 200, 404 or
410; the unfinished-job limit holds under concurrent submits.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from tests.service.conftest import LiveServer, wait_status
from tests.service.test_jobs import submit

STEPS = 5


def grid(n: int) -> dict:
    """An n x n grid of quads."""
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    points = np.column_stack([x.ravel(), y.ravel()])
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)).ravel()
    quads = np.column_stack([i, i + 1, i + n + 2, i + n + 1])
    return {"points": points.tolist(), "cells": [{"type": "quad", "data": quads.tolist()}]}


MESH = grid(60)


def files_of(server, job_id: str) -> list:
    folder = server.data_dir / "jobs" / job_id
    return sorted(folder.rglob("*")) + ([folder] if folder.exists() else [])


@pytest.fixture(scope="module")
def racy(tmp_path_factory):
    server = LiveServer(
        tmp_path_factory.mktemp("races") / "data",
        MESHSERVICE_MAX_QUEUED="3",
        MESHSERVICE_RETENTION="4",  # expiry looks every second
    ).start()
    with server.client() as c:
        # the first job may wait for the job fork server to start (no warm-up): time the second
        for _ in range(2):
            started = time.monotonic()
            job = submit(c, "echo_mesh", {"mesh": MESH}, wait=30).json()
            assert job["status"] == "succeeded"
            server.run_time = time.monotonic() - started
            c.delete(f"/v1/jobs/{job['id']}")
    yield server
    server.stop()


def delays(run_time: float) -> list[float]:
    return list(np.linspace(0.3 * run_time, 1.3 * run_time, STEPS))


def test_delete_as_the_job_finishes_leaves_no_file(racy):
    with racy.client() as c:
        for delay in delays(racy.run_time):
            job = submit(c, "echo_mesh", {"mesh": MESH}).json()
            time.sleep(delay)
            r = c.delete(f"/v1/jobs/{job['id']}")
            assert r.status_code == 204, (delay, r.text)
            assert files_of(racy, job["id"]) == [], delay
            assert c.get(f"/v1/jobs/{job['id']}").status_code == 404


def test_cancel_as_the_job_finishes_answers_the_final_state(racy):
    with racy.client() as c:
        for delay in delays(racy.run_time):
            job = submit(c, "echo_mesh", {"mesh": MESH}).json()
            time.sleep(delay)
            r = c.post(f"/v1/jobs/{job['id']}/cancel")
            assert r.status_code == 200, (delay, r.text)
            done = wait_status(c, job["id"], {"succeeded", "cancelled"})
            assert done["status"] in ("succeeded", "cancelled"), done
            assert c.delete(f"/v1/jobs/{job['id']}").status_code == 204
            assert files_of(racy, job["id"]) == []


@pytest.mark.parametrize("fmt", ["vtu", "xdmf", "abaqus"])
def test_delete_during_a_download_answers_404_or_410_and_leaves_no_file(racy, fmt):
    with racy.client() as c:
        for delay in np.linspace(0, 0.6 * racy.run_time, 2):
            job = submit(c, "echo_mesh", {"mesh": MESH}, wait=30).json()
            answers = []

            def download(job_id=job["id"], answers=answers):
                with racy.client() as d:
                    answers.append(d.get(f"/v1/jobs/{job_id}/result", params={"format": fmt}))

            thread = threading.Thread(target=download)
            thread.start()
            time.sleep(delay)
            assert c.delete(f"/v1/jobs/{job['id']}").status_code == 204
            assert files_of(racy, job["id"]) == [], delay
            thread.join(60)
            assert answers[0].status_code in (200, 404, 410), (delay, answers[0].text[:300])
            time.sleep(0.2)  # a conversion the DELETE overtook must not write afterwards
            assert files_of(racy, job["id"]) == [], delay


def test_expiry_during_downloads_never_answers_500(racy):
    with racy.client() as c:
        job = submit(c, "echo_mesh", {"mesh": MESH}, wait=30).json()
        url = f"/v1/jobs/{job['id']}"
        deadline = time.monotonic() + 30
        codes = []
        while time.monotonic() < deadline and (not codes or codes[-1] == 200):
            for fmt in ("vtu", "xdmf", "abaqus", None):
                # conversions are cached: drop them, so that each download converts again
                for cached in (racy.data_dir / "jobs" / job["id"]).glob("result.[vxa]*"):
                    cached.unlink(missing_ok=True)
                r = c.get(f"{url}/result", params={"format": fmt} if fmt else {})
                assert r.status_code in (200, 404, 410), r.text[:300]
                codes.append(r.status_code)
                if r.status_code != 200:
                    break
        assert codes[-1] in (404, 410), "the result never expired"
        assert files_of(racy, job["id"]) == []


def test_unfinished_limit_holds_under_concurrent_submits(racy):
    def post(_):
        with racy.client() as c:
            return submit(c, "sleep", {"seconds": 2})

    with ThreadPoolExecutor(20) as pool:
        answers = list(pool.map(post, range(20)))
    assert sorted(r.status_code for r in answers) == [202] * 3 + [429] * 17
    with racy.client() as c:
        for r in answers:
            if r.status_code == 202:
                assert c.delete(f"/v1/jobs/{r.json()['id']}").status_code == 204
