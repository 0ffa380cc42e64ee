"""Write a calibration out: calibration.json, posterior.npz and specimens.csv.

Files use millimetres for lengths and 1/m for curvatures, with the units in
every field name (``delta_mm``, ``kappa_per_m``). The writers put files in a
given folder; the caller stages it (``airmat.atomic.staged_dir``) so a
failed run leaves nothing half-written.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from airmat import __version__
from airmat.units import M_TO_MM
from calib.posterior import PARAM_NAMES

__all__ = ["calibration_dict", "specimens_csv", "write_report", "summary_text"]


def _summary(p, scale: float) -> dict:
    return {"median": p.median * scale, "lo95": p.lo95 * scale, "hi95": p.hi95 * scale}


def _finite_or_none(x: float):
    return float(x) if math.isfinite(x) else None


def _specimen_row(s, kappa_model: float) -> dict:
    return {
        "scan": s.scan, "l_mm": s.l * M_TO_MM, "L_mm": s.L * M_TO_MM, "l_over_L": s.l / s.L,
        "surface_offset_mm": s.surface_offset * M_TO_MM,
        "kappa_per_m": s.kappa, "kappa_se_per_m": s.kappa_se,
        "kappa_model_per_m": float(kappa_model),
        "radius_mm": _finite_or_none(s.radius * M_TO_MM), "inlier_fraction": s.inlier_fraction,
        "rms_mm": s.rms * M_TO_MM, "arc_deg": s.arc_deg, "n_points": s.n_points,
        "fit_converged": s.fit_converged,
    }


def calibration_dict(cal, *, truth: dict | None = None) -> dict:
    """The content of calibration.json (mm and 1/m).

    Parameters
    ----------
    cal : calib.calibrate.Calibration
    truth : dict, optional
        Known true values (e.g. a synthetic set's truth.json), copied under ``"truth"``.
    """
    p, c = cal.posterior, cal.curve
    out = {
        "airmat_version": __version__,
        "seed": cal.seed,
        "manifest": cal.manifest.path,
        "parameters": {"delta_mm": _summary(p.delta, M_TO_MM), "d_mm": _summary(p.d, M_TO_MM),
                       "sigma_per_m": _summary(p.sigma, 1.0)},
        "priors": p.priors.describe(float(np.min(cal.manifest.L))),
        "specimens": [_specimen_row(s, k) for s, k in zip(cal.specimens, cal.kappa_model)],
        "diagnostics": {
            "tau": dict(zip(PARAM_NAMES, map(float, p.tau))),
            "acceptance_fraction": p.acceptance_fraction, "n_steps": p.n_steps,
            "n_walkers": p.n_walkers, "burn": p.burn, "thin": p.thin,
            "n_samples": int(p.samples.shape[0]), "converged": p.converged, "message": p.message,
        },
        "curve": {
            "L_mm": c.L * M_TO_MM, "l_over_L": c.l_over_L.tolist(), "n_draws": c.n_draws,
            "kappa_per_m": {k: getattr(c, k).tolist()
                            for k in ("median", "lo68", "hi68", "lo95", "hi95")},
        },
        "timings_s": {k: round(v, 3) for k, v in cal.timings.items()},
    }
    if truth is not None:
        out["truth"] = truth
    return out


def specimens_csv(cal) -> str:
    """specimens.csv: one row per specimen with its fit and the posterior median model."""
    rows = [_specimen_row(s, k) for s, k in zip(cal.specimens, cal.kappa_model)]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: ("" if v is None else f"{v:.9g}" if isinstance(v, float) else v)
                         for k, v in r.items()})
    return buf.getvalue()


def write_report(cal, folder, *, truth: dict | None = None) -> list[Path]:
    """Write calibration.json, posterior.npz and specimens.csv into ``folder``.

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    p = cal.posterior
    files = [folder / "calibration.json", folder / "posterior.npz", folder / "specimens.csv"]
    files[0].write_text(json.dumps(calibration_dict(cal, truth=truth), indent=1,
                                   allow_nan=False) + "\n", encoding="utf-8")
    with open(files[1], "wb") as fh:  # a file handle: np.savez would append .npz to a str
        np.savez(fh, delta_m=p.samples[:, 0], d_m=p.samples[:, 1], sigma_per_m=p.samples[:, 2],
                 log_prob=p.log_prob, L_m=np.float64(cal.curve.L))
    files[2].write_text(specimens_csv(cal), encoding="utf-8")
    return files


def summary_text(cal, folder=None) -> str:
    """A short human summary: parameters with 95% intervals, convergence, where the files are."""
    p = cal.posterior
    lines = [f"Delta = {p.delta.median * 1e3:.2f} mm  (95%: {p.delta.lo95 * 1e3:.2f} .. "
             f"{p.delta.hi95 * 1e3:.2f})",
             f"d     = {p.d.median * 1e3:.2f} mm  (95%: {p.d.lo95 * 1e3:.2f} .. {p.d.hi95 * 1e3:.2f})",
             f"sigma = {p.sigma.median:.3f} 1/m  (95%: {p.sigma.lo95:.3f} .. {p.sigma.hi95:.3f})",
             f"MCMC: {p.message}; acceptance {p.acceptance_fraction:.2f}",
             f"{len(cal.specimens)} specimens, L = {cal.curve.L * 1e3:g} mm"]
    if folder is not None:
        lines.append(f"wrote calibration.json, posterior.npz, specimens.csv, curve.png, corner.png "
                     f"to {folder}")
    return "\n".join(lines)
