"""Side by side: ``tetrahedralize`` (ours) and TetGen on the same closed surfaces.

Run from the repository root::

    .venv/bin/python benchmarks/tetrahedralize.py
    .venv/bin/python benchmarks/tetrahedralize.py --shapes torus --size 0.08

Inputs: an icosphere (1,280 triangles), a torus (32 x 16 quads split) and a
box with a box-shaped cavity, each given to every tool as the same points
and triangles. Ours runs with the default ``max_radius_edge=2`` and with
``size`` alone (no radius-edge bound), TetGen with ``pq2`` (radius-edge 2),
``pq1.414`` and ``pY`` (boundary kept, no quality), all with ``-a`` from
the same volume bound where ``--size`` is given. TetGen gets ``add_hole``
for the cavity. Each row: wall seconds of the meshing call (ours after a
warm-up that loads numba's cache), tetrahedra, tetrahedra per second,
points added, least and largest dihedral angle (degrees), the largest
radius-edge ratio, and the ratio of our time to TetGen's ``pq2``.
TetGen is a bench-only dependency, skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.domain import parse_surface  # noqa: E402
from meshcore.tets import tetra_dihedral_angles, tetrahedralize  # noqa: E402
from meshcore.tets.refinement import _shortest_edge, _tet_circumcenters  # noqa: E402
from tests.meshcore.domain import shapes  # noqa: E402


def _cavity():
    P1, T1 = shapes.box((0, 0, 0), (3, 3, 3), 2)
    P2, T2 = shapes.box((1, 1, 1), (2, 2, 2))
    return np.concatenate([P1, P2]), np.concatenate([T1, T2 + len(P1)]), [[1.5, 1.5, 1.5]]


SHAPES = {
    "icosphere": lambda: (*shapes.icosphere(3), []),
    "torus": lambda: (*shapes.torus(nu=32, nv=16), []),
    "cavity": _cavity,
}


def _figures(P, K) -> tuple[float, float, float]:
    d = tetra_dihedral_angles(P, K)
    _, R = _tet_circumcenters(P, K)
    ratio = R / _shortest_edge(P, K)
    return float(d.min()), float(d.max()), float(np.nanmax(ratio))


def run_ours(P, T, **kw):
    s = parse_surface(P, T)
    tetrahedralize(parse_surface(*shapes.box()), **kw)  # warm-up (numba cache)
    t = time.perf_counter()
    r = tetrahedralize(s, **kw)
    dt = time.perf_counter() - t
    K = r.mesh.cells[0].data
    added = r.surface_points_added + r.interior_points_added
    return dt, r.mesh.points, K, added, r.given_up


def run_tetgen(P, T, holes, switches):
    import tetgen

    g = tetgen.TetGen(P, T.astype(np.int32))
    for h in holes:
        g.add_hole(h)
    t = time.perf_counter()
    nodes, elem = g.tetrahedralize(switches=switches + "Q")[:2]
    dt = time.perf_counter() - t
    return dt, np.asarray(nodes), np.asarray(elem, dtype=np.int64), len(nodes) - len(P)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=sorted(SHAPES))
    ap.add_argument("--size", type=float, default=None, help="target edge length (ours, TetGen -a)")
    args = ap.parse_args()
    try:
        import tetgen  # noqa: F401

        have_tetgen = True
    except ImportError:
        have_tetgen = False
        print("tetgen not installed (pip install -e .[bench]): TetGen rows skipped")
    head = f"{'input':<10} {'tool':<26} {'s':>7} {'tets':>8} {'tets/s':>8} {'added':>7} "
    head += f"{'dih min':>7} {'dih max':>7} {'r/e max':>8} {'x pq2':>6}"
    print(head)
    for name in args.shapes:
        P, T, holes = SHAPES[name]()
        rows = []
        extra = {} if args.size is None else {"size": args.size}
        dt, X, K, added, gu = run_ours(P, T, **extra)
        rows.append((f"ours r/e 2 (given up {gu})", dt, X, K, added))
        if args.size is not None:
            dt, X, K, added, gu = run_ours(P, T, size=args.size, max_radius_edge=None)
            rows.append(("ours size only", dt, X, K, added))
        ref = None
        if have_tetgen:
            vol = "" if args.size is None else f"a{args.size**3 / 8.48:.6g}"
            for sw in ("pq2", "pq1.414", "pY"):
                dt, X, K, added = run_tetgen(P, T, holes, sw + (vol if sw != "pY" else ""))
                rows.append((f"tetgen -{sw}", dt, X, K, added))
                if sw == "pq2":
                    ref = dt
        for tool, dt, X, K, added in rows:
            dmin, dmax, rmax = _figures(X, K)
            ratio = f"{dt / ref:6.2f}" if ref else "     -"
            print(
                f"{name:<10} {tool:<26} {dt:7.3f} {len(K):8d} {len(K) / dt:8.0f} {added:7d} "
                f"{dmin:7.2f} {dmax:7.2f} {rmax:8.2f} {ratio}"
            )


if __name__ == "__main__":
    main()
