"""A target is one open sheet: its pieces, and whether it has a boundary.

The mattress follows one surface. A file that holds two sheets (both faces of
a thickened surface, a copy left beside the original) or a closed solid
makes the designer project the mattress onto whichever sheet is nearest,
vertex by vertex: with two sheets 5 mm apart it designed with exit 0, σ
from 0.97 to 1.06 and spurious k2 strings. Such targets are refused here.

Pieces whose boundaries touch are one sheet: a modeller's export of a
polysurface writes each face's mesh with its own copies of the seam
vertices, and where the faces were meshed at different densities a seam
vertex lies on the neighbour's boundary edge rather than on one of its
vertices (a T-junction). So two pieces are joined when a boundary vertex of
one lies within ``gap`` of a boundary edge of the other.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from airmat.errors import InputError
from airmat.geometry.topology import edge_counts

__all__ = ["sheet_pieces", "check_one_sheet", "GAP_FRACTION"]

#: pieces whose boundaries come closer than this fraction of the target's bounding diagonal are joined
GAP_FRACTION = 1e-3
#: at most about this many points stand for the rim edges in the T-junction search
MAX_RIM_SAMPLES = 1_000_000


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    """Connected-component label of each of ``n`` nodes joined by ``pairs`` (k, 2)."""
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (k,) from the points ``p`` to the segments ``a``–``b`` (all (k, 3))."""
    ab = b - a
    t = np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), np.finfo(float).tiny)
    return np.linalg.norm(p - (a + np.clip(t, 0.0, 1.0)[:, None] * ab), axis=1)


def sheet_pieces(vertices: np.ndarray, faces: np.ndarray, *, gap: float) -> tuple[np.ndarray, int]:
    """The sheets a triangle mesh is made of.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        Positions (any length unit; ``gap`` in the same).
    faces : ndarray of shape (m, 3)
    gap : float
        Two pieces (connected through shared vertices) are one sheet when a
        boundary vertex of one lies within ``gap`` of a boundary edge of the
        other.

    Returns
    -------
    sheet : ndarray of shape (m,)
        The sheet of each face, 0 .. n_sheets - 1.
    n_sheets : int

    Examples
    --------
    A square of two triangles, then the same with its second triangle's
    copies of the shared vertices (an unwelded seam), then a triangle and a
    copy of it 5 units above:

    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]], float)
    >>> sheet_pieces(v, np.array([[0, 1, 2], [1, 3, 2]]), gap=1e-3)
    (array([0, 0]), 1)
    >>> sheet_pieces(v, np.array([[0, 1, 2], [4, 3, 5]]), gap=1e-3)
    (array([0, 0]), 1)
    >>> sheet_pieces(np.vstack([v[:3], v[:3] + [0, 0, 5]]), np.array([[0, 1, 2], [3, 4, 5]]), gap=1e-3)
    (array([0, 1]), 2)
    """
    f = np.asarray(faces)
    return _sheets(np.asarray(vertices, dtype=float), f, *edge_counts(f), gap)


