"""Time :func:`meshcore.mesh.quality.report` on large structured meshes.

Prints one row per mesh: cell type, number of cells and points, the best of
three wall-clock times of our whole report (validation, quality measure,
area or volume, histogram, angle extremes and the conformity count), and,
when Gmsh is installed (``pip install -e .[bench]``), the best of three of
``gmsh.model.mesh.getElementQualities`` on the same elements (``gamma`` for
triangles, ``minSJ``, the scaled Jacobian, for quads and hexahedra) and the
ratio ours / Gmsh's. Gmsh computes one measure per element and nothing else,
so the ratio flatters Gmsh; it is there to show we are in the same league.

Run with ``.venv/bin/python benchmarks/quality.py``.
"""

from __future__ import annotations

import time

import numpy as np

from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.quality import report


def grid_2d(nx: int, ny: int, cell_type: str) -> Mesh:
    """A structured grid of the unit square: quads, or each quad split into two triangles."""
    x, y = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1), indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel()])
    ids = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    a, b = ids[:-1, :-1].ravel(), ids[1:, :-1].ravel()
    c, d = ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()
    if cell_type == "quad":
        cells = np.column_stack([a, b, c, d])
    else:
        cells = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return Mesh(points, (CellBlock(cell_type, cells),))


def grid_3d(n: int) -> Mesh:
    """A structured ``n x n x n`` grid of hexahedra over the unit cube."""
    g = np.linspace(0, 1, n + 1)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    ids = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)

    def corner(i: int, j: int, k: int) -> np.ndarray:
        return ids[i : n + i, j : n + j, k : n + k].ravel()

    cells = np.column_stack(
        [corner(0, 0, 0), corner(1, 0, 0), corner(1, 1, 0), corner(0, 1, 0)]
        + [corner(0, 0, 1), corner(1, 0, 1), corner(1, 1, 1), corner(0, 1, 1)]
    )
    return Mesh(points, (CellBlock("hexahedron", cells),))


def shuffled(mesh: Mesh, seed: int = 0) -> Mesh:
    """The same mesh with points and cells renumbered at random (no locality left)."""
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(mesh.points))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))
    blocks = tuple(CellBlock(b.type, inverse[b.data][rng.permutation(len(b))]) for b in mesh.cells)
    return Mesh(mesh.points[perm], blocks)


def best_of(run, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    return best


# Gmsh element type numbers and the Gmsh measure closest to ours
_GMSH = {"triangle": (2, 2, "gamma"), "quad": (3, 2, "minSJ"), "hexahedron": (5, 3, "minSJ")}


def gmsh_time(mesh: Mesh) -> float | None:
    """Best of three of Gmsh's element quality on the same elements; None without Gmsh."""
    try:
        import gmsh
    except ImportError:
        return None
    block = mesh.cells[0]
    etype, dim, measure = _GMSH[block.type]
    points = mesh.points
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("bench")
        tag = gmsh.model.addDiscreteEntity(dim)
        gmsh.model.mesh.addNodes(dim, tag, np.arange(1, len(points) + 1), points.ravel())
        elements = np.arange(1, len(block) + 1)
        gmsh.model.mesh.addElementsByType(tag, etype, elements, (block.data + 1).ravel())
        return best_of(lambda: gmsh.model.mesh.getElementQualities(elements, measure))
    finally:
        gmsh.finalize()


def main() -> None:
    cases = [
        ("triangle, structured", grid_2d(707, 707, "triangle")),
        ("triangle, shuffled", None),
        ("quad, structured", grid_2d(1000, 1000, "quad")),
        ("hexahedron, structured", grid_3d(59)),
    ]
    cases[1] = ("triangle, shuffled", shuffled(cases[0][1]))
    print(f"{'mesh':<24} {'cells':>10} {'points':>10} {'ours [s]':>9} {'gmsh [s]':>9} {'ratio':>6}")
    missing = False
    for name, mesh in cases:
        ours = best_of(lambda mesh=mesh: report(mesh))
        peer = gmsh_time(mesh)
        missing |= peer is None
        other = f"{peer:>9.3f} {ours / peer:>6.2f}" if peer else f"{'-':>9} {'-':>6}"
        print(f"{name:<24} {mesh.n_cells:>10,} {len(mesh.points):>10,} {ours:>9.3f} {other}")
    if missing:
        print("gmsh is not installed (pip install -e .[bench]): its column is skipped")


if __name__ == "__main__":
    main()
