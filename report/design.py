"""The design part of the report: the pattern on Ω, the Table-1 figures and verdict, Ŝ in 3D, the cutting list.

Built from a :class:`airmat.design.pipeline.DesignResult` in memory (SI), shown in mm and 1/m.
"""

from __future__ import annotations

import numpy as np

from airmat import palette
from airmat.units import M_TO_MM
from airmat.design.constructibility import edge_sigma
from airmat.design.string_lengths import CURL_NOTE
from airmat.report.mesh import display_grid, mesh3d_trace
from airmat.report.part import Part, figure_html
from airmat.report.table import html_table

__all__ = ["pattern_figure", "surface_figure", "vertex_sigma", "cutting_rows", "design_part", "CUTTING_COLUMNS"]

CUTTING_COLUMNS = ("id", "face", "family", "l median (mm)", "l lo95 (mm)", "l hi95 (mm)", "κ (1/m)", "L (mm)",
                   "a u (mm)", "a v (mm)", "b u (mm)", "b v (mm)", "flags")


def _polyline_trace(strings, name: str, colour: str, axes: str) -> dict:
    """The strings' dashes as one line trace (None between dashes), hover: id, lengths, κ."""
    x, y, text = [], [], []
    for s in strings:
        p = np.round(s.dash.polyline * M_TO_MM, 1)
        label = (f"{s.dash.id} ({s.side})<br>l = {s.l_median * M_TO_MM:.1f} mm "
                 f"[{s.l_lo95 * M_TO_MM:.1f}, {s.l_hi95 * M_TO_MM:.1f}]<br>κ = {s.kappa:.3f} 1/m"
                 + (f"<br>{', '.join(s.flags)}" if s.flags else ""))
        x.extend([*p[:, 0].tolist(), None])
        y.extend([*p[:, 1].tolist(), None])
        text.extend([label] * len(p) + [None])
    return {"type": "scatter", "mode": "lines", "name": name, "x": x, "y": y, "text": text,
            "hovertemplate": "%{text}<extra></extra>", "line": {"color": colour, "width": 2.5},
            "xaxis": "x" if axes == "1" else "x2", "yaxis": "y" if axes == "1" else "y2"}


def pattern_figure(result) -> dict:
    """The strings on Ω, top face left and bottom face right, by family (:data:`airmat.palette.FAMILIES`).

    Parameters
    ----------
    result : airmat.design.pipeline.DesignResult

    Returns
    -------
    dict
        A plotly figure (mm on Ω).
    """
    m = result.mattress
    w, h = m.width * M_TO_MM, m.height * M_TO_MM
    data = []
    for axes, side in (("1", "top"), ("2", "bottom")):
        for fam in ("k1", "k2"):
            sel = [s for s in result.pattern.strings if s.side == side and s.dash.family == fam]
            if sel:
                data.append(_polyline_trace(sel, f"{side} {fam} ({len(sel)})", palette.FAMILIES[fam], axes))
        outline = {"type": "scatter", "mode": "lines", "x": [0, w, w, 0, 0], "y": [0, 0, h, h, 0],
                   "line": {"color": "grey", "width": 1}, "hoverinfo": "skip", "showlegend": False}
        if axes == "2":
            outline.update(xaxis="x2", yaxis="y2")
        data.append(outline)
    layout = {"grid": {"rows": 1, "columns": 2, "pattern": "independent"},
              "xaxis": {"title": {"text": "u (mm), top face"}, "domain": [0, 0.47]},
              "yaxis": {"title": {"text": "v (mm)"}, "scaleanchor": "x"},
              "xaxis2": {"title": {"text": "u (mm), bottom face (seen from the top)"}, "domain": [0.53, 1]},
              "yaxis2": {"scaleanchor": "x2"}, "legend": {"orientation": "h", "y": -0.2},
              "title": {"text": f"{len(result.pattern.strings)} strings on the {w:.0f} × {h:.0f} mm mattress"}}
    return {"data": data, "layout": layout}


def vertex_sigma(xyz, uv, faces) -> np.ndarray:
    """Per vertex, the mean edge-length ratio σ = |edge on Ŝ| / |edge on Ω| of its edges, shape (n,)."""
    edges, sigma = edge_sigma(xyz, uv, faces)
    n = len(uv)
    total = np.bincount(edges.ravel(), weights=np.repeat(sigma, 2), minlength=n)
    count = np.bincount(edges.ravel(), minlength=n)
    return total / np.maximum(count, 1)


