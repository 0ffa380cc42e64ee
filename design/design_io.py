"""A design's folder, written and read back: the workshop files and the files the check reads.

:func:`write_design` writes every file of a :class:`~airmat.design.pipeline.DesignResult`
into a folder (``design.json``, ``approx_surface.ply`` / ``.obj``, ``target.ply``,
``calibration_samples.npz``, ``pattern.svg``, ``pattern.dxf``,
``cutting_list.csv``, ``preview.png``, ``design.3dm`` for Rhino); :func:`read_design` builds the same
``DesignResult`` from such a folder, so that the check takes a design from
memory or from files alike. Files are in millimetres (lengths rounded to
0.01 mm in ``design.json``); the library side is SI.

``target.ply`` keeps the user's target S (float32 mm, in Ŝ's frame), so that the
check of a folder measures the inflated face's distance to S too; a folder
written before it existed reads with ``approx.target`` None.

``calibration_samples.npz`` keeps the posterior samples (``delta_m``, ``d_m``,
``L_m``; ``sigma_per_m`` when the calibration measured the scatter σ) the string
lengths were computed from, bit for bit; a folder written
before it existed is read with the posterior medians of ``design.json`` as a
single sample.
"""

from __future__ import annotations

import math
import re
import zipfile
from pathlib import Path

import numpy as np

from airmat.atomic import atomic_write_bytes
from airmat.errors import InputError
from airmat.npz_bytes import npz_bytes
from airmat.units import MM, mm_to_m
from airmat.design.calibration_source import CalibrationSource
from airmat.design.constructibility import ConstructibilityReport
from airmat.design.export.design_json import dash_entry, design_document, read_design_json, write_design_json
from airmat.design.mattress import Mattress
from airmat.design.pattern import Dash, Pattern, TensionString
from airmat.design.fold_route import FoldRoute
from airmat.design.pipeline import DesignParams, DesignResult
from airmat.design.surface import ApproxSurface
from airmat.design.surface_io import (read_approx_surface, read_target_surface, write_approx_surface,
                                      write_target_surface)

__all__ = ["write_design", "read_design", "document", "report_dict", "OUTPUT_FILES", "TARGET_FILE", "LENGTH_KEYS"]

OUTPUT_FILES = ("design.json", "approx_surface.ply", "approx_surface.obj", "target.ply", "calibration_samples.npz",
                "pattern.svg", "pattern.dxf", "cutting_list.csv", "preview.png", "design.3dm")
#: the user's target S in a design folder (absent in a folder written before it, or by another tool)
TARGET_FILE = "target.ply"
#: the three string lengths of every dash in design.json ``l_mm``
LENGTH_KEYS = ("median", "lo95", "hi95")

_ID = re.compile(r"^k[12]-(\d+)-(\d+)$")


def _rounded(d: dict, digits: int) -> dict:
    return {k: round(float(v), digits) for k, v in d.items()}


def report_dict(report) -> dict:
    """The constructibility report in file units (Table 1: σ, |κ1|, |κ2| in 1/m)."""
    return {"sigma": _rounded(report.sigma, 5), "kappa1_per_m": _rounded(report.kappa1, 4),
            "kappa2_per_m": _rounded(report.kappa2, 4), "constructible": bool(report.constructible),
            "reasons": [str(r) for r in report.reasons],
            "sigma_band": [float(b) for b in report.sigma_band],
            "kappa_max_per_m": round(float(report.kappa_max), 4),
            "off_target": {"share": round(float(report.off_target["share"]), 4),
                           "max_mm": round(float(report.off_target["max"]) / MM, 2)},
            "warnings": [str(w) for w in report.warnings],
            "metric": {"face": str(report.metric["face"]), "min_ratio": round(float(report.metric["min_ratio"]), 5)},
            "folds": None if report.folds is None else {
                "vertices": int(report.folds["vertices"]), "share": round(float(report.folds["share"]), 4),
                "kappa_max_per_m": round(float(report.folds["kappa_max"]), 2)}}


