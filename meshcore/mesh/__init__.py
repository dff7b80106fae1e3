"""The mesh data type and what every method shares: topology, quality (§8.3.1, §8.4.4), files.

:class:`Mesh` is points plus meshio-named cell blocks; :mod:`.topology`
derives facets, boundaries and conformity (Definition 8.1);
:mod:`.quality` holds every element measure and the report; :mod:`.io` is
the only file-format code.
"""

from meshcore.mesh.mesh import CELL_TYPES, CellBlock, Mesh

__all__ = ["CELL_TYPES", "CellBlock", "Mesh"]
