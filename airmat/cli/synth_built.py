"""`airmat synth-built DESIGN_DIR [--out DIR]`: a synthetic as-built scan of a design, with its known truth.

The design is built and inflated in a true world (Δ, d, cut errors:
:mod:`airmat.asbuilt.true_world`) and its upper face scanned as a scanner would
(:mod:`airmat.synthetic.built_scan`): noise, holes, a floor, clutter, a random
pose, mm or m. Writes scan.<format>, built.ply (the whole built mattress in Ŝ's
frame, mm, as ``airmat check``'s inflated.ply) and truth.json (mm and 1/m).
"""

from __future__ import annotations

from airmat.cli._ranges import check_range
from airmat.cli._vocabulary import add_out_argument, deprecated_alias
from airmat.errors import InputError

EPILOG = """\
The world defaults to the design's calibration medians with no cut errors: the built mattress is then
'airmat check''s median run. Set --delta-mm/--thickness-mm and --cut-error-mm for a world that differs.
Each string is cut with an error drawn from Uniform(-c, c), c = --cut-error-mm (--cut-distribution normal:
N(0, (c/1.96)^2)). truth.json's scan_to_design maps the scan's points back into the design's frame:
x_mm = rotation @ (mm_per_scan_unit * p) + translation_mm."""

#: formats whose files state their own unit, metres (airmat.synthetic.scan_write)
_METRE_FORMATS = ("e57", "las", "laz", "laz14")
#: the formats of airmat.synthetic.scan_write.FORMATS, named here so that the help loads no numerical library
#: (tests/cli/test_synth_built_cli.py holds the two equal)
SCAN_FORMATS = ("e57", "glb", "las", "laz", "laz14", "pcd_ascii", "pcd_binary", "pcd_compressed", "ply", "pts", "txt",
                "xyz")


