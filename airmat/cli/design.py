"""`airmat design TARGET|--preset NAME [--out DIR]`: the string pattern that bends the mattress into a target."""

from __future__ import annotations

import logging
import re

from airmat.cli._jobs import jobs
from airmat.cli._ranges import RANGES, check_range
from airmat.cli._vocabulary import add_out_argument, deprecated_alias
from airmat.cli._refining import (check_corrections, check_regularization, check_rounds, refine_lines,
                                  refine_not_converged, refine_options, wrote_line)
from airmat.constants import PAPER_D
from airmat.errors import InputError
from airmat.units import mm_to_m

_SIZE = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*[xX×*]\s*(\d+(?:\.\d*)?)\s*$")


def add_parser(sub, parents):
    p = sub.add_parser("design", parents=parents,
                       help="design the tension-string pattern for a target surface (paper §3)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("target", nargs="?", metavar="TARGET",
                   help="target surface mesh (OBJ, PLY, STL, OFF) or Rhino file (3DM: its meshes and surfaces); or use --preset")
    p.add_argument("--preset", metavar="NAME", help="a built-in target: vault1, saddle, dome (830x740 mm), "
                                                    "vault2, roof (2600x1600 mm)")
    p.add_argument("--mattress", metavar="WxH", help="mattress size in mm, e.g. 830x740 "
                                                     "(required with TARGET; a preset brings its own)")
    p.add_argument("--thickness-mm", type=float, default=None,
                   help="inflated thickness d (mm, default: the preset's, else 70)")
    p.add_argument("--target-units", choices=("mm", "cm", "m", "in"), default="mm",
                   help="unit of the TARGET file's coordinates (default mm; a 3DM file's own model units take precedence)")
    deprecated_alias(p, "--units", "--target-units")
    p.add_argument("--calibration", metavar="DIR", help="output folder of 'airmat calibrate'; without it the "
                                                         "paper's values are used and outputs say UNCALIBRATED")
    p.add_argument("--L-mm", dest="L_mm", type=float, default=None,
                   help="geodesic spacing L of string ends (mm; default: the calibration's, paper 300)")
    p.add_argument("--mu1-mm", type=float, default=None,
                   help="period of the dashes along a line (mm; default: L, dashes end to end; paper 400)")
    p.add_argument("--mu2-mm", type=float, default=50.0,
                   help="spacing of neighbouring lines (mm, default 50; paper 100)")
    p.add_argument("--margin-mm", type=float, default=30.0,
                   help="dashes stay this far from the edge (mm, default 30)")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the mattress for the design (mm, default 20)")
    deprecated_alias(p, "--spacing-mm", "--resolution-mm")
    p.add_argument("--step-mm", type=float, default=None,
                   help="line integration step (mm, default min(mu2/10, 10))")
    p.add_argument("--kappa-min-per-m", type=float, default=0.25,
                   help="|curvature| below which no string is needed (default 0.25 1/m)")
    p.add_argument("--weight-min", type=float, default=0.0,
                   help="lines stop where the principal-direction weight (dimensionless, 0 to 1) is below this "
                        "(umbilics, where any direction bends alike; default 0: trace through the smoothed line "
                        "field)")
    p.add_argument("--tie-grid-mm", type=float, default=20.0,
                   help="pitch of the grid mesh on the mattress's faces: string ends are tied to its nodes "
                        "(mm, default 20, paper §2.1; 0: free positions)")
    p.add_argument("--k-a1", type=float, default=None, help="U_A edge-length weight (dimensionless; default: the relaxation's)")
    p.add_argument("--k-a2", type=float, default=None, help="U_A closest-point weight (dimensionless; default: the relaxation's)")
    p.add_argument("--k-a3", type=float, default=None, help="U_A smoothing weight (dimensionless; default: the relaxation's)")
    p.add_argument("--flat-metric", action="store_true",
                   help="relax Ŝ in the flat mattress's metric everywhere (the paper's A1), not in the metric of "
                        "the face Ŝ stands for (which its own strings shorten on a saddle)")
    p.add_argument("--dash-span", action="store_true",
                   help="string lengths from Equation 3 at each dash's span on the flat mattress (the paper), "
                        "not at the span its free face has on the approximated surface")
    p.add_argument("--no-folds", action="store_true",
                   help="keep the plain approximated surface when it strains the mattress beyond its sigma band, "
                        "instead of searching stiffer edge weights for one that gathers into drape-like folds "
                        "(the paper's dome)")
    p.add_argument("--end-dashes", action="store_true",
                   help="cut a shorter dash from each line end's leftover inside the margin (too short for a whole "
                        "dash of L), its string's length from Equation 3 at that dash's own length")
    p.add_argument("--L-end-min-mm", type=float, default=None,
                   help="with --end-dashes: the shortest end dash (mm, default L/2)")
    p.add_argument("--refine", action="store_true",
                   help="refine the string lengths through the simulated inflation (adjoint Gauss-Newton), "
                        "so that the inflated named face lands on the approximated surface")
    p.add_argument("--refine-resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the refinement's inflations (mm, default 20; 'airmat refine "
                        "--resolution-mm')")
    p.add_argument("--refine-single-level", action="store_true",
                   help="with --refine: every Gauss-Newton iteration at --refine-resolution-mm (slower, closer)")
    p.add_argument("--refine-defect-corrections", type=int, default=0, metavar="N",
                   help="with --refine: re-correct the coarse mesh by the fine one up to N times where its "
                        "iterations stop early (see 'airmat refine --defect-corrections'; default 0)")
    p.add_argument("--refine-regularization", type=float, default=None, metavar="ALPHA",
                   help="with --refine: weight of the pull toward the open-loop lengths (dimensionless, see 'airmat "
                        "refine --regularization'; default 1e-3)")
    p.add_argument("--refine-reparametrize", type=int, default=None, metavar="N",
                   help="with --refine: rounds of the surface's points moved to where the refined mattress puts "
                        "them (see 'airmat refine --reparametrize'; default 1)")
    add_out_argument(p, "design", "design.json, approx_surface.ply/.obj, target.ply, pattern.svg, pattern.dxf, "
                               "cutting_list.csv, preview.png, design.3dm (Rhino), report.html")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="fold-route relaxations at a time, one forked process each (Linux; default: the CPU "
                        "cores; the same design as one at a time)")
    p.add_argument("--paper", action="append", choices=("A4", "A3"), default=None,
                   help="also write pattern_A4.pdf / pattern_A3.pdf: the 1:1 drawing tiled over pages of that "
                        "size, with crop marks, page numbers and a 20 mm overlap (repeat for both)")
    p.set_defaults(func=run)


