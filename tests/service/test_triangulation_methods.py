"""The ``delaunay_admissible`` method (§9.1.2-§9.1.5) through the API of a live server.

Failure cases first: bad domains and curves are refused with 422 before the
job is queued, naming the ring and vertex or the field.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from service.methods.surface_schema import UNIT_CUBE
from service.methods.triangulation import DELAUNAY_ADMISSIBLE_EXAMPLE
from tests.service.test_jobs import assert_problem, submit

SQUARE = [[0, 0], [4, 0], [4, 4], [0, 4]]


def finished(c, params: dict) -> dict:
    r = submit(c, "delaunay_admissible", params, wait=30)
    assert r.status_code == 200, r.text
    job = r.json()
    assert job["status"] == "succeeded", job
    return c.get(f"/v1/jobs/{job['id']}/result").json()


def polygon(*rings) -> dict:
    return {"domain": {"type": "Polygon", "coordinates": [list(r) for r in rings]}}


def signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = points[triangles]
    return 0.5 * (
        (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
        - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    )


class TestDelaunayAdmissible:
    @pytest.mark.parametrize(
        ("params", "loc"),
        [
            # A bow tie: ring 0 crosses itself.
            (polygon([[0, 0], [2, 2], [2, 0], [0, 2]]), ["coordinates", 0, 0]),
            # Ring 1 (a hole) lies outside ring 0: its vertex 0 is named.
            (polygon(SQUARE, [[5, 5], [6, 5], [6, 6]]), ["coordinates", 1, 0]),
            # Two points make no ring.
            (polygon([[0, 0], [1, 0]]), ["coordinates", 0]),
            # Vertex 2 repeats vertex 1.
            (polygon([[0, 0], [4, 0], [4, 0], [4, 4], [0, 4]]), ["coordinates", 0, 2]),
        ],
        ids=["self-intersection", "hole-outside", "two-points", "duplicate-vertex"],
    )
    def test_bad_domains_are_422_naming_ring_and_vertex(self, client, params, loc):
        r = submit(client, "delaunay_admissible", params)
        assert_problem(r, 422, ["body", "params", "domain", *loc])

    def test_nan_is_422_naming_the_coordinate(self, client):
        body = json.dumps({"method": "delaunay_admissible", "params": polygon(SQUARE)}).replace(
            "[4, 4]", "[4, NaN]"
        )
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422, ["body", "params", "domain", "coordinates", 0, 2, 1])

    @pytest.mark.parametrize(
        ("curve", "loc"),
        [
            ({"ring": 3, "center": [2, 2], "radius": 1}, ["ring"]),
            ({"ring": 1, "center": [2, 2], "radius": -1}, ["radius"]),
            ({"ring": 1, "center": [2, 2], "radius": 0.9}, ["radius"]),
        ],
        ids=["no-such-ring", "negative-radius", "points-off-the-circle"],
    )
    def test_bad_curves_are_422_naming_the_field(self, client, curve, loc):
        hole = [[2 + math.cos(a), 2 + math.sin(a)] for a in np.linspace(0, 6, 12)]
        params = {**polygon(SQUARE, hole), "curves": [{"type": "circle", **curve}]}
        r = submit(client, "delaunay_admissible", params)
        assert_problem(r, 422, ["body", "params", "curves", 0, *loc])

    def test_the_example_gets_its_spikes_split(self, client):
        # The three-pointed star with 5° tips: each long side is encroached
        # by the short side's end and split once.
        res = finished(client, DELAUNAY_ADMISSIBLE_EXAMPLE)
        dom, mesh, stats = res["domain"], res["mesh"], res["stats"]
        assert stats["points_added"] == 3 and stats["input_segments"] == 9
        assert len(dom["segments"]) == 12 == stats["segments"]
        assert sorted(set(dom["source"])) == list(range(9)) and set(dom["ring"]) == {0}
        assert sum(stats["cases_before"].values()) == 9
        assert sum(stats["cases_after"].values()) == 12
        points = np.asarray(mesh["points"])
        (block,) = mesh["cells"]
        triangles = np.asarray(block["data"])
        assert block["type"] == "triangle" and len(triangles) == stats["triangles"]
        # Every output segment is a triangle edge, domain on its left.
        directed = {(int(t[i]), int(t[(i + 1) % 3])) for t in triangles for i in range(3)}
        assert all(tuple(s) in directed for s in dom["segments"])
        ring = np.asarray(DELAUNAY_ADMISSIBLE_EXAMPLE["domain"]["coordinates"][0])
        x, y = ring[:, 0], ring[:, 1]
        area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        a = signed_areas(points, triangles)
        assert a.min() > 0 and math.isclose(a.sum(), area, rel_tol=1e-12)

    def test_points_added_on_a_declared_circle_lie_on_it(self, client):
        # A square with an unevenly sampled circular hole and an island in
        # the hole: the island's points encroach chords of the hole, which
        # are split on the circle.
        theta = np.r_[
            np.linspace(0, np.pi / 2, 12, endpoint=False),
            np.linspace(np.pi / 2, 2 * np.pi, 7, endpoint=False),
        ]
        hole = np.c_[0.5 + 0.45 * np.cos(theta), 0.5 + 0.45 * np.sin(theta)].tolist()
        t = np.arange(8) / 8  # the square sampled every 1/8
        square = np.r_[
            np.c_[t, 0 * t], np.c_[1 + 0 * t, t], np.c_[1 - t, 1 + 0 * t], np.c_[0 * t, 1 - t]
        ]
        square = square.tolist()
        island = [[0.3, 0.3], [0.5, 0.25], [0.5, 0.4], [0.3, 0.5]]
        params = {
            "domain": {"type": "MultiPolygon", "coordinates": [[square, hole], [island]]},
            "curves": [{"ring": 1, "type": "circle", "center": [0.5, 0.5], "radius": 0.45}],
        }
        res = finished(client, params)
        points = np.asarray(res["domain"]["points"])
        added = points[32 + 19 + 4 :]
        assert len(added) == res["stats"]["points_added"] > 0
        radius = np.hypot(added[:, 0] - 0.5, added[:, 1] - 0.5)
        np.testing.assert_allclose(radius, 0.45, rtol=1e-12)
        # Only chords of the hole (ring 1, segments 32 to 50) were split.
        split = np.bincount(res["domain"]["source"]) > 1
        assert split[32 : 32 + 19].any() and not split[:32].any() and not split[51:].any()
        pieces = np.asarray(res["domain"]["ring"])[
            np.isin(res["domain"]["source"], np.flatnonzero(split))
        ]
        assert set(pieces) == {1}

    def test_a_vertex_within_rounding_of_a_segment_fails_the_job_at_its_vertex(self, client):
        # Vertex 3 (0.25, 0.5) is on segment 4 in exact rationals, off it by
        # rounding: valid, but no split point between them exists in float64
        # (an AlgorithmError, a 500, before).
        ring = (np.array([[9, 6], [14, 7], [2, 2], [5, 10], [2, 13]]) / 20).tolist()
        job = submit(client, "delaunay_admissible", polygon(ring), wait=30).json()
        assert job["status"] == "failed" and job["error"]["status"] == 422, job
        assert ["params", "domain", "coordinates", 0, 3] in [
            e["loc"] for e in job["error"]["errors"]
        ]

    def test_the_method_is_listed_with_its_section(self, client):
        methods = {m["name"]: m for m in client.get("/v1/methods").json()}
        spec = methods["delaunay_admissible"]
        assert "§9.1" in spec["section"]
        assert spec["example"] == DELAUNAY_ADMISSIBLE_EXAMPLE
        assert {"domain", "segments", "curves"} <= set(spec["params_schema"]["properties"])


# ---------------------------------------------------------------------------
# The surface form (§9.2-§9.3.5)
# ---------------------------------------------------------------------------


class TestDelaunayAdmissibleSurface:
    def test_schonhardt_prism_comes_back_admissible(self, client):
        from meshcore.delaunay.kernel3d import delaunay3d
        from tests.meshcore.domain.shapes import schonhardt

        P, T = schonhardt()
        res = finished(client, {"surface": {"points": P.tolist(), "triangles": T.tolist()}})
        surf, stats = res["surface"], res["stats"]
        points = np.asarray(surf["points"])
        tri = np.asarray(surf["triangles"])
        assert stats["input_triangles"] == 8 and stats["points_added"] == len(points) - 6 > 0
        assert len(tri) == stats["triangles"] == len(surf["source"])
        assert sorted(set(surf["source"])) == list(range(8))
        faces = delaunay3d(points).tetra[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]]
        have = {tuple(sorted(f)) for f in faces.reshape(-1, 3).tolist()}
        assert all(tuple(sorted(t)) in have for t in tri.tolist())
        (block,) = res["mesh"]["cells"]
        assert block["type"] == "tetra" and len(block["data"]) == stats["tetrahedra"]

    def test_a_cube_comes_back_with_no_point(self, client):
        # The cube's 8 corners are co-spherical: the kernel's symbolic
        # perturbation misses some face diagonals; each square (two exactly
        # coplanar triangles, one facet) is swapped in its plane instead of
        # split (§9.3.2), and the result carries the Delaunay tetrahedralization
        # (whole hull) and which rows are inside (the mesh).
        from meshcore.delaunay.kernel3d import delaunay3d
        from meshcore.geometry.predicates3d import insphere, orient3d

        res = finished(client, {"surface": UNIT_CUBE})
        surf, stats, dt = res["surface"], res["stats"], res["delaunay"]
        P = np.asarray(surf["points"], dtype=float)
        tri = np.asarray(surf["triangles"])
        T = np.asarray(dt["tetrahedra"])
        assert stats["points_added"] == 0 and len(P) == 8 and len(tri) == 12
        assert len(dt["ties"]) == stats["tie_tetrahedra"]
        assert len(T) == stats["delaunay_tetrahedra"] and set(dt["ties"]) <= set(range(len(T)))
        # positively oriented (meshio order: a, b, d, c for orient3d), filling the cube
        assert (orient3d(P[T[:, 0]], P[T[:, 1]], P[T[:, 3]], P[T[:, 2]]) != 0).all()
        e1, e2, e3 = (P[T[:, k]] - P[T[:, 0]] for k in (1, 2, 3))
        vol = np.einsum("ij,ij->i", np.cross(e1, e2), e3) / 6
        assert (vol > 0).all() and math.isclose(vol.sum(), 1.0, rel_tol=1e-12)
        # Delaunay, exactly: no point strictly inside any circumsphere
        a, b, c, d = (np.repeat(P[T[:, k]], 8, axis=0) for k in (0, 1, 3, 2))
        assert (insphere(a, b, c, d, np.tile(P, (len(T), 1))) <= 0).all()
        faces = {tuple(sorted(f)) for f in T[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]]
                 .reshape(-1, 3).tolist()}  # fmt: skip
        assert all(tuple(sorted(t)) in faces for t in tri.tolist())
        if stats["tie_cells"] == 0:  # the kernel's own tetrahedralization
            kernel = delaunay3d(P).tetra[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]]
            have = {tuple(sorted(f)) for f in kernel.reshape(-1, 3).tolist()}
            assert all(tuple(sorted(t)) in have for t in tri.tolist())
        (block,) = res["mesh"]["cells"]
        assert block["data"] == T[dt["inside"]].tolist() and len(dt["inside"]) == len(T)

    @pytest.mark.parametrize(
        ("params", "loc"),
        [
            ({"surface": {**UNIT_CUBE, "triangles": UNIT_CUBE["triangles"][1:]}}, ["surface"]),
            ({"surface": {**UNIT_CUBE, "points": UNIT_CUBE["points"][:2]}}, ["surface"]),
            ({"surface": UNIT_CUBE, **polygon(SQUARE)}, []),
            ({}, []),
            ({"surface": UNIT_CUBE, "curves": []}, []),
        ],
        ids=["open-surface", "two-points", "both-inputs", "no-input", "curves-with-surface"],
    )
    def test_bad_surfaces_are_422(self, client, params, loc):
        r = submit(client, "delaunay_admissible", params)
        assert_problem(r, 422, ["body", "params", *loc])

    def test_nan_in_a_surface_is_422(self, client):
        body = json.dumps({"method": "delaunay_admissible", "params": {"surface": UNIT_CUBE}})
        body = body.replace("[1, 1, 1]", "[1, NaN, 1]")
        r = client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
        assert_problem(r, 422, ["body", "params", "surface", "points", 7, 1])
