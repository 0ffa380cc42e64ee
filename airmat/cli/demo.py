"""`airmat demo [--out DIR]`: synth -> calibrate -> design -> refine -> check -> as built on embedded defaults."""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

from airmat.cli._jobs import add_jobs_argument, jobs, scheduler
from airmat.cli._ranges import check_range, check_resolution
from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError

log = logging.getLogger(__name__)


def add_parser(sub, parents):
    p = sub.add_parser("demo", parents=parents,
                       help="run the whole pipeline on synthetic data and summarise it",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    add_out_argument(p, "demo", "report.html, synth/, calibration/, design/, inflate/ (the check), built/ and "
                                "correct/ (the as-built loop)")
    p.add_argument("--preset", default="vault1", metavar="NAME",
                   help="target preset to design and check ('airmat presets' lists them; default vault1)")
    p.add_argument("--points", type=int, default=100_000,
                   help="points per synthetic scan (a count, default 100000)")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="mesh edge length of the refinement and the inflation check (mm, default 20, as "
                        "'airmat check')")
    p.add_argument("--no-refine", dest="refine", action="store_false",
                   help="check the open-loop string lengths, without refining them through the inflation")
    p.add_argument("--correct", action="store_true",
                   help="then build the design in a synthetic world beyond its calibration (Δ and d 2 mm past "
                        "their 95 %% intervals, ties within ±3 mm), scan it and correct it ('airmat synth-built', "
                        "'airmat correct'); about 30 s more")
    add_jobs_argument(p)
    p.set_defaults(func=run)


def _iv(p, unit: str, scale: float = 1.0, digits: int = 1) -> str:
    return (f"{p.median * scale:.{digits}f} {unit} [{p.lo95 * scale:.{digits}f}, "
            f"{p.hi95 * scale:.{digits}f}]")


def _asbuilt_line(res, world) -> str:
    u, c = res.update, res.correction
    after = c.rms_linear if c.rms_verified is None else c.rms_verified
    sd = 0.5 * (u.interval95[1] - u.interval95[0]) * 1e3          # the 95 % half-widths (mm)
    return (f"  as built     a world with Delta = {world.delta * 1e3:.1f} mm, d = {world.d * 1e3:.1f} mm, ties within "
            f"+-{world.cut_tolerance * 1e3:g} mm: the scan lies {res.to_target.rms * 1e3:.1f} mm RMS from Ŝ; "
            f"learned Delta = {u.mean[0] * 1e3:.1f} +- {sd[0]:.1f} mm, d = {u.mean[1] * 1e3:.1f} +- {sd[1]:.1f} mm; "
            f"re-cut {int((~c.kept).sum())} of {len(c.kept)} strings: predicted {after * 1e3:.1f} mm RMS "
            f"({100 * after / c.diagonal:.2f}% of the diagonal)")


def summary(out: Path, cal, truth: dict, design, check, seconds: dict, refinement=None, asbuilt=None) -> str:
    """A short human summary of a demo, from the objects the run holds (SI inside, mm printed)."""
    post, rep = cal.posterior, design.approx.report
    count = {}
    for s in design.pattern.strings:
        key = f"{s.side} {s.dash.family}"
        count[key] = count.get(key, 0) + 1
    runs = check.runs
    dev = runs["median"].deviation
    env = "; envelope " + ", ".join(f"{k} RMS {runs[k].deviation.rms * 1e3:.1f} mm"
                                    for k in ("lo95", "hi95") if k in runs)
    m = design.mattress
    lines = [
        "airmat demo: synthetic scans -> calibration -> design -> "
        + ("" if refinement is None else "refinement -> ") + "inflation check",
        f"  calibration  Delta = {_iv(post.delta, 'mm', 1e3)} (truth {truth['delta_mm']:g} mm), "
        f"d = {_iv(post.d, 'mm', 1e3)} (truth {truth['d_mm']:g} mm), "
        f"sigma = {_iv(post.sigma, '1/m', digits=2)}; "
        f"{'converged' if post.converged else 'NOT CONVERGED'} ({post.n_steps} steps)",
        f"  design       {design.name} on {m.width * 1e3:.0f} x {m.height * 1e3:.0f} mm: "
        f"sigma {rep.sigma['min']:.4f}/{rep.sigma['avg']:.4f}/{rep.sigma['max']:.4f} (min/avg/max), "
        f"|k1| {rep.kappa1['avg']:.2f}/{rep.kappa1['max']:.2f}, "
        f"|k2| {rep.kappa2['avg']:.2f}/{rep.kappa2['max']:.2f} 1/m (avg/max); "
        f"constructible: {'yes' if rep.constructible else 'no'}",
        f"               {len(design.pattern.strings)} strings: "
        + ", ".join(f"{v} {k}" for k, v in sorted(count.items())),
        *([] if refinement is None else [_refine_line(refinement)]),
        f"  inflation    deviation of the {check.surface} face from Ŝ: RMS {dev.rms * 1e3:.1f} mm "
        f"({dev.rms_pct_diag:.2f}% of the "
        f"diagonal), max {dev.max * 1e3:.1f} mm" + (env if len(runs) > 1 else ""),
        *([] if asbuilt is None else [_asbuilt_line(*asbuilt)]),
        "  time         " + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()),
        f"  files        {out}/report.html, {out}/synth, {out}/calibration, {out}/design, {out}/inflate"
        + ("" if asbuilt is None else f", {out}/built, {out}/correct"),
    ]
    return "\n".join(lines)


