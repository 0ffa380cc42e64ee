"""`airmat plan CALIBRATION [--design DIR] [--add N] [--out DIR]`: which specimens to build and scan next."""

from __future__ import annotations

EPILOG = """\
The plan simulates each candidate specimen's measurement under the calibration's posterior
(its scatter σ plus the fit error --kappa-se-per-m), reweights the posterior draws by it and
keeps, step by step, the l/L whose expected result is smallest: the (Δ, d) 95 % credible area,
or with --design that design's strings' mean 95 % length band. A ratio may come up more than
once: scan that many specimens there. The string length to cut is l = l/L x L, with the
calibration's L."""


def add_parser(sub, parents):
    import argparse

    from airmat.cli._vocabulary import add_out_argument

    p = sub.add_parser("plan", parents=parents,
                       help="which specimens (l/L, how many) to build and scan next to shrink the uncertainty most",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("calibration", metavar="CALIBRATION", help="output folder of 'airmat calibrate'")
    p.add_argument("--design", metavar="DIR", default=None,
                   help="output folder of 'airmat design': shrink its strings' 95 %% length band instead of the "
                        "(Δ, d) credible area")
    p.add_argument("--add", type=int, default=4, metavar="N", help="specimens to propose (a count, default 4)")
    p.add_argument("--l-over-L", default=None, dest="l_over_L", metavar="R1,R2,...",
                   help="candidate ratios l/L (dimensionless; default 0.3 to 0.95 in steps of 0.025)")
    p.add_argument("--kappa-se-per-m", type=float, default=None, metavar="PER_M",
                   help="cylinder-fit standard error of a new specimen's curvature (1/m; default: the median of "
                        "the calibration's specimens)")
    add_out_argument(p, "plan", "plan.json, plan.csv, plan.png")
    p.set_defaults(func=run)


def _ratios(text: str | None):
    from airmat.calib.experiment_design import DEFAULT_L_OVER_L
    from airmat.errors import InputError

    if text is None:
        return DEFAULT_L_OVER_L
    try:
        values = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise InputError(f"--l-over-L {text!r}: expected comma-separated numbers, e.g. 0.3,0.5,0.7,0.9") from None
    if len(set(values)) < 2 or not all(0 < r <= 1 for r in values):
        raise InputError(f"--l-over-L {text!r}: need at least two ratios l/L in (0, 1], e.g. 0.3,0.5,0.7,0.9")
    return values


def run(args) -> int:
    import math

    from airmat.atomic import check_out_dir
    from airmat.calib.calibration_io import read_calibration
    from airmat.calib.experiment_design import plan
    from airmat.calib.plan import summary_text, write_plan
    from airmat.cli.sigint import staged
    from airmat.errors import InputError
    from airmat.listing import listed
    from airmat.summary import band_mm

    if args.add < 1 or args.add > 50:
        raise InputError(f"--add {args.add}: propose between 1 and 50 specimens")
    se = args.kappa_se_per_m
    if se is not None and not (math.isfinite(se) and se >= 0):
        raise InputError(f"--kappa-se-per-m: {se:g} 1/m is not a standard error >= 0")
    candidates = _ratios(args.l_over_L)
    check_out_dir(args.out, inputs=[args.calibration, args.design])
    cal = read_calibration(args.calibration)
    design = None
    if args.design is not None:
        from airmat.design.design_io import read_design

        design = read_design(args.design)
    result = plan(cal, design=design, n_add=args.add, candidates=candidates, kappa_se=se, seed=args.seed)
    with staged(args.out) as tmp:
        write_plan(result, tmp, calibration=str(args.calibration), design=args.design)
    p = cal.posterior
    print(summary_text(result, now_words=f"Δ {band_mm(p.delta, 1)}, d {band_mm(p.d, 1)}"))
    print(f"  wrote {listed(args.out, ('plan.json', 'plan.csv', 'plan.png'))} to {args.out}")
    return 0
