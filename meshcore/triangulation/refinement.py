"""A boundary-conforming quality triangle mesher: ``triangulate``.

Input: a :class:`~meshcore.domain.planar.Domain` (rings and interior constraint
segments, validated by :func:`~meshcore.domain.planar.parse_domain`). Output: a
mesh of counter-clockwise triangles of the domain in which every input
segment, boundary and constraint, is the union of mesh edges (a chain of
point indices from one input vertex to the other), refined until the
requested angle, area and size bounds hold.

Pipeline (each phase timed in :attr:`TriangulationResult.timings`):

1. **Sizing.** ``size`` (target edge length), ``max_area`` and ``size_field``
   give the size ``h(x)`` of the control space (Remark 8.10). A scattered
   field is interpolated linearly on *our* Delaunay triangulation of its
   points (nearest value outside their hull) and sampled on a grid (at most
   512 cells a side) that everything after reads bilinearly.
2. **Boundary.** Unless the boundary is kept, each input segment is split
   into pieces no longer than ``h`` (by the integral of ``1 / h`` along it)
   and, unless ``empty``, than 1.5 times their distance to the nearest
   segment sharing no vertex with theirs (:mod:`meshcore.triangulation.features`:
   a 1 x 1e-6 strip's sides cut in one step, not by 17 rounds of
   refinement splits), new points on a ring declared as a circle going on the circle (§9.1.5),
   and the pieces are made Delaunay-admissible by
   :func:`meshcore.delaunay.admissible.admissible_segments` (§9.1.4: projections of
   the encroaching point of largest angle, protected acute vertices).
3. **Interior** (the pattern idea of §8.2): a lattice of equilateral
   triangles of side ``h`` is laid row by row inside the domain (scan-line
   even-odd intervals of the boundary rings); a varying size gets several
   lattices, each kept where ``h(x)`` is within ``2**(1/8)`` of its side and
   thinned where two meet. Points closer than ``0.6 h`` to a segment (or
   inside a segment's diametral ball) are dropped, and boundary plus
   pattern points are triangulated *once* by
   :func:`meshcore.delaunay.kernel2d.delaunay`.
4. **Constraints and regions** (:mod:`meshcore.delaunay.cdt`): segments missing from
   that triangulation are recovered by flips, then the triangles reached
   from the left of the boundary segments without crossing one are kept:
   holes and exterior go by region, never by a centroid test.
5. **Refinement** (:func:`meshcore.delaunay.cdt.refine`): Ruppert's Delaunay
   refinement of what is still bad (angle, area, circumradius against the
   size): circumcentres or off-centres inserted one at a time, shortest
   edge first, segments split when encroached. On a lattice only the layer
   along the boundary and the seams between lattice levels need it.

Choices the methods text leaves open
------------------------------------
* **Interior points: a pattern, then refinement.** Building the interior by
  inserting circumcentres one at a time (Ruppert, Triangle) costs a cavity
  per point; the §8.2 pattern costs one Delaunay triangulation of points
  whose triangles are already equilateral (mean smallest angle 54 degrees
  against 48 for refinement alone, measured), and refinement then repairs
  the rest. 1M triangles take 0.7 s against Triangle's 1.0 s
  (``benchmarks/triangulate.py``). The lattice points are moved by a
  deterministic 0.1 % jitter: an exact lattice is full of co-circular
  quadruples that would each cost an exact in-circle evaluation (450k
  lattice points triangulate in 0.40 s with it, 0.63 s without).
* **Default quality.** ``min_angle=None`` means 20 degrees whenever interior
  points are added (Triangle's ``-q`` default): a mesher adding points is
  asked for a quality mesh. ``empty=True`` adds no interior point and
  refines nothing.
* **Termination at small input angles** (``min_angle`` up to 30 degrees):
  splits next to an input vertex fall on concentric shells (powers of two
  of the domain's diameter from that vertex), and a triangle whose shortest
  edge joins two split points at the same distance (within 0.1 %) from an
  input vertex where their segments meet at an angle under ``min_angle``
  is left as it is (Miller, Pav and Walkington's rule, as Triangle). Such
  triangles lie in the wedge of that small input angle; every other
  triangle meets the bound. Above 30 degrees (up to 34) the rule applies
  below 60-degree input angles, as theirs: refinement terminates in
  practice, and triangles near input angles under 60 degrees may stay
  under the bound. Bad triangles are split shortest edge first: without
  that order refinement above 30 degrees ran away on random polygons. A
  point budget (``8`` times the points the sizes and the thin parts call
  for, :func:`estimated_triangles`, at least 4M,
  at most :data:`MAX_POINTS`) turns any runaway into an
  :class:`~meshcore.errors.AlgorithmError`.
* **Kept boundary.** With ``keep_boundary`` no point is ever added on an
  input segment: segments are recovered by flips into a constrained
  Delaunay triangulation, and a refinement point that would encroach a
  segment (lie in its open diametral ball, or behind it) is not inserted:
  that triangle stays as it is ("refinement stops at the boundary"),
  counted in :attr:`TriangulationResult.given_up`. The pattern still fills
  the interior.
* **Size.** ``size`` is the target edge length: the lattice side, the
  boundary spacing, and a refinement bound of ``0.8 * size`` on
  circumradii (an equilateral triangle of side ``h`` has circumradius
  ``0.577 h``). ``max_area`` bounds every triangle's area strictly; alone it
  lays the lattice at 90 % of that area per triangle.
* **Rounds.** Refinement has no global rounds (it is one priority queue);
  :attr:`TriangulationResult.rounds` is the depth of the refinement
  cascade: a triangle made while splitting one of depth ``d`` has depth
  ``d + 1``, the initial ones 0.

References
----------
Methods text §8.2 (grid and pattern methods), Remark 8.10 (control space),
§9.1 (Delaunay-admissible segments, §9.1.4 splitting, §9.1.5 on curves), §9
footnote 1 (the "empty" triangulation); J. Ruppert, "A Delaunay refinement
algorithm for quality 2-dimensional mesh generation" (1995); J. R.
Shewchuk, "Delaunay refinement algorithms for triangular mesh generation"
(2002).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.delaunay import cdt
from meshcore.delaunay.admissible import admissible_segments, circles_of, located_in_domain
from meshcore.delaunay.kernel2d import delaunay
from meshcore.domain.planar import Domain, as_domain, parse_size_field
from meshcore.errors import AlgorithmError, InputError, positive_parameter
from meshcore.geometry.predicates import WORK_SIZE
from meshcore.limits import MAX_MIN_ANGLE
from meshcore.mesh import CellBlock, Mesh
from meshcore.triangulation.features import feature_cuts

__all__ = [
    "MAX_POINTS",
    "Estimate",
    "TriangulationResult",
    "check_thinness",
    "estimated_triangles",
    "triangulate",
]

#: Refinement stops with an AlgorithmError past this many points.
MAX_POINTS = 1 << 25
#: ``min_angle`` used when interior points are added and none is given.
DEFAULT_MIN_ANGLE = 20.0
#: Up to this bound every triangle meets ``min_angle`` except in the wedges of
#: input angles below it; above it, also near input angles below MPW_SMALL_ANGLE.
GUARANTEED_MIN_ANGLE = 30.0
#: Miller, Pav and Walkington's "small input angle" (degrees).
MPW_SMALL_ANGLE = 60.0
#: Refinement stops with an AlgorithmError past this many times the points
#: expected from the sizes (or MIN_BUDGET, whichever is larger): a runaway.
BUDGET_FACTOR = 8
MIN_BUDGET = 1 << 22
# Triangle and point estimates saturate here (sizes near underflow).
_ESTIMATE_CAP = 10**18
#: Points of a min-angle mesh per unit of perimeter**2 / area in thin parts: a strip of width
#: w (and length 1, size 0.1) gets edges about w long, 0.9 / w points at the default 20
#: degrees (measured at w = 1e-3 to 1e-5), 0.25 * (2 / w)**2 * w = 1 / w here.
_THIN = 0.25


@dataclass(frozen=True)
class _Tolerances:
    """Every length ratio the mesher decides with; lengths scale with ``h``
    (the local size) or with the domain's diameter, never absolute."""

    #: Lattice points closer than this times ``h`` to a segment are dropped.
    clearance: float = 0.6
    #: ... and those inside ``(1 + ball_margin)`` times a subsegment's diametral ball.
    ball_margin: float = 0.05
    #: Lattice triangle area as a fraction of ``max_area`` (alone).
    area_fill: float = 0.9
    #: Refinement bound on circumradii, in units of the size ``h``.
    circumradius: float = 0.8
    #: Relative tolerance on squared distances for the equidistant split points
    #: of the small-input-angle rule (Triangle's 0.1 %).
    equidistant: float = 1e-3
    #: Unit of the concentric shells, as a fraction of the domain's diameter.
    shell_unit: float = 1.0
    #: Lattice points are moved by up to this fraction of ``h`` (a hash of
    #: their index): it breaks the lattice's exact co-circularities, which would
    #: otherwise send many in-circle tests to exact arithmetic.
    jitter: float = 1e-3
    #: Graded pattern: points of two lattice levels closer than this times the
    #: finer side are thinned.
    thinning: float = 0.5
    #: Graded pattern: ratio of the sides of consecutive lattice levels (the
    #: side stays within its fourth root of the size; measured: 2 gives edge
    #: lengths off by up to 25 %, 2**(1/4) by 6 %).
    level_ratio: float = 2.0**0.25
    #: Off-centres at this times ``cot(min_angle / 2)`` times the shortest edge
    #: from its midpoint (Ungor; Triangle's 0.475, just under the 1/2 that
    #: would make the new angle exactly ``min_angle``).
    offcenter: float = 0.475
    #: Size grid: at most this many cells per side.
    grid_cells: int = 512
    #: Samples of the size along each segment when subdividing.
    segment_samples: int = 9
    #: Boundary pieces are cut to at most this times their distance to the nearest
    #: segment sharing no vertex with theirs (:mod:`meshcore.triangulation.features`).
    feature: float = 1.5
    #: Relative slack when counting a segment's pieces: one exactly n sizes
    #: long gets n pieces, not n + 1 for a rounding of its length.
    count_slack: float = 1e-12
    #: Relative slack on the lattice's row and column counts: a box exactly ``n``
    #: lattice steps across gets the same lattice in every frame (the square with a
    #: hole, sheared, is 10 rows high at size 0.1 and was 9.9999999993 translated by
    #: 1e6: a lattice shifted by half a row, another mesh).
    lattice_slack: float = 1e-9


