"""Grid and pattern meshes (§8.2) and all-quad meshes by grid superposition (§8.5.2).

:func:`grid` meshes a domain with a regular grid of squares, the boundary
cells kept, fitted or split (:mod:`meshcore.grid.cartesian`);
:func:`pattern` keeps the cells of a parallelogram, hexagon or radial
pattern well inside the domain and meshes the gap (:mod:`meshcore.grid.patterns`);
:func:`quad_grid` keeps the grid's inner cells and fills the band along the
boundary with quads (:mod:`meshcore.grid.superposition`), through the gap
filler of :mod:`meshcore.grid.band`. The name ``grid`` is also this
package's, so it is imported from here, not from ``meshcore``:
``from meshcore.grid import grid``.
"""

from meshcore.grid.cartesian import MAX_CELLS, GridResult, estimated_cells, grid
from meshcore.grid.patterns import pattern
from meshcore.grid.superposition import quad_grid

__all__ = ["MAX_CELLS", "GridResult", "estimated_cells", "grid", "pattern", "quad_grid"]