def parse_size_mm(text: str) -> tuple[float, float]:
    """``"830x740"`` -> (0.83, 0.74) m; InputError for anything else.

    Each side must lie in ``RANGES["--mattress"]`` (mm); a size that fits once
    multiplied by 1000 is taken for metres and the message says so.

    Examples
    --------
    >>> parse_size_mm("830x740")
    (0.83, 0.74)
    >>> parse_size_mm("0.83x0.74")
    Traceback (most recent call last):
    ...
    airmat.errors.InputError: --mattress: 0.83 x 0.74 mm is outside [50, 20000] mm per side; sizes are in mm: for a 0.83 x 0.74 m mattress give 830x740
    """
    m = _SIZE.match(text or "")
    if not m or float(m.group(1)) <= 0 or float(m.group(2)) <= 0:
        raise InputError(f"--mattress: expected WIDTHxHEIGHT in mm, e.g. 830x740, got {text!r}")
    w, h = float(m.group(1)), float(m.group(2))
    lo, hi, _, unit = RANGES["--mattress"]
    if not (lo <= w <= hi and lo <= h <= hi):
        hint = (f"; sizes are in mm: for a {w:g} x {h:g} m mattress give {1e3 * w:g}x{1e3 * h:g}"
                if lo <= 1e3 * w <= hi and lo <= 1e3 * h <= hi else "")
        raise InputError(f"--mattress: {w:g} x {h:g} mm is outside [{lo:g}, {hi:g}] {unit} per side{hint}",
                         option="--mattress", value=(w, h))
    return mm_to_m(w), mm_to_m(h)


def _positive(args, names):
    for name in names:
        value = getattr(args, name)
        if value is not None and not (value > 0 and value < float("inf")):
            raise InputError(f"--{name.replace('_', '-')}: must be a positive number, got {value!r}")


