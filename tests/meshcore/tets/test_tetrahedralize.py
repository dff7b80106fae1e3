"""tetrahedralize: facts a user can check on the tetrahedra of closed surfaces."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from meshcore.domain import parse_surface
from meshcore.errors import InputError
from meshcore.geometry.predicates3d import orient3d
from meshcore.mesh import io
from meshcore.mesh.topology import unique_edges, unique_ints
from meshcore.tets import tetra_dihedral_angles, tetra_radius_edge, tetrahedralize
from tests.meshcore.domain import shapes


def two(P1, T1, P2, T2):
    return np.concatenate([P1, P2]), np.concatenate([T1, np.asarray(T2) + len(P1)])


def cavity_box():
    return two(*shapes.box((0, 0, 0), (3, 3, 3), 2), *shapes.box((1, 1, 1), (2, 2, 2)))


SHAPES = {
    "cube": shapes.box,
    "icosphere": lambda: shapes.icosphere(1),
    "torus": lambda: shapes.torus(nu=10, nv=5),
    "box_with_cavity": cavity_box,
    "l_block": shapes.l_block,
    "thin_slab": lambda: shapes.box((0, 0, 0), (1, 1, 0.01)),
    "schonhardt": shapes.schonhardt,
}


#: ``left``'s counts by cause when nothing is left.
NONE_LEFT = {"fold": 0, "surface": 0, "interior": 0, "input_angle": 0}


def faces_of(tetra: np.ndarray) -> np.ndarray:
    f = tetra[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3)
    return np.sort(f, axis=1)


def tri_area(P, F):
    return 0.5 * np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]), axis=1)


def assert_valid(result, surface, *, exact_boundary=False):
    """The facts of the issue, checked exactly where they are signs or counts."""
    P = result.mesh.points
    K = result.mesh.cells[0].data
    assert result.mesh.cells[0].type == "tetra"
    # Every tetrahedron positively oriented (meshio order: orient3d < 0 in Shewchuk's sign).
    assert (orient3d(P[K[:, 0]], P[K[:, 1]], P[K[:, 2]], P[K[:, 3]]) < 0).all()
    # Volumes add up to the enclosed volume.
    a = P[K[:, 0]]
    vol = np.einsum("ij,ij->i", P[K[:, 1]] - a, np.cross(P[K[:, 2]] - a, P[K[:, 3]] - a)) / 6
    assert math.fsum(vol.tolist()) == pytest.approx(surface.volume, rel=1e-12)
    # No face shared by more than two tetrahedra; the faces held once are the boundary.
    keys, counts = np.unique(faces_of(K), axis=0, return_counts=True)
    assert counts.max() <= 2
    boundary = keys[counts == 1]
    sub = np.unique(np.sort(result.boundary_faces, axis=1), axis=0)
    assert np.array_equal(boundary, sub)
    # The boundary faces tile every input triangle: areas per facet (the input
    # triangles joined across exactly coplanar edges), each face's source
    # triangle in its facet.
    src = result.boundary_source
    facet = result.triangle_facet
    first = surface.vertices
    remap = np.full(len(surface.points), -1)
    remap[first] = np.arange(len(first))
    T = remap[surface.triangles]
    n_facets = facet.max() + 1
    area = np.bincount(facet[src], weights=tri_area(P, result.boundary_faces), minlength=n_facets)
    assert np.allclose(area, np.bincount(facet, weights=tri_area(P, T)), rtol=1e-12, atol=0)
    # A facet's triangles are exactly coplanar: every face lies in its source's plane
    # (its input vertices exactly, the points added up to rounding).
    a, b, c = (P[T[src, k]] for k in range(3))
    nrm = np.cross(b - a, c - a)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    for k in range(3):
        off = np.einsum("ij,ij->i", P[result.boundary_faces[:, k]] - a, nrm)
        assert np.abs(off).max() <= 1e-12 * np.abs(P).max()
    if exact_boundary:
        assert np.array_equal(np.sort(result.boundary_faces, axis=1), np.sort(T, axis=1))
    # Each boundary face lies in its input triangle's plane (exactly, for input vertices).
    # Cell sets: one per region, together every tetrahedron once.
    sets = result.mesh.cell_sets
    ids = np.concatenate([sets[f"region_{r}"][0] for r in range(surface.region_count)])
    assert np.array_equal(np.sort(ids), np.arange(len(K)))


class TestRecovery:
    @pytest.mark.parametrize("name", sorted(SHAPES))
    def test_empty_tetrahedralization(self, name):
        s = parse_surface(*SHAPES[name]())
        r = tetrahedralize(s, empty=True)
        assert_valid(r, s)
        assert r.interior_points_added == 0

    def test_convex_delaunay_surface_needs_no_point(self):
        s = parse_surface(*shapes.icosphere(2))
        r = tetrahedralize(s, empty=True)
        assert r.surface_points_added == 0
        assert_valid(r, s, exact_boundary=True)

    def test_cavity_and_island_regions(self):
        P, T = cavity_box()
        P, T = two(P, T, *shapes.box((1.25, 1.25, 1.25), (1.75, 1.75, 1.75)))
        s = parse_surface(P, T)
        r = tetrahedralize(s, empty=True)
        assert_valid(r, s)
        vol = np.zeros(2)
        K = r.mesh.cells[0].data
        X = r.mesh.points
        a = X[K[:, 0]]
        v = np.einsum("ij,ij->i", X[K[:, 1]] - a, np.cross(X[K[:, 2]] - a, X[K[:, 3]] - a)) / 6
        np.add.at(vol, r.region, v)
        assert vol.tolist() == pytest.approx([26.0, 0.125], rel=1e-12)

    def test_translated_and_scaled(self):
        P, T = shapes.l_block()
        base = tetrahedralize(parse_surface(P, T), empty=True)
        # Translations by 1e6 and scalings by 1e-6 round the added points
        # differently (the tetrahedra may differ) but every fact holds; an
        # exact power-of-two scaling changes nothing.
        for Q in (P + 1e6, P * 1e-6):
            s = parse_surface(Q, T)
            assert_valid(tetrahedralize(s, empty=True), s)
        r = tetrahedralize(parse_surface(P * 2.0**-20, T), empty=True)
        assert np.array_equal(r.mesh.cells[0].data, base.mesh.cells[0].data)


class TestKeepBoundary:
    def test_schonhardt_prism_takes_exactly_one_interior_point(self):
        s = parse_surface(*shapes.schonhardt())
        r = tetrahedralize(s, keep_boundary=True)
        assert r.interior_points_added == 1 and r.surface_points_added == 0
        assert len(r.mesh.cells[0].data) == 8
        assert_valid(r, s, exact_boundary=True)

    def test_cube(self):
        s = parse_surface(*shapes.box())
        r = tetrahedralize(s, keep_boundary=True)
        assert r.surface_points_added == 0 and r.interior_points_added <= 1
        assert_valid(r, s, exact_boundary=True)

    @pytest.mark.parametrize("name", ["torus", "box_with_cavity"])
    def test_not_star_shaped(self, name):
        """Recovery's surface points are lifted inside: the input triangles are the faces."""
        s = parse_surface(*SHAPES[name]())
        r = tetrahedralize(s, keep_boundary=True)
        assert r.surface_points_added == 0 and r.interior_points_added > 0
        assert len(r.mesh.points) == len(s.vertices) + r.interior_points_added
        assert_valid(r, s, exact_boundary=True)

    def test_not_star_shaped_translated_and_scaled(self):
        """Every fact holds after a translation by 1e6 or a scaling by 1e-6 (the points
        added round differently); a power-of-two scaling changes nothing."""
        P, T = SHAPES["torus"]()
        base = tetrahedralize(parse_surface(P, T), keep_boundary=True)
        for Q in (P + 1e6, P * 1e-6):
            s = parse_surface(Q, T)
            r = tetrahedralize(s, keep_boundary=True)
            assert r.surface_points_added == 0
            assert_valid(r, s, exact_boundary=True)
        r = tetrahedralize(parse_surface(P * 2.0**-20, T), keep_boundary=True)
        assert np.array_equal(r.mesh.cells[0].data, base.mesh.cells[0].data)
        assert np.array_equal(r.mesh.points, base.mesh.points * 2.0**-20)

    def test_schonhardt_prism_lifted(self, monkeypatch):
        """The lifting path on the prism (its star-shaped cone switched off)."""
        from meshcore.tets import refinement

        monkeypatch.setattr(refinement, "_cone", lambda b, n: None)
        s = parse_surface(*shapes.schonhardt(45.0))
        r = tetrahedralize(s, keep_boundary=True)
        assert r.surface_points_added == 0 and r.interior_points_added > 0
        assert_valid(r, s, exact_boundary=True)


