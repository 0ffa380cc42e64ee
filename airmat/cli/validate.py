"""`airmat validate [--out DIR] [--calibration DIR]`: the simulated cylindrical-specimen experiment against Equation 3.

With ``--calibration`` the specimen is simulated at the calibration's L, each real string
length through the calibrated length map (``airmat.check.length_map``), and compared with the
calibrated κ₁ median (Equation 3 with the posterior median's Δ and d).
"""

from __future__ import annotations

from airmat.cli._jobs import add_jobs_argument, jobs, scheduler
from airmat.cli._vocabulary import add_out_argument
from airmat.errors import InputError


def add_parser(sub, parents):
    p = sub.add_parser("validate", parents=parents,
                       help="simulate the paper's specimen experiment and compare with Equation 3 (Δ = 0)",
                       description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--calibration", metavar="DIR", default=None,
                   help="output folder of 'airmat calibrate': simulate through its calibrated length map and compare "
                        "with its κ₁ median")
    p.add_argument("--thickness-mm", type=float, default=None,
                   help="mattress thickness d of the specimen (mm, default 70, or the calibration's median d)")
    p.add_argument("--L-mm", dest="L_mm", type=float, default=None,
                   help="string span L of the specimen (mm, default 300, the paper's; with --calibration: the "
                        "calibration's)")
    add_out_argument(p, "validate", "validate.json, validate.csv, validate.png")
    p.add_argument("--l-over-L", dest="l_over_L", default="0.3,0.4,0.5,0.6,0.7,0.8,0.9", metavar="R1,R2,...",
                   help="string length ratios l/L (dimensionless; default 0.3,...,0.9)")
    p.add_argument("--resolution-mm", type=float, default=40.0, help="mesh edge length (mm, default 40)")
    add_jobs_argument(p)
    p.set_defaults(func=run)


_COLUMNS = ("l_over_L", "l_sim_over_L", "kappa_polygon_per_m", "kappa_eq3_per_m", "kappa_section_string_face_per_m",
            "kappa_section_string_face_se_per_m", "kappa_section_free_face_per_m", "kappa_section_free_face_se_per_m",
            "kappa_eq3_free_face_per_m", "fold_side_mm", "model_side_mm", "fold_angle_deg", "model_angle_deg",
            "turn_deg", "closes")


