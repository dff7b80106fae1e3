"""Geometry: exact predicates (signs) and inexact constructions (coordinates).

Algorithms never compute a sign themselves: they ask :mod:`.predicates`
(DESIGN.md, "Geometry robustness"). :mod:`.constructions` builds new
coordinates (circumcentres) and may round.
"""

from meshcore.geometry.constructions import circumcenter, circumradius
from meshcore.geometry.predicates import (
    dot2d,
    incircle,
    indiametral,
    insphere,
    orient2d,
    orient3d,
)

__all__ = [
    "circumcenter",
    "circumradius",
    "dot2d",
    "incircle",
    "indiametral",
    "insphere",
    "orient2d",
    "orient3d",
]
