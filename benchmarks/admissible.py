"""Delaunay-admissible boundaries: Steiner points, ours vs Triangle's ``pD``.

Run from the repository root::

    .venv/bin/python benchmarks/admissible.py

For each polygon: the points each side adds to make its segments conforming,
and the output segments that are still not edges of the Delaunay
triangulation of the output points, counted by our exact test (our kernel,
exact predicates) for both sides. Ours makes every segment an edge
(§9.1.4); Triangle's ``pD`` only removes encroachment seen from inside the
domain, so it may leave some. The CGAL column is quoted from the issue
(``make_conforming_Delaunay_2`` on the issue's own star, 5°-corner polygon
and ``la.poly``), not measured here: it is a fixed reference, not a peer of
this run.

Inputs: a 50-vertex random star (sorted uniform angles, radii uniform in
[0.3, 1], seed 1: Triangle's ``pD`` adds 112 points to it, the issue's
figure for its star); eight 5° corners whose sides have lengths 0.75 and
0.225 (the "5°-corner polygon"); a comb of nine adjacent 5° spikes of
heights 4, 3, 1 (the tests' comb); Triangle's own ``A``, ``face`` and
``la`` (``triangle.get_data``, holes passed to Triangle). Triangle is a
bench-only dependency (``pip install -e .[bench]``); without it its column
and its data files are skipped with a note.

A last input is the pathological one of issue 19: a 10,000-vertex random
star (same recipe, seed 1), where ours adds about 604,000 points in 146
rounds (each spike's chain of splits is sequential). Each round inserts its
points into one growing triangulation and re-checks only the pieces its
insertions may have removed; it took 126 s when every round
re-triangulated everything.

Times are the medians of three runs (one run for the 10k star; ours after
a warm-up that loads numba's cache); ``t ours/pD`` is the ratio of times.
The machine's load average is printed first: on a shared machine the
ratios, not the seconds, are what compare.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from meshcore.delaunay.admissible import admissible_segments  # noqa: E402
from meshcore.delaunay.kernel2d import delaunay  # noqa: E402

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
    edges = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    s = np.asarray(segments, dtype=np.int64)
    keys = np.minimum(s[:, 0], s[:, 1]) * n + np.maximum(s[:, 0], s[:, 1])
    return int((~np.isin(keys, edges)).sum())


def median_of(fn, repeat: int = 3):
    """Median wall time of ``repeat`` runs and the last result."""
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), out


def run_ours(points, segments, repeat=3):
    seconds, res = median_of(lambda: admissible_segments(points, segments), repeat)
    return res.added, not_delaunay(res.points, res.segments), seconds


def run_triangle(points, segments, holes, repeat=3):
    data = {"vertices": points.copy(), "segments": segments.copy()}
    if holes is not None and len(holes):
        data["holes"] = np.asarray(holes, dtype=float)
    seconds, out = median_of(lambda: triangle.triangulate(data, "pD"), repeat)
    added = len(out["vertices"]) - len(points)
    return added, not_delaunay(out["vertices"], out["segments"]), seconds


def main() -> None:
    inputs = {"star-50": star(), "corners-5deg": corners(), "comb-5deg": comb()}
    if triangle is not None:
        for name in ("A", "face", "la"):
            inputs[name] = triangle_data(name)
    else:
        print("note: triangle is not installed (pip install -e .[bench]): its column and the")
        print("      A / face / la inputs are skipped\n")
    inputs["star-10000"] = star(10_000)
    admissible_segments(*star(10)[:2])  # warm-up: numba's cache
    print("load average (1, 5, 15 min): {:.1f} {:.1f} {:.1f}\n".format(*os.getloadavg()))
    head = (
        f"{'input':<13}{'pts':>6}{'segs':>6} | {'ours +pts':>9}{'non-Del':>8}{'ms':>9} | "
        f"{'pD +pts':>9}{'non-Del':>9}{'ms':>9} | {'ours/pD':>7}{'t ours/pD':>10} | "
        f"{'CGAL*':>5}{'proto*':>7}"
    )
    print(head)
    print("-" * len(head))
    for name, (points, segments, holes) in inputs.items():
        repeat = 1 if len(points) > 1000 else 3
        ours, ours_left, ours_s = run_ours(points, segments, repeat)
        row = f"{name:<13}{len(points):>6}{len(segments):>6} | {ours:>9}{ours_left:>8}"
        row += f"{1e3 * ours_s:>9.1f} | "
        if triangle is not None:
            pd, pd_left, pd_s = run_triangle(points, segments, holes, repeat)
            ratio = f"{ours / pd:.2f}" if pd else "-"
            row += f"{pd:>9}{pd_left:>9}{1e3 * pd_s:>9.1f} | {ratio:>7}{ours_s / pd_s:>10.1f} | "
        else:
            row += f"{'-':>9}{'-':>9}{'-':>9} | {'-':>7}{'-':>10} | "
        row += f"{CGAL.get(name, '-'):>5}{PROTOTYPE.get(name, '-'):>7}"
        print(row)
    print(
        "\n* CGAL (make_conforming_Delaunay_2) and the issue's 40-line prototype of the "
        "projection rule,\n  quoted from the issue on its own star, 5°-corner polygon and "
        "la.poly: fixed figures, not run here."
    )


if __name__ == "__main__":
    main()
