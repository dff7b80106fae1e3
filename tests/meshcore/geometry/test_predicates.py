"""Exact signs of orient2d, incircle, orient3d and insphere, checked against rational arithmetic.

Every expected sign here is computed with :class:`fractions.Fraction`, which
is exact for float inputs, so a reader can trust it by inspection.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.geometry.predicates import (
    dot2d,
    incircle,
    incircle_scalar,
    indiametral,
    orient2d,
    orient2d_scalar,
)
from meshcore.geometry.predicates3d import (
    dot3d,
    insphere,
    insphere_perturbed,
    insphere_scalar,
    orient3d,
    orient3d_scalar,
)


def _sign(x: Fraction) -> int:
    return (x > 0) - (x < 0)


def exact_orient2d(a, b, c) -> int:
    ax, ay, bx, by, cx, cy = map(Fraction, (*a, *b, *c))
    return _sign((ax - cx) * (by - cy) - (ay - cy) * (bx - cx))


def exact_incircle(a, b, c, d) -> int:
    ax, ay, bx, by, cx, cy, dx, dy = map(Fraction, (*a, *b, *c, *d))
    adx, ady, bdx, bdy, cdx, cdy = ax - dx, ay - dy, bx - dx, by - dy, cx - dx, cy - dy
    return _sign(
        (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy)
        + (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy)
        + (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady)
    )


def exact_orient3d(a, b, c, d) -> int:
    ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz = map(Fraction, (*a, *b, *c, *d))
    adx, ady, adz = ax - dx, ay - dy, az - dz
    bdx, bdy, bdz = bx - dx, by - dy, bz - dz
    cdx, cdy, cdz = cx - dx, cy - dy, cz - dz
    return _sign(
        adz * (bdx * cdy - cdx * bdy)
        + bdz * (cdx * ady - adx * cdy)
        + cdz * (adx * bdy - bdx * ady)
    )


def exact_insphere(a, b, c, d, e) -> int:
    """Shewchuk's insphere: the 4 x 4 lifted determinant of the rows p - e."""
    e = tuple(map(Fraction, e))
    rows = []
    for q in (a, b, c, d):
        r = [Fraction(x) - y for x, y in zip(q, e, strict=True)]
        rows.append([*r, sum(x * x for x in r)])

    def det(m):
        if len(m) == 1:
            return m[0][0]
        return sum(
            (-1) ** j * m[0][j] * det([row[:j] + row[j + 1 :] for row in m[1:]])
            for j in range(len(m))
        )

    return _sign(det(rows))


def naive_orient2d(a, b, c) -> np.ndarray:
    return np.sign(
        (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1]) - (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    )


# ---------------------------------------------------------------------------
# Facts float64 gets wrong
# ---------------------------------------------------------------------------


def ulp_grid(x0: float, y0: float, size: int) -> np.ndarray:
    """The size x size grid of floats starting at (x0, y0), one ulp apart."""
    xs = x0 + np.arange(size) * np.spacing(x0)
    ys = y0 + np.arange(size) * np.spacing(y0)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


