"""A calibration's files, written and read back: calibration.json, posterior.npz, specimens.csv.

Files use millimetres for lengths and 1/m for curvatures, with the units in
every field name (``delta_mm``, ``kappa_per_m``). :func:`write_calibration`
puts the files in a given folder (the caller stages it with
``airmat.atomic.staged_dir`` so a failed run leaves nothing half-written);
:func:`read_calibration` builds the same :class:`~airmat.calib.calibrate.Calibration`
from such a folder (SI units), so that the designer takes a calibration from
memory or from files alike.
"""

from __future__ import annotations

import csv
import io
import math
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.json_doc import dumps, finish, read_object
from airmat.npz_bytes import npz_bytes
from airmat.units import M_TO_MM, MM
from airmat.calib.likelihood import DEFAULT_PRIORS, PARAM_NAMES, Priors

__all__ = ["calibration_dict", "specimens_csv", "write_calibration", "read_calibration", "summary_text"]


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
    cal : airmat.calib.calibrate.Calibration
    truth : dict, optional
        Known true values (e.g. a synthetic set's truth.json), copied under ``"truth"``.
    """
    p, c = cal.posterior, cal.curve
    out = {
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
            "n_samples": int(p.samples.shape[0]), "converged": p.converged, "residual": p.residual,
            "message": p.message,
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
    return finish(out)


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


def write_calibration(cal, folder, *, truth: dict | None = None) -> list[Path]:
    """Write calibration.json, posterior.npz and specimens.csv into ``folder``.

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    p = cal.posterior
    files = [folder / "calibration.json", folder / "posterior.npz", folder / "specimens.csv"]
    files[0].write_text(dumps(calibration_dict(cal, truth=truth), indent=1) + "\n", encoding="utf-8")
    files[1].write_bytes(npz_bytes(delta_m=p.samples[:, 0], d_m=p.samples[:, 1], sigma_per_m=p.samples[:, 2],
                                   log_prob=p.log_prob, L_m=np.float64(cal.curve.L), start=p.start))
    files[2].write_text(specimens_csv(cal), encoding="utf-8")
    return files


def _against(ps, scale: float, truth: dict | None, key: str, unit: str, digits: int) -> str:
    """``"; truth 18.00 mm, median - truth -0.12, inside the 95% interval"`` (empty without that truth)."""
    if truth is None or truth.get(key) is None:
        return ""
    t = float(truth[key])
    inside = ps.lo95 * scale <= t <= ps.hi95 * scale
    return (f";  truth {t:.{digits}f} {unit}, median - truth {ps.median * scale - t:+.{digits}f}, "
            f"{'inside' if inside else 'OUTSIDE'} the 95% interval")


def summary_text(cal, folder=None, *, truth: dict | None = None) -> str:
    """A short human summary: parameters with 95% intervals (beside the truth when given), convergence,
    where the files are.

    Parameters
    ----------
    cal : Calibration
    folder : path, optional
        Where the files were written.
    truth : dict, optional
        A synthetic set's truth (``delta_mm``, ``d_mm``, optionally ``sigma_per_m``).
    """
    p = cal.posterior
    lines = [f"Delta = {p.delta.median * 1e3:.2f} mm  (95%: {p.delta.lo95 * 1e3:.2f} .. "
             f"{p.delta.hi95 * 1e3:.2f}){_against(p.delta, 1e3, truth, 'delta_mm', 'mm', 2)}",
             f"d     = {p.d.median * 1e3:.2f} mm  (95%: {p.d.lo95 * 1e3:.2f} .. {p.d.hi95 * 1e3:.2f})"
             f"{_against(p.d, 1e3, truth, 'd_mm', 'mm', 2)}",
             f"sigma = {p.sigma.median:.3f} 1/m  (95%: {p.sigma.lo95:.3f} .. {p.sigma.hi95:.3f})"
             f"{_against(p.sigma, 1.0, truth, 'sigma_per_m', '1/m', 3)}",
             f"MCMC: {p.message}; acceptance {p.acceptance_fraction:.2f}",
             f"{len(cal.specimens)} specimens, L = {cal.curve.L * 1e3:g} mm"]
    if folder is not None:
        from airmat.listing import listed

        lines.append(f"wrote {listed(folder, ('calibration.json', 'posterior.npz', 'specimens.csv'))} to {folder}")
    return "\n".join(lines)


# --- reading ------------------------------------------------------------------------------------------

def _read_json(path: Path) -> dict:
    if not path.is_file():
        raise InputError("calibration.json not found (expected the output folder of 'airmat calibrate')",
                         path=path)
    doc = read_object(path)
    params = doc.get("parameters")
    for name in ("delta_mm", "d_mm"):
        entry = params.get(name) if isinstance(params, dict) else None
        if not isinstance(entry, dict) or "median" not in entry:
            raise InputError(f"missing field 'parameters.{name}.median'", path=path, field=f"parameters.{name}")
        for key, value in entry.items():
            if key in _BAND_KEYS and not _finite_number(value):
                raise InputError(f"field 'parameters.{name}.{key}' must be a finite number, got {value!r}",
                                 path=path, field=f"parameters.{name}.{key}")
    return doc


_BAND_KEYS = ("median", "lo68", "hi68", "lo95", "hi95")


def _finite_number(value) -> bool:
    """True for a JSON number that is finite (not a bool, a string, a list or NaN)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _read_samples(path: Path) -> dict:
    if not path.is_file():
        raise InputError("posterior.npz not found (expected the output folder of 'airmat calibrate')",
                         path=path)
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:  # our handle: closed on BadZipFile
            arrays = {k: np.asarray(npz[k], dtype=float) for k in npz.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
        why = "empty file" if isinstance(exc, EOFError) else (str(exc) or type(exc).__name__)
        raise InputError(f"not readable as .npz: {why}", path=path) from None
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


def _string_spacing(doc: dict, arrays: dict, folder: Path) -> float:
    """L (m): posterior.npz ``L_m``, else ``curve.L_mm``, else the most common specimen ``L_mm``."""
    curve = doc.get("curve")
    if isinstance(curve, dict) and curve.get("L_mm") is not None and not (
            _finite_number(curve["L_mm"]) and curve["L_mm"] > 0):
        raise InputError(f"field 'curve.L_mm' must be a positive number (mm), got {curve['L_mm']!r}",
                         path=folder / "calibration.json", field="curve.L_mm")
    if "L_m" in arrays and arrays["L_m"].size:
        L = float(np.median(arrays["L_m"]))
        if not (np.isfinite(L) and L > 0):
            raise InputError(f"array 'L_m' must be > 0 m, got {L!r}", path=folder / "posterior.npz", field="L_m")
        return L
    specimens, L = doc.get("specimens"), None
    if isinstance(curve, dict) and curve.get("L_mm") is not None:
        L = float(curve["L_mm"]) * MM
    elif isinstance(specimens, list):
        values = [s.get("L_mm") for s in specimens if isinstance(s, dict) and s.get("L_mm") is not None]
        if values and all(_finite_number(v) for v in values):
            L = float(Counter(float(v) for v in values).most_common(1)[0][0]) * MM
    if L is None or not (np.isfinite(L) and L > 0):
        raise InputError("missing field 'curve.L_mm' (or specimens[].L_mm, or array L_m in posterior.npz): "
                         "the string spacing L the calibration used", path=folder / "calibration.json",
                         field="curve.L_mm")
    return L


def _specimens(rows: list, manifest_path: str):
    from airmat.calib.calibrate import SpecimenFit

    base = Path(manifest_path).parent
    needed = {"scan", "l_mm", "L_mm", "kappa_per_m", "kappa_se_per_m", "inlier_fraction", "rms_mm", "arc_deg",
              "n_points", "fit_converged"}
    rows = [r for r in rows if needed <= r.keys()]     # a foreign folder's partial rows are not specimens
    fits = tuple(SpecimenFit(
        scan=str(r["scan"]), path=str(base / str(r["scan"])), l=r["l_mm"] * MM, L=r["L_mm"] * MM,
        surface_offset=r.get("surface_offset_mm", 0.0) * MM, kappa=float(r["kappa_per_m"]),
        kappa_se=float(r["kappa_se_per_m"]),
        radius=math.inf if r.get("radius_mm") is None else r["radius_mm"] * MM,
        inlier_fraction=float(r["inlier_fraction"]), rms=r["rms_mm"] * MM, arc_deg=float(r["arc_deg"]),
        n_points=int(r["n_points"]), fit_converged=bool(r["fit_converged"])) for r in rows)
    kappa_model = np.array([float(r.get("kappa_model_per_m", np.nan)) for r in rows])
    return fits, kappa_model


def _priors(doc: dict, L_min: float) -> Priors:
    p = doc.get("priors")
    if not isinstance(p, dict) or not np.isfinite(L_min):
        return DEFAULT_PRIORS
    return Priors(delta_max_fraction=p["delta_mm"]["hi"] * MM / L_min, d_min=p["d_mm"]["lo"] * MM,
                  d_max=p["d_mm"]["hi"] * MM, sigma_scale=float(p["sigma_per_m"]["scale"]),
                  sigma_max=float(p["sigma_per_m"]["hi"]))


def read_calibration(folder):
    """Read the output folder of ``airmat calibrate`` back into a :class:`~airmat.calib.calibrate.Calibration`.

    The posterior samples come from ``posterior.npz`` bit for bit; the
    specimens, the curve and the diagnostics from ``calibration.json`` (their
    precision is that of the JSON numbers). A folder holding only the
    parameters and the samples (another tool's posterior, say) is read too:
    what it lacks is empty (no specimens, no curve bands) or NaN.

    Parameters
    ----------
    folder : path
        Folder with ``calibration.json`` and ``posterior.npz``.

    Returns
    -------
    Calibration
        SI units (m, 1/m); ``curve.L`` is the string spacing L of the samples.

    Raises
    ------
    airmat.errors.InputError
        With ``path=`` the offending file, naming the missing field or array.
    """
    from airmat.calib.calibrate import Calibration
    from airmat.calib.curve import KappaCurve
    from airmat.calib.manifest import Manifest
    from airmat.calib.posterior import ParamSummary, Posterior

    folder = Path(folder)
    if folder.is_file():
        hint = f" ({folder.parent})" if folder.name == "calibration.json" else ""
        raise InputError(f"is a file: give the folder that holds calibration.json{hint}, the --out folder of "
                         "'airmat calibrate'", path=folder)
    if not folder.is_dir():
        raise InputError("calibration folder not found", path=folder)
    json_path = folder / "calibration.json"
    doc = _read_json(json_path)
    arrays = _read_samples(folder / "posterior.npz")
    L = _string_spacing(doc, arrays, folder)
    n = arrays["delta_m"].size
    sigma = arrays.get("sigma_per_m", np.full(n, np.nan)).ravel()
    samples = np.column_stack([arrays["delta_m"].ravel(), arrays["d_m"].ravel(),
                               sigma if sigma.size == n else np.full(n, np.nan)])
    try:
        rows = [r for r in doc.get("specimens", []) if isinstance(r, dict)]
        specimens, kappa_model = _specimens(rows, str(doc.get("manifest", folder / "manifest.csv")))
        L_spec = np.array([s.L for s in specimens])
        manifest = Manifest(path=str(doc.get("manifest", "")), scans=tuple(s.scan for s in specimens),
                            scan_paths=tuple(s.path for s in specimens), l=np.array([s.l for s in specimens]),
                            L=L_spec, surface_offset=np.array([s.surface_offset for s in specimens]))
        diag = doc.get("diagnostics", {})
        tau = diag.get("tau", {})
        priors = _priors(doc, float(L_spec.min()) if L_spec.size else math.nan)
        curve = doc.get("curve", {})
        bands = curve.get("kappa_per_m", {})
        grid = np.asarray(curve.get("l_over_L", []), float)
        n_steps = int(diag.get("n_steps", 0))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"not a calibration.json written by 'airmat calibrate': {exc!r}", path=json_path) from None
    post = Posterior(
        samples=samples, log_prob=arrays.get("log_prob", np.full(n, np.nan)).ravel(),
        delta=ParamSummary.of(samples[:, 0]), d=ParamSummary.of(samples[:, 1]),
        sigma=ParamSummary.of(samples[:, 2]) if np.all(np.isfinite(samples[:, 2]))
        else ParamSummary(math.nan, math.nan, math.nan),
        start=arrays.get("start", np.full(3, np.nan)).ravel(),
        tau=np.array([float(tau.get(k, np.nan)) for k in PARAM_NAMES]),
        acceptance_fraction=float(diag.get("acceptance_fraction", np.nan)), n_steps=n_steps,
        n_walkers=int(diag.get("n_walkers", 0)), burn=int(diag.get("burn", 0)), thin=int(diag.get("thin", 1)),
        converged=bool(diag.get("converged", False)), n_iter=n_steps,
        residual=float(diag.get("residual", np.nan)), message=str(diag.get("message", "read from files")),
        priors=priors)
    curve_obj = KappaCurve(L=L, l_over_L=grid,
                           **{k: np.asarray(bands.get(k, np.full(grid.size, np.nan)), float)
                              for k in ("median", "lo68", "hi68", "lo95", "hi95")},
                           n_draws=int(curve.get("n_draws", 0)))
    return Calibration(manifest=manifest, specimens=specimens, posterior=post, curve=curve_obj,
                       kappa_model=kappa_model, seed=int(doc.get("seed", 0)),
                       timings=dict(doc.get("timings_s", {})))
