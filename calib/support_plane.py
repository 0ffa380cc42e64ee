"""Find the plane(s) a specimen rests on (floor, table) so the cylinder fit can ignore them.

Planes are found one after another by a seeded RANSAC
(:func:`airmat.calib.plane_ransac.segment_plane`) on a downsampled cloud and refined by least squares
on their inliers. Not every plane RANSAC finds is a support:

- the slab a plane cuts out of a *curved* specimen around a tangent line
  (large when the specimen is nearly flat) is not one. Within three
  thresholds of a real plane the points scatter as much about the plane as
  about the best quadratic height field; about a tangent slab of a curved
  surface they scatter several times more (the quadratic takes up the
  curvature). Only planes with a median-residual ratio near 1 count.
- a plane RANSAC lays across a curved surface (a secant, crossing it along
  one or two strips) is not one either: the surface normals there are
  tilted against the plane's. A support's points have normals within a
  few degrees of its normal (median).
- the scene lies on one side of a support (the scanner sees the floor from
  above): at most ``max_side_fraction`` of the points well off the plane
  may be on its minority side (clutter), while a plane through a specimen
  has specimen on both sides.
- a support extends under the specimen: most of the points off the plane
  project inside its footprint (a plane merely touching the end of an
  arc, where a groove flattens it, leaves the rest of the arc outside).
- a support is parallel to the largest sharp plane (the floor); the faces
  of a box standing on it are not supports.
- a *flat* specimen is itself a sharp plane parallel to the floor: when
  removing the supports would leave almost nothing (only clutter), the
  supporting plane with the smallest footprint (a specimen lies inside
  the floor's footprint) is the specimen and is given back.

Distances and thresholds are in metres.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.calib.plane_ransac import segment_plane

__all__ = ["Plane", "SupportPlanes", "find_support_planes"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Plane:
    """A plane ``normal . x + offset = 0`` found in a cloud.

    Attributes
    ----------
    normal : ndarray of shape (3,)
        Unit normal.
    offset : float
        Signed offset (m).
    n_inliers : int
        Points within the threshold (of the downsampled cloud).
    bend_ratio : float
        Median distance to the plane over median distance to the best
        quadratic height field, of the points within three thresholds:
        about 1 for a plane, several for the tangent slab of a curved
        surface.
    footprint : float
        Area of the inliers' bounding rectangle in the plane's principal
        axes (m^2).
    normal_deg : float
        Median angle between the inliers' own normals and the plane normal
        (degrees); NaN when no normals were given.
    side_fraction : float
        Share of the points farther than three thresholds from the plane that
        lie on its minority side: 0 when everything is on one side.
    cover_fraction : float
        Share of those points whose projection falls inside the footprint.
    """

    normal: np.ndarray
    offset: float
    n_inliers: int
    bend_ratio: float
    footprint: float
    normal_deg: float = np.nan
    side_fraction: float = 0.0
    cover_fraction: float = 1.0

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distances (m) of ``points`` (N, 3) to the plane."""
        return points @ self.normal + self.offset