class TestRefinement:
    @pytest.mark.parametrize("name", ["cube", "icosphere", "box_with_cavity", "l_block", "torus"])
    def test_radius_edge_and_dihedral_bounds(self, name):
        """max_radius_edge 2 and min_dihedral 15 hold except where ``left`` names the cause.

        No exception on these shapes: on the torus the tetrahedra on the four
        corners of a trapezoid whose two input triangles are coplanar up to
        rounding (flat folds) are dropped, the surface taking their other two
        faces (``triangle_facet`` reports the two triangles as one facet).
        """
        s = parse_surface(*SHAPES[name]())
        r = tetrahedralize(s, max_radius_edge=2.0, min_dihedral=15)
        assert_valid(r, s)
        assert r.given_up == 0
        P, K = r.mesh.points, r.mesh.cells[0].data
        ratio = tetra_radius_edge(P, K)
        dih = tetra_dihedral_angles(P, K).min(axis=1)
        left = r.left
        assert left["radius_edge_above"] == NONE_LEFT
        assert (ratio <= 2.0 + 1e-9).all()
        below = left["dihedral_below"]
        assert below["surface"] == below["interior"] == 0
        assert (dih < 15).sum() == below["fold"] == 0
        assert left["worst"][0]["min_dihedral"] == pytest.approx(dih.min(), abs=1e-4)

    def test_thin_slab_radius_edge(self):
        """A strip 1 x 0.1 x 0.01 (aspect 100): its two large faces are thin facets,
        refined first to twice their feature size (the thickness).

        Before, the radius-edge refinement of such slabs cascaded on the side
        strips (the 1 x 1 x 0.01 slab: over 50k points, not finished in 300 s;
        it now takes 24k tetrahedra, ``benchmarks/tetrahedralize.py``).
        """
        s = parse_surface(*shapes.box((0, 0, 0), (1, 0.1, 0.01)))
        r = tetrahedralize(s, max_radius_edge=2.0)
        assert_valid(r, s)
        assert r.given_up == 0
        assert r.left["radius_edge_above"] == NONE_LEFT
        assert r.surface_points_added + r.interior_points_added < 2_000

    def test_torus_radius_edge_points(self):
        """The 32 x 16 torus at radius-edge 2: 188 points added (938 when the splits a
        rejected centre asks for were made for tetrahedra the round's insertions had
        destroyed, and flat folds were refined; TetGen ``-pq2`` adds 27)."""
        s = parse_surface(*shapes.torus(nu=32, nv=16))
        r = tetrahedralize(s, max_radius_edge=2.0)
        assert_valid(r, s)
        assert r.given_up == 0
        assert r.left["radius_edge_above"] == NONE_LEFT
        assert r.surface_points_added + r.interior_points_added < 300

    def test_size_and_volume(self):
        s = parse_surface(*shapes.box())
        r = tetrahedralize(s, size=0.25, max_radius_edge=None)
        assert_valid(r, s)
        P, K = r.mesh.points, r.mesh.cells[0].data
        e = P[K[:, [0, 0, 0, 1, 1, 2]]] - P[K[:, [1, 2, 3, 2, 3, 3]]]
        assert np.sqrt((e**2).sum(-1)).max() < 0.25 * 2
        r = tetrahedralize(s, max_volume=0.01, max_radius_edge=None)
        assert_valid(r, s)
        a = r.mesh.points[r.mesh.cells[0].data]
        v = (
            np.abs(
                np.einsum(
                    "ij,ij->i", a[:, 1] - a[:, 0], np.cross(a[:, 2] - a[:, 0], a[:, 3] - a[:, 0])
                )
            )
            / 6
        )
        assert v.max() <= 0.01

    def test_min_dihedral_is_reported(self):
        s = parse_surface(*shapes.box())
        r = tetrahedralize(s, size=0.5, max_radius_edge=None, min_dihedral=15)
        assert_valid(r, s)
        d = tetra_dihedral_angles(r.mesh.points, r.mesh.cells[0].data)
        assert d.shape == (len(r.mesh.cells[0].data), 6)
        # With size alone (no radius-edge bound) the sliver pass reaches the bound too.
        assert 15 <= d.min() <= d.max() < 180
        assert r.left["dihedral_below"] == NONE_LEFT

    def test_bad_parameters(self):
        s = parse_surface(*shapes.box())
        for kw in (
            {"max_radius_edge": 1.0},
            {"size": -1},
            {"min_dihedral": 80},
            {"max_volume": math.nan},
        ):
            with pytest.raises(InputError) as info:
                tetrahedralize(s, **kw)
            assert info.value.code == "bad_parameter"
            assert info.value.errors[0]["loc"] == [next(iter(kw))]

    def test_dict_input_and_its_errors(self):
        P, T = shapes.box()
        r = tetrahedralize({"points": P.tolist(), "triangles": T.tolist()}, empty=True)
        assert len(r.mesh.cells[0].data) > 0
        with pytest.raises(InputError) as info:
            tetrahedralize({"points": P.tolist(), "triangles": T[1:].tolist()})
        assert info.value.code == "open_edge"
        assert info.value.errors[0]["loc"][:2] == ["surface", "triangles"]


