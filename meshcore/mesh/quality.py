r"""Quality measures of cells, vectorized over cells, and the mesh quality report.

One measure per cell type, each 1 for the ideal cell and at most 1 (except
the pyramid's, see :func:`scaled_jacobian`):

- triangle: normalized shape ratio ``4 sqrt(3) A / (a² + b² + c²)``
  (:func:`triangle_shape`);
- quad: the corner measure (8.3)/(8.4) of §8.4.4, or its metric form (8.6)
  with a constant metric or one per vertex (:func:`quad_quality`); also the
  simplified measure (8.7) at the ends of one diagonal
  (:func:`quad_quality_simplified`), the shape measure (8.8) of Remark 8.7
  (:func:`quad_shape`) and, for quads in space, the warp angle
  (:func:`quad_warp`);
- tetra: normalized radius ratio ``3 r_in / r_circ`` (:func:`tetra_radius_ratio`);
- pyramid, wedge, hexahedron: scaled Jacobian, the least normalized corner
  Jacobian determinant (:func:`scaled_jacobian`).

Signs. In the plane (points ``(n, 2)``) a triangle or quad is positive when
counterclockwise; its signed area (shoelace) and its quality are then
negative or zero when it is clockwise. Cells of a surface (points ``(n, 3)``,
2D cells) have no sign: their area is the magnitude of the vector area, and
only a zero area makes them invalid. Volumes are signed by meshio's local
numbering (see :mod:`meshcore.mesh.topology`). A cell is *invalid* when its area
or volume is ``<= 0``.

Angles are in degrees. A corner with a zero-length side has angle 0 (its
cell is degenerate), so no function here returns NaN for finite input
(unless squared coordinates overflow, beyond about 1e154; the report then
counts the cell as invalid with quality 0 and skips its angles).

References: §8.4.4 (quad quality (8.3), (8.4), angle in a metric (8.5), quad
quality in a metric (8.6), the simplified measure (8.7), Remark 8.7 (8.8));
§8.4.5 (quads on a surface); §8.3.1, Definition 8.1 (conformity).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numba import njit

from meshcore.errors import InputError
from meshcore.geometry.predicates import WORK_SIZE, orient2d_filtered
from meshcore.mesh.mesh import CELL_TYPES, Mesh
from meshcore.mesh.topology import CELL_FACES, as_blocks, conformity

__all__ = [
    "HISTOGRAM_BINS",
    "cell_angles",
    "cell_quality",
    "metric_factors",
    "planar_quad_measures",
    "quad_angles",
    "quad_quality",
    "quad_quality_simplified",
    "quad_shape",
    "quad_warp",
    "report",
    "reported_quality",
    "scaled_jacobian",
    "signed_area",
    "signed_volume",
    "tetra_radius_ratio",
    "triangle_angles",
    "triangle_shape",
]

#: Number of equal bins over [0, 1] in a report's quality histogram.
HISTOGRAM_BINS = 10

_SQRT3 = math.sqrt(3.0)

# Corners used by the scaled Jacobian: (corner, e1, e2, e3), with
# det(e1 - corner, e2 - corner, e3 - corner) > 0 in a positive cell.
_JACOBIAN_CORNERS: dict[str, tuple[np.ndarray, float]] = {
    "tetra": (np.array([[0, 1, 2, 3], [1, 2, 0, 3], [2, 0, 1, 3], [3, 0, 2, 1]]), math.sqrt(2)),
    "pyramid": (np.array([[0, 1, 3, 4], [1, 2, 0, 4], [2, 3, 1, 4], [3, 0, 2, 4]]), math.sqrt(2)),
    "wedge": (
        np.array(
            [[0, 1, 2, 3], [1, 2, 0, 4], [2, 0, 1, 5], [3, 5, 4, 0], [4, 3, 5, 1], [5, 4, 3, 2]]
        ),
        2 / _SQRT3,
    ),
    "hexahedron": (
        np.array(
            [
                [0, 1, 3, 4],
                [1, 2, 0, 5],
                [2, 3, 1, 6],
                [3, 0, 2, 7],
                [4, 7, 5, 0],
                [5, 4, 6, 1],
                [6, 5, 7, 2],
                [7, 6, 4, 3],
            ]
        ),
        1.0,
    ),
}

# Positive tetrahedra whose signed volumes add up to the cell's. The pyramid
# takes the mean of its two diagonal splits (exact for a bilinear base); the
# wedge is split 0123 / 1234 / 2345; the hexahedron into six tetrahedra around
# its diagonal 0-6.
_TETS: dict[str, tuple[np.ndarray, float]] = {
    "tetra": (np.array([[0, 1, 2, 3]]), 1.0),
    "pyramid": (np.array([[0, 1, 2, 4], [0, 2, 3, 4], [0, 1, 3, 4], [1, 2, 3, 4]]), 0.5),
    "wedge": (np.array([[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]]), 1.0),
    "hexahedron": (
        np.array(
            [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
        ),
        1.0,
    ),
}

_2D = ("triangle", "quad")
_3D = ("tetra", "pyramid", "wedge", "hexahedron")


def _quiet(func):
    """Run ``func`` without floating-point warnings: degenerate cells are handled explicitly."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with np.errstate(all="ignore"):
            return func(*args, **kwargs)

    return wrapper


# ----------------------------------------------------------------------------- input


def _points(points) -> np.ndarray:
    try:
        pts = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "points must be a rectangular list of numbers", loc=("points",), code="bad_shape"
        ) from exc
    if pts.ndim == 1 and pts.size == 0:
        pts = pts.reshape(0, 2)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise InputError(
            f"points must be a list of [x, y] or [x, y, z], got shape {pts.shape}",
            loc=("points",),
            code="bad_shape",
        )
    if not np.isfinite(pts).all():
        i, j = np.argwhere(~np.isfinite(pts))[0]
        raise InputError(
            f"point {i} has a non-finite coordinate ({pts[i, j]})",
            loc=("points", int(i), int(j)),
            code="non_finite",
        )
    return pts


