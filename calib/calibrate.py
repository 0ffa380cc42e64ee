"""Calibration end to end: manifest -> scans -> cylinder fits -> posterior -> curve.

:func:`calibrate` reads every scan of a manifest, fits a cylinder to each
(with a progress bar), samples the posterior of Equation 3's slip Delta,
thickness d and the specimen scatter sigma, and evaluates the calibrated
kappa_1(l / L) curve with its bands. Everything is SI (metres, 1/m); the
report module writes it out in millimetres.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from airmat.constants import PAPER_D, PAPER_D_SD, PAPER_DELTA, PAPER_DELTA_SD
from airmat.errors import InputError
from airmat.progress import progress
from airmat.calib.curve import KappaCurve, kappa_curve, most_common_L
from airmat.calib.manifest import Manifest, read_manifest
from airmat.calib.model import kappa1
from airmat.calib.posterior import (DEFAULT_PRIORS, Posterior, Priors, check_sampler_options,
                                   sample_posterior, specimen_data)
from airmat.summary import Summarized, band_mm

__all__ = ["SpecimenFit", "Calibration", "fit_specimens", "calibrate", "check_unit", "predicted_kappa_range"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SpecimenFit:
    """One scanned specimen and its cylinder fit (SI units).

    Attributes
    ----------
    scan, path : str
        Scan name as in the manifest, and the resolved file.
    l, L, surface_offset : float
        String length, string-end distance, surface offset (m).
    kappa, kappa_se : float
        Curvature of the reference face ``1 / (R + offset)`` and its standard error (1/m).
    radius : float
        Fitted radius of the scanned face (m); ``inf`` for a flat specimen.
    inlier_fraction, rms, arc_deg : float
        Fit quality: inlier share, RMS residual (m), arc covered (degrees).
    n_points : int
        Finite points read from the scan.
    fit_converged : bool
        Whether the cylinder fit converged.
    """

    scan: str
    path: str
    l: float
    L: float
    surface_offset: float
    kappa: float
    kappa_se: float
    radius: float
    inlier_fraction: float
    rms: float
    arc_deg: float
    n_points: int
    fit_converged: bool


@dataclass(frozen=True, repr=False)
class Calibration(Summarized):
    """Result of :func:`calibrate`.

    Attributes
    ----------
    manifest : Manifest
    specimens : tuple of SpecimenFit
    posterior : Posterior
        Samples and summaries of (Delta [m], d [m], sigma [1/m]).
    curve : KappaCurve
        kappa_1 median and bands (1/m) for the most common L.
    kappa_model : ndarray of shape (S,)
        Posterior median of kappa_1 at each specimen (1/m).
    seed : int
    timings : dict
        Seconds spent reading scans, fitting cylinders, sampling and on the curve.
    """

    manifest: Manifest
    specimens: tuple
    posterior: Posterior
    curve: KappaCurve
    kappa_model: np.ndarray
    seed: int
    timings: dict = field(default_factory=dict)


    def _summary(self):
        p = self.posterior
        return "Calibration", [("specimens", len(self.specimens)), ("Δ", band_mm(p.delta)), ("d", band_mm(p.d)),
                               ("σ", f"{p.sigma.median:.3g} 1/m"), ("converged", p.converged)]


def _reference_face(kappa: float, se: float, offset: float, path: str):
    """Curvature and error of the face ``offset`` outward of the scanned one: 1 / (R + offset)."""
    scale = 1.0 + kappa * offset  # (R + offset) / R
    if scale <= 0:
        raise InputError(f"surface_offset {offset * 1e3:g} mm is larger than the fitted radius "
                         f"{1e3 / kappa:.1f} mm", path=path)
    return kappa / scale, se / scale**2


def _fit_one(manifest: Manifest, i: int, scan_units: str, seed: int, fit_options: dict, check_units: bool = True):
    """Read and fit specimen i; returns (SpecimenFit, read seconds, fit seconds)."""
    from airmat.calib.cylinder_stability import fit_cylinder_stable
    from airmat.calib.scan_io import read_scan

    path = manifest.scan_paths[i]
    t0 = time.perf_counter()
    scan = read_scan(path, units=manifest.unit(i) or scan_units, seed=seed)
    t1 = time.perf_counter()
    try:
        fit = fit_cylinder_stable(scan.points, seed=seed, **{"quantization": scan.quantization, "strict": True,
                                                              **fit_options})
    except InputError as err:  # not a cylinder, not converged, unstable: the scan is named
        raise err.with_path(path)
    t2 = time.perf_counter()
    if not fit.converged:  # only with fit_options strict=False
        log.warning("%s: cylinder fit did not converge (%s)", path, fit.message)
    offset = float(manifest.surface_offset[i])
    if check_units:
        check_unit(float(fit.radius), scan.units, l=float(manifest.l[i]), L=float(manifest.L[i]), offset=offset,
                   path=path, explicit=manifest.unit(i) is not None or scan_units is not None)
    kappa, se = _reference_face(float(fit.kappa), float(fit.kappa_se), offset, path)
    if not (np.isfinite(se) and se > 0):
        raise InputError(f"cylinder fit gave no usable standard error ({fit.kappa_se!r} 1/m)",
                         path=path)
    spec = SpecimenFit(scan=manifest.scans[i], path=path, l=float(manifest.l[i]),
                       L=float(manifest.L[i]), surface_offset=offset, kappa=kappa, kappa_se=se,
                       radius=float(fit.radius), inlier_fraction=float(fit.inlier_fraction),
                       rms=float(fit.rms), arc_deg=float(fit.arc_deg),
                       n_points=int(scan.points.shape[0]), fit_converged=bool(fit.converged))
    return spec, t1 - t0, t2 - t1


#: the thickness a fitted radius cannot be below, and the (Delta, d) box Equation 3 predicts from: the paper's
#: values three nominal standard deviations either way (no calibration yet: these are what it measures)
_THICKNESS_MIN = PAPER_D - 3 * PAPER_D_SD
_DELTA_RANGE = (PAPER_DELTA - 3 * PAPER_DELTA_SD, PAPER_DELTA + 3 * PAPER_DELTA_SD)
_D_RANGE = (PAPER_D - 3 * PAPER_D_SD, PAPER_D + 3 * PAPER_D_SD)
#: a curvature this many times outside the predicted range is far from Equation 3
_FAR = 2.0


def predicted_kappa_range(l: float, L: float) -> tuple[float, float]:
    """The curvatures (1/m) Equation 3 gives a string ``l`` over ``L`` (m) for Delta and d in the paper's
    values +- 3 nominal standard deviations: the range a scan in the right unit falls in."""
    D, d = np.meshgrid(np.linspace(*_DELTA_RANGE, 5), np.linspace(*_D_RANGE, 5))
    k = kappa1(l, L, D, d)
    return float(np.min(k)), float(np.max(k))


def check_unit(radius: float, unit: str, *, l: float, L: float, offset: float = 0.0, path=None,
               explicit: bool = False) -> None:
    """Refuse (or warn about) a fitted radius a scan read in the wrong unit gives, naming the unit that fits.

    A scan in centimetres or inches read as millimetres fits a radius 10 or 25 times too small, below
    the mattress's thickness (the inner face would have a negative radius); one in feet read as metres
    3.3 times too large. Either is far from what Equation 3 predicts for the specimen's ``l / L``. When
    another unit puts the curvature inside the predicted range, the scan is refused with that unit
    (:class:`airmat.errors.InputError`), unless the unit was given explicitly (``explicit``; then a
    warning); a radius that is merely far from the prediction, with no unit to explain it, is logged.

    Parameters
    ----------
    radius : float
        Fitted radius of the scanned face (m); ``inf`` for a flat specimen (not checked).
    unit : str
        The unit the scan was read in.
    l, L, offset : float
        The specimen's string length, string-end distance and surface offset (m).
    path : str, optional
        The scan, for the message.
    explicit : bool
        Whether the unit was given (manifest ``units`` column, ``--scan-units``).
    """
    from airmat.units import SCAN_UNITS

    if not np.isfinite(radius) or radius <= 0:
        return
    k_lo, k_hi = predicted_kappa_range(l, L)
    if not k_hi > 0:   # a string as long as the span: Equation 3 predicts a flat specimen, no scale to compare
        return
    kappa = 1.0 / (radius + offset) if radius + offset > 0 else np.inf
    thin = radius + offset < _THICKNESS_MIN
    far = kappa > _FAR * k_hi or kappa < k_lo / _FAR
    if not (thin or far):
        return
    centre = np.sqrt(k_lo * k_hi) if k_lo > 0 else k_hi / 2

    def kappa_in(u):
        r = radius * SCAN_UNITS[u] / SCAN_UNITS[unit] + offset
        return 1.0 / r if r > 0 else np.inf

    # the US survey foot is 2 ppm off the foot: no radius tells them apart, the hint names the foot
    fits = [u for u in SCAN_UNITS if u not in (unit, "us-ft") and k_lo <= kappa_in(u) <= k_hi]
    fits.sort(key=lambda u: abs(np.log(kappa_in(u) / centre)))
    why = (f"radius {radius * 1e3:.3g} mm is below the mattress's thickness (at least {_THICKNESS_MIN * 1e3:g} mm)"
           if thin else f"radius {radius * 1e3:.3g} mm is far from what Equation 3 predicts for l/L = {l / L:.3g} "
           f"({1e3 / k_hi:.3g} to {'inf' if k_lo <= 0 else f'{1e3 / k_lo:.3g}'} mm with the paper's Delta and d)")
    if fits:
        u = fits[0]
        msg = (f"{why}: read in {unit}; in {u} it is {radius * SCAN_UNITS[u] / SCAN_UNITS[unit] * 1e3:.3g} mm, "
               f"as Equation 3 predicts: pass --scan-units {u} or give the scan's units in the manifest")
        if not explicit:
            raise InputError(msg, path=path, radius=radius, unit=unit, fits=u)
        log.warning("%s: %s", path, msg)
    else:
        log.warning("%s: %s (read in %s; no other unit explains it: another mattress?)", path, why, unit)


def fit_specimens(manifest: Manifest, *, scan_units: str | None = None, seed=0,
                  fit_options: dict | None = None, check_units: bool = True):
    """Read and fit every scan of a manifest (progress bar on a terminal).

    Parameters
    ----------
    manifest : Manifest
    scan_units : {"m", "cm", "mm", "in", "ft", "us-ft"}, optional
        Unit of the scan files' coordinates, where the manifest's ``units`` column gives none; default:
        what the file states (m for E57, LAS/LAZ in their CRS's unit, an exporter's comment), else mm.
    seed : int
        Seeds the per-scan random steps (mesh sampling, RANSAC).
    fit_options : dict, optional
        Extra keyword options of ``airmat.calib.cylinder_fit.fit_cylinder``.
    check_units : bool
        Refuse a scan whose fitted radius shows it was read in the wrong unit (:func:`check_unit`).

    Returns
    -------
    specimens : tuple of SpecimenFit
    timings : dict
        ``{"read": s, "fit": s}``.

    Raises
    ------
    airmat.errors.InputError
        Naming the scan file (unreadable scan, not a cylinder, bad offset).
    """
    seeds = np.random.default_rng(seed).integers(2**31, size=len(manifest))
    specimens, t_read, t_fit = [], 0.0, 0.0
    with progress(total=len(manifest), desc="fitting scans", unit="scan") as bar:
        for i in range(len(manifest)):
            spec, tr, tf = _fit_one(manifest, i, scan_units, int(seeds[i]), fit_options or {}, check_units)
            specimens.append(spec)
            t_read, t_fit = t_read + tr, t_fit + tf
            bar.update(1)
            bar.set_postfix_str(f"{spec.scan}: kappa {spec.kappa:.3f} 1/m")
            log.debug("%s: kappa %.4f +- %.4f 1/m", spec.path, spec.kappa, spec.kappa_se)
    return tuple(specimens), {"read": t_read, "fit": t_fit}


def _model_median(samples: np.ndarray, l, L, *, max_draws: int = 2000, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if samples.shape[0] > max_draws:
        samples = samples[rng.choice(samples.shape[0], size=max_draws, replace=False)]
    return np.median(kappa1(l[None, :], L[None, :], samples[:, :1], samples[:, 1:2]), axis=0)


def calibrate(manifest, *, scan_units: str | None = None, n_walkers: int = 32, max_steps: int = 4000,
              seed: int = 0, priors: Priors = DEFAULT_PRIORS, fit_options: dict | None = None,
              n_grid: int = 101) -> Calibration:
    """Calibrate Equation 3 from the scans listed in a manifest.

    Parameters
    ----------
    manifest : str, PathLike or Manifest
        The manifest CSV (see :mod:`airmat.calib.manifest`) or an already read one.
    scan_units : {"m", "cm", "mm", "in", "ft", "us-ft"}, optional
        Unit of the scan files where the manifest's ``units`` column gives none.
    n_walkers, max_steps : int
        emcee ensemble size and chain-length cap (:func:`airmat.calib.posterior.sample_posterior`).
    seed : int
        Seeds every random step; the same seed gives the same result.
    priors : Priors
        Prior bounds of (Delta, d, sigma).
    fit_options : dict, optional
        Extra options of the cylinder fit.
    n_grid : int
        Grid points of the curve over l / L in [0, 1].

    Returns
    -------
    Calibration
        SI units throughout.

    Raises
    ------
    airmat.errors.InputError
        Naming the manifest or the scan at fault.
    """
    check_sampler_options(n_walkers, max_steps)  # fail before minutes of scan fitting
    if not isinstance(manifest, Manifest):
        manifest = read_manifest(manifest)
    specimens, timings = fit_specimens(manifest, scan_units=scan_units, seed=seed,
                                       fit_options=fit_options)
    data = specimen_data([s.kappa for s in specimens], [s.kappa_se for s in specimens],
                         manifest.l, manifest.L)
    t0 = time.perf_counter()
    post = sample_posterior(data, priors=priors, n_walkers=n_walkers, max_steps=max_steps,
                            seed=seed)
    t1 = time.perf_counter()
    curve = kappa_curve(post.samples, most_common_L(manifest.L), n_grid=n_grid, seed=seed)
    kappa_model = _model_median(post.samples, manifest.l, manifest.L, seed=seed)
    timings.update(mcmc=t1 - t0, curve=time.perf_counter() - t1)
    return Calibration(manifest=manifest, specimens=specimens, posterior=post, curve=curve,
                       kappa_model=kappa_model, seed=int(seed), timings=timings)
