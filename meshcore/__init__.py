"""meshcore: the meshing library behind meshservice (numpy/scipy/numba, no HTTP).

The data types and errors are here; each method family is a module named
after it, holding its entry point: ``delaunay.delaunay``,
``domain.parse_domain``, ``admissible.make_admissible``,
``triangulate.triangulate``, ``product.extrude`` and ``product.sweep``,
``merge.merged``, ``radial.radial``, ``quality.report``, and ``io`` for
files and JSON.
"""

from meshcore.errors import AlgorithmError, Cancelled, InputError, MeshcoreError
from meshcore.mesh import CELL_TYPES, CellBlock, Mesh

__all__ = [
    "CELL_TYPES",
    "AlgorithmError",
    "Cancelled",
    "CellBlock",
    "InputError",
    "Mesh",
    "MeshcoreError",
]
