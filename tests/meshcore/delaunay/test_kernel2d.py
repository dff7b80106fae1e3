"""Facts about the Delaunay kernel that a reader can check by hand.

Each triangulation is checked by :func:`assert_delaunay`: triangles are
counter-clockwise by the exact ``orient2d`` (no flat triangle), the
neighbour table is consistent, every interior edge is locally Delaunay by the
exact ``incircle``, the triangles tile the convex hull (area sum, one
triangle per hull edge, every boundary edge a supporting line of the points)
and every point is a vertex.
"""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial import Delaunay as QhullDelaunay

from meshcore.delaunay.kernel2d import (
    IncrementalDelaunay,
    Triangulation,
    _brio_hilbert_keys,
    _incircle_corner,
    _incircle_two_lines,
    _insert_range,
    _insertion_order,
    delaunay,
)
from meshcore.errors import Cancelled, InputError
from meshcore.geometry.ordering import radix_argsort, radix_sort
from meshcore.geometry.predicates import WORK_SIZE, incircle, incircle_exact, orient2d


def edge_set(triangles: np.ndarray) -> set[tuple[int, int]]:
    e = np.sort(np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), 1)
    return set(map(tuple, e.tolist()))


def canonical(triangles: np.ndarray) -> set[tuple[int, ...]]:
    """The triangles as a set of sorted index triples."""
    return set(map(tuple, np.sort(triangles, axis=1).tolist()))


def assert_delaunay(points: np.ndarray, tri: Triangulation) -> None:
    p = np.asarray(points, dtype=float)
    t = tri.triangles
    nb = tri.neighbors
    n, m = len(p), len(t)
    assert t.dtype == np.int64 and nb.dtype == np.int64
    assert t.shape == (m, 3) and nb.shape == (m, 3)
    # Every point is a vertex; every triangle strictly counter-clockwise.
    assert np.array_equal(np.unique(t), np.arange(n))
    assert (orient2d(p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]) == 1).all()
    # Neighbours: symmetric, sharing exactly the edge opposite the vertex.
    rows, cols = np.nonzero(nb >= 0)
    other = nb[rows, cols]
    edge_a = t[rows, (cols + 1) % 3]
    edge_b = t[rows, (cols + 2) % 3]
    back = (nb[other] == rows[:, None]).sum(axis=1)
    assert (back == 1).all()
    j = np.argmax(nb[other] == rows[:, None], axis=1)
    assert np.array_equal(t[other, (j + 1) % 3], edge_b)
    assert np.array_equal(t[other, (j + 2) % 3], edge_a)
    # Locally Delaunay: the far vertex of each neighbour is not inside.
    far = t[other, j]
    assert (incircle(p[t[rows, 0]], p[t[rows, 1]], p[t[rows, 2]], p[far]) <= 0).all()
    # Tiles the convex hull: the area sum is the hull's area (in coordinates
    # relative to a corner, so that a far translation costs no accuracy) ...
    c = p - p.min(axis=0)
    e1 = c[t[:, 1]] - c[t[:, 0]]
    e2 = c[t[:, 2]] - c[t[:, 0]]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    try:
        hull = ConvexHull(c)
    except QhullError:
        hull = None  # Qhull gives up on nearly flat hulls; the exact checks remain
    if hull is not None:
        # Relative 1e-12, plus the rounding of the cross products themselves
        # (it dominates only for slivers, whose area cancels almost entirely).
        rounding = 1e-14 * (np.hypot(*e1.T) * np.hypot(*e2.T)).sum()
        assert abs(area - hull.volume) <= 1e-12 * hull.volume + rounding
    # ... each boundary edge (no neighbour) belongs to one triangle only and
    # leaves every point on its left or on its line (it is a hull edge) ...
    brows, bcols = np.nonzero(nb < 0)
    ba = t[brows, (bcols + 1) % 3]
    bb = t[brows, (bcols + 2) % 3]
    assert len(canonical(np.column_stack([ba, bb, bb]))) == len(ba)
    # No point lies strictly inside a boundary edge either: the collinear
    # points of a hull edge are all vertices of the boundary.
    if len(ba) * n <= 4_000_000:
        pa, pb, q = p[ba][:, None, :], p[bb][:, None, :], p[None, :, :]
        side = orient2d(pa, pb, q)
        assert (side >= 0).all()
        lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)
        between = ((lo <= q) & (q <= hi)).all(axis=2) & ~(q == pa).all(axis=2)
        between &= ~(q == pb).all(axis=2)
        assert not (between & (side == 0)).any()
    # ... and the boundary edges form closed loops (each vertex once in, once out).
    assert np.array_equal(np.sort(ba), np.sort(bb))


