"""`airmat info DIR`: what an output folder holds, its key numbers and its verdict (from its JSON files only).

Recognized by the files in ``DIR``: a synthetic or scanned specimen set
(``manifest.csv``), a calibration (``calibration.json``), a design or a refined
design (``design.json``, with a ``refine`` block), a check (``inflate.json``), a
validation, a gallery or a re-tie list; a folder of such folders (``airmat demo``'s)
is described one sub-folder at a time. Nothing is recomputed: it reads JSON.
"""

from __future__ import annotations

from pathlib import Path

from airmat.errors import InputError

#: file -> what a folder holding it is (the first match names the folder)
KINDS = (("inflate.json", "check"), ("design.json", "design"), ("calibration.json", "calibration"),
         ("validate.json", "validation"), ("gallery.json", "gallery"), ("retie.json", "re-tie list"),
         ("manifest.csv", "specimen set"))


def add_parser(sub, parents):
    p = sub.add_parser("info", parents=parents,
                       help="say what an output folder holds: calibration, design, refined design, check; its "
                            "key numbers (mm, %% of the diagonal) and verdict",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("folder", metavar="DIR", help="an output folder of an airmat command")
    p.set_defaults(func=run)


def _load(path: Path) -> dict:
    from airmat.json_doc import read_object

    return read_object(path)


def _iv(p: dict | None, unit: str, digits: int = 1) -> str:
    """``median unit [lo95, hi95]`` of a posterior summary."""
    if not isinstance(p, dict) or p.get("median") is None:
        return "n/a"
    return f"{p['median']:.{digits}f} {unit} [{p.get('lo95', float('nan')):.{digits}f}, " \
           f"{p.get('hi95', float('nan')):.{digits}f}]"


def _yes(flag) -> str:
    return "yes" if flag else "NO"


def _dev(d: dict | None) -> str:
    if not isinstance(d, dict) or d.get("rms_pct_diag") is None:
        return "n/a"
    return f"{d['rms_pct_diag']:.2f} % of the diagonal (RMS {d.get('rms_mm', float('nan')):.1f} mm" + \
        (f", max {d['max_mm']:.1f} mm)" if d.get("max_mm") is not None else ")")


def describe_calibration(doc: dict) -> list[str]:
    p, diag = doc.get("parameters", {}), doc.get("diagnostics", {})
    specimens = doc.get("specimens", [])
    refused = sum(1 for s in specimens if s.get("fit_converged") is False)
    return [f"  Δ = {_iv(p.get('delta_mm'), 'mm')}, d = {_iv(p.get('d_mm'), 'mm')}, "
            f"σ = {_iv(p.get('sigma_per_m'), '1/m', 2)} (median [95 %])",
            f"  {len(specimens)} specimens" + (f" ({refused} fits not converged)" if refused else "")
            + (f" from {doc['manifest']}" if doc.get("manifest") else ""),
            f"  verdict: MCMC converged: {_yes(diag.get('converged'))}"
            + (f" ({diag['n_steps']} steps)" if diag.get("n_steps") is not None else "")]


def describe_design(doc: dict) -> list[str]:
    m, rep, s = doc.get("mattress", {}), doc.get("report", {}), doc.get("summary", {})
    strings = s.get("strings", {})
    count = {face: sum((strings.get(face) or {}).values()) for face in ("top", "bottom")}
    cal = doc.get("calibration") or {}
    lines = [f"  {doc.get('name', '?')} on a {m.get('width_mm', 0):.0f} x {m.get('height_mm', 0):.0f} x "
             f"{m.get('thickness_mm', 0):.0f} mm mattress; "
             + ("UNCALIBRATED (the paper's values)" if doc.get("uncalibrated") else
                f"calibrated: {cal.get('source') or cal.get('label') or 'yes'}"),
             f"  {count['top'] + count['bottom']} strings (top {count['top']}, bottom {count['bottom']})"]
    converged = [] if doc.get("relaxation") is None else [doc["relaxation"].get("converged", True)]
    r = doc.get("refine")
    deviation = ""
    if r:
        converged.append(r.get("converged", True))
        lines.append(f"  refined: {_dev(r.get('deviation_before'))} -> {_dev(r.get('deviation_after'))}, "
                     f"{r.get('iterations', '?')} iterations at {r.get('resolution_mm', '?')} mm")
        after = r.get("deviation_after") or {}
        if after.get("rms_pct_diag") is not None:
            deviation = f"; deviation {after['rms_pct_diag']:.2f} % of the diagonal (simulated)"
    if doc.get("fold_route"):
        lines.append(f"  fold route: {doc['fold_route'].get('message', '?')}")
    verdict = "yes" if rep.get("constructible") else "NO: " + "; ".join(rep.get("reasons", []))
    lines.append(f"  verdict: constructible: {verdict}{deviation}; converged: {_yes(all(converged))}")
    return lines


def describe_check(doc: dict) -> list[str]:
    dev = doc.get("deviation", {})
    env = doc.get("envelope") or {}
    lines = [f"  {len(doc.get('dashes', []))} strings of {doc.get('design', '?')} inflated at "
             f"{doc.get('resolution_mm', '?')} mm ({doc.get('mesh_vertices', '?')} vertices)",
             f"  {dev.get('surface', 'named')} face from Ŝ: {_dev(dev)}"]
    if env:
        lines.append("  envelope: " + ", ".join(f"{k} {_dev(v)}" for k, v in env.items()))
    pct = dev.get("rms_pct_diag")
    lines.append(f"  verdict: deviation {'n/a' if pct is None else f'{pct:.2f}'} % of the diagonal; "
                 f"converged: {_yes(doc.get('converged'))}")
    return lines


def describe_validation(doc: dict) -> list[str]:
    points = doc.get("points", [])
    return [f"  {len(points)} string length ratios at {doc.get('resolution_mm', '?')} mm, "
            f"L = {doc.get('L_mm', '?')} mm, thickness {doc.get('thickness_mm', '?')} mm",
            f"  verdict: converged: {_yes(doc.get('converged', all(p.get('converged', True) for p in points)))}"]


def describe_gallery(doc: dict) -> list[str]:
    names = [k for k, v in doc.items() if isinstance(v, dict) and "deviation" in v]
    return [f"  {name}: constructible {_yes((doc[name].get('report') or {}).get('constructible'))}, "
            f"deviation {_dev(doc[name].get('deviation'))}, converged {_yes(doc[name].get('converged'))}"
            for name in names]


def describe_retie(doc: dict) -> list[str]:
    counts = doc.get("counts", {})
    return [f"  {doc.get('design_a', '?')} -> {doc.get('design_b', '?')}: "
            + ", ".join(f"{k} {v}" for k, v in counts.items())]


def describe_set(folder: Path) -> list[str]:
    import csv

    try:
        with open(folder / "manifest.csv", newline="", encoding="utf-8") as fh:
            n = sum(1 for _ in csv.DictReader(fh))
    except (OSError, csv.Error, UnicodeDecodeError) as err:
        raise InputError(f"cannot read: {err}", path=folder / "manifest.csv") from None
    lines = [f"  {n} specimen scans listed in manifest.csv"]
    if (folder / "truth.json").is_file():
        t = _load(folder / "truth.json")
        lines.append(f"  synthetic: true Δ = {t.get('delta_mm', float('nan')):g} mm, "
                     f"d = {t.get('d_mm', float('nan')):g} mm")
    return lines


_DESCRIBE = {"check": describe_check, "design": describe_design, "calibration": describe_calibration,
             "validation": describe_validation, "gallery": describe_gallery, "re-tie list": describe_retie}


def describe(folder: Path) -> list[str] | None:
    """The lines on one folder, or None when it holds no file an airmat command writes."""
    for name, kind in KINDS:
        path = folder / name
        if path.is_file():
            if kind == "specimen set":
                return [f"{folder}: {kind}", *describe_set(folder)]
            doc = _load(path)
            if kind == "design" and doc.get("refine"):
                kind = "refined design"
            return [f"{folder}: {kind} ({name})", *_DESCRIBE[kind if kind != "refined design" else "design"](doc)]
    return None


def run(args) -> int:
    folder = Path(args.folder)
    if not folder.exists():
        raise InputError("no such folder", path=folder)
    if not folder.is_dir():
        raise InputError(f"a file: give the folder that holds it ('airmat info {folder.parent}')", path=folder)
    lines = describe(folder)
    if lines is None:
        subs = [d for d in sorted(folder.iterdir()) if d.is_dir() and not d.name.startswith(".")]
        parts = [d for d in (describe(s) for s in subs) if d]
        if not parts:
            raise InputError("holds no output of an airmat command (calibration.json, design.json, "
                             "inflate.json, manifest.csv, ...)", path=folder)
        lines = [f"{folder}: {len(parts)} output folder{'' if len(parts) == 1 else 's'}"
                 + (" and report.html" if (folder / "report.html").is_file() else "")]
        for part in parts:
            lines += ["", *part]
    print("\n".join(lines))
    return 0