TOL = _Tolerances()


@dataclass(frozen=True, eq=False)
class TriangulationResult:
    """What :func:`triangulate` returns.

    Attributes
    ----------
    mesh : Mesh
        2D points and one ``triangle`` block, counter-clockwise. The input
        points come first, in the order of ``domain.points``.
    segments : (k, 2) int64
        The mesh edges lying on input segments, each oriented as its input
        segment (boundary edges with the domain on their left).
    segment_ids : (k,) int64
        The input segment of each: ``0 .. m-1`` the boundary segments of
        ``domain.segments``, ``m + c`` the constraint ``domain.constraints[c]``.
    boundary_points_added : int
        Points added on input segments (subdivision, admissibility, splits).
    interior_points_added : int
        Points added inside (lattice and circumcentres).
    rounds : int
        Depth of the refinement cascade: triangles made while splitting a
        triangle of depth ``d`` have depth ``d + 1``, the first ones 0.
    given_up : int
        Bad triangles left as they are: their circumcentre would encroach a
        kept boundary segment, or could not be inserted.
    boundary_segment_count : int
        ``m``, the number of input boundary segments.
    timings : dict
        Seconds per phase.
    """

    mesh: Mesh
    segments: np.ndarray
    segment_ids: np.ndarray
    boundary_points_added: int
    interior_points_added: int
    rounds: int
    given_up: int
    boundary_segment_count: int
    timings: dict = field(default_factory=dict)

    @property
    def boundary_segments(self) -> np.ndarray:
        """(b, 2) int64: the mesh edges on the domain's boundary rings."""
        return self.segments[self.segment_ids < self.boundary_segment_count]


# ---------------------------------------------------------------------------
# Sizing: the control space
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Sizing:
    """h(x) on a grid: ``H`` (ny, nx) and ``grid`` [x0, y0, dx, dy]; 1x1 = constant."""

    H: np.ndarray
    grid: np.ndarray

    @property
    def uniform(self) -> bool:
        return self.H.size == 1

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        if self.uniform:
            return np.full(len(xy), self.H[0, 0])
        ny, nx = self.H.shape
        fx = np.clip((xy[:, 0] - self.grid[0]) / self.grid[2], 0.0, nx - 1.0)
        fy = np.clip((xy[:, 1] - self.grid[1]) / self.grid[3], 0.0, ny - 1.0)
        i = np.minimum(fx.astype(np.int64), nx - 2)
        j = np.minimum(fy.astype(np.int64), ny - 2)
        u, v = fx - i, fy - j
        H = self.H
        return (1 - v) * ((1 - u) * H[j, i] + u * H[j, i + 1]) + v * (
            (1 - u) * H[j + 1, i] + u * H[j + 1, i + 1]
        )


def _sized_points(domain: Domain, sizing: _Sizing | None) -> float:
    """Points of an equilateral mesh following the sizes, area / (0.866 h**2) (0 without
    sizes; may be inf or nan)."""
    if sizing is None:
        inv = 0.0
    elif sizing.uniform:
        inv = 1.0 / float(sizing.H[0, 0]) / float(sizing.H[0, 0])  # h**2 overflows at 1e300
    else:
        inv = float(np.mean(1.0 / sizing.H / sizing.H))
    return domain.area * inv / (math.sqrt(3.0) / 2.0)