def surface_figure(result) -> dict:
    """Ŝ in 3D coloured by σ (decimated for display), with the strings' ends on it."""
    a = result.approx
    sigma = vertex_sigma(a.xyz, a.uv, a.faces)
    keep, faces = display_grid(a.uv, a.faces)
    trace = mesh3d_trace(a.xyz[keep], faces, intensity=sigma[keep], name="Ŝ", colorscale=palette.SIGMA.plotly,
                         colorbar_title="σ", hover="σ = %{intensity:.4f}")
    trace.update(cmid=1.0)
    layout = {"scene": {"aspectmode": "data", "xaxis": {"title": {"text": "x (mm)"}},
                        "yaxis": {"title": {"text": "y (mm)"}}, "zaxis": {"title": {"text": "z (mm)"}}},
              "title": {"text": "Ŝ coloured by the edge-length ratio σ (Ŝ / Ω); drag to rotate"}}
    return {"data": [trace], "layout": layout}


def cutting_rows(result) -> list:
    """One row per string under :data:`CUTTING_COLUMNS`, sorted by face, family and id (as cutting_list.csv)."""
    rows = []
    for s in sorted(result.pattern.strings, key=lambda s: (s.side, s.dash.family, s.dash.id)):
        a, b = s.dash.a * M_TO_MM, s.dash.b * M_TO_MM
        rows.append([s.dash.id, s.side, s.dash.family, f"{s.l_median * M_TO_MM:.1f}",
                     f"{s.l_lo95 * M_TO_MM:.1f}", f"{s.l_hi95 * M_TO_MM:.1f}", f"{s.kappa:.3f}",
                     f"{s.dash.length * M_TO_MM:.1f}", f"{a[0]:.1f}", f"{a[1]:.1f}", f"{b[0]:.1f}", f"{b[1]:.1f}",
                     ";".join(s.flags)])
    return rows


def _table1(rep) -> str:
    s, k1, k2 = rep.sigma, rep.kappa1, rep.kappa2
    return html_table(["σ min", "σ avg", "σ max", "|κ₁| avg (1/m)", "|κ₁| max (1/m)", "|κ₂| avg (1/m)",
                       "|κ₂| max (1/m)"],
                      [[f"{s['min']:.4f}", f"{s['avg']:.4f}", f"{s['max']:.4f}", f"{k1['avg']:.2f}",
                        f"{k1['max']:.2f}", f"{k2['avg']:.2f}", f"{k2['max']:.2f}"]])


def _verdict(rep) -> str:
    from html import escape

    lo, hi = rep.sigma_band
    head = (f"<p>Tolerances: σ in [{lo:g}, {hi:g}], |κ| ≤ {rep.kappa_max:.2f} 1/m.</p>\n")
    if rep.constructible:
        text = '<p class="banner ok">Constructible: yes.</p>\n'
    else:
        text = ('<div class="banner bad">Constructible: NO<ul>'
                + "".join(f"<li>{escape(r)}</li>" for r in rep.reasons) + "</ul></div>\n")
    warn = "".join(f'<p class="banner warn">Warning: {escape(w)}</p>\n' for w in rep.warnings)
    return head + text + warn


def _fold_section(route) -> str:
    """The fold route's trials (airmat.design.fold_route): σ and the price in distance to S of each."""
    from html import escape

    rows = [[f"× {t.ratio:g}" + (" (chosen)" if i == route.chosen else ""), f"{t.sigma_min:.3f}", f"{t.sigma_max:.3f}",
             f"{t.to_target_rms * 1e3:.1f}", f"{t.to_target_max * 1e3:.1f}", f"{100 * t.fold_share:.1f}"]
            for i, t in enumerate(route.trials)]
    return ("<h3>Folds</h3>\n" + f'<p class="banner {"ok" if route.found else "bad"}">{escape(route.message)}.</p>\n'
            + html_table(["k_A1", "σ min", "σ max", "Ŝ to S RMS (mm)", "Ŝ to S max (mm)", "folds (% of Ω)"], rows))


