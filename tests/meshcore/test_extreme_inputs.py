"""Inputs at the edges of float64 that raised other errors than MeshcoreError (issue 22),
through meshcore's entry points: each now raises InputError with a code and a location,
or runs. Service-level counterparts: tests/service/test_defects.py and test_fuzz.py.
"""

from __future__ import annotations

import numpy as np
import pytest

import meshcore
import meshcore.medial
from meshcore.errors import InputError
from meshcore.mesh import Mesh

RECT = {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]}
L_SHAPE = {
    "type": "Polygon",
    "coordinates": [[[0, 0], [3, 0], [3, 1], [2, 1], [2, 3], [1, 3], [1, 1], [0, 1], [0, 0]]],
}
SQUARE = Mesh(np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]), [("triangle", [[0, 1, 2], [0, 2, 3]])])


def refused(call, *args, **kwargs) -> InputError:
    with pytest.raises(InputError) as info:
        call(*args, **kwargs)
    return info.value


@pytest.mark.parametrize("entry", ["medial_axis", "partition", "simplify", "quad_medial"])
def test_medial_h_too_small_to_count_samples_is_too_many_samples(entry):
    kwargs = {"levels": 0} if entry == "quad_medial" else {}
    e = refused(getattr(meshcore.medial, entry), meshcore.parse_domain(RECT), h=1e-300, **kwargs)
    assert e.code == "too_many_samples" and e.errors[0]["loc"] == ["h"]


def test_domain_below_min_diameter_is_out_of_range():
    tiny = {"type": "Polygon", "coordinates": [[[0, 0], [1e-300, 0], [0, 1e-300], [0, 0]]]}
    e = refused(meshcore.parse_domain, tiny)
    assert e.code == "out_of_range" and e.errors[0]["loc"] == ["coordinates"]


def test_quad_medial_subnormal_size_is_too_many_quads():
    e = refused(meshcore.quad_medial, meshcore.parse_domain(L_SHAPE), size=5e-324)
    assert e.code == "too_many_quads"


@pytest.mark.parametrize(
    ("center", "radius", "loc"),
    [([1e300, 1e300], 1.0, "center"), ([1e12, 0], 1.0, "center"), ([0, 0], 1e-300, "outer_radius")],
)
def test_radial_mesh_that_float64_cannot_resolve_is_out_of_range(center, radius, loc):
    e = refused(meshcore.radial, center=center, outer_radius=radius)
    assert e.code == "out_of_range" and e.errors[0]["loc"] == [loc]


def test_radial_far_from_the_origin_keeps_its_boundary_sets():
    near = meshcore.radial(outer_radius=1.0, balance=True).mesh
    far = meshcore.radial(center=[1e6, -1e6], outer_radius=1.0, balance=True).mesh
    assert {k: [len(a) for a in v] for k, v in far.cell_sets.items()} == {
        k: [len(a) for a in v] for k, v in near.cell_sets.items()
    }


def test_mesh_check_refuses_coordinates_beyond_max_coordinate():
    huge = Mesh(np.array([[0.0, 0], [1e300, 0], [0, 1e300]]), [("triangle", [[0, 1, 2]])])
    e = refused(meshcore.merged, [huge, SQUARE])
    assert e.code == "out_of_range" and e.errors[0]["loc"] == ["meshes", 0, "points", 1, 0]


def test_mesh_check_refuses_a_3d_cell_type_on_2d_points():
    tetra = Mesh(np.array([[0.0, 0], [1, 0], [0, 1], [0.2, 0.2]]), [("tetra", [[0, 1, 2, 3]])])
    e = refused(tetra.check)
    assert e.code == "bad_dimension" and e.errors[0]["loc"] == ["cells", 0, "type"]


def test_triangulate_with_a_subnormal_min_angle_runs():
    res = meshcore.triangulate(meshcore.parse_domain(RECT), size=0.2, min_angle=5e-324)
    assert len(res.mesh.points) > 4


def test_medial_transform_of_subnormal_radii_is_out_of_range():
    e = refused(meshcore.medial_transform, [[0.0, 0.0], [1e-300, 0]], [5e-301, 5e-301], [[0, 1]])
    assert e.code == "out_of_range" and e.errors[0]["loc"][0] == "radius"
