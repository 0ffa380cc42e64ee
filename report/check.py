"""The check part of the report: the deviation map on Ω with the strings, the inflated face in 3D, realized κ.

First the map a user reads first: the deviation of the named face (``DesignCheck.surface``) on
the mattress's Ω coordinates, with the strings drawn, each face in its own colour and line style.
Then the inflated named face in 3D coloured by the same deviation with Ŝ as a wireframe (two
coincident translucent surfaces would flicker: z-fighting), each face's deviation, the runs (with
each run's distance to the user's target S when the design keeps S) and the realized κ per dash.
Every number says which face it measures.

With a Monte-Carlo (``airmat.check.monte_carlo``): Ŝ coloured by each vertex's 95 % deviation
quantile over the samples, and a table of the samples' statistics.

Built from a :class:`airmat.check.inflation_check.DesignCheck` in memory (SI), shown in mm and 1/m;
colours from :mod:`airmat.palette`.
"""

from __future__ import annotations

from html import escape

import numpy as np

from airmat import palette
from airmat.units import M_TO_MM
from airmat.report.mesh import display_grid, grid_image, mesh3d_trace, wireframe_trace
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table

__all__ = ["deviation_map_figure", "overlay_figure", "curvature_figure", "band_figure", "monte_carlo_table",
           "faces_table", "check_part"]

_SCENE = {"aspectmode": "data", "xaxis": {"title": {"text": "x (mm)"}}, "yaxis": {"title": {"text": "y (mm)"}},
          "zaxis": {"title": {"text": "z (mm)"}}}


def _strings_traces(strings) -> list:
    """The dashes on Ω (mm) as line traces, one per face over a white halo; hover: id, face, length, κ."""
    data = []
    for side in ("top", "bottom"):
        sel = [s for s in strings if s.side == side]
        if not sel:
            continue
        x, y, text = [], [], []
        for s in sel:
            p = np.round(s.dash.polyline * M_TO_MM, 1)
            label = f"{s.dash.id} ({side} face)<br>l = {s.l_median * M_TO_MM:.1f} mm<br>κ = {s.kappa:.3f} 1/m"
            x.extend([*p[:, 0].tolist(), None])
            y.extend([*p[:, 1].tolist(), None])
            text.extend([label] * len(p) + [None])
        data.append({"type": "scatter", "mode": "lines", "x": x, "y": y, "hoverinfo": "skip", "showlegend": False,
                     "line": {"color": palette.HALO, "width": 5}})
        data.append({"type": "scatter", "mode": "lines", "name": f"strings on the {side} face ({len(sel)})",
                     "x": x, "y": y, "text": text, "hovertemplate": "%{text}<extra></extra>",
                     "line": {"color": palette.FACES[side], "width": 2.5, "dash": palette.FACE_DASH[side][0]}})
    return data


def deviation_map_figure(check) -> dict:
    """The named face's deviation from Ŝ (median strings) on the mattress's Ω, the strings drawn by face.

    Parameters
    ----------
    check : airmat.check.inflation_check.DesignCheck

    Returns
    -------
    dict
        A plotly figure (mm on Ω): a heatmap of ``runs["median"].deviation.per_vertex`` on Ŝ's grid
        (markers when Ŝ's vertices are not a regular grid) and one line trace per face of strings.
    """
    d, dev, face = check.design, check.runs["median"].deviation, check.surface
    per = dev.per_vertex * M_TO_MM
    bar = {"title": {"text": f"deviation of the {face} face (mm)"}, "len": 0.8}
    hover = f"u %{{x:.0f}} mm, v %{{y:.0f}} mm<br>{face} face: %{{z:.1f}} mm from Ŝ<extra></extra>"
    image = grid_image(d.approx.uv, per)
    if image is not None:
        u, v, z = image
        heat = {"type": "heatmap", "name": f"{face} face", "x": np.round(u, 1), "y": np.round(v, 1),
                "z": np.round(z, 2), "colorscale": palette.DEVIATION.plotly, "zmin": 0, "colorbar": bar,
                "zsmooth": "best", "hovertemplate": hover}
    else:
        uv = np.round(d.approx.uv * M_TO_MM, 1)
        heat = {"type": "scatter", "mode": "markers", "name": f"{face} face", "x": uv[:, 0], "y": uv[:, 1],
                "marker": {"color": np.round(per, 2), "colorscale": palette.DEVIATION.plotly, "cmin": 0,
                           "colorbar": bar, "size": 5}, "showlegend": False,
                "hovertemplate": hover.replace("%{z", "%{marker.color")}
    w, h = d.mattress.width * M_TO_MM, d.mattress.height * M_TO_MM
    layout = {"xaxis": {"title": {"text": "u (mm), the mattress seen from the top"}, "range": [-0.02 * w, 1.02 * w],
                        "constrain": "domain"},
              "yaxis": {"title": {"text": "v (mm)"}, "scaleanchor": "x", "range": [-0.02 * h, 1.02 * h]},
              "legend": {"orientation": "h", "y": -0.15},
              "margin": {"l": 60, "r": 20, "t": 80, "b": 50},
              "title": {"text": f"the inflated {face} face against Ŝ, median strings: RMS {dev.rms * M_TO_MM:.1f} mm, "
                                f"max {dev.max * M_TO_MM:.1f} mm<br>({dev.rms_pct_diag:.2f} % of the diagonal; "
                                "on the mattress, seen from the top)"}}
    return {"data": [heat, *_strings_traces(d.pattern.strings)], "layout": layout}


