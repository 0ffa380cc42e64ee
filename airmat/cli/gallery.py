"""`airmat gallery [--out DIR]`: design (and refine) and inflate every preset; a Table-1-style table."""

from __future__ import annotations

import time
from pathlib import Path

from airmat.cli._jobs import add_jobs_argument, jobs, scheduler
from airmat.cli._ranges import check_resolution
from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError

# airmat.design.presets.PRESETS (a test keeps them equal), without importing the designer at start-up
PRESETS = ("vault1", "saddle", "dome", "vault2", "roof")
HEADER = ("| size | model | σ (min // avg // max) | abs κ₁ (avg // max) [1/m] | abs κ₂ (avg // max) [1/m] "
          "| strings | constructible | deviation RMS // max [mm] | RMS % diag | lo95 // hi95 RMS [mm] "
          "| design + inflate [s] |")
#: the columns --refine adds before the last one
REFINE_COLUMNS = "| open loop RMS % diag | refine iterations |"


def add_parser(sub, parents):
    p = sub.add_parser("gallery", parents=parents,
                       help="design and check all five presets; write a Table-1-style table",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    add_out_argument(p, "gallery", "gallery.md, gallery.json, a design and a check folder per preset")
    p.add_argument("--presets", default=",".join(PRESETS), metavar="NAME,...",
                   help="comma-separated presets ('airmat presets' lists them; default: all five)")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the inflation check (mm, default 20, as 'airmat check')")
    p.add_argument("--calibration", metavar="DIR", default=None,
                   help="output folder of 'airmat calibrate' (default: the paper's values, UNCALIBRATED)")
    p.add_argument("--refine", action="store_true",
                   help="refine each design's string lengths through the inflation (at --resolution-mm) "
                        "before checking it; the table gives the open-loop deviation next to the refined one")
    add_jobs_argument(p)
    p.set_defaults(func=run)


def header(refine: bool) -> str:
    """The table's header, with the refinement's columns when ``refine``."""
    if not refine:
        return HEADER
    head, last = HEADER.rstrip("|").rsplit("|", 1)
    return head + REFINE_COLUMNS + last.replace("design + inflate", "design + refine + inflate") + "|"


def table_row(design, check, seconds: float, refinement=None) -> str:
    """One Markdown row from a DesignResult and its DesignCheck (mm and 1/m printed); with a refinement,
    its open-loop deviation and iterations before the time."""
    rep, runs = design.approx.report, check.runs
    dev = runs["median"].deviation
    s, k1, k2 = rep.sigma, rep.kappa1, rep.kappa2
    size = "small" if design.mattress.width < 1.5 else "large"
    env = " // ".join(f"{runs[k].deviation.rms * 1e3:.1f}" if k in runs else "-" for k in ("lo95", "hi95"))
    return (f"| {size} | {design.name} | {s['min']:.4f} // {s['avg']:.4f} // {s['max']:.4f} "
            f"| {k1['avg']:.2f} // {k1['max']:.2f} | {k2['avg']:.2f} // {k2['max']:.2f} "
            f"| {len(design.pattern.strings)} | {'yes' if rep.constructible else 'no'} "
            f"| {dev.rms * 1e3:.1f} // {dev.max * 1e3:.1f} | {dev.rms_pct_diag:.2f} "
            f"| {env} |"
            + ("" if refinement is None else f" {refinement.deviation_before.rms_pct_diag:.2f} "
               f"| {refinement.iterations}{'' if refinement.converged else ' (not converged)'} |")
            + f" {seconds:.0f} |")


def run(args) -> int:
    import dataclasses

    from airmat.atomic import atomic_write_text, check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.design import design_not_converged, refine_not_converged
    from airmat.cli.inflate import check_not_converged
    from airmat.cli.sigint import staged
    from airmat.json_doc import dumps
    from airmat.units import MM
    from airmat.check.inflation_check import check
    from airmat.check.refinement import refine
    from airmat.check.report import check_dict, write_check
    from airmat.design.calibration_source import load_calibration
    from airmat.design.design_io import report_dict, write_design
    from airmat.design.pipeline import design
    from airmat.design.presets import preset

    # every option is checked before the first preset runs: --out, --presets, --resolution-mm, --jobs,
    # --calibration (--seed, -v, -q by the parser)
    check_out_dir(args.out, inputs=[args.calibration])
    names = [n.strip() for n in args.presets.split(",") if n.strip()]
    unknown = sorted(set(names) - set(PRESETS))
    if unknown or not names:
        raise InputError(f"--presets: unknown preset(s) {', '.join(unknown) or '(none given)'}; "
                         f"choose from {', '.join(PRESETS)}")
    chosen = {name: preset(name) for name in names}
    check_resolution(args.resolution_mm, [mattress for _, mattress in chosen.values()])
    workers = jobs(args)
    calibration = load_calibration(args.calibration) if args.calibration else None
    out = Path(args.out)
    rows, results, timings, what = [], {}, {}, []
    head = header(args.refine)
    sep = "|" + "---|" * (head.count("|") - 1)
    print(head, sep, sep="\n", flush=True)      # the rows follow as each preset is done: one table on stdout
    with staged(out) as tmp:
        for name in names:
            target, mattress = chosen[name]
            t = time.perf_counter()
            result = design(target, mattress, calibration=calibration, seed=args.seed, progress=False)
            result = dataclasses.replace(result, source=str(out / name / "design"))
            t_design = time.perf_counter() - t
            refinement, t_refine = None, 0.0
            if args.refine:
                t = time.perf_counter()
                refinement = refine(result, resolution=args.resolution_mm * MM)
                result, t_refine = refinement.design, time.perf_counter() - t
            write_design(result, tmp / name / "design", workers=workers)
            t = time.perf_counter()
            checked = check(result, resolution=args.resolution_mm * MM, workers=workers, scheduler=scheduler(args),
                            known=refinement.known_runs if refinement else None)
            write_check(checked, tmp / name / "inflate", workers=workers)
            seconds = {"design": t_design, **({"refine": t_refine} if args.refine else {}),
                       "inflate": time.perf_counter() - t}
            rows.append(table_row(result, checked, sum(seconds.values()), refinement))
            doc = check_dict(checked)
            results[name] = {"report": report_dict(result.approx.report), "deviation": doc["deviation"],
                             "envelope": doc["envelope"], "converged": doc["converged"],
                             **({"refine": refinement.block()} if refinement is not None else {})}
            timings[name] = {k: round(v, 3) for k, v in seconds.items()}
            what += [f"{name}: {w}" for w in design_not_converged(result)
                     + refine_not_converged(refinement)
                     + check_not_converged(checked)]
            print(rows[-1], flush=True)
        table = "\n".join([head, sep] + rows)
        atomic_write_text(tmp / "gallery.md", table + "\n")
        results["timings_s"] = timings  # the one field that differs between runs of the same inputs
        atomic_write_text(tmp / "gallery.json", dumps(results, indent=2) + "\n")
    print(f"\nwrote {out / 'gallery.md'} and {out / 'gallery.json'}, and each preset's design and inflate "
          f"folders under {out} ({', '.join(names)})")
    return not_converged("gallery", what)
