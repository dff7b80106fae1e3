"""Optimization-based meshing, correction and optimization of simplicial meshes (Coupez, §8.3).

:func:`optimize` generates a triangle mesh from a domain's boundary, makes a
tangled triangle or tetrahedral mesh valid again with the same boundary, or
raises the worst quality of a valid one, by replacing sub-topologies with
Op(P, δ𝒮) under the criteria (8.1)-(8.2). Import it from here
(``from meshcore.optimize import optimize``): the name is also this package's.
"""

from meshcore.optimize.coupez import OptimizationResult, check_input, check_topology, optimize

__all__ = ["OptimizationResult", "check_input", "check_topology", "optimize"]
