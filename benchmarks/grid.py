"""Side by side: ``grid`` (ours, §8.2) against Gmsh's transfinite quads and our ``triangulate``.

Run from the repository root::

    .venv/bin/python benchmarks/grid.py                     # 100k and 1M cells
    .venv/bin/python benchmarks/grid.py --sizes 100000

Input: the unit square minus a disk of radius 0.25, its circle sampled at
about the cell size (at least 32 points). Rows, at about N cells each:

* ``grid fit`` / ``grid keep`` (ours): cell side ``sqrt(area / N)``; fit
  covers the domain exactly, keep is the staircase. Columns: cells (quads,
  triangles), least scaled Jacobian of the cut quads, largest distance of a
  border vertex to the domain boundary (fit: should be rounding only).
* ``gmsh transfinite``: Gmsh's transfinite quads on the unit square
  (``setTransfiniteCurve`` with sqrt(N) + 1 nodes, ``setTransfiniteSurface``,
  ``Mesh.RecombineAll = 1`` set before ``generate``): a structured grid with
  no boundary to fit, the lower bound for a grid mesher.
* ``triangulate`` (ours): about N triangles (equilateral lattice of side
  ``sqrt(4 area / (sqrt(3) N))``, the quality mesher's defaults).

Each row: wall time and process CPU time (the machine is shared, CPU time
is the steadier figure), the call timed after a warm-up on a small case that
loads numba's cache. Ratios are ours over Gmsh's (wall). Gmsh is a
bench-only dependency (``pip install -e .[bench]``), skipped with a note
when absent.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.grid import grid  # noqa: E402
from meshcore.grid.cartesian import _quad_jacobian  # noqa: E402
from meshcore.triangulation import triangulate  # noqa: E402

AREA = 1.0 - math.pi / 16


def domain(h: float) -> dict:
    n = max(32, 4 * math.ceil(2 * math.pi * 0.25 / h / 4))
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    circ = 0.5 + 0.25 * np.column_stack([np.cos(th), np.sin(th)])
    return {
        "type": "Polygon",
        "coordinates": [[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], circ[::-1].tolist()],
    }


def timed(f):
    w, c = time.perf_counter(), time.process_time()
    out = f()
    return out, time.perf_counter() - w, time.process_time() - c


def border_distance(dom: dict, mesh) -> float:
    """Largest distance from a border vertex of the mesh to the domain's segments."""
    edges = []
    for b in mesh.cells:
        d = b.data
        edges.append(np.sort(np.column_stack([d.ravel(), np.roll(d, -1, axis=1).ravel()]), axis=1))
    e, cnt = np.unique(np.concatenate(edges), axis=0, return_counts=True)
    P = mesh.points[np.unique(e[cnt == 1])]
    segs = []
    for ring in dom["coordinates"]:
        r = np.asarray(ring)
        segs.append(np.stack([r, np.roll(r, -1, axis=0)], axis=1))
    S = np.concatenate(segs)
    a, d = S[:, 0], S[:, 1] - S[:, 0]
    best = np.zeros(len(P))
    for k in range(0, len(P), 1024):
        q = P[k : k + 1024, None, :]
        t = np.clip(((q - a) * d).sum(-1) / (d * d).sum(-1), 0, 1)
        best[k : k + 1024] = np.linalg.norm(a + t[..., None] * d - q, axis=-1).min(axis=1)
    return float(best.max())


def ours_grid(n: int, boundary: str) -> dict:
    h = math.sqrt(AREA / n)
    dom = domain(h)
    res, wall, cpu = timed(lambda: grid(dom, size=h, boundary=boundary))
    st = res.stats
    quads = res.mesh.cells_by_type.get("quad", np.zeros((0, 4), int))
    bset = res.mesh.cell_sets["boundary"][0]
    sj = _quad_jacobian(res.mesh.points, quads[bset]) if len(bset) else np.zeros(1)
    return {
        "row": f"grid {boundary}",
        "wall": wall,
        "cpu": cpu,
        "quads": st["quads"],
        "triangles": st["triangles"],
        "cut_min_sj": float(sj.min()) if boundary != "keep" else float("nan"),
        "border_dist": border_distance(dom, res.mesh) if boundary != "keep" else st["hausdorff"],
        "area_err": abs(st["area"] - st["domain_area"]) / st["domain_area"],
    }


def ours_triangulate(n: int) -> dict:
    s = math.sqrt(4 * AREA / (math.sqrt(3) * n))
    dom = domain(s)
    res, wall, cpu = timed(lambda: triangulate(dom, size=s))
    return {
        "row": "triangulate",
        "wall": wall,
        "cpu": cpu,
        "quads": 0,
        "triangles": len(res.mesh.cells[0].data),
        "cut_min_sj": float("nan"),
        "border_dist": float("nan"),
        "area_err": float("nan"),
    }


def gmsh_transfinite(n: int) -> dict | None:
    try:
        import gmsh
    except ImportError:
        print("note: gmsh not installed (pip install -e .[bench]); its row is skipped")
        return None
    k = round(math.sqrt(n))
    gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        geo = gmsh.model.geo
        p = [geo.addPoint(x, y, 0) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
        lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
        loop = geo.addCurveLoop(lines)
        surf = geo.addPlaneSurface([loop])
        for c in lines:
            geo.mesh.setTransfiniteCurve(c, k + 1)
        geo.mesh.setTransfiniteSurface(surf)
        geo.synchronize()
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        _, wall, cpu = timed(lambda: gmsh.model.mesh.generate(2))
        types, tags, _ = gmsh.model.mesh.getElements(2)
        counts = {int(t): len(g) for t, g in zip(types, tags, strict=True)}
    finally:
        gmsh.finalize()
    return {
        "row": "gmsh transfinite",
        "wall": wall,
        "cpu": cpu,
        "quads": counts.get(3, 0),
        "triangles": counts.get(2, 0),
        "cut_min_sj": float("nan"),
        "border_dist": float("nan"),
        "area_err": float("nan"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    args = ap.parse_args()
    grid(domain(0.05), size=0.05, boundary="fit")  # warm-up: numba's cache
    grid(domain(0.05), size=0.05, boundary="keep")
    triangulate(domain(0.05), size=0.05)
    head = (
        f"{'N':>8} {'row':<17} {'wall s':>7} {'cpu s':>7} {'x gmsh':>7} {'quads':>8} "
        f"{'tris':>7} {'cut SJ':>7} {'border/H':>9} {'area err':>9}"
    )
    print(head)
    for n in args.sizes:
        rows = [ours_grid(n, "fit"), ours_grid(n, "keep"), ours_triangulate(n)]
        g = gmsh_transfinite(n)
        if g is not None:
            rows.append(g)
        ref = g["wall"] if g is not None else float("nan")
        for r in rows:
            print(
                f"{n:>8} {r['row']:<17} {r['wall']:>7.3f} {r['cpu']:>7.3f} "
                f"{r['wall'] / ref:>7.2f} {r['quads']:>8} {r['triangles']:>7} "
                f"{r['cut_min_sj']:>7.3f} {r['border_dist']:>9.2e} {r['area_err']:>9.1e}"
            )
    print(
        "border/H: fit, largest distance of a border vertex to the domain boundary; "
        "keep, the Hausdorff distance of the staircase (to 1/128 cell)."
    )


if __name__ == "__main__":
    main()
