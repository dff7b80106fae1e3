"""Edges, faces, incidence, boundary and conformity on meshes small enough to count by hand."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshcore.errors import InputError
from meshcore.mesh import CellBlock, Mesh, topology
from meshcore.mesh.quality import signed_area, signed_volume


def quad_grid(nx: int = 2, ny: int = 2) -> Mesh:
    """A structured grid of counterclockwise unit quads; for 2 x 2::

    6---7---8
    | 2 | 3 |
    3---4---5
    | 0 | 1 |
    0---1---2
    """
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0))
    ids = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    cells = np.column_stack(
        [ids[:-1, :-1].ravel(), ids[:-1, 1:].ravel(), ids[1:, 1:].ravel(), ids[1:, :-1].ravel()]
    )
    return Mesh(np.column_stack([x.ravel(), y.ravel()]), (CellBlock("quad", cells),))


def hex_grid(n: int = 2) -> Mesh:
    """``n x n x n`` unit hexahedra in meshio order (bottom 0-3 counterclockwise, top 4-7)."""
    g = np.arange(n + 1.0)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    ids = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)

    def c(i: int, j: int, k: int) -> np.ndarray:
        return ids[i : n + i, j : n + j, k : n + k].ravel()

    cells = np.column_stack([c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0)] + [
        c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)
    ])  # fmt: skip
    return Mesh(
        np.column_stack([x.ravel(), y.ravel(), z.ravel()]), (CellBlock("hexahedron", cells),)
    )


def fan_of_three() -> Mesh:
    """Three triangles on the edge 0-1 (a book with three pages: non-manifold)::

    2   3 (above the plane)   4
     \\  |                   /
      0=====================1
    """
    points = [[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, 0, 1], [0.5, -1, 0]]
    return Mesh(
        np.array(points, float), (CellBlock("triangle", [[0, 1, 2], [0, 1, 3], [0, 1, 4]]),)
    )


class TestUniqueEdges:
    def test_two_triangles(self) -> None:
        """Two triangles on a square share the diagonal 0-2::

        3---2
        | / |
        0---1
        """
        edges, cell_edges = topology.unique_edges(np.array([[0, 1, 2], [0, 2, 3]]))
        assert edges.tolist() == [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]]
        # local edges 0-1, 1-2, 2-0 of each triangle
        assert cell_edges.tolist() == [[0, 3, 1], [1, 4, 2]]

    def test_quad_grid_has_twelve_edges(self) -> None:
        edges, cell_edges = topology.unique_edges(quad_grid().cells[0].data, "quad")
        assert len(edges) == 12
        assert cell_edges.shape == (4, 4)
        assert np.bincount(cell_edges.ravel()).tolist().count(2) == 4  # the inner cross

    def test_cell_edges_give_back_the_cells_edges(self) -> None:
        cells = hex_grid(2).cells[0].data
        edges, cell_edges = topology.unique_edges(cells, "hexahedron")
        assert len(edges) == 54  # 3 directions x 2 edge lengths x 3 x 3 lines
        local = topology.CELL_EDGES["hexahedron"]
        np.testing.assert_array_equal(edges[cell_edges], np.sort(cells[:, local], axis=2))

    def test_no_cells(self) -> None:
        edges, cell_edges = topology.unique_edges(np.zeros((0, 3), int))
        assert edges.shape == (0, 2) and cell_edges.shape == (0, 3)

    def test_mixed_edges(self) -> None:
        """A quad and a triangle sharing the edge 1-2, plus a line that is one of their edges::

            3---2
            |   | \\
            0---1---4
        """
        e = topology.edges(
            [("quad", [[0, 1, 2, 3]]), ("triangle", [[1, 4, 2]]), ("line", [[0, 1]])]
        )
        assert len(e) == 6
        assert e.n_cells == 3
        assert sorted(e.counts.tolist()) == [1, 1, 1, 1, 2, 2]


class TestFaces:
    def test_two_tets_share_one_face(self) -> None:
        faces = topology.unique_faces(np.array([[0, 1, 2, 3], [0, 2, 1, 4]]), "tetra")
        tri, cell_faces = faces["triangle"]
        assert len(tri) == 7
        assert np.intersect1d(cell_faces[0], cell_faces[1]).size == 1

    def test_hex_grid_face_count(self) -> None:
        quads, cell_faces = topology.unique_faces(hex_grid(2).cells[0].data, "hexahedron")["quad"]
        assert len(quads) == 36  # 3 directions x 3 planes x 4 faces
        assert cell_faces.shape == (8, 6)

    def test_2d_type_is_refused(self) -> None:
        with pytest.raises(InputError):
            topology.unique_faces(np.array([[0, 1, 2]]), "triangle")

    @pytest.mark.parametrize(
        "cell_type, points",
        [
            ("tetra", [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]),
            ("pyramid", [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.7]]),
            ("wedge", [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]]),
            ("hexahedron", hex_grid(1).points[hex_grid(1).cells[0].data[0]].tolist()),
        ],
    )
    def test_faces_point_outward(self, cell_type: str, points: list) -> None:
        """Each face's right-hand normal points away from the cell centroid."""
        p = np.array(points, float)
        centre = p.mean(axis=0)
        assert signed_volume(p, [np.arange(len(p))], cell_type)[0] > 0
        for faces in topology.CELL_FACES[cell_type].values():
            for face in faces:
                q = p[face]
                normal = np.cross(q[2] - q[0], q[-1] - q[1] if len(face) == 4 else q[1] - q[0])
                normal = normal if len(face) == 4 else -normal
                assert normal @ (q.mean(axis=0) - centre) > 0, (cell_type, face)


