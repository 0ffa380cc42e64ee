"""`airmat validate --out DIR`: the simulated cylindrical-specimen experiment against Equation 3."""

from __future__ import annotations

from airmat.cli._jobs import add_jobs_argument, jobs
from airmat.errors import InputError


def add_parser(sub, parents):
    p = sub.add_parser("validate", parents=parents,
                       help="simulate the paper's specimen experiment and compare with Equation 3 (Delta = 0)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--out", default="out/validate", metavar="DIR",
                   help="output folder: validate.json, validate.csv, validate.png (default out/validate)")
    p.add_argument("--l-over-L", dest="ratios", default="0.3,0.4,0.5,0.6,0.7,0.8,0.9",
                   help="string length ratios (default 0.3,...,0.9)")
    p.add_argument("--resolution-mm", type=float, default=40.0, help="mesh edge length (default 40)")
    add_jobs_argument(p)
    p.set_defaults(func=run)


def _write(points, folder, resolution_mm):
    import json

    from airmat.atomic import atomic_write_text
    from airmat.figures import save_png
    from check.validation import validation_figure

    rows = [{"l_over_L": p.l_over_L, "kappa_sim_per_m": round(p.kappa_sim, 4),
             "kappa_sim_se_per_m": round(p.kappa_sim_se, 4), "kappa_strings_per_m": round(p.kappa_strings, 4),
             "kappa_eq3_per_m": round(p.kappa_eq3, 4),
             "converged": p.converged, "iterations": p.n_iter} for p in points]
    doc = {"experiment": "strip with parallel bottom strings, L = 300 mm, d = 70 mm, Delta = 0; kappa of the "
                         "simulated mid-surface by calib's cylinder fit", "resolution_mm": resolution_mm,
           "points": rows, "converged": all(p.converged for p in points),
           "timings_s": {f"{p.l_over_L:g}": round(p.seconds, 2) for p in points}}
    atomic_write_text(folder / "validate.json", json.dumps(doc, indent=2) + "\n")
    atomic_write_text(folder / "validate.csv", "l_over_L,kappa_sim_per_m,kappa_sim_se_per_m,kappa_strings_per_m,"
                      "kappa_eq3_per_m\n" +
                      "".join(f"{r['l_over_L']},{r['kappa_sim_per_m']},{r['kappa_sim_se_per_m']},"
                              f"{r['kappa_strings_per_m']},{r['kappa_eq3_per_m']}\n" for r in rows))
    save_png(validation_figure(points), folder / "validate.png", dpi=110)
    return rows


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.units import MM
    from check.validation import validate_equation3

    check_out_dir(args.out)
    try:
        ratios = [float(x) for x in args.ratios.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"--l-over-L {args.ratios!r}: expected comma-separated numbers") from None
    if not ratios or any(not (0 < r < 1) for r in ratios):
        raise InputError(f"--l-over-L {args.ratios!r}: ratios must lie in (0, 1)")
    if not (0 < args.resolution_mm <= 75):
        raise InputError(f"--resolution-mm {args.resolution_mm:g}: must be in (0, 75] (L/4 for L = 300 mm)")
    workers = jobs(args)
    points = validate_equation3(ratios, resolution=args.resolution_mm * MM, seed=args.seed, workers=workers)
    with staged(args.out) as tmp:
        rows = _write(points, tmp, args.resolution_mm)
    print("l/L   cylinder fit κ (1/m)   along strings κ (1/m)   Equation 3, Δ = 0 (1/m)")
    for r in rows:
        print(f"{r['l_over_L']:.2f}  {r['kappa_sim_per_m']:8.2f} ± {2 * r['kappa_sim_se_per_m']:.2f}"
              f"       {r['kappa_strings_per_m']:8.2f}              {r['kappa_eq3_per_m']:8.2f}")
    print(f"wrote validate.json, validate.csv, validate.png to {args.out}")
    return not_converged("validate", [f"inflation at l/L = {p.l_over_L:g}: {p.message}"
                                      for p in points if not p.converged])
