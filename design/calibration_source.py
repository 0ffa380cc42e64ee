"""Where the designer gets Equation 3's parameters: a calibration folder or the paper's values.

A calibration folder is what ``airmat calibrate`` writes: ``calibration.json``
(``parameters.delta_mm`` and ``parameters.d_mm`` as ``{median, lo95, hi95}``,
the geodesic string spacing in ``curve.L_mm`` or in the specimens' ``L_mm``)
and ``posterior.npz`` (flat posterior samples ``delta_m``, ``d_m``,
``sigma_per_m``, ``L_m``). The designer propagates the posterior samples of
Δ and d through Equation 3 to give every string length a 95 % interval.

Without a calibration the paper's values are used (L = 300 mm, Δ = 18 mm,
d = 70 mm, Todo et al. 2024 §2.2) with a *stated, not measured* nominal
uncertainty, Δ ~ N(18, 3²) mm and d ~ N(70, 5²) mm, drawn as seeded
Gaussian samples; such a source says ``uncalibrated = True`` and every
output carries that label.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.constants import PAPER_D, PAPER_D_SD, PAPER_DELTA, PAPER_DELTA_SD, PAPER_L
from airmat.errors import InputError
from airmat.units import M_TO_MM

__all__ = ["CalibrationSource", "from_calibration", "load_calibration", "default_calibration", "PAPER"]

log = logging.getLogger(__name__)

#: the paper's Equation 3 parameters (m) and the nominal 1-sigma uncertainty used without a calibration
PAPER = {"L": PAPER_L, "delta": PAPER_DELTA, "d": PAPER_D, "delta_sd": PAPER_DELTA_SD, "d_sd": PAPER_D_SD}


@dataclass(frozen=True)
class CalibrationSource:
    """Posterior samples of Equation 3's Δ and d, and the calibrated string spacing L.

    Attributes
    ----------
    L : float
        Geodesic distance between string ends the calibration used (m).
    delta, d : ndarray of shape (s,)
        Posterior samples of the end slip Δ and of the effective thickness d (m).
    source : str
        The calibration folder, or ``"paper"`` for the default.
    uncalibrated : bool
        True when the values are the paper's, not a calibration of this mattress.
    label : str
        One line for reports, e.g. ``"UNCALIBRATED: paper values ..."``.
    sigma : ndarray of shape (s,) or None
        Posterior samples of the specimen-to-specimen curvature scatter σ (1/m), paired with
        ``delta`` and ``d``; None when not measured (the paper's default: the Monte-Carlo check
        then uses σ = 0 and says so).
    """

    L: float
    delta: np.ndarray
    d: np.ndarray
    source: str
    uncalibrated: bool
    label: str
    sigma: np.ndarray | None = None

    @classmethod
    def from_calibration(cls, cal, **kwargs) -> "CalibrationSource":
        """See :func:`from_calibration`."""
        return from_calibration(cal, **kwargs)

    @property
    def delta_median(self) -> float:
        """Posterior median of Δ (m): the end slip the inflation adds to each string (l* = l + 2Δ)."""
        return float(np.median(self.delta))

    @property
    def n_samples(self) -> int:
        """Number of posterior samples."""
        return int(self.delta.shape[0])

    def summary_mm(self) -> dict:
        """The file-boundary summary: source, label, L_mm, delta_mm and d_mm as {median, lo95, hi95}."""
        def band(x):
            lo, med, hi = np.percentile(np.asarray(x) * M_TO_MM, [2.5, 50.0, 97.5])
            return {"median": round(float(med), 3), "lo95": round(float(lo), 3), "hi95": round(float(hi), 3)}

        return {"source": self.source, "uncalibrated": bool(self.uncalibrated), "label": self.label,
                "L_mm": round(self.L * M_TO_MM, 3), "delta_mm": band(self.delta), "d_mm": band(self.d),
                "n_samples": self.n_samples}


def default_calibration(*, seed=0, n_samples: int = 2000, d: float | None = None) -> CalibrationSource:
    """The paper's Equation 3 parameters with a nominal Gaussian uncertainty (uncalibrated).

    Parameters
    ----------
    seed : int or numpy Generator
        Seed of the Gaussian samples.
    n_samples : int
        Number of samples of Δ and d.
    d : float, optional
        Nominal effective thickness (m); default the paper's 0.070 m. Pass the
        mattress thickness when it differs from the paper's.

    Returns
    -------
    CalibrationSource
        ``uncalibrated=True``; Δ ~ N(18 mm, 3 mm) clipped at 0, d ~ N(d, 5 mm)
        clipped at d / 2; ``sigma=None`` (the paper measured no scatter σ).
    """
    rng = np.random.default_rng(seed)
    d0 = PAPER["d"] if d is None else float(d)
    if not (d0 > 0 and np.isfinite(d0)):
        raise InputError(f"mattress thickness must be > 0 m, got {d0!r}", d=d0)
    delta = np.maximum(rng.normal(PAPER["delta"], PAPER["delta_sd"], n_samples), 0.0)
    dd = np.maximum(rng.normal(d0, PAPER["d_sd"], n_samples), 0.5 * d0)
    label = (f"UNCALIBRATED: paper values L = {PAPER['L'] * M_TO_MM:.0f} mm, "
             f"delta = {PAPER['delta'] * M_TO_MM:.0f} +- {PAPER['delta_sd'] * M_TO_MM:.0f} mm, "
             f"d = {d0 * M_TO_MM:.0f} +- {PAPER['d_sd'] * M_TO_MM:.0f} mm (nominal 1-sigma, not measured)")
    return CalibrationSource(L=PAPER["L"], delta=delta, d=dd, source="paper", uncalibrated=True, label=label)


def _thin(x: np.ndarray, max_samples: int | None) -> np.ndarray:
    """At most ``max_samples`` of ``x``, evenly spaced (deterministic, keeps the first and last)."""
    if max_samples is None or x.size <= max_samples:
        return x.copy()
    return x[np.linspace(0, x.size - 1, max_samples).round().astype(int)]


def from_calibration(cal, *, source: str | None = None, max_samples: int | None = 2000) -> CalibrationSource:
    """The designer's view of a :class:`airmat.calib.calibrate.Calibration`, in memory.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration
        From :func:`airmat.calib.calibrate.calibrate` or :func:`airmat.calib.calibration_io.read_calibration`.
    source : str, optional
        Where the calibration's files are (its folder), for the label and the
        design's files; default the manifest it was made from.
    max_samples : int or None
        Keep at most this many posterior samples, evenly thinned (deterministic),
        to bound the cost of propagating them through Equation 3; ``None``
        keeps all. 2000 samples put the Monte-Carlo error of the 95 % bounds
        well below a millimetre of string length.

    Returns
    -------
    CalibrationSource
        ``uncalibrated=False``; L (m) is the calibration curve's string spacing.
    """
    samples = np.asarray(cal.posterior.samples, float)
    delta, d = _thin(samples[:, 0], max_samples), _thin(samples[:, 1], max_samples)
    sigma = _thin(samples[:, 2], max_samples) if samples.shape[1] > 2 else None
    L = float(cal.curve.L)
    source = str(source if source is not None else cal.manifest.path)
    if samples.shape[0] > delta.size:
        log.debug("thinning %d posterior samples to %d", samples.shape[0], delta.size)
    label = (f"calibrated ({source}): L = {L * M_TO_MM:.0f} mm, "
             f"delta = {np.median(delta) * M_TO_MM:.1f} mm, d = {np.median(d) * M_TO_MM:.1f} mm "
             f"(posterior medians, {delta.size} samples)")
    return CalibrationSource(L=L, delta=delta, d=d, source=source, uncalibrated=False, label=label, sigma=sigma)


def load_calibration(folder, *, max_samples: int | None = 2000) -> CalibrationSource:
    """Read the output folder of ``airmat calibrate`` for the designer.

    :func:`airmat.calib.calibration_io.read_calibration` then :func:`from_calibration`
    with the folder as the source.

    Raises
    ------
    airmat.errors.InputError
        With ``path=`` the offending file, naming the missing field.
    """
    from airmat.calib.calibration_io import read_calibration

    return from_calibration(read_calibration(folder), source=str(folder), max_samples=max_samples)
