"""The API under many concurrent clients (issue 21's table).

Starts ``meshservice serve`` on a loopback port with a fresh data directory
(``MESHSERVICE_MAX_QUEUED`` and ``MESHSERVICE_MAX_STREAMS`` raised), then for
each client count N runs N clients at once, each submitting one job (a
quarter ``triangulate``, the rest ``quality``), following its event stream to
the end and fetching its result; a prober reads one job's status every 50 ms
meanwhile. Prints, per N: jobs completed, errors (connection resets
included), jobs per second, p50/p99 of a client's whole round trip, p99 of
the prober's status read.

    .venv/bin/python benchmarks/load.py [--clients 20 200 1000]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}
QUALITY = {"method": "quality", "params": {"mesh": SQUARE}}
TRIANGULATE = {
    "method": "triangulate",
    "params": {
        "domain": {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]},
        "size": 0.05,
    },
}


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def one_client(c: httpx.AsyncClient, k: int) -> float:
    body = TRIANGULATE if k % 4 == 0 else QUALITY
    t0 = time.perf_counter()
    r = await c.post("/v1/jobs", json=body)
    r.raise_for_status()
    job = r.json()["id"]
    async with c.stream("GET", f"/v1/jobs/{job}/events") as events:
        events.raise_for_status()
        async for line in events.aiter_lines():
            if line.startswith("event: end"):
                break
    r = await c.get(f"/v1/jobs/{job}/result")
    r.raise_for_status()
    json.loads(r.content)
    return time.perf_counter() - t0


def _prober(url: str, job: str, stop: threading.Event, out: list[float]) -> None:
    """Status reads every 50 ms from a thread of its own (not the clients' event loop,
    whose own load would otherwise count as the service's latency)."""
    with httpx.Client(base_url=url, timeout=30) as c:
        while not stop.is_set():
            t0 = time.perf_counter()
            c.get(f"/v1/jobs/{job}")
            out.append(time.perf_counter() - t0)
            stop.wait(0.05)


async def load_round(url: str, n: int, probe_job: str) -> dict:
    limits = httpx.Limits(max_connections=n + 10, max_keepalive_connections=n + 10)
    reads: list[float] = []
    stop = threading.Event()
    async with httpx.AsyncClient(base_url=url, timeout=300, limits=limits) as c:
        prober = threading.Thread(target=_prober, args=(url, probe_job, stop, reads))
        prober.start()
        t0 = time.perf_counter()
        results = await asyncio.gather(
            *(one_client(c, k) for k in range(n)), return_exceptions=True
        )
        wall = time.perf_counter() - t0
        stop.set()
        prober.join()
    times = [r for r in results if isinstance(r, float)]
    errors = [r for r in results if not isinstance(r, float)]
    for e in errors[:3]:
        print("client error:", "".join(traceback.format_exception(e))[-1500:], file=sys.stderr)
    return {
        "clients": n,
        "done": len(times),
        "errors": len(errors),
        "first_error": repr(errors[0])[:80] if errors else "",
        "jobs/s": len(times) / wall,
        "p50": float(np.percentile(times, 50)) if times else float("nan"),
        "p99": float(np.percentile(times, 99)) if times else float("nan"),
        "read p99 ms": 1e3 * float(np.percentile(reads, 99)) if reads else float("nan"),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--clients", type=int, nargs="+", default=[20, 200, 1000])
    parser.add_argument("--server-log", default=None, help="keep the server's log here")
    args = parser.parse_args()
    port = _port()
    url = f"http://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory() as data:
        env = {
            **os.environ,
            "MESHSERVICE_MAX_QUEUED": "100000",
            "MESHSERVICE_MAX_STREAMS": "100000",
        }
        log = open(args.server_log or Path(data) / "server.log", "wb")
        server = subprocess.Popen(
            [sys.executable, "-m", "service", "serve", "--port", str(port), "--data-dir", data],
            cwd=ROOT,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        print(f"server pid {server.pid} on port {port}", file=sys.stderr, flush=True)
        try:
            deadline = time.monotonic() + 300
            while True:
                try:
                    if httpx.get(url + "/readyz", timeout=1).status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if time.monotonic() > deadline or server.poll() is not None:
                    raise SystemExit("the server did not start")
                time.sleep(0.2)
            probe = httpx.post(url + "/v1/jobs", json=QUALITY, params={"wait": 10}).json()["id"]
            rows = [asyncio.run(load_round(url, n, probe)) for n in args.clients]
        finally:
            server.terminate()
            server.wait(30)
    cols = ["clients", "done", "errors", "jobs/s", "p50", "p99", "read p99 ms", "first_error"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for row in rows:
        cells = [f"{row[c]:.2f}" if isinstance(row[c], float) else str(row[c]) for c in cols]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