class TestBoundary:
    def test_quad_grid_boundary_is_eight_counterclockwise_edges(self) -> None:
        mesh = quad_grid()
        b = topology.boundary(mesh)
        assert [blk.type for blk in b.cells] == ["line"]
        lines = b.cells[0].data
        assert len(lines) == 8
        # a closed loop: each boundary point starts one edge and ends one
        assert (
            sorted(lines[:, 0].tolist()) == sorted(lines[:, 1].tolist()) == [0, 1, 2, 3, 5, 6, 7, 8]
        )
        # counterclockwise: the loop's shoelace area is the grid's, 4
        p = mesh.points
        a, b_ = p[lines[:, 0]], p[lines[:, 1]]
        area = 0.5 * np.sum(a[:, 0] * b_[:, 1] - a[:, 1] * b_[:, 0])
        assert area == pytest.approx(4.0)

    def test_holder_of_each_boundary_edge(self) -> None:
        b = topology.boundary(quad_grid())
        lines, holder = b.cells[0].data, b.cell_data["cell"][0]
        cells = quad_grid().cells[0].data
        for (i, j), c in zip(lines, holder, strict=True):
            assert {i, j} <= set(cells[c].tolist())

    def test_hex_grid_boundary(self) -> None:
        b = topology.boundary(hex_grid(2))
        assert [(blk.type, len(blk)) for blk in b.cells] == [("quad", 24)]
        # outward faces: the signed volume of the cone from the centre is positive for each face
        p = hex_grid(2).points
        q = p[b.cells[0].data]
        normal = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
        assert np.all(np.einsum("ij,ij->i", normal, q.mean(axis=1) - [1, 1, 1]) > 0)

    def test_hex_with_pyramid_and_tet(self) -> None:
        """A unit cube, a pyramid on its top face and a tetrahedron on a pyramid side.

        Shared: the cube's top quad (with the pyramid base) and one pyramid
        triangle (with the tetrahedron). Boundary: 5 cube quads, 3 pyramid
        triangles and 3 tetrahedron triangles.
        """
        cube = hex_grid(1).points.tolist()
        hexa = hex_grid(1).cells[0].data[0]  # meshio order: bottom 0-3 and top 4-7 counterclockwise
        apex, far = [0.5, 0.5, 1.7], [0.5, 1.5, 1.5]
        points = np.array(cube + [apex, far])
        top = hexa[4:]
        pyramid = [*top, 8]
        tet = [top[2], top[3], 8, 9]  # on the side face top[2] top[3] apex, reversed
        mesh = Mesh(
            points,
            (
                CellBlock("hexahedron", [hexa]),
                CellBlock("pyramid", [pyramid]),
                CellBlock("tetra", [tet]),
            ),
        )
        assert signed_volume(points, [pyramid], "pyramid")[0] > 0
        assert signed_volume(points, [tet], "tetra")[0] > 0
        b = topology.boundary(mesh)
        assert sorted((blk.type, len(blk)) for blk in b.cells) == [("quad", 5), ("triangle", 6)]
        assert topology.conformity(mesh) == {"nonmanifold": 0, "boundary_edges": 11}

    def test_polyline_boundary_is_its_two_ends(self) -> None:
        mesh = Mesh(np.zeros((4, 2)), (CellBlock("line", [[0, 1], [1, 2], [2, 3]]),))
        b = topology.boundary(mesh)
        assert [(blk.type, blk.data.ravel().tolist()) for blk in b.cells] == [("vertex", [0, 3])]

    def test_volume_mesh_ignores_its_boundary_triangles(self) -> None:
        """Triangles carried with a tetrahedron are not cells of the top dimension."""
        mesh = Mesh(
            np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float),
            (CellBlock("tetra", [[0, 1, 2, 3]]), CellBlock("triangle", [[0, 2, 1]])),
        )
        assert [len(blk) for blk in topology.boundary(mesh).cells] == [4]
        assert topology.top_dimension(mesh) == 3


