r"""The medial axis transform (§9.6): a boundary rebuilt from an axis and its radii.

"The data of the medial axis together with some additional information
(radii, branches, etc.) make it possible to retrieve the boundary of the
domain" (§9.6). The domain is the union of the maximal disks centred on the
axis (Definition 9.1). :func:`medial_transform` takes the axis as a graph,
``nodes`` with their ``radius`` and ``edges`` joining them (branches, loops
and cycles allowed: the axis of an annulus is one closed loop), and builds
that union.

What is united
--------------
* Along an edge ``ij`` the axis carries the disks centred on the segment with
  radii interpolated linearly from ``r_i`` to ``r_j``; their union is the
  convex hull of the two end disks, the *tube* of the edge. A union of the
  node disks alone would be scalloped between nodes; the tubes are not.
* A tube is cut into exact pieces: the two end disks and the quadrilateral
  between the points where the two outer common tangents touch them
  (unit normal ``n`` with ``n . (c_j - c_i) = r_i - r_j``). With ``r = 0`` at
  one end (a branch running into a convex corner) the quadrilateral is a
  triangle with its apex at the corner, so corners come back sharp. When
  one disk contains the other (``|c_i - c_j| <= |r_i - r_j|``) the tube is
  the larger disk and no quadrilateral is added.
* Each disk of radius ``r > 0`` is the regular polygon inscribed in it with
  the fewest vertices whose sagitta ``r (1 - cos(pi / N))`` is at most ``h``
  (at least :attr:`Tolerances.min_circle_vertices`, at most
  :attr:`Tolerances.max_circle_vertices`). The pieces are exact but for
  these inscribed polygons, so the reconstruction lies inside the exact
  union and within ``h`` of it (the Hausdorff distance of the boundaries).
* The pieces are united by GEOS (:func:`shapely.union_all`, cascaded: about
  0.3 s for 10 000 disks of 64 vertices). Holes of the union come out as
  interior rings. Holes thinner than ``h`` on average (``2 area /
  perimeter`` below :attr:`Tolerances.sliver_hole_width` times ``h``) are
  artefacts of the inscribed polygons where disks barely overlap, below the
  resolution asked for, and are dropped.

The step ``h``
--------------
Default: :attr:`Tolerances.default_step` (1e-3) times the diameter of the
union's bounding box (the nodes' box grown by their radii). A fraction of
the diameter rather than of the smallest radius: radii vanish at corner
terminals, and a disk smaller than ``h`` contributes less than ``h`` to the
boundary anyway. It is a distance; pass ``h`` to ask for a finer or coarser
result.

Hausdorff distance
------------------
With ``boundary`` (the domain the axis came from) the result reports the
symmetric Hausdorff distance between the rebuilt boundary (all its rings)
and the boundary's rings. Both are sampled every
:attr:`Tolerances.hausdorff_sampling` times ``h`` along their segments; the
distance from each sample to the other set of segments is exact (GEOS
nearest-segment queries on an STR-tree). Since the distance to a set is
1-Lipschitz, the figure is within half a sampling step of the exact one.

References
----------
Methods text §9.6 (medial axis transform), §9.4 (Definition 9.1); H. Blum,
"A transformation for extracting new descriptors of shape" (1967).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely

from meshcore.domain.planar import Domain
from meshcore.errors import InputError
from meshcore.geometry.tolerances import MAX_COORDINATE, MIN_DIAMETER

__all__ = ["TOLERANCES", "MedialTransform", "Tolerances", "checked_axis", "medial_transform"]

Progress = Callable[[float, str], None] | None


@dataclass(frozen=True)
class Tolerances:
    """Every tolerance of the medial axis transform.

    Attributes
    ----------
    default_step : float
        Default ``h``, times the diameter of the union's bounding box.
    circle_sagitta : float
        Largest sagitta of a disk's inscribed polygon, times ``h``: one half,
        so that the distance to the exact union stays clearly under ``h``
        where a polygon chord and a tangent-quadrilateral corner meet.
    min_circle_vertices, max_circle_vertices : int
        Bounds on the vertex count of a disk's inscribed polygon (the upper
        one bounds memory when ``h`` is tiny against a radius; the sagitta
        is then ``r (1 - cos(pi / max))``, 1.8e-8 r for 16384).
    sliver_hole_width : float
        Holes of the union whose mean width ``2 area / perimeter`` is under
        this times ``h`` are dropped (artefacts of the inscribed polygons).
    hausdorff_sampling : float
        Sampling step of the boundaries for the Hausdorff distance, times
        ``h``.
    max_hausdorff_samples : int
        The sampling step grows so that neither boundary gets more samples.
    """

    default_step: float = 1e-3
    circle_sagitta: float = 0.5
    min_circle_vertices: int = 8
    max_circle_vertices: int = 16384
    sliver_hole_width: float = 1.0
    hausdorff_sampling: float = 0.125
    max_hausdorff_samples: int = 2_000_000


TOLERANCES = Tolerances()


@dataclass(frozen=True, eq=False)
class MedialTransform:
    """The domain rebuilt from a medial axis (result of :func:`medial_transform`).

    Attributes
    ----------
    domain : dict
        GeoJSON geometry ``{"type": "Polygon" | "MultiPolygon",
        "coordinates": ...}``: closed rings, outer rings counter-clockwise,
        holes clockwise, plain Python floats. A ``MultiPolygon`` when the
        union has several parts.
    hausdorff : float or None
        Symmetric Hausdorff distance between the rebuilt boundary and the
        rings of ``boundary``; ``None`` without ``boundary``.
    area : float
        Area of the rebuilt domain.
    h : float
        The step used: the rebuilt boundary is within ``h`` of the exact union.
    stats : dict
        ``nodes``, ``edges``, ``polygons``, ``rings``, ``holes``, ``area``,
        ``h``, ``circle_vertices`` (total over the disks), and with a
        boundary ``boundary_area`` and ``hausdorff``.
    """

    domain: dict
    hausdorff: float | None
    area: float
    h: float
    stats: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------


def _array(value, name: str, ndim: int, width: int | None) -> np.ndarray:
    shape = f"(k, {width})" if width else "(k,)"
    try:
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(
            f"{name} must be a {shape} array of numbers", loc=(name,), code="bad_shape"
        ) from None
    if arr.ndim == 1 and arr.size == 0 and width:
        arr = arr.reshape(0, width)
    if arr.ndim != ndim or (width is not None and arr.shape[1] != width):
        raise InputError(
            f"{name} must be a {shape} array, got shape {arr.shape}", loc=(name,), code="bad_shape"
        )
    return arr


def _first(mask: np.ndarray) -> tuple[int, ...]:
    return tuple(int(x) for x in np.argwhere(mask)[0])


def checked_axis(nodes, radius, edges, boundary=None, h=None):
    """The validated axis arrays ``(nodes, radius, edges, h)`` of :func:`medial_transform`.

    Raises the same :class:`~meshcore.errors.InputError` as
    :func:`medial_transform` for bad input (located at ``nodes``, ``radius``,
    ``edges``, ``boundary`` or ``h``), without building anything.
    """
    P = _array(nodes, "nodes", 2, 2).astype(np.float64)
    n = len(P)
    if n == 0:
        raise InputError(
            "nodes is empty: the axis needs at least one node", loc=("nodes",), code="empty"
        )
    bad = ~np.isfinite(P)
    if bad.any():
        i, c = _first(bad)
        raise InputError(
            f"node {i} has a non-finite coordinate", loc=("nodes", i, c), code="non_finite"
        )
    r = _array(radius, "radius", 1, None).astype(np.float64)
    if len(r) != n:
        raise InputError(
            f"radius has {len(r)} entries for {n} nodes", loc=("radius",), code="shape_mismatch"
        )
    bad = ~np.isfinite(r)
    if bad.any():
        (i,) = _first(bad)
        raise InputError(f"radius of node {i} is not finite", loc=("radius", i), code="non_finite")
    if (r < 0).any():
        (i,) = _first(r < 0)
        raise InputError(
            f"radius of node {i} is negative ({r[i]!r})", loc=("radius", i), code="negative_radius"
        )
    E = _array(edges, "edges", 2, 2)
    if E.dtype.kind == "f":
        bad = ~np.isfinite(E) | (E != np.round(E))
        if bad.any():
            e, c = _first(bad)
            raise InputError(
                f"edge {e} has a non-integer node index", loc=("edges", e, c), code="bad_index"
            )
    elif E.dtype.kind == "b":
        raise InputError("edges must hold node indices", loc=("edges",), code="bad_shape")
    out = (E < 0) | (E >= n)
    if out.any():
        e, c = _first(out)
        raise InputError(
            f"edge {e} refers to node {E[e, c]!r}, outside 0..{n - 1}",
            loc=("edges", e, c),
            code="index_out_of_range",
        )
    E = E.astype(np.int64)
    loops = E[:, 0] == E[:, 1]
    if loops.any():
        (e,) = _first(loops)
        raise InputError(
            f"edge {e} joins node {E[e, 0]} to itself", loc=("edges", e), code="self_loop"
        )
    big = (np.abs(P).max(axis=1) + r) > MAX_COORDINATE
    if big.any():
        (i,) = _first(big)
        raise InputError(
            f"node {i} reaches beyond coordinate magnitude {MAX_COORDINATE:g}",
            loc=("nodes", i),
            code="out_of_range",
        )
    if not (r > 0).any():
        raise InputError(
            "every radius is zero: the union of the disks is empty",
            loc=("radius",),
            code="empty_union",
        )
    if r.max() < MIN_DIAMETER:
        raise InputError(
            f"the largest radius is {r.max():.3g}, below {MIN_DIAMETER:g}: the disks' areas "
            "underflow float64; scale the axis up",
            loc=("radius", int(np.argmax(r))),
            code="out_of_range",
        )
    if boundary is not None and not isinstance(boundary, Domain):
        raise InputError(
            "boundary must be a Domain (see meshcore.domain.planar.parse_domain)",
            loc=("boundary",),
            code="bad_type",
        )
    if h is not None:
        try:
            hv = float(h)
        except (TypeError, ValueError):
            hv = math.nan
        if not (math.isfinite(hv) and hv > 0):
            raise InputError(
                f"h must be a finite number > 0, got {h!r}", loc=("h",), code="bad_value"
            )
        h = hv
    return P, r, E, h


# ---------------------------------------------------------------------------
# The pieces: disks and tangent quadrilaterals
# ---------------------------------------------------------------------------


def _disks(P: np.ndarray, r: np.ndarray, h: float, tol: Tolerances) -> tuple[np.ndarray, int]:
    """Inscribed polygons of the disks of positive radius, sagitta <= circle_sagitta h."""
    keep = np.flatnonzero(r > 0)
    rk = r[keep]
    # r (1 - cos(pi / N)) <= s  <=>  N >= pi / acos(1 - s / r)
    ratio = np.clip(1.0 - tol.circle_sagitta * h / rk, -1.0, 1.0)
    with np.errstate(divide="ignore"):
        need = np.ceil(np.pi / np.arccos(ratio))
    count = np.clip(
        np.nan_to_num(need, posinf=tol.max_circle_vertices),
        tol.min_circle_vertices,
        tol.max_circle_vertices,
    ).astype(np.int64)
    owner = np.repeat(np.arange(len(keep)), count)
    start = np.cumsum(count) - count
    step = np.arange(len(owner)) - np.repeat(start, count)
    theta = 2.0 * np.pi * step / count[owner]
    xy = P[keep][owner] + rk[owner, None] * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    rings = shapely.linearrings(xy, indices=owner)
    return shapely.polygons(rings), int(count.sum())


def _tangent_quads(P: np.ndarray, r: np.ndarray, E: np.ndarray) -> np.ndarray:
    """The quadrilaterals between the outer common tangents of each edge's disks."""
    ci, cj = P[E[:, 0]], P[E[:, 1]]
    ri, rj = r[E[:, 0]], r[E[:, 1]]
    v = cj - ci
    d = np.hypot(v[:, 0], v[:, 1])
    # One disk inside the other (or both empty): the tube is the larger disk.
    ok = (d > np.abs(ri - rj)) & ((ri > 0) | (rj > 0))
    ci, cj, ri, rj, v, d = ci[ok], cj[ok], ri[ok], rj[ok], v[ok], d[ok]
    u = v / d[:, None]
    s = (ri - rj) / d
    c = np.sqrt(np.maximum(1.0 - s * s, 0.0))
    perp = np.stack([-u[:, 1], u[:, 0]], axis=1)
    n_plus = s[:, None] * u + c[:, None] * perp
    n_minus = s[:, None] * u - c[:, None] * perp
    quad = np.stack(
        [
            ci + ri[:, None] * n_plus,
            cj + rj[:, None] * n_plus,
            cj + rj[:, None] * n_minus,
            ci + ri[:, None] * n_minus,
        ],
        axis=1,
    )
    return shapely.polygons(quad)


