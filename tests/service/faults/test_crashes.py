"""Repeated crashes under a steady load: every acknowledged job ends, none is lost.

``MESHSERVICE_FAULT_ROUNDS`` sets the rounds (CI: 3; the long run: 20).
"""

from __future__ import annotations

import os
import random
import signal
import threading
import time

import httpx
import psutil

from tests.service.conftest import LiveServer, wait_status

ROUNDS = int(os.environ.get("MESHSERVICE_FAULT_ROUNDS", "3"))
MAX_ATTEMPTS = 3


class Load:
    """Submits a short job every 0.1 s, each with its own key: about what two workers
    run (jobs of 0–0.3 s), so the queue stays short and the check does not wait on it."""

    def __init__(self, server: LiveServer) -> None:
        self.server = server
        self.acked: dict[str, str] = {}  # idempotency key -> job id
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.count = 0

    def _run(self) -> None:
        with httpx.Client(timeout=5) as c:
            while not self.stop.is_set():
                key = f"load-{self.count}"
                self.count += 1
                body = {"method": "sleep", "params": {"seconds": random.choice([0, 0.1, 0.3])}}
                try:
                    r = c.post(
                        self.server.url + "/v1/jobs", json=body, headers={"Idempotency-Key": key}
                    )
                    if r.status_code in (200, 202):
                        self.acked[key] = r.json()["id"]
                except httpx.HTTPError:
                    pass  # the API is down: not acknowledged
                time.sleep(0.1)

    def __enter__(self) -> Load:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join(10)


def _check_every_job(server: LiveServer, acked: dict[str, str]) -> None:
    assert acked, "no job was acknowledged"
    with server.client() as c:
        for key, job_id in acked.items():
            job = wait_status(c, job_id, {"succeeded", "failed", "cancelled"}, timeout=60)
            assert job["status"] in ("succeeded", "failed"), job
            if job["status"] == "failed":
                assert job["error"]["detail"], job
            assert job["attempt"] <= MAX_ATTEMPTS, job
            replay = c.post(
                "/v1/jobs",
                json={"method": "sleep", "params": {"seconds": 0}},
                headers={"Idempotency-Key": key},
            )
            # the same key names the same job whatever the body: 200/202 same id, or 422
            if replay.status_code in (200, 202):
                assert replay.json()["id"] == job_id


def test_the_api_killed_at_random_moments_loses_no_job(tmp_path):
    server = LiveServer(tmp_path / "data", MESHSERVICE_MAX_QUEUED="10000").start()
    rng = random.Random(7)
    try:
        with Load(server) as load:
            for _ in range(ROUNDS):
                time.sleep(rng.uniform(0.3, 1.5))
                server.stop(signal.SIGKILL)
                server.start()
        _check_every_job(server, load.acked)
    finally:
        server.stop()


def test_job_processes_killed_at_random_fail_alone_with_a_reason(tmp_path):
    server = LiveServer(tmp_path / "data", MESHSERVICE_MAX_QUEUED="10000").start()
    rng = random.Random(11)
    killed = 0
    try:
        with Load(server) as load:
            api = psutil.Process(server.proc.pid)

            def job_processes() -> list[psutil.Process]:
                # grandchildren of the API (children of its fork server)
                return [p for child in api.children() for p in child.children()]

            # without the warm-up, the fork server may still be starting
            deadline = time.monotonic() + 60
            while not job_processes() and time.monotonic() < deadline:
                time.sleep(0.05)
            for _ in range(ROUNDS * 3):
                time.sleep(rng.uniform(0.1, 0.5))
                jobs = job_processes()
                if jobs:
                    try:
                        rng.choice(jobs).send_signal(signal.SIGKILL)
                        killed += 1
                    except psutil.NoSuchProcess:
                        pass
        _check_every_job(server, load.acked)
        with server.client() as c:
            ended = [c.get(f"/v1/jobs/{j}").json() for j in load.acked.values()]
            died = [j for j in ended if j["status"] == "failed"]
            assert all(j["error"]["type"] == "/problems/worker-died" for j in died), died
        assert killed > 0
    finally:
        server.stop()
