"""``design.json``: the whole design in millimetres, the source of every other workshop file.

Layout (all lengths in mm on Ω = [0, W] × [0, H], top face seen from above)::

    schema_version, airmat_version, name, seed, uncalibrated   (airmat/schemas/design.schema.json)
    mattress      {width_mm, height_mm, thickness_mm}
    calibration   {source, uncalibrated, label, L_mm, delta_mm {median, lo95, hi95}, d_mm {...}, n_samples}
    parameters    {L_mm, mu1_mm, mu2_mm, margin_mm, ...}        (what was used)
    report        {sigma {min, avg, max}, kappa1_per_m {avg, max}, kappa2_per_m {avg, max},
                   constructible, reasons}
    summary       {strings {top {k1, k2}, bottom {k1, k2}}, dashes {k1, k2}, no_string {k1, k2}, notes,
                   tie_grid {grid_mm, end_shift_mm {mean, max}, dL_mm {mean, max_abs}},
                   coverage {k1, k2: {need_points, gap_p95_mm, gap_max_mm, interior_gap_max_mm,
                   edge_band_max_mm, weak_band_max_mm, limit_mm, covered}} (airmat.design.coverage; null when not known)}
    dashes        [{id, family, side, polyline_mm, a_mm, b_mm, L_mm, chord_mm, kappa_per_m,
                    l_mm {median, lo95, hi95}, flags, a_node, b_node}]

    refine        {converged, iterations, deviation_before, deviation_after, ..., open_loop_dashes}
                  (a refined design only: airmat.check.refinement; ``open_loop_dashes`` are the strings before
                  the refinement, dashes entries without polyline_mm, which its inflations start from)

``a_node``/``b_node`` are the grid nodes the ends are tied to, ``{row, col, u_mm, v_mm}``
(node (row, col) at u = col · g, v = row · g), or null for free ends (``--tie-grid-mm 0``).

Only dashes that get a string are listed; the others are counted in ``summary.no_string``.
Numbers are rounded (0.01 mm, 1e-4 1/m) so that the same design gives the same bytes.
"""

from __future__ import annotations

import json
from pathlib import Path

from airmat.atomic import atomic_write_text
from airmat.errors import InputError
from airmat.json_doc import finish, read_object
from airmat.units import M_TO_MM

__all__ = ["design_document", "dash_entry", "write_design_json", "read_design_json", "FACES"]

FACES = ("top", "bottom")


def _mm(x) -> float:
    return round(float(x) * M_TO_MM, 2)


def _node(node, point) -> dict | None:
    if node is None:
        return None
    return {"row": int(node[0]), "col": int(node[1]), "u_mm": _mm(point[0]), "v_mm": _mm(point[1])}


def dash_entry(s, *, polyline: bool = True) -> dict:
    """One string of a pattern as a ``dashes`` entry (mm); ``polyline=False`` leaves out ``polyline_mm``."""
    d = s.dash
    entry = {"id": d.id, "family": d.family, "side": s.side,
             "polyline_mm": [[_mm(u), _mm(v)] for u, v in d.polyline] if polyline else None,
             "a_mm": [_mm(d.a[0]), _mm(d.a[1])], "b_mm": [_mm(d.b[0]), _mm(d.b[1])],
             "L_mm": _mm(d.length), "chord_mm": _mm(d.chord),
             "free_span_mm": None if s.free_span is None else _mm(s.free_span),
             "kappa_per_m": round(float(s.kappa), 4),
             "l_mm": {"median": _mm(s.l_median), "lo95": _mm(s.l_lo95), "hi95": _mm(s.l_hi95)},
             "flags": list(s.flags), "a_node": _node(d.a_node, d.a), "b_node": _node(d.b_node, d.b)}
    return entry if polyline else {k: v for k, v in entry.items() if k != "polyline_mm"}


def design_document(pattern, *, mattress, calibration, report: dict, parameters: dict, seed: int,
                    name: str) -> dict:
    """Build the ``design.json`` content.

    Parameters
    ----------
    pattern : Pattern
        Strings with lengths (m).
    mattress : object with ``width``, ``height``, ``thickness`` (m)
    calibration : CalibrationSource
    report : dict
        Table-1 figures already in file units: ``sigma {min, avg, max}``,
        ``kappa1_per_m {avg, max}``, ``kappa2_per_m {avg, max}``, ``constructible``, ``reasons``.
    parameters : dict
        Parameters used, already in file units (``*_mm``, ``*_per_m``).
    seed : int
    name : str
        Preset or target name.

    Returns
    -------
    dict
        JSON-ready; see the module docstring.
    """
    cal = calibration.summary_mm()
    strings = {face: {fam: pattern.count(face, fam) for fam in ("k1", "k2")} for face in FACES}
    return finish({
        "name": str(name),
        "seed": int(seed),
        "uncalibrated": bool(calibration.uncalibrated),
        "mattress": {"width_mm": _mm(mattress.width), "height_mm": _mm(mattress.height),
                     "thickness_mm": _mm(mattress.thickness)},
        "calibration": cal,
        "parameters": parameters,
        "report": report,
        "summary": {"strings": strings, "dashes": dict(pattern.n_dashes),
                    "no_string": dict(pattern.n_no_string), "notes": list(pattern.notes),
                    "tie_grid": pattern.tie_grid.summary_mm() if pattern.tie_grid is not None else None,
                    "coverage": pattern.coverage},
        "dashes": [dash_entry(s) for s in pattern.strings],
    })


def write_design_json(path, doc: dict) -> None:
    """Write the document atomically as UTF-8 JSON, keys in the layout order above."""
    atomic_write_text(path, json.dumps(doc, indent=1, ensure_ascii=False, allow_nan=False) + "\n")


def read_design_json(path) -> dict:
    """Read a ``design.json``; InputError (path=) when missing, unreadable or without ``dashes``/``mattress``."""
    path = Path(path)
    if not path.is_file():
        raise InputError("design.json not found", path=path)
    doc = read_object(path)
    for key in ("dashes", "mattress"):
        if key not in doc:
            raise InputError(f"missing field '{key}'", path=path, field=key)
    return doc
