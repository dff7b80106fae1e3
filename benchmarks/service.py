"""The service end to end: small-job latency, a large job's downloads, a fresh start.

``small`` (the default) starts ``meshservice serve`` on a loopback port with a
fresh data directory, then measures ``POST /v1/jobs?wait=10`` for a small mesh
(two triangles): sequentially and with 8 concurrent clients (p50, p99, jobs
per second), and the same report computed in-process by calling meshcore
directly; prints a table with the ratio of the service round trip to the
direct call.

``large`` runs one ``triangulate`` job of 1.29M triangles (the square with a
circular hole of the method's example at ``size=0.0012``) and times the
first and second request of its result in every download format and of its
previews, with the size of each answer; the ratio column is the first
request over the job's own run time (the target is below 0.5).

``submit`` posts a 1M-vertex domain (about 35 MB of JSON) three times to one
server and reports the time of each call and the server's peak memory above
its size just before (its ``VmHWM`` reset then), and their medians.
``stages`` runs the submit's own steps on the same body in this process
(body buffer, coordinates extraction, validation, ``params.npz``) and
reports their CPU time and peak allocations (tracemalloc), medians of 3.

``fresh`` starts the service with an empty numba cache (``NUMBA_CACHE_DIR``
in a temporary directory) and reports when the port answers and when
``/readyz`` says ready. ``--root DIR`` runs the service from another checkout
(for before/after tables).

    .venv/bin/python benchmarks/service.py [small|large|fresh|submit|stages]
        [--jobs 300] [--root DIR]
"""

from __future__ import annotations

import argparse
import json
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


def _serve(root: Path, data: str, port: int, **env: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "service", "serve", "--port", str(port), "--data-dir", data],
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(root), **env},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _wait_ready(url: str, timeout: float = 900) -> tuple[float, float]:
    """Seconds until the port answers, and until ``/readyz`` says ready."""
    t0 = time.perf_counter()
    opened = None
    while time.perf_counter() - t0 < timeout:
        try:
            r = httpx.get(url + "/readyz", timeout=2)
        except httpx.HTTPError:
            time.sleep(0.05)
            continue
        if opened is None:
            opened = time.perf_counter() - t0
        if r.status_code == 200:
            return opened, time.perf_counter() - t0
        time.sleep(0.05)
    raise RuntimeError("the service did not get ready")


def _small(args: argparse.Namespace) -> None:
    port = _port()
    with tempfile.TemporaryDirectory() as data:
        proc = _serve(args.root, data, port)
        url = f"http://127.0.0.1:{port}"
        try:
            _wait_ready(url)
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


LARGE_FORMATS = ("vtu", "gmsh", "gmsh22", "xdmf", "stl", "ply", "obj", "abaqus")


def _timed_get(c: httpx.Client, path: str, **params: str) -> tuple[int, float, int]:
    t0 = time.perf_counter()
    r = c.get(path, params=params)
    return r.status_code, time.perf_counter() - t0, len(r.content)


def _large(args: argparse.Namespace) -> None:
    # the triangulate method's example (this file's name hides the service package)
    angles = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    hole = np.column_stack([0.5 + 0.25 * np.cos(angles), 0.5 + 0.25 * np.sin(angles)])
    params = {
        "domain": {"type": "Polygon", "coordinates": [SQUARE["points"], hole.tolist()]},
        "curves": [{"ring": 1, "type": "circle", "center": [0.5, 0.5], "radius": 0.25}],
        "min_angle": 30,
        "size": 0.0012,
    }
    body = {"method": "triangulate", "params": params}
    port = _port()
    with tempfile.TemporaryDirectory() as data:
        proc = _serve(args.root, data, port, MESHSERVICE_WORKERS="1")
        url = f"http://127.0.0.1:{port}"
        try:
            _wait_ready(url)
            with httpx.Client(base_url=url, timeout=300) as c:
                job = c.post("/v1/jobs", json=body).json()
                while job["status"] not in ("succeeded", "failed", "cancelled"):
                    job = c.get(f"/v1/jobs/{job['id']}", params={"wait": 10}).json()
                assert job["status"] == "succeeded", job
                run = _seconds(job["finished_at"]) - _seconds(job["started_at"])
                base = f"/v1/jobs/{job['id']}"
                rows = [("result (JSON)", base + "/result", {})]
                rows += [(f"?format={f}", base + "/result", {"format": f}) for f in LARGE_FORMATS]
                rows += [(p, f"{base}/{p}", {}) for p in ("preview.svg", "preview.png")]
                table = []
                for name, path, params in rows:
                    status, first, size = _timed_get(c, path, **params)
                    _, second, _ = _timed_get(c, path, **params)
                    table.append((name, status, first, second, size))
        finally:
            proc.terminate()
            proc.wait(30)
    print(f"triangulate job of 1.29M triangles: run {run:.2f} s, {os.cpu_count()} cores")
    print(f"{'request':<18}{'status':>7}{'first s':>9}{'second s':>10}{'MB':>8}{'first/run':>11}")
    for name, status, first, second, size in table:
        print(
            f"{name:<18}{status:>7}{first:>9.2f}{second:>10.3f}{size / 1e6:>8.1f}"
            f"{first / run:>11.2f}"
        )


def _seconds(stamp: str) -> float:
    from datetime import datetime

    return datetime.fromisoformat(stamp).timestamp()


