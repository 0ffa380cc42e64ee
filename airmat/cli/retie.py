"""`airmat retie DESIGN_A DESIGN_B [--out DIR]`: what to do to each string from shape A to B: keep, re-cut, move, remove, add."""

from __future__ import annotations

EPILOG = """\
categories (a string of A, or of B for 'add'):
  keep     the same two grid nodes in B, length within the cut tolerance: leave it
  re-cut   the same nodes, a new length: cut it to l_b_mm (dl_mm is the change)
  move     new nodes: re-tie it at B's nodes (and cut it to l_b_mm)
  remove   A has more strings on that face: take it off
  add      B has more strings on that face: a new one

Without --out the counts are printed and nothing is written. --seed is accepted, as by every
command, and ignored: the re-tie list has no random step."""


def add_parser(sub, parents):
    import argparse

    from airmat.constants import CUT_TOLERANCE
    from airmat.units import M_TO_MM

    p = sub.add_parser("retie", parents=parents,
                       help="the re-tie list between two designs on the same mattress (one mattress, many shapes)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("design_a", metavar="DESIGN_A", help="output folder of 'airmat design': the shape now")
    p.add_argument("design_b", metavar="DESIGN_B", help="output folder of 'airmat design': the next shape")
    p.add_argument("--out", metavar="DIR", help="output folder: retie.json, retie.csv, retie.png (default: "
                                                "print the counts only, write nothing)")
    p.add_argument("--cut-tolerance-mm", type=float, default=CUT_TOLERANCE * M_TO_MM, metavar="MM",
                   help="a string at the same nodes whose length changes by at most this is kept, by more "
                        "is re-cut (default %(default)g mm)")
    p.set_defaults(func=run)


def run(args) -> int:
    import math

    from airmat.atomic import check_out_dir, staged_dir
    from airmat.design.design_io import read_design
    from airmat.design.export.retie_files import write_retie
    from airmat.design.retie import counts_text, retie_plan
    from airmat.errors import InputError
    from airmat.listing import listed
    from airmat.units import mm_to_m

    tol = args.cut_tolerance_mm
    if not (math.isfinite(tol) and tol >= 0):
        raise InputError(f"--cut-tolerance-mm: {tol:g} mm is not a length >= 0 mm")
    if args.out is not None:
        check_out_dir(args.out, inputs=[args.design_a, args.design_b])
    a, b = read_design(args.design_a), read_design(args.design_b)
    plan = retie_plan(a, b, cut_tolerance=mm_to_m(tol))
    print(f"airmat retie: {len(a.pattern.strings)} strings -> {len(b.pattern.strings)}: "
          f"{counts_text(plan.counts)} (cut tolerance {tol:g} mm)")
    if args.seed != 0:
        print("  --seed is ignored: the re-tie list has no random step")
    if args.out is not None:
        m = a.approx.mattress
        with staged_dir(args.out) as tmp:
            write_retie(tmp, plan, design_a=str(args.design_a), design_b=str(args.design_b),
                        width=m.width, height=m.height)
        print(f"  wrote {listed(args.out, ('retie.json',))} to {args.out}")
    return 0
