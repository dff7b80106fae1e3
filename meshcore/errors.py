"""The one exception hierarchy of meshcore.

Every public function of meshcore raises only subclasses of
:class:`MeshcoreError`, whatever its input. Each carries a machine-readable
``code`` and a human message saying what is wrong and where; input errors
also carry ``errors``, a list of ``{"loc": [...], "msg": ..., "type": code}``
entries in the shape of pydantic's, so that the service can point a client
at the offending field, ring or vertex.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from numbers import Real

import numpy as np


class MeshcoreError(Exception):
    """Base of every error meshcore raises on purpose."""

    code = "meshcore_error"

    def __init__(self, message: str, *, code: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        if code is not None:
            self.code = code


class InputError(MeshcoreError):
    """The input is invalid; ``errors`` locates each fault.

    ``loc`` entries are paths relative to the function's arguments, e.g.
    ``("mesh", "cells", 0, "data", 17, 2)`` for the third index of the 18th
    cell of the first block.
    """

    code = "invalid_input"

    def __init__(
        self,
        message: str,
        *,
        loc: Sequence[str | int] = (),
        code: str | None = None,
        errors: list[dict] | None = None,
    ) -> None:
        super().__init__(message, code=code)
        self.errors = errors or [{"loc": list(loc), "msg": message, "type": self.code}]

    def prefixed(self, *prefix: str | int) -> InputError:
        """The same error with ``prefix`` prepended to every location."""
        errors = [{**e, "loc": [*prefix, *e["loc"]]} for e in self.errors]
        return InputError(self.message, code=self.code, errors=errors)


class AlgorithmError(MeshcoreError):
    """A valid input the algorithm could not handle (no convergence, a limit reached)."""

    code = "algorithm_failed"


class Cancelled(MeshcoreError):
    """Raised by a progress callback to stop the computation."""

    code = "cancelled"


def as_number(value, name: str) -> float:
    """``value`` as a float, or an :class:`InputError` ``bad_parameter`` at ``(name,)``
    where ``float`` refuses it (NaN and infinities pass, an integer beyond float64 is an
    infinity: the callers say how they differ)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf
    except (TypeError, ValueError):
        raise InputError(
            f"{name} must be a number, got {value!r}", loc=(name,), code="bad_parameter"
        ) from None


def positive_parameter(value, name: str, upper: float | None = None) -> float | None:
    """``value`` as a float (None stays None), refused unless a finite number above 0 (and
    at most ``upper``): an :class:`InputError` ``bad_parameter`` at ``(name,)``. The one
    check of the meshers' positive bounds (``size``, ``max_area``, ``max_volume``, ...)."""
    if value is None:
        return None
    x = as_number(value, name)
    if not math.isfinite(x) or x <= 0.0 or (upper is not None and x > upper):
        bound = f" and at most {upper:g}" if upper is not None else ""
        raise InputError(
            f"{name} must be a finite number above 0{bound}, got {value!r}",
            loc=(name,),
            code="bad_parameter",
        )
    return x


def is_number(x) -> bool:
    """Whether ``x`` is a real number: an int or float (Python's or numpy's) or another
    :class:`numbers.Real`, and not a bool (numpy reads a bool as 0 or 1, a numeric string
    as its number; the service's schema refuses both)."""
    return _is_number_type(type(x))


def _is_number_type(kind: type) -> bool:
    return issubclass(kind, Real | np.number) and not issubclass(
        kind, bool | np.bool_ | np.complexfloating
    )


def refuse_non_numbers(
    value, loc: tuple, *, what: str | None = None, code: str = "bad_parameter"
) -> None:
    """An :class:`InputError` ``code`` at ``(*loc, *index)`` of the first entry of
    ``value`` (nested lists or an array) that is not a number (:func:`is_number`), say
    where a list of numbers is converted by numpy, which would take ``[True, 1.5]`` for
    ``[1.0, 1.5]``. A numeric array passes at once; nested lists are scanned entry by entry
    (a malformed nesting, whose entries are lists, is left to the conversion that follows).
    ``what`` names ``value`` in the message (default: ``loc`` joined by dots)."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "iuf":
        return
    try:
        entries = np.asarray(value, dtype=object)
    except (TypeError, ValueError):
        return
    if not any(map(_refused, set(map(type, entries.flat)))):  # the usual case, fast
        return
    i = next(i for i, x in enumerate(entries.flat) if _refused(type(x)))
    where = tuple(int(k) for k in np.unravel_index(i, entries.shape))
    name = what if what is not None else ".".join(map(str, loc))
    raise InputError(
        f"{name} entry {list(where)} is not a number ({entries.flat[i]!r})",
        loc=(*loc, *where),
        code=code,
    )


def _refused(kind: type) -> bool:
    """Entries of this type are refused by :func:`refuse_non_numbers` (a sequence other
    than a string is a malformed nesting, left to the conversion)."""
    nesting = issubclass(kind, Sequence | np.ndarray) and not issubclass(kind, str | bytes)
    return not (nesting or _is_number_type(kind))