def _mattress_and_target(args):
    """The mattress, and a function that loads the target (called after the cheap checks)."""
    from airmat.design.presets import preset
    from airmat.design.mattress import Mattress
    from airmat.design.target import load_target

    if (args.target is None) == (args.preset is None):
        raise InputError("give either a TARGET file or --preset NAME (not both, not neither)")
    size = parse_size_mm(args.mattress) if args.mattress is not None else None
    if args.preset is not None:
        target, mattress = preset(args.preset)
        width, height = size if size else (mattress.width, mattress.height)
        thickness = mattress.thickness if args.thickness_mm is None else mm_to_m(args.thickness_mm)
        return Mattress(width, height, thickness), lambda: target
    if size is None:
        raise InputError("--mattress WxH (mm) is required with a TARGET file, e.g. --mattress 830x740")
    thickness = PAPER_D if args.thickness_mm is None else mm_to_m(args.thickness_mm)
    mattress = Mattress(size[0], size[1], thickness)
    return mattress, lambda: load_target(args.target, units=args.target_units, mattress=mattress)


def _params(args):
    from airmat.design.pipeline import DesignParams

    _positive(args, ["L_mm", "mu1_mm", "mu2_mm", "resolution_mm", "step_mm", "thickness_mm", "k_a1"])
    check_range("--thickness-mm", args.thickness_mm)
    check_range("--L-mm", args.L_mm)
    if not (args.margin_mm >= 0 and args.kappa_min_per_m >= 0 and args.weight_min >= 0
            and args.tie_grid_mm >= 0 and args.tie_grid_mm < float("inf")
            and all(k is None or k >= 0 for k in (args.k_a2, args.k_a3))):
        raise InputError("--margin-mm, --kappa-min-per-m, --weight-min, --tie-grid-mm, --k-a2 and --k-a3 "
                         "must be >= 0")
    if args.L_end_min_mm is not None and not args.end_dashes:
        raise InputError("--L-end-min-mm needs --end-dashes")
    mm = 1e-3
    return DesignParams(L=None if args.L_mm is None else args.L_mm * mm, mu1=None if args.mu1_mm is None else args.mu1_mm * mm,
                        mu2=args.mu2_mm * mm, margin=args.margin_mm * mm, spacing=args.resolution_mm * mm,
                        step=None if args.step_mm is None else args.step_mm * mm, k_a1=args.k_a1,
                        k_a2=args.k_a2, k_a3=args.k_a3, kappa_min=args.kappa_min_per_m,
                        weight_min=args.weight_min, tie_grid=args.tie_grid_mm * mm,
                        face_metric=not args.flat_metric, free_face_span=not args.dash_span,
                        folds=not args.no_folds, end_dashes=args.end_dashes,
                        L_end_min=None if args.L_end_min_mm is None else args.L_end_min_mm * mm)


