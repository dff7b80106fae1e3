r"""A boundary-aligned layer of quads for ``combine``'s all-quad meshes of domains.

The sheared lattice of :mod:`meshcore.quads.combination` meets a curved
boundary at every angle, and the first rows of quads along it carry the
mismatch: on a disk at size 0.05 they averaged 0.75 in quality (8.4)
against 0.98 inside. §8.4.2 leaves the boundary treatment open; the
advancing-front methods of the text (§8.5) start each front with a row of
quads along the boundary. We take up to three such rows and keep the
combination for the rest:

1. every ring is cut into as many pieces as its segments' ``round(length /
   size)`` add up to (at least one each, raised to a multiple of four), spread
   over its segments by arc length (equal pieces on each segment, at least
   one), so every input vertex is a boundary point and the pieces are about
   ``size`` (the extra pieces of a regular polygon, whose segments tie in
   length, went where rounding put them: another mesh under a translation by
   1e6 on the disk, annulus and ellipse of ``benchmarks/quads.py``);
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
  one along the hole 0.906 / 0.947 and 0.890 at 0.1. On a domain with one
  hole the rows may also go across, from the outer ring to the hole, with no
  lattice (:func:`_ruled`): the hole cut into as many pieces as the outer ring,
  each outer point joined to the hole point opposite it (an annulus: the polar
  grid; the lattice between the rows along both circles left nine valence 3-5
  pairs on the annulus at size 0.1). Which is best varies with the domain and the
  size, so ``combine`` (with ``optimize``) makes the meshes of ``ROW_CHOICES``
  (three, two or one row outside with one along the holes, three with two; two
  and two was never the best; across) and keeps the best mean
  (:func:`best_rows`): disk, annulus, ellipse at size 0.1 0.900 / 0.890 / 0.917
  -> 0.908 / 0.947 / 0.929, at 0.05 0.948 / 0.902 / 0.954 -> 0.949 / 0.970 /
  0.960, at 0.025 0.972 / 0.947 / 0.979 -> 0.974 / 0.984 / 0.981 (least 0.64 or
  more, counts 1.00-1.38x; 2.5-4x the CPU time there); issue 20's 40 stars
  unchanged (their boundaries turn too much for these rows).
  The rows keep the boundary's point count, so on a disk they shrink towards the inside: the
  count rises (disk at 0.1: 322, 338, 370 quads for 314 = area / size²);
  rows after the first are kept only while the count stays within
  ``MOST_QUADS`` = 1.4 times area / size².
* **Where.** The rows above on domains whose boundary turns by at most
  ``max_turn`` = 60 degrees at every point after step 1 and that have no
  interior constraints. 30 degrees left the 8-tooth gear of
  ``benchmarks/quads.py`` at size 0.05 to the lattice (least quality 0.38,
  mean 0.83; with the layer 0.57, 0.90); 45, 60 and 75 gave the same meshes
  there. Elsewhere one row with corners (below), unless every input segment is
  parallel to an axis: the lattice's squares then meet the boundary square on
  (L-shape at size 0.1: mean 0.977 with the lattice alone, 0.923 with the row).
* **Corners.** Where the boundary turns by more than ``max_turn`` the row
  changes shape, so that each boundary vertex keeps about one quad per right
  angle (the ideal boundary valence of :mod:`meshcore.quads.optimization`):
  the lattice alone met random star polygons at every angle and left
  straight boundary points held by three quads and corners of 190 degrees
  by four (corners of 34-45 degrees there, least quality 0.36-0.49 after
  ``optimize`` on 18 of 32 stars). A convex corner (turn over 60, angle
  under 120 degrees) is one quad ``(b_{i-1}, b_i, b_{i+1}, o)``, ``o`` the
  fourth corner of the parallelogram, whose angle at ``b_i`` is the input's
  (better than two quads sharing it below 120 degrees); a reflex corner
  (angle over 240) is a fan of ``k = max(1, round((angle - 180) / 90))``
  parallelograms between the two quads along its segments (right angles at
  ``b_i`` there). Segments next to a convex corner get at least two pieces
  (three between two), and pieces are added between corners until the
  points that must stay inner vertices (the parallelograms' far corners)
  fall on even places of the last ring. Where that row fails its guards
  (below) it is tried once more at most ``WIDTH_SHARE`` = 0.45 of the local
  width deep (the distance to the nearest boundary point more than three
  places away along the ring, or on another ring): a spike narrower than two
  rows made the offset ring cross itself. 32 random stars (5-40 vertices,
  jitter 10-80 %, every other one with a hole) at size 0.1: least quality
  away from input corners under 45 degrees under 0.5 on 3 (lattice alone: 18;
  the full-depth row alone: 5), median 0.632 (was 0.494), mean 0.866 (was
  0.838), counts 0.98-1.22x; the width limit alone (no full-depth try) lost
  the row on the 6-tooth gear at size 0.15. The 3 left, and gears of 12 teeth
  at size 0.1, still fail a guard and keep the lattice.
* **Guarded, not trusted.** The offset rings must make a valid domain
  (:func:`~meshcore.domain.planar.parse_domain`: no crossing, no ring
  through another), every layer quad must be strictly convex (exact
  orientation at its four corners:
  :func:`~meshcore.partition.kernel.strictly_convex_rows`) and
  of quality at least ``least_quality`` = 0.3 before the optimization (0.5
  left the gear at size 0.1 to the lattice, least 0.29 and mean 0.73, against
  0.52 and 0.80 with the layer), and the layer and the inner mesh
  must add up to the domain's area; otherwise ``None`` is returned and
  ``combine`` meshes the domain as before. The corner row asks for
  ``CORNER_LEAST_QUALITY`` = 0.2 except at convex corners, whose quad has
  the input's angle (0.3 refused the row on 1 of 32 stars for one quad at
  0.296: its far corners move to the inner mesh's midpoints). Where that
  refuses the row, ``combine`` (with ``optimize``, measure ``angle``) lays it
  once more with strictly convex quads only and keeps the optimized mesh when
  it meets :func:`meets_targets` (the facts the tests assert wherever a row is
  made), else the lattice's: the optimization moves the far corners, which
  the guard judges before it. 32 stars of full radial jitter 10-80 % (5-40
  vertices, every other one with a star-shaped hole, ``size`` 0.1): under the
  targets on 18 before, 12 after; the 7 changed went from least quality
  0.33-0.53 / mean 0.74-0.82 (lattice) to 0.50-0.64 / 0.82-0.85, counts
  1.01-1.43x. A retried row that misses the targets is still kept when the
  lattice's mesh misses them too and the row beats it (:func:`beats_lattice`: a
  higher least quality away from the sharp input corners, with at most
  ``ROW_MOST_QUADS`` = 1.2 times its quads; the lattice is meshed too to compare):
  on issue 20's 40 random stars at size 0.1 (5-60 vertices, jitter 10-80 %, a hole
  on every other one) 9 of the 19 under the targets changed, least 0.155-0.367 ->
  0.278-0.505, worst corners 14-166 -> 25-145 degrees, mean 0.713-0.807 ->
  0.801-0.858, with 1.05-1.16 times the lattice's quads (counts 1.29-1.90x area /
  size², the lattice's 1.15-1.64x). The other 10
  keep the lattice: their offset ring crosses itself even at ``WIDTH_SHARE`` (a
  third try at 0.3 and 0.2 of the width gained 2 of them, not kept).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from meshcore.domain.planar import Domain, parse_domain
from meshcore.errors import MeshcoreError
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.partition.kernel import strictly_convex_rows

__all__ = [
    "CORNER_LEAST_QUALITY",
    "ROW_CHOICES",
    "beats_lattice",
    "best_rows",
    "boundary_layer",
    "least_off_sharp",
    "meets_targets",
    "off_sharp",
    "targets_rank",
]

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
#: The corner row is at most this share of the local width deep (a spike narrower
#: than two rows would make its offset ring cross itself).
WIDTH_SHARE = 0.45
#: The corner row's quads must reach this quality (8.4) before the optimization.
CORNER_LEAST_QUALITY = 0.2
#: A row that misses the targets is kept over the lattice with at most this many
#: times its quads (the row's short pieces at convex corners add some).
ROW_MOST_QUADS = 1.2
#: The rows along the outer rings and along the holes (``rows``, ``hole_rows``) whose
#: optimized meshes :func:`best_rows` compares, the first :func:`boundary_layer`'s
#: defaults.
ROW_CHOICES = ((3, 1), (2, 1), (1, 1), (3, 2), (0, 0))
#: ... when the first has at most this many quads (each choice costs a whole mesh: up to
#: 3 more).
ROWS_MOST_QUADS = 20_000


def _ring_points(dom: Domain, k: int, size: float, total: int | None = None):
    """Ring ``k`` cut into pieces of about ``size`` (a multiple of four of them; or
    ``total`` pieces spread by arc length, at least one per segment), domain on the
    left: point ids (input vertices keep theirs, new points numbered from -1 down) and
    coordinates."""
    ro = dom.ring_offsets
    seg = dom.segments[ro[k] : ro[k + 1]]
    if dom.ring_reversed[k]:
        seg = seg[::-1]
    a, b = dom.points[seg[:, 0]], dom.points[seg[:, 1]]
    length = np.hypot(*(b - a).T)
    if total is None:
        total = int(np.maximum(1, np.rint(length / size)).sum())
        total += -total % 4
    # spread by arc length (rounded: ties alike in any frame), one at least
    x = np.round(total * np.cumsum(length) / length.sum(), 6)
    cnt = np.maximum(np.diff(np.floor(x + 0.5), prepend=0.0).astype(np.int64), 1)
    while cnt.sum() > total:  # a loop over the segments raised to one
        cnt[np.argmax(cnt)] -= 1
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
    corner_least: float = CORNER_LEAST_QUALITY,
    hole_rows: int = 1,
    exact: bool = False,
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
        Rows of quads along the outer rings at most: where that many are not kept,
        one fewer is tried, down to one; then one row with corners (module
        docstring). 0: rows across from the outer ring to the one hole
        (:func:`_ruled`), or None.
    corner_least : float
        The ``least_quality`` of that row's quads away from convex corners.
    hole_rows : int
        Rows along the holes (at most ``rows``).
    exact : bool
        Only ``rows`` and ``hole_rows`` rows: no fewer, no row with corners (else None;
        :func:`best_rows`' other choices).

    Returns
    -------
    (Mesh, (s, 2) int64 boundary edges, inner result, rows) or None
        The quads, the input vertices first (their ids kept), then the added
        boundary points and the points of the rows between, then the inner
        mesh's points; None when no layer is made (module docstring: where,
        guards). Every input segment is a chain of boundary edges; every quad
        is strictly convex (exact); the areas add up to the domain's. ``rows``:
        the rows laid along the outer rings and along the holes, ``(r, h)``, or
        None for the row with corners.

    References
    ----------
    §8.4.2 (twice size), §8.5 (a front starting along the boundary).
    """
    if len(dom.constraints):
        return None
    if rows == 0:
        out = _ruled(dom, size, max_turn, least_quality)
        return None if out is None else (*out, (0, 0))
    for r in range(rows, rows - 1 if exact else 0, -1):  # a loop of at most `rows` tries
        h = min(r, hole_rows)
        out = _layer(dom, size, mesh_inner, max_turn, least_quality, r, h)
        if out is not None:
            return (*out, (r, h))
    if exact:
        return None
    d = dom.points[dom.segments[:, 1]] - dom.points[dom.segments[:, 0]]
    if ((d[:, 0] == 0) | (d[:, 1] == 0)).all():  # the lattice's own directions
        return None
    out = _corner_layer(dom, size, mesh_inner, max_turn, corner_least)
    return None if out is None else (*out, None)