def _check_dim(pts: np.ndarray, cell_type: str) -> None:
    if CELL_TYPES[cell_type][1] == 3 and pts.shape[1] != 3:
        raise InputError(
            f"{cell_type} cells need points in 3D, got points of dimension {pts.shape[1]}",
            loc=("points",),
            code="bad_dimension",
        )


def _prepare(points, cells, cell_type: str, allowed: tuple[str, ...]):
    """Checked ``(n, d)`` points and ``(m, k)`` cells of a type in ``allowed``."""
    if cell_type not in allowed:
        raise InputError(
            f"this measure applies to {', '.join(allowed)} cells, not {cell_type!r}",
            loc=("cell_type",),
            code="unknown_cell_type",
        )
    pts = _points(points)
    data = as_blocks([(cell_type, cells)], len(pts))[0].data
    _check_dim(pts, cell_type)
    return pts, data


def _metric(metric, d: int) -> np.ndarray | None:
    """The Cholesky factor ``L`` (``M = L L^T``) of a constant SPD metric ``(d, d)``."""
    if metric is None:
        return None
    try:
        m = np.asarray(metric, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "metric must be a square matrix of numbers", loc=("metric",), code="bad_metric"
        ) from exc
    if m.shape != (d, d) or not np.isfinite(m).all():
        raise InputError(
            f"metric must be a finite {d}x{d} matrix for {d}D points, got shape {m.shape}",
            loc=("metric",),
            code="bad_metric",
        )
    if not np.allclose(m, m.T, rtol=1e-12, atol=0.0):
        raise InputError("metric must be symmetric", loc=("metric",), code="bad_metric")
    try:
        return np.linalg.cholesky(m)
    except np.linalg.LinAlgError as exc:
        raise InputError(
            "metric must be positive definite", loc=("metric",), code="bad_metric"
        ) from exc


def metric_factors(metric, d: int, n: int) -> np.ndarray | None:
    """Cholesky factors of a constant metric ``(d, d)`` or of one metric per point ``(n, d, d)``.

    Parameters
    ----------
    metric : (d, d) or (n, d, d) float64, or None
    d : int
        The points' dimension.
    n : int
        The number of points (for a metric per point).

    Returns
    -------
    None, (d, d) or (n, d, d) float64
        ``L`` with ``M = L L^T`` (per point for a stack).

    Raises
    ------
    InputError
        ``bad_metric``, located at ``("metric",)`` or ``("metric", p)`` for
        the first point whose metric is not finite, symmetric and positive
        definite.
    """
    if metric is None:
        return None
    try:
        m = np.asarray(metric, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "metric must be a square matrix of numbers", loc=("metric",), code="bad_metric"
        ) from exc
    if m.ndim != 3:
        return _metric(m, d)
    if m.shape != (n, d, d):
        raise InputError(
            f"a metric per point must have shape ({n}, {d}, {d}), got {m.shape}",
            loc=("metric",),
            code="bad_metric",
        )
    finite = np.isfinite(m).all(axis=(1, 2))
    sym = np.isclose(m, np.swapaxes(m, 1, 2), rtol=1e-12, atol=0.0).all(axis=(1, 2))
    bad = ~(finite & sym)
    if not bad.any():
        bad = ~(np.linalg.eigvalsh(m).min(axis=1) > 0)
    if bad.any():
        p = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"the metric of point {p} is not a finite symmetric positive definite matrix",
            loc=("metric", p),
            code="bad_metric",
        )
    return np.linalg.cholesky(m)


def _mapped(P: list[_V], Lrows: np.ndarray) -> list[_V]:
    """Cell vertices mapped row by row by ``x -> L^T x``, ``Lrows`` of shape ``(m, d, d)``."""
    d = Lrows.shape[1]
    out = []
    for v in P:
        out.append(_V(sum(v.c[i] * Lrows[:, i, j] for i in range(d)) for j in range(d)))
    return out


# ----------------------------------------------------------------------------- kernels


class _V:
    """Rows of vectors stored by component: ``d`` contiguous arrays ``(m,)``.

    Component arrays stream through memory much faster than the strided
    columns of an ``(m, d)`` array, which matters at a million cells.
    """

    __slots__ = ("c",)

    def __init__(self, components) -> None:
        self.c = tuple(components)

    def __sub__(self, other: _V) -> _V:
        return _V(a - b for a, b in zip(self.c, other.c, strict=True))

    def __neg__(self) -> _V:
        return _V(-a for a in self.c)

    def scaled(self, s: np.ndarray) -> _V:
        return _V(a * s for a in self.c)

    def __add__(self, other: _V) -> _V:
        return _V(a + b for a, b in zip(self.c, other.c, strict=True))

    def dot(self, other: _V) -> np.ndarray:
        out = self.c[0] * other.c[0]
        for a, b in zip(self.c[1:], other.c[1:], strict=True):
            out += a * b
        return out

    def cross(self, other: _V):
        """The z component (an array) in the plane, the cross product (a ``_V``) in space."""
        a, b = self.c, other.c
        if len(a) == 2:
            return a[0] * b[1] - a[1] * b[0]
        return _V((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))

    def norm(self) -> np.ndarray:
        return np.sqrt(self.dot(self))


def _gather(pts: np.ndarray, cells: np.ndarray) -> list[_V]:
    """The coordinates of each local node of the cells: ``k`` vectors of ``m`` rows."""
    cols = [np.ascontiguousarray(pts[:, i]) for i in range(pts.shape[1])]
    out = []
    for j in range(cells.shape[1]):
        idx = np.ascontiguousarray(cells[:, j])
        out.append(_V(col.take(idx) for col in cols))
    return out


