"""The calibration part of the report: κ₁(l/L) with its bands and the specimens, parameters, diagnostics.

Built from a :class:`airmat.calib.calibrate.Calibration` in memory (SI), shown in mm and 1/m. Given
the truth of a synthetic set (``truth.json``: ``delta_mm``, ``d_mm``, optionally ``sigma_per_m``),
the true curve is drawn and each true value stands beside its posterior. Colours from
:mod:`airmat.palette`.
"""

from __future__ import annotations

import numpy as np

from airmat import palette
from airmat.units import M_TO_MM
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table

__all__ = ["curve_figure", "truth_rows", "calibration_part"]


def _band(x, lo, hi, name: str, alpha: float) -> dict:
    """A filled band between ``lo`` and ``hi`` as one closed polygon."""
    return {"type": "scatter", "mode": "lines", "name": name, "fill": "toself", "hoverinfo": "skip",
            "x": np.round(np.concatenate([x, x[::-1]]), 4),
            "y": np.round(np.concatenate([hi, lo[::-1]]), 4),
            "line": {"width": 0}, "fillcolor": palette.rgba(palette.CALIBRATION["band"], alpha)}


def curve_figure(cal, *, truth: dict | None = None) -> dict:
    """κ₁ against l/L: posterior median, 68 % and 95 % bands, the specimens of that L, and the true curve.

    Error bars are ``2 sqrt(s_i² + σ²)`` (the specimen's standard error and the scatter σ),
    as in ``airmat.calib.plots.curve_figure``.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration
    truth : dict, optional
        ``{"delta_mm", "d_mm"}`` of a synthetic set: Equation 3's curve at those values, dashed.

    Returns
    -------
    dict
        A plotly figure.
    """
    c, p = cal.curve, cal.posterior
    spec = cal.specimens
    same_L = np.array([np.isclose(s.L, c.L) for s in spec], bool)
    x = np.array([s.l / s.L for s in spec])[same_L]
    y = np.array([s.kappa for s in spec])[same_L]
    err = 2.0 * np.hypot([s.kappa_se for s in spec], p.sigma.median)[same_L]
    names = [s.scan for s, keep in zip(spec, same_L) if keep]
    data = [_band(c.l_over_L, c.lo95, c.hi95, "95 % band", 0.18),
            _band(c.l_over_L, c.lo68, c.hi68, "68 % band", 0.35),
            {"type": "scatter", "mode": "lines", "name": "posterior median", "x": np.round(c.l_over_L, 4),
             "y": np.round(c.median, 4), "line": {"color": palette.CALIBRATION["median"], "width": 2},
             "hovertemplate": "l/L %{x:.3f}<br>κ₁ %{y:.3f} 1/m<extra>median</extra>"},
            {"type": "scatter", "mode": "markers", "name": "specimens (±2 sd incl. σ)",
             "x": np.round(x, 4), "y": np.round(y, 4), "text": names,
             "error_y": {"type": "data", "array": np.round(err, 4), "visible": True},
             "marker": {"color": palette.CALIBRATION["specimens"], "size": 7},
             "hovertemplate": "%{text}<br>l/L %{x:.3f}<br>κ %{y:.3f} 1/m<extra></extra>"}]
    if truth is not None:
        from airmat.calib.model import kappa1

        k = kappa1(c.l_over_L * c.L, c.L, truth["delta_mm"] / M_TO_MM, truth["d_mm"] / M_TO_MM)
        data.append({"type": "scatter", "mode": "lines", "x": np.round(c.l_over_L, 4), "y": np.round(k, 4),
                     "name": f"truth (Δ = {truth['delta_mm']:g} mm, d = {truth['d_mm']:g} mm)",
                     "line": {"color": palette.CALIBRATION["truth"], "width": 1.5, "dash": "dash"},
                     "hovertemplate": "l/L %{x:.3f}<br>κ₁ %{y:.3f} 1/m<extra>truth</extra>"})
    layout = {"title": {"text": f"κ₁(l/L) for L = {c.L * M_TO_MM:g} mm ({c.n_draws} posterior draws)"},
              "xaxis": {"title": {"text": "string length ratio l / L"}, "range": [0, 1]},
              "yaxis": {"title": {"text": "curvature κ₁ (1/m)"}}, "legend": {"x": 0.6, "y": 0.98}}
    return {"data": data, "layout": layout}


