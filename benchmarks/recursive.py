"""Side by side: ``recursive_partition`` (ours, §8.7.2) against Gmsh and ``triangulate``.

Run from the repository root::

    .venv/bin/python benchmarks/recursive.py                    # 10k and 100k cells
    .venv/bin/python benchmarks/recursive.py --sizes 10000

Domains and columns as in ``benchmarks/paving.py`` (the square with a hole,
the L-shape, the plate with 20 holes and the gear; ``h = sqrt(area / N)``
for quads, ``h = sqrt(4 area / (sqrt(3) N))`` for about N triangles).
Triangles: Gmsh's default 2D algorithm (6, Frontal-Delaunay) and our
``triangulate`` against ``recursive_partition`` with ``element="triangle"``;
quality is the normalized shape ratio
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
    describe,
    geometry,
    gmsh_model,
    gmsh_quads,
    main,
    size_for,
)
from benchmarks.quads import gmsh_cells  # noqa: E402


def describe_triangles(P, T, seconds, cpu) -> dict:
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
        "cpu": cpu,
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
    # about n triangles: the quad size for n / 2 quads, times sqrt(4 / (2 sqrt(3)))
    h = size_for(domain, n // 2) * math.sqrt(2 / math.sqrt(3)) if tri else size_for(domain, n)
    if tool.startswith("gmsh") and not tri:
        return gmsh_quads(domain, int(tool[4:]), h, n)
    if tool.startswith("gmsh"):
        gmsh = gmsh_model(domain, h)
        t, c = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        P, cells = gmsh_cells(gmsh)
        gmsh.finalize()
        return describe_triangles(P, cells["triangle"], seconds, cpu)
    from meshcore.partition import recursive_partition
    from meshcore.triangulation import triangulate

    g = geometry(domain, h)
    warm = geometry(domain, 0.1)
    if tool == "triangulate-tri":
        triangulate(warm, size=0.1)  # warm-up: numba's cache
        t, c = time.perf_counter(), time.process_time()
        res = triangulate(g, size=h)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        return describe_triangles(res.mesh.points, res.mesh.cells[0].data, seconds, cpu)
    element = "triangle" if tri else "quad"
    recursive_partition(warm, size=0.1, element=element)  # warm-up
    t, c = time.perf_counter(), time.process_time()
    res = recursive_partition(g, size=h, element=element)
    seconds, cpu = time.perf_counter() - t, time.process_time() - c
    P, C = res.mesh.points, res.mesh.cells[0].data
    out = (
        describe_triangles(P, C, seconds, cpu)
        if tri
        else describe(P, C, np.zeros((0, 3)), seconds, cpu)
    )
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