def _fresh(args: argparse.Namespace) -> None:
    port = _port()
    with tempfile.TemporaryDirectory() as data, tempfile.TemporaryDirectory() as cache:
        proc = _serve(args.root, data, port, NUMBA_CACHE_DIR=cache)
        try:
            opened, ready = _wait_ready(f"http://127.0.0.1:{port}")
        finally:
            proc.terminate()
            proc.wait(30)
    print(f"fresh start (empty numba cache), {os.cpu_count()} cores")
    print(f"{'port answers s':>15}{'ready s':>9}")
    print(f"{opened:>15.2f}{ready:>9.2f}")


def _rss(pid: int, field: str) -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(field)


def _big_submit(args: argparse.Namespace) -> None:
    """Submit a 1M-vertex domain (a circle's ring) three times and measure each call: time
    and the server's peak memory above its size just before (medians printed last)."""
    n = 1_000_000
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles)]).round(12).tolist()
    body = {
        "method": "triangulate",
        "params": {"domain": {"type": "Polygon", "coordinates": [ring]}, "empty": True},
    }
    payload = json.dumps(body).encode()
    del ring, body
    port = _port()
    rows = []
    with tempfile.TemporaryDirectory() as data:
        proc = _serve(args.root, data, port, MESHSERVICE_WORKERS="1")
        url = f"http://127.0.0.1:{port}"
        try:
            _wait_ready(url)
            with httpx.Client(base_url=url, timeout=300) as c:
                c.post("/v1/jobs", json={"method": "quality", "params": {"mesh": SQUARE}})
                for _ in range(3):
                    before = _rss(proc.pid, "VmRSS")
                    with open(f"/proc/{proc.pid}/clear_refs", "w") as f:
                        f.write("5")  # reset the peak (VmHWM) to the current size
                    t0 = time.perf_counter()
                    r = c.post(
                        "/v1/jobs", content=payload, headers={"Content-Type": "application/json"}
                    )
                    elapsed = time.perf_counter() - t0
                    peak = _rss(proc.pid, "VmHWM")
                    assert r.status_code == 202, r.text[:500]
                    c.post(f"/v1/jobs/{r.json()['id']}/cancel")
                    rows.append((elapsed, (peak - before) / 1e6))
        finally:
            proc.terminate()
            proc.wait(30)
    size = len(payload)
    print(f"submit of a {n}-vertex domain ({size / 1e6:.1f} MB of JSON), {os.cpu_count()} cores")
    print(f"{'call':>6}{'call s':>8}{'peak above idle MB':>20}{'peak / body':>13}")
    for k, (elapsed, mb) in enumerate(rows):
        print(f"{k + 1:>6}{elapsed:>8.2f}{mb:>20.0f}{mb * 1e6 / size:>13.2f}")
    elapsed, mb = (float(np.median(col)) for col in zip(*rows, strict=True))
    print(f"{'median':>6}{elapsed:>8.2f}{mb:>20.0f}{mb * 1e6 / size:>13.2f}")


def _submit_stages(args: argparse.Namespace) -> None:
    """The submit's own steps on a 1M-vertex body in this process, three times: CPU
    seconds and the peak of allocations (tracemalloc) from the body's buffer on."""
    import gc
    import tracemalloc

    # This script's folder is first on the path and its name shadows the package.
    here = Path(__file__).resolve().parent
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != here]
    sys.modules.pop("service", None)
    from service import bodies
    from service.methods.domain_schema import ARRAYS, PACK, pack_arrays, write_npz
    from service.methods.registry import default_registry

    n = 1_000_000
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles)]).round(12).tolist()
    params = {"domain": {"type": "Polygon", "coordinates": [ring]}, "empty": True}
    payload = json.dumps(params).encode()
    del ring, params
    model = default_registry()["triangulate"].params

    def submit(out: Path) -> None:
        buf = bytearray(payload)  # the body as the API reads it
        body, arrays = bodies.extract_coordinates(buf)
        parsed = model.model_validate_json(body, context={ARRAYS: arrays})
        del buf, body, arrays
        parsed.check()
        packed: dict = {}
        parsed.model_dump_json(context={PACK: packed})
        with open(out, "wb") as f:
            write_npz(pack_arrays(packed), f)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "params.npz"
        submit(out)  # compile
        for _ in range(3):
            gc.collect()
            tracemalloc.start()
            t0 = time.process_time()
            submit(out)
            cpu = time.process_time() - t0
            rows.append((cpu, tracemalloc.get_traced_memory()[1] / 1e6))
            tracemalloc.stop()
    size = len(payload) / 1e6
    print(f"submit steps of a {n}-vertex domain ({size:.1f} MB of JSON), in process")
    print(f"{'run':>6}{'CPU s':>8}{'peak MB':>9}{'peak / body':>13}")
    for k, (cpu, mb) in enumerate(rows):
        print(f"{k + 1:>6}{cpu:>8.2f}{mb:>9.1f}{mb / size:>13.2f}")
    cpu, mb = (float(np.median(col)) for col in zip(*rows, strict=True))
    print(f"{'median':>6}{cpu:>8.2f}{mb:>9.1f}{mb / size:>13.2f}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument(
        "mode",
        nargs="?",
        default="small",
        choices=("small", "large", "fresh", "submit", "stages"),
    )
    parser.add_argument("--jobs", type=int, default=300)
    parser.add_argument("--root", type=Path, default=ROOT, help="the checkout to serve from")
    args = parser.parse_args()
    modes = {
        "small": _small,
        "large": _large,
        "fresh": _fresh,
        "submit": _big_submit,
        "stages": _submit_stages,
    }
    modes[args.mode](args)


if __name__ == "__main__":
    main()
