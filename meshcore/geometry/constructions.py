"""Inexact geometric constructions: new coordinates computed in float64.

Unlike :mod:`meshcore.geometry.predicates`, these functions round: they build
points (circumcentres) and lengths, never decide a sign. Each is computed
relative to a vertex of its triangle so that the result does not degrade when
the input is translated far from the origin (DESIGN.md, "Geometry
robustness").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.errors import InputError

__all__ = ["circumcenter", "circumradius", "point_segment_distance", "point_segment_distance_2d"]


def _triple(a, b, c) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrays = []
    for name, arg in zip("abc", (a, b, c), strict=True):
        try:
            arr = np.asarray(arg, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"{name} must be an array of 2D points", loc=(name,), code="bad_shape"
            ) from exc
        if arr.ndim == 0 or arr.shape[-1] != 2:
            raise InputError(
                f"{name} must have shape (..., 2), got {arr.shape}", loc=(name,), code="bad_shape"
            )
        arrays.append(arr)
    try:
        return tuple(np.broadcast_arrays(*arrays))
    except ValueError as exc:
        raise InputError(
            "point arrays do not broadcast: " + ", ".join(str(x.shape) for x in arrays),
            loc=(),
            code="bad_shape",
        ) from exc


def _offset(a, b, c) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentre of each triangle relative to its vertex a, and a."""
    a, b, c = _triple(a, b, c)
    bx = b[..., 0] - a[..., 0]
    by = b[..., 1] - a[..., 1]
    cx = c[..., 0] - a[..., 0]
    cy = c[..., 1] - a[..., 1]
    b2 = bx * bx + by * by
    c2 = cx * cx + cy * cy
    den = 2.0 * (bx * cy - by * cx)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (cy * b2 - by * c2) / den
        uy = (bx * c2 - cx * b2) / den
    return np.stack([ux, uy], axis=-1), a


def circumcenter(a, b, c) -> np.ndarray:
    """Centres of the circles through the vertices of triangles.

    Parameters
    ----------
    a, b, c : (n, 2) float64 or (2,) float64
        Triangle vertices (shapes broadcast, any leading shape ``(..., 2)``).

    Returns
    -------
    (n, 2) float64
        Circumcentres. Rows of degenerate (collinear) triangles are infinite
        or NaN; callers decide degeneracy with :func:`~.predicates.orient2d`,
        not from this result.

    Raises
    ------
    InputError
        ``bad_shape`` for arrays that are not ``(..., 2)`` or do not broadcast.

    Notes
    -----
    Computed as ``a + u`` where ``u`` solves the 2x2 system in coordinates
    relative to ``a``; the relative error of ``u`` grows like the inverse of
    the triangle's smallest angle's sine, independently of the distance of
    the triangle from the origin. References: methods text §9.1 (circumcircle
    of a triangle) and §9.4 (medial axis from circumcentres).
    """
    u, a = _offset(a, b, c)
    return a + u


def circumradius(a, b, c) -> np.ndarray:
    """Radii of the circles through the vertices of triangles.

    Parameters
    ----------
    a, b, c : (n, 2) float64 or (2,) float64
        Triangle vertices (shapes broadcast).

    Returns
    -------
    (n,) float64
        Circumradii (infinite or NaN for collinear vertices).

    Raises
    ------
    InputError
        ``bad_shape`` as :func:`circumcenter`.

    Notes
    -----
    The norm of the offset from vertex a to the circumcentre, so it is as
    accurate as that offset. References: methods text §9.4.
    """
    u, _ = _offset(a, b, c)
    return np.hypot(u[..., 0], u[..., 1])


def point_segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Distance from each point ``q`` (n, 2) or (n, 3) to the segment ``(a[i], b[i])`` (rows), and
    the parameter of the segment's nearest point (0 at ``a``, 1 at ``b``; 0 on a segment of
    length 0).

    Returns
    -------
    (n,) float64, (n,) float64
        Distances, parameters. Rounded as the foot ``a + t (b - a)`` is.
    """
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", q - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    off = a + t[:, None] * d - q
    return (np.hypot(*off.T) if off.shape[1] == 2 else np.linalg.norm(off, axis=1)), t


@njit(cache=True, inline="always")
def point_segment_distance_2d(qx, qy, ax, ay, bx, by):
    """Distance from the point ``(qx, qy)`` to the segment ``(ax, ay)-(bx, by)``, for
    compiled loops: the same operations as :func:`point_segment_distance`, so rounded
    as it rounds (the foot ``a + t (b - a)``, ``t`` clipped to [0, 1])."""
    dx = bx - ax
    dy = by - ay
    dd = dx * dx + dy * dy
    t = ((qx - ax) * dx + (qy - ay) * dy) / (dd if dd > 0 else 1.0)
    t = min(max(t, 0.0), 1.0)
    return math.hypot(ax + t * dx - qx, ay + t * dy - qy)


def coons_grid(bottom, right, top, left) -> np.ndarray:
    """The points of a structured grid by transfinite (Coons) interpolation of its sides.

    Parameters
    ----------
    bottom, top : (n1 + 1, 2) float64
        Sides running in ``u``, left to right.
    left, right : (n2 + 1, 2) float64
        Sides running in ``v``, bottom to top; the corners are shared::

            left[-1] = top[0]  ----  top[-1] = right[-1]
               |                        |
            left[0] = bottom[0] ---- bottom[-1] = right[0]

    Returns
    -------
    (n1 + 1, n2 + 1, 2) float64
        ``grid[i, j]`` at ``u = i / n1``, ``v = j / n2``; the boundary rows
        and columns are the given sides exactly, the inside the bilinearly
        blended interpolation of the four sides (it reproduces any affine
        image of a square grid, and may fold where a side turns back).
    """
    n1, n2 = len(bottom) - 1, len(left) - 1
    u = np.linspace(0.0, 1.0, n1 + 1)[:, None, None]
    v = np.linspace(0.0, 1.0, n2 + 1)[None, :, None]
    B, T = bottom[:, None, :], top[:, None, :]
    L, R = left[None, :, :], right[None, :, :]
    grid = (
        (1 - v) * B
        + v * T
        + (1 - u) * L
        + u * R
        - ((1 - u) * (1 - v) * bottom[0] + u * (1 - v) * bottom[-1])
        - ((1 - u) * v * top[0] + u * v * top[-1])
    )
    grid[:, 0], grid[:, -1], grid[0, :], grid[-1, :] = bottom, top, left, right
    return grid