class TestOrient2dNearCollinear:
    """Kettner et al.'s classic: points a few ulps around (0.5, 0.5) against
    the line through (12, 12) and (24, 24). The float determinant gets
    hundreds of signs wrong; the exact signs form a clean staircase."""

    def test_ulp_grid_against_fractions(self):
        a = ulp_grid(0.5, 0.5, 48)
        b = np.array([12.0, 12.0])
        c = np.array([24.0, 24.0])
        expected = np.array([exact_orient2d(p, b, c) for p in a])
        got = orient2d(a, b, c)
        naive = naive_orient2d(a, np.broadcast_to(b, a.shape), np.broadcast_to(c, a.shape))
        assert (naive != expected).sum() > 100  # the trap is real
        np.testing.assert_array_equal(got, expected)
        # The exact picture: the sign is that of x - y, i.e. of i - j.
        i, j = np.divmod(np.arange(len(a)), 48)
        np.testing.assert_array_equal(expected, np.sign(j - i))

    def test_scalar_matches_vectorized_on_ulp_grid(self):
        a = ulp_grid(0.5, 0.5, 16)
        got = orient2d(a, [12.0, 12.0], [24.0, 24.0])
        scalar = [orient2d_scalar(x, y, 12.0, 12.0, 24.0, 24.0) for x, y in a]
        np.testing.assert_array_equal(got, scalar)

    def test_collinear_far_from_origin(self):
        # Exactly collinear points translated by 1e6 (dyadic, so exactly).
        t = np.arange(100) * 2.0**-20
        pts = np.column_stack([1e6 + 3 * t, -1e6 + 5 * t])
        assert (orient2d(pts[:-2], pts[1:-1], pts[2:]) == 0).all()
        # One ulp off the line changes the sign, consistently.
        moved = pts[1:-1] + [0.0, np.spacing(1e6)]
        got = orient2d(pts[:-2], moved, pts[2:])
        expected = [
            exact_orient2d(a, b, c) for a, b, c in zip(pts[:-2], moved, pts[2:], strict=True)
        ]
        np.testing.assert_array_equal(got, expected)
        assert (got != 0).all()


class TestIncircleNearCocircular:
    def test_ulp_grid_around_a_cocircular_point(self):
        # (1, 1) is on the circle through (0, 0), (1, 0), (0, 1); move it by ulps.
        a, b, c = np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0])
        d = ulp_grid(1.0, 1.0, 12) - 6 * np.spacing(1.0) / 2
        expected = np.array([exact_incircle(a, b, c, p) for p in d])
        np.testing.assert_array_equal(incircle(a, b, c, d), expected)
        assert set(expected) == {-1, 0, 1}

    def test_cocircular_translated_and_scaled(self):
        # Integer points on x^2 + y^2 = 25, moved by 1e6 and scaled by 2**-20.
        circle = np.array(
            [[5, 0], [4, 3], [3, 4], [0, 5], [-3, 4], [-5, 0], [0, -5], [4, -3]], float
        )
        for shift, scale in [(0.0, 1.0), (1e6, 1.0), (0.0, 2.0**-20), (1e6, 2.0**-20)]:
            p = circle * scale + shift
            got = incircle(p[0], p[1], p[2], p[3:])
            assert (got == 0).all()
        inside = np.array([[4.0, 2.999999999]]) + 1e6
        p = circle + 1e6
        assert incircle(p[0], p[1], p[2], inside)[0] == exact_incircle(p[0], p[1], p[2], inside[0])

    def test_scalar_matches_vectorized(self):
        rng = np.random.default_rng(3)
        pts = rng.integers(-4, 5, size=(500, 4, 2)) / 3.0 + 1e3
        got = incircle(pts[:, 0], pts[:, 1], pts[:, 2], pts[:, 3])
        scalar = [incircle_scalar(*q.ravel()) for q in pts]
        np.testing.assert_array_equal(got, scalar)


# ---------------------------------------------------------------------------
# Property tests against exact rational evaluation
# ---------------------------------------------------------------------------

# The predicates assume no underflow (as Shewchuk's): nonzero coordinates
# are kept above 1e-30 in magnitude (the kernel rescales its input to ensure it).
coords = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False).filter(
    lambda x: x == 0.0 or abs(x) > 1e-30
)
point2 = st.tuples(coords, coords)
small_int = st.integers(min_value=-6, max_value=6)
scales = st.sampled_from([1.0, 0.1, 1.0 / 3.0, 1e-6, 2.0**-30, 7.0])
shifts = st.sampled_from([0.0, 1e6, -12345.678, 0.1])


@st.composite
def degenerate_points(draw, count: int, dim: int = 2):
    """Integer lattice points, scaled by a (maybe inexact) factor and shifted:
    collinear and co-circular configurations are frequent, and rounding
    makes the nearly degenerate ones hard for float arithmetic."""
    scale = draw(scales)
    shift = draw(shifts)
    raw = [tuple(draw(small_int) for _ in range(dim)) for _ in range(count)]
    return [tuple(v * scale + shift for v in p) for p in raw]


