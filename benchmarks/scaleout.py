"""Throughput of the ``local`` executor against ``dask`` on the same machine.

Starts a Dask scheduler with 2 single-threaded workers and two services
(one with 2 local worker processes, one on the cluster), then in one run:

- 200 medium jobs (``triangulate`` of a square with a hole to about 50k
  triangles), all submitted at once: wall time and jobs per second;
- 100 tiny ``quality`` jobs one after the other with ``?wait=``: the p50
  round trip, whose difference between the two is the dask path's overhead
  per job.

    .venv/bin/python benchmarks/scaleout.py [--jobs 200]
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
ENV = {
    **os.environ,
    "DASK_DISTRIBUTED__WORKER__DAEMON": "False",
    "MESHSERVICE_MAX_QUEUED": "100000",
}


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _ring(cx: float, cy: float, r: float, n: int) -> list[list[float]]:
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)]).tolist()


MEDIUM = {
    "method": "triangulate",
    "params": {
        "domain": {
            "type": "Polygon",
            "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], _ring(0.5, 0.5, 0.2, 200)[::-1]],
        },
        "size": 0.0065,
        "min_angle": 30,
    },
}
TINY = {
    "method": "quality",
    "params": {
        "mesh": {
            "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
            "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
        }
    },
}


def _wait_ready(url: str, workers: int | None = None) -> None:
    for _ in range(600):
        try:
            r = httpx.get(url + "/readyz")
            if r.status_code == 200 and (workers is None or r.json()["workers"] >= workers):
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"{url} never became ready")


def _throughput(url: str, n: int) -> tuple[float, int]:
    with httpx.Client(base_url=url, timeout=120) as c:
        t0 = time.perf_counter()
        answers = [c.post("/v1/jobs", json=MEDIUM) for _ in range(n)]
        assert all(a.status_code == 202 for a in answers), answers[0].text
        ids = [a.json()["id"] for a in answers]

        def finish(job_id: str) -> str:
            while True:
                job = c.get(f"/v1/jobs/{job_id}", params={"wait": 30}).json()
                if job["status"] in ("succeeded", "failed", "cancelled"):
                    return job["status"]

        with ThreadPoolExecutor(16) as pool:
            statuses = list(pool.map(finish, ids))
        wall = time.perf_counter() - t0
        triangles = c.get(f"/v1/jobs/{ids[0]}/result").json()["quality"]["triangle"]["count"]
    assert statuses.count("succeeded") == n, statuses
    return wall, triangles


def _latency(url: str, n: int) -> float:
    with httpx.Client(base_url=url, timeout=60) as c:
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            assert c.post("/v1/jobs", json=TINY, params={"wait": 10}).status_code == 200
            times.append(time.perf_counter() - t0)
    return float(np.median(times[5:]))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=200)
    args = parser.parse_args()
    procs = []
    sport, local_port, dask_port = _port(), _port(), _port()
    address = f"tcp://127.0.0.1:{sport}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": ROOT, "env": ENV}
    with tempfile.TemporaryDirectory() as tmp:
        try:
            procs.append(
                subprocess.Popen(
                    [
                        str(BIN / "dask"),
                        "scheduler",
                        "--host",
                        "127.0.0.1",
                        "--port",
                        str(sport),
                        "--no-dashboard",
                    ],
                    **quiet,
                )
            )
            for _ in range(2):
                procs.append(
                    subprocess.Popen(
                        [str(BIN / "dask"), "worker", address, "--nthreads", "1", "--no-dashboard"],
                        **quiet,
                    )
                )
            for port, extra in (
                (local_port, {}),
                (dask_port, {"MESHSERVICE_DASK_SCHEDULER": address}),
            ):
                procs.append(
                    subprocess.Popen(
                        [
                            str(BIN / "meshservice"),
                            "serve",
                            "--port",
                            str(port),
                            "--workers",
                            "2",
                            "--data-dir",
                            f"{tmp}/{port}",
                        ],
                        **{**quiet, "env": {**ENV, **extra}},
                    )
                )
            local, dask = f"http://127.0.0.1:{local_port}", f"http://127.0.0.1:{dask_port}"
            _wait_ready(local)
            _wait_ready(dask, workers=2)
            rows = []
            for name, url in (("local, 2 processes", local), ("dask, 2 workers", dask)):
                _throughput(url, 4)  # warm up
                wall, triangles = _throughput(url, args.jobs)
                rows.append((name, wall, args.jobs / wall, _latency(url, 100) * 1000))
        finally:
            for p in reversed(procs):
                p.terminate()
            for p in procs:
                p.wait(30)
    print(f"{args.jobs} triangulate jobs of {triangles} triangles each; 2 cores")
    print(f"{'executor':<22}{'wall s':>9}{'jobs/s':>9}{'tiny job p50 ms':>17}")
    for name, wall, rate, p50 in rows:
        print(f"{name:<22}{wall:>9.2f}{rate:>9.2f}{p50:>17.1f}")
    per_job = (rows[1][1] - rows[0][1]) / args.jobs * 1000
    print(
        f"dask overhead per job: {per_job:.1f} ms (throughput), "
        f"{rows[1][3] - rows[0][3]:.1f} ms (tiny job round trip)"
    )


if __name__ == "__main__":
    main()
