"""Files of the inflation check: inflate.json, inflated.ply, inflated.3dm, deviation.png (mm, 1/m).

With Monte-Carlo samples (:mod:`airmat.check.monte_carlo`): inflate.json's ``monte_carlo``
block, ``inflated_bands.ply`` (Ŝ with per-vertex 50 % / 95 % deviation quantiles)
and a third panel of deviation.png, the 95 % band.

``inflated.3dm`` is the design's Rhino file (:mod:`airmat.design.export.rhino`) with the
inflated shapes added: each run's mid-surface at Ŝ's vertices after the Kabsch
alignment of the check (``CheckRun.deviation.aligned``), i.e. in Ŝ's frame, on
layers ``inflated::median`` (visible), ``inflated::lo95`` and ``inflated::hi95`` (hidden);
with a Monte-Carlo, Ŝ coloured by the 95 % quantile on the hidden layer ``monte_carlo::p95``.

``inflate.json``'s ``deviation {rms_mm, max_mm, rms_pct_diag}`` is measured on the named
face (``deviation.surface``, see :mod:`airmat.check.compare`), with every face under
``deviation.surfaces`` for reference; ``to_target`` is the same aligned face's distance to the
user's target S (``deviation.to_target`` per run) with Ŝ's own distance to S (``approx``), or a
note when the design was read from a folder written before ``target.ply``, which does not keep S.
``inflated.ply`` is the whole inflated mattress moved
into Ŝ's frame by the named face's alignment, so it overlays ``approx_surface.ply``.

:func:`deviation_figure` returns the figure of deviation.png as a
``matplotlib.figure.Figure`` (no pyplot state, :mod:`airmat.figures`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat import palette
from airmat.atomic import atomic_write_bytes, atomic_write_text
from airmat.figures import new_figure, save_png
from airmat.json_doc import dumps, finish
from airmat.units import M_TO_MM

__all__ = ["check_dict", "monte_carlo_dict", "deviation_figure", "write_check", "write_bands", "summary_text"]

_MM = M_TO_MM


def monte_carlo_dict(check) -> dict:
    """The ``monte_carlo`` block of inflate.json (mm), from ``airmat.check.monte_carlo``."""
    mc = check.monte_carlo
    dr, st = mc.draws, mc.stats()
    idx, corr = mc.sensitive()
    strings = check.design.pattern.strings
    out = {"samples": dr.n, "seed": dr.seed, "surface": check.surface,
           "chain": "per sample: (delta, d, sigma) drawn from the design's calibration posterior; per string, "
                    "kappa = kappa1(l_median; delta, d) + N(0, sigma^2) independent per string, turned into a "
                    "length by Equation 3 at the design's median (delta, d), then simulated at the length map's "
                    "l* (airmat.check.monte_carlo)",
           "sigma_source": dr.sigma_source,
           "rms_mm": {"median": round(st["rms_median"] * _MM, 3), "median_se": round(st["rms_median_se"] * _MM, 3),
                      "p95": round(st["rms_p95"] * _MM, 3), "p95_se": round(st["rms_p95_se"] * _MM, 3),
                      "per_sample": [round(float(r) * _MM, 3) for r in mc.rms]},
           "se_method": "bootstrap of the quantile over the samples (1000 resamples, seeded by seed)",
           "converged": int(np.count_nonzero(mc.converged))}
    if mc.tolerance is not None:
        out["tolerance_mm"] = round(mc.tolerance * _MM, 3)
        out["p_rms_within_tolerance"] = round(st["p_within"], 4)
        out["p_rms_within_tolerance_se"] = round(st["p_within_se"], 4)
    out["sensitive_strings"] = [{"id": strings[i].dash.id, "side": strings[i].side,
                                 "correlation": round(float(c), 3)} for i, c in zip(idx, corr)]
    out["sensitivity"] = ("Pearson correlation over the samples between a string's curvature change "
                          "(kappa - kappa at the medians) and the run's RMS deviation, largest |r| first: the "
                          "scatter is independent per string, so r measures that string's own effect; its "
                          "standard error is about 1/sqrt(samples)")
    out["bands_file"] = "inflated_bands.ply"
    return out


def write_bands(check, path) -> None:
    """inflated_bands.ply: Ŝ's mesh (mm) with the Monte-Carlo deviation quantiles per vertex.

    Vertex properties ``deviation_q50_mm`` and ``deviation_q95_mm``: the 50 % and 95 % quantiles,
    over the samples, of each vertex's distance from the aligned inflated face (mm).
    """
    import trimesh

    a, q = check.design.approx, check.monte_carlo.per_vertex_q
    mesh = trimesh.Trimesh(a.xyz * _MM, a.faces, process=False)
    mesh.vertex_attributes["deviation_q50_mm"] = (q[0] * _MM).astype(np.float32)
    mesh.vertex_attributes["deviation_q95_mm"] = (q[1] * _MM).astype(np.float32)
    atomic_write_bytes(path, trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=True))


def _dev_dict(dev) -> dict:
    return {"rms_mm": round(dev.rms * M_TO_MM, 3), "max_mm": round(dev.max * M_TO_MM, 3),
            "rms_pct_diag": round(dev.rms_pct_diag, 4)}


def _run_dict(run) -> dict:
    inf, dev = run.inflation, run.deviation
    others = run.deviations or {}
    to_target = {} if run.to_target is None else {"to_target": run.to_target.summary_mm()}
    return {"deviation": {**_dev_dict(dev), "surface": dev.surface,
                          "surfaces": {k: _dev_dict(v) for k, v in others.items()}, **to_target},
            "solver": {"converged": bool(inf.converged), "iterations": int(inf.n_iter),
                       "residual": float(inf.residual),
                       "stages": int(inf.stages), "message": inf.message}}


#: inflate.json's ``to_target`` when the design does not keep its target S (a folder without target.ply)
TO_TARGET_NOTE = {"note": "the design was read from a folder without target.ply, which does not keep the target "
                          "S: only the deviation from S-hat (approx_surface) is measured"}


def check_dict(check) -> dict:
    """The inflate.json document of a :class:`~airmat.check.inflation_check.DesignCheck`."""
    med, d = check.runs["median"], check.design
    doc = {"design": str(d.source if d.source is not None else d.name),
           "resolution_mm": round(check.resolution * M_TO_MM, 3),
           "mesh_vertices": int(med.inflation.mesh.n_vertices),
           "delta_mm": round(d.calibration.delta_median * M_TO_MM, 3),
           "surface": check.surface,
           "note": "strings simulated at l* = l + 2 delta (their ends do not slip in the simulation); "
                   f"deviation of the aligned {check.surface} face (the face that keeps its length, opposite "
                   "the larger share of bending |kappa| x span) from approx_surface, correspondence through the "
                   "mattress; the other faces under deviation.surfaces; kappa_realized on the same face (the turn of "
                   "the face's normal from one end of the dash to the other over its arc: its mean normal "
                   "curvature), "
                   "kappa_realized_free on the face opposite each dash's string; inflated.ply in "
                   "approx_surface's frame",
           **_run_dict(med)}
    approx = getattr(check, "approx_to_target", None)
    doc["to_target"] = TO_TARGET_NOTE if med.to_target is None else {
        **med.to_target.summary_mm(), "surface": check.surface,
        **({} if approx is None else {"approx": approx.summary_mm()}),
        "note": "distance of the same aligned face to the closest points of the user's target S (its rim "
                "included), % of approx_surface's diagonal; over_target: the same over the points that lie over "
                "S, not beyond its rim (a target smaller than the mattress, a hole in it), and their share; "
                "approx: S-hat's own distance to S; deviation is to S-hat, the near-developable surface the "
                "mattress can make"}
    doc["envelope"] = {k: _run_dict(r)["deviation"] for k, r in check.runs.items() if k != "median"}
    doc["envelope_solver"] = {k: _run_dict(r)["solver"] for k, r in check.runs.items() if k != "median"}
    doc["dashes"] = [{"id": s.dash.id, "side": s.side, "kappa_target_per_m": round(float(s.kappa), 4),
                      **{f"kappa_realized_{k}_per_m": round(float(r.kappa_realized[n]), 4)
                         for k, r in check.runs.items()}}
                     for n, s in enumerate(d.pattern.strings)]
    free = med.kappa_realized_free
    for n, dash in enumerate(doc["dashes"]):
        dash["kappa_realized_per_m"] = dash.pop("kappa_realized_median_per_m")
        if free is not None:
            dash["kappa_realized_free_per_m"] = round(float(free[n]), 4)
    doc["converged"] = bool(check.converged)
    base = check.open_loop       # a refined design: every run carried on from its open-loop equilibrium
    doc["start"] = {"from": "flat"} if base is None else {
        "from": "open-loop equilibrium", "converged": bool(base.converged), "iterations": int(base.n_iter),
        "seconds": round(base.seconds, 3)}
    if check.monte_carlo is not None:
        doc["monte_carlo"] = monte_carlo_dict(check)
    if getattr(check, "tolerance", None) is not None:      # the tolerance to first order (airmat.check.tolerance)
        doc["tolerance"] = check.tolerance.block()
    # the one field that differs between two runs of the same inputs: wall-clock seconds per run
    doc["timings_s"] = {k: round(r.inflation.seconds, 3) for k, r in check.runs.items()}
    if getattr(check, "tolerance", None) is not None:       # wall-clock seconds live in timings_s only
        doc["timings_s"]["tolerance"] = round(check.tolerance.seconds, 3)
        if check.tolerance.validation is not None:
            doc["timings_s"]["tolerance_validation"] = round(check.tolerance.validation.seconds, 3)
    if check.monte_carlo is not None:
        doc["timings_s"]["monte_carlo_runs"] = round(check.monte_carlo.seconds, 3)
    return finish(doc)


def _draw_strings_by_face(ax, strings) -> None:
    """The strings' chords on Ω (mm) in their face's colour and line style, over a white halo."""
    for s in strings:
        a, b = s.dash.a * M_TO_MM, s.dash.b * M_TO_MM
        ax.plot([a[0], b[0]], [a[1], b[1]], color=palette.HALO, lw=3.2, solid_capstyle="round")
        ax.plot([a[0], b[0]], [a[1], b[1]], color=palette.FACES[s.side], lw=1.6, ls=palette.FACE_DASH[s.side][1])


def deviation_figure(check):
    """Ŝ on Ω coloured by the deviation of the median inflation, and realized against target κ per dash.

    Parameters
    ----------
    check : airmat.check.inflation_check.DesignCheck

    Returns
    -------
    matplotlib.figure.Figure
    """
    d, med = check.design, check.runs["median"]
    uv, faces = d.approx.uv, d.approx.faces
    kappa = np.array([s.kappa for s in d.pattern.strings])
    mc = check.monte_carlo
    fig = new_figure((19, 5.5) if mc is not None else (13, 5.5))
    axes = fig.subplots(1, 3 if mc is not None else 2,
                        gridspec_kw={"width_ratios": [1.25, 1, 1.25] if mc is not None else [1.25, 1]})
    ax, ax2 = axes[0], axes[1]
    tpc = ax.tripcolor(uv[:, 0] * M_TO_MM, uv[:, 1] * M_TO_MM, faces, med.deviation.per_vertex * M_TO_MM,
                       shading="gouraud", cmap=palette.DEVIATION.matplotlib)
    fig.colorbar(tpc, ax=ax, label=f"deviation of the {check.surface} face from Ŝ (mm)")
    _draw_strings_by_face(ax, d.pattern.strings)
    ax.set_aspect("equal")
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    dev = med.deviation
    ax.set_title(f"deviation of the inflated {check.surface} face from Ŝ, median strings: RMS "
                 f"{dev.rms * M_TO_MM:.1f} mm, max {dev.max * M_TO_MM:.1f} mm\n(on the mattress; strings: "
                 "top face solid, bottom face dashed)", fontsize=9)
    ax2.axline((0, 0), slope=1, color="grey", lw=0.8)
    for key in ("median", "lo95", "hi95"):
        if key in check.runs:
            ax2.plot(kappa, check.runs[key].kappa_realized, palette.RUN_MARKERS[key].matplotlib, ms=4,
                     color=palette.RUNS[key], label=f"strings at {key}")
    ax2.set_xlabel("target κ of the dash (1/m)")
    ax2.set_ylabel(f"realized κ on the {check.surface} face (1/m)")
    ax2.legend(fontsize=8)
    ax2.set_title("curvature along each dash", fontsize=9)
    env = " · ".join(f"{k} {r.deviation.rms * M_TO_MM:.1f} ({r.deviation.max * M_TO_MM:.1f})"
                     for k, r in check.runs.items())
    if mc is not None:
        ax3 = axes[2]
        band = ax3.tripcolor(uv[:, 0] * M_TO_MM, uv[:, 1] * M_TO_MM, faces, mc.per_vertex_q[1] * M_TO_MM,
                             shading="gouraud", cmap=palette.BAND.matplotlib)
        fig.colorbar(band, ax=ax3, label=f"95 % quantile of the {check.surface} face's deviation (mm)")
        ax3.set_aspect("equal")
        ax3.set_xlabel("u (mm)")
        st = mc.stats()
        ax3.set_title(f"95 % band of the {check.surface} face over {mc.rms.size} Monte-Carlo samples\n"
                      f"(RMS median "
                      f"{st['rms_median'] * M_TO_MM:.1f}, 95th percentile {st['rms_p95'] * M_TO_MM:.1f} mm)",
                      fontsize=9)
    fig.suptitle(f"airmat inflate: the {check.surface} face against Ŝ, RMS (max) in mm with the strings at {env}",
                 fontsize=10)
    fig.tight_layout()
    return fig


def write_check(check, folder, *, workers: int = 1) -> dict:
    """Write inflate.json, inflated.ply, inflated.3dm and deviation.png into ``folder``; return the JSON document.

    With ``workers`` of 2 or more the figure (matplotlib) and the other files are written side by side on
    forked processes (:class:`airmat.forked.ForkedMap`, Linux); the same files."""
    from airmat.forked import ForkedMap

    folder = Path(folder)
    doc = check_dict(check)
    ForkedMap(lambda part: _write_part(part, check, doc, folder), ("figure", "rest"), workers).results()
    return doc


def _write_part(part: str, check, doc: dict, folder: Path) -> None:
    """One of :func:`write_check`'s two groups of files: ``"figure"`` (deviation.png) or ``"rest"``."""
    if part == "figure":
        save_png(deviation_figure(check), folder / "deviation.png", dpi=110)
        return
    import trimesh

    from airmat.design.design_io import document
    from airmat.design.export.rhino import write_3dm

    atomic_write_text(folder / "inflate.json", dumps(doc, indent=2) + "\n")
    med = check.runs["median"]
    inf = med.inflation
    mesh = trimesh.Trimesh(med.deviation.apply(inf.xyz) * M_TO_MM, inf.mesh.faces, process=False)
    atomic_write_bytes(folder / "inflated.ply", trimesh.exchange.ply.export_ply(mesh, encoding="binary"))
    a = check.design.approx
    write_3dm(folder / "inflated.3dm", document(check.design), a.xyz, a.uv, a.faces,
              shapes={k: r.deviation.aligned for k, r in check.runs.items()},
              band=None if check.monte_carlo is None else check.monte_carlo.per_vertex_q[1])
    if check.monte_carlo is not None:
        write_bands(check, folder / "inflated_bands.ply")


