"""Side by side: our Delaunay kernel, Triangle (C) and scipy's Qhull.

Run from the repository root::

    .venv/bin/python benchmarks/delaunay.py            # 100k and 1M points
    .venv/bin/python benchmarks/delaunay.py --sizes 100000 --qhull-timeout 20
    .venv/bin/python benchmarks/delaunay.py --inputs rect-boundary --no-qhull --repeat 7

Inputs: uniform random points in the unit square, and points evenly spaced
on the boundary of a 2 x 1 rectangle (top and bottom share their x
coordinates, so the input is as collinear and co-circular as it gets).
Triangle is a bench-only dependency (``pip install -e .[bench]``) and is
skipped with a note when absent; Qhull runs in a child process with a time
limit because it is pathologically slow on the boundary input.

The first call of our kernel compiles it (or loads numba's cache) and is
reported separately; the timed runs exclude it. Times are CPU seconds of this
process (``time.process_time``: the machine is shared, and wall time counts
the other processes' turns), the median of ``--repeat`` runs, ours and
Triangle taking turns; the ratio is that of the medians. The load average is
printed with the table. Peak memory is the
tracemalloc peak of one extra run of ours (numpy allocations, which hold all
of the kernel's arrays but its sort keys).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from meshcore.delaunay.kernel2d import delaunay  # noqa: E402


def random_square(n: int) -> np.ndarray:
    return np.random.default_rng(12345).random((n, 2))


def rectangle_boundary(n: int) -> np.ndarray:
    nb, nr = n // 3, n // 6
    xs = np.linspace(0.0, 2.0, nb + 1)
    ys = np.linspace(0.0, 1.0, nr + 1)
    return np.concatenate(
        [
            np.column_stack([xs[:-1], np.zeros(nb)]),
            np.column_stack([np.full(nr, 2.0), ys[:-1]]),
            np.column_stack([xs[::-1][:-1], np.ones(nb)]),
            np.column_stack([np.zeros(nr), ys[::-1][:-1]]),
        ]
    )


INPUTS = {"random": random_square, "rect-boundary": rectangle_boundary}

_QHULL_CHILD = """
import sys, time, numpy as np
from scipy.spatial import Delaunay
p = np.load(sys.argv[1])
t = time.perf_counter()
Delaunay(p)
print(time.perf_counter() - t)
"""


def time_pair(p: np.ndarray, repeat: int) -> tuple[float, float | None]:
    """Median CPU seconds of ours and of Triangle (None if absent), taking turns."""
    try:
        import triangle
    except ImportError:
        triangle = None
    ours, tri = [], []
    for _ in range(repeat):
        t = time.process_time()
        delaunay(p)
        ours.append(time.process_time() - t)
        if triangle is not None:
            t = time.process_time()
            triangle.triangulate({"vertices": p}, "")
            tri.append(time.process_time() - t)
    return float(np.median(ours)), (float(np.median(tri)) if tri else None)


def peak_ours_mb(p: np.ndarray) -> float:
    tracemalloc.start()
    delaunay(p)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def time_qhull(p: np.ndarray, timeout: float) -> float | str:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "points.npy")
        np.save(path, p)
        try:
            out = subprocess.run(
                [sys.executable, "-c", _QHULL_CHILD, path],
                capture_output=True,
                text=True,
                timeout=timeout,
                check=False,
            )
        except subprocess.TimeoutExpired:
            return f">{timeout:g} s"
        if out.returncode != 0:
            return "error: " + (out.stderr.strip().splitlines() or ["?"])[-1][:40]
        return float(out.stdout.strip())


def fmt(x: float | str | None) -> str:
    if x is None:
        return "n/a"
    if isinstance(x, str):
        return x
    return f"{x:.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--repeat", type=int, default=5, help="median of R runs (ours, Triangle)")
    parser.add_argument("--qhull-timeout", type=float, default=60.0)
    parser.add_argument("--no-qhull", action="store_true")
    parser.add_argument(
        "--inputs", nargs="+", choices=list(INPUTS), default=list(INPUTS), help="inputs to run"
    )
    args = parser.parse_args()

    t = time.perf_counter()
    delaunay(random_square(100))
    first_call = time.perf_counter() - t
    print(f"first call of ours (numba compile or cache load): {first_call:.2f} s")
    try:
        import triangle  # noqa: F401
    except ImportError:
        print("note: Triangle is not installed (pip install -e .[bench]); its column is n/a")

    header = (
        f"{'input':<14} {'n':>9} {'ours CPU s':>10} {'triangle CPU s':>14} {'qhull wall s':>12} "
        f"{'ours/triangle':>13} {'ours peak MB':>12}"
    )
    print(header)
    print("-" * len(header))
    for n in args.sizes:
        for name in args.inputs:
            p = INPUTS[name](n)
            ours, tri = time_pair(p, args.repeat)
            qh = None if args.no_qhull else time_qhull(p, args.qhull_timeout)
            ratio = f"{ours / tri:.2f}" if tri else "n/a"
            peak = peak_ours_mb(p)
            print(
                f"{name:<14} {len(p):>9} {fmt(ours):>10} {fmt(tri):>14} {fmt(qh):>12} "
                f"{ratio:>13} {peak:>12.0f}",
                flush=True,
            )
    with open("/proc/loadavg") as f:
        print("load average:", " ".join(f.read().split()[:3]))


if __name__ == "__main__":
    main()