def _ratio(num: np.ndarray, den: np.ndarray, empty: float = 0.0) -> np.ndarray:
    """``num / den`` where ``den > 0``, else ``empty``."""
    out = np.full(np.broadcast(num, den).shape, empty)
    np.divide(num, den, out=out, where=den > 0)
    return out


def _cos(a: _V, b: _V, aa: np.ndarray, bb: np.ndarray) -> np.ndarray:
    """Cosine between rows of ``a`` and ``b`` (squared lengths given); 1 where undefined.

    Not clipped: rounding may put it a hair outside ``[-1, 1]``.
    """
    return _ratio(a.dot(b), np.sqrt(aa * bb), 1.0)


def _acos_deg(cos: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _triangle(P: list[_V]):
    """Area (signed in the plane), shape ratio and the 3 corner cosine arrays of triangles."""
    e0, e1, e2 = P[1] - P[0], P[2] - P[1], P[0] - P[2]
    l0, l1, l2 = e0.dot(e0), e1.dot(e1), e2.dot(e2)
    c = e2.cross(e0)  # = (p1 - p0) x (p2 - p0)
    area = 0.5 * c if isinstance(c, np.ndarray) else 0.5 * c.norm()
    shape = _ratio((4 * _SQRT3) * area, l0 + l1 + l2)
    cos = [_cos(e0, -e2, l0, l2), _cos(e1, -e0, l1, l0), _cos(e2, -e1, l2, l1)]
    return area, shape, cos


def _quad(P: list[_V]):
    """Area and the 4 corner cosine and turn arrays of quads.

    A corner's turn is ``(next - P) x (prev - P)``: in the plane its z
    component, in space its component along the vector area
    ``(p2 - p0) x (p3 - p1)``, so that a convex corner turns positively.
    """
    d1, d2 = P[2] - P[0], P[3] - P[1]
    normal = d1.cross(d2)
    planar = isinstance(normal, np.ndarray)
    area = 0.5 * normal if planar else 0.5 * normal.norm()
    edges = [P[(j + 1) % 4] - P[j] for j in range(4)]
    lengths = [e.dot(e) for e in edges]
    cos, turn = [], []
    for j in range(4):
        a, b = edges[j], -edges[j - 1]
        cos.append(_cos(a, b, lengths[j], lengths[j - 1]))
        turn.append(a.cross(b) if planar else a.cross(b).dot(normal))
    return area, cos, turn


def _quad_q(cos: list[np.ndarray], turn: list[np.ndarray]) -> np.ndarray:
    big = np.abs(cos[0])
    for c in cos[1:]:
        np.maximum(big, np.abs(c), out=big)
    bad = turn[0] <= 0
    for t in turn[1:]:
        bad |= t <= 0
    return _corner_q(big, bad)


def _corner_q(big: np.ndarray, bad: np.ndarray) -> np.ndarray:
    # Q_P = 1 - |1 - 2 theta / pi| for 0 < theta < pi, i.e. 1 - (2/pi) arcsin|cos theta|:
    # the least corner has the largest |cos| (``big``). A corner turning the wrong way
    # (theta >= pi) or not at all (theta = 0 or pi: ``bad``) gives 0.
    q = 1.0 - (2.0 / math.pi) * np.arcsin(np.minimum(big, 1.0, out=big))
    q[bad] = 0.0
    return q


@njit(cache=True)
def _planar_quad_corners(X):
    """:func:`_quad`'s cosines and turns of planar quads ``X`` (k, 4, 2) (corner
    coordinates in order), with the same operations (so the same values), in one loop:
    whether the corners 0 and 2 turn left (exact
    :func:`~meshcore.geometry.predicates.orient2d_filtered`), the largest ``|cos|`` of
    the corners 0 and 2 and of all four (NaN as ``np.maximum`` propagates it) and
    whether a corner's turn is at most 0."""
    k = X.shape[0]
    convex = np.empty(k, np.bool_)
    big2 = np.empty(k)
    big4 = np.empty(k)
    bad = np.empty(k, np.bool_)
    work = np.empty(WORK_SIZE)
    ex = np.empty(4)
    ey = np.empty(4)
    ll = np.empty(4)
    for i in range(k):
        for j in range(4):
            ex[j] = X[i, (j + 1) % 4, 0] - X[i, j, 0]
            ey[j] = X[i, (j + 1) % 4, 1] - X[i, j, 1]
            ll[j] = ex[j] * ex[j] + ey[j] * ey[j]
        b2 = b4 = 0.0
        turned = False
        for j in range(4):
            ax, ay = ex[j], ey[j]
            bx, by = -ex[(j + 3) % 4], -ey[(j + 3) % 4]
            den = np.sqrt(ll[j] * ll[(j + 3) % 4])
            c = abs((ax * bx + ay * by) / den) if den > 0 else 1.0
            if not c <= b4:  # NaN too
                b4 = c
            if j % 2 == 0 and not c <= b2:
                b2 = c
            turned |= ax * by - ay * bx <= 0
        big2[i], big4[i], bad[i] = b2, b4, turned
        convex[i] = True
        for j in (0, 2):
            p, c, n = (j + 3) % 4, j, j + 1
            o = orient2d_filtered(
                X[i, p, 0], X[i, p, 1], X[i, c, 0], X[i, c, 1], X[i, n, 0], X[i, n, 1], work
            )
            convex[i] &= o > 0
    return convex, big2, big4, bad


def planar_quad_measures(points: np.ndarray, cells: np.ndarray):
    """Of planar quads ``cells`` (m, 4) over float64 ``points`` (n, 2), without a metric,
    in one compiled loop: ``(convex, simplified, quality)``, (m,) each: whether the
    corners 0 and 2 turn left (exact orientation), :func:`quad_quality_simplified` (8.7)
    and :func:`quad_quality` (8.4), the same values as those functions (which use it for
    such quads). Unchecked input: for callers that checked it (``combine``'s candidates).

    References
    ----------
    §8.4.4, equations (8.4) and (8.7).
    """
    X = np.ascontiguousarray(points[cells], dtype=np.float64)
    convex, big2, big4, bad = _planar_quad_corners(X)
    return convex, _corner_q(big2, bad), _corner_q(big4, bad)


def _reflex(area: np.ndarray, turn: list[np.ndarray], planar: bool) -> list[np.ndarray]:
    """Corners turning against the quad's own sense (in the plane, the sign of its area)."""
    if planar:
        return [t * area < 0 for t in turn]
    return [t < 0 for t in turn]


def _quad_angles(area, cos, turn, planar: bool) -> np.ndarray:
    ang = _acos_deg(np.stack(cos))
    reflex = np.stack(_reflex(area, turn, planar))
    ang[reflex] = 360.0 - ang[reflex]
    return ang.T


def _tet6(a: _V, b: _V, c: _V, d: _V) -> np.ndarray:
    """Six times the signed volume of tetrahedra ``a b c d``."""
    return (b - a).dot((c - a).cross(d - a))


def _volume(P: list[_V], cell_type: str) -> np.ndarray:
    tets, scale = _TETS[cell_type]
    v = sum(_tet6(P[a], P[b], P[c], P[d]) for a, b, c, d in tets)
    return v * (scale / 6.0)


def _radius_ratio(P: list[_V]) -> np.ndarray:
    a, b, c = P[1] - P[0], P[2] - P[0], P[3] - P[0]
    bc, ca, ab = b.cross(c), c.cross(a), a.cross(b)
    det = a.dot(bc)  # 6 V
    s2 = ab.norm() + bc.norm() + ca.norm() + (b - a).cross(c - a).norm()  # twice the area
    num = bc.scaled(a.dot(a)) + ca.scaled(b.dot(b)) + ab.scaled(c.dot(c))
    # r_in = 3V / S and r_circ = |num| / (12 |V|), so 3 r_in / r_circ = 3 det |det| / (S |num|)
    return _ratio(6.0 * det * np.abs(det), s2 * num.norm())


def _jacobian(P: list[_V], cell_type: str) -> np.ndarray:
    corners, scale = _JACOBIAN_CORNERS[cell_type]
    out = None
    for c, i, j, k in corners:
        e1, e2, e3 = P[i] - P[c], P[j] - P[c], P[k] - P[c]
        norm = np.sqrt(e1.dot(e1) * e2.dot(e2) * e3.dot(e3))
        v = _ratio(e1.dot(e2.cross(e3)), norm)
        out = v if out is None else np.minimum(out, v, out=out)
    return out * scale


def _face_cos(P: list[_V], cell_type: str) -> list[np.ndarray]:
    """Corner cosine arrays of the faces of 3D cells, faces in ``CELL_FACES`` order."""
    rows = []
    for faces in CELL_FACES[cell_type].values():
        k = faces.shape[1]
        for face in faces:
            edges = [P[face[(j + 1) % k]] - P[face[j]] for j in range(k)]
            lengths = [e.dot(e) for e in edges]
            rows.extend(_cos(edges[j], -edges[j - 1], lengths[j], lengths[j - 1]) for j in range(k))
    return rows


def _extreme_angles(cos: list[np.ndarray], reflex: list[np.ndarray] | None = None):
    """Least and largest angle in degrees over corner cosine arrays.

    arccos is decreasing, so this needs only the extreme cosines. A reflex
    corner (``reflex`` true) has the angle ``360 - arccos(cos)``.
    """
    lo, hi, rlo, rhi = 2.0, -2.0, 2.0, -2.0  # cosine extremes: convex, reflex corners

    def low(c: np.ndarray, x: float) -> float:  # fmin/fmax skip NaN (from overflow)
        v = float(np.fmin.reduce(c)) if len(c) else math.nan
        return x if math.isnan(v) else min(x, v)

    def high(c: np.ndarray, x: float) -> float:
        v = float(np.fmax.reduce(c)) if len(c) else math.nan
        return x if math.isnan(v) else max(x, v)

    for j, c in enumerate(cos):
        if reflex is not None and reflex[j].any():
            r = reflex[j]
            lo, hi = low(c[~r], lo), high(c[~r], hi)
            rlo, rhi = low(c[r], rlo), high(c[r], rhi)
        else:
            lo, hi = low(c, lo), high(c, hi)
    if hi < -1.5 and rhi < -1.5:
        return None, None

    def deg(x: float) -> float:
        return math.degrees(math.acos(min(1.0, max(-1.0, x))))

    smallest = deg(hi) if hi >= -1.5 else 360.0 - deg(rlo)
    largest = 360.0 - deg(rhi) if rhi >= -1.5 else deg(lo)
    return smallest, largest


# ----------------------------------------------------------------------------- public measures


@_quiet
def triangle_angles(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Corner angles of triangles.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 3) int

    Returns
    -------
    (m, 3) float64
        The angle at nodes 0, 1, 2 in degrees, in ``[0, 180]`` (unsigned: a
        clockwise triangle has the same angles as its mirror image).
    """
    pts, data = _prepare(points, cells, "triangle", ("triangle",))
    return _acos_deg(np.stack(_triangle(_gather(pts, data))[2])).T


@_quiet
def triangle_shape(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Normalized shape ratio of triangles: ``4 sqrt(3) A / (a² + b² + c²)``.

    ``A`` is the area and ``a, b, c`` the side lengths. The ratio is 1 for
    the equilateral triangle only, ``sqrt(3)/2`` for the right isosceles
    triangle, and tends to 0 as the triangle flattens. We chose it over the
    radius ratio because it needs no square root of the area and degrades
    smoothly; both rank triangles alike near equilateral.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 3) int

    Returns
    -------
    (m,) float64
        In ``[-1, 1]`` for points in the plane (negative for a clockwise
        triangle), in ``[0, 1]`` on a surface; 0 when all three points coincide.
    """
    pts, data = _prepare(points, cells, "triangle", ("triangle",))
    return _triangle(_gather(pts, data))[1]


@_quiet
def quad_quality(points: np.ndarray, cells: np.ndarray, metric: np.ndarray | None = None):
    """Corner quality of quads, (8.3) and (8.4) of §8.4.4, or its metric form (8.6).

    At each corner ``P`` with angle ``theta`` between ``P -> next`` and
    ``P -> prev`` measured in the quad's sense of turning,
    ``Q_P = 2 theta / pi`` below a right angle, ``2 - 2 theta / pi`` from a
    right angle to a straight one, and 0 from ``pi`` on; the quad's quality is
    the least ``Q_P``. It is 1 exactly for rectangles, ``2/3`` for a rhombus
    with 60 and 120 degree corners, and 0 for a non-convex quad.

    With a metric ``M``, angles are measured with ``<u, v>_M = u^T M v``
    (8.5). The text's metric may vary from point to point, (8.6) taking the
    least value over the metrics of the four corners; for the constant metric
    accepted here all four are the same, so (8.6) is (8.4) applied to the
    points mapped by ``x -> L^T x`` where ``M = L L^T`` (Cholesky).

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
        In the plane, a quad is positive when counterclockwise and a clockwise
        quad has quality 0 (every corner turns the wrong way). On a surface
        the sense is that of the quad's vector area, so only non-convex or
        flat quads get 0.
    cells : (m, 4) int
    metric : (d, d) or (n, d, d) float64, optional
        A constant symmetric positive definite metric, ``d`` the points'
        dimension, or one per point: then each quad takes the least of the
        four values measured in the metrics of its corners (the 16 corner
        evaluations of Remark 8.6).

    Returns
    -------
    (m,) float64
        In ``[0, 1]``.

    Raises
    ------
    InputError
        ``bad_metric`` when the metric is not a finite SPD ``(d, d)`` matrix
        (or ``(n, d, d)`` stack, naming the first bad point).

    References
    ----------
    §8.4.4, equations (8.3), (8.4), (8.5), (8.6).
    """
    pts, data = _prepare(points, cells, "quad", ("quad",))
    L = metric_factors(metric, pts.shape[1], len(pts))
    if L is None and pts.shape[1] == 2:
        return planar_quad_measures(pts, data)[2]
    if L is not None and L.ndim == 3:
        P = _gather(pts, data)
        q = None
        for j in range(4):  # (8.6): the least value over the metrics of the corners
            _, cos, turn = _quad(_mapped(P, L[data[:, j]]))
            qj = _quad_q(cos, turn)
            q = qj if q is None else np.minimum(q, qj, out=q)
        return q
    if L is not None:
        pts = pts @ L
    _, cos, turn = _quad(_gather(pts, data))
    return _quad_q(cos, turn)


@_quiet
def quad_quality_simplified(points: np.ndarray, cells: np.ndarray, metric=None) -> np.ndarray:
    """The simplified quad quality (8.7) of §8.4.4, at the ends of the diagonal 0-2.

    For a quad ``ABCD`` made of the triangles ``ABC`` and ``CDA`` (nodes 0
    and 2 the ends of their common edge ``AC``), the least of the corner
    values (8.3) at ``A`` and ``C``, each angle measured in the metrics at
    ``A`` and at ``C``: four values instead of the sixteen of (8.6). The
    corners at ``B`` and ``D`` are triangle corners and do not enter, except
    that a quad with any corner turning the wrong way (or not at all) gets
    0, as in :func:`quad_quality`.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 4) int
        Nodes 0 and 2 the ends of the diagonal the measure is about.
    metric : (d, d) or (n, d, d) float64, optional
        Constant, or one per point (only those of nodes 0 and 2 are used).

    Returns
    -------
    (m,) float64
        In ``[0, 1]``; 1 when the corners at nodes 0 and 2 are right angles.

    References
    ----------
    §8.4.4, equation (8.7).
    """
    pts, data = _prepare(points, cells, "quad", ("quad",))
    L = metric_factors(metric, pts.shape[1], len(pts))
    if L is None and pts.shape[1] == 2:
        return planar_quad_measures(pts, data)[1]
    P = _gather(pts, data)
    if L is None or L.ndim == 2:
        mapped = [P if L is None else _gather(pts @ L, data)]
    else:
        mapped = [_mapped(P, L[data[:, j]]) for j in (0, 2)]
    q = None
    for Pm in mapped:
        _, cos, turn = _quad(Pm)
        qj = _quad_q([cos[0], cos[2]], turn)
        q = qj if q is None else np.minimum(q, qj, out=q)
    return q


#: alpha of (8.8): 1 for the square (S_min = 1/2, h_max = sqrt 2, sides 1).
_SHAPE_ALPHA = 4.0 * math.sqrt(2.0)


@_quiet
def quad_shape(points: np.ndarray, cells: np.ndarray, metric=None) -> np.ndarray:
    """The shape quality (8.8) of Remark 8.7: ``alpha S_min / (h_max sqrt(sum d_i²))``.

    ``S_min`` is the least area of the four triangles ``012, 123, 230, 301``
    of the quad (signed: in the plane by the plane's orientation, on a
    surface along the quad's vector area, so a non-convex or clockwise quad
    scores ``<= 0``), ``h_max`` the longest of the four sides and two
    diagonals, ``d_i`` the four sides (the sum runs over ``i = 1..4`` in
    the text; we read the ``d_i`` as the sides), and ``alpha = 4 sqrt(2)``
    makes the square 1. A rectangle of sides ``1`` and ``r >= 1`` scores
    ``2 sqrt(2) r / (sqrt(1 + r²) sqrt(2 + 2 r²)) = 2 r / (1 + r²)`` (0.8 at
    ``r = 2``), so unlike (8.4) this measure also penalizes stretched quads.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 4) int
    metric : (d, d) float64, optional
        A constant SPD metric: the measure of the points mapped by
        ``x -> L^T x`` (``M = L L^T``). The text defines (8.8) for the
        isotropic case only; a metric per point is refused.

    Returns
    -------
    (m,) float64
        At most 1, 1 exactly for squares; ``<= 0`` when some corner is not convex.

    References
    ----------
    §8.4.4, Remark 8.7, equation (8.8).
    """
    pts, data = _prepare(points, cells, "quad", ("quad",))
    L = metric_factors(metric, pts.shape[1], len(pts))
    if L is not None and L.ndim == 3:
        raise InputError(
            "the shape measure (8.8) takes a constant metric only",
            loc=("metric",),
            code="bad_metric",
        )
    if L is not None:
        pts = pts @ L
    P = _gather(pts, data)
    d1, d2 = P[2] - P[0], P[3] - P[1]
    normal = d1.cross(d2)
    planar = isinstance(normal, np.ndarray)
    nn = None if planar else normal.norm()
    smin = None
    for a, b, c in ((0, 1, 2), (1, 2, 3), (2, 3, 0), (3, 0, 1)):
        t = (P[b] - P[a]).cross(P[c] - P[a])
        s = 0.5 * t if planar else _ratio(0.5 * t.dot(normal), nn)
        smin = s if smin is None else np.minimum(smin, s, out=smin)
    edges = [P[(j + 1) % 4] - P[j] for j in range(4)]
    sides = [e.dot(e) for e in edges]
    hmax2 = np.maximum(d1.dot(d1), d2.dot(d2))
    for s2 in sides:
        np.maximum(hmax2, s2, out=hmax2)
    return _ratio(_SHAPE_ALPHA * smin, np.sqrt(hmax2 * (sides[0] + sides[1] + sides[2] + sides[3])))


@_quiet
def quad_warp(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Warp of quads in space: the larger of the two fold angles, in degrees.

    Split along the diagonal 0-2, a quad is the triangles ``012`` and
    ``023``; the fold angle is the angle between their normals. The warp is
    the larger of that angle and the one of the split along 1-3. It is 0 for
    a planar quad (and for every quad of points in the plane) and grows as
    the quad twists out of a plane (§8.4.5: quads of a surface need not be
    planar).

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 4) int

    Returns
    -------
    (m,) float64
        In ``[0, 180]``; 0 where a split triangle is degenerate.
    """
    pts, data = _prepare(points, cells, "quad", ("quad",))
    if pts.shape[1] == 2:
        return np.zeros(len(data))
    P = _gather(pts, data)
    out = None
    for a, b, c, d in ((0, 1, 2, 3), (1, 2, 3, 0)):
        n1 = (P[b] - P[a]).cross(P[c] - P[a])
        n2 = (P[c] - P[a]).cross(P[d] - P[a])
        n11, n22 = n1.dot(n1), n2.dot(n2)
        ang = _acos_deg(_cos(n1, n2, n11, n22))
        out = ang if out is None else np.maximum(out, ang, out=out)
    return out


@_quiet
def quad_angles(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Interior corner angles of quads in degrees.

    Angles are taken in the quad's own sense of turning (the sign of its area
    in the plane, its vector area in space), so a clockwise square has four
    right angles like a counterclockwise one, and the reflex corner of a
    non-convex quad gets its angle above 180.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 4) int

    Returns
    -------
    (m, 4) float64
        The angle at nodes 0 to 3, in ``[0, 360)``.
    """
    pts, data = _prepare(points, cells, "quad", ("quad",))
    area, cos, turn = _quad(_gather(pts, data))
    return _quad_angles(area, cos, turn, pts.shape[1] == 2)


@_quiet
def tetra_radius_ratio(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Normalized radius ratio of tetrahedra, ``3 r_in / r_circ``.

    ``r_in = 3 V / S`` (``S`` the surface area) and ``r_circ`` the
    circumradius. It is 1 for the regular tetrahedron and tends to 0 for
    slivers, needles and caps alike.

    Parameters
    ----------
    points : (n, 3) float64
    cells : (m, 4) int

    Returns
    -------
    (m,) float64
        In ``[-1, 1]``, with the sign of the volume (negative for an inverted
        tetrahedron); 0 for a flat one.
    """
    pts, data = _prepare(points, cells, "tetra", ("tetra",))
    return _radius_ratio(_gather(pts, data))


@_quiet
def scaled_jacobian(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """Scaled Jacobian: the least normalized corner Jacobian determinant.

    At a corner with edge vectors ``e1, e2, e3`` to three neighbours (in
    the right-handed order of a positive cell), the normalized determinant is
    ``det[e1, e2, e3] / (|e1| |e2| |e3|)``. The scaled Jacobian is its least
    value over the corners, times a factor making the ideal cell 1:

    - hexahedron: the 8 corners, factor 1 (1 for any rectangular box);
    - wedge: the 6 corners (two triangle edges and the lateral edge), factor
      ``2/sqrt(3)`` (1 for a right prism on an equilateral triangle);
    - pyramid: the 4 base corners (two base edges and the edge to the apex),
      factor ``sqrt(2)`` (1 when all eight edges are equal). The apex is not
      a corner of its own, since four edges meet there; it enters through
      the four base corners, which all turn negative when it crosses the
      base plane. A pyramid taller than the equilateral one scores above 1
      (up to ``sqrt(2)``), as in Verdict; reports clip at 1;
    - tetra: the 4 corners, factor ``sqrt(2)`` (1 for the regular tetrahedron;
      up to ``sqrt(2)`` at a right-angled corner).

    Parameters
    ----------
    points : (n, 3) float64
    cells : (m, k) int
    cell_type : {"hexahedron", "wedge", "pyramid", "tetra"}

    Returns
    -------
    (m,) float64
        Negative when some corner is inverted; 0 when a corner has a zero-length edge.
    """
    pts, data = _prepare(points, cells, cell_type, tuple(_JACOBIAN_CORNERS))
    return _jacobian(_gather(pts, data), cell_type)


@_quiet
def signed_area(points: np.ndarray, cells: np.ndarray, cell_type: str = "triangle"):
    """Area of triangles or quads, signed in the plane.

    In the plane this is the shoelace formula, positive counterclockwise; for
    a quad it is ``(p2 - p0) x (p3 - p1) / 2``, the same as the shoelace sum.
    On a surface (points ``(n, 3)``) it is the length of the vector area,
    never negative.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, 3) or (m, 4) int
    cell_type : {"triangle", "quad"}

    Returns
    -------
    (m,) float64
    """
    pts, data = _prepare(points, cells, cell_type, _2D)
    P = _gather(pts, data)
    return _triangle(P)[0] if cell_type == "triangle" else _quad(P)[0]


@_quiet
def signed_volume(points: np.ndarray, cells: np.ndarray, cell_type: str = "tetra"):
    """Signed volume of 3D cells, by a fixed decomposition into tetrahedra.

    tetra: ``det[p1 - p0, p2 - p0, p3 - p0] / 6``; pyramid: the mean of the
    splits along the base diagonals 0-2 and 1-3 (exact for a bilinear base);
    wedge: tetrahedra 0123, 1234, 2345; hexahedron: six tetrahedra around the
    diagonal 0-6 (each face split by a diagonal through 0 or 6). For planar
    faces all of these are exact.

    Parameters
    ----------
    points : (n, 3) float64
    cells : (m, k) int
    cell_type : {"tetra", "pyramid", "wedge", "hexahedron"}

    Returns
    -------
    (m,) float64
        Positive for cells numbered as in :mod:`meshcore.mesh.topology`.
    """
    pts, data = _prepare(points, cells, cell_type, _3D)
    return _volume(_gather(pts, data), cell_type)


@_quiet
def cell_angles(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """Corner angles of cells in degrees.

    Triangles: :func:`triangle_angles`; quads: :func:`quad_angles`; 3D cells:
    the corner angles of their faces (unsigned, in ``[0, 180]``), faces in the
    order of :data:`meshcore.mesh.topology.CELL_FACES` (triangle faces, then quad
    faces), corners in face order. We chose face angles over dihedral angles
    for 3D cells because they are defined alike for every cell type and
    flag the same needles and flattened faces.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, k) int
    cell_type : str
        triangle, quad, tetra, pyramid, wedge or hexahedron.

    Returns
    -------
    (m, c) float64
        ``c`` = 3, 4, 12, 16, 18 or 24.
    """
    pts, data = _prepare(points, cells, cell_type, _2D + _3D)
    P = _gather(pts, data)
    if cell_type == "triangle":
        return _acos_deg(np.stack(_triangle(P)[2])).T
    if cell_type == "quad":
        area, cos, turn = _quad(P)
        return _quad_angles(area, cos, turn, pts.shape[1] == 2)
    return _acos_deg(np.stack(_face_cos(P, cell_type))).T


@_quiet
def cell_quality(points: np.ndarray, cells: np.ndarray, cell_type: str, metric=None):
    """The quality measure of DESIGN.md for one block of cells, unclipped.

    triangle: :func:`triangle_shape`; quad: :func:`quad_quality` (with
    ``metric`` if given); tetra: :func:`tetra_radius_ratio`; pyramid, wedge,
    hexahedron: :func:`scaled_jacobian`.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, k) int
    cell_type : str
    metric : (d, d) float64, optional
        Used for quads only.

    Returns
    -------
    (m,) float64
    """
    pts, data = _prepare(points, cells, cell_type, _2D + _3D)
    return _block_measures(pts, data, cell_type, _metric(metric, pts.shape[1]), angles=False)[0]


def _reported(q: np.ndarray, measure: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(quality clipped into [0, 1] with invalid cells at 0, invalid mask) of one block."""
    bad = ~(measure > 0)  # NaN (overflow) counts as invalid
    q = np.clip(q, 0.0, 1.0, out=q)
    q[bad | np.isnan(q)] = 0.0
    return q, bad