def _expected_points(domain: Domain, sizing: _Sizing | None) -> int:
    """Points of an equilateral mesh following the sizes (:func:`_sized_points`), plus those
    the angle bound forces where the boundary runs close to itself: ``_THIN * perimeter**2
    / area`` (constraints counted on both sides)."""
    P = domain.points
    edges = np.concatenate([domain.segments, domain.constraints, domain.constraints])
    perimeter = float(np.hypot(*(P[edges[:, 1]] - P[edges[:, 0]]).T).sum())
    points = _sized_points(domain, sizing) + _THIN * (perimeter / domain.area) * perimeter
    return _ESTIMATE_CAP if math.isnan(points) else int(min(points, _ESTIMATE_CAP))  # 0 * inf


class Estimate(NamedTuple):
    """What :func:`estimated_triangles` says of a request's sizes (as 3D's
    :class:`meshcore.tets.sizing.Estimate`)."""

    #: About how many triangles the sizes together ask for (at most 2 * 10**18).
    triangles: int
    #: The size that alone asks for the most ("size", "max_area" or "size_field"; the first
    #: of equals in that order), the one to relax; None without sizes.
    binding: str | None


def estimated_triangles(domain, *, max_area=None, size=None, size_field=None) -> Estimate:
    """About how many triangles :func:`triangulate` makes for these sizes, and which binds.

    Parameters
    ----------
    domain : Domain or dict
    max_area, size, size_field
        As :func:`triangulate`.

    Returns
    -------
    Estimate
        ``triangles``: twice the points of an equilateral mesh following the sizes
        together (area / (0.866 h**2); none when no size is given: the mesh then
        follows the boundary's own spacing) and of those the angle bound forces where
        the boundary runs close to itself (``0.25 perimeter**2 / area``: a strip of
        width w and length L needs edges about w long, about L / w points, whatever
        the size). ``binding``: the size whose points alone are the most (the field's
        nearest values over the domain's box alone). Meant for refusing runaway
        requests up front, naming the size to relax (Remark 8.10's control space).

    Raises
    ------
    InputError
        As :func:`triangulate` for the same arguments.
    """
    dom = as_domain(domain)
    max_area = positive_parameter(max_area, "max_area")
    size = positive_parameter(size, "size")
    fp = fv = None
    if size_field is not None:
        fp, fv = parse_size_field(size_field)
    # nearest field values: an estimate needs no triangulation of the field
    alone = {  # each given size alone
        name: _sizing(dom, *bounds, linear=False)
        for name, bounds, given in (
            ("size", (size, None, None, None), size is not None),
            ("max_area", (None, max_area, None, None), max_area is not None),
            ("size_field", (None, None, fp, fv), fp is not None),
        )
        if given
    }
    # together: the field's grid (interpolated once) capped by the uniform sizes, as _sizing
    sizing = _sizing(dom, size, max_area, None, None)
    field = alone.get("size_field")
    if field is not None:
        sizing = field if sizing is None else _Sizing(np.minimum(field.H, sizing.H), field.grid)
    points = {name: _sized_points(dom, s) for name, s in alone.items()}
    binding = max(points, key=points.get) if points else None
    return Estimate(2 * _expected_points(dom, sizing), binding)


def check_thinness(domain, most: int, *, code: str, advice: str) -> None:
    """Refuse a domain so thin that a mesh meeting the angle bound would be more than
    ``most`` triangles whatever the size (a strip of width w and length L needs about
    2 L / w: :func:`estimated_triangles` without sizes), in milliseconds, with the
    estimate, rather than met by a time or memory limit.

    Raises
    ------
    InputError
        ``code`` at ``domain``, the message ending with ``advice``.
    """
    dom = as_domain(domain)
    forced = estimated_triangles(dom).triangles
    if forced > most:
        raise InputError(
            f"the domain is so thin (area {dom.area:.3g} for its boundary's length) that "
            f"triangles meeting the angle bound would be about {forced:,} whatever the "
            f"size; {advice}",
            loc=("domain",),
            code=code,
        )


def _interpolate_field(fp: np.ndarray, fv: np.ndarray, q: np.ndarray, linear=True) -> np.ndarray:
    """Linear interpolation on our Delaunay triangulation of fp; nearest outside."""
    near = fv[cKDTree(fp).query(q)[1]]
    if len(fp) < 3 or not linear:
        return near
    try:
        tri = delaunay(fp)
    except InputError:  # collinear field points: nearest value everywhere
        return near
    t, bary = _locate_points(tri.points, tri.triangles, tri.neighbors, q)
    inside = t >= 0
    vals = near.copy()
    vals[inside] = np.einsum("ij,ij->i", bary[inside], fv[tri.triangles[t[inside]]])
    return vals


def _locate_points(points, triangles, neighbors, q):
    """Triangle of each query point (-1 outside the hull) and barycentric weights."""
    t = np.empty(len(q), np.int64)
    bary = np.zeros((len(q), 3))
    cdt.locate_many(points, triangles, neighbors, q, t, bary, np.empty(WORK_SIZE))
    return t, bary


def _sizing(domain: Domain, size, max_area, field_pts, field_vals, linear=True) -> _Sizing | None:
    h_area = None
    if max_area is not None:
        h_area = math.sqrt(4.0 * TOL.area_fill * max_area / math.sqrt(3.0))
    if field_pts is None:
        hs = [h for h in (size, h_area) if h is not None]
        if not hs:
            return None
        return _Sizing(np.array([[min(hs)]]), np.zeros(4))
    lo = domain.points.min(axis=0)
    hi = domain.points.max(axis=0)
    ext = hi - lo  # both positive: a valid domain has area
    cells = min(TOL.grid_cells, max(8, 4 * int(math.sqrt(len(field_pts)))))
    step = ext.max() / cells
    nx = int(math.ceil(ext[0] / step)) + 1
    ny = int(math.ceil(ext[1] / step)) + 1
    gx = lo[0] + step * np.arange(nx)
    gy = lo[1] + step * np.arange(ny)
    X, Y = np.meshgrid(gx, gy)
    q = np.column_stack([X.ravel(), Y.ravel()])
    H = _interpolate_field(field_pts, field_vals, q, linear).reshape(ny, nx)
    for h in (size, h_area):
        if h is not None:
            H = np.minimum(H, h)
    if nx == 1 or ny == 1:
        H = np.array([[H.min()]])
    return _Sizing(H, np.array([lo[0], lo[1], step, step]))


# ---------------------------------------------------------------------------
# Boundary subdivision
# ---------------------------------------------------------------------------


