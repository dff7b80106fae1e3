"""Numbers in nested lists, checked before numpy converts them: numpy reads ``True`` as
1 and a numeric string as its number, which the service's schema refuses; the library's
parsers (planar domains, surfaces, point sets, size fields) refuse them the same way.

Kept apart from :mod:`meshcore.errors`, which the command-line client imports without
numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Real

import numpy as np

from meshcore.errors import InputError


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