def _write(points, folder, resolution_mm, *, layout, delta=0.0, d=None, lengths=None):
    import numpy as np

    from airmat.atomic import atomic_write_text
    from airmat.json_doc import dumps
    from airmat.figures import save_png
    from airmat.check.validation import validation_figure

    rows = [{"l_over_L": p.l_over_L, "l_sim_over_L": round(p.l_sim_over_L, 5),
             "kappa_polygon_per_m": round(p.kappa_strings, 4),
             "kappa_eq3_per_m": round(p.kappa_eq3, 4),
             "kappa_section_string_face_per_m": round(p.kappa_sim, 4), "kappa_section_string_face_se_per_m":
             round(p.kappa_sim_se, 4), "kappa_section_free_face_per_m": round(p.kappa_free, 4),
             "kappa_section_free_face_se_per_m": round(p.kappa_free_se, 4),
             "kappa_eq3_free_face_per_m": round(p.kappa_eq3_free, 4),
             "fold_side_mm": round(p.fold_side * 1e3, 2), "model_side_mm": round(p.model_side * 1e3, 2),
             "fold_angle_deg": round(float(np.degrees(p.fold_angle)), 2),
             "model_angle_deg": round(float(np.degrees(p.model_angle)), 2), "turn_deg": round(p.turn_deg, 1),
             "closes": p.closes,
             # the established key names (kappa_sim: the cross-section circles of the string face)
             "kappa_sim_per_m": round(p.kappa_sim, 4), "kappa_sim_se_per_m": round(p.kappa_sim_se, 4),
             "kappa_strings_per_m": round(p.kappa_strings, 4),
             "converged": p.converged, "iterations": p.n_iter} for p in points]
    d = layout.thickness if d is None else d
    doc = {"experiment": f"strip of {layout.n_series} chained parallel bottom strings per row, rows aligned "
                         f"({layout.width * 1e3:.0f} mm), L = {layout.L * 1e3:.0f} mm, "
                         f"d = {layout.thickness * 1e3:.0f} mm, "
                         "Delta = 0 (with a calibration: its L and thickness, each real l simulated at the calibrated "
                         "map's l_sim, against Equation 3 with the posterior median's Delta, d). kappa_polygon: the "
                         "paper's kappa_1 (Figure 4b), the circle through consecutive folds (under the strings' "
                         "middles: the polygon's vertices) on the string (bottom) face; Equation 3 gives it as "
                         "2 cos(theta/2) / L*. Circles fitted to the "
                         "cross-sections of the string face and of the free (top) face over the middle 2L; the "
                         "model's free face bends by (pi - theta) / L. fold_side / fold_angle: the simulated "
                         "polygon's mean side (fold to fold) and interior angle at the inner folds, next to "
                         "Equation 3's L* = L - (pi - theta) d and theta (model_side, model_angle). closes: the "
                         "strip turns >= 330 deg (no self-contact in the simulation)",
           "resolution_mm": resolution_mm, "L_mm": layout.L * 1e3, "thickness_mm": layout.thickness * 1e3,
           "equation3": {"delta_mm": delta * 1e3, "d_mm": d * 1e3}, "points": rows,
           "converged": all(p.converged for p in points),
           # the one field that differs between two runs of the same inputs: wall-clock seconds per ratio
           "timings_s": {f"{p.l_over_L:g}": round(p.seconds, 2) for p in points}}
    if lengths is not None:
        doc["length_map"] = {"l_real_mm": (lengths.l_real * 1e3).round(3).tolist(),
                             "l_sim_mm": (lengths.l_sim * 1e3).round(3).tolist()}
    atomic_write_text(folder / "validate.json", dumps(doc, indent=2) + "\n")
    atomic_write_text(folder / "validate.csv", ",".join(_COLUMNS) + "\n" +
                      "".join(",".join(str(r[c]) for c in _COLUMNS) + "\n" for r in rows))
    save_png(validation_figure(points, layout=layout, delta=delta, d=d, calibrated=lengths is not None),
             folder / "validate.png", dpi=110)
    return rows