def approx_to_target(approx) -> dict:
    """Ŝ's distance to the user's target S (closest points on S's mesh): RMS, max (mm) and % of Ŝ's diagonal,
    and ``over_target``: the same over the part of Ŝ that lies over S, not beyond its rim, with its share
    (:meth:`airmat.design.target_distance.TargetDistance.summary_mm`).

    Only when the design has S (``approx.target``): one designed in memory, or read from a
    folder that keeps ``target.ply``.
    """
    from airmat.design.target_distance import distance_to_target

    diag = float(np.linalg.norm(np.ptp(approx.xyz, axis=0)))
    return distance_to_target(approx.xyz, approx.target, diagonal=diag).summary_mm()


def _write_samples(path: Path, calibration: CalibrationSource) -> None:
    arrays = dict(delta_m=calibration.delta, d_m=calibration.d, L_m=np.float64(calibration.L))
    if calibration.sigma is not None:
        arrays["sigma_per_m"] = calibration.sigma
    atomic_write_bytes(path, npz_bytes(**arrays))


def document(result: DesignResult) -> dict:
    """The design document (content of design.json, mm) of a DesignResult: what every workshop file shows."""
    a = result.approx
    doc = design_document(result.pattern, mattress=a.mattress, calibration=result.calibration,
                          report=report_dict(a.report) if a.report is not None else None,
                          parameters=result.params.file_dict(result.params.L), seed=result.seed,
                          name=result.name)
    if a.target is not None and doc.get("report") is not None:
        doc["report"]["to_target"] = approx_to_target(a)
    if a.relax is not None:   # exit code 3 of 'airmat design' when False (airmat.cli._exit)
        doc["relaxation"] = {"converged": bool(a.relax.converged), "iterations": int(a.relax.n_iter),
                             "message": str(a.relax.message)}
    if result.fold_route is not None:    # Ŝ contracted below its σ band: the folded Ŝ searched (design.fold_route)
        doc["fold_route"] = result.fold_route.summary_mm()
    if result.refine is not None:   # lengths refined through the inflation (check.refine)
        doc["refine"] = dict(result.refine)
        if result.open_loop is not None:     # what its inflations start from (airmat.check.inflation_check)
            doc["refine"]["open_loop_dashes"] = [dash_entry(s, polyline=False) for s in result.open_loop]
    return doc


def write_design(result: DesignResult, folder, *, papers: tuple = (), workers: int = 1) -> dict:
    """Write every output file of ``result`` into ``folder`` (use inside ``airmat.atomic.staged_dir``).

    Parameters
    ----------
    result : DesignResult
    folder : str or Path
    papers : tuple of {"A4", "A3"}, keyword-only
        Also write ``pattern_<paper>.pdf``, the drawing tiled at 1:1 (:mod:`airmat.design.export.pdf`).
    workers : int, keyword-only
        With 2 or more, the preview (matplotlib: the slowest file of a small design) and the rest are
        written side by side on forked processes (:class:`airmat.forked.ForkedMap`, Linux); the same files.

    Returns
    -------
    dict
        The design document (content of design.json).
    """
    from airmat.forked import ForkedMap

    folder = Path(folder)
    doc = document(result)
    ForkedMap(lambda part: _write_part(part, result, doc, folder, papers), ("preview", "rest"), workers).results()
    return doc


