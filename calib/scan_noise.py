"""Scanner noise from local roughness, independent of any global model.

The cloud is binned into cubic voxels holding about ``target_per_voxel``
points each; in every well-filled voxel the spread about the local best
plane (the smallest eigenvalue of the voxel's covariance,
:func:`airmat.calib.voxel_grid.voxel_moments`) measures the noise normal to the
surface. The median over voxels is robust to clutter, edges and the
floor-specimen junction.

On a cylinder of radius R the curvature inside a voxel of size h adds about
h^2 / (27 R) to the estimate, negligible at the voxel sizes used
(10-20 mm: 0.06 mm at R = 67 mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.calib.voxel_grid import voxel_moments

__all__ = ["NoiseEstimate", "local_noise"]

#: smallest voxel edge in noise standard deviations (thinner voxels clip the noise)
_MIN_VOXEL_SIGMAS = 14.0


@dataclass(frozen=True)
class NoiseEstimate:
    """Local noise of a point cloud.

    Attributes
    ----------
    sigma : float
        Median RMS distance of the points to their voxel's best plane (m),
        corrected for the 3 fitted plane parameters.
    voxel : float
        Voxel edge length used (m).
    roughness : float
        ``sigma / voxel``: small (< 0.05) for points on a surface, about
        0.25-0.3 for points filling a volume (random clutter).
    n_voxels : int
        Voxels with enough points that entered the median.
    """

    sigma: float
    voxel: float
    roughness: float
    n_voxels: int


def local_noise(points: np.ndarray, *, target_per_voxel: int = 24, max_points: int = 200_000,
                min_count: int = 10, seed=0) -> NoiseEstimate:
    """Estimate the scanner noise normal to the surface from local roughness.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (m).
    target_per_voxel : int
        Points a typical voxel should hold; the voxel size adapts to the
        sampling density (two or three passes).
    max_points : int
        Clouds larger than this are randomly subsampled first (speed).
    min_count : int
        Voxels with fewer points are ignored.
    seed : int or numpy Generator
        Seed of the subsampling.

    Returns
    -------
    NoiseEstimate
    """
    rng = np.random.default_rng(seed)
    pts = np.asarray(points, dtype=float)
    if len(pts) > max_points:
        pts = pts[rng.choice(len(pts), max_points, replace=False)]
    ext = np.ptp(pts, axis=0)
    ext2 = np.sort(ext)[1:]  # a surface spans about its two largest extents
    voxel = float(np.sqrt(target_per_voxel * ext2[0] * ext2[1] / max(len(pts), 1)))
    voxel = max(voxel, float(np.linalg.norm(ext)) * 1e-4, np.finfo(float).tiny)
    for _ in range(3):
        inverse, count, _, cov = voxel_moments(pts, voxel)
        typical = float(np.median(count[inverse]))  # occupancy seen by a typical point
        ratio = target_per_voxel / max(typical, 1.0)
        if 0.6 < ratio < 1.6:
            break
        voxel *= float(np.sqrt(ratio))
    sigma, n_full = _median_plane_rms(count, cov, min_count)
    if n_full and voxel < _MIN_VOXEL_SIGMAS * sigma:
        # a voxel only a few sigma thick clips the noise: widen it and measure again
        voxel = _MIN_VOXEL_SIGMAS * sigma
        _, count, _, cov = voxel_moments(pts, voxel)
        sigma, n_full = _median_plane_rms(count, cov, min_count)
    return NoiseEstimate(sigma=sigma, voxel=voxel, roughness=sigma / voxel, n_voxels=n_full)


def _median_plane_rms(count, cov, min_count):
    full = count >= min_count
    if not np.any(full):
        return np.nan, 0
    lam = np.linalg.eigvalsh(cov[full])[:, 0].clip(min=0.0)
    n = count[full]
    return float(np.median(np.sqrt(lam * n / (n - 3)))), int(full.sum())