def _interval(ps, scale: float, digits: int) -> list:
    return [f"{ps.median * scale:.{digits}f}", f"{ps.lo95 * scale:.{digits}f}", f"{ps.hi95 * scale:.{digits}f}"]


def truth_rows(cal, truth: dict) -> list:
    """Per parameter in ``truth``: name, truth, posterior median − truth, and whether the 95 % interval holds it.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration
    truth : dict
        ``delta_mm``, ``d_mm`` and optionally ``sigma_per_m``.

    Returns
    -------
    list of (str, float, float, bool)
        In the file's units (mm, 1/m).
    """
    p = cal.posterior
    out = []
    for key, name, ps, scale in (("delta_mm", "Δ", p.delta, M_TO_MM), ("d_mm", "d", p.d, M_TO_MM),
                                 ("sigma_per_m", "σ", p.sigma, 1.0)):
        if truth.get(key) is not None:
            t = float(truth[key])
            out.append((name, t, ps.median * scale - t, bool(ps.lo95 * scale <= t <= ps.hi95 * scale)))
    return out


def _params_table(cal, truth) -> str:
    p = cal.posterior
    rows = [["Δ slip (mm)", *_interval(p.delta, M_TO_MM, 2)], ["d thickness (mm)", *_interval(p.d, M_TO_MM, 2)],
            ["σ specimen scatter (1/m)", *_interval(p.sigma, 1.0, 3)]]
    columns = ["parameter", "median", "2.5 %", "97.5 %"]
    if truth is not None:
        known = {name: (t, diff, inside) for name, t, diff, inside in truth_rows(cal, truth)}
        columns += ["truth", "median − truth", "truth in the 95 % interval"]
        for row, name, digits in zip(rows, ("Δ", "d", "σ"), (2, 2, 3)):
            t = known.get(name)
            row += (["–", "–", "–"] if t is None else
                    [f"{t[0]:.{digits}f}", f"{t[1]:+.{digits}f}", "yes" if t[2] else "NO"])
    return html_table(columns, rows, table_id="calibration-parameters")


def calibration_part(cal, *, truth: dict | None = None) -> Part:
    """The calibration section of the page.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration
    truth : dict, optional
        The truth of a synthetic set (``delta_mm``, ``d_mm``, optionally ``sigma_per_m``): beside the
        posterior in the parameters' table, and its curve on the κ₁(l/L) plot.

    Returns
    -------
    airmat.report.part.Part
    """
    p = cal.posterior
    params = _params_table(cal, truth)
    diag = html_table(["diagnostic", "value"], [
        ["converged", "yes" if p.converged else "NO"], ["steps", p.n_steps], ["walkers", p.n_walkers],
        ["burn-in / thin", f"{p.burn} / {p.thin}"],
        ["autocorrelation time τ (Δ, d, log σ) (steps)", ", ".join(f"{t:.1f}" for t in p.tau)],
        ["acceptance fraction", f"{p.acceptance_fraction:.3f}"],
        ["multiple × max τ / steps (≤ 1 when converged)", f"{p.residual:.3f}"], ["message", p.message]])
    rows = [[s.scan, f"{s.l * M_TO_MM:.1f}", f"{s.L * M_TO_MM:.1f}", f"{s.kappa:.4f}", f"{s.kappa_se:.4f}",
             f"{float(km):.4f}", f"{s.inlier_fraction:.3f}", f"{s.arc_deg:.1f}", f"{s.rms * M_TO_MM:.3f}",
             s.n_points, "yes" if s.fit_converged else "NO"]
            for s, km in zip(cal.specimens, np.asarray(cal.kappa_model).ravel())]
    spec = html_table(["scan", "l (mm)", "L (mm)", "κ (1/m)", "se (1/m)", "model κ (1/m)", "inlier fraction",
                       "arc (°)", "RMS (mm)", "points", "fit converged"], rows, sortable=True,
                      table_id="specimens")
    body = (figure_html(curve_figure(cal, truth=truth), "calibration-curve", height=460)
            + "<h3>Parameters (posterior median and 95 % interval"
            + (", and the truth of the synthetic set" if truth is not None else "") + ")</h3>\n" + params
            + "<h3>Convergence of the sampler</h3>\n" + diag
            + f"<h3>Specimens ({len(cal.specimens)})</h3>\n" + spec)
    banners = () if p.converged else (("bad", f"Calibration: the sampler did NOT converge ({p.message})"),)
    return Part("Calibration", body, banners)