def off_sharp(mesh: Mesh, dom: Domain) -> np.ndarray:
    """(q,) bool: the quads of ``mesh`` with no corner at an input vertex of ``dom``
    whose angle inside is under 45 or over 270 degrees (a quad there is forced to a
    small or a large corner)."""
    P, Q = mesh.points, mesh.cells_by_type["quad"]
    inside = dom.corner_angles()
    sharp = dom.points[(inside < 45) | (inside > 270)]
    if not len(sharp):
        return np.ones(len(Q), bool)
    at = cKDTree(sharp).query(P)[0] == 0  # the input vertex itself, not a point near it
    return ~at[Q].any(axis=1)


def meets_targets(mesh: Mesh, dom: Domain, size: float, ok: np.ndarray | None = None) -> bool:
    """Whether an all-quad mesh of ``dom`` (the input vertices first) has within 1.5
    times area / size² quads and, away from the input's sharp corners (under 45 or
    over 270 degrees inside: a quad there is forced to a small or a large corner;
    ``ok``: the other quads, when the caller has them, as :func:`off_sharp`), every
    corner in [30, 150] degrees and quality (8.4) at least 0.5."""
    P, Q = mesh.points, mesh.cells_by_type["quad"]
    n0 = len(dom.points)
    ratio = len(Q) * size * size / dom.area  # size**2 overflows past 1e154
    if not 1 / 1.5 <= ratio <= 1.5 or not np.array_equal(P[:n0], dom.points):
        return False
    if ok is None:
        ok = off_sharp(mesh, dom)
    if not ok.any():
        return True
    ang = quality.quad_angles(P, Q[ok])
    return bool(
        ang.min() >= 30 and ang.max() <= 150 and quality.quad_quality(P, Q[ok]).min() >= 0.5
    )


