r"""A boundary-aligned layer of quads for ``combine``'s all-quad meshes of smooth domains.

The sheared lattice of :mod:`meshcore.quads.combination` meets a curved
boundary at every angle, and the first rows of quads along it carry the
mismatch: on a disk at size 0.05 they averaged 0.75 in quality (8.4)
against 0.98 inside. §8.4.2 leaves the boundary treatment open; the
advancing-front methods of the text (§8.5) start each front with a row of
quads along the boundary. We take up to three such rows and keep the
combination for the rest:

1. every input segment is cut into ``round(length / size)`` equal pieces
   (at least one, a few more so that each ring has a multiple of four), so
   every input vertex is a boundary point and the pieces are about ``size``;
2. each boundary point ``b_i`` gets an offset point ``o_i`` inside, along
   the bisector of the normals of its two pieces, at the local spacing
   (the mean piece length over five points) divided by the cosine of half
   the turn (a parallel offset); each further row offsets the last ring the
   same way;
3. the rings of the even points ``o_0, o_2, ...`` of the last offset bound
   an inner domain, meshed by ``combine`` with ``all_quad``, ``twice_size``,
   ``keep_boundary`` and ``inner``: its boundary segments (about ``2 size``
   long) are split at their midpoints, which become the odd offset points;
4. the layer is the quads ``(b_i, b_{i+1}, o_{i+1}, o_i)`` between each
   ring and the next.

Choices the text leaves open
----------------------------
* **How many rows.** Along the outer rings three where they are kept
  (otherwise two, then one); along the holes one. The combination's
  irregular vertices gather where the lattice meets the innermost ring, so
  a shorter ring leaves fewer of them (disk at size 0.1, mean quality after
  ``optimize``: one row 0.891, two 0.904, three 0.901; README). Along a
  hole the rows spread outwards and meet the outer ones sooner: on the
  annulus (radii 1 and 0.45) three rows along the hole too gave 0.908 /
  0.943 at sizes 0.05 / 0.025 and did not fit at 0.1 (two and two: 0.871),
  one along the hole 0.906 / 0.947 and 0.890 at 0.1. The rows keep the
  boundary's point count, so on a disk they shrink towards the inside: the
  count rises (disk at 0.1: 322, 338, 370 quads for 314 = area / size²);
  rows after the first are kept only while the count stays within
  ``MOST_QUADS`` = 1.4 times area / size².
* **Where.** Only on domains whose boundary turns by at most
  ``max_turn`` = 60 degrees at every point after step 1 and that have no
  interior constraints: a corner's two layer quads share its angle (45
  degrees each at a square's corner, where the lattice alone gives
  rectangles), so domains with corners keep the lattice up to the boundary.
  30 degrees left the 8-tooth gear of ``benchmarks/quads.py`` at size 0.05
  to the lattice (least quality 0.38, mean 0.83; with the layer 0.57,
  0.90); 45, 60 and 75 gave the same meshes there.
* **Guarded, not trusted.** The offset rings must make a valid domain
  (:func:`~meshcore.domain.planar.parse_domain`: no crossing, no ring
  through another), every layer quad must be strictly convex (exact
  :func:`~meshcore.geometry.predicates.orient2d` at its four corners) and
  of quality at least ``least_quality`` = 0.3 before the optimization (0.5
  left the gear at size 0.1 to the lattice, least 0.29 and mean 0.73, against
  0.52 and 0.80 with the layer), and the layer and the inner mesh
  must add up to the domain's area; otherwise ``None`` is returned and
  ``combine`` meshes the domain as before.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import Domain, parse_domain
from meshcore.errors import MeshcoreError
from meshcore.geometry.predicates import orient2d
from meshcore.mesh import CellBlock, Mesh, quality

__all__ = ["boundary_layer"]

#: Each offset is by the local spacing averaged over this many points on either
#: side: the few pieces cut shorter so that a ring's count is a multiple of four
#: otherwise bend each further row more (the third row on the disk at size 0.1
#: turned by more than ``max_turn`` and was refused).
SPACING_WINDOW = 2
#: Rows after the first are kept only when the mesh has at most this many times
#: area / size² quads: the rows keep the boundary's point count, so on a disk
#: they shrink inwards (three rows on the annulus of radii 1 and 0.45 at size
#: 0.15 gave 1.56 times; the count is to stay within 1.5 times).
MOST_QUADS = 1.4


def _ring_points(dom: Domain, k: int, size: float):
    """Ring ``k`` cut into pieces of about ``size``, domain on the left: point ids
    (input vertices keep theirs, new points numbered from -1 down) and coordinates."""
    ro = dom.ring_offsets
    seg = dom.segments[ro[k] : ro[k + 1]]
    if dom.ring_reversed[k]:
        seg = seg[::-1]
    a, b = dom.points[seg[:, 0]], dom.points[seg[:, 1]]
    length = np.hypot(*(b - a).T)
    cnt = np.maximum(1, np.rint(length / size)).astype(np.int64)
    while cnt.sum() % 4:  # a loop of at most three steps
        cnt[np.argmax(length / cnt)] += 1
    rep = np.repeat(np.arange(len(seg)), cnt)
    t = (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)) / cnt[rep]
    X = a[rep] + t[:, None] * (b - a)[rep]
    ids = np.where(t == 0, seg[rep, 0], -1)
    return ids, X


def _offsets(X: np.ndarray, max_turn: float) -> np.ndarray | None:
    """The parallel offset of a closed loop (domain on its left) by its local spacing,
    or None where it turns by more than ``max_turn`` degrees."""
    e = np.roll(X, -1, axis=0) - X
    le = np.hypot(*e.T)
    n = np.column_stack([-e[:, 1], e[:, 0]]) / le[:, None]
    n_prev = np.roll(n, 1, axis=0)
    cos_turn = (n * n_prev).sum(axis=1)
    if (cos_turn < np.cos(np.radians(max_turn))).any():
        return None
    m = n + n_prev
    m /= np.hypot(*m.T)[:, None]
    half = (m * n).sum(axis=1)  # the cosine of half the turn
    d = 0.5 * (le + np.roll(le, 1))
    d = sum(np.roll(d, j) for j in range(-SPACING_WINDOW, SPACING_WINDOW + 1))
    return X + m * (d / (2 * SPACING_WINDOW + 1) / half)[:, None]


def boundary_layer(
    dom: Domain,
    size: float,
    mesh_inner: Callable[[Domain], Mesh],
    max_turn: float = 60.0,
    least_quality: float = 0.3,
    rows: int = 3,
):
    """Rows of quads along the boundary and an inner all-quad mesh (module docstring).

    Parameters
    ----------
    dom : Domain
    size : float
        The quads' side.
    mesh_inner : callable(Domain) -> Mesh
        The all-quad mesh of the inner domain, keeping its boundary segments
        whole at the coarse level and splitting each at its midpoint (as
        ``combine`` with ``all_quad``, ``twice_size`` and ``keep_boundary``).
    max_turn, least_quality : float
        The layer is made only where the boundary turns by at most
        ``max_turn`` degrees at each point, and kept only when each of its
        quads reaches ``least_quality`` (8.4).
    rows : int
        Rows of quads along the outer rings at most (one along the holes): where
        that many are not kept, one fewer is tried, down to one.

    Returns
    -------
    (Mesh, (s, 2) int64 boundary edges, inner result) or None
        The quads, the input vertices first (their ids kept), then the added
        boundary points and the points of the rows between, then the inner
        mesh's points; None when no layer is made (module docstring: where,
        guards). Every input segment is a chain of boundary edges; every quad
        is strictly convex (exact); the areas add up to the domain's.

    References
    ----------
    §8.4.2 (twice size), §8.5 (a front starting along the boundary).
    """
    if len(dom.constraints):
        return None
    for r in range(rows, 0, -1):  # a loop of at most `rows` tries
        out = _layer(dom, size, mesh_inner, max_turn, least_quality, r)
        if out is not None:
            return out
    return None


def _layer(dom, size, mesh_inner, max_turn, least_quality, rows):
    """:func:`boundary_layer` with exactly ``rows`` rows along the outer rings (one
    along the holes), or None."""
    nring = len(dom.ring_offsets) - 1
    loops, offs, between = [], [], []
    for k in range(nring):  # a loop over rings
        ids, X = _ring_points(dom, k, size)
        chain = [X]
        for _ in range(1 if dom.ring_is_hole[k] else rows):
            off = _offsets(chain[-1], max_turn)
            if off is None:
                return None
            chain.append(off)
        loops.append((ids, X))
        offs.append(chain[-1])
        between.append(chain[1:-1])
    polys: dict[int, list] = {}
    for k in range(nring):
        ring = offs[k][0::2]
        polys.setdefault(int(dom.ring_polygon[k]), []).append(np.vstack([ring, ring[:1]]).tolist())
    try:
        inner = parse_domain({"type": "MultiPolygon", "coordinates": list(polys.values())})
    except MeshcoreError:
        return None
    res = mesh_inner(inner)
    M = res.mesh
    Pin = M.points
    n_in = len(inner.points)
    if not np.array_equal(Pin[:n_in], inner.points):
        return None
    # the offset points: even ones are the inner input vertices, odd ones the midpoints
    tree = cKDTree(Pin)
    n0 = len(dom.points)
    extra = [np.zeros((0, 2))]
    bedges = []
    nextra = 0
    base = n0  # ids of added boundary points start here; inner ids are shifted later
    added_ids, off_ids = [], []
    for k in range(nring):
        ids, X = loops[k]
        new = ids < 0
        ids = ids.copy()
        ids[new] = base + nextra + np.arange(new.sum())
        nextra += int(new.sum())
        extra.append(X[new])
        added_ids.append(ids)
        o = np.empty(len(X), np.int64)
        o[0::2] = inner.ring_offsets[k] + np.arange(len(X) // 2)
        mids = 0.5 * (Pin[o[0::2]] + Pin[np.roll(o[0::2], -1)])
        dist, hit = tree.query(mids)
        if (dist > 0).any():
            return None
        o[1::2] = hit
        off_ids.append(o)
    nmid = sum(len(x) for c in between for x in c)
    shift = n0 + nextra + nmid
    P = np.concatenate([dom.points, *extra, *[x for c in between for x in c], Pin])
    out = [M.cells_by_type["quad"] + shift]
    nxt = n0 + nextra
    for b, o, chain in zip(added_ids, off_ids, between, strict=True):
        bedges.append(np.column_stack([b, np.roll(b, -1)]))
        ring_ids = [b]
        for x in chain:
            ring_ids.append(nxt + np.arange(len(x)))
            nxt += len(x)
        ring_ids.append(o + shift)
        for r0, r1 in zip(ring_ids[:-1], ring_ids[1:], strict=True):
            out.append(np.column_stack([r0, np.roll(r0, -1), np.roll(r1, -1), r1]))
    layer = np.concatenate(out[1:])
    corners = [
        orient2d(P[layer[:, i - 1]], P[layer[:, i]], P[layer[:, (i + 1) % 4]]) for i in range(4)
    ]
    if not all((c > 0).all() for c in corners):
        return None
    if quality.quad_quality(P, layer).min() < least_quality:
        return None
    Q = np.concatenate(out)
    if rows > 1 and len(Q) * size**2 > MOST_QUADS * dom.area:
        return None
    area = quality.signed_area(P, Q, "quad").sum()
    if abs(area - dom.area) > 1e-9 * dom.area:
        return None
    return Mesh(P, (CellBlock("quad", Q),)), np.concatenate(bedges), res