def _write_part(part: str, result: DesignResult, doc: dict, folder: Path, papers: tuple) -> None:
    """One of :func:`write_design`'s two groups of files: ``"preview"`` (preview.png) or ``"rest"``."""
    from airmat.design.export import write_3dm, write_cutting_list, write_dxf, write_pdf, write_preview, write_svg

    a, m = result.approx, result.approx.mattress
    if part == "preview":
        write_preview(folder / "preview.png", doc, a.xyz, a.uv, a.faces)
        return
    write_design_json(folder / "design.json", doc)
    write_approx_surface(folder, a.xyz, a.uv, a.faces, width=m.width, height=m.height)
    if a.target is not None:        # a design read from a folder without target.ply has none
        write_target_surface(folder / TARGET_FILE, a.target)
    _write_samples(folder / "calibration_samples.npz", result.calibration)
    write_svg(folder / "pattern.svg", doc)
    write_dxf(folder / "pattern.dxf", doc)
    write_cutting_list(folder / "cutting_list.csv", doc)
    write_3dm(folder / "design.3dm", doc, a.xyz, a.uv, a.faces)
    for paper in papers:  # on request: tens of pages, seconds each on a large mattress
        write_pdf(folder / f"pattern_{paper}.pdf", doc, paper)


# --- reading ------------------------------------------------------------------------------------------

def _get(doc, keys: str, path: Path):
    node = doc
    for key in keys.split("."):
        if not isinstance(node, dict) or key not in node:
            raise InputError(f"no field '{keys}': is this a folder written by 'airmat design'?", path=path,
                             field=keys)
        node = node[key]
    return node


def _number(value, what: str, path: Path) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} is not a number: {value!r}", path=path) from None
    if not math.isfinite(x):
        raise InputError(f"{what} is not finite: {value!r}", path=path)
    return x


def _points(value, what: str, path: Path) -> np.ndarray:
    try:
        pts = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a list of [u, v] numbers", path=path) from None
    pts = pts.reshape(-1, 2) if pts.ndim == 1 and pts.size == 2 else pts
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) == 0:
        raise InputError(f"{what} must be a non-empty list of [u, v] points", path=path)
    if not np.all(np.isfinite(pts)):
        raise InputError(f"{what} has a non-finite coordinate", path=path)
    return pts * MM


def _grid_node(node, what: str, path: Path) -> tuple | None:
    if node is None:
        return None
    try:
        return int(node["row"]), int(node["col"])
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{what} must be null or {{row, col, u_mm, v_mm}}", path=path) from None


def _string(dash, k: int, path: Path, width: float, height: float) -> TensionString:
    """One dash entry of design.json as a TensionString (SI), checked."""
    did = str(dash.get("id", f"#{k}")) if isinstance(dash, dict) else f"#{k}"
    try:
        a = _points(dash["a_mm"], f"dash {did} a_mm", path)
        b = _points(dash["b_mm"], f"dash {did} b_mm", path)
        side, family = dash["side"], dash.get("family", "k1")
        l = [_number(dash["l_mm"][key], f"dash {did} l_mm.{key}", path) * MM for key in LENGTH_KEYS]
        kappa = _number(dash["kappa_per_m"], f"dash {did} kappa_per_m", path)
        poly = _points(dash.get("polyline_mm", [dash["a_mm"], dash["b_mm"]]), f"dash {did} polyline_mm", path)
    except (KeyError, TypeError) as err:
        raise InputError(f"dash {did} lacks field {err}", path=path) from None
    if a.shape != (1, 2) or b.shape != (1, 2) or side not in ("top", "bottom") or family not in ("k1", "k2"):
        raise InputError(f"dash {did}: a_mm/b_mm must be [u, v], side top or bottom, family k1 or k2",
                         path=path)
    ends = np.concatenate([a, b])
    if np.any(ends < -1e-9) or np.any(ends[:, 0] > width + 1e-9) or np.any(ends[:, 1] > height + 1e-9):
        raise InputError(f"string {did} has an end outside the {width / MM:.0f} x {height / MM:.0f} mm "
                         f"mattress: a = {a[0] / MM} mm, b = {b[0] / MM} mm", path=path)
    if not (0.0 <= l[1] <= l[0] <= l[2]):
        raise InputError(f"dash {did}: l_mm must satisfy 0 <= lo95 <= median <= hi95", path=path)
    # the dash's ends are the string's: the polyline runs from a to b
    poly = np.concatenate([a, poly[1:-1], b]) if len(poly) >= 2 else ends
    length = dash.get("L_mm")
    length = _number(length, f"dash {did} L_mm", path) * MM if length is not None else \
        float(np.linalg.norm(np.diff(poly, axis=0), axis=1).sum())
    free = dash.get("free_span_mm")
    free = None if free is None else _number(free, f"dash {did} free_span_mm", path) * MM
    if free is not None and not 0.0 < free <= length + 0.01 * MM:       # L_mm and it rounded to 0.01 mm
        raise InputError(f"dash {did}: free_span_mm must be in (0, L_mm], got {free / MM:g} mm", path=path)
    m = _ID.match(did)
    line, index = (int(m.group(1)), int(m.group(2))) if m else (0, k + 1)
    nodes = [_grid_node(dash.get(f"{end}_node"), f"dash {did} {end}_node", path) for end in ("a", "b")]
    return TensionString(dash=Dash(id=did, family=family, line=line, index=index, polyline=poly, length=length,
                                   a_node=nodes[0], b_node=nodes[1]),
                         kappa=kappa, side=side, l_median=l[0], l_lo95=l[1], l_hi95=l[2],
                         flags=_flags(dash.get("flags", ()), did, path), free_span=free)


