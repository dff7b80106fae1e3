"""Big request bodies: GeoJSON coordinates parsed from the JSON bytes straight into numpy.

A 1M-vertex domain is about 40 MB of JSON. Parsed the ordinary way (pydantic
or :mod:`json`), each position becomes a Python list of two Python floats,
about 130 bytes a vertex: four times the body, then copied again into the
validator's arrays. :func:`extract_coordinates` instead finds, in one
compiled pass over the bytes, every ``"coordinates"`` member whose value is
a nested array of ``[x, y]`` pairs (the depth of a Polygon or of a
MultiPolygon), converts each ring to a ``(k, 2)`` float64 array chunk by
chunk (numpy's C parser, correctly rounded as :func:`float` is), and
replaces the value in the body by a short marker string. The rest of the
body is validated by pydantic as before; the domain model swaps the marker
for its arrays (:class:`service.methods.domain_schema.DomainIn`). So the
call holds the body and the arrays (16 bytes a vertex), nothing else big.

Only what the ordinary path would accept identically is taken: well-formed
JSON numbers, no empty array, every innermost array exactly two numbers,
all of them finite. Anything else (a 3D position, a string, an empty ring,
``1e999``) is left in the body for pydantic, so refusals keep their exact
location and message. Bodies under :data:`MIN_BODY` bytes are not scanned.
"""

from __future__ import annotations

import secrets

import numpy as np
from numba import njit

#: Bodies smaller than this are parsed the ordinary way (the scan would not pay).
MIN_BODY = 1 << 16
#: Positions per chunk handed to numpy's text parser (bounds the temporary text).
_CHUNK = 1 << 15
_BRACKETS = bytes.maketrans(b"[]", b"  ")
#: Prefix of the marker strings; with a random part per body, a client cannot forge one.
MARKER = "\x00meshservice-coordinates:"


@njit(cache=True)
def _skip_space(b, i):
    n = len(b)
    while i < n and (b[i] == 32 or b[i] == 9 or b[i] == 10 or b[i] == 13):
        i += 1
    return i


@njit(cache=True)
def _number_end(b, i):
    """End of the JSON number at ``b[i]`` (RFC 8259 grammar), or -1."""
    n = len(b)
    j = i
    if j < n and b[j] == 45:  # -
        j += 1
    if j >= n:
        return -1
    if b[j] == 48:  # a lone leading 0
        j += 1
    elif 49 <= b[j] <= 57:
        while j < n and 48 <= b[j] <= 57:
            j += 1
    else:
        return -1
    if j < n and b[j] == 46:  # .
        j += 1
        k = j
        while j < n and 48 <= b[j] <= 57:
            j += 1
        if j == k:
            return -1
    if j < n and (b[j] == 101 or b[j] == 69):  # e E
        j += 1
        if j < n and (b[j] == 43 or b[j] == 45):
            j += 1
        k = j
        while j < n and 48 <= b[j] <= 57:
            j += 1
        if j == k:
            return -1
    return j


