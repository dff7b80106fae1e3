"""Side by side: ``grid`` and ``quad_grid`` (ours, §8.2, §8.5.2) against Gmsh and our own.

Run from the repository root::

    .venv/bin/python benchmarks/grid.py                     # grid: 100k and 1M cells
    .venv/bin/python benchmarks/grid.py --sizes 100000
    .venv/bin/python benchmarks/grid.py quad_grid           # quad_grid: the four domains
    .venv/bin/python benchmarks/grid.py quad_grid --domains square_hole

``quad_grid`` domains (polygons; circles sampled at about the mesh size):
the unit square minus a disk of radius 0.25 (about 100k quads), the L-shape
(2 x 2 minus a 1 x 1 corner), a plate with 5 x 5 round holes, a 24-tooth
gear (about 25k quads each). Rows: ``quad_grid(size=h)`` with ``smooth``
off and on (``h = sqrt(area / N)``), ``(fallback)`` when the band was
triangulated rather than projected; our ``quad_combine`` on the domain
(``all_quad``, ``optimize``, size ``2 h``: its split halves the size); Gmsh
(OpenCASCADE geometry from the same polygon) ``Mesh.Algorithm`` 8, 9 and 11
with ``Mesh.RecombineAll = 1`` and ``Mesh.RecombinationAlgorithm = 3``
(Blossom full-quad) set before ``generate`` (``recombine()`` afterwards
ignores the recombination algorithm), ``MeshSizeMin = MeshSizeMax =
1.3 h`` (about the same count), each in a child process with a ``--limit``
(60 s) wall-time limit.
Columns: wall and CPU seconds, CPU over ours smoothed, quads, triangles
left, least and mean quad quality (8.4), least scaled Jacobian, share of
interior vertices of valence 4.

``grid`` rows, on the unit square minus a disk of radius 0.25 (its circle
sampled at about the cell size, at least 32 points), at about N cells each:

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
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.grid import grid, quad_grid  # noqa: E402
from meshcore.grid.cartesian import _quad_jacobian  # noqa: E402
from meshcore.mesh.quality import quad_quality  # noqa: E402
from meshcore.quads.combination import combine  # noqa: E402
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


# ----------------------------------------------------------------------------- quad_grid


def _circle(cx, cy, r, h, start=0.0):
    n = max(16, 4 * math.ceil(2 * math.pi * r / h / 4))
    th = start + 2 * np.pi * np.arange(n) / n
    return np.column_stack([cx + r * np.cos(th), cy + r * np.sin(th)])[::-1]


def qg_domains(h: float) -> dict:
    sq = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    holes = [_circle(0.1 + 0.2 * i, 0.1 + 0.2 * j, 0.06, h) for i in range(5) for j in range(5)]
    k = 24
    th = np.linspace(0, 2 * np.pi, 4 * k, endpoint=False)
    r = np.where((np.arange(4 * k) // 2) % 2 == 0, 1.0, 0.85)
    gear = np.column_stack([r * np.cos(th), r * np.sin(th)])
    return {
        "square_hole": (100_000, [sq, _circle(0.5, 0.5, 0.25, h)]),
        "l_shape": (25_000, [np.array([[0.0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]])]),
        "plate": (25_000, [sq, *holes]),
        "gear": (25_000, [gear, _circle(0, 0, 0.3, h)]),
    }


def qg_area(rings) -> float:
    def a(r):
        return 0.5 * float(np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]))

    return abs(a(rings[0])) - sum(abs(a(r)) for r in rings[1:])


def measures(P: np.ndarray, Q: np.ndarray, n_tri: int) -> dict:
    d1, d2 = P[Q[:, 2]] - P[Q[:, 0]], P[Q[:, 3]] - P[Q[:, 1]]
    s = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    Q = np.where((s < 0)[:, None], Q[:, ::-1], Q)  # Gmsh orients by its normal
    q = quad_quality(P, Q)
    sj = _quad_jacobian(P, Q)
    e = np.sort(np.concatenate([Q[:, [c, (c + 1) % 4]] for c in range(4)]), axis=1)
    ue, cnt = np.unique(e, axis=0, return_counts=True)
    border = np.zeros(len(P), dtype=bool)
    border[ue[cnt == 1].ravel()] = True
    val = np.bincount(ue.ravel(), minlength=len(P))
    inner = ~border & (val > 0)
    return {
        "quads": len(Q),
        "tris": n_tri,
        "qmin": float(q.min()),
        "qmean": float(q.mean()),
        "sj": float(sj.min()),
        "v4": float((val[inner] == 4).mean()),
    }


def gmsh_child(rings, algorithm: int, s: float) -> dict:
    import gmsh

    gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.MeshSizeMin", s)
        gmsh.option.setNumber("Mesh.MeshSizeMax", s)
        gmsh.option.setNumber("Mesh.Algorithm", algorithm)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
        occ = gmsh.model.occ
        loops = []
        for r in rings:
            pts = [occ.addPoint(x, y, 0) for x, y in r]
            lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
            loops.append(occ.addCurveLoop(lines))
        occ.addPlaneSurface(loops)
        occ.synchronize()
        w, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        wall, cpu = time.perf_counter() - w, time.process_time() - c
        tags, coords, _ = gmsh.model.mesh.getNodes()
        P = coords.reshape(-1, 3)[:, :2]
        index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        quads = np.zeros((0, 4), dtype=np.int64)
        n_tri = 0
        for etype in (2, 3):
            _, nodes = gmsh.model.mesh.getElementsByType(etype)
            if etype == 3 and len(nodes):
                quads = index[nodes.astype(np.int64)].reshape(-1, 4)
            if etype == 2:
                n_tri = len(nodes) // 3
    finally:
        gmsh.finalize()
    return {"wall": wall, "cpu": cpu, **measures(P, quads, n_tri)}


def gmsh_row(name: str, h: float, algorithm: int, s: float, limit: float) -> dict | None:
    cmd = [sys.executable, __file__, "--child", name, str(h), str(algorithm), str(s)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=limit, check=True)
    except subprocess.TimeoutExpired:
        return {"row": f"gmsh {algorithm}", "note": f"past {limit:g} s"}
    except subprocess.CalledProcessError as exc:
        return {"row": f"gmsh {algorithm}", "note": exc.stderr.strip().splitlines()[-1][:60]}
    return {"row": f"gmsh {algorithm}", **json.loads(out.stdout.strip().splitlines()[-1])}


def ours_quad_grid(rings, h: float, smooth: bool) -> dict:
    dom = {"type": "Polygon", "coordinates": [r.tolist() for r in rings]}
    w, c = time.perf_counter(), time.process_time()
    res = quad_grid(dom, size=h, smooth=smooth)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    P, Q = res.mesh.points, res.mesh.cells[0].data
    return {
        "row": "quad_grid" + (" smooth" if smooth else ""),
        "route": res.stats["band"],
        "wall": wall,
        "cpu": cpu,
        **measures(P, Q, 0),
    }


def ours_quad_combine(rings, h: float) -> dict:
    """``quad_combine`` on the domain, ``all_quad`` and ``optimize`` (its split halves the size)."""
    dom = {"type": "Polygon", "coordinates": [r.tolist() for r in rings]}
    w, c = time.perf_counter(), time.process_time()
    res = combine(domain=dom, size=2 * h, all_quad=True, optimize=True)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    blocks = res.mesh.cells_by_type
    Q = blocks.get("quad", np.zeros((0, 4), np.int64))
    n_tri = len(blocks.get("triangle", ()))
    return {"row": "quad_combine", "wall": wall, "cpu": cpu, **measures(res.mesh.points, Q, n_tri)}


#: Gmsh's full-quad recombination splits each quad into four: MeshSize about
#: this many times our quad side gives about the same count (measured on the
#: square with a hole).
GMSH_SIZE = 1.3


def quad_grid_main(argv: list[str]) -> None:
    """``quad_grid`` (and ``quad_combine``) against Gmsh's quad algorithms 8, 9, 11."""
    ap = argparse.ArgumentParser(description="quad_grid against Gmsh's quad algorithms")
    ap.add_argument("--domains", nargs="+", default=["square_hole", "l_shape", "plate", "gear"])
    ap.add_argument("--limit", type=float, default=60.0, help="wall seconds per Gmsh run")
    ap.add_argument("--algorithms", type=int, nargs="+", default=[8, 9, 11])
    args = ap.parse_args(argv)
    quad_grid({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}, size=0.1)
    combine(domain=domain(0.1), size=0.1, all_quad=True, optimize=True)
    try:
        import gmsh  # noqa: F401

        have_gmsh = True
    except ImportError:
        have_gmsh = False
        print("note: gmsh not installed (pip install -e .[bench]); its rows are skipped")
    print(
        f"{'domain':<12} {'row':<16} {'wall s':>7} {'cpu s':>7} {'cpu/ours':>8} {'quads':>7} "
        f"{'tris':>5} {'Q min':>6} {'Q mean':>6} {'SJ min':>6} {'val4':>6}"
    )
    for name in args.domains:
        n, rings0 = qg_domains(0.01)[name]
        h = math.sqrt(qg_area(rings0) / n)
        rings = qg_domains(h)[name][1]
        rows = [
            ours_quad_grid(rings, h, False),
            ours_quad_grid(rings, h, True),
            ours_quad_combine(rings, h),
        ]
        if have_gmsh:
            rows += [gmsh_row(name, h, alg, GMSH_SIZE * h, args.limit) for alg in args.algorithms]
        ref = rows[1]["cpu"]
        for r in rows:
            if "note" in r:
                print(f"{name:<12} {r['row']:<16} {r['note']}")
                continue
            label = r["row"] + (" (fallback)" if r.get("route") == "triangulation" else "")
            print(
                f"{name:<12} {label:<16} {r['wall']:>7.2f} {r['cpu']:>7.2f} "
                f"{r['cpu'] / ref:>8.2f} {r['quads']:>7} {r['tris']:>5} {r['qmin']:>6.3f} "
                f"{r['qmean']:>6.3f} {r['sj']:>6.3f} {r['v4']:>6.3f}",
                flush=True,
            )


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        name, h, alg, s = sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5])
        print(json.dumps(gmsh_child(qg_domains(h)[name][1], alg, s)))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "quad_grid":
        quad_grid_main(sys.argv[2:])
        return
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