def _flags(value, did: str, path: Path) -> tuple:
    if not isinstance(value, (list, tuple)):
        raise InputError(f"dash {did} flags must be a list of strings, got {value!r}", path=path)
    return tuple(str(f) for f in value)


def _calibration(folder: Path, doc: dict, path: Path, L: float, thickness: float) -> CalibrationSource:
    cal = _get(doc, "calibration", path)
    samples = folder / "calibration_samples.npz"
    if samples.is_file():
        try:
            with open(samples, "rb") as fh, np.load(fh, allow_pickle=False) as npz:  # closed on BadZipFile
                delta, d = np.asarray(npz["delta_m"], float).ravel(), np.asarray(npz["d_m"], float).ravel()
                sigma = np.asarray(npz["sigma_per_m"], float).ravel() if "sigma_per_m" in npz.files else None
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            why = "empty file" if isinstance(exc, EOFError) else (str(exc) or type(exc).__name__)
            raise InputError(f"not readable as the design's calibration samples: {why}", path=samples) from None
        if delta.size == 0 or delta.shape != d.shape or not (np.all(np.isfinite(delta)) and np.all(d > 0)):
            raise InputError("calibration samples must be finite, non-empty, of one length, with d > 0",
                             path=samples)
        if sigma is not None and (sigma.shape != delta.shape or not np.all(sigma >= 0)):
            raise InputError("calibration samples: sigma_per_m must be >= 0, one per delta_m", path=samples)
    else:   # a folder from another tool: the medians as one sample (d defaults to the thickness)
        delta = np.array([_number(_get(doc, "calibration.delta_mm.median", path), "calibration.delta_mm.median",
                                  path) * MM])
        d_mm = cal.get("d_mm", {}).get("median") if isinstance(cal.get("d_mm"), dict) else None
        d = np.array([_number(d_mm, "calibration.d_mm.median", path) * MM if d_mm is not None else thickness])
        sigma = None
    if delta.min() < 0:
        raise InputError("calibration delta must be >= 0", path=path)
    return CalibrationSource(L=L, delta=delta, d=d, source=str(cal.get("source", "")),
                             uncalibrated=bool(cal.get("uncalibrated", False)), label=str(cal.get("label", "")),
                             sigma=sigma)