def rectangle_boundary(n: int, width: float = 2.0, height: float = 1.0) -> np.ndarray:
    """About n points evenly spaced on a rectangle's boundary, counter-clockwise.

    Top and bottom share their x coordinates exactly, so every four points
    facing each other are co-circular, the worst case for ties.
    """
    nb, nr = max(n // 3, 1), max(n // 6, 1)
    xs = np.linspace(0.0, width, nb + 1)
    ys = np.linspace(0.0, height, nr + 1)
    return np.concatenate(
        [
            np.column_stack([xs[:-1], np.zeros(nb)]),
            np.column_stack([np.full(nr, width), ys[:-1]]),
            np.column_stack([xs[::-1][:-1], np.full(nb, height)]),
            np.column_stack([np.zeros(nr), ys[::-1][:-1]]),
        ]
    )


def square_grid(k: int) -> np.ndarray:
    g = np.arange(k, dtype=float)
    x, y = np.meshgrid(g, g, indexing="ij")
    return np.column_stack([x.ravel(), y.ravel()])


def integer_circle(r2: int) -> np.ndarray:
    """All integer points on the circle x^2 + y^2 = r2 (exactly co-circular)."""
    r = int(np.sqrt(r2))
    pts = [(x, y) for x in range(-r, r + 1) for y in range(-r, r + 1) if x * x + y * y == r2]
    return np.array(pts, dtype=float)


# ---------------------------------------------------------------------------
# General position: exactly scipy's triangles
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 4, 10, 1000, 20000])
def test_random_points_match_qhull(n):
    p = np.random.default_rng(n).random((n, 2))
    tri = delaunay(p)
    if n <= 1000:
        assert_delaunay(p, tri)
    assert canonical(tri.triangles) == canonical(QhullDelaunay(p).simplices)


def test_random_points_big_valid():
    p = np.random.default_rng(11).normal(size=(20000, 2))
    assert_delaunay(p, delaunay(p))


