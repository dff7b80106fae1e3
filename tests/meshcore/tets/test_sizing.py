"""tetrahedralize's size_field: scattered sizes interpolated linearly, meshes that follow it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from meshcore.domain import parse_surface
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates3d import orient3d
from meshcore.tets import tetrahedralize
from meshcore.tets.sizing import SizeField3d, estimated_tetrahedra
from tests.meshcore.domain import shapes

CORNERS = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]


def linear(X):
    return 0.1 + 0.2 * X[:, 0] + 0.3 * X[:, 1] + 0.4 * X[:, 2]


@pytest.mark.parametrize("how", ["as_given", "translate", "scale"])
def test_a_linear_field_is_reproduced_inside_the_hull_and_nearest_outside(how):
    P = np.array(CORNERS, dtype=float)
    rng = np.random.default_rng(3)
    inside = rng.dirichlet(np.ones(4), size=200) @ P[:4]  # in the tetrahedron of 4 corners
    outside = np.array([[2.0, 2.0, 2.0], [-1.0, 0.0, 0.0]])
    move = {"as_given": lambda X: X, "translate": lambda X: X + 1e6, "scale": lambda X: X * 1e-6}
    field = SizeField3d({"points": move[how](P), "values": linear(P)})
    np.testing.assert_allclose(field(move[how](inside)), linear(inside), rtol=1e-9)
    np.testing.assert_array_equal(field(move[how](outside)), linear(P)[[4, 0]])


def test_coplanar_or_few_points_give_the_nearest_value():
    flat = SizeField3d(
        {"points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], "values": [1, 2, 3, 4]}
    )
    np.testing.assert_array_equal(flat(np.array([[0.9, 0.1, 5.0], [0.1, 0.2, -1]])), [2, 1])
    two = SizeField3d({"points": [[0, 0, 0], [1, 1, 1]], "values": [0.5, 0.25]})
    np.testing.assert_array_equal(two(np.array([[0.2, 0.2, 0.2], [0.9, 0.8, 1.0]])), [0.5, 0.25])


@pytest.mark.parametrize(
    ("field", "loc", "code"),
    [
        ({"points": [[0, 0, 0], [1, 1, 1], [0, 0, 0]], "values": [1, 1, 1]}, 2, "duplicate_points"),
        ({"points": [[0, 0], [1, 1]], "values": [1, 1]}, None, "bad_parameter"),
        ({"points": [[0, 0, 0]], "values": [0.0]}, 0, "bad_parameter"),
    ],
)
def test_bad_fields_are_refused_where_they_are(field, loc, code):
    with pytest.raises(InputError) as err:
        SizeField3d(field)
    assert err.value.code == code
    assert err.value.errors[0]["loc"][0] == "size_field"
    if loc is not None:
        assert err.value.errors[0]["loc"][-1] == loc


def test_the_tetrahedra_follow_the_field():
    P, T = shapes.box()
    field = {"points": CORNERS, "values": [0.12, 0.5, 0.5, 0.5, 0.5]}
    res = tetrahedralize({"points": P.tolist(), "triangles": T.tolist()}, size_field=field)
    X, K = res.mesh.points, res.mesh.cells[0].data
    a, b, c, d = (X[K[:, i]] for i in range(4))
    assert (orient3d(a, b, d, c) > 0).all()  # meshio's order: positive volumes, exactly
    volume = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)).sum() / 6
    assert volume == pytest.approx(1.0, rel=1e-12)
    centre = X[K].mean(axis=1)
    edge = np.linalg.norm(a - b, axis=1)
    near = np.median(edge[np.linalg.norm(centre, axis=1) < 0.3])
    far = np.median(edge[np.linalg.norm(centre - 1, axis=1) < 0.3])
    assert near < 0.5 * far
    uniform = tetrahedralize({"points": P.tolist(), "triangles": T.tolist()}, size=0.12)
    assert len(K) < 0.5 * len(uniform.mesh.cells[0].data)  # graded: fewer than uniformly fine
    estimate = estimated_tetrahedra((P, T), size_field=field).tetrahedra  # at grid cells
    assert estimate <= len(K) <= 1.5 * estimate, (len(K), estimate)


@pytest.mark.parametrize("bound", [{"size": 0.15}, {"max_volume": 0.15**3 / (6 * 2**0.5)}])
def test_the_estimate_is_the_count_within_a_factor_1_5(bound):
    cube = parse_surface(*shapes.box((0, 0, 0), (1, 1, 1)))
    made = len(tetrahedralize(cube, max_radius_edge=None, **bound).mesh.cells[0].data)
    estimate = estimated_tetrahedra(cube, **bound).tetrahedra
    assert estimate <= made <= 1.5 * estimate, (made, estimate)


def test_no_bound_no_estimate_and_tiny_sizes_saturate():
    cube = parse_surface(*shapes.box((0, 0, 0), (1, 1, 1)))
    assert estimated_tetrahedra(cube) == (0, None)
    assert estimated_tetrahedra(cube, size=1e300) == (0, "size")
    assert estimated_tetrahedra(cube, size=1e-300) == (10**18, "size")
    one = {"points": [[0.5, 0.5, 0.5]], "values": [1e-300]}  # was found at the point limit
    assert estimated_tetrahedra(cube, size_field=one) == (10**18, "size_field")
    assert estimated_tetrahedra(cube, size_field={**one, "values": [1e300]}) == (0, "size_field")
    both = estimated_tetrahedra(cube, size=1e-300, max_volume=1e-300, size_field=one)
    assert both == (10**18, "size")  # equals: the first of size, max_volume, size_field


@pytest.mark.parametrize("name", ["size", "max_volume"])
@pytest.mark.parametrize("value", [0, -1.0, float("nan"), float("inf"), "big"])
def test_the_estimate_refuses_a_bound_that_is_not_positive_located(name, value):
    cube = parse_surface(*shapes.box((0, 0, 0), (1, 1, 1)))
    with pytest.raises(InputError) as err:
        estimated_tetrahedra(cube, **{name: value})
    assert (err.value.errors[0]["loc"], err.value.code) == ([name], "bad_parameter")


def test_a_constant_field_is_estimated_as_that_size_and_the_smaller_holds():
    cube = parse_surface(*shapes.box((0, 0, 0), (1, 1, 1)))
    by_size = estimated_tetrahedra(cube, size=0.15).tetrahedra
    field = {"points": [[0.5, 0.5, 0.5], [9.0, 9.0, 9.0]], "values": [0.15, 0.15]}
    by_field = estimated_tetrahedra(cube, size_field=field).tetrahedra
    assert by_field == pytest.approx(by_size, rel=1e-9)
    coarse = {"points": field["points"], "values": [1.0, 1.0]}
    both = estimated_tetrahedra(cube, size=0.15, size_field=coarse)
    assert both.tetrahedra == pytest.approx(by_size, rel=1e-9) and both.binding == "size"
    fine = estimated_tetrahedra(cube, size=1.0, max_volume=1.0, size_field=field)
    assert fine.tetrahedra == pytest.approx(by_size, rel=1e-9) and fine.binding == "size_field"


def test_the_point_limit_is_an_error_not_an_under_refined_mesh(monkeypatch):
    from meshcore.tets import refinement

    monkeypatch.setattr(refinement, "KNOBS", dataclasses.replace(refinement.KNOBS, max_points=200))
    cube = parse_surface(*shapes.box((0, 0, 0), (1, 1, 1)))
    with pytest.raises(AlgorithmError) as err:
        tetrahedralize(cube, size=0.1)
    assert err.value.code == "too_many_points"