@settings(max_examples=300, deadline=None)
@given(point2, point2, point2)
def test_orient2d_random_matches_fractions(a, b, c):
    assert orient2d(a, b, c) == exact_orient2d(a, b, c)


@settings(max_examples=500, deadline=None)
@given(degenerate_points(3))
def test_orient2d_degenerate_matches_fractions(p):
    a, b, c = p
    assert orient2d(a, b, c) == exact_orient2d(a, b, c)
    assert orient2d_scalar(*a, *b, *c) == exact_orient2d(a, b, c)


@settings(max_examples=300, deadline=None)
@given(point2, point2, point2, point2)
def test_incircle_random_matches_fractions(a, b, c, d):
    assert incircle(a, b, c, d) == exact_incircle(a, b, c, d)


@settings(max_examples=500, deadline=None)
@given(degenerate_points(4))
def test_incircle_degenerate_matches_fractions(p):
    a, b, c, d = p
    assert incircle(a, b, c, d) == exact_incircle(a, b, c, d)
    assert incircle_scalar(*a, *b, *c, *d) == exact_incircle(a, b, c, d)


@settings(max_examples=300, deadline=None)
@given(degenerate_points(4, dim=3))
def test_orient3d_degenerate_matches_fractions(p):
    a, b, c, d = p
    assert orient3d(a, b, c, d) == exact_orient3d(a, b, c, d)
    assert orient3d_scalar(*a, *b, *c, *d) == exact_orient3d(a, b, c, d)


def test_vectorized_degenerate_batch_matches_fractions():
    # Many rows at once: the filter decides some rows, the exact stage the rest.
    rng = np.random.default_rng(7)
    p = rng.integers(-5, 6, size=(4000, 4, 2)) * 0.1 + 1e6
    got_o = orient2d(p[:, 0], p[:, 1], p[:, 2])
    got_i = incircle(p[:, 0], p[:, 1], p[:, 2], p[:, 3])
    exp_o = [exact_orient2d(*q[:3]) for q in p]
    exp_i = [exact_incircle(*q) for q in p]
    np.testing.assert_array_equal(got_o, exp_o)
    np.testing.assert_array_equal(got_i, exp_i)
    assert 0 in exp_o and 0 in exp_i


# ---------------------------------------------------------------------------
# Symmetries
# ---------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(degenerate_points(4))
def test_antisymmetry_under_permutation(p):
    a, b, c, d = p
    o = orient2d(a, b, c)
    assert orient2d(b, c, a) == o and orient2d(c, a, b) == o
    assert orient2d(b, a, c) == -o and orient2d(a, c, b) == -o
    s = incircle(a, b, c, d)
    assert incircle(b, c, a, d) == s and incircle(c, a, b, d) == s
    assert incircle(b, a, c, d) == -s
    # d's role is symmetric with a's up to the sign of the 4x4 determinant.
    assert incircle(d, b, c, a) == -s


def test_orient3d_sign_convention():
    a, b, c = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    assert orient3d(a, b, c, [0.2, 0.2, -1.0]) == 1  # below
    assert orient3d(a, b, c, [0.2, 0.2, 1.0]) == -1  # above
    assert orient3d(a, b, c, [5.0, 7.0, 0.0]) == 0


def test_shapes_broadcast_and_dtype():
    a = np.zeros((5, 2))
    out = orient2d(a, [1.0, 0.0], [0.0, 1.0])
    assert out.shape == (5,) and out.dtype == np.int8
    assert orient2d([0, 0], [1, 0], [0, 1]).shape == ()
    assert incircle(np.zeros((2, 3, 2)), [1, 0], [0, 1], [0.1, 0.1]).shape == (2, 3)


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (([0, 0, 0], [1, 0], [0, 1]), "bad_shape"),
        ((np.zeros((3, 2)), np.zeros((4, 2)), [0, 1]), "bad_shape"),
        (([0, np.nan], [1, 0], [0, 1]), "non_finite"),
        ((["a", "b"], [1, 0], [0, 1]), "bad_shape"),
    ],
)
def test_bad_input_raises_input_error(args, code):
    with pytest.raises(InputError) as info:
        orient2d(*args)
    assert info.value.code == code


