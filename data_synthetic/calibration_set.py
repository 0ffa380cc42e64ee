"""Synthetic calibration sets: scans of specimens with known Delta, d and scatter.

For true slip Delta, thickness d, string-end distance L and a list of string
lengths l, every specimen is bent to ``kappa_1(l) * exp(s z)`` (Equation 3
times a lognormal specimen-to-specimen scatter of log-sd ``s``, ``z ~ N(0, 1)``),
scanned with :func:`airmat.synthetic.specimen_scan.specimen_scan` and written
as a PLY file in millimetres, cycling through the PLY encodings a real scanner
zoo produces (ascii, binary little/big endian, float or double, extra
properties). Next to the scans: ``manifest.csv`` (the input of
``airmat calibrate``) and ``truth.json`` (the true values). Same seed, same
bytes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.atomic import staged_dir
from airmat.constants import PAPER_D, PAPER_DELTA, PAPER_L
from airmat.errors import InputError
from airmat.units import M_TO_MM
from airmat.calib.manifest import write_manifest_text
from airmat.calib.model import flat_length, kappa1

__all__ = ["CalibrationSet", "calibration_set", "DEFAULT_L_OVER_L", "PLY_FORMATS"]

#: default string-length ratios: 12 specimens from 0.3 to 0.95 (the last two flat
#: for the paper's Delta = 18 mm at L = 300 mm)
DEFAULT_L_OVER_L = tuple(np.round(np.linspace(0.30, 0.95, 12), 4).tolist())

#: (encoding, coordinate dtype, colours?, extra properties) cycled over the specimens
PLY_FORMATS = (
    ("binary_little_endian", "float32", False, ()),
    ("ascii", "float64", False, ()),
    ("binary_big_endian", "float64", False, ("confidence",)),
    ("binary_little_endian", "float64", True, ()),
    ("ascii", "float32", False, ("intensity",)),
    ("binary_big_endian", "float32", True, ("confidence",)),
)


@dataclass(frozen=True)
class CalibrationSet:
    """What :func:`calibration_set` wrote.

    Attributes
    ----------
    folder, manifest, truth_path : str
        The output folder, its manifest.csv and truth.json.
    scans : tuple of str
        Scan file names (relative to the folder).
    truth : dict
        The content of truth.json (mm and 1/m).
    """

    folder: str
    manifest: str
    truth_path: str
    scans: tuple
    truth: dict


def _check(delta, d, L, ratios, n_points, scatter):
    if not (L > 0 and d > 0 and 0 <= delta < L / 2):
        raise InputError(f"need L > 0, d > 0 and 0 <= Delta < L/2 (got L={L} m, d={d} m, "
                         f"Delta={delta} m)")
    if ratios.ndim != 1 or ratios.size < 3:
        raise InputError(f"need at least 3 string-length ratios l/L, got {ratios.size}")
    if not np.all((ratios > 0) & (ratios <= 1)):
        raise InputError(f"string-length ratios l/L must lie in (0, 1], got {ratios.tolist()}")
    if n_points < 1000:
        raise InputError(f"{n_points} points per scan are too few: use at least 1000")
    if not 0 <= scatter < 1:
        raise InputError(f"scatter (log-sd) must be in [0, 1), got {scatter}")


def _extras(rng, n, colors, names):
    col = rng.integers(0, 256, size=(n, 3), dtype=np.uint8) if colors else None
    extra = {name: rng.uniform(0, 1, n).astype(np.float32) for name in names} or None
    return col, extra


def _truth(*, delta, d, L, l, k_model, k_true, scatter, scans, seed, n_points) -> dict:
    return {
        "delta_mm": delta * M_TO_MM, "d_mm": d * M_TO_MM, "L_mm": L * M_TO_MM,
        "sigma_per_m": float(np.sqrt(np.mean((k_true - k_model) ** 2))),
        "scatter_log_sd": scatter, "flat_l_mm": float(flat_length(L, delta)) * M_TO_MM,
        "seed": seed, "n_points": n_points,
        "specimens": [{"scan": s, "l_mm": float(li * M_TO_MM), "kappa_model_per_m": float(km),
                       "kappa_per_m": float(kt)}
                      for s, li, km, kt in zip(scans, l, k_model, k_true)],
    }


def calibration_set(out, *, delta: float = PAPER_DELTA, d: float = PAPER_D, L: float = PAPER_L,
                    l_over_L=DEFAULT_L_OVER_L, n_points: int = 100_000, scatter: float = 0.03,
                    seed: int = 0, **scan_options) -> CalibrationSet:
    """Write a synthetic calibration set (scans, manifest.csv, truth.json) to ``out``.

    Parameters
    ----------
    out : path
        Output folder; files are staged and moved in only when all are written.
    delta, d, L : float
        True slip, mattress thickness and string-end distance (m).
    l_over_L : sequence of float
        String length ratios in (0, 1]; ``l`` is rounded to 0.1 mm (a tape
        measure) and the truth computed from the rounded value.
    n_points : int
        Points per scan (specimen, floor and clutter).
    scatter : float
        Log-sd of the lognormal specimen-to-specimen curvature scatter. truth.json
        reports it and ``sigma_per_m``, the RMS of the realized curvature
        deviations ``kappa_i - kappa_1(l_i)`` (1/m), which is what the
        posterior's additive scatter sigma estimates.
    seed : int
        Seeds the scatter, the scans and their extra properties.
    **scan_options
        Passed to :func:`~airmat.synthetic.specimen_scan.specimen_scan` (noise,
        outlier_fraction, ...).

    Returns
    -------
    CalibrationSet
    """
    from airmat.synthetic.ply_write import write_ply
    from airmat.synthetic.specimen_scan import specimen_scan

    ratios = np.atleast_1d(np.asarray(l_over_L, dtype=float))
    _check(delta, d, L, ratios, n_points, scatter)
    rng = np.random.default_rng(seed)
    l = np.round(ratios * L * M_TO_MM, 1) / M_TO_MM
    k_model = kappa1(l, L, delta, d)
    k_true = k_model * np.exp(scatter * rng.standard_normal(l.size))
    scan_seeds = rng.integers(2**31, size=l.size)
    scans = tuple(f"specimen_{i:02d}.ply" for i in range(l.size))
    with staged_dir(out) as tmp:
        for i, name in enumerate(scans):
            spec = specimen_scan(float(k_true[i]), L=L, thickness=d, n_points=n_points,
                                 seed=int(scan_seeds[i]), **scan_options)
            encoding, dtype, colors, names = PLY_FORMATS[i % len(PLY_FORMATS)]
            col, extra = _extras(np.random.default_rng(int(scan_seeds[i]) + 1), spec.points.shape[0],
                                 colors, names)
            write_ply(tmp / name, spec.points * M_TO_MM, encoding=encoding, dtype=dtype,
                      colors=col, extra=extra)
        (tmp / "manifest.csv").write_text(
            write_manifest_text(scans, l * M_TO_MM, np.full(l.size, L * M_TO_MM)), encoding="utf-8")
        truth = _truth(delta=delta, d=d, L=L, l=l, k_model=k_model, k_true=k_true, scatter=scatter,
                       scans=scans, seed=seed, n_points=n_points)
        (tmp / "truth.json").write_text(json.dumps(truth, indent=1) + "\n", encoding="utf-8")
    out = Path(out)
    return CalibrationSet(folder=str(out), manifest=str(out / "manifest.csv"),
                          truth_path=str(out / "truth.json"), scans=scans, truth=truth)
