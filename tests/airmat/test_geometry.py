"""Shared geometry (airmat.geometry): Ω's grid, mesh topology, polylines, graph curvature."""

import numpy as np
import pytest

from airmat.geometry.graph_curvature import graph_curvature
from airmat.geometry.grid import boundary_loop, cell_count, grid_faces, parametric_mesh, rectangle_grid
from airmat.geometry.polyline import arc_length, interpolate_at, midpoints, points_at_fractions
from airmat.geometry.topology import (boundary_edge_mask, boundary_vertex_mask, boundary_vertices,
                                      cotangent_matrix, cotangent_umbrella, edge_counts, face_edges, mesh_edges)


@pytest.mark.parametrize("diagonals", ["alternating", "union_jack"])
@pytest.mark.parametrize("nx, ny", [(3, 3), (9, 5), (8, 7)])
def test_grid_counts_orientation_and_euler(diagonals, nx, ny):
    uv, f = rectangle_grid(0.8, 0.4, nx, ny, diagonals=diagonals)
    assert uv.shape == (nx * ny, 2) and f.shape == (2 * (nx - 1) * (ny - 1), 3) and f.dtype == np.int64
    assert np.array_equal(uv[0], [0, 0]) and np.array_equal(uv[-1], [0.8, 0.4])
    p = uv[f]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    assert np.all(cross > 0)                                              # counter-clockwise: normal +z
    assert 0.5 * cross.sum() == pytest.approx(0.8 * 0.4, rel=1e-12)       # tiles the rectangle
    e = mesh_edges(f)
    assert len(uv) - len(e) + len(f) == 1                                 # a disc
    assert boundary_edge_mask(f).sum() == 2 * (nx - 1) + 2 * (ny - 1)


def _mirror_symmetric(faces, nx, ny) -> bool:
    g = np.arange(nx * ny).reshape(ny, nx)
    tris = {tuple(sorted(t)) for t in faces}
    return all({tuple(sorted(t)) for t in m.ravel()[faces]} == tris for m in (g[:, ::-1], g[::-1, :]))


def test_mirror_symmetry_of_the_two_patterns():
    # union jack: symmetric under both mirrors whenever the cell counts are even (the simulator's grids)
    for nx, ny in [(9, 7), (3, 3), (17, 5)]:
        assert _mirror_symmetric(grid_faces(nx, ny, diagonals="union_jack"), nx, ny)
    # alternating: only with even cell counts; the designer's ceil(W / spacing) may be odd
    assert _mirror_symmetric(grid_faces(9, 7, diagonals="alternating"), 9, 7)
    assert not _mirror_symmetric(grid_faces(8, 7, diagonals="alternating"), 8, 7)
    # the two patterns are different meshes
    assert not np.array_equal(grid_faces(9, 7, diagonals="alternating"), grid_faces(9, 7, diagonals="union_jack"))
    # alternating: no preferred diagonal; union jack: each quadrant has one
    f = grid_faces(9, 7, diagonals="alternating")
    diag = np.sort(f[:48, [0, 2]], axis=1)                  # first half: one triangle per cell
    ac = (diag[:, 1] - diag[:, 0]) == 10                     # a-c diagonal (i, j) -> (i+1, j+1)
    assert ac.sum() == 24


def test_grid_rejects_unknown_diagonals():
    with pytest.raises(ValueError, match="diagonals"):
        grid_faces(3, 3, diagonals="random")


def test_cell_count():
    assert cell_count(0.8, 0.1) == 8 and cell_count(0.8 + 1e-12, 0.1) == 8 and cell_count(0.81, 0.1) == 9
    assert cell_count(0.81, 0.1, even=True) == 10 and cell_count(0.8, 0.1, even=True) == 8
    assert cell_count(0.05, 0.1, even=True) == 2


def test_boundary_loop_walks_the_rim_counter_clockwise():
    nx, ny = 5, 4
    uv, f = rectangle_grid(1.0, 0.6, nx, ny, diagonals="union_jack")
    loop = boundary_loop(nx, ny)
    assert np.array_equal(np.sort(loop), boundary_vertices(f))
    p = uv[loop]
    area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    assert area == pytest.approx(0.6)                                      # positive: CCW