@pytest.mark.parametrize("top", [0, 1, 5, 2047, 2048, 1 << 40, (1 << 62) + 12345])
def test_radix_argsort_is_the_stable_argsort(top):
    # Ties (few distinct keys), keys spanning one to six 11-bit digits, all-equal digits.
    rng = np.random.default_rng(top % 1000)
    for size in (0, 1, 7, 3000):
        keys = rng.integers(0, top + 1, size, dtype=np.int64)
        keys[: size // 2] = keys[size // 2 : 2 * (size // 2)]  # every key at least twice
        assert np.array_equal(radix_argsort(keys), np.argsort(keys, kind="stable"))
        perm = np.argsort(keys, kind="stable")
        values = rng.integers(-5, 5, size, dtype=np.int64)
        keys_in, values_in = keys.copy(), values.copy()
        sorted_keys, moved = radix_sort(keys, values)
        assert np.array_equal(sorted_keys, keys[perm]) and np.array_equal(moved, values[perm])
        # The first pass reads the inputs in place: they must come back untouched.
        assert np.array_equal(keys, keys_in) and np.array_equal(values, values_in)


def test_radix_sort_refuses_a_negative_key():
    with pytest.raises(ValueError, match="non-negative"):
        radix_argsort(np.array([3, -1, 2], dtype=np.int64))


def test_two_lines_incircle_is_the_exact_sign():
    # Two points on each of two horizontal (or vertical) lines, in every order: symmetric
    # trapezoids (exact ties on linspace samples), rectangles and random ones.
    rng = np.random.default_rng(2)
    g = np.linspace(0.0, 2.0, 1001) * 0.25
    work = np.empty(WORK_SIZE)
    ties = 0
    for trial in range(300):
        if trial % 3 == 0:
            i = rng.integers(1, 990)
            xs, y0, y1 = g[[i, i + 2, i + 1, i + rng.integers(1, 4)]], 0.0, 0.25
        elif trial % 3 == 1:
            c, a, b = rng.uniform(-1, 1, 3)
            xs, (y0, y1) = np.array([c - a, c + a, c - b, c + b]), rng.uniform(-1, 1, 2)
        else:
            xs, (y0, y1) = rng.uniform(-1, 1, 4), rng.uniform(-1, 1, 2)
        pts = [(xs[0], y0), (xs[1], y0), (xs[2], y1), (xs[3], y1)]
        if len(set(pts)) < 4 or y0 == y1:
            continue
        for perm in itertools.permutations(pts):
            q = [c for pt in perm for c in pt]
            exact = incircle_exact(*q, work)
            assert _incircle_two_lines(*q) == exact
            ties += exact == 0
            # the mirror image in y = x (two vertical lines), which the kernel
            # settles as minus the sign of this one
            mirror = [q[k ^ 1] for k in range(8)]
            assert incircle_exact(*mirror, work) == -exact
    assert ties > 100
    assert _incircle_two_lines(*rng.uniform(-1, 1, 8)) == 2  # not two lines: not settled


def test_corner_incircle_is_the_exact_sign():
    # Two points on one axis-parallel line and two on the perpendicular one, in
    # every order: samples of a rectangle's sides near a corner (exact ties
    # where the offsets' products match: the corner's bisector), corners away
    # from the origin (inexact offsets are left unsettled), random ones.
    rng = np.random.default_rng(3)
    g = np.linspace(0.0, 1.0, 1001) * 0.25
    work = np.empty(WORK_SIZE)
    ties = settled = 0
    for trial in range(240):
        if trial % 4 < 2:
            i, j = rng.integers(0, 40, 2)
            k, m = rng.integers(0, 3, 2)
            h, v = g[[i, i + 1 + k]], g[[j, j + 1 + m]]
            if trial % 4 == 0:
                v = h  # on the bisector: co-circular
            if trial % 8 == 1:
                h, v = h[::-1], v[::-1]  # offsets in both directions
        else:
            h, v = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        X, Y = (0.0, 0.0) if trial % 3 else tuple(rng.choice([0.5, 0.25, -0.125], 2))
        sides = rng.choice([-1.0, 1.0], 2)
        pts = [(X + sides[0] * h[0], Y), (X + sides[0] * h[1], Y)]
        pts += [(X, Y + sides[1] * v[0]), (X, Y + sides[1] * v[1])]
        if len(set(pts)) < 4:
            continue
        for perm in itertools.permutations(pts):
            if len({x for x, _ in perm[:3]}) == 1 or len({y for _, y in perm[:3]}) == 1:
                continue  # a, b, c on one line: never a triangle of the kernel
            q = [c for pt in perm for c in pt]
            s = _incircle_corner(*q)
            exact = incircle_exact(*q, work)
            if s != 2:
                assert s == exact
                settled += 1
                ties += exact == 0
    assert ties > 300 and settled > 3000, (ties, settled)
    assert _incircle_corner(*rng.uniform(-1, 1, 8)) == 2  # not a corner: not settled


@pytest.mark.parametrize("width, height", [(2.0, 1.0), (1.0, 2.0)])
def test_sampled_rectangle_is_delaunay(width, height):
    # A rectangle's sides sampled from each corner in travel order (as the
    # medial axis samples them: the top's x are not the bottom's), wide and
    # tall: the corners' bisectors and the long sides are the fast paths.
    n = 200
    t = np.arange(n) / n
    corners = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    ends = np.roll(corners, -1, axis=0)
    p = np.concatenate([a + t[:, None] * (b - a) for a, b in zip(corners, ends, strict=True)])
    tri = delaunay(p)
    assert_delaunay(p, tri)
    assert len(tri.triangles) == len(p) - 2


@pytest.mark.parametrize("spread", [1.0, 1e-12])
def test_insertion_order_is_the_stable_sort_of_round_and_curve(spread):
    # With spread 1e-12 most of the 3,000 points share their Hilbert cell with
    # others: the ties keep index order (insertion) and insertion order (hints).
    rng = np.random.default_rng(5)
    p = np.concatenate([rng.random((40, 2)), 0.5 + spread * rng.random((3000, 2))])
    nbits = 14
    p.flags.writeable = False  # as delaunay passes it (one compiled signature)
    rnd, curve, nrounds = _brio_hilbert_keys(p, 1.0, nbits)
    assert rnd.min() >= 0 and rnd.max() < nrounds
    order, along, curve_sorted = _insertion_order(rnd, curve, nrounds)
    forward = np.where(rnd % 2 == 1, (1 << (2 * nbits)) - 1 - curve, curve)
    assert np.array_equal(order, np.argsort((rnd << (2 * nbits)) | forward, kind="stable"))
    assert np.array_equal(along, np.argsort(curve[order], kind="stable"))
    assert np.array_equal(curve_sorted, np.sort(curve))


def test_three_points_one_triangle_with_no_neighbours():
    #   2
    #   | \
    #   0--1   given clockwise: returned counter-clockwise
    tri = delaunay([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    assert canonical(tri.triangles) == {(0, 1, 2)}
    assert (tri.neighbors == -1).all()
    assert orient2d(*tri.points[tri.triangles[0]]) == 1


# ---------------------------------------------------------------------------
# Degenerate input: ties, collinear runs
# ---------------------------------------------------------------------------


def test_square_grid_is_delaunay_and_deterministic():
    # A 12 x 12 grid: every unit square is four co-circular points.
    p = square_grid(12)
    tri = delaunay(p)
    assert_delaunay(p, tri)
    assert len(tri.triangles) == 2 * 11 * 11
    again = delaunay(p)
    assert np.array_equal(tri.triangles, again.triangles)
    assert np.array_equal(tri.neighbors, again.neighbors)


def test_tie_breaking_does_not_depend_on_input_order():
    # We promise: the triangle set is a function of the point set.
    p = np.concatenate([square_grid(9), integer_circle(25) + 20.0])
    base = canonical(delaunay(p).triangles)
    rng = np.random.default_rng(5)
    for _ in range(3):
        perm = rng.permutation(len(p))
        tri = delaunay(p[perm])
        assert canonical(perm[tri.triangles]) == base


def test_points_on_a_circle():
    # 4 * 9 * ... integer points on x^2 + y^2 = 5^2 13^2 17^2, all co-circular.
    p = integer_circle(5**2 * 13**2 * 17**2)
    assert len(p) > 50
    tri = delaunay(p)
    assert_delaunay(p, tri)
    assert len(tri.triangles) == len(p) - 2  # a triangulated convex polygon
    # With the centre added every triangle is a fan triangle at the centre.
    q = np.vstack([p, [0.0, 0.0]])
    tri = delaunay(q)
    assert_delaunay(q, tri)
    assert (tri.triangles == len(p)).any(axis=1).all()


def test_rectangle_boundary_has_no_flat_triangle():
    # 100 points per long side, 50 per short side, all on the hull.
    p = rectangle_boundary(600)
    tri = delaunay(p)
    assert_delaunay(p, tri)
    # Every point is on the hull, so: n - 2 triangles, n boundary edges.
    assert len(tri.triangles) == len(p) - 2
    assert (tri.neighbors < 0).sum() == len(p)


def test_collinear_points_inside_and_on_hull():
    # A triangle whose edges and medians carry many collinear points.
    t = np.linspace(0.0, 1.0, 33)[1:-1, None]
    a, b, c = np.array([0.0, 0.0]), np.array([64.0, 0.0]), np.array([0.0, 64.0])
    m = (a + b + c) / 3
    p = np.vstack([a, b, c, a + t * (b - a), b + t * (c - b), c + t * (a - c), a + t * (m - a)])
    tri = delaunay(p)
    assert_delaunay(p, tri)


def test_collinear_start_then_off_line_points():
    # The first points in any order are collinear; the last one is not.
    p = np.column_stack([np.arange(50.0), np.zeros(50)])
    p = np.vstack([p, [[10.0, 3.0]]])
    tri = delaunay(p)
    assert_delaunay(p, tri)
    assert len(tri.triangles) == 49


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=3, max_size=60, unique=True
    ),
    st.randoms(use_true_random=False),
)
def test_lattice_points_property(raw, rnd):
    p = np.array(raw, dtype=float) / 3.0 + 1e6 / 3.0
    if (orient2d(p[0], p[1], p) == 0).all():
        with pytest.raises(InputError) as info:
            delaunay(p)
        assert info.value.code == "collinear_points"
        return
    tri = delaunay(p)
    assert_delaunay(p, tri)
    perm = np.array(rnd.sample(range(len(p)), len(p)))
    assert canonical(perm[delaunay(p[perm]).triangles]) == canonical(tri.triangles)


# ---------------------------------------------------------------------------
# Invariance under exact translation and scaling
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        lambda: np.random.default_rng(1).integers(0, 2**16, (3000, 2)) * 2.0**-10,
        lambda: square_grid(15) * 0.25,
        lambda: np.round(rectangle_boundary(300) * 2**10) / 2**10,
    ],
    ids=["random-dyadic", "grid", "rectangle-boundary"],
)
def test_translation_and_scaling_change_nothing(make):
    p = np.unique(make(), axis=0)
    base = delaunay(p)
    for moved in (p + 1e6, p * 2.0**-20, (p + 1e6) * 2.0**-20, p * 2.0**20 - 1e6):
        tri = delaunay(moved)
        assert np.array_equal(tri.triangles, base.triangles)
        assert np.array_equal(tri.neighbors, base.neighbors)


