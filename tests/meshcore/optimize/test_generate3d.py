"""Facts about tetrahedra generated from a closed surface by :func:`meshcore.optimize.optimize`.

§8.3.3 and Figure 8.11: from Op(P, δ𝒮), P the surface vertex nearest the
centroid, the optimization reaches a valid mesh: every tet positive by the
exact orient3d, a mesh topology whose boundary faces are exactly the input
triangles (outward), the enclosed volume to 1e-12 relative, and the Sur
series non-increasing down to that volume. Without point insertion a stuck
run fails with the count of inverted tets and where, never a wrong mesh.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from meshcore.domain.surface import parse_surface
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import quality
from meshcore.optimize import check_topology, optimize
from meshcore.optimize.coupez3d import initial_candidates
from tests.meshcore.optimize.test_coupez import assert_monotone


def icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit icosahedron subdivided ``level`` times, points on the sphere."""
    t = (1 + 5**0.5) / 2
    V = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
        (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]  # fmt: skip
    F = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
        (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
        (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]  # fmt: skip
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(level):
        mids: dict = {}

        def mid(a, b, mids=mids):
            key = (min(a, b), max(a, b))
            if key not in mids:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                mids[key] = len(V) - 1
            return mids[key]

        F = [
            tri
            for a, b, c in F
            for ab, bc, ca in [(mid(a, b), mid(b, c), mid(c, a))]
            for tri in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))
        ]
    return np.array(V), np.array(F)


def grid_cube(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit cube, each face cut into k x k squares of two triangles (coplanar points)."""
    g = np.linspace(0.0, 1.0, k + 1)
    index: dict = {}
    F = []
    for ax in range(3):
        u, v = [a for a in range(3) if a != ax]
        for side in (0, 1):
            flip = (ax == 1) == bool(side)  # outward: (u, v, ax) right-handed on the far side
            for i in range(k):
                for j in range(k):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[ax], p[u], p[v] = float(side), g[i + di], g[j + dj]
                        quad.append(index.setdefault(tuple(p), len(index)))
                    a, b, c, d = quad
                    F += [(a, c, b), (a, d, c)] if flip else [(a, b, c), (a, c, d)]
    return np.array(list(index)), np.array(F)


def ring(sections: int, sides: int, R: float = 1.0, r: float = 0.4):
    """A pipe closing on itself (Figure 8.11): ``sections`` regular ``sides``-gons on a circle."""
    a = 2 * np.pi * np.arange(sections)[:, None]
    b = 2 * np.pi * np.arange(sides)[None, :]
    a, b = a / sections + 0 * b, b / sides + 0 * a
    P = np.stack(
        [(R + r * np.cos(b)) * np.cos(a), (R + r * np.cos(b)) * np.sin(a), r * np.sin(b)], axis=-1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(sections), np.arange(sides), indexing="ij")
    i1, j1 = (i + 1) % sections, (j + 1) % sides
    A, B, C, D = i * sides + j, i1 * sides + j, i1 * sides + j1, i * sides + j1
    F = np.concatenate([np.stack([A, B, C], -1), np.stack([A, C, D], -1)]).reshape(-1, 3)
    return P, F


def schonhardt() -> tuple[np.ndarray, np.ndarray]:
    """Schönhardt's twisted prism: no tetrahedralization of its six vertices exists."""
    a = np.radians([0.0, 120.0, 240.0])
    P = np.vstack(
        [
            np.column_stack([np.cos(a), np.sin(a), np.zeros(3)]),
            np.column_stack([np.cos(a + np.pi / 6), np.sin(a + np.pi / 6), np.ones(3)]),
        ]
    )
    F = [(0, 2, 1), (3, 4, 5)]
    for i in range(3):
        j = (i + 1) % 3
        F += [(i, j, 3 + j), (i, 3 + j, 3 + i)]  # the reflex diagonals
    return P, np.array(F)


SHAPES = {
    "cube": lambda: grid_cube(3),
    "ring": lambda: ring(24, 8),
    # planar side quads whose diagonals turn one way: needs inserted points (below)
    "ring12x6": lambda: ring(12, 6),
    "sphere": lambda: icosphere(2),
}


def assert_valid_3d(res, surf):
    P, T = res.mesh.points, res.mesh.cells[0].data
    assert (orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], P[T[:, 3]]) < 0).all()  # all positive
    bnd = check_topology(res.mesh, T)
    # every surface triangle is a tet face (the boundary faces are exactly them, outward)
    verts = np.unique(surf.triangles)
    assert np.array_equal(P[: len(verts)], surf.points[verts])

    def canon(f):
        f = np.asarray(f)
        r = np.argmin(f, axis=1)
        return sorted(
            map(tuple, np.stack([f[np.arange(len(f)), (r + i) % 3] for i in range(3)], 1))
        )

    new = np.full(len(surf.points), -1)
    new[verts] = np.arange(len(verts))
    assert canon(bnd) == canon(new[surf.triangles])
    vol = math.fsum(quality.signed_volume(P, T))
    assert vol == pytest.approx(surf.volume, rel=1e-12)
    assert_monotone(res.stats["sur"])
    assert res.stats["sur"][-1] == pytest.approx(surf.volume, rel=1e-12)
    assert res.stats["inverted_after"] == 0


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_generation_from_surface(name):
    surf = parse_surface(*SHAPES[name]())
    # size above the diameter: only the points the stuck first stage needs are inserted
    res = optimize(surface=surf, size=10.0)
    assert_valid_3d(res, surf)
    assert res.stats["use"] == "generation"
    # the optimization stage never lowers the least quality
    assert res.stats["least_quality_after"] >= res.stats["least_quality_before_optimization"]
    if name == "ring12x6":
        P, T = res.mesh.points, res.mesh.cells[0].data
        assert quality.tetra_radius_ratio(P, T).min() > 0.01


