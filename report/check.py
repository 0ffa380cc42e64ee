"""The check part of the report: Ŝ and the inflated shape overlaid in 3D, the envelope, realized κ per dash.

With a Monte-Carlo (``airmat.check.monte_carlo``): Ŝ coloured by each vertex's 95 % deviation
quantile over the samples, and a table of the samples' statistics.

Built from a :class:`airmat.check.inflation_check.DesignCheck` in memory (SI), shown in mm and 1/m.
"""

from __future__ import annotations

from html import escape

import numpy as np

from airmat.units import M_TO_MM
from airmat.report.mesh import display_grid, mesh3d_trace
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table

__all__ = ["overlay_figure", "curvature_figure", "band_figure", "monte_carlo_table", "check_part"]

_RUN_MARK = {"median": ("circle", "rgb(31,119,180)"), "lo95": ("triangle-down", "rgb(44,160,44)"),
             "hi95": ("triangle-up", "rgb(255,127,14)")}


def overlay_figure(check) -> dict:
    """Ŝ (grey, translucent) and the aligned inflated mid-surface of the median run coloured by its deviation."""
    a, dev = check.design.approx, check.runs["median"].deviation
    keep, faces = display_grid(a.uv, a.faces)
    s_hat = mesh3d_trace(a.xyz[keep], faces, name="Ŝ (design)", color="lightgrey", opacity=0.45)
    inflated = mesh3d_trace(dev.aligned[keep], faces, intensity=dev.per_vertex[keep] * M_TO_MM,
                            name="inflated (median strings)", colorscale="Viridis",
                            colorbar_title="deviation (mm)", hover="deviation %{intensity:.1f} mm")
    layout = {"scene": {"aspectmode": "data", "xaxis": {"title": {"text": "x (mm)"}},
                        "yaxis": {"title": {"text": "y (mm)"}}, "zaxis": {"title": {"text": "z (mm)"}}},
              "legend": {"x": 0, "y": 1},
              "title": {"text": f"inflated mid-surface over Ŝ: RMS {dev.rms * M_TO_MM:.1f} mm, "
                                f"max {dev.max * M_TO_MM:.1f} mm; drag to rotate"}}
    return {"data": [s_hat, inflated], "layout": layout}


def band_figure(check) -> dict:
    """Ŝ coloured by the 95 % quantile over the Monte-Carlo samples of each vertex's deviation (mm).

    Parameters
    ----------
    check : airmat.check.inflation_check.DesignCheck
        With ``monte_carlo`` (its ``per_vertex_q`` of shape (2, n) on Ŝ's n vertices, m).

    Returns
    -------
    dict
        A plotly figure: one ``mesh3d`` trace on the decimated display grid (mm).
    """
    a, mc = check.design.approx, check.monte_carlo
    keep, faces = display_grid(a.uv, a.faces)
    q95 = mc.per_vertex_q[1][keep] * M_TO_MM
    trace = mesh3d_trace(a.xyz[keep], faces, intensity=q95, name="Ŝ, 95 % deviation quantile",
                         colorscale="Viridis", colorbar_title="95 % quantile of deviation (mm)",
                         hover="95 % quantile %{intensity:.1f} mm")
    layout = {"scene": {"aspectmode": "data", "xaxis": {"title": {"text": "x (mm)"}},
                        "yaxis": {"title": {"text": "y (mm)"}}, "zaxis": {"title": {"text": "z (mm)"}}},
              "legend": {"x": 0, "y": 1},
              "title": {"text": f"Monte-Carlo band, {mc.draws.n} samples: 95 % of the built shapes deviate "
                                f"from Ŝ by at most this much (max {float(q95.max()) if q95.size else 0.0:.1f} mm)"}}
    return {"data": [trace], "layout": layout}


def monte_carlo_table(check, *, top: int = 10) -> tuple:
    """Two HTML tables of ``airmat.check.monte_carlo``: its statistics (mm), and the ``top`` most sensitive strings.

    Returns
    -------
    (str, str)
        The statistics table (samples, seed, σ source, converged runs, RMS median and 95th percentile
        with bootstrap standard errors, P(RMS ≤ T) when a tolerance was given) and the strings' table
        (id, face, Pearson correlation of its curvature change with the run's RMS).
    """
    mc, strings = check.monte_carlo, check.design.pattern.strings
    st = mc.stats()
    rows = [["samples", mc.draws.n], ["seed", mc.draws.seed], ["σ source", mc.draws.sigma_source],
            ["converged runs", f"{int(mc.converged.sum())} of {mc.converged.size}"],
            ["RMS median (mm)", f"{st['rms_median'] * M_TO_MM:.2f} ± {st['rms_median_se'] * M_TO_MM:.2f}"],
            ["RMS 95th percentile (mm)", f"{st['rms_p95'] * M_TO_MM:.2f} ± {st['rms_p95_se'] * M_TO_MM:.2f}"]]
    if mc.tolerance is not None:
        rows.append([f"P(RMS ≤ {mc.tolerance * M_TO_MM:g} mm)", f"{st['p_within']:.3f} ± {st['p_within_se']:.3f}"])
    stats = html_table(["statistic", "value (± bootstrap standard error)"], rows, table_id="monte-carlo-stats")
    idx, corr = mc.sensitive(top)
    sens = html_table(["string", "face", "correlation with RMS"],
                      [[strings[i].dash.id, strings[i].side, f"{c:+.3f}"] for i, c in zip(idx, corr)],
                      sortable=True, table_id="monte-carlo-strings")
    return stats, sens