def test_scaling_by_1e6_on_general_position_points():
    # 1e-6 is not a power of two, so the scaled coordinates round; points in
    # general position keep their triangulation all the same.
    p = np.random.default_rng(2).integers(0, 2**20, (5000, 2)) * 2.0**-20
    base = canonical(delaunay(p).triangles)
    assert canonical(delaunay(p * 1e-6).triangles) == base
    assert canonical(delaunay(p * 1e6 + 1e6).triangles) == base


# ---------------------------------------------------------------------------
# Bad input and the callback
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "code"),
    [
        ([[0.0, 0.0], [1.0, 0.0]], "too_few_points"),
        ([[0.0, 0.0], [1.0, 0.0], [0.0, np.nan]], "non_finite"),
        ([[0.0, 0.0], [1.0, 0.0], [np.inf, 1.0]], "non_finite"),
        ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], "bad_shape"),
        ([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [-4.0, -4.0]], "collinear_points"),
        ([[0.0, 0.0], [1.0, 0.0], [0.0, 1e-300]], "coordinates_out_of_range"),
        ("not points", "bad_shape"),
        ([[0.0, 0.0], [1.0, True], [0.0, 1.0]], "bad_shape"),  # numpy reads True as 1.0
        ([["0", "0"], ["1", "0"], ["0", "1"]], "bad_shape"),  # and "1" as 1.0
        (np.array([[0, 0], [1, 0], [0, 1]], dtype=bool), "bad_shape"),
    ],
)
def test_bad_input_raises_input_error(points, code):
    with pytest.raises(InputError) as info:
        delaunay(points)
    assert info.value.code == code


