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
its points are boundary points). TetGen runs twice: ``-pD`` as the issue
names it, and ``-pDM`` (no merging of coplanar facets): without ``-M``
TetGen merges adjacent input triangles that are coplanar up to its
tolerance and flips their common edge, so its output triangles are not in
the input triangles (column ``changed``: input edges its surface neither
keeps nor splits); with ``-M`` its surface is the input's, as ours.
``missing``, ours: defects of the result's ``tetrahedra`` as a Delaunay
tetrahedralization holding every output triangle, all checked exactly
(output triangles that are not faces, tetrahedra not positive, faces in
more than two, neighbours' far corners strictly inside a circumsphere;
-1 if the volume is not the hull's); TetGen's: its ``trifaces`` that are not
faces of our kernel's Delaunay tetrahedralization of its output points,
recomputed from scratch (its symbolic perturbation decides co-spherical
ties, which TetGen decides its own way: its count on boxes is not a defect,
on random inputs it is).

Inputs: Schönhardt's prism (30° twist), the unit cube (12 triangles), an
icosphere (level 3), a torus (32 x 16), a *bumpy sphere*: 4,000
directions on a Fibonacci spiral, their convex hull's triangles, radii
``1 + 0.15 sin(6 theta) sin(5 phi)`` (star-shaped, so a valid closed
surface), a thin slab (1 x 1 x 0.01, each face a 4 x 4 grid), the
L-block (an L-shaped prism whose caps are fans), a *lens*
(a bipyramid over 7 points at radius 0.8-1.2 around the axis, apexes at
+-0.1: dihedral angles of 10-14° along its rim) and a *knife* (a triangular
prism over a 10° wedge, top turned by 3°: a dihedral angle of 7°),
and the random star polyhedra of ``benchmarks/robustness3d.py`` (seeds
``--stars`` first..last, one row for all: sums, and the seeds where ours
adds more than TetGen). Times are CPU seconds of this process (both sides
run in it, single-threaded), so the load changes them less than wall
time. TetGen is a bench-only dependency, skipped with a note when absent.
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

from benchmarks.robustness3d import star_polyhedron  # noqa: E402
from meshcore.delaunay.admissible3d import make_admissible_surface  # noqa: E402
from meshcore.delaunay.kernel3d import delaunay3d  # noqa: E402
from meshcore.domain import parse_surface  # noqa: E402
from tests.meshcore.delaunay.test_admissible3d import delaunay_defects  # noqa: E402
from tests.meshcore.domain import shapes  # noqa: E402


def lens(k: int = 7):
    """A flat bipyramid over ``k`` points around the axis: small dihedral angles at its rim."""
    rng = np.random.default_rng(7)
    a = 2 * np.pi * (np.arange(k) + rng.uniform(-0.2, 0.2, k)) / k
    r = rng.uniform(0.8, 1.2, k)
    ring = np.stack([r * np.cos(a), r * np.sin(a), rng.uniform(-0.005, 0.005, k)], 1)
    P = np.concatenate([ring, [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]]])
    i = np.arange(k)
    j = (i + 1) % k
    T = np.concatenate([np.stack([i, j, np.full(k, k)], 1), np.stack([j, i, np.full(k, k + 1)], 1)])
    return P, T


def knife(angle: float = 10.0, turn: float = 3.0):
    """A triangular prism over a thin wedge, its top turned: sharp dihedral angles."""
    w = np.radians(angle)
    base = np.array([[0.0, 0.0], [1.0, 0.0], [np.cos(w), np.sin(w)]])
    c = base.mean(axis=0)
    t = np.radians(turn)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    top = (base - c) @ rot.T + c
    P = np.concatenate([np.column_stack([base, np.zeros(3)]), np.column_stack([top, np.ones(3)])])
    i = np.arange(3)
    j = (i + 1) % 3
    T = np.concatenate(
        [[[0, 2, 1], [3, 4, 5]], np.stack([i, j, j + 3], 1), np.stack([i, j + 3, i + 3], 1)]
    )
    return P, T


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
    "slab": lambda: shapes.box((0.0, 0.0, 0.0), (1.0, 1.0, 0.01), n=4),
    "lblock": shapes.l_block,
    "lens": lens,
    "knife": knife,
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
    times, res = [], None
    for _ in range(repeat):
        t = time.process_time()
        res = make_admissible_surface(s)
        times.append(time.process_time() - t)
    return statistics.median(times), res