def _params(doc: dict, path: Path) -> DesignParams:
    p = doc.get("parameters", {})
    if not isinstance(p, dict):
        raise InputError("field 'parameters' must be an object", path=path)
    fields = {"L": "L_mm", "mu1": "mu1_mm", "mu2": "mu2_mm", "margin": "margin_mm", "step": "step_mm",
              "spacing": "spacing_mm", "tie_grid": "tie_grid_mm"}
    kw = {k: _number(p[v], f"parameters.{v}", path) * MM for k, v in fields.items() if v in p}
    kw.setdefault("tie_grid", 0.0)      # a folder from before the tie grid: its ends were free
    kw.update({k: _number(p[k], f"parameters.{k}", path) for k in ("k_a1", "k_a2", "k_a3", "weight_min")
               if k in p})
    if "kappa_min_per_m" in p:
        kw["kappa_min"] = _number(p["kappa_min_per_m"], "parameters.kappa_min_per_m", path)
    if "n_kappa_points" in p:
        kw["n_kappa_points"] = int(_number(p["n_kappa_points"], "parameters.n_kappa_points", path))
    # a folder from before the face metric was relaxed in Ω's metric
    kw["face_metric"] = bool(p.get("face_metric", False))
    # and before Equation 3 took the free face's span
    kw["free_face_span"] = bool(p.get("free_face_span", False))
    # and before the fold route
    kw["folds"] = bool(p.get("folds", False))
    # and the shorter end dashes (absent: whole dashes only)
    kw["end_dashes"] = bool(p.get("end_dashes", False))
    if "L_end_min_mm" in p:
        kw["L_end_min"] = _number(p["L_end_min_mm"], "parameters.L_end_min_mm", path) * MM
    return DesignParams(**kw)


def _report(doc: dict, path: Path) -> ConstructibilityReport | None:
    r = doc.get("report")
    if r is None:
        return None
    try:
        return ConstructibilityReport(
            sigma=dict(r["sigma"]), kappa1=dict(r["kappa1_per_m"]), kappa2=dict(r["kappa2_per_m"]),
            constructible=bool(r["constructible"]), reasons=list(r.get("reasons", [])),
            sigma_band=tuple(r.get("sigma_band", (0.9, 1.1))),
            **({"kappa_max": float(r["kappa_max_per_m"])} if "kappa_max_per_m" in r else {}),
            **({"off_target": {"share": float(r["off_target"]["share"]), "max": r["off_target"]["max_mm"] * MM}}
               if "off_target" in r else {}),
            warnings=list(r.get("warnings", [])),
            **({"metric": {"face": str(r["metric"]["face"]), "min_ratio": float(r["metric"]["min_ratio"])}}
               if "metric" in r else {}),
            folds=None if r.get("folds") is None else {
                "vertices": int(r["folds"]["vertices"]), "share": float(r["folds"]["share"]),
                "kappa_max": float(r["folds"]["kappa_max_per_m"])})
    except (KeyError, TypeError, ValueError) as err:
        raise InputError(f"report lacks field {err}", path=path) from None


def _fold_route(doc: dict, path: Path) -> FoldRoute | None:
    r = doc.get("fold_route")
    if r is None:
        return None
    try:
        return FoldRoute.from_summary_mm(r)
    except (KeyError, TypeError, ValueError) as err:
        raise InputError(f"fold_route lacks field {err}", path=path) from None


def _refine_block(doc: dict, path: Path, width: float, height: float) -> tuple:
    """design.json's ``refine`` block (written by a refinement) without its ``open_loop_dashes``, and those
    strings (the open-loop ones a refined design's inflations start from); (None, None) when not refined."""
    block = doc.get("refine")
    if block is None:
        return None, None
    if not isinstance(block, dict):
        raise InputError(f"field 'refine' must be an object, got {block!r}", path=path)
    block = dict(block)
    dashes = block.pop("open_loop_dashes", None)
    if dashes is None:
        return block, None
    if not isinstance(dashes, list):
        raise InputError("field 'refine.open_loop_dashes' must be a list", path=path)
    try:
        return block, tuple(_string(dash, k, path, width, height) for k, dash in enumerate(dashes))
    except InputError as err:        # say which list: these dashes are not the pattern's
        raise InputError(f"refine.open_loop_dashes: {err.message}", path=path) from None


