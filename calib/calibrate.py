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

from airmat.errors import InputError
from airmat.progress import progress
from airmat.calib.curve import KappaCurve, kappa_curve, most_common_L
from airmat.calib.manifest import Manifest, read_manifest
from airmat.calib.model import kappa1
from airmat.calib.posterior import (DEFAULT_PRIORS, Posterior, Priors, check_sampler_options,
                                   sample_posterior, specimen_data)
from airmat.summary import Summarized, band_mm

__all__ = ["SpecimenFit", "Calibration", "fit_specimens", "calibrate"]

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


def _fit_one(manifest: Manifest, i: int, scan_units: str, seed: int, fit_options: dict):
    """Read and fit specimen i; returns (SpecimenFit, read seconds, fit seconds)."""
    from airmat.calib.cylinder_stability import fit_cylinder_stable
    from airmat.calib.scan_io import read_scan

    path = manifest.scan_paths[i]
    t0 = time.perf_counter()
    scan = read_scan(path, units=scan_units, seed=seed)
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


def fit_specimens(manifest: Manifest, *, scan_units: str | None = None, seed=0,
                  fit_options: dict | None = None):
    """Read and fit every scan of a manifest (progress bar on a terminal).

    Parameters
    ----------
    manifest : Manifest
    scan_units : {"m", "cm", "mm", "in"}, optional
        Unit of the scan files' coordinates; default: the format's own (m for E57, LAS/LAZ), else mm.
    seed : int
        Seeds the per-scan random steps (mesh sampling, RANSAC).
    fit_options : dict, optional
        Extra keyword options of ``airmat.calib.cylinder_fit.fit_cylinder``.

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
            spec, tr, tf = _fit_one(manifest, i, scan_units, int(seeds[i]), fit_options or {})
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
    scan_units : {"m", "cm", "mm", "in"}, optional
        Unit of the scan files.
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
