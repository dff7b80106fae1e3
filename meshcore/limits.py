"""The limits and defaults that the service's params models need when they are defined.

Plain data (the standard library only), so that the API process can declare its
fields without importing the method packages that use these values
(:mod:`service.methods.registry`); each method module imports its own from here.
"""

#: Largest ``min_angle`` accepted by ``triangulate`` (degrees); Delaunay refinement is
#: known to terminate in practice up to about 34 degrees, provably below 20.7.
MAX_MIN_ANGLE = 34.0
#: Smallest radius-edge bound accepted by ``tetrahedralize`` (Shewchuk's analysis needs
#: > 2; below ~1.1 no tetrahedralization exists).
MIN_RADIUS_EDGE = 1.1
#: Default bound on the cells of a grid's bounding box (``grid``, ``quad_grid``).
MAX_CELLS = 4_000_000
#: Most quads a ``quad_medial`` job may make.
MAX_QUADS = 4_000_000
#: ``simplify``: details and holes under this fraction of the local radius are removed.
DEFAULT_THRESHOLD = 0.5
#: ``medial_axis``: default pruning angle, degrees (:mod:`meshcore.medial.axis`, step 5).
DEFAULT_PRUNE = 25.0
