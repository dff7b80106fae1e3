"""Side by side: ``paving`` (ours, §8.5.1) and Gmsh's quad meshers, all-quad meshes.

Run from the repository root::

    .venv/bin/python benchmarks/paving.py                    # 10k and 100k quads
    .venv/bin/python benchmarks/paving.py --sizes 10000

Domains (polygons, circles sampled at about the mesh size with a multiple
of 4 vertices, :func:`benchmarks.grid._circle`; Gmsh gets the same
polygon as OpenCASCADE lines): the unit square minus a centred disk of
radius 0.25, the L-shape ``[0, 1]^2`` minus ``[0.5, 1]^2``, a plate (the
unit square with 5 x 4 round holes of radius 0.06) and a 24-tooth gear with
a round hole (:func:`benchmarks.grid.qg_domains`). Sizes
``h = sqrt(area / N)`` for about N quads. Peers (Gmsh,
``Mesh.MeshSizeMin = MeshSizeMax``, calibrated by a first untimed run to
about N quads, ``Mesh.RecombineAll = 1``, all
options set before ``generate``, one thread):
algorithm 8 (Frontal-Delaunay for quads) with ``RecombinationAlgorithm = 3``
(Blossom full-quad), algorithm 9 (packing of parallelograms), algorithm 11
(quasi-structured quad). Ours: ``paving`` with smoothing and clean-up
(timed after a warm-up call at about 2,000 quads on the same domain, which
loads numba's cache for every kernel the timed call reaches, the clean-up's too).

Columns: CPU seconds of the meshing call (the machine is shared: wall
times follow the load), wall seconds, quads (and triangles left, if any), least and mean
corner quality (8.4), least scaled Jacobian (the least
sine of a corner), the share of interior
vertices of valence 4, and irregular boundary vertices (a boundary vertex
whose count of quads differs from its interior angle over 90 degrees,
rounded, at least 1: 2 on a smooth side, 1 at a right-angle corner, 3 at
the L's reflex corner). Every run is a child process; Gmsh is a bench-only
dependency and is skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from benchmarks.grid import _circle  # noqa: E402 (the same domains)
from benchmarks.grid import qg_area as area  # noqa: E402
from benchmarks.grid import qg_domains as quad_grid_domains  # noqa: E402
from benchmarks.quads import ccw, gmsh_cells  # noqa: E402 (the peers' mesh readers)

DOMAINS = ("hole", "L", "plate", "gear")


def rings(domain: str, h: float) -> list[np.ndarray]:
    """The domain's rings (outer counter-clockwise, holes clockwise) for size h."""
    if domain == "L":
        return [np.array([[0.0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]])]
    sq = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    if domain == "hole":
        return [sq, _circle(0.5, 0.5, 0.25, h)]
    if domain == "plate":
        return [
            sq,
            *(
                _circle(0.1 + 0.2 * i, 0.125 + 0.25 * j, 0.06, h)
                for i in range(5)
                for j in range(4)
            ),
        ]
    return quad_grid_domains(h)["gear"][1]


def size_for(domain: str, n: int) -> float:
    """h = sqrt(area / n), the area at that size's sampling of the circles."""
    h = math.sqrt(area(rings(domain, 0.01)) / n)
    return math.sqrt(area(rings(domain, h)) / n)


def geometry(domain: str, h: float) -> dict:
    return {"type": "Polygon", "coordinates": [r.tolist() for r in rings(domain, h)]}


def gmsh_model(domain: str, h: float):
    import gmsh

    gmsh.initialize(["-noenv"])
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    occ = gmsh.model.occ
    loops = []
    for r in rings(domain, h):
        pts = [occ.addPoint(x, y, 0) for x, y in r]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        loops.append(occ.addCurveLoop(lines))
    occ.addPlaneSurface(loops)
    occ.synchronize()
    return gmsh