def targets_rank(mesh: Mesh, dom: Domain, size: float) -> tuple:
    """How near an all-quad mesh of ``dom`` comes to :func:`meets_targets` at ``size``,
    to compare meshes of one domain that miss them (the larger, the nearer): whether it
    meets them, then how many of the three targets it meets (within 1.5 times area /
    size² quads; away from the sharp input corners, every corner in [30, 150] degrees
    and least quality at least 0.5, which implies the corners), then that least quality
    (:func:`least_off_sharp`), then the mean quality (8.4); qualities rounded to 1e-6 (a
    1e6 translation moves them ~1e-9)."""
    P, Q = mesh.points, mesh.cells_by_type["quad"]
    ok = off_sharp(mesh, dom)
    ratio = len(Q) * size * size / dom.area
    least = least_off_sharp(mesh, dom, ok)
    ang = quality.quad_angles(P, Q[ok]) if ok.any() else np.full(1, 90.0)
    met = (1 / 1.5 <= ratio <= 1.5) + (least >= 0.5) + (ang.min() >= 30 and ang.max() <= 150)
    mean = float(quality.quad_quality(P, Q).mean())
    # meets_targets' own test from the measures above (its input vertices first too)
    meets = bool(met == 3 and np.array_equal(P[: len(dom.points)], dom.points))
    return meets, int(met), round(least, 6), round(mean, 6)


