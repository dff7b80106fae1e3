"""Geometry: exact predicates (signs) and inexact constructions (coordinates).

Algorithms never compute a sign themselves: they ask :mod:`.predicates` (2D)
and :mod:`.predicates3d` (3D), whose exact stages stand on the expansion
arithmetic of :mod:`.expansions` (DESIGN.md, "Geometry robustness").
:mod:`.constructions` builds new coordinates (circumcentres, distances) and may round;
:mod:`.tolerances` holds the shared tolerances.
"""

from meshcore.geometry.constructions import circumcenter, circumradius, point_segment_distance
from meshcore.geometry.predicates import dot2d, incircle, indiametral, orient2d
from meshcore.geometry.predicates3d import insphere, orient3d

__all__ = [
    "circumcenter",
    "circumradius",
    "dot2d",
    "incircle",
    "indiametral",
    "insphere",
    "orient2d",
    "orient3d",
    "point_segment_distance",
]
