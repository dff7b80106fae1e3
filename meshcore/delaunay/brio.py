"""BRIO's rounds, shared by the 2D and 3D Delaunay kernels' insertion orders.

A point's round comes from a hash of its index (splitmix64: a reproducible
fair coin sequence): point ``i`` joins the last round with probability 1/2,
the one before with 1/4, ...; the first round gathers the smallest
``2**-rounds`` fraction. N. Amenta, S. Choi and G. Rote, "Incremental
constructions con BRIO" (2003).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

__all__ = ["brio_round", "brio_rounds"]


@njit(cache=True)
def brio_rounds(n):
    """The last round's number for n points: rounds until about 64 points are left."""
    rounds = 0
    m = n
    while m > 64:
        m >>= 1
        rounds += 1
    return rounds


@njit(cache=True)
def brio_round(i, rounds):
    """The round (0 to ``rounds``) of the point with hash index ``i``."""
    # splitmix64 of the index: a reproducible fair coin sequence.
    z = np.uint64(i) + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    # The number of trailing zero bits (64 for z = 0), at most ``rounds``.
    return rounds - min(np.int64(trailing_zeros(z)), rounds)