def summary_text(doc: dict, out) -> str:
    dev, env, s = doc["deviation"], doc["envelope"], doc["solver"]
    lines = [f"airmat check: {len(doc['dashes'])} strings, {doc['mesh_vertices']} vertices at "
             f"{doc['resolution_mm']:g} mm",
             f"  solver: {'converged' if s['converged'] else 'NOT CONVERGED'} in {s['iterations']} Newton "
             f"iterations, residual {s['residual']:.1e}, {doc['timings_s']['median']:.1f} s",
             *([] if doc.get("start", {}).get("from", "flat") == "flat" else [
                 f"  refined design: its open-loop lengths inflated first ({doc['start']['iterations']} Newton "
                 f"iterations, {doc['start']['seconds']:.1f} s), each run carried on from there, as it was refined"]),
             f"  deviation from Ŝ ({dev.get('surface', 'mid')} face): RMS {dev['rms_mm']:.1f} mm "
             f"({dev['rms_pct_diag']:.2f}% of the diagonal), max {dev['max_mm']:.1f} mm"]
    tt = doc.get("to_target", {})
    if "rms_mm" in tt:
        own = f"; Ŝ itself RMS {tt['approx']['rms_mm']:.1f} mm from S" if "approx" in tt else ""
        lines.append(f"  distance to the target S (same face): RMS {tt['rms_mm']:.1f} mm "
                     f"({tt['rms_pct_diag']:.2f}% of the diagonal), max {tt['max_mm']:.1f} mm{own}")
        over = tt.get("over_target")
        if over is not None and over["share"] < 1.0:
            own_over = tt.get("approx", {}).get("over_target")
            lines.append(f"    over S ({100 * over['share']:.0f}% of the face; the rest lies beyond its rim): RMS "
                         f"{over['rms_mm']:.1f} mm ({over['rms_pct_diag']:.2f}%), max {over['max_mm']:.1f} mm"
                         + (f"; Ŝ itself RMS {own_over['rms_mm']:.1f} mm there" if own_over else ""))
    ref = {k: v for k, v in dev.get("surfaces", {}).items() if k != dev.get("surface")}
    if ref:
        lines.append("  other faces (reference): " + ", ".join(
            f"{k} RMS {v['rms_mm']:.1f} mm ({v['rms_pct_diag']:.2f}%)" for k, v in ref.items()))
    for k, e in env.items():
        lines.append(f"  strings at {k}: RMS {e['rms_mm']:.1f} mm, max {e['max_mm']:.1f} mm")
    if doc["dashes"]:
        err = np.array([x["kappa_realized_per_m"] - x["kappa_target_per_m"] for x in doc["dashes"]])
        lines.append(f"  realized minus target curvature per dash (on the {dev.get('surface', 'mid')} face): "
                     f"mean {err.mean():+.2f}, "
                     f"RMS {np.sqrt(np.mean(err ** 2)):.2f} 1/m")
    mc = doc.get("monte_carlo")
    if mc is not None:
        r = mc["rms_mm"]
        line = (f"  Monte-Carlo, {mc['samples']} samples (seed {mc['seed']}): RMS median {r['median']:.1f} "
                f"+- {r['median_se']:.1f} mm, 95th percentile {r['p95']:.1f} +- {r['p95_se']:.1f} mm")
        if "tolerance_mm" in mc:
            line += (f", P(RMS <= {mc['tolerance_mm']:g} mm) = {mc['p_rms_within_tolerance']:.2f} "
                     f"+- {mc['p_rms_within_tolerance_se']:.2f}")
        lines.append(line)
        if not mc["sigma_source"].startswith("posterior"):
            lines.append(f"  Monte-Carlo scatter sigma: {mc['sigma_source']}")
    if doc.get("tolerance") is not None:
        from airmat.check.tolerance import summary_line

        lines.append(summary_line(doc["tolerance"]))
    from airmat.listing import listed

    lines.append(f"  wrote {listed(out, ('inflate.json', 'inflated.ply', 'inflated.3dm'))} to {out}")
    return "\n".join(lines)