def test_parametric_mesh_of_a_plane_is_the_grid_shifted():
    v, f = parametric_mesh(lambda s, t: np.column_stack([s, t, 2 * s]), (-0.3, 0.5), (0.1, 0.4), spacing=0.1)
    uv, f2 = rectangle_grid(0.8, 0.3, 9, 4, diagonals="alternating")
    assert np.array_equal(f, f2)
    assert np.allclose(v[:, :2], uv + [-0.3, 0.1], atol=1e-15) and np.allclose(v[:, 2], 2 * v[:, 0])


@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_edge_counts_equal_numpys_row_unique(dtype):
    """The one-key-per-edge unique gives the rows, order, counts and dtype of ``np.unique(axis=0)``."""
    rng = np.random.default_rng(3)
    faces = rng.integers(0, 500, size=(4000, 3)).astype(dtype)
    edges, counts = edge_counts(faces)
    rows = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    want, want_counts = np.unique(rows, axis=0, return_counts=True)
    assert np.array_equal(face_edges(faces), rows) and face_edges(faces).dtype == rows.dtype
    assert np.array_equal(edges, want) and edges.dtype == want.dtype
    assert np.array_equal(counts, want_counts) and counts.max() > 1
    assert edge_counts(np.zeros((0, 3), dtype))[0].shape == (0, 2)


def test_boundary_masks_of_a_fan():
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    assert mesh_edges(f).tolist() == [[0, 1], [0, 2], [0, 3], [0, 4], [1, 2], [2, 3], [3, 4]]
    assert boundary_edge_mask(f).tolist() == [True, False, False, True, True, True, True]
    assert boundary_vertex_mask(f, 6).tolist() == [True, True, True, True, True, False]
    by_second = mesh_edges(f, by_second=True)
    assert np.array_equal(by_second[np.lexsort((by_second[:, 1], by_second[:, 0]))], mesh_edges(f))
    assert np.all(np.diff(by_second[:, 1]) >= 0)


def test_cotangent_matrix_by_hand_and_linear_precision():
    # right isosceles triangles: the square split along 0-2
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    c = cotangent_matrix(uv, f).toarray()
    # edge 0-1: opposite angle at 2 is 45° -> 1/2 cot 45° = 0.5; diagonal 0-2: two right angles -> 0
    assert c[0, 1] == pytest.approx(0.5) and c[0, 3] == pytest.approx(0.5) and abs(c[0, 2]) < 1e-15
    assert np.allclose(c.sum(axis=1), 0)
    # on a grid the umbrella annihilates the flat positions at interior vertices (and any affine map)
    uv, f = rectangle_grid(0.7, 0.5, 8, 6, diagonals="alternating")
    interior = np.setdiff1d(np.arange(len(uv)), boundary_vertices(f))
    u = cotangent_umbrella(uv, f)
    affine = np.column_stack([uv, 0.3 * uv[:, 0] - 2 * uv[:, 1] + 1])
    assert np.abs((u @ affine)[interior]).max() < 1e-12
    assert np.abs(cotangent_matrix(uv, f) @ uv)[interior].max() < 1e-12
    z = uv[:, 0] ** 2                                                     # not affine: not annihilated
    assert np.abs((u @ z)[interior]).max() > 1e-4


def test_polyline_of_a_straight_line():
    p = np.array([[0.0, 0.0], [0.3, 0.4], [0.6, 0.8], [1.2, 1.6]])
    s = arc_length(p)
    assert np.allclose(s, [0.0, 0.5, 1.0, 2.0])
    q = interpolate_at(p, s, np.linspace(0, 2, 9))
    assert np.allclose(q, np.outer(np.linspace(0, 2, 9), [0.6, 0.8]))
    assert np.allclose(points_at_fractions(p, np.array([0.0, 0.25, 1.0])), [[0, 0], [0.3, 0.4], [1.2, 1.6]])
    m = midpoints([p, p[:2], np.array([[1.0, 1.0], [1.0, 3.0], [2.0, 3.0]])])
    assert np.allclose(m, [[0.6, 0.8], [0.15, 0.2], [1.0, 2.5]])
    assert midpoints([]).shape == (0, 2)


def test_graph_curvature_of_a_sphere_and_a_cylinder():
    r = 0.4
    k, d = graph_curvature(0.0, 0.0, -1 / r, 0.0, -1 / r)                 # top of a sphere, normal up
    assert np.allclose(k, [1 / r, 1 / r])
    k, d = graph_curvature(0.0, 0.0, 0.0, 0.0, -1 / r)                    # cylinder along x
    assert np.allclose(k, [1 / r, 0.0]) and np.allclose(np.abs(d[0]), [0, 1, 0])
