"""Register a scan of the built mattress onto its predicted top face: any frame, m or mm, floor and clutter.

The scan's unit is read from its size: its robust extent (the diagonal of the
1 %..99 % percentile box along its principal axes) is compared with the
reference's; about 1x means the scan is in the reference's unit, about 1/1000x
that a file in metres was read as millimetres (``scale`` 1000), anything else
is refused. The floor is found on a voxel grid by the calibration's support
plane search (:func:`airmat.calib.support_plane.find_support_planes`), which
only accepts a plane the rest of the scene lies above (a curved top face's
tangent slab or a secant through it is not a support) and gives a flat
specimen back; its points are dropped. The global start needs no guess: the
principal axes of the largest connected part of what remains are matched to the
reference's in the 8 proper ways (two orders of the in-plane axes, four sign
choices), and each start is refined by ICP. The best start (most points within
``inlier_distance``) is refined on every remaining voxel point by a robust ICP:
point-to-plane residuals against points sampled densely on the reference with
interpolated normals, plus the overhang of points beyond the reference's
outline (which holds the slide along a cylinder's axis and the turn about a
dome's axis: point-to-plane alone leaves them free, only the outline fixes
them), weighted by Tukey's biweight with a scale annealed from a quarter of the
reference's diagonal down to ``inlier_distance``.

A scan that does not fit is refused: fewer than ``min_inlier_share`` of the
points over the predicted shape within ``inlier_distance`` of it, an RMS above
``max_rms``, or less than ``min_coverage`` of the shape seen. A shape with a
symmetry (a rectangle of a cylinder, a saddle, a dome) fits equally well in
several poses; ``n_equivalent`` counts them, and the scan then needs a marker
or a start (``init``) to tell them apart.

The scan's preparation (unit, floor, clutter, voxels) is :mod:`airmat.asbuilt.scan_cloud`; the ICP
:mod:`airmat.asbuilt.surface_icp`; this module chooses the start, runs them and judges the fit.
Lengths in metres.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.asbuilt.scan_cloud import check_points, largest_part, prepare_scan, unit_factor
from airmat.asbuilt.surface_icp import SurfaceFit, tukey_ladder
from airmat.errors import InputError
from airmat.summary import Summarized

__all__ = ["Registration", "register", "ALTERNATIVE_SHARE"]

log = logging.getLogger(__name__)

#: scan points the starts' ICP works on, its iterations per level and its step tolerance (share of the span)
_N_START, _START_ITER_LEVEL, _START_TOL = 1500, 10, 1e-5
#: points sampled on the reference for the starts' ICP
_N_COARSE_SAMPLES = 20_000
#: a start's pose is an alternative (:attr:`Registration.alternatives`) when it keeps at least this share of the
#: best start's inliers: on vault1 built at Δ = 22, d = 75 mm (its design's medians 17.9, 69.8 mm) with ±3 mm
#: ties (``docs/guide/correct.md``'s example) the true pose's start holds 14 488 inliers within 30 mm of the
#: median prediction, the half-turned one 14 637 (99 %), the next distinct pose 6 851 (47 %)
ALTERNATIVE_SHARE = 0.9


@dataclass(frozen=True, repr=False)
class Registration(Summarized):
    """A scan registered onto a reference surface: ``x_ref = rotation @ (scale * x_scan) + translation``.

    Attributes
    ----------
    rotation : ndarray of shape (3, 3)
        Proper rotation.
    translation : ndarray of shape (3,)
        Translation (m, in the reference's frame).
    scale : float
        The unit factor detected: 1 (the scan is in the reference's unit) or 1000 (a scan in metres
        read as millimetres).
    rms : float
        RMS of the inliers' signed distances to the reference (m).
    inlier_share : float
        Share of the scan points over the reference (projecting inside its outline) that lie within
        the inlier distance of it.
    coverage : float
        Share of the reference's area that has a registered scan point near it.
    n_used : int
        Voxel points the final ICP used (the inliers).
    converged : bool
        Whether the last ICP level stopped on its step tolerance.
    iterations : int
        ICP iterations of the chosen start, all levels.
    n_equivalent : int
        Starts that ended in a distinct pose fitting as well as the best: 1 when the pose is unique,
        more on a symmetric shape.
    message : str
        What was detected and removed, in words.
    alternatives : tuple of (ndarray of shape (3, 3), ndarray of shape (3,))
        Other distinct poses (rotation, translation (m), after the unit factor) whose starts hold at least
        :data:`ALTERNATIVE_SHARE` of the best one's inliers, most inliers first: starts (``init``) to try
        when the pose kept proves wrong later (a built mattress that differs from its prediction can fit
        the half-turned pose of a near-symmetric shape slightly better than the true one).
    voxel : float
        Voxel edge (m) the scan was reduced to (``register``'s ``voxel``).
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    rms: float
    inlier_share: float
    coverage: float
    n_used: int
    converged: bool
    iterations: int
    n_equivalent: int
    message: str
    alternatives: tuple = ()
    voxel: float = 0.0

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Scan points (N, 3), in the scan's unit, mapped into the reference's frame (m)."""
        return (self.scale * np.asarray(points, dtype=float)) @ self.rotation.T + self.translation

    def _summary(self):
        return "Registration", [("rms", f"{self.rms * 1e3:.2f} mm"), ("inliers", f"{100 * self.inlier_share:.0f} %"),
                                ("coverage", f"{100 * self.coverage:.0f} %"), ("scale", f"{self.scale:g}"),
                                ("converged", self.converged), ("poses", self.n_equivalent)]


def register(scan_points: np.ndarray, reference_vertices: np.ndarray, reference_faces: np.ndarray, *, seed=0,
             units: str = "auto", voxel: float | None = None, inlier_distance: float = 0.015,
             min_inlier_share: float = 0.8, max_rms: float | None = None, min_coverage: float = 0.5,
             n_reference_samples: int = 200_000, remove_floor: bool = True,
             init: tuple | None = None, local: bool = False, name: str = "the scan",
             clouds: dict | None = None) -> Registration:
    """Register a scan onto a reference surface (the predicted inflated top face), robustly.

    Parameters
    ----------
    scan_points : ndarray of shape (N, 3)
        The scan as read (:func:`airmat.calib.scan_io.read_scan`: metres, or metres / 1000 for a
        file in metres read as millimetres), in any frame, with floor and clutter.
    reference_vertices : ndarray of shape (V, 3)
        The reference mesh (m).
    reference_faces : ndarray of shape (F, 3)
        Its triangles, consistently oriented.
    seed : int
        Seed of the reference sampling and the floor's RANSAC.
    units : {"auto", "same", "m-as-mm"}
        ``"auto"`` detects the unit factor from the extents; the others force 1 or 1000.
    voxel : float, optional
        Voxel edge (m) the scan is downsampled to. Default: 1/150 of the reference's diagonal.
    inlier_distance : float
        A point within this distance of the reference is an inlier (m); also the final Tukey scale.
    min_inlier_share, min_coverage : float
        Refuse the scan below these shares (see :class:`Registration`).
    max_rms : float, optional
        Refuse the scan above this inlier RMS (m). Default: ``inlier_distance / 3`` (points spread evenly
        within ``inlier_distance`` have an RMS of ``inlier_distance / sqrt(3)``).
    n_reference_samples : int
        Points sampled on the reference.
    remove_floor : bool
        Search the support plane and drop its points.
    init : (rotation, translation), optional
        A start (after the unit factor) instead of the principal-axes starts.
    local : bool
        With ``init``: no annealed search from it (whose first Tukey scale, a quarter of the diagonal, lets a
        1 500-point subset carry the pose centimetres away) and no final level at twice ``inlier_distance`` (whose
        optimum lies degrees from the last one's), only the final ICP at ``inlier_distance``. For a start within
        about ``inlier_distance`` of the pose: the same scan registered before onto a nearby reference.
    name : str
        The scan's name in error messages.
    clouds : dict, optional
        A cache the caller keeps for one scan across registrations: the scan reduced to voxels and its floor
        removed (0.6 s on a million points) is kept there by unit factor, voxel, floor and seed, and taken from
        there when a later call asks for the same (give it the first registration's ``voxel``).

    Returns
    -------
    Registration

    Raises
    ------
    airmat.errors.InputError
        Shapes wrong, unit ambiguous, or the scan does not match the reference (the numbers in
        ``err.data``).
    """
    scan = check_points(scan_points, "scan_points")
    ref_v = check_points(reference_vertices, "reference_vertices")
    ref_f = np.asarray(reference_faces)
    if ref_f.ndim != 2 or ref_f.shape[1] != 3:
        raise InputError(f"reference_faces must have shape (F, 3), got {ref_f.shape}")
    max_rms = inlier_distance / 3 if max_rms is None else float(max_rms)
    fit = SurfaceFit(ref_v, ref_f, n_reference_samples, seed)
    diag = float(np.linalg.norm(ref_v.max(axis=0) - ref_v.min(axis=0)))
    scale = unit_factor(scan, fit.pts, units, name)
    voxel = diag / 150 if voxel is None else float(voxel)
    key = (scale, voxel, bool(remove_floor), repr(seed))
    cloud = None if clouds is None else clouds.get(key)
    if cloud is None:
        cloud = prepare_scan(scan * scale, voxel, remove_floor=remove_floor, seed=seed, name=name)
        if clouds is not None:
            clouds[key] = cloud
    pts, normals = cloud.voxels, cloud.voxel_normals
    starts = [init] if init is not None else _pca_starts(largest_part(pts, 3 * voxel), fit.pts)
    ladder = tukey_ladder(0.25 * diag, inlier_distance)
    local = init is not None and local
    if local:
        trials = [(np.asarray(init[0], dtype=float), np.asarray(init[1], dtype=float), 0, True)]
    else:
        pick = np.random.default_rng(seed).permutation(len(pts))[:_N_START]
        coarse = SurfaceFit(ref_v, ref_f, _N_COARSE_SAMPLES, seed)   # the starts need no fine reference
        trials = [coarse.icp(pts[pick], *start, ladder, normals=normals[pick], max_iter_level=_START_ITER_LEVEL,
                             tol=_START_TOL) for start in starts]
    inliers = np.array([fit.inliers(pts, r, t, inlier_distance) for r, t, *_ in trials])
    best = int(np.argmax(inliers.sum(axis=1)))
    n_eq = _n_equivalent(trials, inliers, best, pts, inlier_distance)
    alternatives = _alternatives(trials, inliers.sum(axis=1), best, pts, inlier_distance)
    # the final fit on scan points, not voxel centroids: a centroid lies up to half a voxel inside the
    # mattress's outline, which would leave the slide the outline fixes that much slack
    rot, trans, iters, converged = fit.icp(cloud.points, *trials[best][:2], ladder[-1:] if local else ladder[-2:],
                                           normals=cloud.normals)
    reg = Registration(rotation=rot, translation=trans, scale=scale, converged=converged,
                       iterations=iters + trials[best][2], n_equivalent=n_eq, message=cloud.message,
                       alternatives=alternatives, voxel=voxel,
                       **_assess(fit, cloud.points @ rot.T + trans, inlier_distance, voxel))
    _refuse_mismatch(reg, name, inlier_distance, min_inlier_share, max_rms, min_coverage)
    if n_eq > 1:
        log.warning("%s: %d poses fit the reference equally well (a symmetric shape): the one kept may be "
                    "any of them; mark the scan or give a start", name, n_eq)
    return reg


def _pca_starts(src, ref):
    """The 8 proper rotations taking the principal axes of ``src`` onto those of ``ref``, with translations."""
    cs, cr = src.mean(axis=0), ref.mean(axis=0)
    es = np.linalg.svd(src - cs, full_matrices=False)[2]  # rows: axes by decreasing variance
    er = np.linalg.svd(ref[:: max(1, len(ref) // 20_000)] - cr, full_matrices=False)[2]
    starts = []
    for order in ((0, 1, 2), (1, 0, 2)):
        for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            a = es[list(order)] * np.array([s1, s2, 1.0])[:, None]
            a[2] = np.cross(a[0], a[1])
            rot = er.T @ a
            rot = rot if np.linalg.det(rot) > 0 else er.T @ (a * [[1], [1], [-1]])
            starts.append((rot, cr - rot @ cs))
    return starts


def _same_pose(pts, a, b, tol) -> bool:
    """Whether the poses ``a`` and ``b`` ((rotation, translation) each) place every point of ``pts`` within ``tol``
    of each other."""
    return bool(np.abs(pts @ (a[0] - b[0]).T + (a[1] - b[1])).max() < tol)


def _n_equivalent(trials, inliers, best, pts, inlier_distance) -> int:
    """Distinct poses among the starts that fit as well as the best (1: the pose is unique).

    A pose fits as well when its inliers (``inliers[i]``, a mask over ``pts``) are as many as the
    best's within the scatter of a paired count (three standard deviations of the points that are
    inliers of one pose only); two poses are the same when they place every point within
    ``inlier_distance`` of each other.
    """
    poses = []
    for (r, t, *_), mask in zip(trials, inliers):
        only_best = np.count_nonzero(inliers[best] & ~mask)
        only_this = np.count_nonzero(mask & ~inliers[best])
        if only_best - only_this > 3 * np.sqrt(only_best + only_this) + 1:
            continue
        if not any(_same_pose(pts, (r, t), other, inlier_distance) for other in poses):
            poses.append((r, t))
    return max(1, len(poses))


def _alternatives(trials, counts, best, pts, inlier_distance) -> tuple:
    """The distinct poses other than the best's among the starts with at least :data:`ALTERNATIVE_SHARE` of its
    inlier count ``counts[best]``, most inliers first: ((rotation, translation), ...). Two poses are the same
    when they place every point of ``pts`` within ``inlier_distance`` of each other."""
    kept = [trials[best][:2]]
    for i in np.argsort(-counts, kind="stable"):
        r, t = trials[i][:2]
        if counts[i] < ALTERNATIVE_SHARE * counts[best]:
            break
        if not any(_same_pose(pts, (r, t), other, inlier_distance) for other in kept):
            kept.append((r, t))
    return tuple(kept[1:])


def _assess(fit, p, inlier_distance, voxel) -> dict:
    """RMS, inlier share and coverage of the registered voxel points ``p`` (N, 3)."""
    from pykdtree.kdtree import KDTree

    r, over = fit.distances(p)
    inl = over & (np.abs(r) < inlier_distance)
    rms = float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else np.inf
    probe = fit.pts[:fit.n_interior:10]
    near = KDTree(p[inl]).query(probe, distance_upper_bound=1.5 * voxel)[0] if np.count_nonzero(inl) > 1 else \
        np.full(len(probe), np.inf)
    return {"rms": rms, "inlier_share": float(np.count_nonzero(inl) / max(np.count_nonzero(over), 1)),
            "coverage": float(np.mean(np.isfinite(near))), "n_used": int(np.count_nonzero(inl))}


def _refuse_mismatch(reg, name, inlier_distance, min_share, max_rms, min_coverage):
    data = {"inlier_share": reg.inlier_share, "rms": reg.rms, "coverage": reg.coverage}
    mm = inlier_distance * 1e3
    if reg.inlier_share < min_share:
        raise InputError(f"{name} does not match this design: only {100 * reg.inlier_share:.0f} % of its points over "
                         f"the predicted shape lie within {mm:.0f} mm of it (at least {100 * min_share:.0f} % "
                         "needed): a scan of another design, or of the wrong side?", **data)
    if reg.rms > max_rms:
        raise InputError(f"{name} does not match this design: its points within {mm:.0f} mm of the predicted shape "
                         f"scatter by {reg.rms * 1e3:.1f} mm RMS (at most {max_rms * 1e3:.1f} mm): a scan of "
                         "another design, or a noisy scan?", **data)
    if reg.coverage < min_coverage:
        raise InputError(f"{name} covers only {100 * reg.coverage:.0f} % of the predicted shape (at least "
                         f"{100 * min_coverage:.0f} % needed): scan more of the mattress's top face, or it is not "
                         "this design", **data)