def read_design(folder) -> DesignResult:
    """Read a folder written by :func:`write_design` (``airmat design``) into a DesignResult.

    Ŝ comes from ``approx_surface.ply`` (float32 mm in the file), the target S
    from ``target.ply`` (float32 mm; ``approx.target`` is None without it, in a
    folder written before it), the strings from ``design.json`` (0.01 mm), the
    calibration samples from ``calibration_samples.npz`` (exact). ``mfield``,
    ``stripes`` and Ŝ's ``relax`` and ``curvature`` are None: the files do not keep them.
    A folder written by another tool needs only ``mattress``, ``calibration.delta_mm``,
    ``dashes`` and ``approx_surface.ply``: Ŝ's ``report`` is then None and the
    parameters are the defaults.

    Raises
    ------
    airmat.errors.InputError
        A missing folder or file, a missing or non-numeric field (named), a
        string outside the mattress (its id named), or inconsistent lengths.
    """
    folder = Path(folder)
    path = folder / "design.json"
    if folder.is_file():
        hint = f" ({folder.parent})" if folder.name == "design.json" else ""
        raise InputError(f"is a file: give the folder that holds design.json{hint}, the --out folder of "
                         "'airmat design'", path=folder)
    if not folder.is_dir():
        raise InputError("design folder not found (give the --out folder of 'airmat design')", path=folder)
    if not path.is_file():
        raise InputError("no design.json here: give the --out folder of 'airmat design'", path=folder)
    doc = read_design_json(path)
    size = {k: mm_to_m(_number(_get(doc, f"mattress.{k}_mm", path), f"mattress.{k}_mm", path))
            for k in ("width", "height", "thickness")}
    if min(size.values()) <= 0:
        raise InputError("mattress sizes must be > 0", path=path)
    mattress = Mattress(size["width"], size["height"], size["thickness"])
    dashes = _get(doc, "dashes", path)
    if not isinstance(dashes, list):
        raise InputError("field 'dashes' must be a list", path=path)
    strings = tuple(_string(dash, k, path, mattress.width, mattress.height) for k, dash in enumerate(dashes))
    params = _params(doc, path)
    L = params.L
    if isinstance(doc.get("calibration"), dict) and "L_mm" in doc["calibration"]:
        L = _number(doc["calibration"]["L_mm"], "calibration.L_mm", path) * MM
    if L is None:           # a folder from another tool: the dashes' own spacing
        L = float(np.median([s.dash.length for s in strings])) if strings else math.nan
    calibration = _calibration(folder, doc, path, L, mattress.thickness)
    params = params if params.L is not None else DesignParams(**{**params.__dict__, "L": L})
    summary = doc.get("summary", {})
    if not isinstance(summary, dict) or not all(isinstance(summary.get(k, {}), dict)
                                                for k in ("dashes", "no_string")):
        raise InputError("field 'summary' must be an object with objects 'dashes' and 'no_string'", path=path)
    pattern = Pattern(strings=strings, L=params.L,
                      n_dashes=dict(summary.get("dashes", {})), n_no_string=dict(summary.get("no_string", {})),
                      notes=tuple(summary.get("notes", ())), coverage=summary.get("coverage"))
    refine, open_loop = _refine_block(doc, path, mattress.width, mattress.height)
    xyz, uv, faces = read_approx_surface(folder / "approx_surface.ply")
    name = str(doc.get("name", folder.name))
    target = read_target_surface(folder / TARGET_FILE, name=name) if (folder / TARGET_FILE).is_file() else None
    approx = ApproxSurface(target=target, mattress=mattress, xyz=xyz, uv=uv, faces=faces, relax=None, curvature=None,
                           report=_report(doc, path))
    return DesignResult(name=name, approx=approx, pattern=pattern,
                        calibration=calibration, params=params, seed=int(_number(doc.get("seed", 0), "seed", path)),
                        source=str(folder), refine=refine, open_loop=open_loop,
                        fold_route=_fold_route(doc, path))