@pytest.mark.parametrize("where", [1, 2, 500])
def test_duplicate_points_are_named(where):
    p = np.random.default_rng(0).random((1000, 2))
    p[where] = p[7]
    with pytest.raises(InputError) as info:
        delaunay(p)
    err = info.value
    assert err.code == "duplicate_points"
    lo, hi = sorted((7, where))
    assert f"points {lo} and {hi}" in err.message
    assert err.errors[0]["loc"] == ["points", hi]


def test_duplicates_of_collinear_points_are_reported_as_duplicates():
    with pytest.raises(InputError) as info:
        delaunay([[0.0, 0.0], [1.0, 1.0], [1.0, 1.0], [2.0, 2.0]])
    assert info.value.code == "duplicate_points"


def test_progress_is_reported_and_can_cancel():
    p = np.random.default_rng(0).random((200_000, 2))
    seen = []
    delaunay(p, progress=lambda f, msg: seen.append(f))
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)

    def stop(fraction, message):
        raise Cancelled("stop")

    with pytest.raises(Cancelled):
        delaunay(p, progress=stop)


def test_result_is_read_only_and_input_untouched():
    p = np.random.default_rng(0).random((50, 2))
    before = p.copy()
    tri = delaunay(p)
    assert np.array_equal(p, before)
    with pytest.raises(ValueError):
        tri.triangles[0, 0] = 1