def _subdivide(P, seg, sizing: _Sizing | None, seg_circle: np.ndarray, circles: np.ndarray, beta):
    """Split every segment into pieces no longer than h along it and, unless ``beta`` is
    None, than ``beta`` times their feature size (:mod:`meshcore.triangulation.features`).

    Returns new points (q, 2), their segment ids (q,) and parameters (q,)
    (0 at the segment's first vertex, 1 at its second), ordered by segment
    then parameter.
    """
    empty = (np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0))
    if len(seg) == 0:
        return empty
    if sizing is None:
        sid, t = np.zeros(0, np.int64), np.zeros(0)
    else:
        sid, t = _size_cuts(P, seg, sizing)
    if beta is not None:
        sid, t = feature_cuts(P, seg, sid, t, beta)
    if len(sid) == 0:
        return empty
    a = P[seg[:, 0]]
    d = P[seg[:, 1]] - a
    pts = a[sid] + t[:, None] * d[sid]
    c = seg_circle[sid]
    on = c >= 0
    if on.any():
        cc = circles[c[on]]
        v = pts[on] - cc[:, :2]
        r = np.hypot(v[:, 0], v[:, 1])
        pts[on] = cc[:, :2] + v * (cc[:, 2] / np.where(r > 0, r, 1))[:, None]
    return pts, sid.astype(np.int64), t


def _size_cuts(P, seg, sizing: _Sizing):
    """Segment ids and parameters of the cuts making pieces no longer than h along them."""
    a = P[seg[:, 0]]
    b = P[seg[:, 1]]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    k = TOL.segment_samples
    s = np.linspace(0.0, 1.0, k)
    if sizing.uniform:
        n = np.ceil(length / sizing.H[0, 0] * (1 - TOL.count_slack)).astype(np.int64)
        n = np.maximum(n, 1)
        total = n - 1
        sid = np.repeat(np.arange(len(seg)), total)
        first = np.repeat(np.cumsum(total) - total, total)
        j = np.arange(total.sum()) - first + 1
        t = j / n[sid]
    else:
        xy = a[:, None, :] + s[None, :, None] * d[:, None, :]
        h = sizing(xy.reshape(-1, 2)).reshape(len(seg), k)
        inv = length[:, None] / h
        cum = np.concatenate(
            [
                np.zeros((len(seg), 1)),
                np.cumsum(0.5 * (inv[:, 1:] + inv[:, :-1]) / (k - 1), axis=1),
            ],
            axis=1,
        )
        n = np.maximum(np.ceil(cum[:, -1] * (1 - TOL.count_slack)).astype(np.int64), 1)
        total = n - 1
        sid = np.repeat(np.arange(len(seg)), total)
        first = np.repeat(np.cumsum(total) - total, total)
        j = np.arange(total.sum()) - first + 1
        target = j / n[sid] * cum[sid, -1]
        # invert the piecewise-linear cumulative integral of each segment
        # (every segment has a positive length and size: cum[:, -1] > 0)
        flat = (cum / cum[:, -1:] + np.arange(len(seg))[:, None]).ravel()
        pos = np.searchsorted(flat, target / cum[sid, -1] + sid) - 1
        pos = np.clip(pos, sid * k, sid * k + k - 2)
        lo_c = cum.ravel()[pos]
        hi_c = cum.ravel()[pos + 1]
        w = np.where(hi_c > lo_c, (target - lo_c) / np.where(hi_c > lo_c, hi_c - lo_c, 1), 0)
        t = (pos - sid * k + w) / (k - 1)
    return sid.astype(np.int64), t


# ---------------------------------------------------------------------------
# The interior pattern (§8.2)
# ---------------------------------------------------------------------------


