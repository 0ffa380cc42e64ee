"""`airmat calibrate MANIFEST [--out DIR]`: Equation 3's Δ and d from scans, with uncertainty."""

from __future__ import annotations

import json
import math
from pathlib import Path

from airmat.errors import InputError


def add_parser(sub, parents):
    p = sub.add_parser("calibrate", parents=parents,
                       help="fit cylinders to specimen scans and sample the posterior of Δ and d",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("manifest", metavar="MANIFEST",
                   help="CSV with columns scan,l_mm,L_mm[,surface_offset_mm]; scans relative to it")
    from airmat.cli._vocabulary import add_out_argument

    add_out_argument(p, "calibrate", "calibration.json, posterior.npz, specimens.csv, curve.png, corner.png, "
                                     "report.html")
    from airmat.cli.fit import add_scan_options

    add_scan_options(p, index=False)
    p.add_argument("--walkers", type=int, default=32, help="emcee walkers (a count, default 32)")
    p.add_argument("--max-steps", type=int, default=4000,
                   help="cap on the chain length in steps (default 4000)")
    p.add_argument("--truth", metavar="JSON", default=None,
                   help="truth.json of a synthetic set: the true values beside the posterior (report.html, "
                        "the summary) and on the plots")
    p.set_defaults(func=run)


def _read_truth(path):
    if path is None:
        return None
    try:
        truth = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("truth file not found", path=path) from None
    except (OSError, ValueError) as err:
        raise InputError(f"cannot read the truth file: {err}", path=path) from None
    if not isinstance(truth, dict) or not {"delta_mm", "d_mm"} <= truth.keys():
        raise InputError("truth file must be a JSON object with delta_mm and d_mm", path=path)
    for key in ("delta_mm", "d_mm", "sigma_per_m"):
        value = truth.get(key)
        if key in truth and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                 and math.isfinite(value)):
            raise InputError(f"field '{key}' must be a finite number, got {value!r}", path=path, field=key)
    return truth


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.calib.calibrate import calibrate
    from airmat.calib.plots import plot_corner, plot_curve
    from airmat.calib.calibration_io import summary_text, write_calibration
    from airmat.report.page import write_report

    check_out_dir(args.out, inputs=[args.manifest, args.truth])
    truth = _read_truth(args.truth)
    cal = calibrate(args.manifest, scan_units=args.scan_units, n_walkers=args.walkers,
                    max_steps=args.max_steps, seed=args.seed)
    with staged(args.out) as tmp:
        write_calibration(cal, tmp, truth=truth)
        plot_curve(cal, tmp / "curve.png", truth=truth)
        plot_corner(cal.posterior, tmp / "corner.png", truths=truth)
        write_report(tmp, calibration=cal, truth=truth, title=f"airmat calibrate: {args.manifest}")
    print(summary_text(cal, args.out, truth=truth))
    return not_converged("calibrate", calibration_not_converged(cal))


def calibration_not_converged(cal) -> list[str]:
    """What did not converge in a calibration: the MCMC, the specimens' cylinder fits."""
    what = [] if cal.posterior.converged else [f"MCMC: {cal.posterior.message}"]
    fits = [s.scan for s in cal.specimens if not s.fit_converged]
    if fits:
        what.append(f"cylinder fit of {len(fits)} specimen(s): {', '.join(fits)}")
    return what