def test_sphere_without_insertion_keeps_the_points():
    surf = parse_surface(*icosphere(2))
    res = optimize(surface=surf, insert_points=False)
    assert_valid_3d(res, surf)
    assert len(res.mesh.points) == len(surf.points)
    assert res.stats["operators"]["ball_fan"] + res.stats["operators"]["shell_fan"] > 0


def test_insertion_to_size():
    surf = parse_surface(*grid_cube(2))
    res = optimize(surface=surf, size=0.6)
    assert_valid_3d(res, surf)
    assert res.stats["points_inserted"] > 1  # G where stuck, then midpoints of long edges
    assert res.stats["stages"] == 2


def test_stuck_without_insertion_is_a_clean_failure():
    surf = parse_surface(*schonhardt())
    with pytest.raises(AlgorithmError) as err:
        optimize(surface=surf, insert_points=False)
    msg = str(err.value)
    assert "still inverted or flat" in msg and "within the box" in msg
    res = optimize(surface=surf, size=10.0)  # a point inside makes it
    assert_valid_3d(res, surf)
    assert res.stats["points_inserted"] > 0


@pytest.mark.parametrize("name", ["cube", "ring12x6", "sphere"])
@pytest.mark.parametrize("place", ["translated", "scaled"])
def test_translated_far_away(name, place):
    """Translated by 1e6 or scaled by 1e-6, the same tetrahedra (the flat rule of
    ``coupez.TOL.flat`` and centroids relative to a vertex: rounding decides nothing)."""
    P, F = SHAPES[name]()
    Q, size = (P + 1e6, 10.0) if place == "translated" else (P * 1e-6, 1e-5)
    surf = parse_surface(Q, F)
    res = optimize(surface=surf, size=size)
    assert_valid_3d(res, surf)
    ref = optimize(surface=parse_surface(P, F), size=10.0)
    np.testing.assert_array_equal(res.mesh.cells[0].data, ref.mesh.cells[0].data)


def test_ring_without_insertion_fails_wherever_it_lies():
    """The 12x6 ring's side quads are planar (to rounding at the origin, exactly at 1e6): no
    tetrahedralization of its points without flat tets exists (TetGen -pY adds 11-12
    points). Without insertion it fails, at 1e6 and scaled by 1e-6 as at the origin (6 flat
    left each time), never a mesh whose validity rounding decided (the origin's used to hold
    tets of volume 1e-18)."""
    P, F = ring(12, 6)
    for Q in (P, P + 1e6, P * 1e-6):
        with pytest.raises(AlgorithmError) as err:
            optimize(surface=parse_surface(Q, F), insert_points=False)
        assert "6 element(s) still inverted or flat" in str(err.value)


@pytest.mark.parametrize(
    "points, triangles, code",
    [
        (icosphere(1)[0], icosphere(1)[1][1:], "open_edge"),
        (
            np.vstack([icosphere(0)[0], icosphere(0)[0] * 0.3]),
            np.vstack([icosphere(0)[1], icosphere(0)[1][:, ::-1] + 12]),
            "unsupported_input",
        ),
    ],
)
def test_bad_surface(points, triangles, code):
    with pytest.raises(InputError) as err:
        optimize(surface=(points, triangles))
    assert err.value.code == code
    assert err.value.errors[0]["loc"][0] in ("surface", "triangles")


def test_no_two_inputs():
    square = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
    with pytest.raises(InputError) as err:
        optimize(domain=square, surface=icosphere(0))
    assert err.value.code == "bad_input"


def test_cube_grid_without_insertion_far_away():
    """The 6x6 cube (coplanar points on every face) keeps its points: the flat tets
    capping planar surface quads go by edge removals and vertex star cavities."""
    P, F = grid_cube(6)
    surf = parse_surface(P + 1e6, F)
    res = optimize(surface=surf, insert_points=False)
    assert_valid_3d(res, surf)
    assert len(res.mesh.points) == len(surf.points)


def test_initial_vertices_do_not_depend_on_translation_or_scale():
    """The ring's vertices are equidistant from its centroid in sets: only rounding, which a
    translation by 1e6 or a scaling by 1e-6 changes, would order them; near ties go by
    index, so every start of Op(P, δ𝒮) is the same vertex whatever the placement."""
    P, F = ring(12, 6)
    first = initial_candidates(P, F)
    for Q in (P + 1e6, P * 1e-6):
        np.testing.assert_array_equal(initial_candidates(Q, F), first)
