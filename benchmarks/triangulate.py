"""Side by side: ``triangulate`` (ours), Triangle (C) and Gmsh, min angle 30 degrees.

Run from the repository root::

    .venv/bin/python benchmarks/triangulate.py                 # 10k, 100k, 1M triangles
    .venv/bin/python benchmarks/triangulate.py --sizes 10000 100000 --no-gmsh
    .venv/bin/python benchmarks/triangulate.py --scaling            # 10k .. 1M, ours and Triangle
    .venv/bin/python benchmarks/triangulate.py --scaling 10000 100000 1000000 10000000
    .venv/bin/python benchmarks/triangulate.py --small              # fixed costs of a small job

Inputs (one planar straight-line graph, the same for every tool):

* ``square-hole``: the unit square minus a disk of radius 0.25 (its circle
  sampled with 256 points), at about 10k, 100k and 1M triangles;
* ``star``: a random 50-vertex star polygon (angles down to 0.8 degrees);
* ``comb``: a bar with five spikes of apex angle 5 degrees;

each with the 30 degree bound alone (the mesh then follows the boundary)
and with an area bound giving about 100k triangles.

How each tool is asked for "about N triangles" (mean triangle area
``area / N``): Triangle ``pq30a<A>Q`` with ``A = area / (0.63 N)`` (its
triangles average 63 % of the bound); ours ``min_angle=30, max_area=A`` with
``A = area / (0.9 N)`` (the lattice lays triangles at 90 % of the bound);
Gmsh's default 2D algorithm (Frontal-Delaunay) with ``MeshSizeMin = MeshSizeMax
= h``, ``h`` the side of an equilateral triangle of area ``area / N``. Each
row reports the triangles actually made, so the throughput (triangles per
second) is the fair comparison; a last row gives Triangle and ours the *same*
area bound.

Every run is a child process: wall time of the meshing call only (ours
after a warm-up call that loads numba's cache; parsing the domain is not
timed), peak resident memory of the child (``getrusage``, whole process,
Python and imports included), and the quality of the result (smallest
angle, fraction of triangles with an angle under 30 degrees) computed by
:mod:`meshcore.mesh.quality`.

``--scaling``: the square with a hole at 10k, 100k, 1M (and, asked for,
10M) triangles, ours and Triangle only: seconds and peak memory of each,
the ratio, and the exponent ``b`` of ``seconds ~ triangles**b`` fitted by
least squares on the log-log points of each tool (1 is linear). The
10M-triangle runs need about 4 GB each: run them alone on a quiet machine.

``--small``: the star at 30 degrees alone (about 400 triangles), ours
(``triangulate`` of the parsed domain) and Triangle (``pq30Q``) in this
process, CPU milliseconds per call: the median of 3 batches of 200 calls
each, the batches of both tools alternating; the ratio ours / Triangle.
What a small job costs beyond the mesh itself (set-up, validation, the
admissible-boundary rounds, numba dispatch) shows here.

Triangle and Gmsh are bench-only dependencies (``pip install -e .[bench]``)
and are skipped with a note when absent.
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

TRIANGLE_FILL = 0.63  # Triangle's mean triangle area over its a-bound (measured)
OURS_FILL = 0.9  # ours: the lattice's triangle area over max_area (TOL.area_fill)


# ---------------------------------------------------------------------------
# Inputs: (points (n, 2), segments (m, 2), hole points, area)
# ---------------------------------------------------------------------------


def square_hole():
    th = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    circ = 0.5 + 0.25 * np.column_stack([np.cos(th), np.sin(th)])
    pts = np.vstack([[[0, 0], [1, 0], [1, 1], [0, 1]], circ])
    ring = [np.arange(4), 4 + np.arange(256)]
    return pts, ring, [[0.5, 0.5]]


def star():
    rng = np.random.default_rng(1)
    th = np.sort(rng.uniform(0, 2 * np.pi, 50))
    r = rng.uniform(0.3, 1.0, 50)
    return np.column_stack([r * np.cos(th), r * np.sin(th)]), [np.arange(50)], []


def comb(k=5, angle=5.0):
    w = 2 * math.tan(math.radians(angle / 2))
    pts = [[0.0, 0.0], [float(k), 0.0]]
    for i in range(k - 1, -1, -1):
        x = i + 0.5
        pts += [[i + 1.0, 0.3], [x + w / 2, 0.3], [x, 1.3], [x - w / 2, 0.3]]
    return np.asarray(pts), [np.arange(len(pts))], []


INPUTS = {"square-hole": square_hole, "star": star, "comb": comb}


def segments_of(rings):
    return np.concatenate([np.column_stack([r, np.roll(r, -1)]) for r in rings])


def geometry_of(pts, rings):
    return {"type": "Polygon", "coordinates": [pts[r].tolist() for r in rings]}


def area_of(pts, rings):
    a = 0.0
    for k, r in enumerate(rings):
        p = pts[r]
        s = 0.5 * abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
        a += s if k == 0 else -s
    return a


# ---------------------------------------------------------------------------
# Child runs
# ---------------------------------------------------------------------------


def _quality(points, triangles):
    from meshcore.mesh.quality import triangle_angles

    ang = triangle_angles(points, triangles).min(axis=1)
    return float(ang.min()), float(np.mean(ang < 30.0))


def child(tool: str, case: str, target: int) -> dict:
    """Run one tool on one input in this process and describe the result."""
    import resource

    pts, rings, holes = INPUTS[case]()
    area = area_of(pts, rings)
    mean_area = area / target if target else None
    if tool == "ours":
        from meshcore.domain.planar import parse_domain
        from meshcore.triangulation.refinement import triangulate

        domain = parse_domain(geometry_of(pts, rings))
        triangulate(parse_domain(geometry_of(*square_hole()[:2])), min_angle=30, max_area=1e-3)
        kw = {} if mean_area is None else {"max_area": mean_area / OURS_FILL}
        if os.environ.get("BENCH_SAME_A"):
            kw = {"max_area": float(os.environ["BENCH_SAME_A"])}
        t = time.perf_counter()
        res = triangulate(domain, min_angle=30, **kw)
        seconds = time.perf_counter() - t
        P, T = res.mesh.points, res.mesh.cells[0].data
    elif tool == "triangle":
        import triangle

        data = {"vertices": pts, "segments": segments_of(rings)}
        if holes:
            data["holes"] = np.asarray(holes, float)
        sw = "pq30Q"
        if mean_area is not None:
            sw = f"pq30a{mean_area / TRIANGLE_FILL:.17f}Q"
        if os.environ.get("BENCH_SAME_A"):
            sw = f"pq30a{float(os.environ['BENCH_SAME_A']):.17f}Q"
        t = time.perf_counter()
        out = triangle.triangulate(data, sw)
        seconds = time.perf_counter() - t
        P, T = out["vertices"], out["triangles"]
    elif tool == "gmsh":
        import gmsh

        h = math.sqrt(4 * mean_area / math.sqrt(3)) if mean_area else 0.1
        gmsh.initialize(["-noenv"])
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h if mean_area else 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        loops = []
        for r in rings:
            tags = [gmsh.model.geo.addPoint(float(x), float(y), 0.0, h) for x, y in pts[r]]
            lines = [
                gmsh.model.geo.addLine(tags[i], tags[(i + 1) % len(tags)]) for i in range(len(tags))
            ]
            loops.append(gmsh.model.geo.addCurveLoop(lines))
        gmsh.model.geo.addPlaneSurface(loops)
        gmsh.model.geo.synchronize()
        t = time.perf_counter()
        gmsh.model.mesh.generate(2)
        seconds = time.perf_counter() - t
        tags, coords, _ = gmsh.model.mesh.getNodes()
        P = coords.reshape(-1, 3)[:, :2]
        index = np.empty(int(tags.max()) + 1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        _, elem_nodes = gmsh.model.mesh.getElementsByType(2)
        T = index[elem_nodes.astype(np.int64).reshape(-1, 3)]
        gmsh.finalize()
    else:
        raise SystemExit(f"unknown tool {tool}")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    min_angle, under = _quality(np.asarray(P, float), np.asarray(T, np.int64))
    return {
        "triangles": int(len(T)),
        "seconds": seconds,
        "min_angle": min_angle,
        "under30": under,
        "peak_mb": peak,
    }


def run_child(tool: str, case: str, target: int, timeout: float, env_extra=None) -> dict | str:
    env = {**os.environ, **(env_extra or {})}
    try:
        out = subprocess.run(
            [sys.executable, __file__, "--child", tool, case, str(target)],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
            env=env,
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


# ---------------------------------------------------------------------------
# Table
# ---------------------------------------------------------------------------


def fmt_row(label, tool, r, ours):
    if isinstance(r, str):
        return f"| {label} | {tool} | {r} | | | | | | |"
    tps = r["triangles"] / r["seconds"]
    ratio = ""
    if tool != "ours" and isinstance(ours, dict):
        ours_tps = ours["triangles"] / ours["seconds"]
        ratio = f"{ours['seconds'] / r['seconds']:.2f} / {ours_tps / tps:.2f}"
    return (
        f"| {label} | {tool} | {r['triangles']:,} | {r['seconds']:.3f} | {tps / 1e6:.2f} M/s | "
        f"{r['min_angle']:.2f} | {100 * r['under30']:.3f} % | {r['peak_mb']:.0f} | {ratio} |"
    )


def fitted_exponent(sizes, seconds) -> float:
    """Least-squares slope of log(seconds) against log(size)."""
    if len(sizes) < 2:
        return float("nan")
    return float(np.polyfit(np.log(sizes), np.log(seconds), 1)[0])


def scaling(sizes, timeout: float) -> None:
    """Seconds and peak memory against size, ours and Triangle, one child each."""
    tools = ["ours"] + (["triangle"] if available("triangle") else [])
    print(
        "| target | ours triangles | ours s | ours peak MB | Triangle triangles | "
        "Triangle s | Triangle peak MB | ours/Triangle time |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    fits = {tool: ([], []) for tool in tools}
    for n in sizes:
        res = {tool: run_child(tool, "square-hole", n, timeout) for tool in tools}
        cells = []
        for tool in ("ours", "triangle"):
            r = res.get(tool, "skipped")
            if isinstance(r, dict):
                cells += [f"{r['triangles']:,}", f"{r['seconds']:.3f}", f"{r['peak_mb']:.0f}"]
                fits[tool][0].append(r["triangles"])
                fits[tool][1].append(r["seconds"])
            else:
                cells += [str(r), "", ""]
        ours, tri = res.get("ours"), res.get("triangle")
        ratio = (
            f"{ours['seconds'] / tri['seconds']:.2f}"
            if isinstance(ours, dict) and isinstance(tri, dict)
            else ""
        )
        print(f"| {n:,} | " + " | ".join(cells) + f" | {ratio} |", flush=True)
    for tool, (tris, secs) in fits.items():
        print(f"{tool}: seconds ~ triangles**{fitted_exponent(tris, secs):.3f}")


def small(calls: int = 200, batches: int = 3) -> None:
    """CPU ms per call on the star (q30 only), ours and Triangle, alternating batches."""
    from meshcore.domain.planar import parse_domain
    from meshcore.triangulation.refinement import triangulate

    pts, rings, _ = star()
    domain = parse_domain(geometry_of(pts, rings))
    runs = {"ours": lambda: triangulate(domain, min_angle=30)}
    if available("triangle"):
        import triangle

        data = {"vertices": pts, "segments": segments_of(rings)}
        runs["triangle"] = lambda: triangle.triangulate(data, "pq30Q")
    sizes = {
        "ours": len(runs["ours"]().mesh.cells[0].data),  # also loads numba's cache
        "triangle": len(runs["triangle"]()["triangles"]) if "triangle" in runs else 0,
    }
    times = {name: [] for name in runs}
    for _ in range(batches):
        for name, run in runs.items():
            t = time.process_time()
            for _ in range(calls):
                run()
            times[name].append(1e3 * (time.process_time() - t) / calls)
    print("load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    print("| tool | triangles | CPU ms per call (median of batches) | batches |")
    print("|---|---:|---:|---|")
    for name, ts in times.items():
        cells = ", ".join(f"{t:.2f}" for t in ts)
        print(f"| {name} | {sizes[name]} | {float(np.median(ts)):.2f} | {cells} |")
    if "triangle" in times:
        ratio = float(np.median(times["ours"])) / float(np.median(times["triangle"]))
        print(f"ours / Triangle: {ratio:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--no-gmsh", action="store_true")
    ap.add_argument("--timeout", type=float, default=600)
    ap.add_argument("--child", nargs=3, metavar=("TOOL", "CASE", "N"))
    ap.add_argument(
        "--scaling",
        type=int,
        nargs="*",
        metavar="N",
        help="scaling table of the square with a hole (default sizes 10k 100k 1M)",
    )
    ap.add_argument("--small", action="store_true", help="fixed costs: the star, many calls")
    args = ap.parse_args()
    if args.small:
        small()
        return
    if args.child:
        tool, case, n = args.child
        print(json.dumps(child(tool, case, int(n))))
        return
    if args.scaling is not None:
        scaling(args.scaling or [10_000, 100_000, 1_000_000], args.timeout)
        return
    tools = ["ours"]
    notes = []
    if available("triangle"):
        tools.append("triangle")
    else:
        notes.append("Triangle not installed (pip install -e .[bench]): skipped")
    if available("gmsh") and not args.no_gmsh:
        tools.append("gmsh")
    elif not args.no_gmsh:
        notes.append("Gmsh not installed (pip install -e .[bench]): skipped")
    rows = [("square-hole", n) for n in args.sizes]
    rows += [("star", 0), ("comb", 0), ("star", 100_000), ("comb", 100_000)]
    print(
        "| input | tool | triangles | seconds | triangles/s | min angle | under 30° | "
        "peak MB | ours/peer: time / throughput |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---|")
    for case, n in rows:
        label = f"{case} {'q30 only' if n == 0 else f'~{n:,}'}"
        results = {}
        for tool in tools:
            if tool == "gmsh" and n == 0:
                continue  # Gmsh has no angle bound to mesh "by quality only"
            results[tool] = run_child(tool, case, n, args.timeout)
            print(fmt_row(label, tool, results[tool], results.get("ours")), flush=True)
    if "triangle" in tools and args.sizes:
        n = max(args.sizes)
        pts, rings, _ = square_hole()
        a = area_of(pts, rings) / (TRIANGLE_FILL * n)
        label = f"square-hole same a={a:.3g}"
        env = {"BENCH_SAME_A": str(float(a))}
        ours = run_child("ours", "square-hole", n, args.timeout, env)
        print(fmt_row(label, "ours", ours, None))
        print(
            fmt_row(
                label, "triangle", run_child("triangle", "square-hole", n, args.timeout, env), ours
            )
        )
    for note in notes:
        print("note:", note)
    print(
        "ratios: ours/peer wall time (below 1: ours faster) / ours/peer triangles per second "
        "(above 1: ours faster)"
    )


if __name__ == "__main__":
    main()
