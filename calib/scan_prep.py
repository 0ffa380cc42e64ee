"""Scan preparation for the cylinder fit: voxel sizes and the points off the floor and walls.

Lengths in metres.
"""

from __future__ import annotations

import logging

import numpy as np

from airmat.calib.point_normals import normals_knn
from airmat.calib.support_plane import find_support_planes
from airmat.calib.voxel_grid import voxel_cloud

__all__ = ["specimen_voxel", "specimen_candidates", "dominant_planes"]

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
    """Points off the support plane(s) (floor, table) and the room's other planes (a wall), and how many
    were on them.

    ``sub`` is a random subset of ``pts`` (m), ``sigma`` the noise (m),
    ``diag`` the scan's robust bounding diagonal (m) and ``est`` its
    :class:`airmat.calib.scan_noise.NoiseEstimate`.

    A lab scan is mostly floor (57-85 % of the points, 4 m across) and often a
    wall. The support search alone keeps a plane that leaves less than a
    fifth of the scan as the flat specimen, and judges whether the specimen
    lies inside a floor's footprint with the wall's points counted against
    it; :func:`dominant_planes` removes every sharp plane the rest of the
    scene lies on one side of, the floor as well as a wall, unless what is
    left is no surface (then the plane was a flat specimen).
    """
    # coarse grid for the plane search; sparse scans need voxels holding a few points
    coarse = voxel_cloud(sub, max(diag / 100, 0.6 * est.voxel), min_count=3).points
    if len(coarse) < _MIN_VOXELS:
        return pts, 0
    threshold = 4 * sigma
    planes = find_support_planes(coarse, normals=normals_knn(coarse), threshold=threshold,
                                 reference=sub[:20_000], seed=int(rng.integers(2**31)))
    chosen = dominant_planes(planes, coarse, sub[:20_000], threshold)
    on = np.zeros(len(pts), dtype=bool)
    for plane in chosen:
        on |= np.abs(plane.distance(pts)) < threshold
    n_support = int(np.count_nonzero(on))
    if n_support:
        log.debug("removed %d points on %d plane(s)", n_support, len(chosen))
    return np.compress(~on, pts, axis=0), n_support  # as pts[~on], 4x faster on (N, 3)


#: a sharp plane, as airmat.calib.support_plane judges one: bend ratio, normals (degrees), minority side share
_SHARP = (1.5, 5.0, 0.2)
#: least share of the scene off the planes, projected inside a plane's footprint, for it to be the room's
_MIN_COVER = 0.5
#: a remainder rougher than this (local scatter over voxel size) is clutter, not a specimen's surface
_SURFACE_ROUGHNESS = 0.1
#: a remainder of fewer points than this share of the reference holds no specimen
_MIN_REST = 0.02


def dominant_planes(planes, coarse: np.ndarray, reference: np.ndarray, threshold: float) -> list:
    """The planes of the room to remove: the supports, and every other sharp plane (a wall) with the rest of
    the scene on one side and inside its footprint, once the points of all of them are set aside.

    Parameters
    ----------
    planes : airmat.calib.support_plane.SupportPlanes
        The support search's result (its candidates are every plane RANSAC found).
    coarse : ndarray of shape (N, 3)
        The voxel-grid points the planes were found in (m).
    reference : ndarray of shape (M, 3)
        A random subset of the full-resolution scan (m), which counts what is left.
    threshold : float
        Plane inlier distance (m).

    Returns
    -------
    list of airmat.calib.support_plane.Plane
    """
    max_bend, max_deg, max_side = _SHARP
    sharp = [p for p in planes.candidates if p.bend_ratio <= max_bend and not p.normal_deg > max_deg
             and p.side_fraction <= max_side]
    if not sharp:
        return list(planes.supports)
    off = np.ones(len(coarse), dtype=bool)
    for p in sharp:
        off &= np.abs(p.distance(coarse)) >= 3 * threshold
    rest = coarse[off]
    room = [p for p in sharp if p is planes.specimen_plane or any(p is s for s in planes.supports)
            or _cover(p, coarse, rest, threshold) >= _MIN_COVER]
    if planes.specimen_plane is not None and not _is_surface(reference, room, threshold):
        room = [p for p in room if p is not planes.specimen_plane]   # a flat specimen: what is left is clutter
    return room


def _cover(plane, coarse, rest, threshold) -> float:
    """Share of ``rest`` whose projection on ``plane`` falls inside its inliers' footprint (1-99 %)."""
    if not len(rest):
        return 0.0
    inliers = coarse[np.abs(plane.distance(coarse)) < threshold]
    if len(inliers) < 3:
        return 0.0
    c = inliers.mean(axis=0)
    axes = np.linalg.svd(inliers - c, full_matrices=False)[2][:2]
    lo, hi = np.percentile((inliers - c) @ axes.T, [1, 99], axis=0)
    uv = (rest - c) @ axes.T
    return float(np.mean(np.all((uv >= lo) & (uv <= hi), axis=1)))


def _is_surface(reference, room, threshold) -> bool:
    """Whether the reference points off the planes ``room`` sample a surface (a specimen), not clutter."""
    from airmat.calib.scan_noise import local_noise

    off = np.ones(len(reference), dtype=bool)
    for p in room:
        off &= np.abs(p.distance(reference)) >= threshold
    rest = reference[off]
    if len(rest) < max(_MIN_REST * len(reference), 200):
        return False
    est = local_noise(rest, seed=0)
    return bool(est.n_voxels and est.roughness < _SURFACE_ROUGHNESS)