def _monte_carlo_html(check) -> str:
    stats, sens = monte_carlo_table(check)
    return ("<h3>Monte-Carlo: the 95 % deviation band</h3>\n"
            + figure_html(band_figure(check), "check-band", height=620) + stats
            + "<p>The strings whose curvature scatter moves the shape most (Pearson r over the samples between "
              "the string's curvature change and the run's RMS; standard error about 1/√samples):</p>\n"
            + (sens if check.monte_carlo.sensitive(1)[0].size else
               "<p>None ranked: it needs 3 or more samples whose RMS varies.</p>\n"))


def curvature_figure(check) -> dict:
    """Realized against target κ per dash for every run (hover: the dash id), with the line y = x."""
    strings = check.design.pattern.strings
    kappa = np.array([s.kappa for s in strings], float)
    ids = [s.dash.id for s in strings]
    data = []
    for key, run in check.runs.items():
        symbol, colour = _RUN_MARK.get(key, ("square", "black"))
        data.append({"type": "scatter", "mode": "markers", "name": f"strings at {key}",
                     "x": np.round(kappa, 4), "y": np.round(np.asarray(run.kappa_realized, float), 4),
                     "text": ids, "marker": {"symbol": symbol, "color": colour, "size": 7},
                     "hovertemplate": "%{text}<br>target %{x:.3f} 1/m<br>realized %{y:.3f} 1/m<extra>"
                                      + key + "</extra>"})
    lo, hi = (min(float(kappa.min()), 0.0) * 1.1, max(float(kappa.max()), 0.0) * 1.1) if kappa.size else (0, 1)
    data.append({"type": "scatter", "mode": "lines", "name": "realized = target", "x": [lo, hi],
                 "y": [lo, hi], "line": {"color": "grey", "dash": "dot", "width": 1}, "hoverinfo": "skip"})
    layout = {"xaxis": {"title": {"text": "target κ of the dash (1/m)"}},
              "yaxis": {"title": {"text": "realized κ along the dash (1/m)"}},
              "title": {"text": "curvature along each dash"}}
    return {"data": data, "layout": layout}


def _runs_table(check) -> str:
    rows = []
    for key, run in check.runs.items():
        inf, dev = run.inflation, run.deviation
        rows.append([key, "yes" if inf.converged else "NO", inf.n_iter, f"{inf.residual:.2e}",
                     f"{dev.rms * M_TO_MM:.1f}", f"{dev.max * M_TO_MM:.1f}", f"{dev.rms_pct_diag:.2f}",
                     inf.message])
    # no wall-clock time on the page: the same inputs give the same bytes (times are in inflate.json)
    return html_table(["string lengths", "converged", "Newton iterations", "residual", "RMS (mm)", "max (mm)",
                       "RMS (% of diagonal)", "message"], rows)


def check_part(check, *, with_design_banner: bool = True) -> Part:
    """The inflation-check section of the page.

    Parameters
    ----------
    check : airmat.check.inflation_check.DesignCheck
    with_design_banner : bool
        Say UNCALIBRATED at the top for an uncalibrated design (when the page has no design part to say it).

    Returns
    -------
    airmat.report.part.Part
    """
    d = check.design
    banners = []
    if with_design_banner and d.calibration.uncalibrated:
        banners.append(("warn", f"UNCALIBRATED design: {d.calibration.label}"))
    failed = [k for k, r in check.runs.items() if not r.inflation.converged]
    body = (f"<p>Design <b>{escape(d.name)}</b> inflated on a {check.resolution * M_TO_MM:g} mm double-layer mesh "
            f"({check.runs['median'].inflation.mesh.n_vertices} vertices); strings simulated at l* = l + 2Δ.</p>\n")
    if check.open_loop is not None:      # a refined design: inflated the way it was refined
        body += (f"<p>A refined design: its open-loop strings were inflated from the flat mattress first "
                 f"({check.open_loop.n_iter} Newton iterations"
                 f"{'' if check.open_loop.converged else ', NOT converged'}), and every run below was carried "
                 f"on from that equilibrium to its own lengths, the path the refinement took.</p>\n")
    if failed:
        msg = "; ".join(f"{k}: {check.runs[k].inflation.message}" for k in failed)
        body += f'<div class="banner bad">The inflation did NOT converge ({escape(msg)}).</div>\n'
        banners.append(("bad", f"Inflation did NOT converge for {', '.join(failed)}: the shapes below are "
                               "not equilibria."))
    if not d.pattern.strings:
        body += '<div class="banner bad">The design has no strings: the mattress inflates flat.</div>\n'
    body += ("<h3>Ŝ and the inflated shape</h3>\n" + figure_html(overlay_figure(check), "check-overlay", height=620)
             + "<h3>Runs: the median lengths and the tolerance envelope (lo95, hi95)</h3>\n" + _runs_table(check))
    if d.pattern.strings:
        body += ("<h3>Realized against target curvature per dash</h3>\n"
                 + figure_html(curvature_figure(check), "check-curvature", height=480))
    if check.monte_carlo is not None:
        body += _monte_carlo_html(check)
    return Part("Inflation check", body, tuple(banners))