def _capsule_rows(p0, p1, delta, y0, dy):
    """Per (segment, lattice row) pair within ``delta`` of the segment: the row,
    and the x-interval of the row inside the capsule of radius delta."""
    ylo = np.minimum(p0[:, 1], p1[:, 1]) - delta
    yhi = np.maximum(p0[:, 1], p1[:, 1]) + delta
    jlo = np.ceil((ylo - y0) / dy).astype(np.int64)
    jhi = np.floor((yhi - y0) / dy).astype(np.int64)
    cnt = np.maximum(jhi - jlo + 1, 0)
    s = np.repeat(np.arange(len(p0)), cnt)
    j = jlo[s] + np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    y = y0 + j * dy
    a, b, r = p0[s], p1[s], delta[s]
    lo = np.full(len(s), np.inf)
    hi = np.full(len(s), -np.inf)
    for c in (a, b):  # the two end disks
        h2 = r * r - (y - c[:, 1]) ** 2
        ok = h2 >= 0
        w = np.sqrt(np.where(ok, h2, 0))
        lo = np.where(ok, np.minimum(lo, c[:, 0] - w), lo)
        hi = np.where(ok, np.maximum(hi, c[:, 0] + w), hi)
    ex = b[:, 0] - a[:, 0]
    ey = b[:, 1] - a[:, 1]
    L = np.hypot(ex, ey)
    ry = y - a[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        # band |(x - ax) ey - ry ex| < r L  and projection 0 <= (x - ax) ex + ry ey <= L^2
        c1 = a[:, 0] + (ry * ex - r * L) / ey
        c2 = a[:, 0] + (ry * ex + r * L) / ey
        d1 = a[:, 0] + (-ry * ey) / ex
        d2 = a[:, 0] + (L * L - ry * ey) / ex
    band_lo = np.where(ey != 0, np.minimum(c1, c2), np.where(np.abs(ry) < r, -np.inf, np.inf))
    band_hi = np.where(ey != 0, np.maximum(c1, c2), np.where(np.abs(ry) < r, np.inf, -np.inf))
    proj_in = (ry * ey >= 0) & (ry * ey <= L * L)
    proj_lo = np.where(ex != 0, np.minimum(d1, d2), np.where(proj_in, -np.inf, np.inf))
    proj_hi = np.where(ex != 0, np.maximum(d1, d2), np.where(proj_in, np.inf, -np.inf))
    s_lo = np.maximum(band_lo, proj_lo)
    s_hi = np.minimum(band_hi, proj_hi)
    ok = s_lo <= s_hi
    lo = np.where(ok, np.minimum(lo, s_lo), lo)
    hi = np.where(ok, np.maximum(hi, s_hi), hi)
    return j, lo, hi


def _lattice(P, bseg, allseg, h: float, keep_boundary: bool, window=None):
    """Lattice points (k, 2) inside the domain and clear of every segment.

    ``window = (gy0, gstep, xlo, xhi)``: only in the x-span ``[xlo[g],
    xhi[g]]`` of the horizontal band ``g`` (of height ``gstep`` from
    ``gy0``) that each lattice row falls in.
    """
    lo = P.min(axis=0)
    hi = P.max(axis=0)
    dy = h * math.sqrt(3.0) / 2.0
    if dy > hi[1] - lo[1]:  # two rows, dy / 2 below and above the box: no point inside
        return np.zeros((0, 2))  # (and a size of 1e300 would overflow the capsules below)
    nx = int(math.floor((hi[0] - lo[0]) / h * (1 + TOL.lattice_slack))) + 2
    ny = int(math.floor((hi[1] - lo[1]) / dy * (1 + TOL.lattice_slack))) + 2
    y0 = lo[1] + 0.5 * ((hi[1] - lo[1]) - (ny - 1) * dy)
    x0 = lo[0] + 0.5 * ((hi[0] - lo[0]) - (nx - 1.5) * h)
    # Scan lines: even-odd intervals of each row inside the boundary rings.
    a = P[bseg[:, 0]]
    b = P[bseg[:, 1]]
    ya = a[:, 1]
    yb = b[:, 1]
    ylo = np.minimum(ya, yb)
    yhi = np.maximum(ya, yb)
    # Rows y_j = y0 + j dy in [ylo, yhi) (half-open, decided on the very
    # floats y_j that the crossings use, so that the two segments at a ring
    # vertex agree and every row crosses each ring an even number of times).
    jlo = np.ceil((ylo - y0) / dy).astype(np.int64)
    jlo += (y0 + jlo * dy < ylo).astype(np.int64)
    jlo -= (y0 + (jlo - 1) * dy >= ylo).astype(np.int64)
    jhi = np.ceil((yhi - y0) / dy).astype(np.int64) - 1
    jhi -= (y0 + jhi * dy >= yhi).astype(np.int64)
    jhi += (y0 + (jhi + 1) * dy < yhi).astype(np.int64)
    cnt = np.maximum(jhi - jlo + 1, 0)
    s = np.repeat(np.arange(len(bseg)), cnt)
    j = jlo[s] + np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    y = y0 + j * dy
    xc = a[s, 0] + (y - ya[s]) * (b[s, 0] - a[s, 0]) / (yb[s] - ya[s])
    order = np.lexsort((xc, j))
    j, xc = j[order], xc[order]
    if len(j) % 2:
        raise AlgorithmError("scan line crossing count is odd; the boundary is not closed")
    rows, xs, xe = np.ascontiguousarray(j[0::2]), xc[0::2], xc[1::2]
    if window is not None:
        gy0, gstep, wlo, whi = window
        g = np.clip(np.floor((y0 + rows * dy - gy0) / gstep).astype(np.int64), 0, len(wlo) - 1)
        xs = np.maximum(xs, wlo[g])
        xe = np.minimum(xe, whi[g])
    off = x0 + 0.5 * h * (rows % 2)
    i0 = np.maximum(np.ceil((xs - off) / h).astype(np.int64), 0)
    i1 = np.minimum(np.floor((xe - off) / h).astype(np.int64), nx - 1)
    # Drop points near the segments (capsules of radius delta).
    sa = P[allseg[:, 0]]
    sb = P[allseg[:, 1]]
    sl = np.hypot(*(sb - sa).T)
    delta = np.full(len(allseg), TOL.clearance * h)
    if not keep_boundary:
        delta = np.maximum(delta, 0.5 * sl * (1 + TOL.ball_margin))
    cj, clo, chi = _capsule_rows(sa, sb, delta, y0, dy)
    inrange = (cj >= 0) & (cj < ny)
    cj, clo, chi = cj[inrange], clo[inrange], chi[inrange]
    coff = x0 + 0.5 * h * (cj % 2)
    ci0 = np.maximum(np.ceil((clo - coff) / h).astype(np.int64), 0)
    ci1 = np.minimum(np.floor((chi - coff) / h).astype(np.int64), nx - 1)
    ccnt = np.maximum(ci1 - ci0 + 1, 0)
    cr = np.repeat(cj, ccnt)
    ci = np.repeat(ci0, ccnt) + np.arange(ccnt.sum()) - np.repeat(np.cumsum(ccnt) - ccnt, ccnt)
    dropped = np.sort(cr * nx + ci)
    grid = (nx, x0, y0, h, dy, TOL.jitter * h)
    out = np.empty((_lattice_points(rows, i0, i1, dropped, *grid, _NO_POINTS), 2))
    _lattice_points(rows, i0, i1, dropped, *grid, out)
    return out


#: The ``out`` of :func:`_lattice_points` that asks for the count only.
_NO_POINTS = np.empty((0, 2))


@njit(cache=True)
def _lattice_points(rows, i0, i1, dropped, nx, x0, y0, h, dy, amp, out):
    """The lattice points of the row intervals (row ``rows[t]``, columns ``i0[t]`` to
    ``i1[t]``) whose index ``row * nx + column`` is not in the sorted ``dropped``,
    jittered by a hash of that index; written to ``out`` in interval order when it
    has rows. Returns their number. One compiled pass: no per-point temporaries.
    The intervals come as the scan lines make them, row after row and left to right
    in a row, so the indices never decrease and the search in ``dropped`` walks
    forward."""
    write = out.shape[0] > 0
    nd = len(dropped)
    n = 0
    p = 0
    for t in range(len(rows)):
        r = rows[t]
        for i in range(i0[t], i1[t] + 1):
            key = r * nx + i
            while p < nd and dropped[p] < key:
                p += 1
            if p < nd and dropped[p] == key:
                continue
            if write:
                # deterministic jitter (a hash of the lattice index)
                z = np.uint64(key) * np.uint64(0x9E3779B97F4A7C15)
                z ^= z >> np.uint64(29)
                z *= np.uint64(0xBF58476D1CE4E5B9)
                z ^= z >> np.uint64(32)
                u = np.float64(z & np.uint64(0xFFFF)) / 65535.0 - 0.5
                v = np.float64((z >> np.uint64(16)) & np.uint64(0xFFFF)) / 65535.0 - 0.5
                out[n, 0] = (x0 + h * (np.float64(i) + 0.5 * np.float64(r % 2))) + amp * u
                out[n, 1] = (y0 + dy * np.float64(r)) + amp * v
            n += 1
    return n


def _graded_pattern(P, bseg, allseg, sizing: _Sizing, keep_boundary: bool):
    """Near-equilateral points following a varying size (§8.2 with Remark 8.10).

    Level ``k`` is the lattice of side ``s_k = h_min q**(k + 1/2)`` (``q`` =
    :attr:`_Tolerances.level_ratio`), kept where ``h(x)`` lies in ``[h_min
    q**k, h_min q**(k + 1))`` (so its side is within ``q**(1/2)`` of the size
    there) and laid only over the bands of the size grid where that can
    happen. Where two levels meet, points closer than half the finer side
    (Delaunay edges of the candidates) are thinned; refinement then repairs
    the seams.
    """
    H, grid = sizing.H, sizing.grid
    hmin = float(H.min())
    q = TOL.level_ratio
    levels = max(1, int(math.ceil(math.log(float(H.max()) / hmin, q))) + 1)
    cmin = np.minimum(np.minimum(H[:-1, :-1], H[:-1, 1:]), np.minimum(H[1:, :-1], H[1:, 1:]))
    cmax = np.maximum(np.maximum(H[:-1, :-1], H[:-1, 1:]), np.maximum(H[1:, :-1], H[1:, 1:]))
    pts, side = [], []
    for k in range(levels):
        lo, hi = hmin * q**k, hmin * q ** (k + 1)
        if k == levels - 1:
            hi = np.inf
        active = (cmin < hi) & (cmax >= lo)
        if not active.any():
            continue
        first = np.where(active.any(axis=1), np.argmax(active, axis=1), active.shape[1])
        last = np.where(
            active.any(axis=1), active.shape[1] - 1 - np.argmax(active[:, ::-1], axis=1), -1
        )
        wlo = grid[0] + grid[2] * first
        whi = grid[0] + grid[2] * (last + 1)
        s_k = hmin * q ** (k + 0.5)
        lat = _lattice(P, bseg, allseg, s_k, keep_boundary, (grid[1], grid[3], wlo, whi))
        h = sizing(lat)
        band = (h >= lo) & (h < hi) if k else h < hi
        pts.append(lat[band])
        side.append(np.full(int(band.sum()), s_k))
    if not pts:
        return np.zeros((0, 2))
    X = np.concatenate(pts)
    side = np.concatenate(side)
    X, first = np.unique(X, axis=0, return_index=True)
    side = side[first]
    if len(X) < 3:
        return X
    try:
        tri = delaunay(X)
    except InputError:  # all collinear: nothing to thin
        return X
    t = tri.triangles
    e = np.unique(
        np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1), axis=0
    )
    a, b = e[:, 0], e[:, 1]
    length = np.hypot(*(X[b] - X[a]).T)
    close = length < TOL.thinning * np.minimum(side[a], side[b])
    a, b = a[close], b[close]
    drop = np.zeros(len(X), bool)
    drop[np.where(side[a] < side[b], a, np.where(side[a] > side[b], b, np.maximum(a, b)))] = True
    return X[~drop]