def changed_edges(P, T, nodes, trifaces) -> int:
    """Input edges TetGen's surface neither keeps nor splits (no Steiner point on them):
    it merged the two (nearly coplanar) triangles and flipped their common edge, so its
    output triangles are not on the input surface."""
    P = np.asarray(P, dtype=float)

    def edges(F):
        E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        return {tuple(e) for e in E.tolist()}

    X = np.asarray(nodes, dtype=float)[len(P) :]
    scale = np.abs(P).max()
    count = 0
    for a, b in edges(np.asarray(T)) - edges(np.asarray(trifaces)):
        d = P[b] - P[a]
        t = (X - P[a]) @ d / (d @ d)
        gap = np.linalg.norm(P[a] + t[:, None] * d - X, axis=1)
        count += not ((gap < 1e-9 * scale) & (t > 0) & (t < 1)).any()
    return count


def run_tetgen(P, T, repeat, switches):
    """(CPU s, points added, output triangles not Delaunay by our rule, changed edges)."""
    import tetgen

    times = []
    for _ in range(repeat):
        g = tetgen.TetGen(P, T.astype(np.int32))
        t = time.process_time()
        nodes = g.tetrahedralize(switches=switches)[0]
        times.append(time.process_time() - t)
    tri = np.asarray(g.trifaces, dtype=np.int64)
    nodes = np.asarray(nodes)
    return (
        statistics.median(times),
        len(nodes) - len(P),
        missing_faces(nodes, tri),
        changed_edges(P, T, nodes, tri),
    )


def measure(P, T, repeat, have_tetgen):
    """Ours (added, on edges, on faces, s, missing), then per TetGen switch set
    (s, added, missing, changed)."""
    dt, r = run_ours(P, T, repeat)
    bad = delaunay_defects(r.points, r.tetrahedra, r.triangles)
    ours = (
        r.added_on_edges + r.added_on_faces,
        r.added_on_edges,
        r.added_on_faces,
        dt,
        sum(bad.values()) if bad.pop("volume_gap") < 1e-9 else -1,
    )
    return ours, [run_tetgen(P, T, repeat, sw) for sw in TETGEN] if have_tetgen else []


#: TetGen's conforming Delaunay as the issue names it, and with -M (no merging of
#: coplanar facets: its output triangles stay in the input triangles, as ours).
TETGEN = ("pDQ", "pDMQ")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shapes", nargs="+", default=[*SHAPES, "stars"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--stars", type=int, nargs=2, default=(1, 40), metavar=("FIRST", "LAST"))
    args = ap.parse_args()
    try:
        import tetgen  # noqa: F401

        have_tetgen = True
    except ImportError:
        have_tetgen = False
        print("tetgen not installed (pip install -e .[bench]): TetGen columns skipped")
    make_admissible_surface(parse_surface(*shapes.box()))  # warm-up (numba cache)
    print(f"load average: {os.getloadavg()[0]:.1f}; CPU seconds; medians of {args.repeat}")
    head = f"{'input':<11} {'vertices':>8} {'ours: added':>11} {'edges':>6} {'faces':>6} "
    head += f"{'s':>7} {'missing':>7}"
    for sw in TETGEN if have_tetgen else ():
        head += f" | {'-' + sw[:-1]:>6}: {'added':>6} {'s':>7} {'ratio':>6} {'missing':>7}"
        head += f" {'changed':>7}"
    print(head)
    for name in args.shapes:
        if name == "stars":
            seeds = list(range(args.stars[0], args.stars[1] + 1))
            cases = [star_polyhedron(seed) for seed in seeds]
            cases = [(np.asarray(c["points"]), np.asarray(c["triangles"])) for c in cases]
            label = f"stars x{len(cases)}"
        else:
            seeds, cases, label = [], [SHAPES[name]()], name
        rows = [measure(P, T, args.repeat, have_tetgen) for P, T in cases]
        ours = np.sum([o for o, _ in rows], axis=0)
        vertices = sum(len(np.unique(T)) for _, T in cases)
        line = f"{label:<11} {vertices:8d} {int(ours[0]):11d} {int(ours[1]):6d} {int(ours[2]):6d} "
        line += f"{ours[3]:7.3f} {int(ours[4]):7d}"
        more = {}
        for k, sw in enumerate(TETGEN if have_tetgen else ()):
            peer = np.sum([p[k] for _, p in rows], axis=0)
            line += (
                f" | {'':>6}  {int(peer[1]):6d} {peer[0]:7.3f} {ours[3] / max(peer[0], 1e-9):6.1f} "
            )
            line += f"{int(peer[2]):7d} {int(peer[3]):7d}"
            more[sw] = [
                (s, "" if p[k][2] == p[k][3] == 0 else "*")
                for s, (o, p) in zip(seeds, rows, strict=False)
                if o[0] > p[k][1]
            ]
        print(line)
        for sw, seen in more.items():
            if seen:
                text = " ".join(f"{s}{mark}" for s, mark in seen)
                print(
                    f"  ours adds more than -{sw[:-1]} (*: its output missing or changed): {text}"
                )


if __name__ == "__main__":
    main()
