"""`airmat fit SCAN [--json]`: curvature of one scanned cylindrical specimen: a few lines on stdout, or JSON."""

from __future__ import annotations

import math
import sys

from airmat.units import M_TO_MM, SCAN_UNITS


def add_parser(sub, parents):
    p = sub.add_parser(
        "fit", parents=parents,
        help="fit a cylinder to a specimen scan; print its radius and κ with its error",
        description="Robust cylinder fit of a scanned specimen (floor, clutter, holes and "
                    "string-end grooves allowed). Prints a short summary: radius (mm), κ ± its "
                    "standard error (1/m), inliers, arc, converged; with --json one JSON object "
                    "instead: radius_mm, kappa_per_m, kappa_se_per_m, axis, inlier_fraction, rms_mm, "
                    "arc_deg, ...")
    p.add_argument("scan", metavar="SCAN",
                   help="scan file: E57, LAS/LAZ, PCD, PLY (points or mesh), OBJ, STL, OFF, GLB/glTF, "
                        "PTS/XYZ/TXT columns")
    add_scan_options(p)
    p.add_argument("--noise-mm", type=float, default=None,
                   help="scanner noise (standard deviation, mm); estimated from the scan when omitted")
    p.add_argument("--json", action="store_true",
                   help="for scripts: print the fit as one JSON object (airmat/schemas/fit.schema.json; mm and "
                        "1/m) instead of the summary; a refused fit prints its error as one JSON object too "
                        "({error: {type, message, path, exit_code}}; exit code and stderr line unchanged)")
    p.set_defaults(func=run)


def add_scan_options(p, *, index=True):
    """--scan-units (shared with ``calibrate``) and --scan-index."""
    p.add_argument("--scan-units", choices=sorted(SCAN_UNITS), default=None,
                   help="unit of the scan's coordinates (default: the unit the file states: E57 in metres, "
                        "LAS/LAZ in its CRS's unit (metres without one), an exporter's units comment in OBJ "
                        "or PLY; millimetres otherwise)")
    if index:
        p.add_argument("--scan-index", type=int, default=None, metavar="N",
                       help="multi-scan E57: fit scan N only (an index from 0); default: all scans merged with "
                        "their poses")


def run(args) -> int:
    from airmat.errors import AirmatError

    try:
        return _fit(args)
    except AirmatError as err:
        if args.json:
            _print_json(error_to_json(err, args.scan))
        raise


def error_to_json(err, scan: str) -> dict:
    """The JSON record of a refused fit (airmat/schemas/fit.schema.json): the error and the exit code it gives."""
    from airmat.cli._exit import BAD_INPUT, FAILED
    from airmat.errors import InputError
    from airmat.json_doc import finish

    return finish({"scan": str(scan), "converged": False,
                   "error": {"type": type(err).__name__, "message": " ".join(str(err.message).split()),
                             "path": err.path,
                             "exit_code": BAD_INPUT if isinstance(err, InputError) else FAILED}})


def _print_json(doc: dict) -> None:
    from airmat.json_doc import dumps

    sys.stdout.write(dumps(doc, indent=2) + "\n")
    sys.stdout.flush()


def _fit(args) -> int:
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import check
    from airmat.errors import InputError
    from airmat.calib.cylinder_stability import fit_cylinder_stable
    from airmat.calib.scan_io import read_scan

    if args.noise_mm is not None and not args.noise_mm > 0:
        raise InputError(f"--noise-mm must be > 0, got {args.noise_mm}")
    scan = read_scan(args.scan, units=args.scan_units, seed=args.seed, scan_index=args.scan_index)
    noise = None if args.noise_mm is None else args.noise_mm / M_TO_MM
    try:
        fit = fit_cylinder_stable(scan.points, seed=args.seed, noise=noise, quantization=scan.quantization,
                                  strict=True)
    except InputError as err:
        raise err.with_path(scan.path)
    check()
    doc = fit_to_json(fit, scan)
    if args.json:
        _print_json(doc)
    else:
        sys.stdout.write(summary_text(doc) + "\n")
        sys.stdout.flush()
    return not_converged("fit", [] if fit.converged else [f"{scan.path}: cylinder fit: {fit.message}"])


