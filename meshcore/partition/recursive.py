r"""Mesh generation by recursive partition (divide and conquer, §8.7.2): 2D (3D: ``surface=``).

Input: a planar :class:`~meshcore.domain.planar.Domain` (holes allowed, no
interior constraints) and a size map (``size`` / ``size_field``, the control
space of Remark 8.10). Output: triangles, or only quads, whose edges contain
every input segment and every separator.

Algorithm
---------
1. **Boundary.** Every ring segment is split following ``h``
   (:func:`~meshcore.partition.boundary.resample_boundary`); for quads every
   ring gets an even count (Remark 8.9), the repairs listed in ``stats``.
2. **Holes first.** Each hole is joined to the outer ring by a separator
   (a *bridge*): among the 16 nearest outer vertices of each hole vertex,
   the shortest segment that leaves both ends inside their interior angles
   and touches no edge of any ring (exact :func:`orient2d`); every pair
   when none of those is valid. The bridge is subdivided by the sizes and
   the polygon walks it twice, once each way (a weakly simple polygon).
3. **Recursion** (:mod:`meshcore.partition.kernel`, one compiled loop over a
   stack of polygons). A separator is a segment between two vertices of the
   current polygon, *valid* when it leaves both ends strictly inside the
   interior angle of that occurrence of the vertex and touches no other
   polygon edge (closed test, collinear overlaps included): then it lies
   inside the polygon. Candidates (every pair of vertices, or of 60 sampled
   positions above 60 vertices; when no sampled pair is valid, the sampled
   pairs again with separators down to 1e-6 rad from an edge instead of 0.05,
   then all pairs) are ranked, the best valid one is taken. For quads no
   separator closer than 0.3 rad (17 degrees) to an edge at its ends is
   taken: such a separator leaves a sliver no quad of quality 0.1 fits
   (paving's closure was stuck on them); the polygon goes to the centre
   pattern or is handed back stuck instead. (Along a finely
   sampled arc every separator is that close to an edge: all pairs there
   cost m**2 scores per split of an m-vertex polygon, 21 CPU s for a
   100k-vertex circle, 3.7 s with the relaxed sampled pairs first.)

   * ``balanced``: ``I / min(m1, m2) + 1.5 * c`` where ``I`` is the
     integral of ``1 / h`` along the separator (its length in local sizes),
     ``m1``, ``m2`` the boundary sides on either side, and ``c = max(0,
     1 - a / a*)`` with ``a`` the least of the four angles the separator
     makes at its ends, ``a*`` 60 degrees (triangles) or 90 (quads): short
     separators cutting the polygon into parts of similar size with good
     angles;
   * ``angle``: separators from the vertex of largest reflex angle first,
     ranked by how evenly they bisect it (``balanced`` once no vertex is
     reflex).

   The separator gets ``k`` pieces, ``k`` the integral rounded (odd for
   quads), its points at equal steps of that integral for ``h`` varying
   linearly between its ends, "as in Delaunay point insertion". The
   separators stay in the mesh.
4. **Patterns.** The recursion ends at triangles, or for quads at strictly
   convex quads: only separators with an odd number of sides on each side
   are allowed and their piece counts are odd, so every polygon keeps an
   even side count; a split that would leave a four-sided part that is not
   strictly convex is refused.

Choices the text leaves open
----------------------------
* **Quads when the even recursion is stuck.** Straight separators of three
  or more pieces leave flat vertices; a hexagon with two of them side by
  side has no split into convex quads. When some polygon has no valid even
  split, the whole domain is meshed again by the guaranteed route: triangles
  by this recursion at 2.5 times the size (so that the median edge of the
  result is near the size), each cut into three quads by its edge
  midpoints and centroid (§8.4, Figure 8.13). Conforming, only quads, areas
  exact; ``stats["fallback"]`` says it happened.
* Smoothing ("a point relocation step", which the text allows): for quads
  only (``smooth``), by :func:`~meshcore.partition.smoothing.smooth_quads`,
  never inverting a cell nor lowering the least quality; the separators
  stay chains of edges, slightly moved. Quads may leave the recursion with
  nearly flat corners at separator points (the exact test accepts them;
  corners at input points need corner quality 0.1), which it repairs.
  Then the topological clean-up of paving
  (:func:`meshcore.quads.advancing_front.clean_up`: the operators of §8.4.3
  where quads are poor or valences irregular, the boundary kept), which
  the separators' flat points and valence-6 ends need: on the square with
  a hole at 10k quads the least quality (8.4) goes from 0.18-0.30 to 0.55,
  the mean to 0.85. The separators are then no longer all chains of edges
  (the clean-up may swap or remove their inner edges); the input segments
  still are. Last the corners are squared
  (:func:`~meshcore.partition.smoothing.square_corners`, steepest descent
  on their skew, under the same rules): at 10k quads the mean quality goes
  0.853 -> 0.892 (square with a hole), 0.875 -> 0.908 (L), 0.825 -> 0.869
  (plate), 0.821 -> 0.863 (gear), the least unchanged, for about 0.15 s.
  Triangles are not smoothed.
* Ties between candidates (symmetric domains are full of them) are broken
  by position after rounding the scores to 1e-7, so that a translated or
  scaled domain gives the same mesh.
* Interior constraints are refused (``code="unsupported"``).

The 3D part of §8.7.2 (separator surfaces, the Schönhardt prism) is
:mod:`meshcore.partition.recursive3d`, reached with ``surface=``.

References
----------
Methods text §8.7.2 (recursive partition), Remark 8.10 (control space),
Remark 8.9 (even counts), §8.4 Figure 8.13 (a triangle into three quads).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import as_domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.partition import kernel
from meshcore.partition.boundary import SizeMap, resample_boundary, size_map
from meshcore.partition.smoothing import (
    boundary_edges,
    boundary_points,
    smooth_quads,
    square_corners,
)

__all__ = [
    "FALLBACK_SCALE",
    "PartitionResult",
    "partition_polygon",
    "recursive_partition",
    "split_triangles",
    "stuck_error",
]

_NEAREST = 16  # outer vertices tried per hole vertex before every pair
_MAX_CELLS = 20_000_000
#: The guaranteed quad route meshes triangles at this many times the size: a
#: triangle of side H gives half edges H / 2 and spokes 0.29 H, median near H / 2.5.
FALLBACK_SCALE = 2.5


@dataclass(frozen=True)
class PartitionResult:
    """Result of :func:`recursive_partition`.

    Attributes
    ----------
    mesh : Mesh
        Triangles (counter-clockwise) or only quads.
    quality : dict
        :func:`meshcore.mesh.quality.report` of the mesh.
    stats : dict
        ``depth`` (recursion depth), ``separators`` by pieces (``"1"``,
        ``"2-3"``, ``"4-7"``, ``"8+"``), ``bridges``, ``patterns`` (leaves
        met: triangles, quads), ``full_searches``, ``fallback``,
        ``parity_repairs``, ``smoothing_undone``, ``corners_squared`` (moves
        kept by :func:`~meshcore.partition.smoothing.square_corners`),
        ``clean_up``, ``seconds`` per phase.
    """

    mesh: Mesh
    quality: dict
    stats: dict = field(default_factory=dict)


def _edges(loops: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    ea = np.concatenate(loops)
    eb = np.concatenate([np.roll(lp, -1) for lp in loops])
    return ea, eb


def _pieces(P: np.ndarray, a: int, b: int, sizes: SizeMap) -> int:
    L = float(np.hypot(*(P[b] - P[a])))
    ha, hb = sizes(np.array([P[a], P[b]]))
    t = L / ha if abs(hb - ha) <= 1e-9 * ha else L * math.log(hb / ha) / (hb - ha)
    return max(1, int(math.floor(t + 0.5)))


def _bridge(P, outer: np.ndarray, hole: np.ndarray, others: list[np.ndarray]):
    """(position in outer, position in hole) of the shortest valid bridge."""
    ea, eb = _edges([outer, hole, *others])
    n_o, n_h = len(outer), len(hole)
    tree = cKDTree(P[outer])
    for full in (False, True):
        if full:
            ia = np.repeat(np.arange(n_o), n_h)
            ib = np.tile(np.arange(n_h), n_o)
        else:
            k = min(_NEAREST, n_o)
            _, nn = tree.query(P[hole], k=k)
            nn = np.asarray(nn).reshape(n_h, k)
            ia = nn.ravel()
            ib = np.repeat(np.arange(n_h), k)
        d = P[outer[ia]] - P[hole[ib]]
        order = np.argsort(np.einsum("ij,ij->i", d, d), kind="stable")
        ia, ib = ia[order], ib[order]
        r = kernel.bridge_candidates_valid(
            P,
            outer[ia],
            hole[ib],
            outer[(ia - 1) % n_o],
            outer[(ia + 1) % n_o],
            hole[(ib - 1) % n_h],
            hole[(ib + 1) % n_h],
            ea,
            eb,
        )
        if r >= 0:
            return int(ia[r]), int(ib[r])
    raise AlgorithmError("no bridge joins a hole to its outer ring", code="no_bridge")


def _join_holes(P: np.ndarray, loops, ring_polygon, sizes: SizeMap):
    """One polygon cycle per part: holes joined to the outer ring by subdivided bridges."""
    cycles = []
    bridges = 0
    for p in np.unique(ring_polygon):
        rings = [loops[k] for k in np.flatnonzero(ring_polygon == p)]
        cyc, holes = rings[0], list(rings[1:])
        while holes:
            # the hole closest to the current cycle first: its bridge is short
            tree = cKDTree(P[cyc])
            dist = [float(tree.query(P[h])[0].min()) for h in holes]
            h = holes.pop(int(np.argmin(dist)))
            ia, ib = _bridge(P, cyc, h, holes)
            a, b = int(cyc[ia]), int(h[ib])
            k = _pieces(P, a, b, sizes)
            f = np.arange(1, k) / k
            ids = len(P) + np.arange(k - 1)
            P = np.concatenate([P, P[a] + f[:, None] * (P[b] - P[a])])
            hrot = np.roll(h, -ib)
            cyc = np.concatenate([cyc[: ia + 1], ids, hrot, [b], ids[::-1], cyc[ia:]])
            bridges += 1
        cycles.append(cyc.astype(np.int64))
    return P, cycles, bridges


def partition_polygon(
    points: np.ndarray,
    loops: list[np.ndarray],
    ring_polygon: np.ndarray,
    sizes: SizeMap,
    *,
    quad: bool,
    strategy: str = "balanced",
    leave_stuck: bool = False,
):
    """Mesh polygons given as point loops by recursive partition, keeping their vertices.

    Parameters
    ----------
    points : (n, 2) float64
    loops : list of (n_k,) int64
        Rings as cycles of point indices, domain on the left; the first ring
        of each polygon is its outer ring.
    ring_polygon : (R,) int64
        Polygon of each ring.
    sizes : SizeMap
    quad : bool
        Only strictly convex quads (every polygon's side count must be even).
    strategy : {"balanced", "angle"}
    leave_stuck : bool
        In quad mode, a sub-polygon without a valid even split is left
        unmeshed and handed back (``stats["stuck"]``, counter-clockwise
        cycles of point indices, possibly weakly simple: a bridge walked
        both ways) instead of making the whole call fail; the cells cover
        the rest exactly.

    Returns
    -------
    points : (N, 2) float64
        ``points`` then the bridge and separator points.
    cells : (m, 3) or (m, 4) int64
        Counter-clockwise cells; no point is added on the loops.
    stats : dict or None
        As :class:`PartitionResult` ``stats`` (with ``stuck`` when
        ``leave_stuck``); cells and stats None when quad mode is stuck (a
        polygon without a valid even split) and ``leave_stuck`` is off.

    References
    ----------
    Methods text §8.7.2; module docstring.
    """
    n_fixed = len(points)
    P0, cycles, bridges = _join_holes(np.asarray(points, np.float64), loops, ring_polygon, sizes)
    strat = kernel.ANGLE if strategy == "angle" else kernel.BALANCED
    total = sum(len(c) for c in cycles)
    h = sizes.smallest
    # rough capacity: the cells the sizes ask for, grown when a buffer fills
    lo, hi = P0.min(axis=0), P0.max(axis=0)
    est = int(min(4.0 * float(np.prod(hi - lo)) / h / h, _MAX_CELLS)) + 4 * total + 64
    while True:
        P = np.empty((len(P0) + est, 2))
        P[: len(P0)] = P0
        buf = np.empty(4 * total + 64 * int(math.sqrt(est)) + 4096, np.int64)
        nstack = 2 * int(math.log2(est + 2)) + 64 + 4 * len(cycles)
        nstack = max(nstack, 4096)
        st_start = np.empty(nstack, np.int64)
        st_len = np.empty(nstack, np.int64)
        st_depth = np.zeros(nstack, np.int64)
        w = 0
        for c, cyc in enumerate(cycles):
            buf[w : w + len(cyc)] = cyc
            st_start[c], st_len[c] = w, len(cyc)
            w += len(cyc)
        cells = np.full((est + 4 * total, 4), -1, np.int64)
        st = np.zeros(14, np.int64)
        stuck = np.empty(len(buf) if leave_stuck else 0, np.int64)
        status = kernel.recurse(
            n_fixed, P, len(P0), buf, st_start, st_len, st_depth, len(cycles), sizes.H, sizes.grid,
            quad, strat, cells, st, stuck,
        )  # fmt: skip
        if status == kernel.FULL:
            if est >= 4 * _MAX_CELLS:
                raise AlgorithmError("recursive partition past its cell budget", code="runaway")
            est *= 2
            continue
        if status == kernel.STUCK:
            return P0, None, None
        break
    ncell, npts = int(st[0]), int(st[1])
    cells = cells[:ncell, : (4 if quad else 3)].copy()
    stats = {
        "depth": int(st[2]),
        "separators": {"1": int(st[3]), "2-3": int(st[4]), "4-7": int(st[5]), "8+": int(st[6])},
        "bridges": bridges,
        "patterns": {"quad": int(st[7]), "triangle": int(st[8]), "centre": int(st[12])},
        "full_searches": int(st[9]),
    }
    if leave_stuck:
        left, w = [], 0
        while w < st[13]:
            left.append(stuck[w + 1 : w + 1 + stuck[w]].copy())
            w += 1 + int(stuck[w])
        stats["stuck"] = left
    return P[:npts].copy(), cells, stats


def stuck_error(dom, size: float) -> InputError:
    """The error when even the triangle recursion (the guaranteed route) found no valid
    separator in some part of ``dom``: a boundary feature far below ``size`` (a sliver
    spike, nearly coincident vertices, a hole almost touching a ring) leaves no
    separator that passes the exact tests. Located at the domain; the message names
    its shortest segment and sharpest corner, the usual culprits."""
    P, S = dom.points, dom.segments
    length = np.hypot(*(P[S[:, 1]] - P[S[:, 0]]).T)
    short = int(np.argmin(length))
    angle = dom.corner_angles()
    sharp = int(np.argmin(angle))
    return InputError(
        f"recursive partition into triangles at size {size:.6g} found no valid separator "
        "in some part of the domain: it has features far below the size (its shortest "
        f"segment is {length[short]:.3g} long, from "
        f"{dom.vertex_name(int(S[short, 0]))}; its sharpest corner is {angle[sharp]:.3g} "
        f"degrees, at {dom.vertex_name(sharp)}): remove them or mesh with triangulate",
        loc=("domain",),
        code="features_below_size",
    )


def split_triangles(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle into three quads by its edge midpoints and centroid (Figure 8.13).

    Parameters
    ----------
    points : (n, 2) float64
    triangles : (m, 3) int64, counter-clockwise

    Returns
    -------
    points : (n + e + m, 2) float64
        The points, the edge midpoints (one per edge, shared), the centroids.
    quads : (3 m, 4) int64
        Counter-clockwise, strictly convex, conforming.
    """
    n, m = len(points), len(triangles)
    e = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, inv = np.unique(e, axis=0, return_inverse=True)
    mid = (points[uniq[:, 0]] + points[uniq[:, 1]]) / 2.0
    cen = points[triangles].mean(axis=1)
    mids = (n + inv.ravel()).reshape(m, 3)  # m01, m12, m20
    c = n + len(uniq) + np.arange(m)
    v0, v1, v2 = triangles.T
    m01, m12, m20 = mids.T
    quads = np.concatenate(
        [
            np.column_stack([v0, m01, c, m20]),
            np.column_stack([v1, m12, c, m01]),
            np.column_stack([v2, m20, c, m12]),
        ]
    )
    return np.concatenate([points, mid, cen]), quads


def recursive_partition(
    domain=None,
    *,
    surface=None,
    size: float | None = None,
    size_field=None,
    element: str | None = None,
    strategy: str = "balanced",
    smooth: bool = True,
    progress: Callable[[float, str], None] | None = None,
) -> PartitionResult:
    """Mesh a planar domain, or a closed surface, by recursive partition into two (§8.7.2).

    Parameters
    ----------
    domain : Domain or dict
        2D: holes allowed; interior constraints are refused.
    surface : Surface or dict
        3D instead of ``domain``: a closed surface, meshed into tetrahedra by
        :func:`~meshcore.partition.recursive3d.recursive_partition_3d` (its
        guarantees; ``smooth`` does not apply).
    size : float, optional
        Target edge length.
    size_field : dict, optional
        ``{"points": (k, 2), "values": (k,)}`` (Remark 8.10; ``(k, 3)``
        points with a surface); ``size`` bounds it.
    element : {"triangle", "quad", "tetra"}, optional
        ``triangle`` (the 2D default) or ``quad`` with a domain; ``tetra``
        (the default) with a surface.
    strategy : {"balanced", "angle"}
        Separator ranking (module docstring).
    smooth : bool
        Quads: relocate the separator points by
        :func:`~meshcore.partition.smoothing.smooth_quads`, then the
        topological clean-up, then
        :func:`~meshcore.partition.smoothing.square_corners` (none inverting
        a cell nor lowering the least quality). Triangles are not smoothed.
    progress : callable, optional
        ``progress(fraction, message)``; may raise to cancel.

    Returns
    -------
    PartitionResult
        Guarantees: only triangles (or only quads), every cell of positive
        area (strictly convex quads), the cells' areas adding up to the
        domain's, every input segment a chain of mesh edges, every separator
        inside the domain and a chain of mesh edges, conforming.

    Raises
    ------
    InputError
        Bad domain, size, element or strategy (``loc`` names it), or
        interior constraints (``code="unsupported"``); ``features_below_size``
        (:func:`stuck_error`) when even the triangle recursion is stuck.

    References
    ----------
    Methods text §8.7.2, Remarks 8.9, 8.10; module docstring.
    """
    if (domain is None) == (surface is None):
        raise InputError(
            "give a domain (2D) or a surface (3D), not both",
            loc=("surface",) if surface is not None else ("domain",),
            code="bad_parameter",
        )
    if surface is not None:
        if element not in (None, "tetra"):
            raise InputError(
                f"element must be 'tetra' with a surface, got {element!r}",
                loc=("element",),
                code="bad_parameter",
            )
        from meshcore.partition.recursive3d import recursive_partition_3d  # imports this module

        return recursive_partition_3d(
            surface, size=size, size_field=size_field, strategy=strategy, progress=progress
        )
    element = "triangle" if element is None else element
    dom = as_domain(domain)
    if element not in ("triangle", "quad"):
        raise InputError(
            f"element must be 'triangle' or 'quad', got {element!r}",
            loc=("element",),
            code="bad_parameter",
        )
    if strategy not in ("balanced", "angle"):
        raise InputError(
            f"strategy must be 'balanced' or 'angle', got {strategy!r}",
            loc=("strategy",),
            code="bad_parameter",
        )
    if len(dom.constraints):
        raise InputError(
            "recursive_partition does not take interior constraint segments",
            loc=("segments",),
            code="unsupported",
        )
    sizes = size_map(dom, size, size_field)
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - clock
        clock = now

    def report(fraction: float, message: str) -> None:
        if progress is not None:
            progress(fraction, message)

    quad = element == "quad"
    report(0.0, "boundary")
    bnd = resample_boundary(dom, sizes, even=quad)
    lap("boundary")
    report(0.1, "recursion")
    pts, cells, stats = partition_polygon(
        bnd.points, bnd.loops, bnd.ring_polygon, sizes, quad=quad, strategy=strategy
    )
    fallback = False
    if cells is None and not quad:
        raise stuck_error(dom, sizes.smallest)
    if cells is None:
        fallback = True
        twice = SizeMap(FALLBACK_SCALE * sizes.H, sizes.grid)
        bnd = resample_boundary(dom, twice, even=False)
        pts, tri, stats = partition_polygon(
            bnd.points, bnd.loops, bnd.ring_polygon, twice, quad=False, strategy=strategy
        )
        if tri is None:
            raise stuck_error(dom, twice.smallest)
        pts, cells = split_triangles(pts, tri)
    lap("recursion")
    undone = squared = 0
    clean: dict = {"region": 0, "operators": {}}
    if quad and smooth:
        # here, not at the top: meshcore.quads imports this package (paving)
        from meshcore.quads.advancing_front import clean_up

        report(0.7, "smoothing")
        fixed = boundary_points(pts, cells)
        pts, undone = smooth_quads(pts, cells, fixed)
        lap("smoothing")
        report(0.8, "clean-up")
        pts, cells, ops, region = clean_up(pts, cells, np.flatnonzero(fixed))
        clean = {"region": region, "operators": ops}
        lap("clean-up")
        pts, squared = square_corners(pts, cells, boundary_points(pts, cells))
        lap("corners")
    mesh = Mesh(pts, (CellBlock("quad" if quad else "triangle", cells),))
    report(0.9, "quality")
    # the edges of one cell are the resampled rings (tested: input segments as chains)
    q = quality.report(mesh, boundary_edges(cells))
    lap("quality")
    stats = {
        **stats,
        "cells": int(len(cells)),
        "points": int(len(pts)),
        "fallback": fallback,
        "parity_repairs": bnd.repairs,
        "smoothing_undone": int(undone),
        "corners_squared": int(squared),
        "clean_up": clean,
        "seconds": timings,
    }
    report(1.0, "done")
    return PartitionResult(mesh, q, stats)
