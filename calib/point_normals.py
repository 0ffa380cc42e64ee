"""Unit normals of a point cloud from its nearest neighbours (PCA), with pykdtree's k-d tree.

The normal of a point is the eigenvector of the smallest eigenvalue of the
covariance of its ``knn`` nearest neighbours (itself included), as
open3d's ``estimate_normals`` computes it; the sign is arbitrary. One
k-d tree query (pykdtree: exact neighbours, so the result is the same on
every run and thread count; it imports in milliseconds where
``scipy.spatial`` takes a third of a second) and one batched ``eigh`` over
all points: no loop per point.
Lengths in metres.
"""

from __future__ import annotations

import numpy as np

__all__ = ["normals_knn"]


def normals_knn(points: np.ndarray, knn: int = 20) -> np.ndarray:
    """Unit normals of a (downsampled) cloud from its ``knn`` nearest neighbours.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (m).
    knn : int
        Neighbours per point, the point itself included (at most N).

    Returns
    -------
    ndarray of shape (N, 3)
        Unit normals, sign arbitrary (the component of largest magnitude
        made positive, so equal inputs give equal outputs).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-1, 1, (500, 2))
    >>> n = normals_knn(np.column_stack([xy, 0.3 * xy[:, 0]]))
    >>> np.allclose(np.abs(n @ [-0.3, 0, 1]) / np.hypot(0.3, 1), 1)
    True
    """
    from pykdtree.kdtree import KDTree

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    if len(pts) < 3:
        return np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    k = min(int(knn), len(pts))
    centre = pts.mean(axis=0)
    local = pts - centre  # conditioning: clouds far from the origin keep their precision
    _, idx = KDTree(local).query(local, k=k)
    nb = local[idx]                                       # (N, k, 3)
    nb = nb - nb.mean(axis=1, keepdims=True)
    cov = np.matmul(nb.transpose(0, 2, 1), nb)  # batched 3xk @ kx3: several times faster than einsum
    normals = np.linalg.eigh(cov)[1][:, :, 0]
    big = np.take_along_axis(normals, np.argmax(np.abs(normals), axis=1)[:, None], axis=1)
    return normals * np.where(big < 0, -1.0, 1.0)