# ---------------------------------------------------------------------------
# Output and Hausdorff distance
# ---------------------------------------------------------------------------


def _parts(geom) -> list:
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    return [g for g in shapely.get_parts(geom) if g.geom_type == "Polygon" and not g.is_empty]


def _without_slivers(poly, h: float, tol: Tolerances):
    holes = [
        ring
        for ring in poly.interiors
        if 2.0 * shapely.Polygon(ring).area > tol.sliver_hole_width * h * ring.length
    ]
    return shapely.Polygon(poly.exterior, holes)


def _geojson(polys: list) -> dict:
    coords = []
    for p in polys:
        coords.append(
            [np.asarray(p.exterior.coords)[:, :2].tolist()]
            + [np.asarray(ring.coords)[:, :2].tolist() for ring in p.interiors]
        )
    if len(coords) == 1:
        return {"type": "Polygon", "coordinates": coords[0]}
    return {"type": "MultiPolygon", "coordinates": coords}


def _ring_segments(rings: list[np.ndarray]) -> np.ndarray:
    """(s, 2, 2) float64: the segments of closed rings given without repeats."""
    segs = [np.stack([ring, np.roll(ring, -1, axis=0)], axis=1) for ring in rings if len(ring)]
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def _samples(segs: np.ndarray, step: float) -> np.ndarray:
    """Points along the segments, at most ``step`` apart, segment ends included."""
    length = np.hypot(*(segs[:, 1] - segs[:, 0]).T)
    count = np.maximum(np.ceil(length / step), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(segs)), count)
    start = np.cumsum(count) - count
    t = (np.arange(len(owner)) - np.repeat(start, count)) / count[owner]
    return segs[owner, 0] + t[:, None] * (segs[owner, 1] - segs[owner, 0])


