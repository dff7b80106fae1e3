"""Robustness probe: every method's example, mutated, posted to a real server.

Starts ``meshservice serve`` on a loopback port with a fresh data directory (or
uses ``--url``), with ``MESHSERVICE_JOB_TIME_LIMIT`` and
``MESHSERVICE_JOB_MEMORY_LIMIT`` set from ``--timeout`` and ``--memory``: each
job runs in a forked child under that memory and time limit. Then, for each
method's example (``GET /v1/methods``, the one openapi.yaml and the README
show) and a few variants (3D, point cloud, mesh input, patterns), it posts
mutations one by one: numeric fields set to 1e300, 1e-300, 0, -1, NaN,
Infinity, true, 1e12, 1e30, 1e-6; coordinates scaled by 1e±300, 1e±150,
moved to 1e6 or 1e15; spikes, cracks, near-duplicate and collinear vertices,
thin and degenerate shapes, touching holes, empty lists, wrong nesting;
meshes and surfaces scaled, flattened, opened, with bad indices.

Every answer must be a 2xx or a 4xx problem document (a failed job's
``error`` a 4xx). Flagged: ``500`` (any 5xx but the limits), ``HANG`` (the
job hit the time limit, 504, or the submit did not answer in time), ``OOM``
(507 out of memory), ``LAX`` (``true`` taken for a number). Prints one line
per probe (flagged ones marked ``!!``) and the counts; writes every outcome
as a JSON line to ``--out``. Not run by CI (1,163 probes take about 30
minutes with two workers on two busy cores):

    .venv/bin/python benchmarks/probe.py [--methods triangulate,grid] [--only scale]
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]

LENGTH_KEYS = {"size", "h", "radius", "outer_radius", "inner_radius", "tolerance", "margin"}
POSITION_KEYS = {"coordinates", "points", "nodes", "target", "center", "origin"}
BAD_NUMBERS = [1e300, 1e-300, 0, -1, "NaN", "Infinity", True, 10**12, 10**30, 1e-6]

UNIT_CUBE = {
    "points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]]
    + [[1, 1, 1]],
    "triangles": [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4], [2, 6, 7]]
    + [[2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]],
}
FAN = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]],
    "cells": [{"type": "triangle", "data": [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]}],
}


def circle(n: int, r: float = 1.0, cx: float = 0.0, cy: float = 0.0) -> list[list[float]]:
    t = [2 * math.pi * k / n for k in range(n)]
    return [[cx + r * math.cos(a), cy + r * math.sin(a)] for a in t]


DISK = {"type": "Polygon", "coordinates": [circle(48)]}

#: Variants beside the examples: method#variant -> params.
VARIANTS = {
    "recursive_partition#3d": {"surface": UNIT_CUBE, "size": 0.3},
    "optimize#mesh": {"mesh": FAN},
    "optimize#surface": {"surface": UNIT_CUBE, "size": 0.3},
    "quad_combine#mesh": {"mesh": FAN},
    "medial_axis#points": {"points": circle(64)},
    "delaunay_admissible#surface": {"surface": UNIT_CUBE},
    "pattern#hexagon": {"domain": DISK, "pattern": {"type": "hexagon", "size": 0.1}},
    "pattern#parallelogram": {
        "domain": DISK,
        "pattern": {"type": "parallelogram", "vectors": [[0.1, 0], [0.05, 0.1]]},
    },
}


# ---------------------------------------------------------------------------- mutations


def scaled(params, s: float, off: float = 0.0):
    """``params`` with positions scaled by ``s`` then moved by ``off``, lengths scaled."""

    def number(v):
        return isinstance(v, int | float) and not isinstance(v, bool)

    def positions(v):
        if isinstance(v, list) and v and all(number(x) for x in v):
            return [x * s + off for x in v]
        return [positions(x) for x in v] if isinstance(v, list) else v

    def lengths(v):
        if isinstance(v, list):
            return [lengths(x) for x in v]
        return v * s if number(v) else v

    def walk(v):
        if isinstance(v, list):
            return [walk(x) for x in v]
        if not isinstance(v, dict):
            return v
        out = {}
        for k, x in v.items():
            if k in POSITION_KEYS:
                out[k] = positions(x)
            elif k in LENGTH_KEYS and number(x):
                out[k] = x * s
            elif k == "max_area" and number(x):
                out[k] = x * s * s
            elif k in ("values", "radii", "vectors", "vector", "radius"):
                out[k] = lengths(x)
            else:
                out[k] = walk(x)
        return out

    return walk(params)


def with_path(params, path, value):
    p = copy.deepcopy(params)
    d = p
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value
    return p


def numeric_paths(params) -> list[tuple]:
    """Paths of the numbers of ``params`` outside its geometry (domain, meshes, surfaces)."""
    skip = {"domain", "mesh", "meshes", "surface", "source", "axis", "target", "points"}
    out = []

    def walk(v, path):
        if isinstance(v, dict):
            for k, x in v.items():
                if k not in skip:
                    walk(x, (*path, k))
        elif isinstance(v, list):
            for i, x in enumerate(v):
                walk(x, (*path, i))
        elif isinstance(v, int | float) and not isinstance(v, bool):
            out.append(path)

    walk(params, ())
    return out


def domain_mutations(ex: dict) -> dict:
    ring = [[float(x), float(y)] for x, y in ex["domain"]["coordinates"][0]]
    if ring[0] == ring[-1]:
        ring = ring[:-1]
    xs, ys = [v[0] for v in ring], [v[1] for v in ring]
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    w = x1 - x0

    def outer(new, holes=None):
        p = copy.deepcopy(ex)
        rest = p["domain"]["coordinates"][1:]
        p["domain"] = {"type": "Polygon", "coordinates": [new] + (rest if holes is None else holes)}
        if holes is not None:
            p.pop("curves", None)  # they name the example's rings
        return p

    a, b = ring[0], ring[1]
    ex_, ey_ = b[0] - a[0], b[1] - a[1]
    L = math.hypot(ex_, ey_)
    ux, uy, nx, ny = ex_ / L, ey_ / L, ey_ / L, -ex_ / L
    mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
    d = math.tan(math.radians(1e-6) / 2) * w
    foot = [[mx - ux * d, my - uy * d], [mx + ux * d, my + uy * d]]
    sq = [[0, 0], [4, 0], [4, 4], [0, 4]]
    m = {f"scale{s:g}": scaled(ex, s) for s in (1e300, 1e-300, 1e150, 1e-150)}
    m.update({f"offset{o:g}": scaled(ex, 1.0, o) for o in (1e6, 1e15)})
    m["scale1e-6_offset1e6"] = scaled(ex, 1e-6, 1e6)
    m["coords1e300_only"] = outer([[x * 1e300, y * 1e300] for x, y in ring], [])
    m["coords1e-300_only"] = outer([[x * 1e-300, y * 1e-300] for x, y in ring], [])
    m["spike1e-6deg"] = outer([a, foot[0], [mx + nx * w, my + ny * w], foot[1]] + ring[1:])
    m["crack"] = outer([a, foot[0], [mx - nx * 0.3 * w, my - ny * 0.3 * w], foot[1]] + ring[1:], [])
    for eps in (1e-15, 1e-9):
        m[f"near_dup{eps:g}"] = outer([a, [a[0] + eps * ux, a[1] + eps * uy]] + ring[1:])
    m["collinear1000"] = outer(
        [[a[0] + ex_ * k / 1000, a[1] + ey_ * k / 1000] for k in range(1000)] + ring[1:]
    )
    m["nearly_collinear1e-13"] = outer([a, [mx + nx * 1e-13 * L, my + ny * 1e-13 * L]] + ring[1:])
    m["hole_touch_vertex"] = outer(sq, [[[0, 0], [1, 2], [2, 1]]])
    m["hole_touch_edge"] = outer(sq, [[[2, 0], [3, 1], [1, 1]]])
    m["hole_near_outer1e-12"] = outer(sq, [[[2, 1e-12], [3, 1], [1, 1]]])
    m["bowtie"] = outer([[0, 0], [1, 1], [1, 0], [0, 1]], [])
    m["triangle"] = outer([[x0, y0], [x1, y0], [x0, y1]], [])
    m["thin_triangle1e-9"] = outer([[x0, y0], [x1, y0], [x0, y0 + 1e-9 * w]], [])
    m["strip1e-6"] = outer([[x0, y0], [x1, y0], [x1, y0 + 1e-6 * w], [x0, y0 + 1e-6 * w]], [])
    m["strip1e-9"] = outer([[x0, y0], [x1, y0], [x1, y0 + 1e-9 * w], [x0, y0 + 1e-9 * w]], [])
    m["aspect1e6"] = outer([[0, 0], [1e6, 0], [1e6, 1], [0, 1]], [])
    m["two_points"] = outer([[0, 0], [1, 0]], [])
    m["all_same"] = outer([[1, 1]] * 4, [])
    m["collinear_ring"] = outer([[0, 0], [1, 0], [2, 0], [3, 0]], [])
    m["empty_coordinates"] = with_path(ex, ("domain", "coordinates"), [])
    m["empty_ring"] = with_path(ex, ("domain", "coordinates"), [[]])
    m["nesting_too_deep"] = with_path(ex, ("domain", "coordinates"), [[ring]])
    m["nesting_flat"] = with_path(ex, ("domain", "coordinates"), ring)
    m["multipolygon_touching"] = with_path(
        ex,
        ("domain",),
        {
            "type": "MultiPolygon",
            "coordinates": [[[[0, 0], [1, 0], [1, 1], [0, 1]]], [[[1, 0], [2, 0], [2, 1], [1, 1]]]],
        },
    )
    m["coordinate_true"] = outer([[True, 0]] + ring[1:])
    m["coordinate_string"] = outer([["0", 0]] + ring[1:])
    m["coordinate_3d"] = outer([v + [0] for v in ring])
    m["circle1e5"] = outer(circle(100_000, 0.5 * w, (x0 + x1) / 2, (y0 + y1) / 2), [])
    return m


def mesh_mutations(key: str, ex: dict) -> dict:
    mesh = ex["meshes"][0] if key == "meshes" else ex[key]
    pts = mesh["points"]

    def put(**change):
        new = {**mesh, **change}
        return {**ex, "meshes": [new] + ex["meshes"][1:]} if key == "meshes" else {**ex, key: new}

    def tri(data):
        return put(cells=[{"type": "triangle", "data": data}])

    m = {f"mesh_scale{s:g}": put(points=[[x * s for x in p] for p in pts]) for s in (1e300, 1e-300)}
    m["mesh_offset1e15"] = put(points=[[x + 1e15 for x in p] for p in pts])
    m["mesh_all_same"] = put(points=[[1.0] * len(p) for p in pts])
    m["mesh_collinear"] = put(points=[[float(i)] + [0.0] * (len(p) - 1) for i, p in enumerate(pts)])
    m["mesh_no_cells"] = put(cells=[])
    m["mesh_empty_block"] = tri([])
    m["mesh_no_points"] = put(points=[])
    m["mesh_index_1e12"] = tri([[0, 1, 10**12]])
    m["mesh_index_2e63"] = tri([[0, 1, 2**63]])
    m["mesh_index_negative"] = tri([[0, 1, -1]])
    m["mesh_index_true"] = tri([[True, 1, 2]])
    m["mesh_index_half"] = tri([[0.5, 1, 2]])
    m["mesh_wrong_arity"] = tri([[0, 1]])
    m["mesh_repeated_point"] = tri([[0, 0, 1]])
    m["mesh_mixed_dimension"] = put(points=[pts[0] + [0]] + pts[1:])
    m["mesh_point_data_short"] = put(point_data={"a": [1.0]})
    m["mesh_cell_set_out_of_range"] = put(cell_sets={"a": [[99]]})
    return m


def surface_mutations(ex: dict) -> dict:
    s = ex["surface"]
    m = {f"surface_scale{k:g}": scaled(ex, k) for k in (1e300, 1e-300, 1e100, 1e-100)}
    m.update({f"surface_offset{o:g}": scaled(ex, 1.0, o) for o in (1e6, 1e15)})
    m["surface_flat"] = {**ex, "surface": {**s, "points": [[p[0], p[1], 0.0] for p in s["points"]]}}
    m["surface_open"] = {**ex, "surface": {**s, "triangles": s["triangles"][:-1]}}
    m["surface_empty"] = {**ex, "surface": {"points": [], "triangles": []}}
    m["surface_one_triangle"] = {
        **ex,
        "surface": {"points": s["points"][:3], "triangles": [[0, 1, 2]]},
    }
    m["surface_index_out_of_range"] = {
        **ex,
        "surface": {**s, "triangles": s["triangles"][:-1] + [[0, 1, 99]]},
    }
    m["surface_duplicate_triangle"] = {
        **ex,
        "surface": {**s, "triangles": s["triangles"] + [s["triangles"][0]]},
    }
    return m


def mutations(example: dict) -> dict:
    out = {}
    for path in numeric_paths(example):
        for v in BAD_NUMBERS:
            out[f"{'.'.join(map(str, path))}={v!r}"] = with_path(example, path, v)
    out["unknown_field"] = {**example, "zzz_unknown": 1}
    out["empty_params"] = {}
    out["params_list"] = []
    if "points" in example and "domain" not in example:
        out["cloud_two_points"] = {**example, "points": [[0, 0], [1, 0]]}
        out["cloud_collinear"] = {**example, "points": [[k, 0] for k in range(50)]}
        out["cloud_duplicates"] = {**example, "points": [[0, 0]] * 50}
        for s in (1e300, 1e-300):
            out[f"cloud_scale{s:g}"] = scaled(example, s)
        out["cloud_offset1e15"] = scaled(example, 1.0, 1e15)
        out["cloud_circle1e5"] = {**example, "points": circle(100_000)}
    if isinstance(example.get("domain"), dict):
        out.update(domain_mutations(example))
    for key in ("mesh", "source", "meshes"):
        if key in example:
            out.update(mesh_mutations(key, example))
    if "surface" in example:
        out.update(surface_mutations(example))
    return out


# ---------------------------------------------------------------------------- the server


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _serve(root: Path, data: str, port: int, args: argparse.Namespace) -> subprocess.Popen:
    env = {
        **os.environ,
        "PYTHONPATH": str(root),
        "MESHSERVICE_JOB_TIME_LIMIT": str(args.timeout),
        "MESHSERVICE_JOB_MEMORY_LIMIT": str(args.memory),
        "MESHSERVICE_WORKERS": str(args.workers),
        "MESHSERVICE_MAX_QUEUED": "10000",
        "MESHSERVICE_WARMUP": "false",
    }
    cmd = [sys.executable, "-m", "service", "serve", "--port", str(port), "--data-dir", data]
    return subprocess.Popen(cmd, cwd=root, env=env, stdout=subprocess.DEVNULL)


def _wait_ready(url: str, timeout: float = 600) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if httpx.get(url + "/readyz", timeout=2).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise RuntimeError("the service did not get ready")


def outcome(client: httpx.Client, method: str, params, timeout: float) -> tuple[str, str]:
    """(flag, what): flag '' for a 2xx or a 4xx, else '500', 'HANG' or 'OOM'."""
    body = {"method": method, "params": params}
    try:
        r = client.post("/v1/jobs", json=body, params={"wait": 30}, timeout=timeout + 60)
    except httpx.TimeoutException:
        return "HANG", "submit did not answer"
    if r.status_code >= 500:
        return "500", f"submit {r.status_code} {r.text[:200]}"
    if r.status_code >= 400:
        loc = ".".join(map(str, (r.json().get("errors") or [{"loc": ["-"]}])[0]["loc"]))
        return "", f"{r.status_code} @{loc}"
    job = r.json()
    end = time.monotonic() + timeout + 120
    while job["status"] in ("queued", "running") and time.monotonic() < end:
        job = client.get(f"/v1/jobs/{job['id']}", params={"wait": 30}, timeout=60).json()
    client.delete(f"/v1/jobs/{job['id']}")
    if job["status"] == "succeeded":
        return "", "ok"
    if job["status"] != "failed":
        return "HANG", f"still {job['status']}"
    err = job["error"]
    what = f"job {err['status']} {err['type'].rsplit('/', 1)[-1]}: {err['detail'][:160]}"
    if err["status"] == 504:
        return "HANG", what
    if err["status"] == 507 and "memory" in err["type"]:
        return "OOM", what
    return ("500" if err["status"] >= 500 else ""), what


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", help="a running server (else one is started)")
    parser.add_argument("--root", type=Path, default=ROOT, help="the checkout to serve")
    parser.add_argument("--methods", default="", help="comma-separated, method or method#variant")
    parser.add_argument("--only", default="", help="only mutations whose name holds this")
    parser.add_argument("--timeout", type=float, default=60.0, help="job time limit, seconds")
    parser.add_argument("--memory", type=int, default=8_000_000_000, help="job memory, bytes")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("probe.jsonl"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as data:
        proc = None
        url = args.url
        if url is None:
            port = _port()
            url = f"http://127.0.0.1:{port}"
            proc = _serve(args.root, data, port, args)
        try:
            _wait_ready(url)
            _sweep(url, args)
        finally:
            if proc is not None:
                proc.terminate()
                proc.wait(30)


def _sweep(url: str, args: argparse.Namespace) -> None:
    examples = {m["name"]: m["example"] for m in httpx.get(url + "/v1/methods").json()}
    examples.update({k: v for k, v in VARIANTS.items() if k.partition("#")[0] in examples})
    chosen = [m for m in args.methods.split(",") if m] or list(examples)
    probes = [
        (name, label, params)
        for name in chosen
        for label, params in mutations(examples[name]).items()
        if args.only in label
    ]
    counts: Counter = Counter()
    with httpx.Client(base_url=url) as client, args.out.open("w") as out:

        def run(probe):
            name, label, params = probe
            t0 = time.monotonic()
            flag, what = outcome(client, name.partition("#")[0], params, args.timeout)
            if label.endswith("=True") and not flag and not what.startswith("422"):
                flag = "LAX"  # true taken for a number
            return name, label, flag, what, time.monotonic() - t0

        with ThreadPoolExecutor(args.workers) as pool:
            for name, label, flag, what, wall in pool.map(run, probes):
                counts[flag or "fine"] += 1
                mark = "!!" if flag else "  "
                print(f"{mark} {name:28s} {label:30s} {wall:6.1f}s {what}", flush=True)
                row = {"method": name, "probe": label, "flag": flag, "what": what, "wall": wall}
                out.write(json.dumps(row) + "\n")
    print(f"{len(probes)} probes: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
