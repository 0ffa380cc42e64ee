"""`airmat check DESIGN_DIR [--out DIR]`: simulate the inflation of a design and compare it with Ŝ.

The check stage's command; ``airmat inflate`` is its other name (an alias: the same parser, and the
name the run was called by in its stderr lines).
"""

from __future__ import annotations

from airmat.cli._jobs import add_jobs_argument, jobs, scheduler
from airmat.cli._ranges import check_range
from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError

#: ``--validation-samples``'s default, airmat.check.tolerance_validation.VALIDATION_SAMPLES (not imported:
#: ``airmat --help`` stays free of numpy; tests/cli/test_tolerance_cli.py holds the two equal)
VALIDATION_DEFAULT = 16


def add_parser(sub, parents):
    p = sub.add_parser("check", aliases=["inflate"], parents=parents,
                       help="simulate the mattress inflating with its string pattern and measure how far it lands "
                            "from Ŝ (paper §3.4)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("design", metavar="DESIGN_DIR", help="output folder of 'airmat design'")
    add_out_argument(p, "check", "inflate.json, inflated.ply, inflated.3dm (Rhino), deviation.png, report.html")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="edge length of the double-layer mesh (mm, default 20, near the loop-pin spacing)")
    p.add_argument("--pressure-pa", type=float, default=None, help="inflation pressure (Pa, default 2000)")
    p.add_argument("--no-envelope", action="store_true",
                   help="skip the runs with every string at its lo95 and hi95 length")
    p.add_argument("--calibrated-map", action="store_true",
                   help="simulate each string at the rest length that makes the simulated specimen bend as the "
                        "calibration says (built from specimen runs at this resolution, cached), not at l + 2Δ")
    p.add_argument("--samples", type=int, default=0, metavar="K",
                   help="also inflate K (a count) Monte-Carlo samples of the string lengths (calibration posterior and "
                        "per-string scatter): RMS quantiles, inflated_bands.ply, the 95%% band (default 0: none)")
    p.add_argument("--tolerance-mm", type=float, default=None, metavar="T",
                   help="report the probability that the RMS deviation is <= T mm (from --samples or the linear "
                        "tolerance)")
    p.add_argument("--tolerance", choices=("linear", "samples", "none"), default=None,
                   help="the tolerance of the shape: 'linear' (the adjoint Jacobian at the median run times the "
                        "covariance of the string lengths, checked against --validation-samples full samples; the "
                        "default without "
                        "--samples, where the lengths have a spread), 'samples' (the K runs of --samples; the "
                        "default with it) or 'none'")
    p.add_argument("--validation-samples", type=int, default=VALIDATION_DEFAULT, metavar="N",
                   help="with the linear tolerance: full samples (an even count, in antithetic pairs) that check it "
                        "and give its mean shift, on a mesh twice as coarse as --resolution-mm up to 40 mm "
                        f"(default {VALIDATION_DEFAULT})")
    p.add_argument("--cut-tolerance-mm", type=float, default=0.0, metavar="t",
                   help="with the linear tolerance: every string cut and tied within +-t mm (uniform), on top of "
                        "the calibration's spread (mm, default 0)")
    add_jobs_argument(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from dataclasses import replace

    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.units import MM
    from airmat.check.inflation_check import check
    from airmat.design.design_io import read_design
    from airmat.inflation.model import Parameters
    from airmat.check.report import summary_text, write_check
    from airmat.report.page import write_report

    check_out_dir(args.out, inputs=[args.design])
    if not (args.resolution_mm > 0):
        raise InputError(f"--resolution-mm must be > 0, got {args.resolution_mm!r}")
    params = Parameters()
    if args.pressure_pa is not None:
        check_range("--pressure-pa", args.pressure_pa)
        params = replace(params, pressure=args.pressure_pa)
    if args.samples < 0:
        raise InputError(f"--samples must be >= 0, got {args.samples}")
    mode = _tolerance_mode(args)
    workers = jobs(args)
    design = read_design(args.design)
    result = check(design, resolution=args.resolution_mm * MM, params=params, envelope=not args.no_envelope,
                   workers=workers, calibrated_map=args.calibrated_map, scheduler=scheduler(args),
                   samples=args.samples, seed=args.seed if args.seed is not None else 0,
                   tolerance=args.tolerance_mm * MM if args.tolerance_mm is not None else None)
    if mode == "linear":
        result = _with_linear_tolerance(design, result, args, workers)
    with staged(args.out) as tmp:
        doc = write_check(result, tmp, workers=workers)
        write_report(tmp, check=result, title=f"airmat {getattr(args, 'command', 'check')}: {design.name}")
    print(summary_text(doc, args.out))
    if design.refine is None and len(design.pattern.strings):
        print(f"  next: these are the open-loop lengths (Equation 3, one dash at a time); "
              f"'airmat refine {args.design} --out DIR' adjusts them together through the inflation")
    return not_converged(getattr(args, "command", "check"), check_not_converged(result))


def _tolerance_mode(args) -> str:
    """``--tolerance`` resolved (``samples`` with --samples K, else ``linear``), its options checked."""
    mode = args.tolerance or ("samples" if args.samples > 0 else "linear")
    if mode == "samples" and args.samples == 0:
        raise InputError("--tolerance samples needs --samples K > 0")
    if args.tolerance_mm is not None:
        if args.samples == 0 and mode != "linear":
            raise InputError("--tolerance-mm needs --samples K > 0 or --tolerance linear")
        if not (args.tolerance_mm > 0):
            raise InputError(f"--tolerance-mm must be > 0, got {args.tolerance_mm!r}")
    if not (args.cut_tolerance_mm >= 0):
        raise InputError(f"--cut-tolerance-mm must be >= 0, got {args.cut_tolerance_mm!r}")
    n = args.validation_samples
    if n < 0 or n % 2:
        raise InputError(f"--validation-samples must be an even count >= 0 (antithetic pairs), got {n}")
    if n != VALIDATION_DEFAULT and mode != "linear":
        raise InputError("--validation-samples needs the linear tolerance (--tolerance linear)")
    if args.cut_tolerance_mm > 0 and mode != "linear":
        raise InputError("--cut-tolerance-mm needs the linear tolerance (--tolerance linear)")
    return mode


def _with_linear_tolerance(design, result, args, workers):
    """The check with its linear tolerance (airmat.check.tolerance), or as it is where none applies."""
    import logging
    from dataclasses import replace

    from airmat.check.tolerance import applies, tolerance
    from airmat.units import MM

    why_not = applies(design, args.cut_tolerance_mm * MM)
    if why_not is not None:
        logging.getLogger(__name__).log(logging.WARNING if args.tolerance == "linear" else logging.INFO,
                                        "no linear tolerance: %s", why_not)
        return result
    lin = tolerance(design, run=result, cut_tolerance=args.cut_tolerance_mm * MM, validate=args.validation_samples,
                    tolerance=args.tolerance_mm * MM if args.tolerance_mm is not None else None,
                    seed=args.seed if args.seed is not None else 0, workers=workers, scheduler=scheduler(args))
    return replace(result, tolerance=lin)


def check_not_converged(result) -> list[str]:
    """What did not converge in an inflation check: each run (median, lo95, hi95) by name."""
    out = [f"inflation with the {k} string lengths: {r.inflation.message}"
           for k, r in result.runs.items() if not r.inflation.converged]
    mc = result.monte_carlo
    if mc is not None and not mc.converged.all():
        out.append(f"{int((~mc.converged).sum())} of {mc.converged.size} Monte-Carlo runs")
    return out
