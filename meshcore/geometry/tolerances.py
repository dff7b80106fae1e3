"""Tolerances shared across method families, relative to a diameter.

Every method decides "the same point" and "too large for float64" the same
way: a distance below :attr:`Tolerances.coincident` times the diameter of
the input's bounding box is zero, and no coordinate may exceed
:data:`MAX_COORDINATE` (squares of coordinate differences stay finite) nor,
where squares are formed, may an input be smaller than :data:`MIN_DIAMETER`.
Signs never use a tolerance: they come exactly from
:mod:`meshcore.geometry.predicates`. Tolerances that belong to one
algorithm only (a refinement's split fractions, a search cap) stay in a
frozen dataclass of that algorithm's module, named there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MAX_COORDINATE",
    "MAX_COORDINATE_3D",
    "MIN_DIAMETER",
    "MIN_DIAMETER_3D",
    "TOLERANCES",
    "Tolerances",
]

MAX_COORDINATE = 1e150
"""Largest coordinate magnitude accepted: squared differences stay below 1e301."""

MIN_DIAMETER = 1e-100
"""Smallest input diameter accepted where squared distances are formed (circumcentres,
radii): a feature 1e-50 of the diameter still squares to a normal float64 (above 1e-300)."""

MAX_COORDINATE_3D = 1e50
"""Largest coordinate of a closed surface: the 3D constructions (circumspheres, volumes)
multiply up to six lengths, which stay below 1e300."""

MIN_DIAMETER_3D = 1e-50
"""Smallest diameter of a closed surface, for the same products at the small end."""


@dataclass(frozen=True)
class Tolerances:
    """Geometric tolerances as fractions of a diameter.

    Attributes
    ----------
    coincident : float
        Two positions closer than ``coincident * diameter`` (the diameter of
        the bounding box of the points concerned) are the same point: a base
        vertex whose positions on every section of an extrusion agree this
        closely is numbered once (it lies on a rotation axis), a last section
        this close to the first closes the ring, a base this close to a plane
        is planar, a sample point must lie this far inside a foreign cell to
        count as an overlap, and :func:`meshcore.product.merge.merged` joins
        points this close by default.
    """

    coincident: float = 1e-9

    def distance(self, points: np.ndarray) -> float:
        """``coincident`` times the diameter of the bounding box of ``points`` (..., d)."""
        if points.size == 0:
            return 0.0
        comps = [points[..., i] for i in range(points.shape[-1])]  # strided views: fast reductions
        diameter = math.hypot(*(float(c.max()) - float(c.min()) for c in comps))
        return self.coincident * diameter


TOLERANCES = Tolerances()
