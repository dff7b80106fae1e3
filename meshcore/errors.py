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