def test_dihedral_angles_of_the_regular_tetrahedron():
    P = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    d = tetra_dihedral_angles(P, np.array([[0, 1, 2, 3]]))
    assert d == pytest.approx(np.full((1, 6), math.degrees(math.acos(1 / 3))))


# ---------------------------------------------------------------------------
# Hypothesis: star-shaped polyhedra
# ---------------------------------------------------------------------------


def star(n: int, seed: int):
    rng = np.random.default_rng(seed)
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(n, 3))])
    return shapes.star(rng.uniform(0.6, 1.4, size=len(d)), d)


@st.composite
def star_polyhedra(draw):
    return star(draw(st.integers(6, 30)), draw(st.integers(0, 2**31 - 1)))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(star_polyhedra())
# Sharp vertices (corners of 8.8 degrees, dihedral angles of 23) where `empty`'s recovery
# split ever nearer the vertex without protecting balls: 200 rounds in 38 s (13637), two
# points coinciding in a facet's plane (60, 110).
@example(star(29, 13637))
@example(star(30, 60))
@example(star(30, 110))
def test_star_shaped_polyhedra(surf):
    P, T = surf
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    if (np.einsum("ij,ij->i", a, np.cross(b, c)) <= 1e-9).any():
        return  # a face plane through the centre: not strictly star-shaped
    s = parse_surface(P, T)
    assert_valid(tetrahedralize(s, empty=True), s)
    r = tetrahedralize(s, keep_boundary=True)
    assert_valid(r, s, exact_boundary=True)
    assert r.surface_points_added == 0 and r.interior_points_added <= 1