@njit(cache=True)
def _pairs_array(b, i, rings, nrings, cuts, ncuts, chunk):
    """Scan the array at ``b[i] == '['`` as nested arrays of ``[x, y]`` pairs.

    Appends a row ``(start, end, positions, polygon)`` to ``rings`` per ring
    (the array whose items are pairs) and ``(ring, first position, byte)``
    to ``cuts`` every ``chunk`` positions. Returns ``(end, depth, nrings,
    ncuts)``: ``end`` after the closing bracket and ``depth`` the nesting of
    the numbers (3: Polygon, 4: MultiPolygon); ``end`` is -1 when the value
    is not such an array and -2 when a table is full.
    """
    n = len(b)
    count = np.zeros(6, np.int64)  # items of the open array at each depth
    kind = np.zeros(6, np.int64)  # 0 empty so far, 1 numbers, 2 arrays
    start = np.zeros(6, np.int64)
    depth = 0
    leaf = -1
    pos = i
    while True:
        pos = _skip_space(b, pos)
        if pos >= n:
            return -1, 0, nrings, ncuts
        c = b[pos]
        if c == 91:  # [
            if depth > 0:
                if kind[depth] == 1:
                    return -1, 0, nrings, ncuts
                kind[depth] = 2
                count[depth] += 1
                if leaf > 0 and depth == leaf - 1 and (count[depth] - 1) % chunk == 0:
                    if ncuts == len(cuts):
                        return -2, 0, nrings, ncuts
                    cuts[ncuts, 0] = nrings
                    cuts[ncuts, 1] = count[depth] - 1
                    cuts[ncuts, 2] = pos
                    ncuts += 1
            depth += 1
            if depth > 4:
                return -1, 0, nrings, ncuts
            kind[depth] = 0
            count[depth] = 0
            start[depth] = pos
            pos += 1
            continue
        if kind[depth] == 0 and c != 93 and c != 45 and not (48 <= c <= 57):
            return -1, 0, nrings, ncuts
        if c == 93:  # ]
            if kind[depth] == 0:
                return -1, 0, nrings, ncuts  # an empty array: left to the ordinary path
            if kind[depth] == 1 and count[depth] != 2:
                return -1, 0, nrings, ncuts
            if kind[depth] == 2 and depth == leaf - 1:
                if nrings == len(rings):
                    return -2, 0, nrings, ncuts
                rings[nrings, 0] = start[depth]
                rings[nrings, 1] = pos + 1
                rings[nrings, 2] = count[depth]
                rings[nrings, 3] = count[1] - 1 if leaf == 4 else 0
                nrings += 1
            depth -= 1
            pos += 1
            if depth == 0:
                if leaf != 3 and leaf != 4:
                    return -1, 0, nrings, ncuts
                return pos, leaf, nrings, ncuts
        else:
            if kind[depth] == 2:
                return -1, 0, nrings, ncuts
            end = _number_end(b, pos)
            if end < 0:
                return -1, 0, nrings, ncuts
            if leaf < 0:
                leaf = depth
                if leaf < 3:
                    return -1, 0, nrings, ncuts
                # the first position of the first ring opened before ``leaf`` was known
                if ncuts == len(cuts):
                    return -2, 0, nrings, ncuts
                cuts[ncuts, 0] = nrings
                cuts[ncuts, 1] = 0
                cuts[ncuts, 2] = start[depth]
                ncuts += 1
            elif depth != leaf:
                return -1, 0, nrings, ncuts
            kind[depth] = 1
            count[depth] += 1
            pos = end
        pos = _skip_space(b, pos)
        if pos >= n:
            return -1, 0, nrings, ncuts
        if b[pos] == 44:  # ,
            pos += 1
            pos = _skip_space(b, pos)
            if pos < n and b[pos] == 93:
                return -1, 0, nrings, ncuts  # a trailing comma
        elif b[pos] != 93:
            return -1, 0, nrings, ncuts


@njit(cache=True)
def _scan(b, key, rings, cuts, found, chunk):
    """Find every member named ``key`` whose value :func:`_pairs_array` takes.

    ``found`` rows: ``(value start, value end, depth, first ring, ring end,
    first cut, cut end)``. Returns the number of rows, or -2 when a table is
    full (the caller retries with larger ones).
    """
    n = len(b)
    nk = len(key)
    nrings = np.int64(0)  # not a literal 0: _pairs_array would be compiled for it too
    ncuts = np.int64(0)
    nfound = 0
    pos = 0
    while pos < n:
        c = b[pos]
        if c != 34:  # not a string: structure, numbers and literals need no care here
            pos += 1
            continue
        s = pos + 1
        j = s
        while j < n and b[j] != 34:
            j += 2 if b[j] == 92 else 1  # a backslash escapes the next byte
        if j >= n:
            return nfound
        pos = j + 1
        if j - s != nk:
            continue
        same = True
        for t in range(nk):
            if b[s + t] != key[t]:
                same = False
                break
        if not same:
            continue
        k = _skip_space(b, pos)
        if k >= n or b[k] != 58:  # : (a string value equal to the key, not a member name)
            continue
        k = _skip_space(b, k + 1)
        if k >= n or b[k] != 91:
            continue
        r0, c0 = nrings, ncuts
        end, depth, nrings, ncuts = _pairs_array(b, k, rings, nrings, cuts, ncuts, chunk)
        if end == -2 or nfound == len(found):
            return -2
        if end < 0:
            nrings, ncuts = r0, c0
            continue
        found[nfound, 0] = k
        found[nfound, 1] = end
        found[nfound, 2] = depth
        found[nfound, 3] = r0
        found[nfound, 4] = nrings
        found[nfound, 5] = c0
        found[nfound, 6] = ncuts
        nfound += 1
        pos = end
    return nfound


_POW10 = np.array([10.0**k for k in range(23)])


