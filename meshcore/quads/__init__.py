"""Quadrilateral meshes from triangles: combination and quad optimization (§8.4).

:func:`combine` pairs the triangles of a mesh into quads (§8.4.2-§8.4.4),
:func:`optimize_quads` improves a quad mesh by topological operators and
smoothing (§8.4.3).
"""

from meshcore.quads.combination import QuadResult, check_input, check_metric_2d, combine, split_all
from meshcore.quads.optimization import OptimizeResult, optimize_quads

__all__ = [
    "OptimizeResult",
    "QuadResult",
    "check_input",
    "check_metric_2d",
    "combine",
    "optimize_quads",
    "split_all",
]
