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

import json
import logging
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.units import M_TO_MM, MM

__all__ = ["CalibrationSource", "load_calibration", "default_calibration", "PAPER"]

log = logging.getLogger(__name__)

#: the paper's Equation 3 parameters (m) and the nominal 1-sigma uncertainty used without a calibration
PAPER = {"L": 0.300, "delta": 0.018, "d": 0.070, "delta_sd": 0.003, "d_sd": 0.005}


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
    """

    L: float
    delta: np.ndarray
    d: np.ndarray
    source: str
    uncalibrated: bool
    label: str

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
        clipped at d / 2.
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


def _read_json(path: Path) -> dict:
    if not path.is_file():
        raise InputError("calibration.json not found (expected the output folder of 'airmat calibrate')",
                         path=path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"not readable as JSON: {exc}", path=path) from exc
    if not isinstance(doc, dict):
        raise InputError("expected a JSON object at the top level", path=path)
    params = doc.get("parameters")
    for name in ("delta_mm", "d_mm"):
        entry = params.get(name) if isinstance(params, dict) else None
        if not isinstance(entry, dict) or "median" not in entry:
            raise InputError(f"missing field 'parameters.{name}.median'", path=path, field=f"parameters.{name}")
    return doc


def _L_from_json(doc: dict, path: Path) -> float | None:
    curve = doc.get("curve")
    if isinstance(curve, dict) and curve.get("L_mm") is not None:
        return float(curve["L_mm"]) * MM
    specimens = doc.get("specimens")
    if isinstance(specimens, list):
        values = [s.get("L_mm") for s in specimens if isinstance(s, dict) and s.get("L_mm") is not None]
        if values:
            return float(Counter(float(v) for v in values).most_common(1)[0][0]) * MM
    return None


def _read_samples(path: Path) -> dict:
    if not path.is_file():
        raise InputError("posterior.npz not found (expected the output folder of 'airmat calibrate')",
                         path=path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: np.asarray(npz[k], dtype=float) for k in npz.files}
    except (OSError, ValueError) as exc:
        raise InputError(f"not readable as .npz: {exc}", path=path) from exc
    for name in ("delta_m", "d_m"):
        if name not in arrays:
            raise InputError(f"missing array '{name}'", path=path, field=name)
    delta, d = arrays["delta_m"].ravel(), arrays["d_m"].ravel()
    if delta.size == 0 or delta.shape != d.shape:
        raise InputError(f"arrays 'delta_m' {delta.shape} and 'd_m' {d.shape} must be non-empty and "
                         f"of the same length", path=path)
    bad = ~np.isfinite(delta) | ~np.isfinite(d) | (delta < 0) | (d <= 0)
    if np.any(bad):
        raise InputError(f"{int(bad.sum())} posterior samples are non-finite or non-physical "
                         f"(need delta_m >= 0 and d_m > 0)", path=path)
    return arrays


def load_calibration(folder, *, max_samples: int | None = 2000) -> CalibrationSource:
    """Read the output folder of ``airmat calibrate``.

    Parameters
    ----------
    folder : path
        Folder with ``calibration.json`` and ``posterior.npz``.
    max_samples : int or None
        Keep at most this many posterior samples, evenly thinned (deterministic),
        to bound the cost of propagating them through Equation 3; ``None``
        keeps all. 2000 samples put the Monte-Carlo error of the 95 % bounds
        well below a millimetre of string length.

    Returns
    -------
    CalibrationSource
        ``uncalibrated=False``; L (m) from ``posterior.npz`` ``L_m``, else
        ``curve.L_mm``, else the most common specimen ``L_mm``.

    Raises
    ------
    airmat.errors.InputError
        With ``path=`` the offending file, naming the missing field.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("calibration folder not found", path=folder)
    doc = _read_json(folder / "calibration.json")
    arrays = _read_samples(folder / "posterior.npz")
    if "L_m" in arrays and arrays["L_m"].size:
        L = float(np.median(arrays["L_m"]))
        if not (np.isfinite(L) and L > 0):
            raise InputError(f"array 'L_m' must be > 0 m, got {L!r}", path=folder / "posterior.npz", field="L_m")
    else:
        L = _L_from_json(doc, folder / "calibration.json")
    if L is None or not (np.isfinite(L) and L > 0):
        raise InputError("missing field 'curve.L_mm' (or specimens[].L_mm, or array L_m in posterior.npz): "
                         "the string spacing L the calibration used", path=folder / "calibration.json",
                         field="curve.L_mm")
    delta, d = arrays["delta_m"].ravel(), arrays["d_m"].ravel()
    if max_samples is not None and delta.size > max_samples:
        keep = np.linspace(0, delta.size - 1, max_samples).round().astype(int)
        log.debug("thinning %d posterior samples to %d", delta.size, max_samples)
        delta, d = delta[keep], d[keep]
    label = (f"calibrated ({folder}): L = {L * M_TO_MM:.0f} mm, "
             f"delta = {np.median(delta) * M_TO_MM:.1f} mm, d = {np.median(d) * M_TO_MM:.1f} mm "
             f"(posterior medians, {delta.size} samples)")
    return CalibrationSource(L=L, delta=delta.copy(), d=d.copy(), source=str(folder), uncalibrated=False,
                             label=label)
