"""`airmat correct DESIGN_DIR SCAN [--out DIR]`: learn from a scan of the built mattress and correct its strings.

The scan (any format 'airmat fit' reads, any frame, metres or millimetres, partial, with the floor
and clutter around it) is registered onto the design's predicted inflated shape; its deviation
from Ŝ and from the prediction is mapped; Equation 3's Δ and d and every string's length error are
updated with it; and the strings are corrected so that the next build lands on Ŝ. The output
folder is a design folder (the corrected lengths, Ŝ unchanged) with the re-tie list, the maps,
correct.json and, in calibration/, the updated calibration.
"""

from __future__ import annotations

from airmat.cli._ranges import check_range
from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError

EPILOG = """\
Next: re-cut the strings retie.csv lists (keep the others), re-inflate, and scan again; or
'airmat check DIR' to see the corrected design's predicted shape, and
'airmat design --calibration DIR/calibration ...' to design another shape with what this one taught."""


def add_parser(sub, parents):
    import argparse

    p = sub.add_parser("correct", parents=parents,
                       help="register a scan of the built mattress, learn Δ, d and each tie's error from it, and "
                            "correct the string lengths",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("design", metavar="DESIGN_DIR", help="the folder of the design the mattress was built from")
    p.add_argument("scan", metavar="SCAN", help="a scan of the built, inflated mattress from above (PLY, E57, "
                                                "LAS/LAZ, PCD, GLB, PTS, ...)")
    add_out_argument(p, "correct", "the corrected design, retie.csv/.json/.png, correct.json, deviation maps, "
                                   "calibration/, report.html")
    p.add_argument("--scan-units", choices=("m", "cm", "mm", "in"), default=None,
                   help="unit of the scan file's coordinates (default the format's: metres for E57 and LAS/LAZ, "
                        "else millimetres; a scan in metres read as mm is detected from its size)")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the inflations (mm, default 20, as 'airmat check')")
    p.add_argument("--cut-tolerance-mm", type=float, default=3.0,
                   help="how well strings are cut and tied, +-mm: the prior of each tie's error (default 3)")
    p.add_argument("--keep-tolerance-mm", type=float, default=1.0,
                   help="a string whose length would change by at most this is kept (mm, default 1)")
    p.add_argument("--relinearisations", type=int, default=10, metavar="N",
                   help="relinearisations of the update at most, each one inflation (a count 0 to 10, default 10; "
                        "the update stops earlier once it converges)")
    p.add_argument("--calibration", metavar="DIR", default=None,
                   help="the cylinder calibration the design was made from (default: the design's own "
                        "calibration folder)")
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from airmat.asbuilt.correct_io import CORRECT_FILES, summary_lines, write_correct
    from airmat.asbuilt.pipeline import correct
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import check, staged
    from airmat.design.design_io import read_design
    from airmat.listing import listed
    from airmat.report.page import write_report
    from airmat.units import MM

    for name in ("--resolution-mm", "--cut-tolerance-mm", "--keep-tolerance-mm"):
        check_range(name, getattr(args, name[2:].replace("-", "_")))
    from airmat.asbuilt.update import MAX_RELINEARISATIONS

    if not 0 <= args.relinearisations <= MAX_RELINEARISATIONS:
        raise InputError(f"--relinearisations: {args.relinearisations} is outside 0 to {MAX_RELINEARISATIONS}")
    scan = Path(args.scan)
    if not scan.is_file():
        raise InputError(f"{scan}: no such scan file" if not scan.exists() else f"{scan}: not a file")
    check_out_dir(args.out, inputs=[args.design, args.scan])
    design = read_design(args.design)
    base = None
    if args.calibration is not None:
        from airmat.calib.calibration_io import read_calibration

        base = read_calibration(args.calibration)
    check()
    res = correct(design, scan, resolution=args.resolution_mm * MM, scan_units=args.scan_units,
                  cut_tolerance=args.cut_tolerance_mm * MM, keep_tolerance=args.keep_tolerance_mm * MM,
                  base_calibration=base, seed=args.seed, max_relinearisations=args.relinearisations)
    with staged(args.out) as tmp:
        doc = write_correct(Path(tmp), res)
        write_report(tmp, design=res.correction.design, asbuilt=res, title=f"airmat correct: {design.name}")
    print("\n".join([f"airmat correct: {design.name} from {scan.name} -> {args.out}", *summary_lines(doc),
                     f"  wrote {listed(args.out, (*CORRECT_FILES, 'report.html'))} to {args.out}"]))
    return not_converged("correct", [] if res.update.converged else [f"the as-built update: {res.update.message}"])
