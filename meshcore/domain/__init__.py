"""Validated inputs: planar domains (GeoJSON polygons with holes and constraint segments).

:func:`parse_domain` checks a polygon exactly and normalizes its
orientation; the boundary discretization every 2D method of chapters 8 and
9 starts from.
"""

from meshcore.domain.planar import Domain, parse_domain

__all__ = ["Domain", "parse_domain"]