def _refine_line(r) -> str:
    b, a = r.deviation_before, r.deviation_after
    dropped = f", {len(r.dropped)} string{'' if len(r.dropped) == 1 else 's'} dropped" if r.dropped else ""
    return (f"  refinement   RMS {b.rms * 1e3:.1f} -> {a.rms * 1e3:.1f} mm ({b.rms_pct_diag:.2f} -> "
            f"{a.rms_pct_diag:.2f}% of the diagonal), {r.iterations} Gauss-Newton iterations, "
            + ("" if r.reparametrization is None else
               f"Ŝ's points moved {r.reparametrization.moved_rms * 1e3:.1f} mm RMS along it, ")
            + f"{'converged' if r.converged else 'NOT CONVERGED'}{dropped}")


def _published(cal, staged: Path, out: Path):
    """The calibration with its manifest and scan paths where the run publishes them (``out``)."""
    def move(p: str) -> str:
        return str(out / Path(p).relative_to(staged)) if Path(p).is_relative_to(staged) else p

    man = dataclasses.replace(cal.manifest, path=move(cal.manifest.path),
                              scan_paths=tuple(move(p) for p in cal.manifest.scan_paths))
    specimens = tuple(dataclasses.replace(s, path=move(s.path)) for s in cal.specimens)
    return dataclasses.replace(cal, manifest=man, specimens=specimens)


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.calibrate import calibration_not_converged
    from airmat.cli.design import design_not_converged, refine_not_converged
    from airmat.cli.inflate import check_not_converged
    from airmat.cli.sigint import staged
    from airmat.units import MM
    from airmat.calib.calibrate import calibrate
    from airmat.calib.calibration_io import write_calibration
    from airmat.calib.plots import plot_corner, plot_curve
    from airmat.check.inflation_check import check
    from airmat.check.refinement import refine
    from airmat.check.report import write_check
    from airmat.synthetic.calibration_set import calibration_set
    from airmat.design.calibration_source import from_calibration
    from airmat.design.design_io import write_design
    from airmat.design.pipeline import design
    from airmat.design.presets import preset
    from airmat.report.page import write_report

    # every option is checked before the first step runs: --out, --preset, --points, --resolution-mm,
    # --jobs (--seed, -v, -q by the parser)
    check_out_dir(args.out)
    try:
        target, mattress = preset(args.preset)
    except InputError as err:
        raise InputError(f"--preset: {err.message}") from None
    check_range("--points", args.points)
    check_resolution(args.resolution_mm, [mattress])
    workers = jobs(args)
    out = Path(args.out)
    seconds = {}
    with staged(out) as tmp:
        t = time.perf_counter()
        log.info("synth: %d points per scan", args.points)
        cs = calibration_set(tmp / "synth", n_points=args.points, seed=args.seed)
        seconds["synth"] = time.perf_counter() - t

        t = time.perf_counter()
        log.info("calibrate: %d scans", len(cs.scans))
        cal = _published(calibrate(cs.manifest, seed=args.seed), tmp, out)
        write_calibration(cal, tmp / "calibration", truth=cs.truth)
        plot_curve(cal, tmp / "calibration" / "curve.png", truth=cs.truth)
        plot_corner(cal.posterior, tmp / "calibration" / "corner.png", truths=cs.truth)
        seconds["calibrate"] = time.perf_counter() - t

        t = time.perf_counter()
        log.info("design: preset %s", args.preset)
        source = from_calibration(cal, source=str(out / "calibration"))
        result = design(target, mattress, calibration=source, seed=args.seed, progress=False)
        result = dataclasses.replace(result, source=str(out / "design"))
        seconds["design"] = time.perf_counter() - t

        refinement = None
        if args.refine:
            t = time.perf_counter()
            log.info("refine: %g mm", args.resolution_mm)
            refinement = refine(result, resolution=args.resolution_mm * MM)
            result = refinement.design
            seconds["refine"] = time.perf_counter() - t
        write_design(result, tmp / "design", workers=workers)

        t = time.perf_counter()
        log.info("inflate: %g mm", args.resolution_mm)
        checked = check(result, resolution=args.resolution_mm * MM, workers=workers, scheduler=scheduler(args),
                        known=refinement.known_runs if refinement else None)
        write_check(checked, tmp / "inflate", workers=workers)
        seconds["inflate"] = time.perf_counter() - t
        asbuilt = _as_built(args, tmp, out, result, checked, cal) if args.correct else None
        if asbuilt is not None:
            seconds["as built"] = asbuilt[2]
        text = summary(out, cal, cs.truth, result, checked, seconds, refinement,
                       None if asbuilt is None else asbuilt[:2])
        page_text = "\n".join(ln for ln in text.splitlines() if not ln.lstrip().startswith("time "))
        write_report(tmp, calibration=cal, design=result, check=checked, summary=page_text, truth=cs.truth,
                     title=f"airmat demo: {args.preset}")
    print(text)
    return not_converged("demo", calibration_not_converged(cal) + design_not_converged(result)
                         + refine_not_converged(refinement)
                         + check_not_converged(checked)
                         + ([] if asbuilt is None or asbuilt[0].update.converged
                            else [f"the as-built update: {asbuilt[0].update.message}"]))