def _refine_section(b: dict) -> str:
    """What the refinement through the inflation did: the deviation before and after, its iterations."""
    from html import escape

    def row(label, d):
        return [label, f"{d['rms_mm']:.1f}", f"{d['rms_pct_diag']:.2f}", f"{d['max_mm']:.1f}"]

    if "deviation_before" not in b:          # corrected from a scan of the built mattress (airmat correct)
        after = b.get("rms_verified_mm") if b.get("rms_verified_mm") is not None else b.get("rms_linear_mm")
        return (f"<h3>String lengths corrected from a scan of the built mattress</h3>\n"
                f"<p>{escape(str(b.get('method', '')))}: {b.get('recut', 0)} strings re-cut, {b.get('kept', 0)} "
                f"kept; the face's predicted RMS from Ŝ {b.get('rms_before_mm', float('nan')):.1f} mm as built, "
                f"{after:.1f} mm after the re-cut.</p>\n")
    coarse = b.get("coarse_resolution_mm")
    mesh = f"{b['resolution_mm']:g} mm" + (f" (the iterations on the {coarse:g} mm mesh)" if coarse else "")
    rows = [row(f"before ({b.get('lengths_before', 'open-loop')} lengths)", b["deviation_before"]),
            row("after (these lengths)", b["deviation_after"])]
    text = (f"<h3>String lengths refined through the inflation</h3>\n"
            f"<p>The lengths were adjusted together so that the inflated {escape(b['surface'])} face lands on "
            f"Ŝ, at {mesh}: {b['iterations']} Gauss–Newton iterations, {b['seconds']:.1f} s; "
            f"{escape(b['message'])}.</p>\n"
            + html_table([f"the {b['surface']} face against Ŝ", "RMS (mm)", "% of the diagonal", "max (mm)"],
                         rows, table_id="refine-deviation"))
    r = b.get("reparametrization")
    if r is not None:
        text += (f"<p>Ŝ's points moved {r['moved_rms_mm']:.1f} mm RMS along it (at most {r['moved_max_mm']:.1f} mm; "
                 f"{r['off_surface_rms_mm']:.2f} mm RMS off it) to where the refined mattress puts them. "
                 f"\"after\" is against that Ŝ, \"before\" against the designed one (against the moved Ŝ: "
                 f"{r['deviation_before']['rms_mm']:.1f} mm RMS).</p>\n")
    gone = ", ".join(b["dropped"]) or "none"
    short = ", ".join(b["flagged"]) or "none"
    text += (f"<p>Dropped (a string reached its flat span: not needed): {escape(gone)}. Flagged (at the "
             f"shortest a tie allows): {escape(short)}. 'airmat inflate' at {b['resolution_mm']:g} mm reproduces "
             f"the deviation after.</p>\n")
    return text


def design_part(result) -> Part:
    """The design section of the page.

    Parameters
    ----------
    result : airmat.design.pipeline.DesignResult

    Returns
    -------
    airmat.report.part.Part
    """
    from html import escape

    rep, pat, cal = result.approx.report, result.pattern, result.calibration
    banners = []
    if cal.uncalibrated:
        banners.append(("warn", f"UNCALIBRATED design: {cal.label}"))
    body = f"<p>Target <b>{escape(result.name)}</b>; string lengths from: {escape(cal.label)}.</p>\n"
    if pat.strings:
        body += figure_html(pattern_figure(result), "design-pattern", height=560)
    else:
        why = "; ".join(pat.notes) or "no dash has a curvature that needs a string"
        body += f'<div class="banner bad">This design has no strings: {escape(why)}</div>\n'
        banners.append(("bad", "The design has no strings."))
    flagged = sum(1 for s in pat.strings if "beyond_reach" in s.flags)
    if flagged:
        body += (f'<p class="banner warn">{flagged} strings are beyond the reach of the calibration '
                 "(flag beyond_reach).</p>\n")
    counts = [[side, fam, pat.count(side, fam)] for side in ("top", "bottom") for fam in ("k1", "k2")]
    body += (html_table(["face", "family", "strings"], counts)
             + f"<p>Dashes without a string (|κ| too small): k1 {pat.n_no_string.get('k1', 0)}, "
               f"k2 {pat.n_no_string.get('k2', 0)}.</p>\n")
    body += "".join(f'<p class="banner warn">{escape(n)}.</p>\n' for n in pat.notes if CURL_NOTE in n)
    if rep is not None:
        body += "<h3>Table-1 figures of Ŝ and the verdict</h3>\n" + _table1(rep) + _verdict(rep)
        if getattr(result, "fold_route", None) is not None:
            body += _fold_section(result.fold_route)
        if not rep.constructible:
            banners.append(("bad", "The design is NOT constructible: " + "; ".join(rep.reasons)))
    b = getattr(result, "refine", None)
    if b:
        body += _refine_section(b)
        if not b.get("converged", True):
            banners.append(("warn", f"The refinement did not converge: {b['message']}"))
    body += "<h3>Ŝ in 3D</h3>\n" + figure_html(surface_figure(result), "design-surface", height=600)
    if pat.strings:
        body += (f"<h3>Cutting list ({len(pat.strings)} strings; click a header to sort)</h3>\n"
                 "<p>Cut each string to l median (tie to tie); lo95–hi95 is the tolerance.</p>\n"
                 '<div class="scroll">' + html_table(CUTTING_COLUMNS, cutting_rows(result), sortable=True,
                                                     table_id="cutting-list") + "</div>\n")
    return Part("Design", body, tuple(banners))
