"""Round-trip latency of a small ``quality`` job through the live service.

Starts ``meshservice serve`` on a loopback port with a fresh data directory,
then measures ``POST /v1/jobs?wait=10`` for a small mesh (two triangles):
sequentially and with 8 concurrent clients (p50, p99, jobs per second), and
the same report computed in-process by calling meshcore directly; prints a
table with the ratio of the service round trip to the direct call.

    .venv/bin/python benchmarks/service.py [--jobs 300]
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx
import numpy as np

from meshcore.mesh import io, quality

ROOT = Path(__file__).resolve().parents[1]
SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}
BODY = {"method": "quality", "params": {"mesh": SQUARE}}


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _one(client: httpx.Client) -> float:
    t0 = time.perf_counter()
    r = client.post("/v1/jobs", json=BODY, params={"wait": 10})
    elapsed = time.perf_counter() - t0
    assert r.status_code == 200 and r.json()["status"] == "succeeded", r.text
    return elapsed


def _sequential(url: str, n: int) -> tuple[list[float], float]:
    with httpx.Client(base_url=url, timeout=30) as c:
        for _ in range(10):
            _one(c)
        t0 = time.perf_counter()
        times = [_one(c) for _ in range(n)]
        return times, time.perf_counter() - t0


def _concurrent(url: str, n: int, clients: int) -> tuple[list[float], float]:
    times: list[float] = []
    lock = threading.Lock()
    per = n // clients

    def work() -> None:
        with httpx.Client(base_url=url, timeout=60) as c:
            mine = [_one(c) for _ in range(per)]
        with lock:
            times.extend(mine)

    threads = [threading.Thread(target=work) for _ in range(clients)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return times, time.perf_counter() - t0


def _direct(n: int) -> list[float]:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        quality.report(io.from_json(SQUARE))
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=300)
    args = parser.parse_args()
    port = _port()
    with tempfile.TemporaryDirectory() as data:
        proc = subprocess.Popen(
            [sys.executable, "-m", "service", "serve", "--port", str(port), "--data-dir", data],
            cwd=ROOT,
            env={**os.environ},
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        url = f"http://127.0.0.1:{port}"
        try:
            for _ in range(300):
                try:
                    if httpx.get(url + "/readyz").status_code == 200:
                        break
                except httpx.HTTPError:
                    time.sleep(0.1)
            seq, seq_wall = _sequential(url, args.jobs)
            conc, conc_wall = _concurrent(url, args.jobs, 8)
        finally:
            proc.terminate()
            proc.wait(30)
    direct = _direct(args.jobs)

    def ms(values: list[float], q: float) -> float:
        return float(np.percentile(values, q) * 1000)

    d50 = ms(direct, 50)
    print(f"quality job on a 2-triangle mesh, {args.jobs} jobs, {os.cpu_count()} cores")
    print(f"{'run':<22}{'p50 ms':>9}{'p99 ms':>9}{'jobs/s':>9}{'p50 / direct':>14}")
    for name, values, wall in (
        ("service, sequential", seq, seq_wall),
        ("service, 8 clients", conc, conc_wall),
        ("meshcore direct", direct, sum(direct)),
    ):
        print(
            f"{name:<22}{ms(values, 50):>9.2f}{ms(values, 99):>9.2f}"
            f"{len(values) / wall:>9.1f}{ms(values, 50) / d50:>14.1f}"
        )


if __name__ == "__main__":
    main()
