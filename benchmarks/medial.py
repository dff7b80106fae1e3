"""Side by side: ``medial_axis`` (ours), Triangle's Delaunay and scikit-image's raster axes.

Run from the repository root::

    .venv/bin/python benchmarks/medial.py                  # 10k, 100k, 1M points; 512², 2048²
    .venv/bin/python benchmarks/medial.py --big            # also 8192² rasters (minutes, ~5 GB)
    .venv/bin/python benchmarks/medial.py --sizes 10000 100000 --rasters 512
    .venv/bin/python benchmarks/medial.py --quad-medial 0.1 0.15   # quad_medial's table only

Three tables, one run:

1. **Ours vs Triangle, same points.** The 2 x 1 rectangle sampled with
   ``N`` = 10k, 100k and 1M boundary points (``h = perimeter / N``). Ours:
   the whole :func:`meshcore.medial.axis.medial_axis` call (sampling, our
   Delaunay kernel, types, Voronoi graph, pruning, radii) and, apart, our
   Delaunay of the samples. Triangle: only its Delaunay triangulation of the same samples
   (``triangle.triangulate({"vertices": samples}, "")``), the step that
   dominates any Delaunay-based axis. The Hausdorff error of our axis to the
   analytic one is given too.
2. **Raster axes.** scikit-image's ``skimage.morphology.medial_axis``
   (distance transform + skeleton) and ``skeletonize`` on the rectangle and
   on the annulus of radii 0.5 and 1, rasterized on square images of 512²,
   2048² (and with ``--big`` 8192²) pixels over the shape's bounding box
   plus a 2 % margin (pixel centres tested exactly against the shape; the
   rasterization is not timed). Skeleton pixels become their centres'
   coordinates.
3. **Ours at several h**, rectangle and annulus (the annulus polygon has a
   vertex every ``h`` on both circles), so that a row of table 2 can be
   read against the row of table 3 with the nearest wall time: at equal
   time, our error against the raster's. The last table pairs each raster
   row with our most accurate row that is not slower, and gives the error
   ratio.

Error: the symmetric Hausdorff distance between the computed axis and the
analytic one (the rectangle's: the segment (0.5, 0.5)-(1.5, 0.5) and the
four half-diagonals to the corners; the annulus's: the circle of radius
0.75). From the computed axis to the analytic one: exact point-to-segment
or point-to-circle distances of its points (a raster axis: its pixel
centres; ours: its edges densified every ``h / 8``). From the analytic axis
(sampled every ``step / 8``, ``step`` the pixel size or ``h``) to the
computed one: to the nearest pixel centre (k-d tree), or exactly to the
nearest of our segments (GEOS STR-tree). scikit-image's ``skeletonize``
(a thinning) does not keep the branches into the rectangle's corners: its
error there is the corner's distance to the central segment, 0.707.

``--quad-medial SIZE...``: instead, :func:`meshcore.medial.partitioning.quad_medial` on
issue 20's 40 random stars (:func:`tests.meshcore.quads.stars.issue_star`) and on
gears of 6-12 teeth (depth 0.12, sampled about ``size`` apart, as the tests draw them)
at each size: per domain the count over area / size**2 and, away from the quads at
input corners under 45 degrees (one quad holds such a corner), the least quality
(8.4), the corner range and the quads under 0.5, with the CPU seconds; then a summary
line per family and size (on how many domains each of the issue's facts holds).

Timing: table 1 in CPU seconds of this process (``time.process_time``: the
machine is shared, and wall time counts the other processes' turns), the
median of ``--repeat`` runs, ours and Triangle taking turns, the load average
printed under it; our Delaunay is timed apart, as a call of
:func:`meshcore.delaunay.kernel2d.delaunay` on the samples. Tables 2-4: wall
clock of the call alone, best of ``--repeat`` runs (default 3; one for 8192²
rasters). Ours after a warm-up call that loads numba's cache. Triangle and
scikit-image are bench-only dependencies (``pip install -e .[bench]``),
skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np
from scipy.spatial import cKDTree

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.delaunay.kernel2d import delaunay  # noqa: E402
from meshcore.domain.planar import parse_domain  # noqa: E402
from meshcore.medial.axis import medial_axis  # noqa: E402

MARGIN = 0.02  # raster margin around the bounding box, times its extent

# ---------------------------------------------------------------------------
# Shapes and their analytic axes
# ---------------------------------------------------------------------------

RECT_AXIS = np.array(
    [
        [[0.5, 0.5], [1.5, 0.5]],
        [[0.5, 0.5], [0.0, 0.0]],
        [[0.5, 0.5], [0.0, 1.0]],
        [[1.5, 0.5], [2.0, 0.0]],
        [[1.5, 0.5], [2.0, 1.0]],
    ]
)


def rect_domain():
    return parse_domain({"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1]]]})


def annulus_domain(h: float):
    """The annulus as a polygon with a vertex about every ``h`` on each circle."""

    def ring(r):
        n = max(16, math.ceil(2 * math.pi * r / h))
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        return (r * np.column_stack([np.cos(t), np.sin(t)])).tolist()

    return parse_domain({"type": "Polygon", "coordinates": [ring(1.0), ring(0.5)]})


SHAPES = {
    "rectangle": {
        "box": (0.0, 0.0, 2.0, 1.0),
        "inside": lambda x, y: (x > 0) & (x < 2) & (y > 0) & (y < 1),
    },
    "annulus": {
        "box": (-1.0, -1.0, 1.0, 1.0),
        "inside": lambda x, y: (np.hypot(x, y) > 0.5) & (np.hypot(x, y) < 1.0),
    },
}


def _segment_distance(p: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """(k,) distance from each point to the nearest of the segments (s, 2, 2)."""
    best = np.full(len(p), np.inf)
    for a, b in segs:  # five analytic segments
        d = b - a
        t = np.clip(((p - a) @ d) / (d @ d), 0.0, 1.0)
        q = a + t[:, None] * d
        best = np.minimum(best, np.hypot(*(p - q).T))
    return best


def _densify(segs: np.ndarray, step: float) -> np.ndarray:
    length = np.hypot(*(segs[:, 1] - segs[:, 0]).T)
    count = np.maximum(np.ceil(length / step), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(segs)), count + 1)
    start = np.cumsum(count + 1) - (count + 1)
    t = (np.arange(len(owner)) - np.repeat(start, count + 1)) / count[owner]
    return segs[owner, 0] + t[:, None] * (segs[owner, 1] - segs[owner, 0])


def hausdorff(shape: str, points: np.ndarray, step: float, segments=None) -> float:
    """Symmetric Hausdorff distance between a point set and the analytic axis.

    With ``segments`` (s, 2, 2) (a polyline axis, ``points`` its densified
    samples), the distance from the analytic axis to it is exact (STR-tree
    nearest segment), not to the nearest sample.
    """
    if len(points) == 0:
        return math.inf
    if shape == "rectangle":
        to_axis = _segment_distance(points, RECT_AXIS)
        exact = _densify(RECT_AXIS, step / 8)
    else:
        to_axis = np.abs(np.hypot(*points.T) - 0.75)
        n = math.ceil(2 * math.pi * 0.75 / (step / 8))
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        exact = 0.75 * np.column_stack([np.cos(t), np.sin(t)])
    if segments is not None and len(segments):
        import shapely

        tree = shapely.STRtree(shapely.linestrings(segments))
        _, from_axis = tree.query_nearest(
            shapely.points(exact), return_distance=True, all_matches=False
        )
    else:
        from_axis, _ = cKDTree(points).query(exact)
    return float(max(to_axis.max(), from_axis.max()))


def axis_error(shape: str, ax) -> float:
    """Hausdorff error of our axis: its edges densified every h / 8 one way, exact the other."""
    segs = ax.nodes[ax.edges]
    pts = _densify(segs, ax.h / 8) if len(segs) else ax.nodes
    return hausdorff(shape, pts, ax.h, segs)


# ---------------------------------------------------------------------------
# Runs
# ---------------------------------------------------------------------------


def best_time(fn, repeat: int):
    best, out = math.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def available(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def raster(shape: str, res: int):
    x0, y0, x1, y1 = SHAPES[shape]["box"]
    extent = max(x1 - x0, y1 - y0) * (1 + 2 * MARGIN)
    px = extent / res
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    xs = cx - extent / 2 + (np.arange(res) + 0.5) * px
    ys = cy - extent / 2 + (np.arange(res) + 0.5) * px
    X, Y = np.meshgrid(xs, ys)  # row i is y index, column j is x
    mask = SHAPES[shape]["inside"](X, Y)
    return mask, xs, ys, px


def table_triangle(sizes, repeat, have_triangle, notes):
    print("\n### 1. Rectangle 2 x 1, N boundary points: our axis vs Triangle's Delaunay\n")
    print(
        "| N | ours: axis CPU s | ours: Delaunay CPU s | Triangle Delaunay CPU s | "
        "axis / Triangle | our Delaunay / Triangle | axis Hausdorff error | error / h |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    domain = rect_domain()
    medial_axis(domain, h=0.05)  # warm-up: numba's cache
    for n in sizes:
        h = 6.0 / n
        ours, phase, tri = [], [], []
        for _ in range(repeat):  # ours and Triangle take turns
            t = time.process_time()
            ax = medial_axis(domain, h=h)
            ours.append(time.process_time() - t)
            pts = np.ascontiguousarray(ax.samples)
            t = time.process_time()
            delaunay(pts)
            phase.append(time.process_time() - t)
            if have_triangle:
                import triangle

                t = time.process_time()
                triangle.triangulate({"vertices": pts}, "")
                tri.append(time.process_time() - t)
        t_ours, t_del = float(np.median(ours)), float(np.median(phase))
        err = axis_error("rectangle", ax)
        if have_triangle:
            t_tri = float(np.median(tri))
            cells = f"{t_tri:.4f} | {t_ours / t_tri:.2f} | {t_del / t_tri:.2f}"
        else:
            cells = "skipped | | "
        print(
            f"| {len(ax.samples):,} | {t_ours:.4f} | {t_del:.4f} | {cells} | {err:.3g} | "
            f"{err / ax.h:.2f} |",
            flush=True,
        )
    with open("/proc/loadavg") as f:
        print("\nload average:", " ".join(f.read().split()[:3]))
    if not have_triangle:
        notes.append("Triangle not installed (pip install -e .[bench]): skipped")


def table_raster(rasters, repeat, notes) -> list[dict]:
    print("\n### 2. Raster axes (scikit-image), square images over the bounding box\n")
    print("| shape | pixels | pixel size | method | seconds | skeleton pixels | Hausdorff error |")
    print("|---|---:|---:|---|---:|---:|---:|")
    if not available("skimage"):
        notes.append("scikit-image not installed (pip install -e .[bench]): skipped")
        return []
    from skimage.morphology import medial_axis as sk_medial_axis
    from skimage.morphology import skeletonize

    rows = []
    for shape in SHAPES:
        for res in rasters:
            mask, xs, ys, px = raster(shape, res)
            rep = 1 if res >= 8192 else repeat
            for name, fn in (("medial_axis", sk_medial_axis), ("skeletonize", skeletonize)):
                t, skel = best_time(lambda fn=fn, mask=mask: fn(mask), rep)
                iy, ix = np.nonzero(skel)
                pts = np.column_stack([xs[ix], ys[iy]])
                err = hausdorff(shape, pts, px)
                rows.append(
                    {"shape": shape, "res": res, "method": name, "seconds": t, "error": err}
                )
                print(
                    f"| {shape} | {res}² | {px:.3g} | {name} | {t:.3f} | {len(pts):,} | "
                    f"{err:.3g} |",
                    flush=True,
                )
            del mask
    return rows


def table_ours(steps, repeat) -> list[dict]:
    print("\n### 3. Our axis at several h\n")
    print("| shape | h | boundary samples | seconds | axis nodes | Hausdorff error | error / h |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    rows = []
    medial_axis(rect_domain(), h=0.05)
    for shape in SHAPES:
        for h in steps:
            domain = rect_domain() if shape == "rectangle" else annulus_domain(h)
            t, ax = best_time(lambda domain=domain, h=h: medial_axis(domain, h=h), repeat)
            err = axis_error(shape, ax)
            rows.append({"shape": shape, "h": h, "seconds": t, "error": err})
            print(
                f"| {shape} | {h:.3g} | {len(ax.samples):,} | {t:.4f} | {len(ax.nodes):,} | "
                f"{err:.3g} | {err / ax.h:.2f} |",
                flush=True,
            )
    return rows


def table_equal_time(raster_rows, our_rows):
    if not raster_rows:
        return
    print("\n### 4. At equal wall time: our most accurate axis not slower than the raster one\n")
    print(
        "| shape | raster | raster s | raster error | our h | our s | our error | "
        "our error / raster error |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for r in raster_rows:
        ours = [o for o in our_rows if o["shape"] == r["shape"] and o["seconds"] <= r["seconds"]]
        label = f"{r['method']} {r['res']}²"
        if not ours:
            print(
                f"| {r['shape']} | {label} | {r['seconds']:.3f} | {r['error']:.3g} | "
                "none as fast | | | |"
            )
            continue
        o = min(ours, key=lambda o: o["error"])
        print(
            f"| {r['shape']} | {label} | {r['seconds']:.3f} | {r['error']:.3g} | {o['h']:.3g} | "
            f"{o['seconds']:.4f} | {o['error']:.3g} | {o['error'] / r['error']:.2g} |"
        )


def quad_medial_main(sizes) -> None:
    """``--quad-medial``: the stars and gears table (module docstring)."""
    from meshcore.medial import quad_medial
    from meshcore.mesh import quality
    from tests.meshcore.quads.stars import issue_star
    from tests.meshcore.quads.test_curved_domains import _gear, _ring, _sampled

    print(f"load average {os.getloadavg()[0]:.2f}\n")
    print("| domain | size | count / (area / size²) | least Q | Q < 0.5 | corners | CPU s |")
    print("|---|---:|---:|---:|---:|---|---:|")
    rows: dict[tuple[str, float], list] = {}
    for size in sizes:
        cases = [("star", f"star {k}", issue_star(k)[0]) for k in range(40)]
        cases += [
            (
                "gear",
                f"gear {k}",
                {"type": "Polygon", "coordinates": [_ring(_sampled(_gear(k, 0.12), size))]},
            )
            for k in range(6, 13)
        ]
        for family, name, geo in cases:  # a loop over 47 domains
            dom = parse_domain(geo)
            t0 = time.process_time()
            res = quad_medial(dom, size=size)
            sec = time.process_time() - t0
            P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
            sharp = np.zeros(len(P), bool)
            for x in dom.points[np.flatnonzero(dom.corner_angles() < 45)]:  # the spikes
                sharp |= (P == x).all(axis=1)
            ok = ~sharp[Q].any(axis=1)
            q, ang = quality.quad_quality(P, Q)[ok], quality.quad_angles(P, Q)[ok]
            ratio = len(Q) * size**2 / dom.area
            row = (ratio, q.min(), ang.min(), ang.max(), int((q < 0.5).sum()))
            rows.setdefault((family, size), []).append(row)
            print(
                f"| {name} | {size} | {ratio:.2f} | {q.min():.3f} | {row[4]} | "
                f"{ang.min():.1f}-{ang.max():.1f} | {sec:.2f} |",
                flush=True,
            )
    print()
    for (family, size), got in rows.items():
        r, q, lo, hi, under = (np.array(c) for c in zip(*got, strict=True))
        print(
            f"{len(got)} {family}s at size {size}: count {r.min():.2f}-{r.max():.2f}x (over 1.5x "
            f"on {(r > 1.5).sum()}), least Q {q.min():.3f}-{q.max():.3f} (>= 0.5 on "
            f"{(q >= 0.5).sum()}, >= 0.3 on {(q >= 0.3).sum()}), corners in [30, 150] on "
            f"{((lo >= 30) & (hi <= 150)).sum()}, quads under 0.5: {under.sum()}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quad-medial", type=float, nargs="+", default=None, metavar="SIZE")
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--rasters", type=int, nargs="*", default=[512, 2048])
    ap.add_argument("--big", action="store_true", help="add 8192² rasters (minutes, ~5 GB)")
    ap.add_argument(
        "--steps", type=float, nargs="*", default=[0.05, 0.02, 0.005, 0.002, 0.0005, 0.0002]
    )
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if args.quad_medial:
        quad_medial_main(args.quad_medial)
        return
    notes: list[str] = []
    rasters = list(args.rasters) + ([8192] if args.big and 8192 not in args.rasters else [])
    if not args.big and 8192 not in rasters:
        notes.append("8192² rasters skipped (minutes and ~5 GB each): pass --big")
    table_triangle(args.sizes, args.repeat, available("triangle"), notes)
    raster_rows = table_raster(rasters, args.repeat, notes)
    our_rows = table_ours(args.steps, args.repeat)
    table_equal_time(raster_rows, our_rows)
    print()
    for note in notes:
        print("note:", note)
    print(
        "ratios: ours/peer wall time (below 1: ours faster); error ratios below 1: ours closer "
        "to the analytic axis"
    )


if __name__ == "__main__":
    main()