def star_by_seed(seed: int):
    """The star polyhedron of ``seed`` in ``benchmarks/robustness3d.py`` (radii 0.5 to 1.5)."""
    first = np.random.default_rng(seed)
    n, inner = int(first.integers(6, 31)), int(first.integers(0, 2**31 - 1))
    rng = np.random.default_rng(inner)
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(n, 3))])
    return shapes.star(rng.uniform(0.5, 1.5, size=len(d)), d)


def test_small_input_angles_are_left_and_named():
    """Seed 16 of ``benchmarks/robustness3d.py``: sharp vertices (segments 25 degrees
    apart on different facets, dihedral angles down to 23 degrees).

    Before the protecting balls (``meshcore.tets.angles``) the refinement split
    ever nearer input vertex 2 (points 1e-15 from it) until two points coincided
    in a facet's plane (``recovery_failed``). Now: a valid mesh, no added point
    near an input vertex, and every tetrahedron above the bound counted by cause,
    those skinny because of the input named by place.
    """
    s = parse_surface(*star_by_seed(16))
    r = tetrahedralize(s, max_radius_edge=2.0)
    assert_valid(r, s)
    P, K = r.mesh.points, r.mesh.cells[0].data
    above = tetra_radius_edge(P, K) > 2.0
    left = r.left["radius_edge_above"]
    assert above.sum() == sum(left.values())
    places = r.left["input_angles"]
    assert left["input_angle"] == sum(p["tetrahedra"] for p in places) > 0
    # Since the subface renumbering fix the mesh is no longer over-refined (826
    # tetrahedra, was 3,712 of which many from wrongly split subfaces): every one
    # left above the bound is there because of the input's angles, in a small mesh.
    assert sum(left.values()) == left["input_angle"]
    assert len(K) < 1500
    n = len(s.vertices)
    d = np.linalg.norm(P[n:, None] - P[None, :n], axis=2).min()
    edges = np.linalg.norm(P[s.triangles[:, 0]] - P[s.triangles[:, 1]], axis=1)
    assert d > 1e-3 * edges.min()


def wedge(degrees: float):
    """A unit prism over a triangle with a corner of ``degrees``: its edge 0-3 has that
    interior dihedral angle."""
    a = math.radians(degrees)
    c = [(0, 0), (1, 0), (math.cos(a), math.sin(a))]
    P = np.array([(x, y, 0.0) for x, y in c] + [(x, y, 1.0) for x, y in c])
    T = [[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]]
    return P, np.array(T)


