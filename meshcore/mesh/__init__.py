"""The mesh data type and what every method shares: topology, quality (§8.3.1, §8.4.4), files.

:class:`Mesh` is points plus meshio-named cell blocks; :mod:`.topology`
derives facets, boundaries and conformity (Definition 8.1);
:mod:`.quality` holds every element measure and the report; :mod:`.io` is
the only file-format code (:mod:`.formats`, the formats' names, is plain data).

``CELL_TYPES``, ``CellBlock`` and ``Mesh`` are loaded on first use, so that
importing :mod:`.formats` does not load numpy and numba.
"""

import importlib

__all__ = ["CELL_TYPES", "CellBlock", "Mesh"]


def __getattr__(name: str):
    """``CELL_TYPES``, ``CellBlock`` or ``Mesh``, imported from :mod:`.mesh` on first use."""
    if name in __all__:
        value = getattr(importlib.import_module("meshcore.mesh.mesh"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'meshcore.mesh' has no attribute {name!r}")
