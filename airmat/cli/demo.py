"""`airmat demo [--out DIR]`: synth -> calibrate -> design -> inflate on embedded defaults."""

from __future__ import annotations

import contextlib
import io
import json
import logging
import time
from pathlib import Path

log = logging.getLogger(__name__)


def add_parser(sub, parents):
    p = sub.add_parser("demo", parents=parents,
                       help="run the whole pipeline on synthetic data and summarise it",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--out", default="out/demo", metavar="DIR",
                   help="output folder (default out/demo): synth/, calibration/, design/, inflate/")
    p.add_argument("--preset", default="vault1",
                   help="target preset to design and inflate (default vault1)")
    p.add_argument("--points", type=int, default=100_000, help="points per synthetic scan (default 100000)")
    p.add_argument("--resolution-mm", default="20",
                   help="mesh edge length of the inflation check (default 20, as 'airmat inflate')")
    p.set_defaults(func=run)


def run_steps(steps, seed: int, quiet_children: bool = True) -> dict:
    """Run ``[(name, argv), ...]`` through the airmat parser in order; return seconds per step.

    Each step's own summary goes to the log at debug level; a failing step
    raises its error unchanged (the dispatcher reports it in one line).
    """
    from airmat.cli import build_parser

    parser = build_parser()
    seconds = {}
    for name, argv in steps:
        args = parser.parse_args(argv + ["--seed", str(seed)])
        t0 = time.perf_counter()
        log.info("%s: airmat %s", name, " ".join(argv))
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf) if quiet_children else contextlib.nullcontext():
            args.func(args)
        log.debug("%s", buf.getvalue())
        seconds[name] = time.perf_counter() - t0
    return seconds


def _iv(p: dict, unit: str, digits: int = 1) -> str:
    return f"{p['median']:.{digits}f} {unit} [{p['lo95']:.{digits}f}, {p['hi95']:.{digits}f}]"


def summary(out: Path, seconds: dict) -> str:
    """A short human summary of a demo folder."""
    cal = json.loads((out / "calibration" / "calibration.json").read_text())
    truth = json.loads((out / "synth" / "truth.json").read_text())
    des = json.loads((out / "design" / "design.json").read_text())
    inf = json.loads((out / "inflate" / "inflate.json").read_text())
    par, diag, rep = cal["parameters"], cal["diagnostics"], des["report"]
    dashes = des["dashes"]
    count = {}
    for dash in dashes:
        key = f"{dash['side']} {dash['family']}"
        count[key] = count.get(key, 0) + 1
    dev, env = inf["deviation"], inf["envelope"]
    solver = inf["solver"]
    solver = solver.get("median", solver) if isinstance(solver, dict) else solver
    lines = [
        "airmat demo: synthetic scans -> calibration -> design -> inflation check",
        f"  calibration  Delta = {_iv(par['delta_mm'], 'mm')} (truth {truth['delta_mm']:g} mm), "
        f"d = {_iv(par['d_mm'], 'mm')} (truth {truth['d_mm']:g} mm), "
        f"sigma = {_iv(par['sigma_per_m'], '1/m', 2)}; "
        f"{'converged' if diag['converged'] else 'NOT CONVERGED'} ({diag['n_steps']} steps)",
        f"  design       {des['name']} "
        f"on {des['mattress']['width_mm']:.0f} x {des['mattress']['height_mm']:.0f} mm: "
        f"sigma {rep['sigma']['min']:.4f}/{rep['sigma']['avg']:.4f}/{rep['sigma']['max']:.4f} (min/avg/max), "
        f"|k1| {rep['kappa1_per_m']['avg']:.2f}/{rep['kappa1_per_m']['max']:.2f}, "
        f"|k2| {rep['kappa2_per_m']['avg']:.2f}/{rep['kappa2_per_m']['max']:.2f} 1/m (avg/max); "
        f"constructible: {'yes' if rep['constructible'] else 'no'}",
        f"               {len(dashes)} strings: " + ", ".join(f"{v} {k}" for k, v in sorted(count.items())),
        f"  inflation    deviation from S-hat: RMS {dev['rms_mm']:.1f} mm ({dev['rms_pct_diag']:.2f}% of the "
        f"diagonal), max {dev['max_mm']:.1f} mm; envelope lo95 RMS {env['lo95']['rms_mm']:.1f} mm, "
        f"hi95 RMS {env['hi95']['rms_mm']:.1f} mm",
        "  time         " + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()),
        f"  files        {out}/synth, {out}/calibration, {out}/design, {out}/inflate",
    ]
    return "\n".join(lines)


def run(args) -> int:
    from airmat.atomic import check_out_dir

    check_out_dir(args.out)
    out = Path(args.out)
    steps = [
        ("synth", ["synth", str(out / "synth"), "--points", str(args.points)]),
        ("calibrate", ["calibrate", str(out / "synth" / "manifest.csv"), "--out", str(out / "calibration"),
                       "--truth", str(out / "synth" / "truth.json")]),
        ("design", ["design", "--preset", args.preset, "--calibration", str(out / "calibration"),
                    "--out", str(out / "design")]),
        ("inflate", ["inflate", str(out / "design"), "--out", str(out / "inflate"),
                     "--resolution-mm", str(args.resolution_mm)]),
    ]
    seconds = run_steps(steps, args.seed)
    print(summary(out, seconds))
    return 0
