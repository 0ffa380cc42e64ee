"""`airmat refine DESIGN_DIR [--out DIR]`: refine a design's string lengths through the simulated inflation."""

from __future__ import annotations

from pathlib import Path

from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError
from airmat.cli._refining import (check_corrections, check_regularization, check_rounds, refine_lines,
                                  refine_not_converged, refine_options, wrote_line)


def add_parser(sub, parents):
    p = sub.add_parser("refine", parents=parents,
                       help="refine the string lengths through the inflation so that it lands on the surface",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("design", metavar="DESIGN_DIR", help="output folder of 'airmat design'")
    add_out_argument(p, "refine", "the refined design (the files of 'airmat design', with a 'refine' block in "
                               "design.json)")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the inflations (mm, default 20); 'airmat check' at the same "
                        "resolution reproduces the promised deviation")
    p.add_argument("--max-iter", type=int, default=20, help="Gauss-Newton iterations (a count, default 20)")
    p.add_argument("--single-level", action="store_true",
                   help="run every Gauss-Newton iteration at --resolution-mm (slower, closer; measured in "
                        "docs/decisions.md, Refinement); default: on twice that mesh")
    p.add_argument("--defect-corrections", type=int, default=0, metavar="N",
                   help="where the iterations on the coarse mesh stop early, solve the fine mesh at their lengths, "
                        "re-correct the coarse one by it and go on, up to N times (default 0; what it gains and "
                        "costs: docs/benchmarks.md, 'bench/bench_refine.py --corrections 0 1')")
    p.add_argument("--regularization", type=float, default=None, metavar="ALPHA",
                   help="weight of the pull toward the open-loop lengths, alpha * mean((l* - l*_open)^2) beside "
                        "the mean squared deviation (dimensionless, default 1e-3: a 32 mm change of every string costs as much "
                        "as 1 mm RMS)")
    p.add_argument("--reparametrize", type=int, default=None, metavar="N",
                   help="rounds of the surface's points moved along it to where the refined mattress puts them "
                        "(the metric its face realizes), each followed by more iterations; 0 keeps the surface's "
                        "points as designed (default 1; the iterations are split evenly)")
    p.set_defaults(func=run)


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.units import MM
    from airmat.check.refine_setup import check_refinable
    from airmat.check.refinement import refine
    from airmat.design.design_io import read_design, write_design
    from airmat.report.page import write_report

    check_out_dir(args.out, inputs=[args.design])
    if not (args.resolution_mm > 0):
        raise InputError(f"--resolution-mm must be > 0, got {args.resolution_mm!r}")
    if args.max_iter < 1:
        raise InputError(f"--max-iter must be >= 1, got {args.max_iter}")
    check_corrections("--defect-corrections", args.defect_corrections, args.single_level, "--single-level")
    check_regularization("--regularization", args.regularization)
    check_rounds("--reparametrize", args.reparametrize)
    design = read_design(args.design)
    check_refinable(design, args.resolution_mm * MM, path=Path(args.design) / "design.json")
    refinement = refine(design, resolution=args.resolution_mm * MM, max_iter=args.max_iter,
                        **refine_options(args.defect_corrections, args.regularization, args.single_level,
                                         args.reparametrize))
    with staged(args.out) as tmp:
        write_design(refinement.design, tmp)
        write_report(tmp, design=refinement.design, title=f"airmat refine: {design.name}")
    print("\n".join([f"airmat refine: {design.name} -> {args.out}", *refine_lines(refinement.block()),
                     wrote_line(args.out),
                     f"  next: 'airmat check {args.out} --out DIR --resolution-mm {args.resolution_mm:g}' inflates "
                     f"the refined lengths (the same deviation) with their lo95/hi95 envelope"]))
    return not_converged("refine", refine_not_converged(refinement))
