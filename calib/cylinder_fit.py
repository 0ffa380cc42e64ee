"""Robust curvature of a scanned cylindrical specimen: ``fit_cylinder``.

The pipeline, each step in its own module:

1. local noise from voxel roughness (:mod:`airmat.calib.scan_noise`), which sets
   every threshold (so they scale with the scanner, not bare constants);
2. voxel downsampling that drops sparse clutter voxels
   (:mod:`airmat.calib.voxel_grid`), normals (:mod:`airmat.calib.point_normals`), then
   the support plane(s) the specimen rests on (:mod:`airmat.calib.support_plane`,
   a seeded RANSAC), taking care that a flat specimen is not one;
3. axis from the scatter of the normals, circle by RANSAC (:mod:`airmat.calib.circle_ransac`)
   in the projection along it, or a quadratic height field for a nearly
   flat specimen (:mod:`airmat.calib.cylinder_init`);
4. robust geometric least squares over axis direction, position and
   curvature (:mod:`airmat.calib.cylinder_lsq`): a trust region on the
   downsampled points, then rounds on a random subset of the
   full-resolution points near the surface that leave out the string-end
   grooves (:mod:`airmat.calib.groove_bands`), then Newton steps on all of them
   (:mod:`airmat.calib.cylinder_irls`), with the standard error of kappa from a
   cluster-robust sandwich covariance.

Steps 1-3 look at a random subset of at most 100,000 points; step 4 at
every point near the surface.

What is not a cylindrical arc (a sphere cap, a box, random points) is
refused with :class:`airmat.errors.NotACylinderError` saying why.
All lengths are in metres, curvatures in 1/m.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError, NotACylinderError
from airmat.calib.cylinder_init import initial_cylinder
from airmat.calib.cylinder_irls import kappa_standard_error, polish
from airmat.calib.cylinder_lsq import arc_from_local, distance_from_local, refine
from airmat.calib.cylinder_refine import full_resolution_fit, surface_spread
from airmat.calib.scan_noise import local_noise
from airmat.calib.scan_readers.raw import MIN_STEPS_ACROSS
from airmat.calib.point_normals import normals_knn
from airmat.calib.scan_prep import specimen_candidates, specimen_voxel
from airmat.calib.voxel_grid import voxel_cloud
from airmat.summary import Summarized, mm

__all__ = ["CylinderFit", "fit_cylinder", "MIN_FIT_POINTS", "MAX_SPECIMEN_EXTENT"]

log = logging.getLogger(__name__)

#: fewest points fit_cylinder accepts
MIN_FIT_POINTS = 50
#: a refused fit with fewer points than this on the specimen says the scan may be too sparse: synthetic scans
#: of 4000 points (about 2800 on the specimen) lost 1 or 2 of 12 fits, with the normals' scatter as the reason
SPARSE_SPECIMEN_POINTS = 5000
#: largest specimen surface (robust bounding diagonal of the fitted face, m): the paper's
#: large mattress (2.6 m x 1.6 m) is 3.05 m across; a km survey tile read in mm is several m
MAX_SPECIMEN_EXTENT = 4.0


@dataclass(frozen=True, repr=False)
class CylinderFit(Summarized):
    """A cylinder fitted to a specimen scan (SI units).

    Attributes
    ----------
    radius : float
        Radius of the scanned face (m); ``inf`` when the specimen is flat
        (kappa below twice its standard error).
    kappa : float
        Curvature ``1/R`` (1/m), >= 0. Near 0 the estimate is folded (its
        sign is not observable without knowing the scanner side), so a
        flat specimen gives kappa of the order of ``kappa_se``.
    kappa_se : float
        Standard error of kappa (1/m): the larger of the classical and the
        cluster-robust (correlated residuals along the arc) estimates.
    axis : ndarray of shape (3,)
        Unit axis direction (for a flat specimen: the direction of least bending).
    center : ndarray of shape (3,)
        A point on the axis (m); for a flat specimen a point on the plane.
    inlier_fraction : float
        Inliers over the points off the support plane(s).
    rms : float
        RMS geometric residual (m) of the points of the final fit: the
        inliers off the string-end groove bands.
    arc_deg : float
        Angle of the arc the inliers cover (degrees).
    n_points : int
        Points given.
    n_inliers : int
        Points within three noise levels of the surface.
    n_support : int
        Points assigned to the floor/table plane(s).
    noise : float
        Scanner noise estimated from local roughness (m).
    kappa_se_iid : float
        Classical standard error of kappa, as if residuals were independent (1/m).
    converged : bool
        Whether the final least squares met its tolerance.
    n_iter : int
        Least-squares function evaluations, all stages.
    residual : float
        RMS residual of all inliers, grooves included (m).
    message : str
        The final least squares' message.
    kappa_spread : float
        Largest difference of kappa between fits from other seeds
        (:func:`airmat.calib.cylinder_stability.fit_cylinder_stable`), 1/m; 0 when
        not compared.
    n_seeds : int
        Seeds the fit was compared over (1: none).
    """

    radius: float
    kappa: float
    kappa_se: float
    axis: np.ndarray
    center: np.ndarray
    inlier_fraction: float
    rms: float
    arc_deg: float
    n_points: int
    n_inliers: int
    n_support: int
    noise: float
    kappa_se_iid: float
    converged: bool
    n_iter: int
    residual: float
    message: str
    kappa_spread: float = 0.0
    n_seeds: int = 1


    def _summary(self):
        return "CylinderFit", [("radius", mm(self.radius, 2)), ("κ", f"{self.kappa:.4g} ± {self.kappa_se:.2g} 1/m"),
                               ("inliers", f"{self.n_inliers}/{self.n_points}"), ("rms", mm(self.rms, 2)),
                               ("arc", f"{self.arc_deg:.0f}°"), ("converged", self.converged)]


def fit_cylinder(points, *, seed=0, noise: float | None = None, min_inlier_fraction: float = 0.5,
                 max_rms_ratio: float = 3.0, max_rms_rel: float = 0.002, inlier_sigmas: float = 3.0,
                 band_sigmas: float = 5.0, max_planarity: float = 0.3, remove_support: bool = True,
                 loss: str = "arctan", loss_sigmas: float = 2.0, groove_sigmas: float = 0.2,
                 n_subsample: int = 50_000, n_clusters: int = 24, quantization: float = 0.0,
                 max_extent: float = MAX_SPECIMEN_EXTENT, strict: bool = False) -> CylinderFit:
    """Fit a cylinder to a scan of a bent specimen, robustly.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Scan points (m), finite; floor, clutter and holes allowed.
    seed : int
        Seed of every random step (subsampling, RANSAC).
    noise : float, optional
        Scanner noise standard deviation (m); estimated from local roughness
        when omitted.
    min_inlier_fraction : float
        Refuse when fewer of the points off the supports are inliers.
    max_rms_ratio, max_rms_rel : float
        Refuse when the RMS residual of the fitted face exceeds both
        ``max_rms_ratio`` times the local noise and ``max_rms_rel`` times the
        inliers' extent (the second keeps noise-free, slightly imperfect
        surfaces, e.g. simulated ones, acceptable; raise both to accept
        anything cylinder-like).
    inlier_sigmas : float
        Inlier band, in units of the residual scale.
    band_sigmas : float
        Points within this many residual scales enter the full-resolution
        fit. The residual scale is the local noise, or the face's own
        departure from a cylinder when that is more than 1.5 times larger.
    max_planarity : float
        Refuse when the normals' eigenvalue ratio exceeds this (sphere-like).
    remove_support : bool
        Look for and remove floor/table planes.
    loss, loss_sigmas : str, float
        Robust loss of the final fit and its scale in noise levels. The
        default ``arctan`` redescends (weight ``1 / (1 + (e/f)^4)``): the
        string-end grooves, several noise levels deep, lose their pull on R.
    groove_sigmas : float
        Arc bands whose median residual departs by more than this many noise
        levels from the best cross-section circle (string-end grooves) are
        left out of the fit (:mod:`airmat.calib.groove_bands`).
    n_subsample : int
        Size of the random subset the selection rounds run on before the
        final pass over every point (speed).
    n_clusters : int
        Arc bins of the cluster-robust standard error.
    quantization : float
        Step of the coordinates as the file stored them (m; 32-bit floats
        far from the origin, a LAS scale, :attr:`airmat.calib.scan_io.Scan.quantization`).
        Rounding to it is noise of standard deviation ``step / sqrt(12)``:
        the noise level is at least that, so the fit and its standard error
        account for it by their effect, not the step alone; refused when
        fewer than :data:`airmat.calib.scan_readers.raw.MIN_STEPS_ACROSS`
        steps span the scan (no surface is left).
    max_extent : float
        Refuse when the fitted face (its inliers' robust bounding diagonal)
        spans more than this (m): no specimen is that large, a survey tile
        or a room read in the wrong unit is.
    strict : bool
        Raise :class:`airmat.errors.InputError` when the final least
        squares did not converge, instead of reporting it in the result.

    Returns
    -------
    CylinderFit

    Raises
    ------
    airmat.errors.NotACylinderError
        (an InputError) when the points are not a cylindrical arc; the
        message says why.
    airmat.errors.InputError
        For an array of the wrong shape or non-finite values.
    """
    pts = _check_points(points)
    rng = np.random.default_rng(seed)
    sub = pts[rng.choice(len(pts), _SUB, replace=False)] if len(pts) > _SUB else pts
    lo, hi = np.percentile(sub, [0.5, 99.5], axis=0)
    diag = float(np.linalg.norm(hi - lo))
    est = local_noise(sub, seed=rng)
    if not (est.roughness < 0.15):
        raise NotACylinderError(
            f"points do not sample a surface: local scatter {est.sigma * 1e3:.3g} mm in "
            f"{est.voxel * 1e3:.3g} mm voxels", roughness=est.roughness)
    # rounding to a step q is noise of sd q / sqrt(12) (uniform): a floor under the local estimate, which a
    # grid of points flattens toward 0 (a LAS at 1 cm scale looked like 0.002 mm of noise)
    noise_level = float(noise) if noise is not None else \
        max(est.sigma, quantization / np.sqrt(12), 1e-6 * diag)
    if quantization * MIN_STEPS_ACROSS > diag:
        raise InputError(f"coordinates lost precision: stored as 32-bit floats far from the origin (or on a "
                         f"coarse grid), their step {quantization * 1e3:.3g} mm across a scan {diag:.3g} m wide "
                         f"leaves no surface to fit (export in float64 or re-centred)", quantization=quantization,
                         noise=noise_level)
    cand, n_support = specimen_candidates(pts, sub, noise_level, diag, est, rng) if remove_support \
        else (pts, 0)
    cand_sub = cand[rng.choice(len(cand), _SUB, replace=False)] if len(cand) > _SUB else cand
    density = 24.0 / est.voxel**2 * len(pts) / len(sub)  # points per m^2 of surface, full scan
    init, stage = _start(cand_sub, len(pts), specimen_voxel(len(cand), len(cand_sub), density, noise_level),
                         noise_level, diag, max_planarity, rng)
    # a surface that departs from a cylinder by more than the local noise (a simulated or
    # wrinkled face) sets the scale of the bands and the loss itself
    sigma = noise_level
    spread = surface_spread(cand_sub, stage.frame, sigma, band_sigmas, int(rng.integers(2**31)))
    if spread > 1.5 * sigma:
        log.debug("residual scale %.3g mm exceeds the local noise %.3g mm; using it",
                 spread * 1e3, sigma * 1e3)
        sigma = spread
    # a flat specimen keeps the footprint's axis: choosing the direction of largest
    # apparent curvature would bias |kappa| up
    frame, final, used, n_more = full_resolution_fit(
        cand, stage.frame, sigma=sigma, band_sigmas=band_sigmas, loss=loss, f_scale=loss_sigmas * sigma,
        n_subsample=n_subsample, groove_sigmas=groove_sigmas, rng=rng, hold_axis=True if init.flat else None)
    fit = _summarize(cand, frame, final, used=used, n_points=len(pts), n_support=n_support,
                      noise=noise_level, sigma=sigma, n_iter=stage.n_iter + n_more, scatter=init.scatter,
                      inlier_sigmas=inlier_sigmas, min_inlier_fraction=min_inlier_fraction,
                      max_rms_ratio=max_rms_ratio, max_rms_rel=max_rms_rel, max_extent=max_extent, loss=loss,
                      f_scale=loss_sigmas * sigma, n_clusters=n_clusters, noise_given=noise is not None)
    if strict and not fit.converged:
        raise InputError(f"cylinder fit did not converge ({fit.message}); the radius would be unreliable",
                         fit_message=fit.message)
    return fit


def _start(cand_sub, n_points, voxel, sigma, diag, max_planarity, rng):
    """Downsample, initialize (axis and circle, or height field) and fit the downsampled cloud."""
    down = voxel_cloud(cand_sub, voxel, min_count=5).points
    if len(down) < MIN_FIT_POINTS:
        raise NotACylinderError(
            f"too few points on the specimen: {n_points} points, {len(cand_sub)} of them off the floor, "
            f"fill only {len(down)} surface patches (need {MIN_FIT_POINTS}; a specimen scan has "
            f"thousands of points)", n_points=n_points)
    init = initial_cylinder(down, normals_knn(down), threshold=max(4 * sigma, 2e-3 * diag),
                            max_planarity=max_planarity, flat_deg=_FLAT_DEG, seed=int(rng.integers(2**31)))
    if init.nearly_flat:  # axis from the height field, held still: Gauss-Newton
        stage = polish(down[init.inliers], init.frame, f_scale=sigma, loss="soft_l1", hold_axis=True)
    else:
        stage = refine(down[init.inliers], init.frame, f_scale=sigma, max_nfev=100)
    return init, stage


#: normal spread (degrees) below which a specimen is initialized as nearly flat
_FLAT_DEG = 20.0

#: points the noise estimate, the plane search and the initialization look at (random subset)
_SUB = 100_000


def _check_points(points) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError(f"{int(np.count_nonzero(~np.isfinite(pts).all(axis=1)))} points have "
                         f"non-finite coordinates (read_scan drops them)")
    if len(pts) < MIN_FIT_POINTS:
        raise NotACylinderError(f"too few points: only {len(pts)} points (need at least {MIN_FIT_POINTS}; "
                                f"a specimen scan has thousands)",
                                n_points=len(pts))
    return pts


def _summarize(cand, frame, final, *, used, n_points, n_support, noise, sigma, n_iter, scatter,
               inlier_sigmas, min_inlier_fraction, max_rms_ratio, max_rms_rel, max_extent, loss, f_scale,
               n_clusters, noise_given=False):
    """Inliers, refusal checks, standard error, arc and centre: the CylinderFit.

    ``noise`` is the local noise, ``sigma`` the working residual scale (>= noise), both m.
    """
    X, Z = frame.local(cand)  # one pass: residuals and arc positions
    e = distance_from_local(X, Z, frame.kappa)
    near = np.abs(e) < 10 * sigma
    stride = max(len(e) // 50_000, 1)  # order statistics from a systematic subsample (speed)
    scale = 1.4826 * float(np.median(np.abs(e[near][::stride]))) if near.any() else np.inf
    inl = np.abs(e) < inlier_sigmas * max(sigma, scale)
    n_inl = int(np.count_nonzero(inl))
    frac = n_inl / len(cand)
    if frac < min_inlier_fraction:
        raise NotACylinderError(f"only {100 * frac:.0f}% inliers (need {100 * min_inlier_fraction:.0f}%)"
                                + _why(scatter, len(cand)), inlier_fraction=frac)
    rms = float(np.sqrt(np.mean(np.compress(used, e) ** 2)))  # the fitted face, off the groove bands
    inl_idx = np.flatnonzero(inl)[::stride]
    inl_sub = cand[inl_idx]
    ext = float(np.linalg.norm(np.ptp(inl_sub, axis=0)))
    lo, hi = np.percentile(inl_sub, [0.5, 99.5], axis=0)
    span = float(np.linalg.norm(hi - lo))
    if span > max_extent:
        raise NotACylinderError(f"the fitted surface spans {span:.3g} m, more than any specimen (at most "
                                f"{max_extent:g} m): a survey tile or a room? check the unit (--scan-units)",
                                extent=span)
    if rms > max_rms_ratio * noise and rms > max_rms_rel * ext:
        hint = "" if noise_given else \
            f"; if the scanner is noisier than that estimate (stereo, RGB-D), pass --noise-mm {rms * 1e3:.2g}"
        raise NotACylinderError(f"RMS {rms * 1e3:.3g} mm against {noise * 1e3:.2g} mm "
                                f"{'given' if noise_given else 'estimated'} noise" + _why(scatter, len(cand)) + hint,
                                rms=rms, noise=noise)
    se_iid, se_cl = kappa_standard_error(None, frame, f_scale=f_scale, loss=loss, n_clusters=n_clusters,
                                         state=final.state,
                                         arc=arc_from_local(np.compress(used, X), np.compress(used, Z), frame.kappa),
                                         axial=np.compress(used, cand, axis=0) @ frame.axis)
    kappa, se = abs(frame.kappa), max(se_iid, se_cl)
    flat = not kappa > 2 * se   # also kappa == 0 with se == 0 (a degenerate grid): no 1 / 0
    center = frame.origin if flat else frame.origin + frame.normal / frame.kappa
    s = arc_from_local(X[inl_idx], Z[inl_idx], frame.kappa)
    q_lo, q_hi = np.quantile(s, [0.005, 0.995])
    arc = float(np.degrees((q_hi - q_lo) / 0.99 * kappa))
    axis = frame.axis * np.sign(frame.axis[np.argmax(np.abs(frame.axis))])
    if not final.converged:                  # the callers warn, naming the scan
        log.debug("cylinder least squares did not converge: %s", final.message)
    return CylinderFit(radius=np.inf if flat else 1.0 / kappa, kappa=kappa, kappa_se=se, axis=axis,
                       center=center, inlier_fraction=frac, rms=rms, arc_deg=arc, n_points=n_points,
                       n_inliers=n_inl, n_support=n_support, noise=noise, kappa_se_iid=se_iid,
                       converged=final.converged, n_iter=n_iter,
                       residual=float(np.sqrt(np.mean(np.compress(inl, e) ** 2))), message=final.message)


def _why(scatter, n_specimen: int) -> str:
    """A hint when the normals already looked unlike a cylinder's (and, on a sparse scan, why they may)."""
    if scatter.spread_deg >= _FLAT_DEG and (scatter.planarity > 0.1 or scatter.in_band < 0.6):
        sparse = (f"; only {n_specimen} points on the specimen: so few give noisy normals, a denser scan "
                  f"(at least {SPARSE_SPECIMEN_POINTS}) may fit" if n_specimen < SPARSE_SPECIMEN_POINTS else "")
        return (f"; normals do not lie in a plane (sphere-like?): eigenvalue ratio "
                f"{scatter.planarity:.2f}, {100 * scatter.in_band:.0f}% within 10 degrees of one" + sparse)
    return ""
