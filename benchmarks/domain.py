"""Time :func:`meshcore.domain.planar.parse_domain` on large boundaries.

Prints one row per input: the number of boundary vertices, the median of
three CPU times of the whole validation (structure, duplicates, exact
intersection test of every segment pair the grid proposes, hole containment,
orientation, exact area), the peak memory one validation allocates
(tracemalloc: the returned domain included, its 16 MB of points for 1M
vertices, the segments being derived on first use; plus a 16 MB copy of a
writable input array); and, when shapely is installed
(``pip install shapely``), the median of three CPU times of GEOS's validity
check ``shapely.is_valid`` on the same polygon (construction excluded) and
the ratio ours / GEOS. GEOS answers a yes/no with a reason; we also
normalize orientation and compute the area.

Inputs: a circle and a 2 x 1 rectangle (250k points per side: long collinear
runs) with 1M vertices each, given as numpy arrays (the circle also as a
read-only array, as the service hands it over) and as JSON-style lists
(what the service hands over); a plate with 10,000 holes of 100 vertices
(containment of many rings); the 1M circle with 10,000 interior constraint
segments (a 100 x 100 grid of short dashes); a random star of 100k
vertices, whose long edges run side by side (quadratic for both).

Run with ``.venv/bin/python benchmarks/domain.py``.
"""

from __future__ import annotations

import os
import sys
import time
import tracemalloc

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from meshcore.domain.planar import parse_domain  # noqa: E402  (this checkout's, not an installed one)

try:
    import shapely
except ImportError:  # the peer is optional
    shapely = None


def circle(n: int, r: float = 1.0, center=(0.0, 0.0), reverse: bool = False) -> np.ndarray:
    t = 2 * np.pi * np.arange(n) / n
    if reverse:
        t = -t
    return np.column_stack([center[0] + r * np.cos(t), center[1] + r * np.sin(t)])


def rectangle(per_side: int) -> np.ndarray:
    t = np.arange(per_side) / per_side
    return np.concatenate(
        [
            np.column_stack([2 * t, 0 * t]),
            np.column_stack([2 + 0 * t, t]),
            np.column_stack([2 - 2 * t, 1 + 0 * t]),
            np.column_stack([0 * t, 1 - t]),
        ]
    )


def spike_fan(n: int) -> np.ndarray:
    """A star with n vertices at random radii in [1, 1.3]: long, nearly radial edges
    packed side by side, the worst case of a grid (and of GEOS's chain index)."""
    t = 2 * np.pi * np.arange(n) / n
    r = 1 + 0.3 * np.random.default_rng(0).random(n)
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


def plate_with_holes(k: int, m: int) -> list[np.ndarray]:
    """A k x k grid of circular holes (m vertices each) in a square plate."""
    outer = np.array([[0.0, 0.0], [k, 0.0], [k, k], [0.0, k]])
    holes = [circle(m, 0.3, (i + 0.5, j + 0.5), reverse=True) for i in range(k) for j in range(k)]
    return [outer, *holes]


def chords(k: int) -> list[list[list[float]]]:
    """k * k short horizontal constraint segments on a grid inside the unit disk."""
    g = (np.arange(k) + 0.5) / k * 1.2 - 0.6
    x, y = np.meshgrid(g, g, indexing="ij")
    half = 0.25 * 1.2 / k
    return [[[a - half, b], [a + half, b]] for a, b in zip(x.ravel(), y.ravel(), strict=True)]


def median_of(f, repeat: int = 3) -> float:
    """Median CPU seconds of ``repeat`` calls (CPU time: the machine is shared)."""
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        f()
        times.append(time.process_time() - t0)
    return float(np.median(times))


def peak_mb(f) -> float:
    """Peak memory a call allocates (tracemalloc, numpy's arrays included), MB."""
    tracemalloc.start()
    try:
        f()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def main() -> None:
    one_million = circle(1_000_000)
    rect = rectangle(250_000)
    frozen = one_million.copy()  # read-only: parse_domain uses it without a copy
    frozen.setflags(write=False)
    plate = plate_with_holes(100, 100)
    cases = [
        ("circle, 1M vertices (array)", [one_million], None),
        ("circle, 1M vertices (read-only)", [frozen], None),
        ("circle, 1M vertices (lists)", [one_million.tolist()], None),
        ("rectangle 250k per side (array)", [rect], None),
        ("rectangle 250k per side (lists)", [rect.tolist()], None),
        ("plate, 10k holes x 100 vertices", plate, None),
        ("circle 1M + 10k constraints", [one_million], chords(100)),
        ("random star 100k (spike fan)", [spike_fan(100_000)], None),
    ]
    parse_domain({"type": "Polygon", "coordinates": [circle(100)]})  # warm up numba
    head = f"{'input':34s} {'vertices':>9s} {'ours [s]':>9s} {'peak MB':>8s}"
    head += f" {'GEOS [s]':>9s} {'ours/GEOS':>9s}"
    print(head)
    print("-" * len(head))
    for name, rings, segments in cases:
        geometry = {"type": "Polygon", "coordinates": rings}
        domain = parse_domain(geometry, segments)
        ours = median_of(lambda g=geometry, s=segments: parse_domain(g, s))
        peak = peak_mb(lambda g=geometry, s=segments: parse_domain(g, s))
        n = domain.boundary_point_count
        row = f"{name:34s} {n:9d} {ours:9.3f} {peak:8.1f}"
        if shapely is not None and segments is None:
            poly = shapely.Polygon(np.asarray(rings[0]), [np.asarray(h) for h in rings[1:]])
            geos = median_of(lambda p=poly: shapely.is_valid(p))
            row += f" {geos:9.3f} {ours / geos:9.2f}"
        else:
            row += f" {'-':>9s} {'-':>9s}"
        print(row)
    if shapely is None:
        print("\nshapely not installed: GEOS columns skipped (pip install shapely).")


if __name__ == "__main__":
    main()