@njit(cache=True)
def _exact_numbers(b, start, end, out):
    """Parse the numbers of ``b[start:end]`` (a scanned ring) into ``out``; False if one is hard.

    Clinger's fast path: a decimal mantissa below 2**53 and a power of ten
    up to 1e22 are both exact doubles, so one product or quotient is the
    correctly rounded value. Longer mantissas and larger exponents are
    hard (the caller parses the ring with numpy's C parser instead).
    """
    k = 0
    i = start
    while i < end:
        c = b[i]
        if not (c == 45 or 48 <= c <= 57):
            i += 1
            continue
        negative = c == 45
        if negative:
            i += 1
        mantissa = 0
        digits = 0
        shift = 0
        while i < end and 48 <= b[i] <= 57:
            if mantissa or b[i] != 48:
                mantissa = mantissa * 10 + (b[i] - 48)
                digits += 1
                if digits > 17:
                    return False
            i += 1
        if i < end and b[i] == 46:
            i += 1
            while i < end and 48 <= b[i] <= 57:
                if mantissa or b[i] != 48:
                    mantissa = mantissa * 10 + (b[i] - 48)
                    digits += 1
                    if digits > 17:
                        return False
                shift -= 1
                i += 1
        if i < end and (b[i] == 101 or b[i] == 69):
            i += 1
            sign = 1
            if b[i] == 43 or b[i] == 45:
                sign = -1 if b[i] == 45 else 1
                i += 1
            e = 0
            while i < end and 48 <= b[i] <= 57:
                if e < 100000:
                    e = e * 10 + (b[i] - 48)
                i += 1
            shift += sign * e
        if mantissa == 0:
            value = 0.0
        elif mantissa > 9007199254740992 or shift > 22 or shift < -22:
            return False
        elif shift >= 0:
            value = float(mantissa) * _POW10[shift]
        else:
            value = float(mantissa) / _POW10[-shift]
        out[k] = -value if negative else value
        k += 1
    return True


def _bytes(raw: bytes | bytearray) -> np.ndarray:
    """The body as a read-only uint8 array, bytes or bytearray alike (numba compiles a
    writable array as another type: one copy of the kernels, not two)."""
    b = np.frombuffer(raw, np.uint8)
    b.setflags(write=False)
    return b


def _ring(raw: bytes, ring: np.ndarray, cuts: np.ndarray) -> np.ndarray | None:
    """The ``(k, 2)`` positions of one scanned ring, or None if one is not finite."""
    start, end, count, _ = (int(x) for x in ring)
    out = np.empty((count, 2))
    if _exact_numbers(_bytes(raw), start, end, out.reshape(-1)):
        out.setflags(write=False)  # parse_domain takes read-only rings without a copy
        return out
    view = memoryview(raw)
    bounds = [*(int(c) for c in cuts[:, 2]), end]
    firsts = [*(int(c) for c in cuts[:, 1]), count]
    for a, b, p, q in zip(bounds[:-1], bounds[1:], firsts[:-1], firsts[1:], strict=True):
        text = bytes(view[a:b]).translate(_BRACKETS).rstrip(b" \t\r\n,")
        values = np.fromstring(text, sep=",")
        if values.size != 2 * (q - p):  # cannot happen for a scanned ring; be safe
            return None
        out[p:q] = values.reshape(-1, 2)
    if not np.isfinite(out).all():  # 1e999: pydantic's message says where
        return None
    out.setflags(write=False)
    return out


def extract_coordinates(raw: bytes | bytearray) -> tuple[bytes | bytearray, dict[str, list]]:
    """The body with big ``"coordinates"`` values replaced by markers, and their arrays.

    Returns
    -------
    body : bytes
        ``raw`` itself when nothing was taken, else a copy in which each
        taken value is the JSON string of its marker.
    arrays : dict
        Marker -> a Polygon's rings (a list of read-only ``(k, 2)`` float64 arrays) or
        a MultiPolygon's polygons (a list of such lists), in input order.
    """
    if len(raw) < MIN_BODY:
        return raw, {}
    b = _bytes(raw)
    key = np.frombuffer(b"coordinates", np.uint8)
    size = 64
    while True:
        rings = np.empty((size, 4), np.int64)
        cuts = np.empty((size, 3), np.int64)
        found = np.empty((size, 7), np.int64)
        nfound = _scan(b, key, rings, cuts, found, _CHUNK)
        if nfound != -2:
            break
        size *= 8
    token = secrets.token_hex(8)
    arrays: dict[str, list] = {}
    pieces = []
    last = 0
    for f, (v0, v1, depth, r0, r1, c0, c1) in enumerate(found[:nfound].tolist()):
        parsed = []
        for r in range(r0, r1):
            mine = cuts[c0:c1][cuts[c0:c1, 0] == r]
            ring = _ring(raw, rings[r], mine)
            if ring is None:
                break
            parsed.append(ring)
        else:
            marker = f"{MARKER}{token}:{f}"
            if depth == 4:
                polygons: list[list[np.ndarray]] = []
                for r, ring in zip(range(r0, r1), parsed, strict=True):
                    if rings[r, 3] == len(polygons):
                        polygons.append([])
                    polygons[-1].append(ring)
                arrays[marker] = polygons
            else:
                arrays[marker] = parsed
            pieces += [raw[last:v0], b'"\\u0000', marker[1:].encode(), b'"']
            last = v1
    if not arrays:
        return raw, {}
    pieces.append(raw[last:])
    return b"".join(pieces), arrays
