"""Delaunay-admissible surfaces in 3D: Steiner points, ours vs TetGen ``-pD``.

Run from the repository root::

    .venv/bin/python benchmarks/admissible3d.py
    .venv/bin/python benchmarks/admissible3d.py --shapes bumpy --repeat 1

For each closed surface: the points each side adds so that every surface
triangle (ours: every output triangle, each inside one input triangle) is a
face of the Delaunay tetrahedralization of the points, and the wall seconds
of the call (median of ``--repeat`` runs; ours after a warm-up that loads
numba's cache). TetGen's ``-pD`` ("conforming Delaunay": Steiner points on
the boundary until the boundary is Delaunay) meshes the whole volume: its
count is ``len(nodes) - len(points)`` (with ``-pD`` and no quality switch
its points are boundary points). The two "missing" columns check both
sides by one exact rule: the output boundary triangles (TetGen's
``trifaces``) that are not faces of our kernel's Delaunay
tetrahedralization of the output points, recomputed from scratch, with its
symbolic perturbation deciding co-spherical ties. TetGen decides such ties
its own way (its output is a Delaunay tetrahedralization, not ours), so on
inputs with co-circular faces (cube, torus) it adds nothing where ours must
split the faces whose diagonal our tie-breaking rejects.

Inputs: Schönhardt's prism (30° twist), the unit cube (12 triangles), an
icosphere (level 3), a torus (32 x 16) and a *bumpy sphere*: 4,000
directions on a Fibonacci spiral, their convex hull's triangles, radii
``1 + 0.15 sin(6 theta) sin(5 phi)`` (star-shaped, so a valid closed
surface). TetGen is a bench-only dependency, skipped with a note when
absent.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from meshcore.delaunay.admissible3d import make_admissible_surface  # noqa: E402
from meshcore.delaunay.kernel3d import delaunay3d  # noqa: E402
from meshcore.domain import parse_surface  # noqa: E402
from tests.meshcore.domain import shapes  # noqa: E402


def bumpy_sphere(n: int = 4000, amplitude: float = 0.15):
    """A star-shaped bumpy sphere of ``n`` vertices (Fibonacci directions)."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5**0.5) * i
    d = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    r = 1 + amplitude * np.sin(6 * theta) * np.sin(5 * phi)
    return shapes.star(r, d)


SHAPES = {
    "schonhardt": shapes.schonhardt,
    "cube": shapes.box,
    "icosphere": lambda: shapes.icosphere(3),
    "torus": lambda: shapes.torus(nu=32, nv=16),
    "bumpy": bumpy_sphere,
}


def missing_faces(points, triangles) -> int:
    """Output triangles that are not faces of our kernel's tetrahedralization (from scratch)."""
    used, tri = np.unique(triangles, return_inverse=True)
    D = delaunay3d(points[used])
    tri = tri.reshape(-1, 3)
    faces = np.sort(D.tetra[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), 1)
    have = {tuple(f) for f in faces.tolist()}
    return sum(tuple(sorted(t)) not in have for t in tri.tolist())


def run_ours(P, T, repeat):
    s = parse_surface(P, T)
    make_admissible_surface(parse_surface(*shapes.box()))  # warm-up (numba cache)
    times, res = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        res = make_admissible_surface(s)
        times.append(time.perf_counter() - t)
    return statistics.median(times), res


def run_tetgen(P, T, repeat):
    import tetgen

    times, added, missing = [], 0, 0
    for _ in range(repeat):
        g = tetgen.TetGen(P, T.astype(np.int32))
        t = time.perf_counter()
        nodes = g.tetrahedralize(switches="pDQ")[0]
        times.append(time.perf_counter() - t)
        added = len(nodes) - len(P)
        missing = missing_faces(np.asarray(nodes), np.asarray(g.trifaces, dtype=np.int64))
    return statistics.median(times), added, missing


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=list(SHAPES))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    try:
        import tetgen  # noqa: F401

        have_tetgen = True
    except ImportError:
        have_tetgen = False
        print("tetgen not installed (pip install -e .[bench]): TetGen column skipped")
    print(f"load average: {os.getloadavg()[0]:.1f}")
    print(
        f"{'input':<11} {'vertices':>8} {'ours added':>10} {'(edges':>7} {'faces)':>7} "
        f"{'ours s':>7} {'tetgen -pD added':>16} {'tetgen s':>8} {'time ratio':>10} "
        f"{'tetgen missing':>14} {'ours missing':>12}"
    )
    for name in args.shapes:
        P, T = SHAPES[name]()
        dt, r = run_ours(P, T, args.repeat)
        added = r.added_on_edges + r.added_on_faces
        if have_tetgen:
            tt, tadded, tmiss = run_tetgen(P, T, args.repeat)
            peer = f"{tadded:16d} {tt:8.3f} {dt / tt:10.2f} {tmiss:14d}"
        else:
            peer = f"{'-':>16} {'-':>8} {'-':>10} {'-':>14}"
        print(
            f"{name:<11} {len(np.unique(T)):8d} {added:10d} {r.added_on_edges:7d} "
            f"{r.added_on_faces:7d} {dt:7.3f} {peer} {missing_faces(r.points, r.triangles):12d}"
        )


if __name__ == "__main__":
    main()
