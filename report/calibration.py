"""The calibration part of the report: κ₁(l/L) with its bands and the specimens, parameters, diagnostics.

Built from a :class:`airmat.calib.calibrate.Calibration` in memory (SI), shown in mm and 1/m.
"""

from __future__ import annotations

import numpy as np

from airmat.units import M_TO_MM
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table

__all__ = ["curve_figure", "calibration_part"]


def _band(x, lo, hi, name: str, alpha: float) -> dict:
    """A filled band between ``lo`` and ``hi`` as one closed polygon."""
    return {"type": "scatter", "mode": "lines", "name": name, "fill": "toself", "hoverinfo": "skip",
            "x": np.round(np.concatenate([x, x[::-1]]), 4),
            "y": np.round(np.concatenate([hi, lo[::-1]]), 4),
            "line": {"width": 0}, "fillcolor": f"rgba(31,119,180,{alpha})"}


def curve_figure(cal) -> dict:
    """κ₁ against l/L: posterior median, 68 % and 95 % bands, and the specimens of that L.

    Error bars are ``2 sqrt(s_i² + σ²)`` (the specimen's standard error and the scatter σ),
    as in ``airmat.calib.plots.curve_figure``.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration

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
             "y": np.round(c.median, 4), "line": {"color": "rgb(31,119,180)", "width": 2},
             "hovertemplate": "l/L %{x:.3f}<br>κ₁ %{y:.3f} 1/m<extra>median</extra>"},
            {"type": "scatter", "mode": "markers", "name": "specimens (±2 sd incl. σ)",
             "x": np.round(x, 4), "y": np.round(y, 4), "text": names,
             "error_y": {"type": "data", "array": np.round(err, 4), "visible": True},
             "marker": {"color": "rgb(214,39,40)", "size": 7},
             "hovertemplate": "%{text}<br>l/L %{x:.3f}<br>κ %{y:.3f} 1/m<extra></extra>"}]
    layout = {"title": {"text": f"κ₁(l/L) for L = {c.L * M_TO_MM:g} mm ({c.n_draws} posterior draws)"},
              "xaxis": {"title": {"text": "string length ratio l / L"}, "range": [0, 1]},
              "yaxis": {"title": {"text": "curvature κ₁ (1/m)"}}, "legend": {"x": 0.6, "y": 0.98}}
    return {"data": data, "layout": layout}


def _interval(ps, scale: float, digits: int) -> list:
    return [f"{ps.median * scale:.{digits}f}", f"{ps.lo95 * scale:.{digits}f}", f"{ps.hi95 * scale:.{digits}f}"]


def calibration_part(cal) -> Part:
    """The calibration section of the page.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration

    Returns
    -------
    airmat.report.part.Part
    """
    p = cal.posterior
    params = html_table(["parameter", "median", "2.5 %", "97.5 %"], [
        ["Δ slip (mm)", *_interval(p.delta, M_TO_MM, 2)],
        ["d thickness (mm)", *_interval(p.d, M_TO_MM, 2)],
        ["σ specimen scatter (1/m)", *_interval(p.sigma, 1.0, 3)]])
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
    body = (figure_html(curve_figure(cal), "calibration-curve", height=460)
            + "<h3>Parameters (posterior median and 95 % interval)</h3>\n" + params
            + "<h3>Convergence of the sampler</h3>\n" + diag
            + f"<h3>Specimens ({len(cal.specimens)})</h3>\n" + spec)
    banners = () if p.converged else (("bad", f"Calibration: the sampler did NOT converge ({p.message})"),)
    return Part("Calibration", body, banners)
