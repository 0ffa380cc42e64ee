"""`airmat synth [--out DIR]`: write a synthetic calibration set (scans, manifest.csv, truth.json)."""

from __future__ import annotations

import argparse

from airmat.cli._ranges import check_range
from airmat.cli._vocabulary import add_note, add_out_argument, default_out, deprecated_alias
from airmat.errors import InputError


def _ratios(text: str) -> tuple:
    try:
        values = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise InputError(f"--l-over-L {text!r}: expected comma-separated numbers, "
                         "e.g. 0.3,0.5,0.7,0.9") from None
    if not values or not all(0 < r < 1 for r in values):
        raise InputError(f"--l-over-L {text!r}: every ratio l/L must lie in (0, 1), e.g. 0.3,0.5,0.7,0.9")
    return values


def output_folder(args) -> str:
    """``--out``, else the old positional OUTDIR (with a note), else ``out/synth``; both at once is refused."""
    if args.outdir is not None and args.out is not None:
        raise InputError(f"give the output folder once: --out {args.out} (the positional {args.outdir} is "
                         "its old form)")
    if args.outdir is not None:
        add_note(args, f"airmat synth: the positional OUTDIR is deprecated, use --out {args.outdir}")
        return args.outdir
    return args.out if args.out is not None else default_out("synth")


def add_parser(sub, parents):
    p = sub.add_parser("synth", parents=parents,
                       help="write a synthetic calibration set with known Δ, d and scatter",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    # the old form of --out, still accepted (with a note)
    p.add_argument("outdir", nargs="?", default=None, metavar="OUTDIR", help=argparse.SUPPRESS)
    add_out_argument(p, "synth", "the scans, manifest.csv, truth.json", default=False)
    p.add_argument("--delta-mm", type=float, default=18.0, help="true string-end slip Δ (mm, default 18)")
    p.add_argument("--thickness-mm", type=float, default=70.0,
                   help="true mattress thickness d (mm, default 70)")
    deprecated_alias(p, "--d-mm", "--thickness-mm")
    p.add_argument("--L-mm", type=float, default=300.0, dest="L_mm",
                   help="geodesic distance L of the string ends (mm, default 300)")
    p.add_argument("--l-over-L", default=None, dest="l_over_L", metavar="R1,R2,...",
                   help="string length ratios l/L (dimensionless; default: 12 from 0.3 to 0.95)")
    p.add_argument("--points", type=int, default=100_000, help="points per scan (a count, default 100000)")
    p.add_argument("--scatter", type=float, default=0.03,
                   help="log-sd of the lognormal specimen-to-specimen curvature scatter (dimensionless, "
                        "default 0.03)")
    p.set_defaults(func=run)


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli.sigint import check
    from airmat.units import MM
    from airmat.synthetic.calibration_set import DEFAULT_L_OVER_L, calibration_set

    out = output_folder(args)
    check_out_dir(out)
    check_range("--thickness-mm", args.thickness_mm)
    check_range("--L-mm", args.L_mm)
    if not (0 <= args.delta_mm < args.L_mm / 2):
        raise InputError(f"--delta-mm: {args.delta_mm:g} mm is outside [0, L/2) = [0, {args.L_mm / 2:g}) mm")
    if not (0 <= args.scatter <= 1):
        raise InputError(f"--scatter: {args.scatter:g} is outside [0, 1] (a log-sd)")
    check_range("--points", args.points)
    ratios = DEFAULT_L_OVER_L if args.l_over_L is None else _ratios(args.l_over_L)
    check()  # a Ctrl-C that a library's import swallowed
    cs = calibration_set(out, delta=args.delta_mm * MM, d=args.thickness_mm * MM, L=args.L_mm * MM,
                         l_over_L=ratios, n_points=args.points, scatter=args.scatter,
                         seed=args.seed)
    t = cs.truth
    print(f"wrote {len(cs.scans)} scans ({args.points} points each), manifest.csv and truth.json "
          f"to {cs.folder}\n"
          f"truth: Delta = {t['delta_mm']:g} mm, d = {t['d_mm']:g} mm, L = {t['L_mm']:g} mm, "
          f"sigma = {t['sigma_per_m']:.3f} 1/m (flat from l = {t['flat_l_mm']:.1f} mm)\n"
          f"next: airmat calibrate {cs.manifest} --truth {cs.truth_path} [--out DIR]")
    return 0