@_quiet
def reported_quality(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """The per-cell values that :func:`report` summarizes for one block of cells.

    :func:`cell_quality` clipped into ``[0, 1]``, with invalid cells (area or
    volume ``<= 0``, see the module docstring) at 0: the values the report's
    min, mean, max and histogram are taken over.

    Parameters
    ----------
    points : (n, 2) or (n, 3) float64
    cells : (m, k) int
    cell_type : str
        A 2D or 3D cell type.

    Returns
    -------
    (m,) float64 in [0, 1]
    """
    pts, data = _prepare(points, cells, cell_type, _2D + _3D)
    q, measure, _ = _block_measures(pts, data, cell_type, None, angles=False)
    return _reported(q, measure)[0]


def _block_measures(pts, data, cell_type, L, angles=True):
    """(quality, area or volume, (min, max) angle in degrees or None) of one cell type."""
    P = _gather(pts, data)
    planar = pts.shape[1] == 2
    amin = amax = None
    if cell_type == "triangle":
        measure, q, cos = _triangle(P)
        if angles:
            amin, amax = _extreme_angles(cos)
    elif cell_type == "quad":
        measure, cos, turn = _quad(P)
        if L is not None:
            _, mcos, mturn = _quad(_gather(pts @ L, data))
            q = _quad_q(mcos, mturn)
        else:
            q = _quad_q(cos, turn)
        if angles:
            amin, amax = _extreme_angles(cos, _reflex(measure, turn, planar))
    else:
        measure = _volume(P, cell_type)
        q = _radius_ratio(P) if cell_type == "tetra" else _jacobian(P, cell_type)
        if angles:
            amin, amax = _extreme_angles(_face_cos(P, cell_type))
    return q, measure, (amin, amax)


# ----------------------------------------------------------------------------- report


def _stats(q: np.ndarray) -> dict:
    if len(q) == 0:
        return {"min": None, "mean": None, "max": None, "histogram": [0] * HISTOGRAM_BINS}
    bins = np.minimum((q * HISTOGRAM_BINS).astype(np.int64), HISTOGRAM_BINS - 1)
    lo, hi = float(q.min()), float(q.max())
    return {
        "min": lo,
        "mean": min(max(float(q.mean()), lo), hi),  # rounding may leave the range by an ulp
        "max": hi,
        "histogram": np.bincount(bins, minlength=HISTOGRAM_BINS).tolist(),
    }


@_quiet
def report(
    mesh: Mesh,
    boundary_segments: np.ndarray | None = None,
    *,
    metric: np.ndarray | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> dict:
    """The quality report of a mesh, in the JSON shape of DESIGN.md.

    For each cell type present (blocks of the same type pooled), in the
    order of :data:`meshcore.mesh.CELL_TYPES`:

    - ``vertex``: ``{"count"}``;
    - ``line``: ``{"count", "length": {"min", "max"}}``;
    - 2D and 3D types: ``{"count", "invalid", "quality": {"min", "mean",
      "max", "histogram"}, "angle": {"min", "max"}}``.

    ``invalid`` counts cells of area or volume ``<= 0`` (see the module
    docstring for signs). ``quality`` summarizes :func:`cell_quality`
    clipped into ``[0, 1]``, with invalid cells counted as 0: min, mean and
    max are of these clipped values, and ``histogram`` counts them in 10
    equal bins over ``[0, 1]`` (the last bin includes 1). Angles, in degrees,
    are those of :func:`cell_angles`. A block without cells gives ``None``
    for min, mean and max.

    ``conformity`` is :func:`meshcore.mesh.topology.conformity`: facets of the
    top-dimension cells shared by more than two cells, and boundary facets
    that are not among ``boundary_segments``.

    Every value is a plain ``int``, ``float``, ``list`` or ``None``, ready for
    ``json.dumps``. The mesh is checked only as far as the measures need
    (finite points, known types, shapes, indices in range): cells that repeat
    a point are reported as invalid rather than refused.

    Parameters
    ----------
    mesh : Mesh
    boundary_segments : (s, 2) int, optional
        The input boundary of a 2D mesh.
    metric : (d, d) float64, optional
        Constant SPD metric for the quad measure (8.6).
    progress : callable(fraction, message), optional
        Called before each cell type, before the conformity count and at the
        end. It may raise (:class:`~meshcore.errors.Cancelled`) to stop.

    Returns
    -------
    dict

    Raises
    ------
    InputError
        For non-finite or badly shaped points, unknown cell types, wrong cell
        shapes, out-of-range indices (``loc`` = ``("cells", b, "data", c, j)``),
        3D cells with 2D points, a bad metric or bad ``boundary_segments``.

    References
    ----------
    §8.4.4 (quad measures), §8.3.1 Definition 8.1 (conformity).
    """
    pts = _points(mesh.points)
    blocks = as_blocks(mesh, len(pts))
    by_type: dict[str, list[np.ndarray]] = {}
    for block in blocks:
        _check_dim(pts, block.type)
        by_type.setdefault(block.type, []).append(block.data)
    L = _metric(metric, pts.shape[1])
    steps = len(by_type) + 1
    out: dict = {}
    for i, cell_type in enumerate(t for t in CELL_TYPES if t in by_type):
        if progress is not None:
            progress(i / steps, f"quality of {cell_type} cells")
        parts = by_type[cell_type]
        data = np.concatenate(parts) if len(parts) > 1 else parts[0]
        entry: dict = {"count": len(data)}
        if cell_type == "line":
            if len(data):
                ends = _gather(pts, data)
                length = (ends[1] - ends[0]).norm()
                entry["length"] = {"min": float(length.min()), "max": float(length.max())}
            else:
                entry["length"] = {"min": None, "max": None}
        elif cell_type != "vertex":
            if len(data):
                q, measure, (amin, amax) = _block_measures(pts, data, cell_type, L)
                q, bad = _reported(q, measure)
                entry["invalid"] = int(np.count_nonzero(bad))
            else:
                q, amin, amax = np.zeros(0), None, None
                entry["invalid"] = 0
            entry["quality"] = _stats(q)
            entry["angle"] = {"min": amin, "max": amax}
        out[cell_type] = entry
    if progress is not None:
        progress((steps - 1) / steps, "conformity")
    out["conformity"] = conformity(Mesh(pts, tuple(blocks)), boundary_segments)
    if progress is not None:
        progress(1.0, "quality report done")
    return out
