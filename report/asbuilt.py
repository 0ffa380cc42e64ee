"""The as-built part of the report: the scan of the built mattress against Ŝ, what it taught, what to re-cut.

A map on the mattress's Ω of the scan's deviation from Ŝ (per Ŝ vertex, the signed normal distance
of the scan points near it: grey where the scan has no points), then tables: the registration, the
two deviations (against Ŝ and against the prediction), the calibration's (Δ, d) before and after the
scan, the strings whose ties look wrong, and the correction's counts.

Built from an :class:`airmat.asbuilt.pipeline.AsBuilt` in memory (SI), shown in mm.
"""

from __future__ import annotations

from html import escape

import numpy as np

from airmat import palette
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table
from airmat.units import M_TO_MM

__all__ = ["asbuilt_map_figure", "asbuilt_part"]


def asbuilt_map_figure(res) -> dict:
    """The scan's signed deviation from Ŝ per Ŝ vertex on Ω (mm), a plotly figure."""
    a, dev = res.design.approx, res.to_target
    per = dev.per_vertex * M_TO_MM
    ok = np.isfinite(per)
    uv = np.round(a.uv * M_TO_MM, 1)
    lim = float(np.nanmax(np.abs(per))) if ok.any() else 1.0
    data = [{"type": "scatter", "mode": "markers", "name": "no scan points", "x": uv[~ok, 0], "y": uv[~ok, 1],
             "marker": {"color": "#BBBBBB", "size": 4}, "hoverinfo": "skip"},
            {"type": "scatter", "mode": "markers", "name": "scan", "x": uv[ok, 0], "y": uv[ok, 1],
             "marker": {"color": np.round(per[ok], 2), "colorscale": palette.SIGMA.plotly, "cmin": -lim, "cmax": lim,
                        "colorbar": {"title": {"text": "scan − Ŝ along the normal (mm)"}}, "size": 5},
             "hovertemplate": "u %{x:.0f} mm, v %{y:.0f} mm<br>%{marker.color:.1f} mm from Ŝ<extra></extra>"}]
    layout = {"xaxis": {"title": {"text": "u (mm), the mattress seen from the top"}, "constrain": "domain"},
              "yaxis": {"title": {"text": "v (mm)"}, "scaleanchor": "x"}, "legend": {"orientation": "h", "y": -0.15},
              "title": {"text": f"the built {res.surface} face (scan {escape(res.scan)}) against Ŝ: RMS "
                                f"{dev.rms * M_TO_MM:.1f} mm ({dev.rms_pct_diag:.2f} % of the diagonal), "
                                f"{100 * dev.coverage:.0f} % covered"}}
    return {"data": data, "layout": layout}


def _interval(mean, interval, i) -> str:
    """Median [95 % interval] of parameter ``i`` (mm)."""
    return f"{mean[i] * M_TO_MM:.2f} [{interval[0, i] * M_TO_MM:.2f}, {interval[1, i] * M_TO_MM:.2f}]"


def asbuilt_part(res) -> Part:
    """The report's part for a scan of the built mattress (:func:`airmat.asbuilt.pipeline.correct`)."""
    reg, upd, corr = res.registration, res.update, res.correction
    after = corr.rms_linear if corr.rms_verified is None else corr.rms_verified
    reg_rows = [["registration RMS (mm)", round(reg.rms * M_TO_MM, 2)],
                ["points on the predicted face", f"{100 * reg.inlier_share:.0f} % ({len(res.points)} used)"],
                ["face covered by the scan", f"{100 * reg.coverage:.0f} %"],
                ["unit factor", f"{reg.scale:g}"], ["poses that fit as well", reg.n_equivalent]]
    dev_rows = [[f"against {name}", round(d.rms * M_TO_MM, 1), round(d.max * M_TO_MM, 1), round(d.p95 * M_TO_MM, 1),
                 round(d.rms_pct_diag, 2), f"{100 * d.coverage:.0f} %"]
                for name, d in (("Ŝ", res.to_target), ("the prediction", res.to_prediction))]
    cal_rows = [[name, _interval(upd.prior_mean, upd.prior_interval95, i), _interval(upd.mean, upd.interval95, i)]
                for i, name in enumerate(("Δ (mm)", "d (mm)"))]
    flagged = [[i, round(e * M_TO_MM, 1), round(se * M_TO_MM, 1)]
               for i, e, se in zip(upd.ids, upd.error, upd.error_se) if i in upd.flagged]
    counts = corr.plan.counts
    body = (figure_html(asbuilt_map_figure(res), "asbuilt-map", height=560)
            + "<h3>Registration</h3>\n" + html_table(["", "value"], reg_rows)
            + f"<h3>The built {escape(res.surface)} face</h3>\n"
            + html_table(["", "RMS (mm)", "max (mm)", "p95 (mm)", "RMS % of the diagonal", "covered"], dev_rows)
            + "<h3>What the scan taught: Equation 3's Δ and d, median [95 % interval]</h3>\n"
            + html_table(["", "before the scan", "after the scan"], cal_rows)
            + (f"<p>{upd.iterations} linearisations; {escape(upd.message)}</p>\n")
            + ("<h3>Ties that look wrong</h3>\n" + html_table(["string", "length error (mm)", "± se (mm)"], flagged)
               if flagged else "<p>No tie looks wrong.</p>\n")
            + "<h3>The correction</h3>\n"
            + html_table(["keep", "re-cut", "move", "remove", "add", "predicted RMS after (mm)"],
                         [[counts["keep"], counts["recut"], counts["move"], counts["remove"], counts["add"],
                           round(after * M_TO_MM, 1)]])
            + "".join(f"<p>{escape(n)}</p>\n" for n in res.notes))
    banners = () if upd.converged else (("warn", f"as-built update: {upd.message}"),)
    return Part(title="As built: the scan against Ŝ, what it taught, what to re-cut", body=body, banners=banners)