def least_off_sharp(mesh: Mesh, dom: Domain, ok: np.ndarray | None = None) -> float:
    """The least quality (8.4) of the quads of ``mesh`` away from the sharp input
    corners of ``dom`` (as :func:`meets_targets`; 1.0 if none); ``ok``: those quads, when
    the caller has them (:func:`off_sharp`)."""
    if ok is None:
        ok = off_sharp(mesh, dom)
    if not ok.any():
        return 1.0
    return float(quality.quad_quality(mesh.points, mesh.cells_by_type["quad"][ok]).min())


def best_rows(first, again: Callable, dom: Domain, size: float):
    """Of the optimized all-quad meshes of ``dom`` with the rows of ``ROW_CHOICES``
    along its rings, the one that meets :func:`meets_targets`, else any, of the highest
    mean quality (8.4), the first on ties, and whether it meets them. ``first``: the mesh made (its
    ``stats["layer_rows"]``: its rows), returned as it is past ``ROWS_MOST_QUADS``
    quads; ``again(rows, hole_rows)`` makes another with exactly those rows, or
    returns None where they do not fit (so does a
    :class:`~meshcore.errors.MeshcoreError`: left out); hole rows other than one only where ``dom``
    has holes, and no more rows outside than ``first`` has (it fell back from them).

    The rows change where the lattice meets the innermost ring, hence the irregular
    vertices there; which count is best varies with the domain and the size, and the
    mean before the optimization does not tell (disk at size 0.1, one / two / three
    rows: 0.857 / 0.855 / 0.849 before, 0.900 / 0.902 / 0.900 after).
    """

    def key(res):
        P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
        return meets_targets(res.mesh, dom, size), float(quality.quad_quality(P, Q).mean())

    best, best_key, laid = first, key(first), first.stats["layer_rows"]
    if len(first.mesh.cells_by_type["quad"]) > ROWS_MOST_QUADS:
        return first, best_key[0]
    holes = bool(dom.ring_is_hole.any())
    for r, h in ROW_CHOICES:  # a loop of at most len(ROW_CHOICES) meshes
        if (r, h) == laid or r > laid[0] or (h != 1 and not holes):
            continue  # the first fell back from more rows: they do not fit
        try:
            res = again(r, h)
        except MeshcoreError:
            continue
        if res is None:  # these rows do not fit
            continue
        k = key(res)
        if k > best_key:
            best, best_key = res, k
    return best, best_key[0]