# ---------------------------------------------------------------------------
# Incremental insertion (the rounds of delaunay_admissible)
# ---------------------------------------------------------------------------


def test_incremental_insertion_gives_the_triangles_of_the_whole_set():
    # A 6 x 6 grid (co-circular everywhere: the ties decide) and random
    # points, then three batches inside the hull, some on grid lines and
    # circles: after each batch, the triangles are those delaunay() makes of
    # all points so far.
    rng = np.random.default_rng(7)
    first = np.vstack([square_grid(6), rng.random((40, 2)) * 5])
    inc = IncrementalDelaunay(first)
    points = first
    for batch in (rng.random((30, 2)) * 5, rng.integers(0, 11, (20, 2)) / 2, [[2.5, 2.5]]):
        batch = np.asarray(batch, dtype=float)
        batch = batch[~(batch[:, None, :] == points[None, :, :]).all(axis=2).any(axis=1)]
        batch = np.unique(batch, axis=0)
        near = np.zeros(len(batch), dtype=np.int64)
        assert inc.insert(batch, near) is None
        points = np.vstack([points, batch])
        tri = inc.triangulation(points)
        assert_delaunay(points, tri)
        assert canonical(tri.triangles) == canonical(delaunay(points).triangles)
    # A point inserted on an existing one is named, not inserted.
    assert inc.insert(np.array([points[3]]), np.array([0])) == (len(points), 3)


def test_the_insertion_log_names_the_edges_it_removed():
    # The log the admissible splitting loop reads (one point per call, as
    # that loop inserts): the edges a point's insertion removed, as slot
    # pairs (-1 the vertex at infinity), are those of the triangulation
    # without it that are gone.
    rng = np.random.default_rng(11)
    points = np.vstack([square_grid(6), rng.random((40, 2)) * 5])
    inc = IncrementalDelaunay(points)
    total = 0
    for xy in np.vstack([rng.random((25, 2)) * 5, [[2.5, 2.5], [1.0, 1.5], [4.5, 0.0]]]):
        n = len(inc)
        pts, V, A, stack, vt, hint, state, work, order, slot, log = inc.insertion_arrays(1)
        pts[n] = xy * inc.scale
        order[n] = slot[n] = n
        hint[n] = slot[0]
        nlog = _insert_range(pts, V, A, stack, vt, hint, state, work, n, n + 1, log)
        inc.grown_to(n + 1)
        before = edge_set(delaunay(points).triangles)
        points = np.vstack([points, xy])
        tri = inc.triangulation(points)
        assert canonical(tri.triangles) == canonical(delaunay(points).triangles)
        pairs = log[: 2 * nlog].reshape(-1, 2)
        pairs = pairs[(pairs >= 0).all(axis=1)]
        removed = {tuple(sorted(e)) for e in order[pairs].tolist()}
        assert removed == before - edge_set(tri.triangles)
        total += len(removed)
    assert total > 28  # the insertions flipped edges away
