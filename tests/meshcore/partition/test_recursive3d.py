"""Recursive partition (§8.7.2), 3D: facts a reader can check by hand.

Every mesh: only tetrahedra, each positive by exact orient3d, volumes adding
up to the enclosed volume, no face held by more than two tetrahedra, and the
faces held once exactly the input triangles (no point on the surface).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshcore.domain import parse_surface
from meshcore.errors import InputError
from meshcore.geometry.predicates3d import orient3d
from meshcore.partition import recursive_partition
from tests.meshcore.domain import shapes


def faces_of(K: np.ndarray) -> np.ndarray:
    return np.sort(K[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3), axis=1)


def check(P, T, **kw):
    """The result, after asserting the facts of the module docstring."""
    s = parse_surface(P, T)
    r = recursive_partition(surface={"points": P, "triangles": T}, **kw)
    X, K = r.mesh.points, r.mesh.cells[0].data
    assert [b.type for b in r.mesh.cells] == ["tetra"]
    assert (orient3d(X[K[:, 0]], X[K[:, 1]], X[K[:, 2]], X[K[:, 3]]) < 0).all()
    a = X[K[:, 0]]
    vol = np.einsum("ij,ij->i", X[K[:, 1]] - a, np.cross(X[K[:, 2]] - a, X[K[:, 3]] - a)) / 6
    assert math.fsum(vol.tolist()) == pytest.approx(s.volume, rel=1e-12)
    keys, counts = np.unique(faces_of(K), axis=0, return_counts=True)
    assert counts.max() <= 2
    # The surface's vertices come first, in increasing input index, unchanged.
    v = s.vertices
    assert np.array_equal(X[: len(v)], s.points[v])
    remap = np.full(len(s.points), -1)
    remap[v] = np.arange(len(v))
    assert np.array_equal(keys[counts == 1], np.unique(np.sort(remap[s.triangles], 1), axis=0))
    assert r.quality["tetra"]["invalid"] == 0
    assert r.stats["cells"] == len(K)
    return r


def test_schonhardt_prism_takes_one_steiner_point():
    """No tetrahedralization of its six vertices exists: one interior point, 8 tetrahedra."""
    r = check(*shapes.schonhardt(), size=5.0)
    assert r.stats["steiner_points"] == 1
    assert r.stats["patterns"]["steiner"] == 1
    assert len(r.mesh.points) == 7 and len(r.mesh.cells[0].data) == 8


def test_coarse_cube_needs_no_steiner_point():
    """12 triangles: split by separator planes through its corners, no point added."""
    r = check(*shapes.box(), size=0.4)
    assert r.stats["steiner_points"] == 0
    assert len(r.mesh.points) == 8


def test_grid_cube_cut_at_the_size():
    """A 4 x 4 grid per face at size 0.25: the separators follow the grid planes."""
    r = check(*shapes.box(n=4), size=0.25)
    assert sum(r.stats["separators"].values()) >= 7
    assert r.stats["oversized_leaves"] == 0


@pytest.mark.parametrize("strategy", ["balanced", "angle"])
def test_l_block(strategy):
    check(*shapes.prism(shapes.L_POLYGON, shapes.L_CAPS, 1.0), size=0.5, strategy=strategy)


def test_torus_ring():
    """Genus 1: the first separator is a pair of opposite cross-sections of the tube."""
    r = check(*shapes.torus(nu=12, nv=6), size=0.6)
    assert r.stats["separators"] and sum(r.stats["separators"].values()) >= 2


def test_two_bodies():
    P1, T1 = shapes.box((0, 0, 0), (1, 1, 1), 2)
    P2, T2 = shapes.box((2, 0, 0), (3, 1, 1), 2)
    check(np.concatenate([P1, P2]), np.concatenate([T1, T2 + len(P1)]), size=0.5)


def test_translated_and_scaled_inputs_give_the_same_mesh():
    P, T = shapes.box(n=2)
    a = recursive_partition(surface=(P, T), size=0.5).mesh
    b = recursive_partition(surface=(P * 2.0**-20 + 2.0**20, T), size=0.5 * 2.0**-20).mesh
    assert np.array_equal(a.cells[0].data, b.cells[0].data)


@pytest.mark.parametrize(
    "kw, loc",
    [
        ({"size": 0}, ("size",)),
        ({"size": 0.5, "strategy": "random"}, ("strategy",)),
        ({"size": 0.5, "element": "triangle"}, ("element",)),
        ({"size": 0.5, "domain": {"type": "Polygon", "coordinates": []}}, ("surface",)),
    ],
)
def test_bad_input_names_the_field(kw, loc):
    with pytest.raises(InputError) as e:
        recursive_partition(surface=shapes.box(), **kw)
    assert tuple(e.value.errors[0]["loc"][: len(loc)]) == loc


def test_cavity_is_refused():
    P1, T1 = shapes.box((0, 0, 0), (3, 3, 3), 2)
    P2, T2 = shapes.box((1, 1, 1), (2, 2, 2))
    with pytest.raises(InputError) as e:
        recursive_partition(
            surface=(np.concatenate([P1, P2]), np.concatenate([T1, T2 + len(P1)])), size=1.0
        )
    assert e.value.code == "unsupported"


@st.composite
def star_polyhedra(draw):
    n = draw(st.integers(6, 24))
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(n, 3))])
    return shapes.star(rng.uniform(0.6, 1.4, size=len(d)), d), draw(st.sampled_from([0.5, 2.0]))


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(star_polyhedra())
def test_star_shaped_polyhedra(case):
    (P, T), size = case
    check(P, T, size=size)
