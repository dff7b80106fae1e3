"""The API under many concurrent clients (issue 21's table).

Starts ``meshservice serve`` on a loopback port with a fresh data directory
(``MESHSERVICE_MAX_QUEUED`` and ``MESHSERVICE_MAX_STREAMS`` raised), then for
each client count N runs N clients at once, each with its own connection,
submitting one job (a quarter ``triangulate``, the rest ``quality``),
following its event stream to the end and fetching its result; a prober in a
process of its own reads one job's status every 50 ms meanwhile. The clients
run at a lower CPU priority than the service and the prober (they stand for
clients on other machines; on 2 cores they would otherwise take the
service's share). Prints, per N: jobs completed, errors (connection resets
included), jobs per second, p50/p99 of a client's whole round trip, p99 of
the prober's status read over the round and after the last submit was
answered (streams held, workers saturated).

    .venv/bin/python benchmarks/load.py [--clients 20 200 1000]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing
import os
import queue
import socket
import ssl
import subprocess
import sys
import tempfile
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


#: Niceness of the clients: on this one machine they stand for clients elsewhere, so they
#: must not take the service's CPU share (the service and the prober keep theirs).
CLIENT_NICE = 5


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def one_client(url: str, k: int, tls: ssl.SSLContext, acked: list[float]) -> float:
    """One client of its own (its own connection, as N real clients have): submit,
    follow the event stream to its end, fetch the result; the round trip's seconds.
    ``tls``: one context shared by all (httpx builds one per client otherwise, 50 ms);
    ``acked``: gets the time (monotonic) the submit was answered."""
    body = TRIANGULATE if k % 4 == 0 else QUALITY
    t0 = time.perf_counter()
    async with httpx.AsyncClient(base_url=url, timeout=300, verify=tls) as c:
        r = await c.post("/v1/jobs", json=body)
        r.raise_for_status()
        acked.append(time.monotonic())
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


def _probe(url: str, job: str, stop, out) -> None:
    with httpx.Client(base_url=url, timeout=30) as c:
        while not stop.is_set():
            t0 = time.monotonic()
            c.get(f"/v1/jobs/{job}").raise_for_status()
            out.put((t0, time.monotonic() - t0))
            stop.wait(0.05)
    out.put(None)


class Prober:
    """Reads one job's status every 50 ms, in a process of its own started before the
    clients lower their priority (:data:`CLIENT_NICE`): neither the clients' event loop,
    their GIL nor their CPU share counts as the service's latency."""

    def __init__(self, url: str, job: str) -> None:
        ctx = multiprocessing.get_context("fork")  # the benchmark may be loaded from a path
        self._stop, self._out = ctx.Event(), ctx.Queue()
        self._proc = ctx.Process(target=_probe, args=(url, job, self._stop, self._out))
        self._reads: list[tuple[float, float]] = []

    def __enter__(self) -> Prober:
        self._proc.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._drain(block=True)
        self._proc.join()

    def _drain(self, block: bool) -> None:
        while True:
            try:
                read = self._out.get(block=block)
            except queue.Empty:
                return
            if read is None:
                return
            self._reads.append(read)

    def latencies(self, since: float, until: float) -> list[float]:
        """Seconds of each read that started between ``since`` and ``until`` (monotonic)."""
        time.sleep(0.2)  # the reads in flight
        self._drain(block=False)
        return [dt for t, dt in self._reads if since <= t <= until]


async def load_round(url: str, n: int, prober: Prober) -> dict:
    """``n`` clients at once (:func:`one_client`), the ``prober`` reading beside them.

    Status reads are reported over the whole round and over its part after the
    last submit was answered (the streams held, the workers saturated, no burst
    of submits queued in front of the read)."""
    t0 = time.monotonic()
    tls = ssl.create_default_context()
    acked: list[float] = []
    clients = (one_client(url, k, tls, acked) for k in range(n))
    results = await asyncio.gather(*clients, return_exceptions=True)
    wall = time.monotonic() - t0
    reads = prober.latencies(t0, t0 + wall)
    held = prober.latencies(max(acked, default=t0), t0 + wall)
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
        "held read p99 ms": 1e3 * float(np.percentile(held, 99)) if held else float("nan"),
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
            with Prober(url, probe) as prober:
                os.nice(CLIENT_NICE)
                rows = [asyncio.run(load_round(url, n, prober)) for n in args.clients]
        finally:
            server.terminate()
            server.wait(30)
    cols = ["clients", "done", "errors", "jobs/s", "p50", "p99", "read p99 ms", "held read p99 ms"]
    cols.append("first_error")
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for row in rows:
        cells = [f"{row[c]:.2f}" if isinstance(row[c], float) else str(row[c]) for c in cols]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