# ---------------------------------------------------------------------------
# The driver
# ---------------------------------------------------------------------------


class _Work:
    """The growable arrays of the refinement kernel (see :mod:`meshcore.delaunay.cdt`)."""

    def __init__(self, P, V, A, S, ntri, npts, pseg, ppar, vt, n_input, scratch=4096):
        self.P, self.V, self.A, self.S = P, V, A, S
        self.pseg, self.ppar, self.vt = pseg, ppar, vt
        tcap = len(V) // 3
        self.G = np.zeros(tcap, np.int32)
        self.mark = np.zeros(tcap, np.int64)
        self.fan = np.full(len(P), -1, np.int32)
        self.st = np.zeros(cdt.ST_SIZE, np.int64)
        self.st[cdt.ST_NPTS] = npts
        self.st[cdt.ST_NTRI] = ntri
        self.st[cdt.ST_NINPUT] = n_input
        self.Qe = np.empty((3, ntri + 8 * scratch), np.int32)
        self.Qb = np.empty((2, cdt.NBUCKETS), np.int32)
        self.SQ = np.empty((2, 3 * ntri + 8 * scratch), np.int32)
        self.scr = np.empty((8, scratch), np.int64)
        self.work = np.empty(WORK_SIZE)

    @property
    def M(self):
        return (
            self.P,
            self.V,
            self.A,
            self.S,
            self.G,
            self.vt,
            self.pseg,
            self.ppar,
            self.fan,
            self.mark,
        )

    @property
    def Qs(self):
        return (self.Qe, self.Qb, self.SQ)

    @staticmethod
    def _grown(a, n, fill=None, axis=0):
        shape = list(a.shape)
        shape[axis] = n
        out = np.empty(shape, a.dtype) if fill is None else np.full(shape, fill, a.dtype)
        if axis == 0:
            out[: a.shape[0]] = a
        else:
            out[:, : a.shape[1]] = a
        return out

    def grow_space(self):
        sc = self.scr.shape[1]
        if int(self.st[cdt.ST_NPTS]) + 2 >= len(self.P):
            n = 2 * len(self.P)
            self.P = self._grown(self.P, n)
            self.pseg = self._grown(self.pseg, n)
            self.ppar = self._grown(self.ppar, n)
            self.vt = self._grown(self.vt, n)
            self.fan = self._grown(self.fan, n, -1)
        if int(self.st[cdt.ST_NTRI]) + sc >= len(self.G):
            n = 2 * len(self.G) + sc
            self.V = self._grown(self.V, 3 * n)
            self.A = self._grown(self.A, 3 * n)
            self.S = self._grown(self.S, 3 * n)
            self.G = self._grown(self.G, n, 0)
            self.mark = self._grown(self.mark, n, 0)

    def grow_queue(self):
        sc = self.scr.shape[1]
        self.Qe = self._grown(self.Qe, 2 * self.Qe.shape[1] + 8 * sc, axis=1)
        self.SQ = self._grown(self.SQ, 2 * self.SQ.shape[1] + 8 * sc, axis=1)

    def grow_scratch(self):
        self.scr = np.empty((8, 2 * self.scr.shape[1]), np.int64)
        self.grow_space()
        self.grow_queue()


