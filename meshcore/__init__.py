"""meshcore: the meshing library behind meshservice (numpy/scipy/numba, no HTTP).

The packages are the table of contents of the methods text: the shared
kernel (:mod:`.geometry`, :mod:`.mesh`, :mod:`.domain`, :mod:`.delaunay`)
below one package per method family (:mod:`.triangulation`,
:mod:`.product`, :mod:`.quads`, :mod:`.medial`, :mod:`.grid`, :mod:`.partition`,
:mod:`.optimize`, :mod:`.tets`). Each method's entry point is re-exported
here, loaded on first use (as are :class:`~meshcore.mesh.Mesh`,
``CellBlock`` and ``CELL_TYPES``) so that ``import meshcore`` stays cheap
(the standard library only)::

    from meshcore import parse_domain, triangulate, medial_axis, extrude

A name that is also a subpackage (``delaunay``, ``grid``, ``optimize``,
``partition``) is imported from its package instead: ``from
meshcore.delaunay import delaunay``, ``from meshcore.grid import grid``,
``from meshcore.medial import partition`` (the medial-axis partition;
``meshcore.partition`` is the recursive-partition package).
"""

from __future__ import annotations

import importlib

from meshcore.errors import AlgorithmError, Cancelled, InputError, MeshcoreError

_ENTRY_POINTS = {
    "CELL_TYPES": "meshcore.mesh",
    "CellBlock": "meshcore.mesh",
    "Mesh": "meshcore.mesh",
    "parse_domain": "meshcore.domain",
    "parse_surface": "meshcore.domain",
    "tetrahedralize": "meshcore.tets",
    "make_admissible": "meshcore.delaunay",
    "triangulate": "meshcore.triangulation",
    "extrude": "meshcore.product",
    "sweep": "meshcore.product",
    "merged": "meshcore.product",
    "radial": "meshcore.product",
    "combine": "meshcore.quads",
    "quad_grid": "meshcore.grid",
    "pattern": "meshcore.grid",
    "optimize_quads": "meshcore.quads",
    "paving": "meshcore.quads",
    "medial_axis": "meshcore.medial",
    "medial_transform": "meshcore.medial",
    "quad_medial": "meshcore.medial",
    "simplify": "meshcore.medial",
    "recursive_partition": "meshcore.partition",
    "report": "meshcore.mesh.quality",
}

__all__ = ["AlgorithmError", "Cancelled", "InputError", "MeshcoreError", *_ENTRY_POINTS]


def __getattr__(name: str):
    """The entry point or mesh type ``name``, imported from its package on first use."""
    if name in _ENTRY_POINTS:
        value = getattr(importlib.import_module(_ENTRY_POINTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'meshcore' has no attribute {name!r}")
