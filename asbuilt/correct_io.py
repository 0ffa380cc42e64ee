"""The folder of ``airmat correct`` (mm, 1/m): a corrected design folder with what the scan said.

- the corrected design: every file of ``airmat design`` (:func:`airmat.design.design_io.write_design`;
  Ŝ unchanged, new lengths and their tolerances), so ``airmat check``, ``airmat synth-built`` and
  ``airmat export`` take the folder as it is;
- ``calibration/``: the updated calibration (``calibration.json``, ``posterior.npz``,
  ``specimens.csv``: :func:`airmat.calib.calibration_io.write_calibration`), which
  ``airmat design --calibration`` reads, when the design had a calibration folder to extend;
- ``correct.json``: the registration, both deviations, the updated (Δ, d) beside the prior, each
  string's error, the correction and the notes;
- ``retie.json``, ``retie.csv``, ``retie.png``: the workshop's list from the built strings to the
  corrected ones (:mod:`airmat.design.export.retie_files`);
- ``deviation_target.png`` and ``deviation_prediction.png``: the scan against Ŝ and against the
  prediction, on Ω; ``deviation.ply``: Ŝ with each vertex's deviation from the scan (mm) and a colour;
- ``report.html`` (written by the command, :func:`airmat.report.page.write_report` with ``asbuilt=``):
  the as-built part and the corrected design.

Write inside ``airmat.atomic.staged_dir``: the folder appears whole or not at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.atomic import atomic_write_text
from airmat.json_doc import dumps, finish
from airmat.units import M_TO_MM

__all__ = ["correct_document", "write_correct", "summary_lines", "CORRECT_FILES"]

#: the files of the folder besides the design's
CORRECT_FILES = ("correct.json", "retie.json", "retie.csv", "retie.png", "deviation_target.png",
                 "deviation_prediction.png", "deviation.ply")


def _mm(x, digits: int = 3):
    return None if x is None or not np.isfinite(x) else round(float(x) * M_TO_MM, digits)


def _deviation(dev) -> dict:
    return {"rms_mm": _mm(dev.rms), "max_mm": _mm(dev.max), "p95_mm": _mm(dev.p95),
            "coverage": round(float(dev.coverage), 4), "rms_pct_diag": round(float(dev.rms_pct_diag), 3)}


def correct_document(res) -> dict:
    """correct.json's content (mm) of an :class:`airmat.asbuilt.pipeline.AsBuilt`."""
    reg, upd, corr = res.registration, res.update, res.correction
    now, before = upd.interval95, upd.prior_interval95
    strings = [{"id": i, "error_mm": _mm(e), "error_se_mm": _mm(se), "flagged": i in upd.flagged,
                "kept": bool(k), "length_mm": _mm(l), "change_mm": _mm(c)}
               for i, e, se, k, l, c in zip(upd.ids, upd.error, upd.error_se, corr.kept, corr.l_real, corr.change)]
    doc = {
        "scan": res.scan, "surface": res.surface,
        "registration": {"rms_mm": _mm(reg.rms), "inlier_share": round(float(reg.inlier_share), 4),
                         "coverage": round(float(reg.coverage), 4), "scale": float(reg.scale),
                         "rotation": np.round(reg.rotation, 9).tolist(),
                         "translation_mm": [_mm(t) for t in reg.translation],
                         "converged": bool(reg.converged), "iterations": int(reg.iterations),
                         "equivalent_poses": int(reg.n_equivalent), "message": reg.message,
                         "points_on_face": int(len(res.points))},
        "deviation": {"to_target": _deviation(res.to_target), "to_prediction": _deviation(res.to_prediction)},
        "update": {"method": "Laplace (Gaussian) update through the face Jacobian (airmat.asbuilt.update)",
                   "delta_mm": _mm(upd.mean[0]), "d_mm": _mm(upd.mean[1]),
                   "delta_95_mm": [_mm(x) for x in now[:, 0]], "d_95_mm": [_mm(x) for x in now[:, 1]],
                   "prior_delta_95_mm": [_mm(x) for x in before[:, 0]],
                   "prior_d_95_mm": [_mm(x) for x in before[:, 1]],
                   "residual_mm": _mm(upd.residual), "noise_sd_mm": _mm(upd.noise_sd),
                   "linearisations": int(upd.iterations), "inflations": int(upd.inflations),
                   "converged": bool(upd.converged), "message": upd.message,
                   "cut_tolerance_mm": _mm(upd.cut_tolerance), "flagged": list(upd.flagged)},
        "correction": {**corr.block(), "counts": dict(corr.plan.counts) if hasattr(corr.plan, "counts") else None},
        "strings": strings,
        "calibration": "calibration/" if res.calibration is not None else None,
        "notes": list(res.notes),
        "seconds": round(float(res.seconds), 1),
    }
    return finish(doc)