@dataclass(frozen=True)
class SupportPlanes:
    """What the plane search decided.

    Attributes
    ----------
    supports : tuple of Plane
        Planes the specimen rests on; their points are not specimen points.
    specimen_plane : Plane or None
        For a flat specimen: the plane that is the specimen.
    candidates : tuple of Plane
        Every plane RANSAC found, supports or not (for diagnostics).
    threshold : float
        Inlier distance used (m).
    """

    supports: tuple
    specimen_plane: Plane | None
    candidates: tuple
    threshold: float

    def support_mask(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: points within the threshold of a support plane."""
        mask = np.zeros(len(points), dtype=bool)
        for plane in self.supports:
            mask |= np.abs(plane.distance(points)) < self.threshold
        return mask


def find_support_planes(points: np.ndarray, *, threshold: float, normals: np.ndarray | None = None,
                        min_fraction: float = 0.1, max_planes: int = 3, max_bend_ratio: float = 1.5,
                        max_normal_deg: float = 5.0, max_side_fraction: float = 0.2,
                        min_cover_fraction: float = 0.5,
                        parallel_deg: float = 5.0, min_rest_fraction: float = 0.2,
                        n_iterations: int = 500, reference=None, seed=0) -> SupportPlanes:
    """Find the support planes (floor, table) of a specimen scan.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        A downsampled scan (m); a few 10,000 points are plenty.
    threshold : float
        Plane inlier distance (m), a few noise standard deviations.
    normals : ndarray of shape (N, 3), optional
        Unit normals of ``points`` (sign arbitrary); enables the secant test.
    min_fraction : float
        A plane must hold this fraction of the points to be considered.
    max_planes : int
        Planes searched at most.
    max_bend_ratio : float
        Planes with a larger :attr:`Plane.bend_ratio` are slabs of a curved
        surface, not planes.
    max_normal_deg : float
        Planes with a larger :attr:`Plane.normal_deg` cross a curved
        surface, not planes.
    max_side_fraction : float
        Supports have at most this :attr:`Plane.side_fraction`.
    min_cover_fraction : float
        Supports have at least this :attr:`Plane.cover_fraction`.
    parallel_deg : float
        Supports are parallel to the largest sharp plane within this angle.
    min_rest_fraction : float
        If fewer points than this fraction remain off the supports, the
        specimen is flat and one of them is the specimen.
    reference : ndarray of shape (M, 3), optional
        Points that count the remaining fraction: a random subset of the
        full-resolution scan (a voxel grid counts each lone clutter point
        like a whole voxel of surface). Default: ``points``.
    n_iterations : int
        RANSAC iterations per plane.
    seed : int
        Seed of the RANSAC.

    Returns
    -------
    SupportPlanes
    """
    pts = np.asarray(points, dtype=float)
    n = len(pts)
    free = np.ones(n, dtype=bool)
    found = []
    for k in range(max_planes):
        idx = np.flatnonzero(free)
        if len(idx) < max(3, min_fraction * n):
            break
        inl = segment_plane(pts[idx], float(threshold), int(n_iterations),
                            seed=int(np.random.default_rng(seed).integers(2**31)) + k)
        if len(inl) < min_fraction * n:
            break
        sel = np.zeros(n, dtype=bool)
        sel[idx[np.asarray(inl)]] = True
        plane = _refine(pts, free, sel, threshold, normals)
        found.append(plane)
        free &= np.abs(plane.distance(pts)) >= threshold
    ref = pts if reference is None else np.asarray(reference, dtype=float)
    limits = (max_bend_ratio, max_normal_deg, max_side_fraction, min_cover_fraction)
    supports, specimen = _classify(found, ref, threshold, limits, parallel_deg, min_rest_fraction)
    for p in found:
        log.debug("plane n=%s inliers=%d bend_ratio=%.3f normal_deg=%.2f side=%.3f cover=%.2f "
                  "footprint=%.3g m^2 support=%s", np.round(p.normal, 3), p.n_inliers, p.bend_ratio,
                  p.normal_deg, p.side_fraction, p.cover_fraction, p.footprint,
                  any(p is s for s in supports))
    return SupportPlanes(supports=tuple(supports), specimen_plane=specimen,
                         candidates=tuple(found), threshold=float(threshold))


def _refine(all_pts: np.ndarray, free: np.ndarray, sel: np.ndarray, t: float, normals) -> Plane:
    """Least-squares plane through the inliers, with its bend ratio and footprint.

    Refit until the inliers (free points within ``t``) stop changing: the
    result no longer depends on which near-best trial RANSAC happened to
    return.
    """
    for _ in range(10):
        inliers = all_pts[sel]
        c = inliers.mean(axis=0)
        _, _, vt = np.linalg.svd(inliers - c, full_matrices=False)
        vt = vt * np.sign(vt[np.arange(3), np.argmax(np.abs(vt), axis=1)])[:, None]
        dist = all_pts @ vt[2] - float(vt[2] @ c)
        new = free & (np.abs(dist) < t)
        if new.sum() < 3 or np.array_equal(new, sel):
            break
        sel = new
    normal = vt[2]
    offset = -float(normal @ c)
    n_in = int(np.count_nonzero(np.abs(dist) < t))
    uv = (inliers - c) @ vt[:2].T
    uv_lo, uv_hi = np.percentile(uv, [1, 99], axis=0)
    footprint = float(np.prod(uv_hi - uv_lo))
    off = (all_pts[np.abs(dist) >= 3 * t] - c) @ vt[:2].T
    cover = float(np.mean(np.all((off >= uv_lo) & (off <= uv_hi), axis=1))) if len(off) else 1.0
    near = np.abs(dist) < 3 * t
    within = np.abs(dist) < t
    above, below = np.count_nonzero(dist >= 3 * t), np.count_nonzero(dist <= -3 * t)
    normal_deg = np.nan if normals is None or not within.any() else float(np.degrees(np.arccos(
        np.clip(np.median(np.abs(normals[within] @ normal)), 0.0, 1.0))))
    return Plane(normal=normal, offset=offset, n_inliers=n_in,
                 bend_ratio=_bend_ratio((all_pts[near] - c) @ vt[:2].T, dist[near]),
                 footprint=footprint, normal_deg=normal_deg,
                 side_fraction=min(above, below) / max(above + below, 1), cover_fraction=cover)


def _bend_ratio(uv: np.ndarray, h: np.ndarray) -> float:
    """Median |h - plane| over median |h - quadratic| (least squares, trimmed)."""
    if len(h) < 12:
        return 1.0
    scale = np.std(uv, axis=0).max() or 1.0
    u, v = (uv / scale).T
    lin = np.column_stack([np.ones_like(u), u, v])
    quad = np.column_stack([lin, u * u, u * v, v * v])
    meds = []
    for basis in (lin, quad):
        keep = np.ones(len(h), dtype=bool)
        for _ in range(10):  # refit without the worst residuals (clutter, grooves, other surfaces)
            b = basis[keep]  # normal equations: 6x6, not an SVD of the (M, 6) basis (10x faster)
            coef, *_ = np.linalg.lstsq(b.T @ b, b.T @ h[keep], rcond=None)
            r = np.abs(h - basis @ coef)
            new = r <= 3 * np.median(r) + np.finfo(float).tiny
            if np.array_equal(new, keep):
                break
            keep = new
        meds.append(np.median(r))
    return float(meds[0] / max(meds[1], np.finfo(float).tiny))


def _classify(found, ref, t, limits, parallel_deg, min_rest_fraction):
    max_bend, max_deg, max_side, min_cover = limits
    sharp = [p for p in found if p.bend_ratio <= max_bend and not p.normal_deg > max_deg
             and p.side_fraction <= max_side and p.cover_fraction >= min_cover]
    if not sharp:
        return [], None
    floor = max(sharp, key=lambda p: p.n_inliers)
    cos_tol = np.cos(np.radians(parallel_deg))
    supports = [p for p in sharp if abs(p.normal @ floor.normal) >= cos_tol]
    on_support = np.zeros(len(ref), dtype=bool)
    for p in supports:
        on_support |= np.abs(p.distance(ref)) < t
    if np.count_nonzero(~on_support) >= min_rest_fraction * len(ref):
        return supports, None
    specimen = min(supports, key=lambda p: p.footprint)  # a specimen lies inside the floor's footprint
    return [p for p in supports if p is not specimen], specimen
