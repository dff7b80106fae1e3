"""Delaunay-admissible boundaries: Steiner points, ours vs Triangle's ``pD`` and ``pcD``.

Run from the repository root::

    .venv/bin/python benchmarks/admissible.py [--stars 1000,3000,10000]

For each polygon: the points each side adds to make its segments conforming,
and the output segments that are still not edges of the Delaunay
triangulation of the output points, counted by our exact test (our kernel,
exact predicates) for both sides. Ours makes every segment an edge
(§9.1.4). Triangle's ``pD`` only removes encroachment seen from inside the
domain (it deletes the triangles outside before it refines), so it may
leave some; ``pcD`` (``c``: the convex hull is triangulated and kept, so
every segment is refined from both sides) is Triangle's full conforming
Delaunay, the yardstick for the point count (``ours/pcD``). The CGAL
column is quoted from the issue (``make_conforming_Delaunay_2`` on the
issue's own star, 5°-corner polygon and ``la.poly``), not measured here: it
is a fixed reference, not a peer of this run (so is the issue's
prototype of the projection rule).

Inputs: a 50-vertex random star (sorted uniform angles, radii uniform in
[0.3, 1], seed 1: Triangle's ``pD`` adds 112 points to it, the issue's
figure for its star); eight 5° corners whose sides have lengths 0.75 and
0.225 (the "5°-corner polygon"); a comb of nine adjacent 5° spikes of
heights 4, 3, 1 (the tests' comb); Triangle's own ``A``, ``face`` and
``la`` (``triangle.get_data``, holes passed to Triangle). Triangle is a
bench-only dependency (``pip install -e .[bench]``); without it its column
and its data files are skipped with a note.

The last inputs are the random stars of issue 19 (same recipe, seed 1,
``--stars``). A star of ``n`` vertices is ``n`` spikes about ``2 pi / n``
wide and up to 0.7 long, and a conforming point set must resolve the gaps
between them, so both sides' counts grow about as ``n ** 1.8``: at 10,000
vertices ours adds about 476,000 points, Triangle's ``pcD`` millions (see
the README for this machine's figures).

``--phases N`` then runs the ``N``-vertex star once more with a CPU timer
around each phase (the compiled splitting loop, the protections of acute
vertices and their searches, the first triangulation, the renumbering of
the output, the growth of the arrays) and prints seconds, calls and
microseconds per added point: where the time goes.

Times are CPU seconds (``time.process_time``: this process alone, so a
loaded machine slows both sides alike), medians of three runs (one run
above 1,000 points unless ``--repeat`` says; ours after a warm-up on the
1,000-vertex star that loads every compiled function from numba's cache:
about 0.12 s, paid once per process);
``t ours/pcD`` is the ratio of CPU times. The machine's load average is
printed first.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from meshcore.delaunay.admissible import admissible_segments  # noqa: E402
from meshcore.delaunay.kernel2d import delaunay  # noqa: E402
from meshcore.mesh.topology import isin_ints, unique_ints  # noqa: E402

try:
    import triangle
except ImportError:  # bench extra not installed
    triangle = None

#: CGAL's make_conforming_Delaunay_2 on the issue's polygons (from the issue).
CGAL = {"star-50": 66, "corners-5deg": 48, "la": 53}
#: The issue's 40-line prototype of the §9.1.4 projection rule.
PROTOTYPE = {"star-50": 24, "corners-5deg": 15, "la": 36}


def ring(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, None]:
    i = np.arange(len(points))
    return points, np.column_stack([i, (i + 1) % len(points)]), None


def star(n: int = 50, seed: int = 1, r0: float = 0.3):
    rng = np.random.default_rng(seed)
    angle = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
    radius = rng.uniform(r0, 1.0, n)
    return ring(np.column_stack([radius * np.cos(angle), radius * np.sin(angle)]))


def corners(k: int = 8, degrees: float = 5.0, ratio: float = 0.3, r0: float = 0.25):
    """k spikes around the origin, each a 5° corner on the unit circle
    between sides of lengths 1 - r0 and ratio * (1 - r0)."""
    half = math.radians(degrees) / 2.0
    pts = []
    for i in range(k):
        a = 2.0 * math.pi * i / k
        tip = np.array([math.cos(a), math.sin(a)])
        d1 = np.array([math.cos(a + math.pi + half), math.sin(a + math.pi + half)])
        d2 = np.array([math.cos(a + math.pi - half), math.sin(a + math.pi - half)])
        pts += [tip + (1 - r0) * d1, tip, tip + ratio * (1 - r0) * d2]
    return ring(np.array(pts))


def comb(teeth: int = 9, degrees: float = 5.0, heights=(4.0, 3.0, 1.0)):
    pts, x = [], 0.0
    for i in range(teeth):
        h = heights[i % len(heights)]
        w = 2.0 * h * math.tan(math.radians(degrees / 2.0))
        pts += [[x, 0.0], [x + w / 2.0, h]]
        x += w
    pts += [[x, 0.0], [x, -1.0], [0.0, -1.0]]
    return ring(np.round(np.array(pts) * 2.0**20) / 2.0**20)


def triangle_data(name: str):
    d = triangle.get_data(name)
    holes = d.get("holes")
    return d["vertices"].astype(float), d["segments"].astype(np.int64), holes


def not_delaunay(points: np.ndarray, segments: np.ndarray) -> int:
    """Segments that are not edges of our (exact) Delaunay triangulation."""
    n = len(points)
    t = delaunay(points).triangles
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    edges = unique_ints(np.minimum(a, b) * n + np.maximum(a, b))
    s = np.asarray(segments, dtype=np.int64)
    keys = np.minimum(s[:, 0], s[:, 1]) * n + np.maximum(s[:, 0], s[:, 1])
    return int((~isin_ints(keys, edges)).sum())


def median_of(fn, repeat: int = 3):
    """Median CPU time of ``repeat`` runs and the last result."""
    times, out = [], None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        times.append(time.process_time() - t)
    return float(np.median(times)), out


def run_ours(points, segments, repeat=3):
    seconds, res = median_of(lambda: admissible_segments(points, segments), repeat)
    return res.added, not_delaunay(res.points, res.segments), seconds


def run_triangle(points, segments, holes, repeat=3, switches="pD"):
    data = {"vertices": points.copy(), "segments": segments.copy()}
    if holes is not None and len(holes):
        data["holes"] = np.asarray(holes, dtype=float)
    seconds, out = median_of(lambda: triangle.triangulate(data, switches), repeat)
    added = len(out["vertices"]) - len(points)
    return added, not_delaunay(out["vertices"], out["segments"]), seconds


#: The phases ``--phases`` times: (module, name) of each function wrapped.
PHASES = (
    ("admissible", "_split_loop"),
    ("admissible", "_protect"),
    ("admissible", "_segment_reach"),
    ("admissible", "delaunay"),
    ("pieces", "_disc_edges"),
    ("pieces", "_in_chain_order"),
    ("pieces", "_grown"),
    ("incremental", "_reserve"),
)


def phases(n: int) -> None:
    """CPU seconds per phase of ``admissible_segments`` on the ``n``-vertex star."""
    from collections import Counter

    import meshcore.delaunay.admissible as adm
    import meshcore.delaunay.admissible_pieces as pieces
    import meshcore.delaunay.kernel2d as kernel

    modules = {"admissible": adm, "pieces": pieces, "incremental": kernel.IncrementalDelaunay}
    spent: Counter = Counter()
    calls: Counter = Counter()
    saved = []

    def timed(name, fn):
        def wrapper(*args):
            t = time.process_time()
            try:
                return fn(*args)
            finally:
                spent[name] += time.process_time() - t
                calls[name] += 1

        return wrapper

    for mod, name in PHASES:
        fn = getattr(modules[mod], name)
        saved.append((modules[mod], name, fn))
        setattr(modules[mod], name, timed(f"{name} ({mod})" if name == "_reserve" else name, fn))
    try:
        points, segments, _ = star(n)
        t = time.process_time()
        res = adm.admissible_segments(points, segments)
        total = time.process_time() - t
    finally:
        for mod, name, fn in saved:
            setattr(mod, name, fn)
    print(f"\nphases of star-{n}: {res.added} points added, {res.rounds} passes, {total:.3f} CPU s")
    print(f"{'phase':<27}{'CPU s':>8}{'calls':>7}{'us/point':>10}")
    for name, sec in [*spent.most_common(), ("(rest: Python)", total - sum(spent.values()))]:
        print(f"{name:<27}{sec:>8.3f}{calls.get(name, 0):>7}{1e6 * sec / res.added:>10.2f}")
    print("\n(_grown and _reserve are the growth of the arrays, numpy copies: Python)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--stars", default="1000,3000,10000", help="vertex counts of the random stars"
    )
    parser.add_argument(
        "--phases", type=int, default=0, help="time the phases on a star of this many vertices"
    )
    parser.add_argument(
        "--repeat", type=int, default=0, help="runs per input (default: 3, 1 above 1,000 points)"
    )
    args = parser.parse_args()
    inputs = {"star-50": star(), "corners-5deg": corners(), "comb-5deg": comb()}
    if triangle is not None:
        for name in ("A", "face", "la"):
            inputs[name] = triangle_data(name)
    else:
        print("note: triangle is not installed (pip install -e .[bench]): its column and the")
        print("      A / face / la inputs are skipped\n")
    for n in (int(v) for v in args.stars.split(",") if v):
        inputs[f"star-{n}"] = star(n)
    admissible_segments(*star(1000)[:2])  # warm-up: loads every compiled function
    print("load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}\n".format(*os.getloadavg()))
    head = (
        f"{'input':<12}{'pts':>6} | {'ours +pts':>9}{'non-Del':>8}{'CPU s':>9} | "
        f"{'pD +pts':>9}{'non-Del':>8}{'CPU s':>8} | {'pcD +pts':>9}{'non-Del':>8}{'CPU s':>8} | "
        f"{'ours/pcD':>8}{'t ours/pcD':>11} | {'CGAL*':>5}{'proto*':>7}"
    )
    print(head)
    print("-" * len(head))
    for name, (points, segments, holes) in inputs.items():
        repeat = args.repeat or (1 if len(points) > 1000 else 3)
        ours, ours_left, ours_s = run_ours(points, segments, repeat)
        row = f"{name:<12}{len(points):>6} | {ours:>9}{ours_left:>8}{ours_s:>9.4f} | "
        if triangle is not None:
            pd, pd_left, pd_s = run_triangle(points, segments, holes, repeat)
            pcd, pcd_left, pcd_s = run_triangle(points, segments, holes, repeat, "pcD")
            ratio = f"{ours / pcd:.2f}" if pcd else "-"
            t_ratio = f"{ours_s / pcd_s:.1f}" if pcd_s else "-"
            row += f"{pd:>9}{pd_left:>8}{pd_s:>8.4f} | {pcd:>9}{pcd_left:>8}{pcd_s:>8.4f} | "
            row += f"{ratio:>8}{t_ratio:>11} | "
        else:
            row += f"{'-':>9}{'-':>8}{'-':>8} | {'-':>9}{'-':>8}{'-':>8} | {'-':>8}{'-':>11} | "
        row += f"{CGAL.get(name, '-'):>5}{PROTOTYPE.get(name, '-'):>7}"
        print(row, flush=True)
    print(
        "\n* CGAL (make_conforming_Delaunay_2) and the issue's 40-line prototype of the "
        "projection rule,\n  quoted from the issue on its own star, 5°-corner polygon and "
        "la.poly: fixed figures, not run here."
    )
    if args.phases:
        phases(args.phases)


if __name__ == "__main__":
    main()