#: the demo's true world lies this far beyond the calibration's 95 % interval of Δ and of d (m), its ties
#: within ±3 mm: a mattress that does not behave as calibrated, cut by hand
WORLD_BEYOND = 0.002
WORLD_TIES = 0.003


def _as_built(args, tmp: Path, out: Path, design, checked, cal):
    """Build the design in a world outside the calibration, scan it, correct it: (AsBuilt, World, seconds)."""
    from airmat.asbuilt.correct_io import write_correct
    from airmat.asbuilt.pipeline import correct
    from airmat.asbuilt.true_world import built_world, median_world, truth_dict
    from airmat.json_doc import dumps
    from airmat.atomic import atomic_write_text
    from airmat.synthetic.built_scan import scan_surface

    t = time.perf_counter()
    p = cal.posterior
    world = dataclasses.replace(median_world(design, cut_tolerance=WORLD_TIES), delta=p.delta.hi95 + WORLD_BEYOND,
                                d=p.d.hi95 + WORLD_BEYOND)
    log.info("as built: Δ %.1f mm, d %.1f mm, ties ±%g mm", world.delta * 1e3, world.d * 1e3, WORLD_TIES * 1e3)
    built = built_world(design, world, resolution=args.resolution_mm * 1e-3, seed=args.seed)
    scan = scan_surface(built.xyz, built.upper_triangles, n_points=200_000, noise=0.0005, coverage=0.85,
                        units="m", seed=[args.seed, 1], floor_z=float(built.xyz[:, 2].min()))
    (tmp / "built").mkdir()
    atomic_write_text(tmp / "built" / "truth.json", dumps(truth_dict(built, design), indent=2) + "\n")
    res = correct(design, scan.points, check=checked, resolution=args.resolution_mm * 1e-3,
                  base_calibration=cal, seed=args.seed)
    (tmp / "correct").mkdir()
    write_correct(tmp / "correct", res)
    return res, world, time.perf_counter() - t