def add_parser(sub, parents):
    import argparse

    p = sub.add_parser("synth-built", parents=parents,
                       help="build a design in a true world (Δ, d, cut errors) and scan it: a synthetic as-built scan "
                            "with known truth",
                       description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("design", metavar="DESIGN_DIR", help="output folder of 'airmat design'")
    add_out_argument(p, "synth-built", "scan.ply (or --scan-format), built.ply, truth.json")
    p.add_argument("--delta-mm", type=float, default=None,
                   help="true string-end slip Δ (mm, default the design calibration's median)")
    p.add_argument("--thickness-mm", type=float, default=None,
                   help="true thickness d of Equation 3 (mm, default the design calibration's median)")
    deprecated_alias(p, "--d-mm", "--thickness-mm")
    p.add_argument("--cut-error-mm", type=float, default=0.0, metavar="C",
                   help="every string cut and tied within +-C mm (default 0: as designed)")
    p.add_argument("--cut-distribution", choices=("uniform", "normal"), default="uniform",
                   help="the cut errors: uniform in [-C, C] (default) or normal with +-C its 95%% interval")
    p.add_argument("--resolution-mm", type=float, default=20.0,
                   help="edge length of the double-layer mesh (mm, default 20, as 'airmat check')")
    p.add_argument("--pressure-pa", type=float, default=None, help="inflation pressure (Pa, default 2000)")
    p.add_argument("--points", type=int, default=200_000, help="points in the scan (a count, default 200000)")
    p.add_argument("--noise-mm", type=float, default=0.5,
                   help="standard deviation of the scanner's Gaussian noise (mm, default 0.5)")
    p.add_argument("--coverage", type=float, default=0.85,
                   help="share of the upper face's area scanned, in (0, 1] (dimensionless, default 0.85)")
    p.add_argument("--scan-units", choices=("mm", "m"), default=None,
                   help="unit of the scan's coordinates (default mm; E57 and LAS/LAZ are in metres)")
    p.add_argument("--scan-format", choices=SCAN_FORMATS, default="ply",
                   help="file format of the scan (default ply)")
    p.set_defaults(func=run)


def _check_options(args) -> str:
    """The options' ranges (exit 2 before any work); returns the scan's unit."""
    import math

    if args.delta_mm is not None and not (math.isfinite(args.delta_mm) and 0 <= args.delta_mm < 150):
        raise InputError(f"--delta-mm: {args.delta_mm:g} mm is outside [0, 150) mm")
    check_range("--thickness-mm", args.thickness_mm)
    if not (math.isfinite(args.cut_error_mm) and 0 <= args.cut_error_mm <= 50):
        raise InputError(f"--cut-error-mm: {args.cut_error_mm:g} mm is outside [0, 50] mm (a tolerance +-C)")
    check_range("--resolution-mm", args.resolution_mm)
    check_range("--pressure-pa", args.pressure_pa)
    check_range("--points", args.points)
    if not (math.isfinite(args.noise_mm) and 0 <= args.noise_mm <= 50):
        raise InputError(f"--noise-mm: {args.noise_mm:g} mm is outside [0, 50] mm")
    if not (0 < args.coverage <= 1):
        raise InputError(f"--coverage: {args.coverage:g} is outside (0, 1] (a share of the face's area)")
    if args.scan_format in _METRE_FORMATS:
        if args.scan_units == "mm":
            raise InputError(f"--scan-units mm: a {args.scan_format} file is in metres")
        return "m"
    return args.scan_units or "mm"


def run(args) -> int:
    from dataclasses import replace
    from pathlib import Path

    from airmat.asbuilt.true_world import built_world, median_world
    from airmat.atomic import check_out_dir
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import check, staged
    from airmat.design.design_io import read_design
    from airmat.inflation.model import Parameters
    from airmat.listing import listed
    from airmat.synthetic.built_scan import scan_surface
    from airmat.units import MM

    units = _check_options(args)
    check_out_dir(args.out, inputs=[args.design])
    design = read_design(args.design)
    params = Parameters() if args.pressure_pa is None else replace(Parameters(), pressure=args.pressure_pa)
    world = median_world(design, cut_tolerance=args.cut_error_mm * MM, distribution=args.cut_distribution)
    world = replace(world, **{k: v * MM for k, v in (("delta", args.delta_mm), ("d", args.thickness_mm))
                              if v is not None})
    check()  # a Ctrl-C that a library's import swallowed
    built = built_world(design, world, resolution=args.resolution_mm * MM, params=params, seed=args.seed)
    floor_z = float(built.xyz[:, 2].min())     # the mattress rests on the floor at its lowest point
    scan = scan_surface(built.xyz, built.upper_triangles, n_points=args.points, noise=args.noise_mm * MM,
                        coverage=args.coverage, units=units, seed=[args.seed, 1], floor_z=floor_z)
    name = f"scan{_suffix(args.scan_format)}"
    with staged(args.out) as tmp:
        doc = _write(Path(tmp), name, args, design, built, scan)
    dev, w = built.deviation, built.world
    print(f"built {design.name} in Δ = {w.delta / MM:.1f} mm, d = {w.d / MM:.1f} mm, cut errors within "
          f"+-{w.cut_tolerance / MM:g} mm ({args.cut_distribution}): the {dev.surface} face lands "
          f"{dev.rms / MM:.1f} mm RMS from Ŝ ({dev.rms_pct_diag:.2f} % of the diagonal)\n"
          f"scan: {len(scan.points)} points in {units}, {100 * scan.coverage:.0f} % of the {built.upper_face} face, "
          f"noise {args.noise_mm:g} mm, a floor and clutter, a random pose (truth.json: scan_to_design)\n"
          f"  wrote {listed(args.out, (name, 'built.ply', 'truth.json'))} to {args.out}")
    return not_converged("synth-built", [] if doc["inflation"]["converged"]
                         else [f"the as-built inflation: {built.inflation.message}"])


def _suffix(fmt: str) -> str:
    from airmat.synthetic.scan_write import FORMATS

    return FORMATS[fmt]


def _write(folder, name, args, design, built, scan) -> dict:
    """scan.*, built.ply and truth.json into ``folder``; returns truth.json's document."""
    import json

    import numpy as np
    import trimesh

    from airmat.asbuilt.true_world import truth_dict
    from airmat.atomic import atomic_write_bytes, atomic_write_text
    from airmat.synthetic.built_scan import CLUTTER, FLOOR, SURFACE, UNITS
    from airmat.synthetic.scan_write import write_scan
    from airmat.units import M_TO_MM

    mm_per_unit = UNITS[scan.units] * M_TO_MM
    # write_scan takes mm and writes E57/LAS in metres; the other formats hold the numbers given
    values = scan.points * mm_per_unit if args.scan_format in _METRE_FORMATS else scan.points
    write_scan(folder / name, values, args.scan_format, seed=args.seed)
    mesh = trimesh.Trimesh(built.xyz * M_TO_MM, built.inflation.mesh.faces, process=False)
    atomic_write_bytes(folder / "built.ply", trimesh.exchange.ply.export_ply(mesh, encoding="binary"))
    back, t_back = scan.inverse()
    counts = np.bincount(scan.labels, minlength=3)
    doc = {"kind": "synthetic as-built scan", "design": str(args.design), "seed": args.seed,
           **truth_dict(built, design),
           "built": {"file": "built.ply", "frame": "the design's (approx_surface's), mm; the whole closed mattress"},
           "scan": {"file": name, "format": args.scan_format, "units": scan.units, "points": int(len(scan.points)),
                    "surface_points": int(counts[SURFACE]), "floor_points": int(counts[FLOOR]),
                    "clutter_points": int(counts[CLUTTER]), "face": built.upper_face,
                    "noise_mm": scan.noise * M_TO_MM, "coverage": float(args.coverage),
                    "coverage_achieved": scan.coverage,
                    "holes": [{"center_mm": (c * M_TO_MM).tolist(), "radius_mm": r * M_TO_MM}
                              for c, r in zip(scan.hole_centers, scan.hole_radii.tolist())],
                    "floor_z_mm": None if scan.floor_z is None else scan.floor_z * M_TO_MM},
           "scan_to_design": {"rotation": back.tolist(), "translation_mm": (t_back * mm_per_unit).tolist(),
                              "scan_units": scan.units, "mm_per_scan_unit": mm_per_unit,
                              "equation": "x_mm = rotation @ (mm_per_scan_unit * p) + translation_mm"}}
    atomic_write_text(folder / "truth.json", json.dumps(doc, indent=1, allow_nan=False) + "\n")
    return doc
