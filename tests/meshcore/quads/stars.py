"""Random star polygons of issue 20 (radial jitter, an optional star-shaped hole): one
generator for the quad tests (``test_curved_domains``, ``test_combination``) and
``benchmarks/quads.py``."""

from __future__ import annotations

import numpy as np


def _closed(xy: np.ndarray) -> list:
    return np.vstack([xy, xy[:1]]).tolist()


def star(rng: np.random.Generator, n: int, jitter: float, hole: bool = False) -> dict:
    """GeoJSON polygon: ``n`` vertices at angles ``2 pi (i + U(-0.3, 0.3)) / n`` and radii
    ``1 + jitter U(-1, 1)``; with ``hole``, a star-shaped hole of ``m`` (5-10, drawn from
    ``rng``) vertices inside the least radius (radii ``0.15 (1 - jitter) (1 + U(-0.5,
    0.5))``). Every random number comes from ``rng``, in this order."""
    t = 2 * np.pi * (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / n
    r = 1 + jitter * rng.uniform(-1, 1, n)
    rings = [_closed(np.column_stack([r * np.cos(t), r * np.sin(t)]))]
    if hole:
        m = int(rng.integers(5, 11))
        th = 2 * np.pi * np.arange(m) / m
        rh = 0.15 * (1 - jitter) * (1 + 0.5 * rng.uniform(-1, 1, m))
        rings.append(_closed(np.column_stack([rh * np.cos(th), rh * np.sin(th)])[::-1]))
    return {"type": "Polygon", "coordinates": rings}


def issue_star(seed: int) -> tuple[dict, int, float]:
    """The issue's random star ``seed`` (5-60 vertices, radial jitter 10-80 %, a hole on
    odd seeds): its GeoJSON polygon, vertex count and jitter."""
    rng = np.random.default_rng(1000 + seed)
    n, jitter = int(rng.integers(5, 61)), float(rng.uniform(0.1, 0.8))
    return star(rng, n, jitter, bool(seed % 2)), n, jitter
