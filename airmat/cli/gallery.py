"""`airmat gallery [--out DIR]`: design and inflate every preset; a Table-1-style table."""

from __future__ import annotations

import json
from pathlib import Path

# design.presets.PRESETS (a test keeps them equal), without importing the designer at start-up
PRESETS = ("vault1", "saddle", "dome", "vault2", "roof")
HEADER = ("| size | model | σ (min // avg // max) | abs κ₁ (avg // max) [1/m] | abs κ₂ (avg // max) [1/m] "
          "| strings | constructible | deviation RMS // max [mm] | RMS % diag | lo95 // hi95 RMS [mm] "
          "| design + inflate [s] |")


def add_parser(sub, parents):
    p = sub.add_parser("gallery", parents=parents,
                       help="design and inflate all five presets; write a Table-1-style table",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--out", default="out/gallery", metavar="DIR", help="output folder (default out/gallery)")
    p.add_argument("--presets", default=",".join(PRESETS), help="comma-separated presets (default: all five)")
    p.add_argument("--resolution-mm", default="20",
                   help="mesh edge length of the inflation check (default 20, as 'airmat inflate')")
    p.add_argument("--calibration", metavar="DIR", default=None,
                   help="calibration folder (default: the paper's values, UNCALIBRATED)")
    p.set_defaults(func=run)


def table_row(name: str, design: dict, inflate: dict, seconds: float) -> str:
    """One Markdown row from a design.json and an inflate.json."""
    rep, dev, env = design["report"], inflate["deviation"], inflate["envelope"]
    s, k1, k2 = rep["sigma"], rep["kappa1_per_m"], rep["kappa2_per_m"]
    size = "small" if design["mattress"]["width_mm"] < 1500 else "large"
    return (f"| {size} | {name} | {s['min']:.4f} // {s['avg']:.4f} // {s['max']:.4f} "
            f"| {k1['avg']:.2f} // {k1['max']:.2f} | {k2['avg']:.2f} // {k2['max']:.2f} "
            f"| {len(design['dashes'])} | {'yes' if rep['constructible'] else 'no'} "
            f"| {dev['rms_mm']:.1f} // {dev['max_mm']:.1f} | {dev['rms_pct_diag']:.2f} "
            f"| {env['lo95']['rms_mm']:.1f} // {env['hi95']['rms_mm']:.1f} | {seconds:.0f} |")


def run(args) -> int:
    from airmat.atomic import atomic_write_text, check_out_dir
    from airmat.cli.demo import run_steps
    from airmat.errors import InputError

    check_out_dir(args.out, inputs=[args.calibration])
    names = [n.strip() for n in args.presets.split(",") if n.strip()]
    unknown = sorted(set(names) - set(PRESETS))
    if unknown:
        raise InputError(f"--presets: unknown preset(s) {', '.join(unknown)}; choose from {', '.join(PRESETS)}")
    out = Path(args.out)
    rows, results = [], {}
    for name in names:
        cal = ["--calibration", args.calibration] if args.calibration else []
        seconds = run_steps([
            ("design", ["design", "--preset", name, "--out", str(out / name / "design")] + cal),
            ("inflate", ["inflate", str(out / name / "design"), "--out", str(out / name / "inflate"),
                         "--resolution-mm", str(args.resolution_mm)]),
        ], args.seed)
        design = json.loads((out / name / "design" / "design.json").read_text())
        inflate = json.loads((out / name / "inflate" / "inflate.json").read_text())
        rows.append(table_row(name, design, inflate, sum(seconds.values())))
        results[name] = {"report": design["report"], "deviation": inflate["deviation"],
                         "envelope": inflate["envelope"], "seconds": seconds}
        print(rows[-1], flush=True)
    sep = "|" + "---|" * (HEADER.count("|") - 1)
    table = "\n".join([HEADER, sep] + rows)
    atomic_write_text(out / "gallery.md", table + "\n")
    atomic_write_text(out / "gallery.json", json.dumps(results, indent=2) + "\n")
    print(f"\n{table}\n\nwrote {out / 'gallery.md'} and {out / 'gallery.json'}")
    return 0
