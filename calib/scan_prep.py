"""Scan preparation for the cylinder fit: voxel sizes and the points off the floor.

Lengths in metres.
"""

from __future__ import annotations

import logging

import numpy as np

from airmat.calib.point_normals import normals_knn
from airmat.calib.support_plane import find_support_planes
from airmat.calib.voxel_grid import voxel_cloud

__all__ = ["specimen_voxel", "specimen_candidates"]

log = logging.getLogger(__name__)

#: fewest coarse voxels the plane search needs
_MIN_VOXELS = 50


def specimen_voxel(n_cand, n_cand_sub, density, sigma, fill=20.0, max_voxels=15_000) -> float:
    """Voxel holding about ``fill`` points of the (subsampled) specimen, ``max_voxels`` at most.

    ``density`` is the scan's points per m^2 of surface (from the noise voxels,
    which hold about 24 points each).
    """
    area = n_cand / density
    v_fill = np.sqrt(fill / (density * n_cand_sub / n_cand))
    return float(max(v_fill, np.sqrt(area / max_voxels), 6 * sigma))


def specimen_candidates(pts, sub, sigma, diag, est, rng):
    """Points off the support plane(s) (floor, table), and how many were on them.

    ``sub`` is a random subset of ``pts`` (m), ``sigma`` the noise (m),
    ``diag`` the scan's robust bounding diagonal (m) and ``est`` its
    :class:`airmat.calib.scan_noise.NoiseEstimate`.
    """
    # coarse grid for the plane search; sparse scans need voxels holding a few points
    coarse = voxel_cloud(sub, max(diag / 100, 0.6 * est.voxel), min_count=3).points
    if len(coarse) < _MIN_VOXELS:
        return pts, 0
    planes = find_support_planes(coarse, normals=normals_knn(coarse), threshold=4 * sigma,
                                 reference=sub[:20_000], seed=int(rng.integers(2**31)))
    on = planes.support_mask(pts)
    n_support = int(np.count_nonzero(on))
    if n_support:
        log.debug("removed %d points on %d support plane(s)", n_support, len(planes.supports))
    return np.compress(~on, pts, axis=0), n_support  # as pts[~on], 4x faster on (N, 3)