def summary_text(doc: dict, out) -> str:
    """A few lines for stdout: strings per face and family, Table-1 figures, verdict, files."""
    from airmat.design.string_lengths import CURL_NOTE

    s, r = doc["summary"], doc["report"]
    lines = [f"airmat design: {doc['name']} on a {doc['mattress']['width_mm']:.0f} x "
             f"{doc['mattress']['height_mm']:.0f} mm mattress"
             + ("  [UNCALIBRATED: paper values]" if doc["uncalibrated"] else "")]
    for face in ("top", "bottom"):
        lines.append(f"  {face:6s} face: {s['strings'][face]['k1']:3d} k1 strings, "
                     f"{s['strings'][face]['k2']:3d} k2 strings")
    lines.append(f"  dashes without string (|kappa| too small): k1 {s['no_string']['k1']}, "
                 f"k2 {s['no_string']['k2']}")
    sg, k1, k2 = r["sigma"], r["kappa1_per_m"], r["kappa2_per_m"]
    lines.append(f"  sigma min/avg/max {sg['min']:.4f} / {sg['avg']:.4f} / {sg['max']:.4f}; "
                 f"|k1| avg/max {k1['avg']:.2f} / {k1['max']:.2f} 1/m; |k2| avg/max {k2['avg']:.2f} / "
                 f"{k2['max']:.2f} 1/m")
    tg = s.get("tie_grid")
    if tg and tg["grid_mm"] > 0:
        lines.append(f"  ends tied to the {tg['grid_mm']:g} mm grid: moved {tg['end_shift_mm']['mean']:.1f} mm on "
                     f"average (max {tg['end_shift_mm']['max']:.1f}), L changed by up to "
                     f"{tg['dL_mm']['max_abs']:.1f} mm")
    if doc.get("fold_route"):
        lines.append(f"  fold route: {doc['fold_route']['message']}")
    tt = r.get("to_target")
    if tt:
        over = tt.get("over_target")
        lines.append(f"  Ŝ to your target S: RMS {tt['rms_mm']:.1f} mm ({tt['rms_pct_diag']:.2f}% of the diagonal), "
                     f"max {tt['max_mm']:.1f} mm"
                     + (f"; over S ({100 * over['share']:.0f}% of Ŝ, the rest beyond its rim): RMS {over['rms_mm']:.1f} mm"
                        if over and over["share"] < 1.0 else ""))
    lines.extend(f"  warning: {w}" for w in r.get("warnings", []))
    lines.extend(f"  warning: {n}" for n in s.get("notes", []) if "extrapolated" in n or CURL_NOTE in n)
    lines.append("  constructible: yes" if r["constructible"] else
                 "  constructible: NO: " + "; ".join(r["reasons"]))
    flagged = sum(1 for d in doc["dashes"] if "beyond_reach" in d["flags"])
    if flagged:
        lines.append(f"  {flagged} strings beyond reach of the calibration (flagged in design.json)")
    if doc.get("refine"):
        lines.extend(refine_lines(doc["refine"]))
    lines.append(wrote_line(out))
    return "\n".join(lines)


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.progress import progress_enabled
    from airmat.design.calibration_source import PAPER, load_calibration
    from airmat.design.design_io import write_design
    from airmat.design.mattress import check_spacing
    from airmat.design.pipeline import design
    from airmat.design.stripes import check_stripe_params
    from airmat.report.page import write_report

    check_out_dir(args.out, inputs=[args.target, args.calibration])
    logging.getLogger("ezdxf").setLevel(logging.WARNING)  # its INFO lines are about DXF internals
    # cheap checks first, so that a bad argument is the only line on stderr
    params = _params(args)
    calibration = load_calibration(args.calibration) if args.calibration else None
    mattress, load = _mattress_and_target(args)
    try:
        check_spacing(mattress, params.spacing)
    except InputError as err:
        raise InputError(f"--resolution-mm {args.resolution_mm:g}: {err.message}") from None
    L = params.L if params.L is not None else (calibration.L if calibration else PAPER["L"])
    check_stripe_params(params.stripe_params(L), mattress.width, mattress.height)
    if args.refine and not (args.refine_resolution_mm > 0):
        raise InputError(f"--refine-resolution-mm must be > 0, got {args.refine_resolution_mm!r}")
    check_regularization("--refine-regularization", args.refine_regularization)
    check_rounds("--refine-reparametrize", args.refine_reparametrize)
    check_corrections("--refine-defect-corrections", args.refine_defect_corrections, args.refine_single_level,
                      "--refine-single-level")
    result = design(load(), mattress, calibration=calibration, params=params, seed=args.seed,
                    progress=progress_enabled(), workers=jobs(args))
    failed = design_not_converged(result)
    if args.refine:
        from airmat.units import MM
        from airmat.check.refinement import refine

        refinement = refine(result, resolution=args.refine_resolution_mm * MM,
                            **refine_options(args.refine_defect_corrections, args.refine_regularization,
                                             args.refine_single_level, args.refine_reparametrize))
        result = refinement.design
        failed += refine_not_converged(refinement)
    with staged(args.out) as tmp:
        doc = write_design(result, tmp, papers=tuple(dict.fromkeys(args.paper or ())), workers=jobs(args))
        write_report(tmp, design=result, title=f"airmat design: {result.name}")
    print(summary_text(doc, args.out))
    return not_converged("design", failed)


def design_not_converged(result) -> list[str]:
    """What did not converge in a design: the U_A relaxation."""
    relax = result.approx.relax
    return [] if relax is None or relax.converged else [f"U_A relaxation: {relax.message}"]