def triangulate(
    domain,
    *,
    curves: Sequence | None = None,
    empty: bool = False,
    min_angle: float | None = None,
    max_area: float | None = None,
    size: float | None = None,
    size_field=None,
    keep_boundary: bool = False,
    progress: Callable[[float, str], None] | None = None,
) -> TriangulationResult:
    """Triangulate a planar domain, conforming to its boundary and constraints.

    Parameters
    ----------
    domain : Domain or dict
        The domain (:func:`meshcore.domain.planar.parse_domain`), or its GeoJSON
        geometry (then parsed here, without constraints).
    curves : list of dict, optional
        ``{"ring": k, "type": "circle", "center": [x, y], "radius": r}``:
        points added on ring ``k`` go on that circle (§9.1.5), not on the
        chord. No effect with ``keep_boundary``.
    empty : bool
        Only the boundary points (plus, unless the boundary is kept, the
        Steiner points making the segments Delaunay-admissible): the "empty"
        triangulation of §9. Excludes the four bounds below.
    min_angle : float, optional
        Degrees, in ``(0, 34]``: refine until every triangle's smallest
        angle reaches it, except next to input angles smaller than it (they
        stay). Terminates for any value up to 30 (module docstring).
        Default 20 when points are added.
    max_area : float, optional
        Largest triangle area.
    size : float, optional
        Target edge length.
    size_field : dict, optional
        ``{"points": (k, 2), "values": (k,)}``: target edge lengths at
        scattered points, interpolated linearly on their Delaunay
        triangulation, nearest value outside it; ``size`` and ``max_area``
        bound it further.
    keep_boundary : bool
        Add no point on any input segment (boundary or constraint): segments
        are recovered by flips and refinement stops where it would encroach.
    progress : callable, optional
        ``progress(fraction, message)``; may raise to cancel.

    Returns
    -------
    TriangulationResult

    Raises
    ------
    InputError
        Bad parameters (``loc`` names the argument), or a bad domain.
    AlgorithmError
        Refinement past :data:`MAX_POINTS` points.

    References
    ----------
    Methods text §8.2, Remark 8.10, §9.1; module docstring.
    """
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

    dom = as_domain(domain)
    min_angle = positive_parameter(min_angle, "min_angle", MAX_MIN_ANGLE)
    max_area = positive_parameter(max_area, "max_area")
    size = positive_parameter(size, "size")
    field_pts = field_vals = None
    if size_field is not None:
        field_pts, field_vals = parse_size_field(size_field)
    if empty:
        given = [
            n
            for n, v in (
                ("min_angle", min_angle),
                ("max_area", max_area),
                ("size", size),
                ("size_field", size_field),
            )
            if v is not None
        ]
        if given:
            raise InputError(
                f"empty=true adds no interior point; it excludes {given[0]}",
                loc=(given[0],),
                code="conflicting_parameters",
            )
    circles, seg_circle = circles_of(dom, curves)
    report(0.0, "sizing")

    P_in = dom.points
    n_input = len(P_in)
    nbs = len(dom.segments)
    seg_in = np.concatenate([dom.segments, dom.constraints]).astype(np.int64)
    if keep_boundary:
        seg_circle[:] = -1
    seg_circle = seg_circle.astype(np.int32)
    circle_arr = circles if len(circles) else np.zeros((1, 3))

    sizing = None if empty else _sizing(dom, size, max_area, field_pts, field_vals)
    wanted = _sized_points(dom, sizing)
    if not wanted < _ESTIMATE_CAP:
        # more points than any machine holds: refused here, not met by an integer
        # overflow in the boundary's cuts or the lattice
        given = (("size", size), ("max_area", max_area), ("size_field", size_field))
        name = next((n for n, v in given if v is not None), "domain")
        raise InputError(
            f"these sizes would make about {wanted:.3g} points on a domain of area "
            f"{dom.area:.6g}: ask for larger sizes",
            loc=(name,),
            code="too_many_triangles",
        )
    if not empty and min_angle is None:
        min_angle = DEFAULT_MIN_ANGLE
    lap("sizing")

    # -- boundary: subdivision by h (unless kept) ---------------------------
    report(0.05, "boundary")
    if keep_boundary:
        newp, newsid, newpar = np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0)
    else:
        beta = None if empty else TOL.feature
        newp, newsid, newpar = _subdivide(P_in, seg_in, sizing, seg_circle, circle_arr, beta)
    P = np.concatenate([P_in, newp])
    pseg = np.concatenate([np.full(n_input, -1, np.int64), newsid])
    ppar = np.concatenate([np.zeros(n_input), newpar])
    sub = _subsegments(seg_in, newsid, n_input)
    adm = None
    if not keep_boundary:
        try:
            P, pseg, ppar, sub, adm = _admissible(P, pseg, ppar, sub, seg_in, seg_circle, circles)
        except InputError as exc:  # indices of the subsegments: the domain's vertices
            raise located_in_domain(exc, dom, seg_in, sub[1], pseg) from None
    lap("boundary")

    # -- interior pattern ---------------------------------------------------
    report(0.1, "interior pattern")
    lat = np.zeros((0, 2))
    if sizing is not None:
        bsub = sub[0][sub[1] < nbs]
        if sizing.uniform:
            lat = _lattice(P, bsub, sub[0], float(sizing.H[0, 0]), keep_boundary)
        else:
            lat = _graded_pattern(P, bsub, sub[0], sizing, keep_boundary)
    # The points, their segments and parameters go straight into the refinement's
    # arrays (with room for the points it adds): no joined copies in between.
    n_lattice = len(lat)
    n_outline = len(P)
    npts = n_outline + n_lattice
    pcap = npts + npts // 8 + 4096
    Pc = np.empty((pcap, 2))
    Pc[:n_outline] = P
    Pc[n_outline:npts] = lat
    P = Pc[:npts]
    pseg_c = np.full(pcap, -1, np.int32)
    pseg_c[:n_outline] = pseg
    ppar_c = np.zeros(pcap)
    ppar_c[:n_outline] = ppar
    del lat, pseg, ppar
    lap("interior")

    # -- one Delaunay triangulation -----------------------------------------
    report(0.15, "Delaunay triangulation")
    # without pattern points, the admissible boundary's own triangulation is that of P
    tri = adm.delaunay if adm is not None and n_lattice == 0 else delaunay(P)
    lap("delaunay")

    # -- segments and regions -----------------------------------------------
    report(0.5, "segments and regions")
    m0 = len(tri.triangles)
    tcap = m0 + m0 // 8 + 4096
    V = np.empty(3 * tcap, np.int32)
    A = np.empty(3 * tcap, np.int32)
    S = np.empty(3 * tcap, np.int32)
    vt = np.zeros(pcap, np.int32)
    cdt.build(tri.triangles, tri.neighbors, V, A, S, vt)
    del tri, P
    work = np.empty(WORK_SIZE)
    info = np.zeros(4, np.int64)
    status = cdt.recover_segments(Pc, V, A, S, vt, sub[0], sub[1], work, info)
    if status != cdt.DONE:
        why = "a vertex lies on it" if status == cdt.COLLINEAR else "it crosses another segment"
        raise AlgorithmError(
            f"segment {int(info[1])} could not be recovered ({why}); "
            "this is a bug for a validated domain"
        )
    bmask = sub[1] < nbs
    inside = cdt.domain_triangles(V, A, S, vt, m0, sub[0][bmask], nbs)
    ntri = cdt.compact(V, A, S, inside, vt)
    del inside
    lap("constraints")

    # -- refinement -----------------------------------------------------------
    w = _Work(Pc, V, A, S, ntri, npts, pseg_c, ppar_c, vt, n_input)
    del Pc, V, A, S, pseg_c, ppar_c, vt  # w holds them (and their grown copies)
    rounds = given_up = 0
    if not empty:
        report(0.6, "refinement")
        prm = np.zeros(cdt.PR_SIZE)
        prm[cdt.PR_SIN2] = math.sin(math.radians(min_angle)) ** 2
        # "Small" input angles for the Miller-Pav-Walkington rule: below the
        # bound itself up to 30 degrees (so that every other triangle meets it),
        # below 60 degrees above that (their rule, as Triangle: terminates).
        small = min_angle if min_angle <= GUARANTEED_MIN_ANGLE else MPW_SMALL_ANGLE
        prm[cdt.PR_COS] = math.cos(math.radians(small))
        half = math.tan(math.radians(min_angle) / 2.0)  # 0 for a subnormal min_angle
        prm[cdt.PR_OFF] = TOL.offcenter / half if half > 0 else 0.0  # 0: circumcentres
        prm[cdt.PR_AREA] = max_area if max_area is not None else np.inf
        prm[cdt.PR_SIZE2] = TOL.circumradius**2 if sizing is not None else 0.0
        prm[cdt.PR_KEEP] = 1.0 if keep_boundary else 0.0
        prm[cdt.PR_UNIT] = TOL.shell_unit * dom.diameter
        prm[cdt.PR_EQUI] = TOL.equidistant
        expected = npts + _expected_points(dom, sizing)
        budget = min(MAX_POINTS, max(MIN_BUDGET, BUDGET_FACTOR * expected))
        prm[cdt.PR_BUDGET] = budget
        prm[cdt.PR_OPS] = 1 << 16
        H = sizing.H if sizing is not None else np.ones((1, 1))
        hg = sizing.grid if sizing is not None else np.zeros(4)
        D = (prm, seg_in, seg_circle, circle_arr, H, hg)
        cdt.init_queues(w.M, D, w.Qs, w.st, w.work)
        while True:
            status = cdt.refine(w.M, D, w.Qs, w.st, w.scr, w.work)
            if status == cdt.DONE:
                break
            if status == cdt.NEED_SPACE:
                w.grow_space()
            elif status == cdt.NEED_QUEUE:
                w.grow_queue()
            elif status == cdt.NEED_SCRATCH:
                w.grow_scratch()
            elif status == cdt.YIELD:
                n = int(w.st[cdt.ST_NPTS])
                report(
                    0.6 + 0.3 * n / (n + max(expected - n, npts)),
                    f"refinement: {n} points, {int(w.st[cdt.ST_QCOUNT])} triangles queued",
                )
            elif status == cdt.BUDGET:
                raise AlgorithmError(
                    f"refinement reached {budget} points without meeting the bounds "
                    f"(min_angle {min_angle:g}): ask for a larger size or a smaller min_angle"
                )
        rounds = int(w.st[cdt.ST_ROUNDS])
        given_up = int(w.st[cdt.ST_GIVEN_UP])
    lap("refine")

    # -- output ---------------------------------------------------------------
    report(0.95, "output")
    npts = int(w.st[cdt.ST_NPTS])
    ntri = int(w.st[cdt.ST_NTRI])
    tris = w.V[: 3 * ntri].reshape(-1, 3).astype(np.int64)
    pts = w.P[:npts]
    pseg_o = w.pseg[:npts]
    used = np.zeros(npts, bool)
    used[tris.ravel()] = True
    if not used.all():
        remap = np.cumsum(used) - 1
        tris = remap[tris]
        pts = pts[used]
        pseg_o = pseg_o[used]
        n_input_out = int(used[:n_input].sum())
    else:
        remap = None
        n_input_out = n_input
    segs, sids = _output_segments(w.V[: 3 * ntri], w.S[: 3 * ntri], w.ppar[:npts], seg_in, nbs)
    if remap is not None:
        segs = remap[segs]
    n_new = len(pts) - n_input_out
    n_boundary = int(np.count_nonzero(pseg_o[n_input_out:] >= 0))
    mesh = Mesh(np.ascontiguousarray(pts), (CellBlock("triangle", tris),))
    lap("output")
    report(1.0, f"{len(tris)} triangles")
    return TriangulationResult(
        mesh=mesh,
        segments=segs,
        segment_ids=sids,
        boundary_points_added=n_boundary,
        interior_points_added=n_new - n_boundary,
        rounds=rounds,
        given_up=given_up,
        boundary_segment_count=nbs,
        timings=timings,
    )