def run(args) -> int:
    from airmat.atomic import check_out_dir
    from airmat.listing import listed
    from airmat.cli._exit import not_converged
    from airmat.cli.sigint import staged
    from airmat.units import MM
    from airmat.check.validation import SpecimenLayout, validate_equation3

    check_out_dir(args.out)
    try:
        ratios = [float(x) for x in args.l_over_L.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"--l-over-L {args.l_over_L!r}: expected comma-separated numbers") from None
    if not ratios or any(not (0 < r < 1) for r in ratios):
        raise InputError(f"--l-over-L {args.l_over_L!r}: ratios must lie in (0, 1)")
    if args.L_mm is not None:
        if args.calibration is not None:
            raise InputError("--L-mm: the calibration fixes L (its manifest's L_mm); give one or the other")
        if not (50 <= args.L_mm <= 2000):
            raise InputError(f"--L-mm {args.L_mm:g}: must be in [50, 2000]")
    L_mm = 300.0 if args.L_mm is None else args.L_mm
    if not (0 < args.resolution_mm <= 75) or (args.calibration is None and args.resolution_mm > L_mm / 4):
        raise InputError(f"--resolution-mm {args.resolution_mm:g}: must be in (0, {min(75.0, L_mm / 4):g}] "
                         f"(L/4 for L = {L_mm:g} mm, at most 75)")
    workers = jobs(args)
    if args.thickness_mm is not None and not (0 < args.thickness_mm <= 1000):
        raise InputError(f"--thickness-mm {args.thickness_mm:g}: must be in (0, 1000]")
    if args.calibration is None:
        layout = SpecimenLayout(**({} if args.L_mm is None else {"L": args.L_mm * MM}),
                                **({} if args.thickness_mm is None else {"thickness": args.thickness_mm * MM}))
        lengths, delta, d = None, 0.0, None
    else:
        import numpy as np

        from airmat.check.length_map import length_map
        from airmat.design.calibration_source import load_calibration

        source = load_calibration(args.calibration)
        d = float(np.median(source.d))
        layout = SpecimenLayout(L=source.L, thickness=d if args.thickness_mm is None else args.thickness_mm * MM)
        if args.resolution_mm > layout.L / 4 / MM:
            raise InputError(f"--resolution-mm {args.resolution_mm:g}: must be <= L/4 = {layout.L / 4 / MM:g} mm")
        lengths = length_map(source, calibrated=True, resolution=args.resolution_mm * MM,
                             thickness=layout.thickness, workers=workers)
        delta = source.delta_median
    points = validate_equation3(ratios, layout=layout, resolution=args.resolution_mm * MM, seed=args.seed,
                                workers=workers, scheduler=scheduler(args), length_map=lengths,
                                delta=delta, d=d)
    with staged(args.out) as tmp:
        rows = _write(points, tmp, args.resolution_mm, layout=layout, delta=delta, d=d, lengths=lengths)
    if lengths is not None:
        _print_calibrated(rows, delta, layout.thickness if d is None else d)
    else:
        _print_plain(rows)
    print(f"wrote {listed(args.out, ('validate.json',))} to {args.out}")
    return not_converged("validate", [f"inflation at l/L = {p.l_over_L:g}: {p.message}"
                                      for p in points if not p.converged])


def _print_plain(rows):
    print("       string face (1/m)                       free face (1/m)              "
          "polygon: side (mm)   angle (°)")
    print("l/L    κ₁ polygon  Eq. 3 (Δ=0)  section circles section circles  model (π-θ)/L  "
          "  sim.  L*        sim.  θ        turn")
    for r in rows:
        print(f"{r['l_over_L']:.2f} {r['kappa_polygon_per_m']:9.2f} {r['kappa_eq3_per_m']:10.2f}"
              f"  {r['kappa_section_string_face_per_m']:6.2f} ± {2 * r['kappa_section_string_face_se_per_m']:.2f}"
              f"   {r['kappa_section_free_face_per_m']:6.2f} ± {2 * r['kappa_section_free_face_se_per_m']:.2f}"
              f"  {r['kappa_eq3_free_face_per_m']:8.2f}     {r['fold_side_mm']:5.0f} {r['model_side_mm']:6.0f}"
              f"     {r['fold_angle_deg']:5.1f} {r['model_angle_deg']:6.1f}    {r['turn_deg']:5.0f}°"
              + ("  closes (no self-contact)" if r["closes"] else ""))


def _print_calibrated(rows, delta, d):
    print(f"calibrated κ₁ median: Equation 3 with Δ = {delta * 1e3:.1f} mm, d = {d * 1e3:.1f} mm; "
          "simulated through the calibrated length map")
    print("l/L   simulated l*/L   κ₁ simulated, sections (1/m)   κ₁ calibrated (1/m)   difference   turn")
    for r in rows:
        k, k3 = r["kappa_section_string_face_per_m"], r["kappa_eq3_per_m"]
        diff = f"{100 * (k / k3 - 1):+6.1f} %" if k3 > 0 else f"{k - k3:+.2f} 1/m"
        print(f"{r['l_over_L']:.2f}  {r['l_sim_over_L']:10.3f}   {k:24.2f}   {k3:18.2f}   {diff:>12}  "
              f"{r['turn_deg']:5.0f}°" + ("  closes (no self-contact)" if r["closes"] else ""))