@pytest.mark.parametrize(
    "case, sharp, most",
    [("wedge", [0, 3], 1_000), ("star_3264", [2, 26], 10_000)],
)
def test_sharp_edges_are_protected(case, sharp, most):
    """Input edges of a small dihedral angle get protecting cylinders
    (``meshcore.tets.angles.protecting_cylinders``).

    Star seed 3264 of ``benchmarks/robustness3d.py`` has an edge of 13 degrees
    (vertices 2 and 26) and one of 349.5 (3 and 12: two facets 10.5 degrees apart
    across a slot outside). Without the cylinders it took 307 CPU s and 1,027,890
    tetrahedra; now about 2,300 (TetGen ``-pq2``: 172), and the tetrahedra left
    above the ratio are counted, nearly all because of a named input angle, the
    sharp edge among them. The 5-degree wedge: every one left is named.
    """
    s = parse_surface(*(wedge(5.0) if case == "wedge" else star_by_seed(3264)))
    r = tetrahedralize(s, max_radius_edge=2.0)
    assert_valid(r, s)
    P, K = r.mesh.points, r.mesh.cells[0].data
    assert len(K) < most
    above = tetra_radius_edge(P, K) > 2.0
    left = r.left["radius_edge_above"]
    assert above.sum() == sum(left.values())
    places = r.left["input_angles"]
    assert left["input_angle"] == sum(p["tetrahedra"] for p in places)
    assert any(p.get("segment") == sharp for p in places)
    if case == "wedge":
        assert left["input_angle"] == above.sum()
    else:
        assert sum(left.values()) - left["input_angle"] < 0.05 * left["input_angle"]


# ---------------------------------------------------------------------------
# Downstream: file formats and a finite element solve
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("fmt, ext", [("gmsh", ".msh"), ("gmsh22", ".msh"), ("vtu", ".vtu")])
def test_download_formats_open_in_meshio(tmp_path, fmt, ext):
    import meshio

    s = parse_surface(*cavity_box())
    r = tetrahedralize(s, empty=True)
    path = tmp_path / f"mesh{ext}"
    path.write_bytes(io.to_bytes(r.mesh, fmt))
    m = meshio.read(path)
    assert m.cells_dict["tetra"].shape == r.mesh.cells[0].data.shape
    if fmt.startswith("gmsh"):
        assert "region_0" in m.cell_sets or "gmsh:physical" in m.cell_data


def test_poisson_converges():
    """P1 tetrahedra, -Δu = 3π² u with u = sin πx sin πy sin πz, exact boundary values:
    the max-norm error at the nodes falls as h², h the mesh's mean edge length.

    The rate is the least-squares slope of log error against log h over the
    sizes 0.25, 0.125 and 0.0625, required in [1.8, 2.25]. A factor 4 in
    size: error / h² moves by about 20 % from mesh to mesh (a node whose star
    happens to be irregular), which over one halving alone moved the rate by
    0.1 to 0.2. h is measured, not the ``size`` asked: as ``size`` halves the
    mean edge shrinks by 1.93 then 1.96 and the points grow 5.8 then 6.7
    times (the surface's share falls), so the slope against ``size`` reads
    1.80 and against N^(-1/3) 2.05; against h, 1.88. With the former round of
    perturbed insertion before the sliver improvement, 1.91, and 1.83 to 1.96
    over 8 seeds of its random candidates; there, over 13 sizes from 0.25 to
    0.031, error / h² stayed within 1.15 to 1.74 and the slope over the finer
    half was 2.04.
    """
    from skfem import (
        Basis,
        ElementTetP1,
        LinearForm,
        MeshTet,
        asm,
        condense,
        solve,
        solver_iter_pcg,
    )
    from skfem.models.poisson import laplace

    @LinearForm
    def rhs(v, w):
        x, y, z = w.x
        return 3 * np.pi**2 * np.sin(np.pi * x) * np.sin(np.pi * y) * np.sin(np.pi * z) * v

    s = parse_surface(*shapes.box())
    h, errors = [], []
    for size in (0.25, 0.125, 0.0625):
        r = tetrahedralize(s, size=size, max_radius_edge=None, min_dihedral=15)
        P, K = r.mesh.points, r.mesh.cells[0].data
        basis = Basis(MeshTet(P.T.copy(), K.T.copy()), ElementTetP1())
        exact = np.sin(np.pi * P[:, 0]) * np.sin(np.pi * P[:, 1]) * np.sin(np.pi * P[:, 2])
        D = unique_ints(r.boundary_faces)  # the nodes on the surface
        system = condense(asm(laplace, basis), asm(rhs, basis), x=exact, D=D)
        u = solve(*system, solver=solver_iter_pcg(rtol=1e-12))
        errors.append(np.abs(u - exact).max())
        edges = unique_edges(K, "tetra")[0]
        h.append(np.linalg.norm(P[edges[:, 0]] - P[edges[:, 1]], axis=1).mean())
    rate = np.polyfit(np.log(h), np.log(errors), 1)[0]
    assert 1.8 <= rate <= 2.25, (rate, h, errors)
