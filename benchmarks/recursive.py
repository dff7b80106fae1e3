"""Side by side: ``recursive_partition`` (ours, §8.7.2) against Gmsh and ``triangulate``.

Run from the repository root::

    .venv/bin/python benchmarks/recursive.py                    # 10k and 100k cells
    .venv/bin/python benchmarks/recursive.py --sizes 10000

Domains and columns as in ``benchmarks/paving.py`` (the square with a hole
and the L-shape; ``h = sqrt(area / N)`` for quads, ``h = sqrt(4 area / (sqrt(3) N))``
for about N triangles). Triangles: Gmsh's default 2D algorithm (6,
Frontal-Delaunay) and our ``triangulate`` against ``recursive_partition``
with ``element="triangle"``; quality is the normalized shape ratio
(:func:`meshcore.mesh.quality.triangle_shape`, 1 for equilateral). Quads:
Gmsh algorithms 8 (with ``RecombinationAlgorithm = 3``), 9 and 11
(``RecombineAll = 1``) against ``recursive_partition`` with
``element="quad"``; quality (8.4). ``valence-4`` is then the share of
interior vertices of valence 6 for triangles (the regular valence).
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from benchmarks.paving import (  # noqa: E402
    AREAS,
    describe,
    geometry,
    gmsh_model,
    main,
)
from benchmarks.quads import gmsh_cells  # noqa: E402


def describe_triangles(P, T, seconds) -> dict:
    from meshcore.mesh.quality import signed_area, triangle_angles, triangle_shape

    cw = signed_area(P, T, "triangle") < 0
    T = T.copy()
    T[cw] = T[cw, ::-1]
    q = triangle_shape(P, T)
    e = np.sort(np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    eu, cnt = np.unique(e, axis=0, return_counts=True)
    deg = np.bincount(eu.ravel(), minlength=len(P))
    on_b = np.zeros(len(P), bool)
    on_b[eu[cnt == 1].ravel()] = True
    used = np.zeros(len(P), bool)
    used[T.ravel()] = True
    inner = used & ~on_b
    return {
        "seconds": seconds,
        "quads": 0,
        "triangles": int(len(T)),
        "min": float(q.min()),
        "mean": float(q.mean()),
        "min_sj": float(np.sin(np.radians(triangle_angles(P, T))).min() * 2 / math.sqrt(3)),
        "valence4": float(np.mean(deg[inner] == 6)),
        "irregular_boundary": -1,
    }


def child(tool: str, domain: str, n: int) -> dict:
    tri = tool.endswith("-tri")
    h = math.sqrt(4 * AREAS[domain] / (math.sqrt(3) * n)) if tri else math.sqrt(AREAS[domain] / n)
    if tool.startswith("gmsh"):
        gmsh = gmsh_model(domain, h)
        if not tri:
            algo = int(tool[4:])
            gmsh.option.setNumber("Mesh.Algorithm", algo)
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
            if algo == 8:
                gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
        t = time.perf_counter()
        gmsh.model.mesh.generate(2)
        seconds = time.perf_counter() - t
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        if tri:
            return describe_triangles(P, cells["triangle"], seconds)
        return describe(P, cells["quad"], cells["triangle"], seconds)
    from meshcore.partition import recursive_partition
    from meshcore.triangulation import triangulate

    g = geometry(domain)
    if tool == "triangulate-tri":
        triangulate(g, size=0.1)  # warm-up: numba's cache
        t = time.perf_counter()
        res = triangulate(g, size=h)
        seconds = time.perf_counter() - t
        return describe_triangles(res.mesh.points, res.mesh.cells[0].data, seconds)
    element = "triangle" if tri else "quad"
    recursive_partition(g, size=0.1, element=element)  # warm-up
    t = time.perf_counter()
    res = recursive_partition(g, size=h, element=element)
    seconds = time.perf_counter() - t
    P, C = res.mesh.points, res.mesh.cells[0].data
    out = describe_triangles(P, C, seconds) if tri else describe(P, C, np.zeros((0, 3)), seconds)
    out["stats"] = {k: res.stats[k] for k in ("depth", "fallback", "separators", "patterns")}
    out["phases"] = res.stats["seconds"]
    return out


LABELS = {
    "gmsh-tri": "Gmsh default 2D (6), triangles",
    "triangulate-tri": "ours triangulate, triangles",
    "ours-tri": "ours recursive_partition, triangles",
    "gmsh8": "Gmsh 8 + Blossom full-quad (3), quads",
    "gmsh9": "Gmsh 9, quads",
    "gmsh11": "Gmsh 11, quads",
    "ours": "ours recursive_partition, quads",
}


if __name__ == "__main__":
    main(os.path.abspath(__file__), child, LABELS, "ours")
