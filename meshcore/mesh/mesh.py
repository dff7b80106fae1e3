"""The mesh type: points plus typed cell blocks, meshio's layout and names.

A :class:`Mesh` holds ``points`` of shape ``(n, d)`` (float64, ``d`` = 2 or 3)
and a tuple of :class:`CellBlock`, each a meshio cell type name and an
``(m, k)`` int64 array of point indices. ``point_data`` maps names to arrays
of length ``n``; ``cell_data`` and ``cell_sets`` map names to one array per
block (meshio's convention). Construction only fixes dtypes; :meth:`Mesh.check`
validates and raises :class:`~meshcore.errors.InputError` naming the offending
block, cell and index.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from meshcore.errors import InputError
from meshcore.geometry.tolerances import MAX_COORDINATE

__all__ = ["CELL_TYPES", "CellBlock", "Mesh"]

#: meshio cell type -> (nodes per cell, topological dimension)
CELL_TYPES: dict[str, tuple[int, int]] = {
    "vertex": (1, 0),
    "line": (2, 1),
    "triangle": (3, 2),
    "quad": (4, 2),
    "tetra": (4, 3),
    "pyramid": (5, 3),
    "wedge": (6, 3),
    "hexahedron": (8, 3),
}


@dataclass(frozen=True)
class CellBlock:
    """Cells of one type: ``data`` is ``(m, k)`` int64, ``k`` fixed by the type."""

    type: str
    data: np.ndarray

    def __post_init__(self) -> None:
        data = np.asarray(self.data, dtype=np.int64)
        if data.ndim == 1 and data.size == 0:
            data = data.reshape(0, CELL_TYPES.get(self.type, (0, 0))[0])
        object.__setattr__(self, "data", data)

    def __len__(self) -> int:
        return len(self.data)


@dataclass(frozen=True, eq=False)
class Mesh:
    """Points ``(n, d)`` float64 and cell blocks, with optional data and sets."""

    points: np.ndarray
    cells: tuple[CellBlock, ...]
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, list[np.ndarray]] = field(default_factory=dict)
    cell_sets: dict[str, list[np.ndarray]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=np.float64)
        if points.ndim == 1 and points.size == 0:
            points = points.reshape(0, 2)
        object.__setattr__(self, "points", points)
        cells = tuple(b if isinstance(b, CellBlock) else CellBlock(*b) for b in self.cells)
        object.__setattr__(self, "cells", cells)
        object.__setattr__(
            self, "point_data", {k: np.asarray(v) for k, v in self.point_data.items()}
        )
        object.__setattr__(
            self,
            "cell_data",
            {k: [np.asarray(a) for a in v] for k, v in self.cell_data.items()},
        )
        object.__setattr__(
            self,
            "cell_sets",
            {
                k: [np.asarray(a, dtype=np.int64).ravel() for a in v]
                for k, v in self.cell_sets.items()
            },
        )

    @property
    def dim(self) -> int:
        """Spatial dimension of the points (2 or 3)."""
        return self.points.shape[1]

    @property
    def n_cells(self) -> int:
        return sum(len(b) for b in self.cells)

    @cached_property
    def cells_by_type(self) -> dict[str, np.ndarray]:
        """All cells of each type, blocks of the same type concatenated in order."""
        out: dict[str, list[np.ndarray]] = {}
        for block in self.cells:
            out.setdefault(block.type, []).append(block.data)
        return {t: np.concatenate(a) if len(a) > 1 else a[0] for t, a in out.items()}

    def check(self) -> Mesh:
        """Validate the mesh and return it.

        Guarantees on return: points are ``(n, 2)`` or ``(n, 3)``, finite and
        at most ``MAX_COORDINATE`` in magnitude; there is at least one cell;
        every block has a known type no higher in dimension than the points, the right
        number of nodes per cell and indices in ``[0, n)``; no cell repeats a
        point; point data, cell data and cell sets have matching lengths.

        Raises
        ------
        InputError
            with ``loc`` naming the field, block, cell and index at fault.
        """
        pts = self.points
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise InputError(
                f"points must be a list of [x, y] or [x, y, z], got shape {pts.shape}",
                loc=("points",),
                code="bad_shape",
            )
        if len(pts) == 0:
            raise InputError("the mesh has no points", loc=("points",), code="empty_mesh")
        bad = ~np.isfinite(pts)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise InputError(
                f"point {i} has a non-finite coordinate ({pts[i, j]})",
                loc=("points", int(i), int(j)),
                code="non_finite",
            )
        big = np.abs(pts) > MAX_COORDINATE
        if big.any():
            i, j = np.argwhere(big)[0]
            raise InputError(
                f"point {i} has a coordinate of magnitude above {MAX_COORDINATE:g} ({pts[i, j]:g})",
                loc=("points", int(i), int(j)),
                code="out_of_range",
            )
        if not self.cells or self.n_cells == 0:
            raise InputError("the mesh has no cells", loc=("cells",), code="empty_mesh")
        n = len(pts)
        for b, block in enumerate(self.cells):
            if block.type not in CELL_TYPES:
                raise InputError(
                    f"cell block {b} has unknown type {block.type!r}; "
                    f"known types: {', '.join(CELL_TYPES)}",
                    loc=("cells", b, "type"),
                    code="unknown_cell_type",
                )
            k, cell_dim = CELL_TYPES[block.type]
            if cell_dim > pts.shape[1]:
                raise InputError(
                    f"cell block {b} ({block.type}) is {cell_dim}D but the points are "
                    f"{pts.shape[1]}D",
                    loc=("cells", b, "type"),
                    code="bad_dimension",
                )
            data = block.data
            if data.ndim != 2 or data.shape[1] != k:
                raise InputError(
                    f"cell block {b} ({block.type}) needs {k} indices per cell, "
                    f"got shape {data.shape}",
                    loc=("cells", b, "data"),
                    code="bad_shape",
                )
            out = (data < 0) | (data >= n)
            if out.any():
                c, j = np.argwhere(out)[0]
                raise InputError(
                    f"cell {c} of block {b} ({block.type}) refers to point {data[c, j]}, "
                    f"but there are only {n} points",
                    loc=("cells", b, "data", int(c), int(j)),
                    code="index_out_of_range",
                )
            if k > 1 and len(data):
                s = np.sort(data, axis=1)
                rep = (s[:, 1:] == s[:, :-1]).any(axis=1)
                if rep.any():
                    c = int(np.flatnonzero(rep)[0])
                    raise InputError(
                        f"cell {c} of block {b} ({block.type}) repeats a point: {data[c].tolist()}",
                        loc=("cells", b, "data", c),
                        code="degenerate_cell",
                    )
        for name, values in self.point_data.items():
            if len(values) != n:
                raise InputError(
                    f"point data {name!r} has {len(values)} values for {n} points",
                    loc=("point_data", name),
                    code="bad_shape",
                )
        for kind, table in (("cell_data", self.cell_data), ("cell_sets", self.cell_sets)):
            for name, arrays in table.items():
                if len(arrays) != len(self.cells):
                    raise InputError(
                        f"{kind} {name!r} has {len(arrays)} arrays for {len(self.cells)} blocks",
                        loc=(kind, name),
                        code="bad_shape",
                    )
                for b, (a, block) in enumerate(zip(arrays, self.cells, strict=True)):
                    if kind == "cell_data" and len(a) != len(block):
                        raise InputError(
                            f"{kind} {name!r} has {len(a)} values for the {len(block)} "
                            f"cells of block {b}",
                            loc=(kind, name, b),
                            code="bad_shape",
                        )
                    if kind == "cell_sets" and len(a) and (a.min() < 0 or a.max() >= len(block)):
                        raise InputError(
                            f"cell set {name!r} refers to a cell outside block {b} "
                            f"({len(block)} cells)",
                            loc=(kind, name, b),
                            code="index_out_of_range",
                        )
        return self
