"""The ``dask`` executor on a real cluster: a scheduler and two workers on loopback.

The processes are started with the same commands as docker/compose.yaml
(``dask scheduler``, a stock ``dask worker`` under its nanny, so daemonic,
the API with MESHSERVICE_DASK_SCHEDULER).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from tests.service.conftest import ROOT, spawn_listening, wait_status
from tests.service.test_jobs import pid_alive, submit, wait_file

BIN = Path(sys.executable).parent
WORKER_ENV = {"PYTHONPATH": str(ROOT)}


def _parent(pid: int) -> int:
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


def _cmdline(pid: int) -> str:
    with open(f"/proc/{pid}/cmdline", "rb") as f:
        return f.read().replace(b"\0", b" ").decode(errors="replace")


def _worker_running(pid: int, cluster: Cluster) -> int:
    """The worker process above job process ``pid``: the ancestor whose parent is one of
    the cluster's nannies (the ``dask worker`` processes it started)."""
    nannies = {proc.pid for proc in cluster.procs}
    chain = [pid]
    while chain[-1] > 1:
        parent = _parent(chain[-1])
        if parent in nannies:
            return chain[-1]
        chain.append(parent)
    raise AssertionError(f"no worker above the job's process: {[_cmdline(p) for p in chain]}")


class Cluster:
    def __init__(self, logs: Path) -> None:
        self.port = 0  # the scheduler's, once started
        self.logs = logs
        self.procs: list[subprocess.Popen] = []

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def start(self, workers: int = 2) -> Cluster:
        """Start the scheduler, and the workers once it listens on its port itself
        (``spawn_listening``: a port taken meanwhile moves the scheduler to another, and
        no worker joins whatever has it)."""
        popen = {"cwd": ROOT, "env": {**os.environ, **WORKER_ENV}}
        scheduler, self.port = spawn_listening(
            lambda port: [
                str(BIN / "dask"),
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
            ],
            self.logs / "scheduler.log",
            time.monotonic() + 60,
            **popen,
        )
        self.procs.append(scheduler)
        for i in range(workers):
            args = ["worker", self.address, "--nthreads", "1", "--no-dashboard", "--name", f"w{i}"]
            with open(self.logs / f"worker{i}.log", "ab") as log:
                self.procs.append(
                    subprocess.Popen(
                        [str(BIN / "dask"), *args], stdout=log, stderr=subprocess.STDOUT, **popen
                    )
                )
        return self

    def stop(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.procs:
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    c = Cluster(tmp_path_factory.mktemp("dask"))
    try:
        yield c.start()
    finally:
        c.stop()


@pytest.fixture
def dask_server(start_server, cluster):
    server = start_server(MESHSERVICE_DASK_SCHEDULER=cluster.address)
    deadline = time.monotonic() + 60
    with server.client() as c:
        while c.get("/readyz").json().get("workers", 0) < 2:
            assert time.monotonic() < deadline, "the two workers never joined"
            time.sleep(0.2)
    return server


def _is_daemon() -> bool:
    import multiprocessing

    return multiprocessing.current_process().daemon


class TestDask:
    def test_workers_are_stock_daemonic_processes(self, cluster):
        from distributed import Client

        with Client(cluster.address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
            assert set(client.run(_is_daemon).values()) == {True}

    def test_readyz_reports_scheduler_and_workers(self, dask_server, cluster):
        ready = httpx.get(dask_server.url + "/readyz").json()
        assert ready == {
            "status": "ready",
            "executor": "dask",
            "scheduler": cluster.address,
            "workers": 2,
        }

    def test_same_result_as_local(self, dask_server, start_server):
        mesh = {
            "points": [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 4, 3], [1, 2, 5, 4]]}],
        }
        with dask_server.client() as c:
            remote = submit(c, "quality", {"mesh": mesh}).json()
            # a job's process on a worker is a new interpreter: its imports take a moment
            remote = wait_status(c, remote["id"], {"succeeded", "failed"}, timeout=120)
            assert remote["status"] == "succeeded", remote
            remote_result = c.get(f"/v1/jobs/{remote['id']}/result").content
        # a local server of its own, not the shared warmed-up one: this module then needs
        # no numba kernel, and runs while the cache is being filled (tests/conftest.py)
        with start_server().client() as c:
            local = submit(c, "quality", {"mesh": mesh}, wait=30).json()
            assert c.get(f"/v1/jobs/{local['id']}/result").content == remote_result

    def test_progress_reaches_the_job(self, dask_server):
        with dask_server.client() as c:
            job = submit(c, "sleep", {"seconds": 1.5}).json()
            deadline = time.monotonic() + 30
            while True:
                state = c.get(f"/v1/jobs/{job['id']}").json()
                if 0 < state["progress"]["fraction"] < 1 or time.monotonic() > deadline:
                    break
                time.sleep(0.05)
            assert 0 < state["progress"]["fraction"] < 1
            assert wait_status(c, job["id"], {"succeeded"})["status"] == "succeeded"

    def test_cancel_kills_the_process_on_the_worker(self, dask_server, tmp_path):
        marker = tmp_path / "pid"
        with dask_server.client() as c:
            job = submit(c, "sleep", {"seconds": 60, "marker": str(marker)}).json()
            pid = int(wait_file(marker, 60))
            assert c.post(f"/v1/jobs/{job['id']}/cancel").json()["status"] == "cancelled"
            deadline = time.monotonic() + 10
            while pid_alive(pid) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert not pid_alive(pid)

    def test_time_limit_kills_the_process_on_the_worker(self, start_server, cluster, tmp_path):
        server = start_server(
            MESHSERVICE_DASK_SCHEDULER=cluster.address, MESHSERVICE_JOB_TIME_LIMIT="15"
        )
        marker = tmp_path / "pid"
        with server.client() as c:
            job = submit(c, "sleep", {"seconds": 60, "marker": str(marker)}).json()
            pid = int(wait_file(marker, 60))
            job = wait_status(c, job["id"], {"failed"}, timeout=60)
            assert job["error"]["type"] == "/problems/time-limit"
            deadline = time.monotonic() + 10
            while pid_alive(pid) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert not pid_alive(pid)

    def test_killed_worker_reruns_the_job_elsewhere(self, dask_server, cluster, tmp_path):
        marker = tmp_path / "pids"
        with dask_server.client() as c:
            job = submit(c, "sleep", {"seconds": 3, "marker": str(marker)}).json()
            child = int(wait_file(marker, 60).split()[0])
            os.kill(_worker_running(child, cluster), signal.SIGKILL)
            job = wait_status(c, job["id"], {"succeeded", "failed"}, timeout=120)
            assert job["status"] == "succeeded", job
            assert job["attempt"] == 2
            assert len(marker.read_text().split()) == 2

    def test_restart_of_the_api_loses_nothing(self, start_server, cluster, tmp_path):
        server = start_server(MESHSERVICE_DASK_SCHEDULER=cluster.address)
        marker = tmp_path / "pid"
        with server.client() as c:
            running = submit(c, "sleep", {"seconds": 2, "marker": str(marker)}).json()
            wait_file(marker, 60)
            queued = [submit(c, "sleep", {"seconds": 0.2}).json() for _ in range(3)]
        server.stop(signal.SIGKILL)
        again = start_server(data_dir=server.data_dir, MESHSERVICE_DASK_SCHEDULER=cluster.address)
        with again.client() as c:
            for job in (running, *queued):
                done = wait_status(c, job["id"], {"succeeded", "failed"}, timeout=120)
                assert done["status"] == "succeeded", done
            assert c.get(f"/v1/jobs/{running['id']}").json()["attempt"] == 2

    def test_run_cancelled_by_the_scheduler_is_requeued(self, dask_server, cluster, tmp_path):
        """Issue 22: a run the scheduler cancels (neither a user's cancel nor shutdown)
        goes back to the queue instead of failing as an internal error."""
        from distributed import Client, Future

        marker = tmp_path / "pids"
        with dask_server.client() as c:
            job = submit(c, "sleep", {"seconds": 1, "marker": str(marker)}).json()
            wait_file(marker, 60)
            with Client(cluster.address, timeout=30) as other:

                def keys(dask_scheduler):
                    return [k for k in dask_scheduler.tasks if str(k).startswith("meshservice-")]

                running = [k for k in other.run_on_scheduler(keys) if job["id"] in k]
                assert len(running) == 1
                other.cancel([Future(running[0], client=other)], force=True)
            done = wait_status(c, job["id"], {"succeeded", "failed", "cancelled"}, timeout=60)
            assert done["status"] == "succeeded", done
            assert done["attempt"] == 2
            assert len(marker.read_text().split()) == 2  # it ran again