def beats_lattice(row: Mesh, lattice: Mesh, lattice_least: float, dom: Domain) -> bool:
    """Whether the optimized mesh with the corner row laid at least quality 0 (``row``)
    is kept over the lattice's (``lattice``, of :func:`least_off_sharp` ``lattice_least``)
    where it misses :func:`meets_targets`: a higher least quality away from the sharp
    input corners, with at most ``ROW_MOST_QUADS`` times the lattice's quads."""
    n_row, n_lat = len(row.cells_by_type["quad"]), len(lattice.cells_by_type["quad"])
    if n_row > ROW_MOST_QUADS * n_lat:
        return False
    return least_off_sharp(row, dom) > lattice_least


def _layer(dom, size, mesh_inner, max_turn, least_quality, rows, hole_rows):
    """:func:`boundary_layer` with exactly ``rows`` rows along the outer rings and
    ``hole_rows`` along the holes, or None."""
    nring = len(dom.ring_offsets) - 1
    parts = []
    for k in range(nring):  # a loop over rings
        ids, X = _ring_points(dom, k, size)
        chain = [X]
        for _ in range(hole_rows if dom.ring_is_hole[k] else rows):
            off = _offsets(chain[-1], max_turn)
            if off is None:
                return None
            chain.append(off)
        n = len(X)
        quads = _band(np.arange(len(chain) * n).reshape(-1, n))
        parts.append((ids, np.concatenate(chain), n, quads, None, n))
    if rows > 1 and _too_many(sum(len(p[3]) for p in parts), dom, size):
        return None  # the rows alone are too many: the inner mesh is not made
    out = _assembled(dom, mesh_inner, parts, least_quality)
    if out is not None and rows > 1 and _too_many(len(out[0].cells[0].data), dom, size):
        return None
    return out


def _ruled(dom, size, max_turn, least_quality):
    """Quads across from the outer ring to the hole of a domain with one hole: the hole
    cut into as many pieces as the outer ring, each hole point joined to the outer point
    opposite it (the cyclic shift of least summed squared distance) and the segments
    between cut into ``K`` equal steps, ``K`` the mean gap over ``size`` rounded, at most
    ``MOST_QUADS`` times area / size² quads in all (an annulus: the polar grid). Returns
    (Mesh, boundary edges, None) as :func:`_assembled`, or None where the domain is not
    one polygon with one hole, a ring turns by more than ``max_turn`` at a point, or a
    quad is not strictly convex (exact) or under ``least_quality``."""
    if not _one_hole(dom):
        return None
    ids_o, Xo = _ring_points(dom, 0, size)
    n = len(Xo)
    if n < dom.ring_offsets[2] - dom.ring_offsets[1] or _offsets(Xo, max_turn) is None:
        return None
    ids_h, Xh = _ring_points(dom, 1, size, n)
    if _offsets(Xh, max_turn) is None:
        return None
    ids_h, Xh = ids_h[::-1], Xh[::-1]  # counter-clockwise, as the outer ring
    gaps = [((Xo - np.roll(Xh, -j, axis=0)) ** 2).sum() for j in range(n)]  # n shifts
    # rounded: a tie (a symmetric domain) goes to the first shift in any frame
    j0 = int(np.argmin(np.round(np.array(gaps) / (n * size * size), 6)))
    ids_h, Xh = np.roll(ids_h, -j0), np.roll(Xh, -j0, axis=0)
    steps = min(
        round(float(np.hypot(*(Xo - Xh).T).mean()) / size),
        int(MOST_QUADS * dom.area / (size * size) / n),
    )
    if steps < 1:
        return None
    t = np.arange(steps + 1)[:, None, None] / steps
    X = (1 - t) * Xo + t * Xh  # (steps + 1, n, 2)
    X[-1] = Xh  # the hole's points exactly
    n0 = len(dom.points)
    gid = np.empty((steps + 1, n), np.int64)
    ids = np.stack([ids_o, ids_h])
    new = ids < 0
    b = ids.copy()
    b[new] = n0 + np.arange(new.sum())
    gid[0], gid[-1] = b
    nb = n0 + int(new.sum())
    gid[1:-1] = nb + np.arange((steps - 1) * n).reshape(steps - 1, n)
    P = np.concatenate([dom.points, Xo[new[0]], Xh[new[1]], X[1:-1].reshape(-1, 2)])
    Q = _band(gid)
    if not strictly_convex_rows(P, Q).all():
        return None
    if quality.quad_quality(P, Q).min() < least_quality:
        return None
    if abs(quality.signed_area(P, Q, "quad").sum() - dom.area) > 1e-9 * dom.area:
        return None
    bedges = np.concatenate(
        [np.column_stack([b[0], np.roll(b[0], -1)]), np.column_stack([b[1], np.roll(b[1], 1)])]
    )
    return Mesh(P, (CellBlock("quad", Q),)), bedges, None


