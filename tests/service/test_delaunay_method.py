"""The ``delaunay`` method through the API of a live server.

Failure cases first: bad points are 422 problems naming the point (before
the job is queued); then 2D and 3D results with the hull as a cell set,
valid and downloadable.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from meshcore.geometry.predicates import orient2d
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import io
from service.methods.delaunay import DELAUNAY_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

CUBE = [[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)]


def finished(c, params: dict) -> dict:
    r = submit(c, "delaunay", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json() | {"_id": job["id"]}


class TestDelaunay:
    @pytest.mark.parametrize(
        "params, loc",
        [
            ({"points": [[0, 0], [1, 0]]}, ["points"]),
            ({"points": [[0, 0], [1, 0], [0, 1, 2]]}, ["points", 2]),
            ({"points": [[0, 0], [1, 0], [0, "x"]]}, ["points", 2]),
            ({"points": [[0, 0], [1, 0], [0, 1]], "size": 1}, ["size"]),
            ({"points": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}, ["points"]),
            ({"points": [[0, 0], [1, 1], [2, 2], [3, 3]]}, ["points"]),
            ({"points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 5, 0]]}, ["points"]),
            ({"points": [*CUBE, [1.0, 0.0, 1.0]]}, ["points", 8]),
            ({"points": [[0, 0], [1, 0], [0, 1], [1, 0]]}, ["points", 3]),
        ],
    )
    def test_bad_points_are_422_naming_them(self, client, params, loc):
        r = submit(client, "delaunay", params)
        assert_problem(r, 422, ["body", "params", *loc])

    def test_nan_is_422(self, client):
        body = '{"method": "delaunay", "params": {"points": [[0, 0], [1, 0], [NaN, 1]]}}'
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert r.status_code == 422

    def test_cube_tetrahedra_and_hull(self, client):
        res = finished(client, {"points": CUBE})
        mesh = io.from_json(res["mesh"])
        assert [b.type for b in mesh.cells] == ["tetra", "triangle"]
        p, t = mesh.points, mesh.cells[0].data
        assert (orient3d(p[t[:, 0]], p[t[:, 1]], p[t[:, 2]], p[t[:, 3]]) == 1).all()
        a, b, c, d = (p[t[:, i]] for i in range(4))
        vol = np.einsum("ij,ij->i", a - d, np.cross(b - d, c - d)).sum() / 6
        assert vol == pytest.approx(1.0, rel=1e-12)
        hull = mesh.cells[1].data
        assert len(hull) == 12  # two triangles per face of the cube
        assert (orient3d(p[hull[:, 0]], p[hull[:, 1]], p[hull[:, 2]], [0.5, 0.5, 0.5]) == 1).all()
        assert [len(s) for s in mesh.cell_sets["hull"]] == [0, 12]
        assert res["stats"]["tetrahedra"] == len(t) and res["stats"]["hull_facets"] == 12
        assert res["stats"]["points"] == 8 and res["stats"]["seconds"] >= 0

    def test_random_points_3d_downloadable(self, client):
        p = np.random.default_rng(0).random((300, 3)).round(6)
        res = finished(client, {"points": p.tolist()})
        mesh = io.from_json(res["mesh"])
        t = mesh.cells[0].data
        a, b, c, d = (mesh.points[t[:, i]] for i in range(4))
        vol = np.einsum("ij,ij->i", a - d, np.cross(b - d, c - d)).sum() / 6
        assert vol == pytest.approx(ConvexHull(p).volume, rel=1e-12)
        r = client.get(f"/v1/jobs/{res['_id']}/result", params={"format": "gmsh"})
        assert r.status_code == 200, r.text
        back = io.from_bytes(r.content, "gmsh")
        assert sorted(back.cell_sets) == ["hull"]

    def test_square_2d(self, client):
        pts = [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]
        res = finished(client, {"points": pts})
        mesh = io.from_json(res["mesh"])
        assert [b.type for b in mesh.cells] == ["triangle", "line"]
        p, t = mesh.points, mesh.cells[0].data
        assert len(t) == 4 and (orient2d(p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]) == 1).all()
        hull = mesh.cells[1].data
        assert len(hull) == 4
        # counter-clockwise around the hull: the centre is left of every edge
        assert (orient2d(p[hull[:, 0]], p[hull[:, 1]], [0.5, 0.5]) == 1).all()
        assert res["stats"]["triangles"] == 4

    def test_example_and_listing(self, client):
        res = finished(client, DELAUNAY_EXAMPLE)
        assert res["stats"]["tetrahedra"] == 2
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        assert "points" in methods["delaunay"]["params_schema"]["properties"]