def _sheets(v, f, edges, counts, gap):
    """:func:`sheet_pieces` with the mesh's :func:`~airmat.geometry.topology.edge_counts` given."""
    piece, n = _face_components(len(v), f, edges)
    if n == 1:
        return piece, 1
    # 1. seams whose vertices coincide within gap (an unwelded export): weld them and look again
    rim = np.unique(edges[counts == 1])
    pairs = rim[cKDTree(v[rim]).query_pairs(gap, output_type="ndarray")]
    _, first, group = np.unique(_components(len(v), pairs), return_index=True, return_inverse=True)
    f = first[group][f]
    edges, counts = edge_counts(f)
    piece, n = _face_components(len(v), f, edges)
    # 2. T-junctions: a boundary vertex of one sheet on a boundary edge of another
    rim = edges[counts == 1]
    if n == 1 or not len(rim):
        return piece, n
    piece_of_vertex = np.zeros(len(v), int)
    piece_of_vertex[f.ravel()] = np.repeat(piece, 3)
    points = np.unique(rim)
    a, b = v[rim[:, 0]], v[rim[:, 1]]
    # each rim edge cut into pieces no longer than `step`, represented by their midpoints: a point within
    # gap of an edge is within step / 2 + gap of one of them (a radius of half the longest edge instead
    # would pair every point with every edge of a fine mesh that has a few long rim edges)
    length = np.linalg.norm(b - a, axis=1)
    step = max(float(np.median(length)), float(length.sum()) / MAX_RIM_SAMPLES, np.finfo(float).tiny)
    cuts = np.maximum(np.ceil(length / step), 1).astype(np.int64)
    seg = np.repeat(np.arange(len(rim)), cuts)
    frac = (np.arange(len(seg)) - np.repeat(np.cumsum(cuts) - cuts, cuts) + 0.5) / cuts[seg]
    samples = a[seg] + frac[:, None] * (b - a)[seg]
    near = cKDTree(v[points]).sparse_distance_matrix(cKDTree(samples), 0.5 * step + gap, output_type="ndarray")
    i, j = points[near["i"]], seg[near["j"]]
    other = piece_of_vertex[i] != piece_of_vertex[rim[j, 0]]
    i, j = i[other], j[other]
    touch = _segment_distance(v[i], a[j], b[j]) <= gap
    joins = np.column_stack([piece_of_vertex[i[touch]], piece_of_vertex[rim[j[touch], 0]]])
    _, sheet = np.unique(_components(n, joins)[piece], return_inverse=True)
    return sheet, int(sheet.max()) + 1


def _face_components(n_vertices: int, faces: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, int]:
    """Connected component of each face (0 .. k - 1, through shared vertices) and their number k."""
    _, piece = np.unique(_components(n_vertices, edges)[faces[:, 0]], return_inverse=True)
    return piece, int(piece.max()) + 1


def check_one_sheet(vertices: np.ndarray, faces: np.ndarray, *, gap_fraction: float = GAP_FRACTION) -> None:
    """Refuse a target that is several sheets, or a closed surface.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        Positions (m), vertices merged.
    faces : ndarray of shape (m, 3)
    gap_fraction : float, default :data:`GAP_FRACTION`
        Pieces closer than this fraction of the bounding diagonal are one
        sheet (:func:`sheet_pieces`).

    Raises
    ------
    airmat.errors.InputError
        Several sheets: the message gives each one's share of the area (the
        largest first, at most five) and how far the nearest other sheet is
        from the largest; ``data`` holds ``n_sheets`` and ``gap_mm``. A
        closed surface (no boundary edge): ``data["closed"]`` is True.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces)
    used = np.zeros(len(v), bool)
    used[f.ravel()] = True
    diag = float(np.linalg.norm(np.ptp(v[used], axis=0)))
    edges, counts = edge_counts(f)
    sheet, n = _sheets(v, f, edges, counts, gap_fraction * diag)
    if n > 1:
        p = v[f]
        area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        share = np.bincount(sheet, weights=area, minlength=n) / area.sum()
        order = np.argsort(-share, kind="stable")
        big = np.unique(f[sheet == order[0]])
        rest = np.unique(f[sheet != order[0]])
        gap_mm = 1e3 * float(cKDTree(v[big]).query(v[rest])[0].min())
        gap_text = f"{gap_mm:.0f}" if gap_mm >= 100 else f"{gap_mm:.2g}"
        shares = ", ".join(f"{100 * s:.3g} %" for s in share[order[:5]]) + (", ..." if n > 5 else "")
        raise InputError(f"the target is {n} separate sheets ({shares} of its area; the nearest to the "
                         f"largest is {gap_text} mm from it): the mattress follows one surface, so join "
                         "them into one or delete all but one (e.g. both faces of a thickened surface)",
                         n_sheets=n, gap_mm=gap_mm)
    if not (counts == 1).any():
        raise InputError("the target is a closed surface (it has no boundary edge: a solid?): the mattress "
                         "follows an open sheet, so give the one face it should follow", closed=True)