def summary_lines(doc: dict) -> list:
    """A few lines for the terminal."""
    r, dv, u, c = doc["registration"], doc["deviation"], doc["update"], doc["correction"]
    after = c["rms_verified_mm"] if c.get("rms_verified_mm") is not None else c["rms_linear_mm"]
    lines = [f"  registration  {r['rms_mm']:.2f} mm RMS, {100 * r['inlier_share']:.0f} % of the points on the "
             f"predicted face, {r['points_on_face']} points, scale {r['scale']:g}",
             f"  as built      {dv['to_target']['rms_mm']:.1f} mm RMS from Ŝ "
             f"({dv['to_target']['rms_pct_diag']:.2f} % of the diagonal), {dv['to_prediction']['rms_mm']:.1f} mm "
             f"from the prediction",
             f"  learned       Δ {u['delta_mm']:.2f} mm [{u['delta_95_mm'][0]:.2f}, {u['delta_95_mm'][1]:.2f}] "
             f"(was [{u['prior_delta_95_mm'][0]:.2f}, {u['prior_delta_95_mm'][1]:.2f}]), d {u['d_mm']:.2f} mm "
             f"[{u['d_95_mm'][0]:.2f}, {u['d_95_mm'][1]:.2f}] (was [{u['prior_d_95_mm'][0]:.2f}, "
             f"{u['prior_d_95_mm'][1]:.2f}]); {len(u['flagged'])} ties flagged"
             + ("" if u["converged"] else f"; {u['message']}"),
             f"  corrected     keep {c['kept']}, re-cut {c['recut']}; predicted {after:.1f} mm RMS from Ŝ after "
             f"the re-cut"]
    return lines + [f"  note: {n}" for n in doc["notes"]]


def write_correct(folder, res) -> dict:
    """Write the whole folder (see the module docstring) into ``folder``; return correct.json's content."""
    from airmat.asbuilt.deviation_map import deviation_figure, write_deviation_ply
    from airmat.design.design_io import write_design
    from airmat.design.export.retie_files import write_retie
    from airmat.figures import save_png

    folder = Path(folder)
    corr, a = res.correction, res.design.approx
    write_design(corr.design, folder)
    if res.calibration is not None:
        from airmat.calib.calibration_io import write_calibration

        (folder / "calibration").mkdir(exist_ok=True)
        write_calibration(res.calibration, folder / "calibration")
    doc = correct_document(res)
    atomic_write_text(folder / "correct.json", dumps(doc, indent=2) + "\n")
    m = res.design.mattress
    write_retie(folder, corr.plan, design_a=f"{res.design.name} as built", design_b=f"{res.design.name} corrected",
                width=m.width, height=m.height)
    save_png(deviation_figure(res.to_target, a.xyz, a.faces, uv=a.uv, title="the scan against Ŝ"),
             folder / "deviation_target.png", dpi=110)
    xyz, tri = res.reference_xyz, res.reference_faces
    save_png(deviation_figure(res.to_prediction, xyz, tri, title="the scan against the prediction"),
             folder / "deviation_prediction.png", dpi=110)
    write_deviation_ply(folder / "deviation.ply", res.to_target, a.xyz, a.faces)
    return doc