class TestConformity:
    def test_edge_shared_by_three_triangles(self) -> None:
        mesh = fan_of_three()
        assert topology.conformity(mesh) == {"nonmanifold": 1, "boundary_edges": 6}
        nm = topology.nonmanifold(mesh)
        assert [(blk.type, blk.data.tolist()) for blk in nm.cells] == [("line", [[0, 1]])]

    def test_quad_grid_counts(self) -> None:
        assert topology.conformity(quad_grid()) == {"nonmanifold": 0, "boundary_edges": 8}

    def test_boundary_segments_are_not_counted(self) -> None:
        """The bottom and left sides (0-1-2 and 0-3-6) are input; the other 4 edges are not."""
        segments = np.array([[0, 1], [2, 1], [0, 3], [6, 3]])  # either direction
        c = topology.conformity(quad_grid(), segments)
        assert c == {"nonmanifold": 0, "boundary_edges": 4}

    def test_all_boundary_segments_given(self) -> None:
        lines = topology.boundary(quad_grid()).cells[0].data
        assert topology.conformity(quad_grid(), lines[::-1, ::-1])["boundary_edges"] == 0

    def test_inner_segment_changes_nothing(self) -> None:
        assert topology.conformity(quad_grid(), [[1, 4]])["boundary_edges"] == 8

    def test_bad_segments(self) -> None:
        with pytest.raises(InputError) as err:
            topology.conformity(quad_grid(), [[0, 9]])
        assert err.value.errors[0]["loc"] == ["boundary_segments", 0, 1]
        with pytest.raises(InputError):
            topology.conformity(quad_grid(), [[0, 1, 2]])
        with pytest.raises(InputError) as err:
            topology.conformity(hex_grid(1), [[0, 1]])
        assert err.value.code == "bad_dimension"

    def test_hex_grid(self) -> None:
        assert topology.conformity(hex_grid(2)) == {"nonmanifold": 0, "boundary_edges": 24}

    def test_large_indices_fold_through_dense_ranks(self) -> None:
        """Indices near 2**21 make (s0 * n + s1) * n + s2 overflow: keys are renumbered."""
        cells = hex_grid(2).cells[0].data
        big = cells * 100_003 + 2_000_000
        mesh_small = Mesh(np.zeros((cells.max() + 1, 3)), (CellBlock("hexahedron", cells),))
        faces_small = topology.facets(mesh_small)["quad"]
        faces_big = topology.facets([("hexahedron", big)])["quad"]
        np.testing.assert_array_equal(faces_big.counts, faces_small.counts)
        np.testing.assert_array_equal(faces_big.nodes, faces_small.nodes * 100_003 + 2_000_000)
        tets = np.array([[0, 1, 2, 3], [0, 2, 1, 4]]) * 900_000
        assert len(topology.unique_faces(tets, "tetra")["triangle"][0]) == 7


