"""Quadrilateral meshes: triangle combination, quad optimization (§8.4), paving (§8.5.1).

:func:`combine` pairs the triangles of a mesh into quads (§8.4.2-§8.4.4),
:func:`optimize_quads` improves a quad mesh by topological operators and
smoothing (§8.4.3), :func:`paving` lays rows of quads from the boundary
inward, without a triangle mesh (§8.5.1).
"""

from meshcore.quads.advancing_front import PavingResult, paving
from meshcore.quads.combination import QuadResult, check_input, check_metric_2d, combine
from meshcore.quads.optimization import OptimizeResult, optimize_quads
from meshcore.quads.splitting import split_all

__all__ = [
    "OptimizeResult",
    "PavingResult",
    "QuadResult",
    "check_input",
    "check_metric_2d",
    "combine",
    "optimize_quads",
    "paving",
    "split_all",
]