def test_circumcenter_is_equidistant_even_far_from_the_origin():
    # Constructions (inexact) live beside the predicates: the circumcentre of
    # a right triangle is the midpoint of its hypotenuse.
    from meshcore.geometry import circumcenter, circumradius

    a, b, c = np.array([0.0, 0.0]), np.array([4.0, 0.0]), np.array([0.0, 2.0])
    for shift in (0.0, 1e6):
        np.testing.assert_allclose(
            circumcenter(a + shift, b + shift, c + shift), [2 + shift, 1 + shift]
        )
        np.testing.assert_allclose(circumradius(a + shift, b + shift, c + shift), np.sqrt(5.0))
    rng = np.random.default_rng(0)
    p = rng.random((100, 3, 2)) + 1e6
    o = circumcenter(p[:, 0], p[:, 1], p[:, 2])
    r = np.linalg.norm(p - o[:, None, :], axis=2)
    np.testing.assert_allclose(r, r[:, :1].repeat(3, axis=1), rtol=1e-6)


# ---------------------------------------------------------------------------
# dot2d and indiametral (diametral balls of §9.1, acute angles)
# ---------------------------------------------------------------------------


def exact_dot2d(a, b, c) -> int:
    ax, ay, bx, by, cx, cy = map(Fraction, (*a, *b, *c))
    return _sign((ax - cx) * (bx - cx) + (ay - cy) * (by - cy))


def test_indiametral_on_the_unit_circle():
    # Segment from (-5, 0) to (5, 0): its diametral ball is the disk of radius 5.
    #
    #        (0, 5)   on the circle: 0 (so is (3, 4))
    #   (0, 2.5)      inside: +1
    #  a---------b
    #        (0, -10) outside: -1
    a, b = [-5.0, 0.0], [5.0, 0.0]
    p = np.array([[0.0, 2.5], [0.0, 5.0], [0.0, -10.0], [3.0, 4.0], [-5.0, 0.0], [2.5, 0.0]])
    np.testing.assert_array_equal(indiametral(a, b, p), [1, 0, -1, 0, 0, 1])
    np.testing.assert_array_equal(dot2d(a, b, p), [-1, 0, 1, 0, 0, -1])


def test_dot2d_decides_what_float64_gets_wrong():
    # c one ulp off the circle of diameter ab, a million away from the origin:
    # the float products cancel to garbage, the exact sign does not.
    x0 = 1e6
    a = np.array([x0, x0])
    b = a + [3.0, 0.0]
    grid = ulp_grid(x0 + 1.5, x0 + 1.5, 7)
    want = [exact_dot2d(a, b, c) for c in grid]
    np.testing.assert_array_equal(dot2d(a, b, grid), want)
    np.testing.assert_array_equal(indiametral(a, b, grid), [-w for w in want])
    t1 = (a[0] - grid[:, 0]) * (b[0] - grid[:, 0])
    t2 = (a[1] - grid[:, 1]) * (b[1] - grid[:, 1])
    assert (np.sign(t1 + t2) != want).any()


@settings(max_examples=500, deadline=None)
@given(degenerate_points(3))
def test_dot2d_degenerate_matches_fractions(p):
    a, b, c = p
    assert dot2d(a, b, c) == exact_dot2d(a, b, c)
    assert indiametral(a, b, c) == -exact_dot2d(a, b, c)
    assert dot2d(b, a, c) == dot2d(a, b, c)


@settings(max_examples=300, deadline=None)
@given(point2, point2, point2)
def test_dot2d_random_matches_fractions(a, b, c):
    assert dot2d(a, b, c) == exact_dot2d(a, b, c)


def test_dot2d_vectorized_batch_matches_fractions():
    # Lattice points on many circles of diameter ab: right angles (0) abound.
    rng = np.random.default_rng(11)
    p = rng.integers(-5, 6, size=(4000, 3, 2)) * 0.1 + 1e6
    got = dot2d(p[:, 0], p[:, 1], p[:, 2])
    want = [exact_dot2d(*q) for q in p]
    np.testing.assert_array_equal(got, want)
    assert 0 in want and 1 in want and -1 in want
    assert dot2d(np.zeros((2, 3, 2)), [1, 0], [0, 1]).shape == (2, 3)
    with pytest.raises(InputError) as info:
        indiametral([0, np.nan], [1, 0], [0, 1])
    assert info.value.code == "non_finite"


