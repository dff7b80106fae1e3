"""Side by side: ``recursive_partition`` in 3D (ours, §8.7.2) against TetGen with the boundary kept.

Run from the repository root::

    .venv/bin/python benchmarks/recursive3d.py
    .venv/bin/python benchmarks/recursive3d.py --shapes box torus

Both sides add no point on the surface (ours never does; TetGen with
``-Y``): TetGen ``pY`` (no interior point unless needed) and ``pYa<v>``
with ``v = h^3 / (6 sqrt 2)``, the volume of a regular tetrahedron of edge
``h`` (interior points to about our size), on the same points and
triangles. Inputs: a unit box sampled on a grid (``h`` = its spacing), the
torus of the tetrahedralization benchmark (32 x 16), an icosphere (1,280
triangles) and the L-block. Each row: CPU seconds of the call (after a
warm-up that loads numba's cache; median of ``--repeat``), tetrahedra,
points added, least dihedral angle (degrees), share of tetrahedra under 10
degrees, least and mean normalized radius ratio
(:func:`meshcore.mesh.quality.report`), and our CPU time over TetGen's.
TetGen is a bench-only dependency, skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.mesh import CellBlock, Mesh, quality  # noqa: E402
from meshcore.partition import recursive_partition  # noqa: E402
from meshcore.tets import tetra_dihedral_angles  # noqa: E402
from tests.meshcore.domain import shapes  # noqa: E402

SHAPES = {
    "box": lambda: (shapes.box(n=8), 0.125),
    "torus": lambda: (shapes.torus(nu=32, nv=16), 0.3),
    "icosphere": lambda: (shapes.icosphere(3), 0.1),
    "l_block": lambda: (shapes.l_block(), 0.5),
}


def figures(P, K) -> dict:
    d = tetra_dihedral_angles(P, K).min(axis=1)
    q = quality.report(Mesh(P, (CellBlock("tetra", K),)))["tetra"]["quality"]
    return {
        "tets": len(K),
        "min_dih": float(d.min()),
        "under10": 100.0 * float((d < 10).mean()),
        "q_min": q["min"],
        "q_mean": q["mean"],
    }


def ours(P, T, h):
    c = time.process_time()
    r = recursive_partition(surface=(P, T), size=h)
    cpu = time.process_time() - c
    out = figures(r.mesh.points, r.mesh.cells[0].data)
    return cpu, out | {"added": len(r.mesh.points) - len(np.unique(T))}, r.stats


def tetgen_run(P, T, switches):
    import tetgen

    g = tetgen.TetGen(P, T.astype(np.int32))
    c = time.process_time()
    nodes, elem = g.tetrahedralize(switches=switches + "Q")[:2]
    cpu = time.process_time() - c
    nodes, elem = np.asarray(nodes), np.asarray(elem, dtype=np.int64)
    return cpu, figures(nodes, elem) | {"added": len(nodes) - len(np.unique(T))}, None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=list(SHAPES))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    recursive_partition(surface=shapes.box(n=2), size=0.5)  # warm-up: numba's cache
    try:
        import tetgen  # noqa: F401

        have_tetgen = True
    except ImportError:
        have_tetgen = False
        print("note: tetgen not installed (pip install -e .[bench]); its rows are skipped")
    print(f"load: {os.getloadavg()}")
    head = "| shape | run | CPU s | tets | added | least dihedral | < 10 deg % | least q | mean q |"
    print(head + " ours / TetGen |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in args.shapes:
        (P, T), h = SHAPES[name]()
        runs = {f"ours, size {h}": lambda P=P, T=T, h=h: ours(P, T, h)}
        if have_tetgen:
            vol = h**3 / (6 * math.sqrt(2))
            runs["TetGen pY"] = lambda P=P, T=T: tetgen_run(P, T, "pY")
            runs[f"TetGen pYa{vol:.3g}"] = lambda P=P, T=T, v=vol: tetgen_run(P, T, f"pYa{v:.6g}")
        rows = {}
        for label, fn in runs.items():
            cpus = []
            for _ in range(args.repeat):
                cpu, fig, stats = fn()
                cpus.append(cpu)
            rows[label] = (statistics.median(cpus), fig, stats)
        ref = rows.get("TetGen pY", (None,))[0]
        for label, (cpu, f, stats) in rows.items():
            ratio = f"{cpu / ref:.0f}x" if ref and label.startswith("ours") else ""
            print(
                f"| {name} | {label} | {cpu:.3f} | {f['tets']:,} | {f['added']:,} | "
                f"{f['min_dih']:.2f} | {f['under10']:.1f} | {f['q_min']:.3f} | "
                f"{f['q_mean']:.3f} | {ratio} |"
            )
            if stats:
                print(
                    f"|  | stats: depth {stats['depth']}, leaves {stats['patterns']}, "
                    f"steiner {stats['steiner_points']}, oversized {stats['oversized_leaves']} "
                    "| | | | | | | | |"
                )


if __name__ == "__main__":
    main()
