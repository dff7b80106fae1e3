"""Side by side: ``quad_grid`` (ours, §8.5.2) against Gmsh's quad algorithms.

Run from the repository root::

    .venv/bin/python benchmarks/quad_grid.py               # the four domains
    .venv/bin/python benchmarks/quad_grid.py --domains square_hole

Domains (polygons; circles sampled at about the mesh size): the unit square
minus a disk of radius 0.25 (about 100k quads), the L-shape (2 x 2 minus a
1 x 1 corner), a plate with 5 x 5 round holes, a 24-tooth gear (about 25k
quads each). Rows:

* ours: ``quad_grid(size=h)`` with ``smooth`` off and on, ``h = sqrt(area /
  N)``, the call timed after a warm-up loading numba's cache;
* Gmsh (OpenCASCADE geometry from the same polygon): ``Mesh.Algorithm`` 8
  (Frontal-Delaunay for quads), 9 (packing of parallelograms) and 11
  (quasi-structured quads), ``Mesh.RecombineAll = 1`` and
  ``Mesh.RecombinationAlgorithm = 3`` (Blossom full-quad) set before
  ``generate`` (``recombine()`` afterwards ignores the recombination
  algorithm), ``MeshSizeMin = MeshSizeMax`` calibrated to about the same
  count. Each Gmsh run is a child process with a 60 s limit.

Columns: wall and CPU seconds, quads, triangles left, least and mean quad
quality (8.4), least scaled Jacobian, share of interior vertices of valence
4. Ratios: Gmsh's wall time over ours (without smoothing).
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

from meshcore.grid import quad_grid  # noqa: E402
from meshcore.grid.cartesian import _quad_jacobian  # noqa: E402
from meshcore.mesh.quality import quad_quality  # noqa: E402


def _circle(cx, cy, r, h, start=0.0):
    n = max(16, 4 * math.ceil(2 * math.pi * r / h / 4))
    th = start + 2 * np.pi * np.arange(n) / n
    return np.column_stack([cx + r * np.cos(th), cy + r * np.sin(th)])[::-1]


def domains(h: float) -> dict:
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


def area(rings) -> float:
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


def gmsh_row(name: str, h: float, algorithm: int, s: float) -> dict | None:
    cmd = [sys.executable, __file__, "--child", name, str(h), str(algorithm), str(s)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=True)
    except subprocess.TimeoutExpired:
        return {"row": f"gmsh {algorithm}", "note": "past 60 s"}
    except subprocess.CalledProcessError as exc:
        return {"row": f"gmsh {algorithm}", "note": exc.stderr.strip().splitlines()[-1][:60]}
    return {"row": f"gmsh {algorithm}", **json.loads(out.stdout.strip().splitlines()[-1])}


def ours(rings, h: float, smooth: bool) -> dict:
    dom = {"type": "Polygon", "coordinates": [r.tolist() for r in rings]}
    w, c = time.perf_counter(), time.process_time()
    res = quad_grid(dom, size=h, smooth=smooth)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    P, Q = res.mesh.points, res.mesh.cells[0].data
    return {
        "row": "ours" + (" smooth" if smooth else ""),
        "wall": wall,
        "cpu": cpu,
        **measures(P, Q, 0),
    }


#: Gmsh's full-quad recombination splits each quad into four: MeshSize about
#: this many times our quad side gives about the same count (measured on the
#: square with a hole).
GMSH_SIZE = 1.3


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        name, h, alg, s = sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5])
        print(json.dumps(gmsh_child(domains(h)[name][1], alg, s)))
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--domains", nargs="+", default=["square_hole", "l_shape", "plate", "gear"])
    args = ap.parse_args()
    quad_grid({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}, size=0.1)
    try:
        import gmsh  # noqa: F401

        have_gmsh = True
    except ImportError:
        have_gmsh = False
        print("note: gmsh not installed (pip install -e .[bench]); its rows are skipped")
    print(
        f"{'domain':<12} {'row':<12} {'wall s':>7} {'cpu s':>7} {'x ours':>7} {'quads':>7} "
        f"{'tris':>5} {'Q min':>6} {'Q mean':>6} {'SJ min':>6} {'val4':>6}"
    )
    for name in args.domains:
        n, rings0 = domains(0.01)[name]
        h = math.sqrt(area(rings0) / n)
        rings = domains(h)[name][1]
        rows = [ours(rings, h, False), ours(rings, h, True)]
        if have_gmsh:
            rows += [gmsh_row(name, h, alg, GMSH_SIZE * h) for alg in (8, 9, 11)]
        ref = rows[0]["wall"]
        for r in rows:
            if "note" in r:
                print(f"{name:<12} {r['row']:<12} {r['note']}")
                continue
            print(
                f"{name:<12} {r['row']:<12} {r['wall']:>7.2f} {r['cpu']:>7.2f} "
                f"{r['wall'] / ref:>7.2f} {r['quads']:>7} {r['tris']:>5} {r['qmin']:>6.3f} "
                f"{r['qmean']:>6.3f} {r['sj']:>6.3f} {r['v4']:>6.3f}"
            )


if __name__ == "__main__":
    main()