def overlay_figure(check) -> dict:
    """The aligned inflated named face (median strings) coloured by its deviation, and Ŝ as a wireframe over it."""
    a, dev, face = check.design.approx, check.runs["median"].deviation, check.surface
    keep, faces = display_grid(a.uv, a.faces)
    inflated = mesh3d_trace(dev.aligned[keep], faces, intensity=dev.per_vertex[keep] * M_TO_MM,
                            name=f"inflated {face} face (median strings)", colorscale=palette.DEVIATION.plotly,
                            colorbar_title=f"deviation of the {face} face (mm)",
                            hover="deviation %{intensity:.1f} mm")
    inflated["cmin"] = 0
    s_hat = wireframe_trace(a.xyz[keep], a.uv[keep], faces, name="Ŝ (design), wireframe", color="#555555")
    layout = {"scene": _SCENE, "legend": {"x": 0, "y": 1},
              "title": {"text": f"the inflated {face} face against Ŝ: RMS {dev.rms * M_TO_MM:.1f} mm, "
                                f"max {dev.max * M_TO_MM:.1f} mm; drag to rotate, click a legend entry to hide it"}}
    return {"data": [inflated, s_hat], "layout": layout}


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
    face = check.surface
    trace = mesh3d_trace(a.xyz[keep], faces, intensity=q95, name=f"Ŝ, 95 % quantile of the {face} face's deviation",
                         colorscale=palette.BAND.plotly, colorbar_title=f"95 % quantile of the {face} face's "
                                                                       "deviation (mm)",
                         hover="95 % quantile %{intensity:.1f} mm")
    layout = {"scene": _SCENE, "legend": {"x": 0, "y": 1},
              "title": {"text": f"Monte-Carlo band, {mc.draws.n} samples: at 95 % of the built shapes the {face} "
                                f"face is this close to Ŝ (max {float(q95.max()) if q95.size else 0.0:.1f} mm)"}}
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
            [f"RMS of the {check.surface} face, median (mm)",
             f"{st['rms_median'] * M_TO_MM:.2f} ± {st['rms_median_se'] * M_TO_MM:.2f}"],
            [f"RMS of the {check.surface} face, 95th percentile (mm)",
             f"{st['rms_p95'] * M_TO_MM:.2f} ± {st['rms_p95_se'] * M_TO_MM:.2f}"]]
    if mc.tolerance is not None:
        rows.append([f"P(RMS of the {check.surface} face ≤ {mc.tolerance * M_TO_MM:g} mm)",
                     f"{st['p_within']:.3f} ± {st['p_within_se']:.3f}"])
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
        data.append({"type": "scatter", "mode": "markers", "name": f"strings at {key}",
                     "x": np.round(kappa, 4), "y": np.round(np.asarray(run.kappa_realized, float), 4),
                     "text": ids, "marker": {"symbol": palette.RUN_MARKERS[key].plotly, "color": palette.RUNS[key],
                                             "size": 7},
                     "hovertemplate": "%{text}<br>target %{x:.3f} 1/m<br>realized %{y:.3f} 1/m<extra>"
                                      + key + "</extra>"})
    lo, hi = (min(float(kappa.min()), 0.0) * 1.1, max(float(kappa.max()), 0.0) * 1.1) if kappa.size else (0, 1)
    data.append({"type": "scatter", "mode": "lines", "name": "realized = target", "x": [lo, hi],
                 "y": [lo, hi], "line": {"color": "grey", "dash": "dot", "width": 1}, "hoverinfo": "skip"})
    layout = {"xaxis": {"title": {"text": "target κ of the dash (1/m)"}},
              "yaxis": {"title": {"text": f"realized κ along the dash on the {check.surface} face (1/m)"}},
              "title": {"text": "curvature along each dash"}}
    return {"data": data, "layout": layout}