def valences(P, cells):
    """(share of interior vertices of valence 4, irregular boundary vertices)."""
    k = cells.shape[1]
    e = np.sort(np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    eu, cnt = np.unique(e, axis=0, return_counts=True)
    n = len(P)
    used = np.zeros(n, bool)
    used[cells.ravel()] = True
    deg = np.bincount(eu.ravel(), minlength=n)
    bnd_e = eu[cnt == 1]
    on_b = np.zeros(n, bool)
    on_b[bnd_e.ravel()] = True
    inner = used & ~on_b
    share4 = float(np.mean(deg[inner] == 4)) if inner.any() else 1.0
    # interior angle at each boundary vertex: sum of the cell corner angles there
    from meshcore.mesh.quality import cell_angles

    ang = cell_angles(P, cells, "quad" if k == 4 else "triangle")  # degrees, (m, k)
    total = np.bincount(cells.ravel(), weights=ang.ravel(), minlength=n)
    ncell = np.bincount(cells.ravel(), minlength=n)
    expect = np.maximum(np.rint(total / 90.0), 1)
    irregular = int(np.count_nonzero(on_b & (ncell != expect)))
    return share4, irregular


def describe(P, quads, triangles, seconds, cpu=float("nan")) -> dict:
    from meshcore.mesh.quality import quad_angles, quad_quality

    quads = ccw(P, quads)
    q = quad_quality(P, quads)
    # scaled Jacobian of a planar quad: the least sine of its corners
    sj = np.sin(np.radians(quad_angles(P, quads))).min(axis=1)
    share4, irregular = valences(P, quads) if not len(triangles) else (float("nan"), -1)
    return {
        "seconds": seconds,
        "cpu": cpu,
        "quads": int(len(quads)),
        "triangles": int(len(triangles)),
        "min": float(q.min()),
        "mean": float(q.mean()),
        "min_sj": float(sj.min()),
        "valence4": share4,
        "irregular_boundary": irregular,
    }


def gmsh_quads(domain: str, algo: int, h: float, n: int) -> dict:
    """Gmsh's quads, its size calibrated by a first (untimed) run to about n quads."""
    for calibrate in (True, False):
        gmsh = gmsh_model(domain, h)
        gmsh.option.setNumber("Mesh.Algorithm", algo)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        if algo == 8:
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
        t, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        if calibrate:
            h *= math.sqrt(max(len(cells["quad"]), 1) / n)
    return describe(P, cells["quad"], cells["triangle"], seconds, cpu)


def child(tool: str, domain: str, n: int) -> dict:
    h = size_for(domain, n)
    if tool.startswith("gmsh"):
        return gmsh_quads(domain, int(tool[4:]), h, n)
    from meshcore.quads import paving

    warm = size_for(domain, 2000)
    paving(geometry(domain, warm), size=warm)  # warm-up: numba's cache
    g = geometry(domain, h)
    t, c = time.perf_counter(), time.process_time()
    res = paving(g, size=h)
    seconds, cpu = time.perf_counter() - t, time.process_time() - c
    out = describe(res.mesh.points, res.mesh.cells[0].data, np.zeros((0, 3)), seconds, cpu)
    out["stats"] = {
        k: res.stats[k]
        for k in ("rows", "strips", "ladders", "fallback", "rows_taken_back", "seams", "clean_up")
    }
    out["phases"] = res.stats["seconds"]
    return out


def run_child(script: str, tool: str, domain: str, n: int, timeout: float) -> dict | str:
    try:
        out = subprocess.run(
            [sys.executable, script, "--child", tool, domain, str(n)],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
        )
    except subprocess.TimeoutExpired:
        return f"timeout {timeout:.0f} s"
    if out.returncode != 0:
        return out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"
    return json.loads(out.stdout.strip().splitlines()[-1])


def available(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


LABELS = {
    "gmsh8": "Gmsh 8 + Blossom full-quad (RecombinationAlgorithm 3)",
    "gmsh9": "Gmsh 9 (packing of parallelograms)",
    "gmsh11": "Gmsh 11 (quasi-structured)",
    "ours": "ours paving",
}

HEADER = (
    "| run | CPU s | wall s | quads | triangles | min Q | mean Q | min SJ | valence-4 interior | "
    "irregular boundary | CPU ratio ours / peer |"
)


def row(label: str, r, ours) -> str:
    if isinstance(r, str):
        return f"| {label} | {r} | | | | | | | | | |"
    ratio = ""
    if isinstance(ours, dict) and ours is not r:
        ratio = f"{ours['cpu'] / r['cpu']:.2f}"
    v4 = "" if math.isnan(r["valence4"]) else f"{100 * r['valence4']:.2f} %"
    irr = "" if r["irregular_boundary"] < 0 else str(r["irregular_boundary"])
    return (
        f"| {label} | {r['cpu']:.2f} | {r['seconds']:.2f} | {r['quads']:,} | {r['triangles']:,} | "
        f"{r['min']:.3f} | "
        f"{r['mean']:.3f} | {r['min_sj']:.3f} | {v4} | {irr} | {ratio} |"
    )


def main(script: str = __file__, child_fn=child, labels=LABELS, ours_tool="ours") -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000])
    ap.add_argument("--domains", nargs="*", default=list(DOMAINS))
    ap.add_argument("--timeout", type=float, default=300)
    ap.add_argument("--tools", nargs="*", default=list(labels), help="default: all")
    ap.add_argument("--child", nargs=3, metavar=("TOOL", "DOMAIN", "N"))
    args = ap.parse_args()
    if args.child:
        tool, domain, n = args.child
        print(json.dumps(child_fn(tool, domain, int(n))))
        return
    tools = [t for t in args.tools if not t.startswith("gmsh") or available("gmsh")]
    if not available("gmsh"):
        print("note: Gmsh not installed (pip install -e .[bench]): ours only")
    print(HEADER)
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for domain in args.domains:
        for n in args.sizes:
            print(f"| **{domain}, ~{n:,} cells** | | | | | | | | | | |", flush=True)
            res = {t: run_child(script, t, domain, n, args.timeout) for t in tools}
            for t in tools:
                ref = res.get(ours_tool + "-tri" if t.endswith("-tri") else ours_tool)
                print(row(labels[t], res[t], ref), flush=True)
            if isinstance(res.get(ours_tool), dict) and "stats" in res[ours_tool]:
                print(f"<!-- ours: {res[ours_tool]['stats']} {res[ours_tool]['phases']} -->")


if __name__ == "__main__":
    main()
