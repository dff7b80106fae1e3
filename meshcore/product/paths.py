"""The generation lines of the product method (§8.1.1, §8.1.2): the sections of a sweep.

A path turns into the positions of every base vertex on every section,
``(layers + 1, n, 3)``: :class:`Translate` (constant or variable steps),
:class:`Rotate`, :class:`Helix` (Figure 8.5 left), :class:`Transforms` (one
affine map per section) or :class:`Sections` (explicit positions). Each
checks its own parameters and names the field at fault.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from meshcore.errors import InputError
from meshcore.geometry.tolerances import MAX_COORDINATE

__all__ = ["Helix", "Path", "Rotate", "Sections", "Transforms", "Translate"]


def _vector(value, loc: tuple, name: str, *, nonzero: bool = False) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be 3 numbers", loc=loc, code="bad_shape") from exc
    if v.shape != (3,):
        raise InputError(
            f"{name} must be 3 numbers, got shape {v.shape}", loc=loc, code="bad_shape"
        )
    if not np.isfinite(v).all():
        raise InputError(f"{name} has a non-finite component", loc=loc, code="non_finite")
    if nonzero and not v.any():
        raise InputError(f"{name} must not be zero", loc=loc, code="zero_vector")
    return v


def _unit(d: np.ndarray) -> np.ndarray:
    """``d`` scaled to length 1, without overflow for huge components."""
    d = d / np.abs(d).max()
    return d / np.linalg.norm(d)


def _finite_sections(X: np.ndarray, loc: tuple) -> np.ndarray:
    """``X``, unless a position is not finite or so large that squared distances overflow."""
    big = ~(np.abs(X) <= MAX_COORDINATE)
    if big.any():
        k, i = np.argwhere(big)[0][:2]
        raise InputError(
            f"vertex {i} on section {k} lies beyond {MAX_COORDINATE:g}: the path or the mesh "
            "is too large for the floating-point range",
            loc=loc,
            code="non_finite",
        )
    return X


def _layers(value, loc: tuple = ("layers",)) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise InputError(
            f"layers must be a positive integer, got {value!r}", loc=loc, code="bad_layers"
        )
    return int(value)


def _angle(value, loc: tuple = ("angle",)) -> float:
    try:
        a = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError("angle must be a number of degrees", loc=loc, code="bad_angle") from exc
    if not math.isfinite(a) or a == 0:
        raise InputError(
            f"angle must be a finite nonzero number of degrees, got {value!r}",
            loc=loc,
            code="bad_angle",
        )
    return a


@dataclass(frozen=True)
class Translate:
    """Translation by ``vector`` in ``layers`` equal steps or in ``steps``.

    ``steps`` are positive relative step sizes (§8.1.2, "a variable stepsize
    from one section to the next"): section ``k`` is the base moved by
    ``vector * sum(steps[:k]) / sum(steps)``, and there are ``len(steps)``
    layers. Give ``layers`` or ``steps``, not both.
    """

    vector: Sequence[float]
    layers: int | None = None
    steps: Sequence[float] | None = None

    def offsets(self) -> np.ndarray:
        """The fraction of ``vector`` reached on each section, ``(layers + 1,)``."""
        if (self.layers is None) == (self.steps is None):
            raise InputError("give either layers or steps", loc=("layers",), code="bad_layers")
        if self.steps is None:
            n = _layers(self.layers)
            return np.arange(n + 1) / n
        try:
            s = np.asarray(self.steps, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError("steps must be numbers", loc=("steps",), code="bad_steps") from exc
        if s.ndim != 1 or len(s) == 0:
            raise InputError("steps must be a non-empty list", loc=("steps",), code="bad_steps")
        bad = ~(np.isfinite(s) & (s > 0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"step {i} must be a positive finite number, got {s[i]}",
                loc=("steps", i),
                code="bad_steps",
            )
        c = np.concatenate([[0.0], np.cumsum(s)]) / s.sum()
        c[-1] = 1.0
        return c

    def _positions(self, pts: np.ndarray) -> np.ndarray:
        v = _vector(self.vector, ("vector",), "vector", nonzero=True)
        c = self.offsets()
        out = np.empty((len(c), *pts.shape))
        for k, ck in enumerate(c):
            np.add(pts, ck * v, out=out[k])
        return out


@dataclass(frozen=True)
class Rotate:
    """Rotation by ``angle`` degrees about an axis, in ``layers`` equal steps.

    Positive angles turn counterclockwise seen from the tip of
    ``axis_direction`` (the right-hand rule). 360° closes the ring.
    """

    axis_point: Sequence[float]
    axis_direction: Sequence[float]
    angle: float
    layers: int

    def _screw(self):
        a = _vector(self.axis_point, ("axis_point",), "axis_point")
        d = _vector(self.axis_direction, ("axis_direction",), "axis_direction", nonzero=True)
        return a, _unit(d), _angle(self.angle), _layers(self.layers), np.zeros(3)

    def _positions(self, pts: np.ndarray) -> np.ndarray:
        return _screw_positions(pts, *self._screw())


@dataclass(frozen=True)
class Helix:
    """Rotation by ``angle`` degrees about an axis together with a translation by ``vector``.

    Section ``k`` is the base turned by ``angle * k / layers`` and moved by
    ``vector * k / layers`` (Figure 8.5, left). A ``vector`` along the axis
    gives a helix of pitch ``|vector| * 360 / |angle|``.
    """

    axis_point: Sequence[float]
    axis_direction: Sequence[float]
    angle: float
    vector: Sequence[float]
    layers: int

    def _screw(self):
        a = _vector(self.axis_point, ("axis_point",), "axis_point")
        d = _vector(self.axis_direction, ("axis_direction",), "axis_direction", nonzero=True)
        w = _vector(self.vector, ("vector",), "vector")
        return a, _unit(d), _angle(self.angle), _layers(self.layers), w

    def _positions(self, pts: np.ndarray) -> np.ndarray:
        return _screw_positions(pts, *self._screw())


@dataclass(frozen=True)
class Transforms:
    """One 4x4 affine matrix per section, ``(layers + 1, 4, 4)``.

    Section ``k`` is ``matrices[k] @ [x, y, z, 1]`` for every base vertex
    (§8.1.2, "a function that associates a vertex position for each section
    with the current vertex position in the initial section"). The first
    matrix need not be the identity. The last row of each must be
    ``[0, 0, 0, 1]``.
    """

    matrices: np.ndarray

    def _matrices(self) -> np.ndarray:
        try:
            m = np.asarray(self.matrices, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(
                "matrices must be 4x4 matrices of numbers", loc=("matrices",), code="bad_shape"
            ) from exc
        if m.ndim != 3 or m.shape[1:] != (4, 4) or len(m) < 2:
            raise InputError(
                f"matrices must be at least two 4x4 matrices, got shape {m.shape}",
                loc=("matrices",),
                code="bad_shape",
            )
        bad = ~np.isfinite(m)
        if bad.any():
            k, i, j = np.argwhere(bad)[0]
            raise InputError(
                f"matrix {k} has a non-finite entry",
                loc=("matrices", int(k), int(i), int(j)),
                code="non_finite",
            )
        last = np.any(m[:, 3] != [0.0, 0.0, 0.0, 1.0], axis=1)
        if last.any():
            k = int(np.flatnonzero(last)[0])
            raise InputError(
                f"matrix {k} is not affine: its last row must be [0, 0, 0, 1]",
                loc=("matrices", k, 3),
                code="not_affine",
            )
        return m

    def _positions(self, pts: np.ndarray) -> np.ndarray:
        m = self._matrices()
        out = np.empty((len(m), *pts.shape))
        for k, mk in enumerate(m):
            np.matmul(pts, mk[:3, :3].T, out=out[k])
            out[k] += mk[:3, 3]
        return out


@dataclass(frozen=True)
class Sections:
    """Explicit positions of every base vertex on every section, ``(layers + 1, n, 3)``.

    ``points[0]`` is the first section; it need not equal the base mesh's own
    points (the base mesh gives the connectivity).
    """

    points: np.ndarray

    def _positions(self, pts: np.ndarray) -> np.ndarray:
        try:
            x = np.asarray(self.points, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(
                "points must be one list of [x, y, z] per section",
                loc=("points",),
                code="bad_shape",
            ) from exc
        if x.ndim != 3 or x.shape[2] != 3 or len(x) < 2:
            raise InputError(
                f"points must be at least two sections of [x, y, z] rows, got shape {x.shape}",
                loc=("points",),
                code="bad_shape",
            )
        if x.shape[1] != len(pts):
            raise InputError(
                f"each section must place the {len(pts)} base vertices, got {x.shape[1]}",
                loc=("points", 0),
                code="bad_shape",
            )
        bad = ~np.isfinite(x)
        if bad.any():
            k, i, j = np.argwhere(bad)[0]
            raise InputError(
                f"section {k}, point {i} has a non-finite coordinate",
                loc=("points", int(k), int(i), int(j)),
                code="non_finite",
            )
        return x


Path = Translate | Rotate | Helix | Transforms | Sections


def _screw_positions(pts, a, d, angle, layers, w) -> np.ndarray:
    """Screw sections: turn ``angle k / layers`` about ``(a, d)``, move by ``w k / layers``.

    Rodrigues' formula, with the three terms computed once and combined per section.
    """
    u = pts - a
    along = np.outer(u @ d, d)
    perp = u - along
    side = np.cross(d, u)
    out = np.empty((layers + 1, *pts.shape))
    for k in range(layers + 1):
        t = math.radians(angle) * k / layers
        c, s = math.cos(t), math.sin(t)
        if k == layers and abs(angle) % 360 == 0:  # a whole number of turns: exactly home
            c, s = 1.0, 0.0
        x = out[k]
        np.multiply(perp, c, out=x)
        x += s * side
        x += along
        x += a + (k / layers) * w
    return out
