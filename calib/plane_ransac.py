"""RANSAC for the dominant plane of a point cloud: seeded, vectorized, reproducible.

Each trial is a plane through three random points; its score is the
number of points within ``threshold``. Every trial is scored on a random
subset of the points (one matrix product per batch: no loop per point),
the best few on all of them, and the best of those wins (ties: the
first), so the same seed gives the same plane on every run and every
machine, unlike a multi-threaded RANSAC whose winner depends on thread
timing. Lengths in metres.
"""

from __future__ import annotations

import numpy as np

__all__ = ["segment_plane"]

#: trials scored per matrix product (memory: batch x N floats)
_BATCH = 64
#: points every trial is scored on, and trials rescored on all points
_N_SCORE, _N_FINALISTS = 2_000, 8


def segment_plane(points: np.ndarray, threshold: float, n_iterations: int = 500, *, seed=0) -> np.ndarray:
    """Indices of the inliers of the best RANSAC plane.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (m), N >= 3.
    threshold : float
        Inlier distance (m).
    n_iterations : int
        Random three-point trials.
    seed : int or numpy Generator
        Seed of the trials.

    Returns
    -------
    ndarray of shape (K,)
        Sorted indices of the points within ``threshold`` of the best plane.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> floor = np.column_stack([rng.uniform(0, 1, (300, 2)), rng.normal(0, 1e-3, 300)])
    >>> clutter = rng.uniform(0, 1, (100, 3))
    >>> inl = segment_plane(np.vstack([floor, clutter]), 4e-3, seed=0)
    >>> bool(np.all(inl[:290] < 300)), bool(len(inl) >= 300)
    (True, True)
    """
    pts = np.asarray(points, dtype=float)
    n = len(pts)
    if n < 3:
        return np.arange(n)
    local = pts - pts.mean(axis=0)
    rng = np.random.default_rng(seed)
    triples = rng.integers(n, size=(int(n_iterations), 3))
    a, b, c = local[triples[:, 0]], local[triples[:, 1]], local[triples[:, 2]]
    normal = np.cross(b - a, c - a)
    length = np.linalg.norm(normal, axis=1)
    ok = length > 0  # collinear or repeated points give no plane
    normal, a = normal[ok] / length[ok, None], a[ok]
    offset = -np.einsum("ij,ij->i", normal, a)
    if not len(normal):
        return np.arange(0)
    probe = local[rng.choice(n, _N_SCORE, replace=False)] if n > _N_SCORE else local
    rough = _counts(normal, offset, probe, threshold)
    finalists = np.sort(np.argsort(-rough, kind="stable")[:_N_FINALISTS])
    best = finalists[int(np.argmax(_counts(normal[finalists], offset[finalists], local, threshold)))]
    return np.flatnonzero(np.abs(local @ normal[best] + offset[best]) < threshold)


def _counts(normal, offset, points, threshold):
    """(T,) points within ``threshold`` of each trial plane, in batches of trials."""
    return np.concatenate([
        np.count_nonzero(np.abs(normal[i:i + _BATCH] @ points.T + offset[i:i + _BATCH, None]) < threshold, axis=1)
        for i in range(0, len(normal), _BATCH)])