def _to_s(d) -> str:
    """A run's distance to the target S as its table cell: RMS in mm (% of Ŝ's diagonal), and over S alone when
    part of the face lies beyond S's rim."""
    if d is None:
        return "–"
    cell = f"{d.rms * M_TO_MM:.1f} ({d.rms_pct_diag:.2f})"
    if d.over is not None and d.over.any() and d.over_share < 1.0:
        cell += f"; over S ({100 * d.over_share:.0f} %): {d.over_rms * M_TO_MM:.1f}"
    return cell


def _runs_table(check) -> str:
    """Each run: convergence, the named face's deviation from Ŝ and, when the design keeps S, its distance to S."""
    to_s = any(run.to_target is not None for run in check.runs.values())
    rows = []
    for key, run in check.runs.items():
        inf, dev = run.inflation, run.deviation
        rows.append([key, "yes" if inf.converged else "NO", inf.n_iter, f"{inf.residual:.2e}",
                     f"{dev.rms * M_TO_MM:.1f}", f"{dev.max * M_TO_MM:.1f}", f"{dev.rms_pct_diag:.2f}",
                     *([_to_s(run.to_target)] if to_s else []), inf.message])
    face = check.surface
    # no wall-clock time on the page: the same inputs give the same bytes (times are in inflate.json)
    return html_table(["string lengths", "converged", "Newton iterations", "residual", f"RMS, {face} face (mm)",
                       f"max, {face} face (mm)", f"RMS, {face} face (% of diagonal)",
                       *(["to S: RMS mm (% diag)"] if to_s else []), "message"], rows, table_id="check-runs")


def faces_table(check) -> str:
    """Each face of the median run against Ŝ (``CheckRun.deviations``): RMS, max (mm), % of the diagonal.

    The named face (``DesignCheck.surface``), which every other number of the check measures, first.
    """
    med, face = check.runs["median"], check.surface
    devs = med.deviations or {face: med.deviation}
    order = [face, *[k for k in ("top", "bottom", "mid") if k in devs and k != face]]
    names = {"top": "top face", "bottom": "bottom face", "mid": "mid-surface"}
    rows = [[names[k] + (" (named: Ŝ stands for it)" if k == face else ""), f"{devs[k].rms * M_TO_MM:.1f}",
             f"{devs[k].max * M_TO_MM:.1f}", f"{devs[k].rms_pct_diag:.2f}"] for k in order]
    return html_table(["surface, median strings", "RMS (mm)", "max (mm)", "RMS (% of diagonal)"], rows,
                      table_id="check-faces")


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
    face = check.surface
    body += (f"<h3>Where the inflated {face} face misses Ŝ, on the mattress</h3>\n"
             + figure_html(deviation_map_figure(check), "check-map", height=640)
             + f"<h3>The inflated {face} face in 3D, Ŝ as a wireframe</h3>\n"
             + figure_html(overlay_figure(check), "check-overlay", height=620)
             + f"<h3>Each face against Ŝ</h3>\n<p>Ŝ stands for the {face} face: every deviation above and below "
               "is that face's. All the faces, for reference:</p>\n"
             + faces_table(check)
             + "<h3>Runs: the median lengths and the tolerance envelope (lo95, hi95)</h3>\n" + _runs_table(check))
    if d.pattern.strings:
        body += ("<h3>Realized against target curvature per dash</h3>\n"
                 + figure_html(curvature_figure(check), "check-curvature", height=480))
    if check.monte_carlo is not None:
        body += _monte_carlo_html(check)
    return Part("Inflation check", body, tuple(banners))