def exact_dot3d(a, b, c) -> int:
    a, b, c = (list(map(Fraction, q)) for q in (a, b, c))
    return _sign(sum((a[k] - c[k]) * (b[k] - c[k]) for k in range(3)))


@settings(max_examples=200, deadline=None)
@given(degenerate_points(3, dim=3))
def test_dot3d_degenerate_matches_fractions(p):
    a, b, c = p
    assert dot3d(a, b, c) == exact_dot3d(a, b, c)
    assert dot3d(b, a, c) == dot3d(a, b, c)


def test_dot3d_vectorized_batch_matches_fractions():
    # Lattice points far from the origin on many spheres of diameter ab: the filter
    # leaves the right angles (0) and their rounded neighbours to the exact stage.
    rng = np.random.default_rng(11)
    p = rng.integers(-3, 4, size=(3000, 3, 3)) * 0.1 + np.array([1e6, -3.0, 0.7])
    got = dot3d(p[:, 0], p[:, 1], p[:, 2])
    want = [exact_dot3d(*q) for q in p]
    np.testing.assert_array_equal(got, want)
    assert 0 in want and 1 in want and -1 in want


# ---------------------------------------------------------------------------
# insphere
# ---------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(degenerate_points(5, dim=3))
def test_insphere_degenerate_matches_fractions(p):
    a, b, c, d, e = p
    assert insphere(a, b, c, d, e) == exact_insphere(a, b, c, d, e)
    assert insphere_scalar(*a, *b, *c, *d, *e) == exact_insphere(a, b, c, d, e)


def test_insphere_vectorized_batch_matches_fractions():
    # Lattice points far from the origin: rounded differences are inexact.
    rng = np.random.default_rng(11)
    p = rng.integers(-2, 3, size=(600, 5, 3)) * 0.1 + np.array([1e6, -3.0, 0.7])
    got = insphere(*(p[:, i] for i in range(5)))
    exp = [exact_insphere(*q) for q in p]
    np.testing.assert_array_equal(got, exp)
    assert 0 in exp and 1 in exp and -1 in exp


def test_insphere_sign_convention():
    # Positively oriented (orient3d > 0) tetrahedron, its circumcentre inside.
    a, b, c, d = [1.0, 0, 0], [0.0, 0, 0], [0.0, 1, 0], [0.0, 0, 1]
    assert orient3d(a, b, c, d) == 1
    assert insphere(a, b, c, d, [0.5, 0.5, 0.5]) == 1
    assert insphere(a, b, c, d, [1.0, 1.0, 1.0]) == 0
    assert insphere(a, b, c, d, [2.0, 2.0, 2.0]) == -1
    assert insphere(b, a, c, d, [0.5, 0.5, 0.5]) == -1


def test_insphere_perturbation_breaks_ties_consistently():
    # The 8 corners of a cube are co-spherical: every tie is broken, the
    # answer never 0, and a point's role (tested or on the sphere) flips it.
    g = np.array([[x, y, z] for x in (0.0, 1) for y in (0.0, 1) for z in (0.0, 1)])
    work = np.empty(16384)
    for idx in np.random.default_rng(2).choice(8, size=(40, 5)):
        if len(set(idx)) < 5 or orient3d(*g[idx[:4]]) == 0:
            continue
        q = g[idx]
        if orient3d(*q[:4]) < 0:
            q[[0, 1]] = q[[1, 0]]
        s = insphere_perturbed(q, work)
        assert s in (-1, 1)
        assert insphere(*q, perturbed=True) == s
        # Exchanging d and e exchanges two rows of the perturbed determinant:
        # the sign flips (the perturbation belongs to the points, not the roles).
        r = q[[0, 1, 2, 4, 3]]
        if orient3d(*r[:4]) != 0:
            assert insphere_perturbed(r, work) == -s
