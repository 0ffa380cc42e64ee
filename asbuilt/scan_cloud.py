"""A scan of the built mattress made ready to register: its unit, its floor and clutter removed, voxel points with normals.

The scan's unit is read from its size (:func:`unit_factor`): its robust extent (:func:`robust_extent`,
the diagonal of the 1 %..99 % percentile box along its principal axes) is compared with the
reference's; about 1x means the scan is in the reference's unit, about 1/1000x that a file in metres
was read as millimetres (factor 1000), anything else is refused. The floor is found on a voxel grid
by the calibration's support plane search (:func:`airmat.calib.support_plane.find_support_planes`),
which only accepts a plane the rest of the scene lies above (a curved top face's tangent slab or a
secant through it is not a support) and gives a flat specimen back; its points are dropped
(:func:`off_floor`). :func:`largest_part` keeps the mattress without the clutter beside it.
Lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.calib.point_normals import normals_knn
from airmat.errors import InputError

__all__ = ["ScanCloud", "prepare_scan", "check_points", "unit_factor", "robust_extent", "off_floor", "largest_part"]

#: extent ratios (reference / scan) accepted for each unit factor: a scan may cover part of the
#: mattress (smaller) or hold the floor around it (larger)
_UNIT_RATIOS = {1.0: (0.2, 5.0), 1000.0: (200.0, 5000.0)}
#: scan points the final ICP works on (a random subset of larger scans)
_N_FINE = 40_000


def robust_extent(points: np.ndarray) -> float:
    """Diagonal of the 1 %..99 % percentile box of ``points`` along their principal axes (their unit).

    Examples
    --------
    >>> pts = np.random.default_rng(0).uniform(0, 1, (5000, 3)) * [0.8, 0.7, 0.0]   # 1.063 m, 2 % in the tails
    >>> round(robust_extent(pts), 2), round(robust_extent(pts @ [[0, 1, 0], [1, 0, 0], [0, 0, 1]] * 1e3), -1)
    (1.09, 1090.0)
    """
    pts = np.asarray(points, dtype=float)
    pts = pts[:: max(1, len(pts) // 200_000)]
    local = pts - pts.mean(axis=0)
    _, _, vt = np.linalg.svd(local[:: max(1, len(local) // 20_000)], full_matrices=False)
    lo, hi = np.percentile(local @ vt.T, [1, 99], axis=0)
    return float(np.linalg.norm(hi - lo))


@dataclass(frozen=True)
class ScanCloud:
    """The scan off the floor: voxel centroids and a random subset of its points (in spatial order:
    :func:`airmat.asbuilt.spatial_order.spatial_order`), with normals."""

    voxels: np.ndarray
    voxel_normals: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    message: str


def prepare_scan(scan, voxel, *, remove_floor, seed, name) -> ScanCloud:
    """Voxel centroids (their normals from their 12 neighbours), the floor removed, and up to
    ``_N_FINE`` scan points off the floor, each with its voxel's normal."""
    from airmat.asbuilt.spatial_order import spatial_order
    from airmat.calib.voxel_grid import voxel_moments

    inverse, _, pts, _ = voxel_moments(scan, voxel)
    normals = normals_knn(pts, 12)
    keep = off_floor(pts, normals, voxel, seed) if remove_floor else np.ones(len(pts), dtype=bool)
    if np.count_nonzero(keep) < 50:
        raise InputError(f"{name} holds too few points off the floor ({np.count_nonzero(keep)} voxels of "
                         f"{voxel * 1e3:.1f} mm): is it a scan of the mattress?", n_points=int(np.count_nonzero(keep)))
    raw = np.flatnonzero(keep[inverse])
    raw = np.sort(np.random.default_rng(seed).permutation(raw)[:_N_FINE])
    raw = raw[spatial_order(scan[raw])]     # ICP's nearest-sample queries walk the tree in step
    message = (f"{len(scan)} points, {len(pts)} voxels of {voxel * 1e3:.1f} mm, "
               f"{np.count_nonzero(~keep)} on or below the floor")
    return ScanCloud(voxels=pts[keep], voxel_normals=normals[keep], points=scan[raw], normals=normals[inverse[raw]],
                  message=message)


def check_points(a, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or len(a) < 3:
        raise InputError(f"{what} must have shape (N, 3) with N >= 3, got {a.shape}")
    finite = np.isfinite(a).all(axis=1)
    return a if finite.all() else a[finite]


def unit_factor(scan, ref_pts, units: str, name: str) -> float:
    """1 or 1000, from the ratio of the robust extents; refuse a ratio neither explains."""
    if units == "same":
        return 1.0
    if units == "m-as-mm":
        return 1000.0
    if units != "auto":
        raise InputError(f"units must be 'auto', 'same' or 'm-as-mm', got {units!r}")
    e_scan, e_ref = robust_extent(scan), robust_extent(ref_pts)
    ratio = e_ref / max(e_scan, np.finfo(float).tiny)
    for factor, (lo, hi) in _UNIT_RATIOS.items():
        if lo <= ratio <= hi:
            return factor
    raise InputError(f"{name}'s size does not tell its unit: its extent is {e_scan * 1e3:.4g} mm, the predicted "
                     f"shape's {e_ref * 1e3:.4g} mm (ratio {ratio:.3g}; about 1 for a scan in millimetres, about "
                     "1000 for one in metres); give the scan's unit or crop it to the mattress",
                     scan_extent=e_scan, reference_extent=e_ref, ratio=ratio)


def off_floor(pts, normals, voxel, seed) -> np.ndarray:
    """(N,) bool: the voxel points neither on a support plane (the floor) nor below it.

    :func:`~airmat.calib.support_plane.find_support_planes` accepts only a plane the rest of the
    scene lies on one side of and rejects the tangent slab of a curved surface; a flat top face
    it gives back as the specimen. What lies beyond the plane, away from most points, goes too.
    """
    from airmat.calib.support_plane import find_support_planes

    found = find_support_planes(pts, threshold=voxel, normals=normals, seed=seed)
    keep = np.ones(len(pts), dtype=bool)
    for plane in found.supports:
        d = plane.distance(pts)
        far = np.abs(d) > 3 * voxel
        side = np.sign(np.median(d[far])) if far.any() else 1.0
        keep &= d * side > voxel
    return keep


def largest_part(pts, eps):
    """The largest connected part of ``pts`` at distance ``eps`` (the mattress without the clutter beside it)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts).query_pairs(eps, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts)))
    _, label = connected_components(graph, directed=False)
    return pts[label == np.argmax(np.bincount(label))]
