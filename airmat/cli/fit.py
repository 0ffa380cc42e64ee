"""`airmat fit SCAN`: curvature of one scanned cylindrical specimen, as JSON on stdout."""

from __future__ import annotations

import json
import math
import sys

from airmat.units import M_TO_MM, SCAN_UNITS


def add_parser(sub, parents):
    p = sub.add_parser(
        "fit", parents=parents,
        help="fit a cylinder to a specimen scan; print kappa and its error as JSON",
        description="Robust cylinder fit of a scanned specimen (floor, clutter, holes and "
                    "string-end grooves allowed). Prints one JSON object: radius_mm, "
                    "kappa_per_m, kappa_se_per_m, axis, inlier_fraction, rms_mm, arc_deg, ...")
    p.add_argument("scan", metavar="SCAN",
                   help="scan file: E57, LAS/LAZ, PCD, PLY (points or mesh), OBJ, STL, OFF, GLB/glTF, "
                        "PTS/XYZ/TXT columns")
    add_scan_options(p)
    p.add_argument("--noise-mm", type=float, default=None,
                   help="scanner noise (standard deviation, mm); estimated from the scan when omitted")
    p.set_defaults(func=run)


def add_scan_options(p, *, index=True):
    """--scan-units (shared with ``calibrate``) and --scan-index."""
    p.add_argument("--scan-units", choices=sorted(SCAN_UNITS), default=None,
                   help="unit of the scan's coordinates (default: metres for E57 and LAS/LAZ, "
                        "whose formats fix it; millimetres otherwise)")
    if index:
        p.add_argument("--scan-index", type=int, default=None, metavar="N",
                       help="multi-scan E57: fit scan N only (from 0); default: all scans merged with their poses")


def run(args) -> int:
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import check
    from airmat.errors import InputError
    from calib.cylinder_stability import fit_cylinder_stable
    from calib.scan_io import read_scan

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
    json.dump(fit_to_json(fit, scan), sys.stdout, indent=2)
    sys.stdout.write("\n")
    sys.stdout.flush()
    return not_converged("fit", [] if fit.converged else [f"{scan.path}: cylinder fit: {fit.message}"])


def fit_to_json(fit, scan) -> dict:
    """The JSON record of a fit: millimetres and 1/m, unit-suffixed names."""
    def mm(x):
        return None if not math.isfinite(x) else round(float(x) * M_TO_MM, 6)

    return {
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
    }