def _one_hole(dom: Domain) -> bool:
    """Whether ``dom`` is one polygon with one hole (the rows across of :func:`_ruled`)."""
    return len(dom.ring_offsets) == 3 and bool(dom.ring_is_hole[1]) and not dom.ring_is_hole[0]


def _band(g: np.ndarray) -> np.ndarray:
    """The quads between consecutive rows of ``g`` ((r + 1, n) point ids, each row a
    closed ring of ``n``): row by row, ``g[i, j], g[i, j + 1], g[i + 1, j + 1], g[i + 1,
    j]``."""
    g1 = np.roll(g, -1, axis=1)
    return np.stack([g[:-1], g1[:-1], g1[1:], g[1:]], axis=-1).reshape(-1, 4)


def _too_many(quads: int, dom: Domain, size: float) -> bool:
    """Whether ``quads`` pass ``MOST_QUADS`` times area / size²."""
    return quads * size * size > MOST_QUADS * dom.area


def _assembled(dom, mesh_inner, parts, least_quality):
    """The layer of each ring and the inner mesh as one mesh, or None (guards).

    ``parts``: per ring ``(ids, Z, nb, local, forced, m)``: the ring's boundary
    points ``Z[:nb]`` (``ids`` as :func:`_ring_points`), then the points of its
    rows, the last ``Z[-m:]`` (``m`` even): its even points bound the inner domain,
    its odd points become the inner mesh's midpoints; ``local`` the layer quads in
    indices of ``Z``; ``forced`` a mask of the quads exempt from ``least_quality``
    (their corner at a sharp input corner; or None)."""
    polys: dict[int, list] = {}
    for k, (_, Z, _, _, _, m) in enumerate(parts):
        ring = Z[len(Z) - m :][0::2]
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
    tree = cKDTree(Pin)
    n0 = len(dom.points)
    nextra = sum(int((p[0] < 0).sum()) for p in parts)
    nmid = sum(len(p[1]) - p[2] - p[5] for p in parts)
    shift = n0 + nextra + nmid
    extra, mids_pts, layers, bedges, forced_all = [], [], [], [], []
    nxt_b, nxt_m = n0, n0 + nextra
    for k, (ids, Z, nb, local, forced, m) in enumerate(parts):
        gid = np.empty(len(Z), np.int64)
        b = ids.copy()
        new = b < 0
        b[new] = nxt_b + np.arange(new.sum())
        nxt_b += int(new.sum())
        extra.append(Z[:nb][new])
        gid[:nb] = b
        nin = len(Z) - nb - m
        gid[nb : nb + nin] = nxt_m + np.arange(nin)
        nxt_m += nin
        mids_pts.append(Z[nb : nb + nin])
        o = np.empty(m, np.int64)
        o[0::2] = inner.ring_offsets[k] + np.arange(m // 2)
        mids = 0.5 * (Pin[o[0::2]] + Pin[np.roll(o[0::2], -1)])
        dist, hit = tree.query(mids)
        if (dist > 0).any():
            return None
        o[1::2] = hit
        gid[len(Z) - m :] = o + shift
        layers.append(gid[local])
        bedges.append(np.column_stack([b, np.roll(b, -1)]))
        forced_all.append(np.zeros(len(local), bool) if forced is None else forced)
    P = np.concatenate([dom.points, *extra, *mids_pts, Pin])
    layer = np.concatenate(layers)
    if not strictly_convex_rows(P, layer).all():
        return None
    free = ~np.concatenate(forced_all)
    if free.any() and quality.quad_quality(P, layer[free]).min() < least_quality:
        return None
    Q = np.concatenate([M.cells_by_type["quad"] + shift, layer])
    area = quality.signed_area(P, Q, "quad").sum()
    if abs(area - dom.area) > 1e-9 * dom.area:
        return None
    return Mesh(P, (CellBlock("quad", Q),)), np.concatenate(bedges), res


def _turns(dom: Domain, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ring ``k``'s segments (domain on the left), their lengths, and the turn (degrees,
    left positive) at each segment's first vertex."""
    ro = dom.ring_offsets
    seg = dom.segments[ro[k] : ro[k + 1]]
    if dom.ring_reversed[k]:
        seg = seg[::-1]
    e = dom.points[seg[:, 1]] - dom.points[seg[:, 0]]
    ep = np.roll(e, 1, axis=0)
    cross = ep[:, 0] * e[:, 1] - ep[:, 1] * e[:, 0]
    turn = np.degrees(np.arctan2(cross, (ep * e).sum(axis=1)))
    return seg, np.hypot(*e.T), turn


def _corner_ring(dom: Domain, k: int, size: float, max_turn: float, share: float):
    """One row of quads along ring ``k`` with corners: ``(ids, Z, nb, local, forced, m)``
    as :func:`_assembled` takes it (module docstring, "Corners"), at most ``share`` of
    the local width deep."""
    seg, length, turn = _turns(dom, k)
    ns = len(seg)
    convex = turn > max_turn
    fans = np.where(turn < -max_turn, np.maximum(1, np.rint(-turn / 90.0)), 0).astype(np.int64)
    # a convex corner takes the points on either side: two corners need a point between
    cnt = np.maximum(np.rint(length / size), 1 + convex + np.roll(convex, -1)).astype(np.int64)
    special = np.flatnonzero(convex | (fans > 0))
    for _ in range(ns + 3):  # each round adds pieces; a parity is fixed for good
        first = np.cumsum(cnt) - cnt  # the point index of each input vertex
        n = int(cnt.sum())
        take = np.ones(n, np.int64)  # offset points each boundary point stands for
        take[(first[convex] - 1) % n] = 0
        take[(first[convex] + 1) % n] = 0
        take[first] += 2 * fans
        ystart = np.cumsum(take) - take
        m = int(take.sum())
        need = ystart[first[special]] + (fans[special] > 0)  # must be even (inner vertices)
        bad = np.flatnonzero((need[1:] - need[:-1]) % 2)
        if len(bad):  # add a piece between the two corners
            lo, hi = special[bad[0]], special[bad[0] + 1]
        elif m % 2:
            lo, hi = (special[-1], special[0] + ns) if len(special) else (0, ns)
        elif m % 4:
            lo, hi = 0, 2 * ns
        else:
            break
        span = np.arange(lo, hi) % ns
        j = span[np.argmax(length[span] / cnt[span])]
        cnt[j] += 1 if (len(bad) or m % 2) else 2
    else:
        return None
    rep = np.repeat(np.arange(ns), cnt)
    t = (np.arange(n) - np.repeat(first, cnt)) / cnt[rep]
    a, b = dom.points[seg[:, 0]], dom.points[seg[:, 1]]
    X = a[rep] + t[:, None] * (b - a)[rep]
    ids = np.where(t == 0, seg[rep, 0], -1)
    e = np.roll(X, -1, axis=0) - X
    le = np.hypot(*e.T)
    nrm = np.column_stack([-e[:, 1], e[:, 0]]) / le[:, None]
    nprev = np.roll(nrm, 1, axis=0)
    mid = nrm + nprev
    mid /= np.hypot(*mid.T)[:, None]
    half = np.maximum((mid * nrm).sum(axis=1), 0.5)
    d = 0.5 * (le + np.roll(le, 1))
    gap = np.full(n, np.inf)
    if np.isfinite(share):
        rings = range(len(dom.ring_offsets) - 1)
        gap = share * _widths(X, [_ring_points(dom, j, size)[1] for j in rings if j != k])
    Y = np.empty((m, 2))
    inner = take == 1
    depth = np.minimum(d / half, gap)
    Y[ystart[inner]] = X[inner] + mid[inner] * depth[inner][:, None]
    quads, forced = [], []
    after = ystart.copy()  # the offset point after each boundary point
    before = ystart.copy()  # and before it
    for v in np.flatnonzero(convex):
        i = first[v]
        o = ystart[i]
        Y[o] = X[i - 1] + X[(i + 1) % n] - X[i]
        before[(i + 1) % n] = after[(i + 1) % n] = o
        before[(i - 1) % n] = after[(i - 1) % n] = o
        quads.append([(i - 1) % n, i, (i + 1) % n, n + o])
        forced.append(True)
    for v in np.flatnonzero(fans):
        i, f = first[v], fans[v]
        ang = np.radians(turn[v]) * np.arange(f + 1) / f
        c, s_ = np.cos(ang), np.sin(ang)
        nx, ny = nprev[i]
        u = np.column_stack([c * nx - s_ * ny, s_ * nx + c * ny])
        r = X[i] + min(d[i], gap[i]) * u
        y0 = ystart[i]
        Y[y0 : y0 + 2 * f + 1 : 2] = r
        Y[y0 + 1 : y0 + 2 * f : 2] = r[:-1] + r[1:] - X[i]
        before[i], after[i] = y0, y0 + 2 * f
        for j in range(f):  # a loop over the fan's quads
            quads.append([i, n + y0 + 2 * j + 2, n + y0 + 2 * j + 1, n + y0 + 2 * j])
            forced.append(False)
    skip = np.zeros(n, bool)  # edges a corner quad covers
    skip[first[convex]] = True
    skip[(first[convex] - 1) % n] = True
    j = np.flatnonzero(~skip)
    edge = np.column_stack([j, (j + 1) % n, n + before[(j + 1) % n], n + after[j]])
    local = np.concatenate([edge, np.array(quads, np.int64).reshape(-1, 4)])
    forced = np.concatenate([np.zeros(len(edge), bool), np.array(forced, bool)])
    par = int(need[0] % 2) if len(special) else 0
    Y = np.roll(Y, -par, axis=0)
    local = np.where(local >= n, n + (local - n - par) % m, local)
    return ids, np.concatenate([X, Y]), n, local, forced, m


def _widths(X: np.ndarray, others: list[np.ndarray], window: int = 3) -> np.ndarray:
    """The distance from each point of the closed loop ``X`` to the nearest point of
    ``others`` or of ``X`` more than ``window`` places away along the loop (inf if
    none among the nearest few): the local width of the domain there."""
    allp = np.concatenate([X, *others]) if others else X
    kq = min(4 * window, len(allp))
    dist, hit = cKDTree(allp).query(X, k=kq)
    n = len(X)
    own = hit < n
    sep = np.abs(hit - np.arange(n)[:, None])
    near = own & (np.minimum(sep, n - sep) <= window)
    dist = np.where(near, np.inf, dist)
    return dist.min(axis=1)


def _corner_layer(dom, size, mesh_inner, max_turn, least_quality):
    """One row of quads along every ring, corners included (module docstring), or None."""
    for share in (np.inf, WIDTH_SHARE):  # a loop of two tries: full depth, then thinner
        rings = range(len(dom.ring_offsets) - 1)
        parts = [_corner_ring(dom, k, size, max_turn, share) for k in rings]
        if any(p is None for p in parts):
            return None
        out = _assembled(dom, mesh_inner, parts, least_quality)
        if out is not None:
            return out
    return None