def _admissible(P, pseg, ppar, sub, seg_in, seg_circle, circles):
    """Split subsegments until each is a Delaunay edge (§9.1.4, meshcore.delaunay.admissible);
    the last item returned is the :class:`~meshcore.delaunay.admissible.AdmissibleSegments`."""
    adm = admissible_segments(P, sub[0], circles=circles, segment_circle=seg_circle[sub[1]])
    if adm.added == 0:
        return P, pseg, ppar, sub, adm
    sid = sub[1][adm.source]
    n = len(P)
    new_sid = np.empty(adm.added, np.int64)
    rows = np.flatnonzero(adm.segments[:, 1] >= n)
    new_sid[adm.segments[rows, 1] - n] = sid[rows]
    X = adm.points[n:]
    a = adm.points[seg_in[new_sid, 0]]
    d = adm.points[seg_in[new_sid, 1]] - a
    t = np.einsum("ij,ij->i", X - a, d) / np.einsum("ij,ij->i", d, d)
    # (writeable copies: numba compiles read-only arrays as another type)
    return (
        np.array(adm.points, dtype=np.float64),
        np.concatenate([pseg, new_sid]),
        np.concatenate([ppar, t]),
        (np.array(adm.segments, dtype=np.int64), sid),
        adm,
    )


def _subsegments(seg_in: np.ndarray, newsid: np.ndarray, n_input: int):
    """Subsegments after subdivision: ((k, 2) endpoints, (k,) segment ids).

    New points ``n_input + i`` are ordered by segment then parameter, so each
    segment's chain is its first vertex, its new points, its second vertex.
    """
    counts = np.bincount(newsid, minlength=len(seg_in))
    starts = n_input + np.cumsum(counts) - counts
    nsub = counts + 1
    sid = np.repeat(np.arange(len(seg_in)), nsub)
    pos = np.arange(nsub.sum()) - np.repeat(np.cumsum(nsub) - nsub, nsub)
    a = np.where(pos == 0, seg_in[sid, 0], starts[sid] + pos - 1)
    b = np.where(pos == nsub[sid] - 1, seg_in[sid, 1], starts[sid] + pos)
    return np.column_stack([a, b]).astype(np.int64), sid.astype(np.int64)


def _output_segments(V, S, ppar, seg_in, nbs):
    """Mesh edges on input segments, oriented as their segment, sorted by id then position."""
    k = np.flatnonzero(S >= 0)
    nxt = np.where(k % 3 == 2, k - 2, k + 1)
    prv = np.where(k % 3 == 0, k + 2, k - 1)
    a = V[nxt].astype(np.int64)
    b = V[prv].astype(np.int64)
    sid = S[k].astype(np.int64)
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    # Each edge once (it is seen from both sides), sorted by (sid, lo, hi).
    order = np.lexsort((hi, lo, sid))
    sid, lo, hi = sid[order], lo[order], hi[order]
    first = np.ones(len(sid), dtype=bool)
    first[1:] = (sid[1:] != sid[:-1]) | (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    sid, a, b = sid[first], lo[first], hi[first]

    def param(p, s):
        return np.where(p == seg_in[s, 0], 0.0, np.where(p == seg_in[s, 1], 1.0, ppar[p]))

    ta = param(a, sid)
    tb = param(b, sid)
    swap = ta > tb
    a2 = np.where(swap, b, a)
    b2 = np.where(swap, a, b)
    order = np.lexsort((np.minimum(ta, tb), sid))
    return np.column_stack([a2, b2])[order], sid[order]