def summary_text(doc: dict) -> str:
    """The few lines ``airmat fit`` prints without ``--json``, from its JSON record (mm, 1/m).

    Examples
    --------
    >>> print(summary_text({"scan": "s.ply", "kind": "points", "scan_units": "mm", "n_scans": 1,
    ...     "radius_mm": 250.04, "kappa_per_m": 3.9994, "kappa_se_per_m": 0.0123, "n_inliers": 23600,
    ...     "n_points": 30000, "n_support": 6000, "inlier_fraction": 0.9833, "rms_mm": 0.21, "arc_deg": 60.2,
    ...     "converged": True, "n_iter": 7, "message": "ok"}))
    airmat fit: s.ply (points in mm)
      radius     250.0 mm
      κ          3.999 ± 0.012 1/m (standard error)
      inliers    23600 of the 24000 points off the floor (98.3 %), RMS 0.21 mm
      arc        60.2°
      converged  yes (7 iterations)
    """
    def num(x, fmt):
        return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)

    radius = "infinite (flat: no curvature measured)" if doc["radius_mm"] is None \
        else f"{num(doc['radius_mm'], '.1f')} mm"
    scans = f", {doc['n_scans']} scans" if doc.get("n_scans", 1) > 1 else ""
    return "\n".join([
        f"airmat fit: {doc['scan']} ({doc['kind']} in {doc['scan_units']}{scans})",
        f"  radius     {radius}",
        f"  κ          {num(doc['kappa_per_m'], '.3f')} ± {num(doc['kappa_se_per_m'], '.3f')} 1/m (standard error)",
        f"  inliers    {doc['n_inliers']} of the {doc['n_points'] - doc.get('n_support', 0)} points off the floor "
        f"({100 * doc['inlier_fraction']:.1f} %), RMS {num(doc['rms_mm'], '.2f')} mm",
        f"  arc        {num(doc['arc_deg'], '.1f')}°",
        f"  converged  " + (f"yes ({doc['n_iter']} iterations)" if doc["converged"] else f"NO: {doc['message']}"),
    ])


def fit_to_json(fit, scan) -> dict:
    """The JSON record of a fit (airmat/schemas/fit.schema.json): millimetres and 1/m, unit-suffixed names."""
    from airmat.json_doc import finish

    def mm(x):
        return x if not math.isfinite(x) else round(float(x) * M_TO_MM, 6)

    return finish({
        "scan": scan.path,
        "kind": scan.kind,
        "radius_mm": mm(fit.radius),
        "kappa_per_m": float(fit.kappa),
        "kappa_se_per_m": float(fit.kappa_se),
        "kappa_se_iid_per_m": float(fit.kappa_se_iid),
        "axis": [round(float(a), 9) for a in fit.axis],
        "center_mm": [mm(c) for c in fit.center + scan.offset],
        "offset_mm": [mm(c) for c in scan.offset],
        "scan_units": scan.units,
        "n_scans": int(scan.n_scans),
        "inlier_fraction": round(float(fit.inlier_fraction), 6),
        "rms_mm": mm(fit.rms),
        "noise_mm": mm(fit.noise),
        "arc_deg": round(float(fit.arc_deg), 4),
        "n_points": int(fit.n_points),
        "n_inliers": int(fit.n_inliers),
        "n_support": int(fit.n_support),
        "n_nonfinite_dropped": int(scan.n_nonfinite_dropped),
        "converged": bool(fit.converged),
        "n_iter": int(fit.n_iter),
        "message": fit.message,
        "n_seeds": int(fit.n_seeds),
        "kappa_spread_per_m": float(fit.kappa_spread),
    }, reasons=_REASONS)


_REASONS = {"radius_mm": "no curvature measured (a flat specimen): the radius is infinite",
            "center_mm": "no curvature measured (a flat specimen): the axis is at infinity",
            "kappa_se_per_m": "the standard error could not be estimated",
            "kappa_se_iid_per_m": "the standard error could not be estimated"}
