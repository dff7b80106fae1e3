"""Validated inputs: planar domains (GeoJSON polygons) and closed triangulated surfaces.

:func:`parse_domain` checks a polygon exactly and normalizes its
orientation; the boundary discretization every 2D method of chapters 8 and
9 starts from. :func:`parse_surface` does the same for closed surfaces in
3D (shells, nesting, outward orientation; §9.3.1, §9.3.5).
"""

from meshcore.domain.planar import Domain, as_domain, parse_domain, parse_size_field
from meshcore.domain.surface import Surface, parse_surface

__all__ = ["Domain", "Surface", "as_domain", "parse_domain", "parse_size_field", "parse_surface"]
