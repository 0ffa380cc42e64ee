"""Voxel grids with per-voxel statistics: point counts, centroids and covariances.

open3d's ``voxel_down_sample`` returns the centroids only. The cylinder fit
also needs, per voxel, how many points fell in it (isolated clutter points
make voxels of one or two points, surfaces make well-filled ones) and the
covariance of those points (its smallest eigenvector is the surface normal,
its smallest eigenvalue the local noise). All of it comes from one
vectorized pass: voxel keys, ``np.unique`` and nine ``np.bincount`` sums,
accumulated relative to each voxel's corner so that clouds far from the
origin lose no precision. Lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["voxel_moments", "VoxelCloud", "voxel_cloud"]


def voxel_moments(points: np.ndarray, voxel: float):
    """Per-voxel count, centroid and covariance of ``points``.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (m).
    voxel : float
        Voxel edge length (m).

    Returns
    -------
    inverse : ndarray of shape (N,)
        Voxel index of every point.
    count : ndarray of shape (V,)
        Points per voxel.
    centroid : ndarray of shape (V, 3)
        Mean point of each voxel (m).
    cov : ndarray of shape (V, 3, 3)
        Covariance (normalized by the count) of each voxel (m^2).
    """
    lo = points.min(axis=0)
    ijk = np.floor((points - lo) / voxel).astype(np.int64)
    dims = ijk.max(axis=0) + 1
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    _, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    local = points - lo - ijk * voxel  # within [0, voxel): no cancellation far from the origin
    nv = len(count)
    s1 = np.stack([np.bincount(inverse, local[:, i], nv) for i in range(3)], axis=1)
    s2 = np.empty((nv, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            s2[:, i, j] = s2[:, j, i] = np.bincount(inverse, local[:, i] * local[:, j], nv)
    mean = s1 / count[:, None]
    cov = s2 / count[:, None, None] - mean[:, :, None] * mean[:, None, :]
    corners = np.empty((nv, 3))
    corners[inverse] = ijk  # every point of a voxel writes the same corner
    centroid = lo + corners * voxel + mean
    return inverse, count, centroid, cov



@dataclass(frozen=True)
class VoxelCloud:
    """A downsampled cloud: one point per well-filled voxel.

    Attributes
    ----------
    points : ndarray of shape (V, 3)
        Voxel centroids (m).
    counts : ndarray of shape (V,)
        Points per voxel.
    voxel : float
        Voxel edge length (m).
    """

    points: np.ndarray
    counts: np.ndarray
    voxel: float


def voxel_cloud(points: np.ndarray, voxel: float, *, min_count: int = 3) -> VoxelCloud:
    """Downsample to voxel centroids, dropping sparse (clutter) voxels.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (m).
    voxel : float
        Voxel edge length (m).
    min_count : int
        Voxels with fewer points are dropped (isolated clutter); at least 3
        (a surface's voxels are well filled).

    Returns
    -------
    VoxelCloud
    """
    _, count, centroid, _ = voxel_moments(points, voxel)
    keep = count >= max(min_count, 3)
    return VoxelCloud(points=centroid[keep], counts=count[keep], voxel=float(voxel))