class TestIncidence:
    def test_pairs_and_incidence(self) -> None:
        """Two triangles: the diagonal 0-2 has both, every other edge one::

        3---2
        | / |
        0---1
        """
        f = topology.facets([("triangle", [[0, 1, 2], [0, 2, 3]])])["line"]
        pairs = {
            tuple(map(int, e)): tuple(p) for e, p in zip(f.nodes, f.pairs.tolist(), strict=True)
        }
        assert pairs[(2, 0)] == (0, 1)  # oriented as in triangle 0
        assert sorted(v for k, v in pairs.items() if k != (2, 0)) == [
            (0, -1), (0, -1), (1, -1), (1, -1)
        ]  # fmt: skip
        inc = f.incidence
        assert inc.shape == (5, 2)
        adjacency = (inc.T @ inc).toarray()
        assert adjacency.tolist() == [[3, 1], [1, 3]]

    def test_nonmanifold_pairs_name_first_two(self) -> None:
        f = topology.facets(fan_of_three())["line"]
        k = int(np.flatnonzero(f.counts == 3)[0])
        assert f.pairs[k].tolist() == [0, 1]
        assert f.incidence[k].toarray().ravel().tolist() == [1, 1, 1]


class TestInput:
    def test_unknown_type(self) -> None:
        with pytest.raises(InputError) as err:
            topology.facets([("polygon", [[0, 1, 2]])])
        assert err.value.code == "unknown_cell_type"

    def test_index_out_of_range(self) -> None:
        mesh = Mesh(np.zeros((3, 2)), (CellBlock("triangle", [[0, 1, 3]]),))
        with pytest.raises(InputError) as err:
            topology.boundary(mesh)
        assert err.value.errors[0]["loc"] == ["cells", 0, "data", 0, 2]

    def test_wrong_width(self) -> None:
        with pytest.raises(InputError):
            topology.conformity(Mesh(np.zeros((3, 2)), (CellBlock("quad", [[0, 1, 2]]),)))


@st.composite
def grid_triangulations(draw):
    """A random triangulation of an nx x ny grid: each square split along a random diagonal."""
    nx, ny = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    flips = np.array(draw(st.lists(st.booleans(), min_size=nx * ny, max_size=nx * ny)))
    ids = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    a, b = ids[:-1, :-1].ravel(), ids[:-1, 1:].ravel()
    c, d = ids[1:, 1:].ravel(), ids[1:, :-1].ravel()
    t1 = np.where(flips[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c]))
    t2 = np.where(flips[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0))
    points = np.column_stack([x.ravel(), y.ravel()])
    return nx, ny, Mesh(points, (CellBlock("triangle", np.concatenate([t1, t2])),))


@settings(max_examples=40, deadline=None)
@given(grid_triangulations())
def test_random_grid_triangulation_is_a_disc(case) -> None:
    """Euler's formula for a disc, V - E + F = 1, and a boundary of 2 (nx + ny) edges."""
    nx, ny, mesh = case
    e = topology.edges(mesh)
    assert len(mesh.points) - len(e) + mesh.n_cells == 1
    assert np.all(signed_area(mesh.points, mesh.cells[0].data) > 0)
    assert int(np.count_nonzero(e.counts == 1)) == 2 * (nx + ny)
    assert topology.conformity(mesh) == {"nonmanifold": 0, "boundary_edges": 2 * (nx + ny)}
    # both cells beside an inner edge hold it, and they differ
    tri, inner = mesh.cells[0].data, e.counts == 2
    pairs = e.pairs[inner]
    assert np.all(pairs[:, 0] != pairs[:, 1]) and np.all(e.pairs[~inner, 1] == -1)
    for side in (0, 1):
        held = tri[pairs[:, side]]
        for end in (0, 1):
            assert np.all((held == e.nodes[inner, end : end + 1]).any(axis=1))


@pytest.mark.parametrize("n", [0, 1, 7, 300])
def test_sort_based_unique_and_isin_match_numpy(n):
    rng = np.random.default_rng(n)
    a = rng.integers(0, 40, (n, 4))
    b = rng.integers(0, 40, n // 2)
    ours = topology.unique_ints(a, return_index=True, return_inverse=True, counts=True)
    theirs = np.unique(a, return_index=True, return_inverse=True, return_counts=True)
    for x, y in zip(ours, theirs, strict=True):
        assert np.array_equal(x, np.ravel(y))
    assert np.array_equal(topology.isin_ints(a, b), np.isin(a, b))


def test_inverse_permutation_gives_each_boundary_sample_its_predecessor():
    succ = np.array([2, 0, 3, 1])  # the cycle 0 -> 2 -> 3 -> 1 -> 0
    pred = topology.inverse_permutation(succ)
    assert pred.tolist() == [1, 3, 0, 2] and pred.dtype == np.int64
    assert np.array_equal(pred[succ], np.arange(4)) and np.array_equal(succ[pred], np.arange(4))
