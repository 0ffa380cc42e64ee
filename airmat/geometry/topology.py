"""Topology of a triangle mesh: its edges, its boundary, and the cotangent Laplacian and areas of a flat mesh.

The designer's U_A3 umbrella term (:func:`airmat.design.local_global.umbrella_operator`) and
the simulator's U_B5 smoothing (:func:`airmat.inflation.energy.smoothing_matrix`)
are both built from these. Positions in metres.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["face_edges", "edge_counts", "mesh_edges", "boundary_edge_mask", "boundary_vertex_mask", "boundary_vertices",
           "boundary_face_flags", "cotangent_matrix", "cotangent_umbrella", "flat_vertex_areas"]


def face_edges(faces: np.ndarray) -> np.ndarray:
    """The three edges of every face, (3 m, 2), each row sorted: edges 01 of all faces, then 12, then 20."""
    f = np.asarray(faces)
    a, b = np.concatenate([f[:, 0], f[:, 1], f[:, 2]]), np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    return np.column_stack([np.minimum(a, b), np.maximum(a, b)])


def edge_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges (e, 2), rows sorted (i < j) and in (i, j) order, and how many faces hold each.

    The same as ``np.unique(face_edges(faces), axis=0, return_counts=True)``,
    through one integer key per edge: 50× faster (10 ms instead of 0.5 s on
    137 500 triangles), since NumPy sorts rows for ``axis=0`` as structured
    records.

    Examples
    --------
    >>> e, c = edge_counts(np.array([[0, 1, 2], [0, 2, 3]]))
    >>> e.tolist(), c.tolist()
    ([[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]], [1, 2, 1, 1, 1])
    """
    f = np.asarray(faces)
    e = face_edges(f).astype(np.int64)
    if not len(e):
        return np.zeros((0, 2), f.dtype), np.zeros(0, np.int64)
    n = int(e.max()) + 1
    keys, counts = np.unique(e[:, 0] * n + e[:, 1], return_counts=True)
    return np.column_stack([keys // n, keys % n]).astype(f.dtype, copy=False), counts


def mesh_edges(faces: np.ndarray, *, by_second: bool = False) -> np.ndarray:
    """Unique undirected edges (e, 2) of a triangle mesh, each row sorted (i < j).

    Parameters
    ----------
    faces : ndarray of shape (m, 3)
    by_second : bool, default False
        Order the rows by (j, i) instead of (i, j): libigl's ``edges`` order,
        which the simulator's spring order (and so its round-off) follows.

    Examples
    --------
    >>> mesh_edges(np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]]
    >>> mesh_edges(np.array([[0, 1, 2], [0, 2, 3]]), by_second=True).tolist()
    [[0, 1], [0, 2], [1, 2], [0, 3], [2, 3]]
    """
    e = edge_counts(faces)[0]
    return e[np.lexsort((e[:, 0], e[:, 1]))] if by_second else e


def boundary_edge_mask(faces: np.ndarray) -> np.ndarray:
    """Which rows of :func:`mesh_edges` lie on the boundary (one face only), shape (e,).

    Examples
    --------
    >>> boundary_edge_mask(np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [True, False, True, True, True]
    """
    return edge_counts(faces)[1] == 1


def boundary_vertex_mask(faces: np.ndarray, n: int) -> np.ndarray:
    """Boolean mask (n,) of the vertices on a boundary edge (n: the number of vertices)."""
    rim = np.zeros(n, bool)
    rim[mesh_edges(faces)[boundary_edge_mask(faces)].ravel()] = True
    return rim


def boundary_vertices(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of the vertices on a boundary edge.

    Examples
    --------
    >>> boundary_vertices(np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1]])).tolist()
    [1, 2, 3]
    """
    return np.unique(mesh_edges(faces)[boundary_edge_mask(faces)])


def boundary_face_flags(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Boundary flags per face corner and per vertex.

    Returns
    -------
    face_flags : ndarray of shape (m, 3), bool
        Whether the edge opposite corner i of each face is a boundary edge (in one face only).
    vertex_flags : ndarray of shape (n,), bool
        Whether each vertex lies on such an edge.

    Examples
    --------
    >>> f, v = boundary_face_flags(np.array([[0, 1, 2], [0, 2, 3]]), 4)
    >>> f.tolist(), v.tolist()
    ([[True, False, True], [True, True, False]], [True, True, True, True])
    """
    # edge opposite corner i: (i+1, i+2), as one integer key per edge (1-D unique is fast)
    opposite = np.sort(np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1), axis=2)
    key = opposite[..., 0] * np.int64(n_vertices) + opposite[..., 1]
    _, inverse, counts = np.unique(key.ravel(), return_inverse=True, return_counts=True)
    rim_edge = (counts[inverse] == 1).reshape(-1, 3)
    rim_vertex = np.zeros(n_vertices, bool)
    rim_vertex[opposite[rim_edge].ravel()] = True
    return rim_edge, rim_vertex


def cotangent_matrix(uv: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """The cotangent Laplacian C (n, n) of a flat mesh (libigl's ``cotmatrix``; 1/2 cot weights).

    ``C[i, j] = (cot α_ij + cot β_ij) / 2`` for an edge ij (α, β the angles
    opposite it), ``C[i, i] = -Σ_j C[i, j]``; ``C @ uv`` vanishes on interior
    vertices (linear precision).

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Flat positions (m).
    faces : ndarray of shape (m, 3)

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n, n)
        Dimensionless.
    """
    import igl

    uv = np.asarray(uv, dtype=float)
    return sp.csr_matrix(igl.cotmatrix(np.column_stack([uv, np.zeros(len(uv))]), faces))


def cotangent_umbrella(uv: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """The umbrella operator U (n, n) with ``(U x)_i = x_i − Σ_j w_ij x_j / Σ_j w_ij``, w the cotangent weights.

    Built as ``-diag(C)⁻¹ C`` from :func:`cotangent_matrix`, so on the flat mesh
    ``U @ uv`` is 0 at every interior vertex (rows of boundary vertices are
    one-sided: callers keep the rows they need).

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Flat positions (m).
    faces : ndarray of shape (m, 3)
    """
    cot = cotangent_matrix(uv, faces)
    return sp.diags(-1.0 / cot.diagonal()) @ cot


def flat_vertex_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Lumped area of each vertex of a flat mesh (n,): a third of each adjacent triangle's area (m²).

    Examples
    --------
    >>> flat_vertex_areas(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]])).round(4).tolist()
    [0.1667, 0.1667, 0.1667]
    """
    uv, faces = np.asarray(uv, float), np.asarray(faces)
    d1, d2 = uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return np.bincount(faces.ravel(), weights=np.repeat(area / 3, 3), minlength=len(uv))