def _directed(points: np.ndarray, segs: np.ndarray) -> float:
    tree = shapely.STRtree(shapely.linestrings(segs))
    _, dist = tree.query_nearest(shapely.points(points), return_distance=True, all_matches=False)
    return float(dist.max()) if len(dist) else math.inf


def _hausdorff(a: np.ndarray, b: np.ndarray, h: float, tol: Tolerances) -> float:
    """Symmetric Hausdorff distance between two sets of segments (s, 2, 2)."""
    total = max(np.hypot(*(a[:, 1] - a[:, 0]).T).sum(), np.hypot(*(b[:, 1] - b[:, 0]).T).sum())
    step = max(tol.hausdorff_sampling * h, total / tol.max_hausdorff_samples)
    return max(_directed(_samples(a, step), b), _directed(_samples(b, step), a))


def _rings_of(polys: list) -> list[np.ndarray]:
    out = []
    for p in polys:
        for ring in (p.exterior, *p.interiors):
            out.append(np.asarray(ring.coords)[:-1, :2])
    return out


def _domain_rings(domain: Domain) -> list[np.ndarray]:
    off = domain.ring_offsets
    return [domain.points[off[k] : off[k + 1]] for k in range(domain.ring_count)]


# ---------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------


def medial_transform(
    nodes,
    radius,
    edges,
    *,
    boundary: Domain | None = None,
    h: float | None = None,
    progress: Progress = None,
    tolerances: Tolerances = TOLERANCES,
) -> MedialTransform:
    """Rebuild a domain as the union of the maximal disks along a medial axis.

    Parameters
    ----------
    nodes : (n, 2) float64
        Axis nodes, ``n >= 1``.
    radius : (n,) float64
        Radius of the maximal disk at each node, ``>= 0`` (zero at terminal
        nodes in convex corners); not all zero.
    edges : (m, 2) int64
        Axis edges as node index pairs (``m`` may be 0); any graph: trees,
        loops, cycles; no edge from a node to itself.
    boundary : Domain, optional
        The domain the axis describes; the result then reports the Hausdorff
        distance between its rings and the rebuilt boundary.
    h : float, optional
        Largest distance allowed between the rebuilt boundary and the exact
        union of the disks. Default: 1e-3 times the diameter of the union's
        bounding box (see the module docstring).
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.
    tolerances : Tolerances

    Returns
    -------
    MedialTransform

    Raises
    ------
    InputError
        ``code`` and ``loc``: ``bad_shape`` (``("nodes",)``, ``("radius",)``,
        ``("edges",)``), ``empty`` (no node), ``non_finite`` (``("nodes", i,
        c)``, ``("radius", i)``), ``shape_mismatch`` (radius count),
        ``negative_radius`` (``("radius", i)``), ``out_of_range`` (a disk
        beyond magnitude 1e150, ``("nodes", i)``; a largest radius below
        ``MIN_DIAMETER``, ``("radius", i)``), ``bad_index`` and
        ``index_out_of_range`` (``("edges", e, c)``), ``self_loop``
        (``("edges", e)``), ``empty_union`` (every radius zero),
        ``bad_type`` (``("boundary",)``), ``bad_value`` (``("h",)``).

    References
    ----------
    Methods text §9.6; Definition 9.1 (§9.4).
    """
    P, r, E, h = checked_axis(nodes, radius, edges, boundary, h)
    lo = (P - r[:, None]).min(axis=0)
    hi = (P + r[:, None]).max(axis=0)
    diameter = float(np.hypot(*(hi - lo)))
    if h is None:
        h = tolerances.default_step * diameter
    if progress is not None:
        progress(0.0, "disks and tangent quadrilaterals")
    disks, circle_vertices = _disks(P, r, h, tolerances)
    quads = _tangent_quads(P, r, E)
    if progress is not None:
        progress(0.3, f"union of {len(disks) + len(quads)} pieces")
    union = shapely.union_all(np.concatenate([disks, quads]))
    polys = [_without_slivers(p, h, tolerances) for p in _parts(union)]
    polys = [shapely.orient_polygons(p, exterior_cw=False) for p in polys]
    polys.sort(key=lambda p: (-p.area, *p.exterior.coords[0]))
    area = float(sum(p.area for p in polys))
    stats = {
        "nodes": len(P),
        "edges": len(E),
        "polygons": len(polys),
        "rings": sum(1 + len(p.interiors) for p in polys),
        "holes": sum(len(p.interiors) for p in polys),
        "area": area,
        "h": float(h),
        "circle_vertices": circle_vertices,
    }
    hausdorff = None
    if boundary is not None:
        if progress is not None:
            progress(0.7, "Hausdorff distance to the boundary")
        hausdorff = _hausdorff(
            _ring_segments(_rings_of(polys)),
            _ring_segments(_domain_rings(boundary)),
            h,
            tolerances,
        )
        stats["boundary_area"] = boundary.area
        stats["hausdorff"] = hausdorff
    if progress is not None:
        progress(1.0, "done")
    return MedialTransform(
        domain=_geojson(polys), hausdorff=hausdorff, area=area, h=float(h), stats=stats
    )
