"""meshcore: the meshing library behind meshservice (numpy/scipy, no HTTP)."""

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
