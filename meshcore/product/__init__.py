"""Product meshes (§8.1): extrusion and sweeping, merging of product blocks, radial meshes (§8.7.1).

:func:`extrude` sweeps a base mesh along a path, :func:`sweep` between a
source and a target section, :func:`merged` joins blocks into one
conforming mesh, :func:`radial` meshes disks, rings and sectors.
"""

from meshcore.product.extrusion import (
    Helix,
    Path,
    ProductResult,
    Rotate,
    Sections,
    Transforms,
    Translate,
    check_extrude,
    check_sweep,
    extrude,
    sweep,
    sweep_boundary,
)
from meshcore.product.merge import MergeResult, merged
from meshcore.product.radial_mesh import RadialResult, radial

__all__ = [
    "Helix",
    "MergeResult",
    "Path",
    "ProductResult",
    "RadialResult",
    "Rotate",
    "Sections",
    "Transforms",
    "Translate",
    "check_extrude",
    "check_sweep",
    "extrude",
    "merged",
    "radial",
    "sweep",
    "sweep_boundary",
]
