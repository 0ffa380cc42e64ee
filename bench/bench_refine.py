"""Benchmark: string lengths refined through the inflation (airmat.check.refinement) vs one inflation, side by side.

Usage::

    .venv/bin/python bench/bench_refine.py                  # vault1 at 20 mm (about 20 s)
    .venv/bin/python bench/bench_refine.py --presets all --resolution-mm 20 --from-flat
    .venv/bin/python bench/bench_refine.py --presets vault1 --coarsest-mm 40 0   # two-level vs all at 20 mm
    .venv/bin/python bench/bench_refine.py --presets saddle --corrections 0 1    # with a defect correction
    .venv/bin/python bench/bench_refine.py --presets vault1 saddle dome --alpha 1e-2 1e-3   # the regularization
    .venv/bin/python bench/bench_refine.py --presets all --reparametrize 0 1   # Ŝ as designed vs re-parametrized
    .venv/bin/python bench/bench_refine.py --presets saddle vault1 --reparametrize 0 1 --draws 8   # path spread
    .venv/bin/python bench/bench_refine.py --presets roof --jacobian-solve per-column all-at-once
    .venv/bin/python bench/bench_refine.py --presets vault1 saddle dome --draws 4 --damping-hold 0 1
    .venv/bin/python bench/bench_refine.py --presets vault1 saddle dome --draws 4 --trial-newton 12 15 20
    .venv/bin/python bench/bench_refine.py --quick          # a smoke run: vault1 at 40 mm, one iteration

Each row: the deviation of the named face from Ŝ at the open-loop lengths
and at the refined ones (what ``airmat inflate`` reports: the open-loop
design inflated from the flat mattress, the refined one carried on from
that equilibrium to its lengths), Gauss–Newton iterations, the refinement's
wall time (everything: the open-loop inflation, the iterations and the
verification), one inflation of the open-loop design at the same resolution
and the verification of the refined one, measured in the same run (the
ratio refine / one inflation has the target <= 5x), strings
dropped / flagged. ``--from-flat`` adds a last column: the refined lengths
inflated from the flat mattress instead (another inflation, not counted in
the refinement's time), to show how much the refined deviation depends on
the path. ``--coarsest-mm 0`` runs every Gauss–Newton iteration at
the resolution itself (no coarse level); ``--corrections N`` allows N defect
corrections of the coarse level (``refine(..., corrections=N)``); ``--alpha A ...``
one row per weight of the pull toward the open-loop lengths (``refine(..., alpha=A)``);
``--reparametrize N ...`` one row per number of rounds of Ŝ re-parametrized in the
realized metric (``refine(..., reparametrize=N)``; 0: Ŝ as designed). "to Ŝ's
surface": the refined face's RMS distance from the nearest points of the designed
Ŝ (its shape, whatever the parametrization); "Ŝ moved": how far the rounds moved
Ŝ's points along it (RMS).

``--jacobian-solve per-column all-at-once``: one row each with the Jacobian's right-hand
sides solved by cvxopt one column at a time (without ``airmat.inflation.cholmod_block``) and in
one CHOLMOD call (the default), in a last column.

``--damping-hold 0 1``: one row (or spread row) each with the Gauss–Newton damping shrunk
after every well-predicted step (0) and held after an iteration that had to
grow it (1, the default; ``airmat.check.gauss_newton.HOLD_AFTER_RETRY``), in a last column.

``--trial-rule shift:4 backtrack:2``: one row (or spread row) each with the Newton method of the
refinement's equilibria refactorizing a refused step with its shift ×4 (the check's rule) or halving
it with the shift ×2 (``airmat.check.trial_equilibrium.TRIAL_REFUSED_STEP``), in a last column.

``--trial-newton 12 15 20``: one row (or spread row) each with the Newton iterations a trial
equilibrium may take before its step counts as failed (``airmat.check.trial_equilibrium.TRIAL_NEWTON``,
20), in a last column.

``--draws K`` measures how much the outcome depends on the Gauss–Newton path: K
refinements of the same design, the first at its own lengths and the others with every
open-loop real length moved by a uniform draw in ±``--jitter-um`` (5 µm by default, the
0.01 mm rounding of design.json; seeds 1 … K−1), and one row per preset and setting with
the spread of the refined deviation, and each draw's time over the open-loop inflation it
starts with (the same design at the same resolution, in the same process).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from pathlib import Path
from unittest import mock

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.check.refinement import refine  # noqa: E402
from airmat.design.closest_point import MeshProjector  # noqa: E402
from airmat.design.presets import PRESETS  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=["vault1"], help=f"names, or all ({', '.join(PRESETS)})")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--max-iter", type=int, default=20)
    ap.add_argument("--coarsest-mm", type=float, nargs="+", default=[40.0],
                    help="coarsest mesh of the two-level scheme; 0: every iteration at the resolution")
    ap.add_argument("--corrections", type=int, nargs="+", default=[0],
                    help="defect corrections of the coarse level (one row each)")
    ap.add_argument("--alpha", type=float, nargs="+", default=[None],
                    help="weights of the pull toward the open-loop lengths (one row each; default: refine's)")
    ap.add_argument("--reparametrize", type=int, nargs="+", default=[None],
                    help="rounds of Ŝ re-parametrized in the realized metric (one row each; default: refine's)")
    ap.add_argument("--draws", type=int, default=1,
                    help="refinements per setting, all but the first with the lengths jittered (a spread table)")
    ap.add_argument("--jitter-um", type=float, default=5.0, help="half-width of the length jitter (µm)")
    ap.add_argument("--jacobian-solve", nargs="+", choices=list(_JACOBIAN_SOLVES), default=None,
                    help="the Jacobian's right-hand sides in one CHOLMOD call (all-at-once, the default) or "
                         "cvxopt's column by column (per-column); one row each, in a last column")
    ap.add_argument("--damping-hold", type=int, nargs="+", choices=(0, 1), default=None,
                    help="1: the damping is held after an iteration that had to grow it (the default); "
                         "0: shrunk after every well-predicted step (the rule before); one row each, in a last column")
    ap.add_argument("--trial-rule", nargs="+", type=trial_rule, default=None,
                    help="RULE:MU_UP of the refinement's equilibria (shift:4, the check's rule; backtrack:2); "
                         "one row each, in a last column")
    ap.add_argument("--trial-newton", type=int, nargs="+", default=None,
                    help="Newton iterations a trial equilibrium may take (airmat.check.trial_equilibrium.TRIAL_NEWTON, "
                         "20); one row each, in a last column")
    ap.add_argument("--from-flat", action="store_true",
                    help="a last column: the refined lengths inflated from the flat mattress (not counted in the "
                         "time), against the check's path from the open-loop equilibrium")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: vault1 at 40 mm, one Gauss–Newton iteration, one draw")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets, args.resolution_mm, args.max_iter, args.draws = ["vault1"], 40.0, 1, 1
    if args.trial_newton and min(args.trial_newton) < 1:
        ap.error(f"--trial-newton: a trial needs at least 1 Newton iteration, got {args.trial_newton}")
    names = list(PRESETS) if args.presets == ["all"] else args.presets
    if args.draws > 1:
        return spread(names, args)
    print("| preset | mattress (mm) | GN mesh (mm) | corrections | alpha | re-param rounds | open loop RMS mm (% diag) "
          "| refined RMS mm (% diag) | refined, to Ŝ's surface mm (% diag) | max mm before / after | iterations "
          "| converged | refine (s) | one inflation (s) | verification (s) | ratio | dropped / flagged "
          "| Ŝ moved (mm RMS) |" + (" Jacobian solve |" if args.jacobian_solve else "")
          + (" damping held |" if args.damping_hold else "") + (" trial refused step |" if args.trial_rule else "")
          + (" trial Newton |" if args.trial_newton else "")
          + (" refined, from flat: RMS mm (% diag) |" if args.from_flat else ""))
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
          + ("---|" if args.jacobian_solve else "") + ("---|" if args.damping_hold else "")
          + ("---|" if args.trial_rule else "") + ("---|" if args.trial_newton else "")
          + ("---|" if args.from_flat else ""))
    for name in names:
        design = designed_preset(name)
        m = design.mattress
        surface = MeshProjector(design.approx.xyz, design.approx.faces)
        diag = float(np.linalg.norm(np.ptp(design.approx.xyz, axis=0)))
        runs = [(c, n, a, k, j, h, t, tn) for c in args.coarsest_mm for n in args.corrections for a in args.alpha
                for k in args.reparametrize for j in (args.jacobian_solve or ["all-at-once"])
                for h in (args.damping_hold or [None]) for t in (args.trial_rule or [None])
                for tn in (args.trial_newton or [None]) if c > 0 or n == 0]
        for coarsest, n, alpha, rounds, jac, hold, trial, cap in runs:
            kw = _options(alpha, rounds)
            with _JACOBIAN_SOLVES[jac](), _damping_hold(hold), trial_refused(trial), trial_newton(cap):
                r = refine(design, resolution=args.resolution_mm * MM, max_iter=args.max_iter,
                           coarsest=coarsest * MM, corrections=n, **kw)
            b, a = r.deviation_before, r.deviation_after
            gn = r.coarse_resolution if r.coarse_resolution is not None else r.resolution
            near = surface.closest_extended(a.aligned).distance
            to_surface = float(np.sqrt(np.mean(near ** 2)))
            moved = "–" if r.reparametrization is None else f"{r.reparametrization.moved_rms / MM:.1f}"
            print(f"| {name} | {m.width / MM:.0f} × {m.height / MM:.0f} | {gn / MM:g} | {len(r.corrections)} "
                  f"| {r.alpha:g} | {r.reparametrize_rounds} "
                  f"| {b.rms / MM:.1f} "
                  f"({b.rms_pct_diag:.2f}) | {a.rms / MM:.1f} ({a.rms_pct_diag:.2f}) "
                  f"| {to_surface / MM:.1f} ({100 * to_surface / diag:.2f}) | {b.max / MM:.1f} / "
                  f"{a.max / MM:.1f} | {r.iterations} | {'yes' if r.converged else 'no'} | {r.seconds:.1f} "
                  f"| {r.inflation_seconds:.1f} | {r.verification_seconds:.1f} "
                  f"| {r.seconds / r.inflation_seconds:.1f}× | {len(r.dropped)} / {len(r.flagged)} | {moved} |"
                  + (f" {jac} |" if args.jacobian_solve else "")
                  + (f" {'yes' if hold else 'no'} |" if args.damping_hold else "")
                  + (f" {trial[0]} ×{trial[1]:g} |" if args.trial_rule else "")
                  + (f" {cap} |" if args.trial_newton else "")
                  + (f" {_from_flat(r)} |" if args.from_flat else ""), flush=True)
    return 0


def _from_flat(r) -> str:
    """The refined lengths inflated from the flat mattress (not from the open-loop equilibrium): RMS mm (% diag)."""
    from airmat.check.compare import deviation
    from airmat.check.inflation_check import design_strings
    from airmat.inflation.simulate import inflate

    d = r.design
    flat = inflate(r.open_loop_run.inflation.mesh, design_strings(d, "median"), tol=r.open_loop_run.tol)
    dev = deviation(flat, d.approx.xyz, d.approx.uv, r.surface)
    return f"{dev.rms / MM:.1f} ({dev.rms_pct_diag:.2f})"


def _setting(module: str, name: str, value):
    """``module.name`` set to ``value`` while the block runs (None: left as it is)."""
    if value is None:
        return contextlib.nullcontext()
    return mock.patch.object(importlib.import_module(module), name, value)


def trial_newton(cap):
    """airmat.check.trial_equilibrium.TRIAL_NEWTON set to ``cap`` (None: left as it is)."""
    return _setting("airmat.check.trial_equilibrium", "TRIAL_NEWTON", None if cap is None else int(cap))


def trial_rule(text: str) -> tuple:
    """``"backtrack:2"`` -> ("backtrack", 2.0)."""
    rule, _, up = text.partition(":")
    if rule not in ("shift", "backtrack") or not up:
        raise argparse.ArgumentTypeError(f"RULE:MU_UP with RULE shift or backtrack, got {text!r}")
    return rule, float(up)


def trial_refused(rule):
    """airmat.check.trial_equilibrium.TRIAL_REFUSED_STEP set to ``rule`` (None: left as it is)."""
    return _setting("airmat.check.trial_equilibrium", "TRIAL_REFUSED_STEP", rule)


def _per_column():
    """The Jacobian solved by cvxopt one column at a time (airmat.inflation.cholmod_block disabled)."""
    import airmat.inflation.cholesky as cholesky

    return mock.patch.object(cholesky, "solve_many", lambda factor, b: None)


_JACOBIAN_SOLVES = {"all-at-once": contextlib.nullcontext, "per-column": _per_column}


def _damping_hold(hold):
    """airmat.check.gauss_newton.HOLD_AFTER_RETRY set to ``hold`` (None: left as it is)."""
    return _setting("airmat.check.gauss_newton", "HOLD_AFTER_RETRY", None if hold is None else bool(hold))


def _options(alpha, rounds) -> dict:
    """refine()'s keyword arguments for a row: its own defaults where the option is None."""
    return {k: v for k, v in (("alpha", alpha), ("reparametrize", rounds)) if v is not None}


def jittered(design, seed: int, half_width: float):
    """``design`` with every string's real lengths moved by one uniform draw in ±half_width (m); seed 0: itself."""
    import dataclasses

    if seed == 0:
        return design
    shift = np.random.default_rng(seed).uniform(-half_width, half_width, len(design.pattern.strings))
    strings = tuple(dataclasses.replace(s, l_median=s.l_median + e, l_lo95=s.l_lo95 + e, l_hi95=s.l_hi95 + e)
                    for s, e in zip(design.pattern.strings, shift))
    return dataclasses.replace(design, pattern=dataclasses.replace(design.pattern, strings=strings))


def spread(names, args) -> int:
    """One row per preset and setting: the refined deviation over ``args.draws`` jittered refinements."""
    print(f"| preset | alpha | re-param rounds | draws (±{args.jitter_um:g} µm) | refined % diag: median | min – max "
          "| ≤ 1 % | converged | refined % diag, each draw | refine / its first inflation, each draw |"
          + (" damping held |" if args.damping_hold else "") + (" trial refused step |" if args.trial_rule else "")
          + (" trial Newton |" if args.trial_newton else ""))
    print("|---|---|---|---|---|---|---|---|---|---|" + ("---|" if args.damping_hold else "")
          + ("---|" if args.trial_rule else "") + ("---|" if args.trial_newton else ""))
    for name in names:
        design = designed_preset(name)
        for alpha in args.alpha:
            for rounds, hold, trial, cap in [(k, h, t, tn) for k in args.reparametrize
                                             for h in (args.damping_hold or [None])
                                             for t in (args.trial_rule or [None])
                                             for tn in (args.trial_newton or [None])]:
                kw = _options(alpha, rounds)
                with _damping_hold(hold), trial_refused(trial), trial_newton(cap):
                    rs = [refine(jittered(design, k, args.jitter_um * 1e-6), resolution=args.resolution_mm * MM,
                                 max_iter=args.max_iter, **kw) for k in range(args.draws)]
                pct = np.array([r.deviation_after.rms_pct_diag for r in rs])
                print(f"| {name} | {rs[0].alpha:g} | {rs[0].reparametrize_rounds} | {args.draws} | {np.median(pct):.2f} "
                      f"| {pct.min():.2f} – {pct.max():.2f} | {int(np.sum(pct <= 1.0))} / {len(pct)} "
                      f"| {sum(r.converged for r in rs)} / {len(rs)} | {' '.join(f'{p:.2f}' for p in pct)} "
                      f"| {' '.join(f'{r.seconds / r.inflation_seconds:.1f}×' for r in rs)} |"
                      + (f" {'yes' if hold else 'no'} |" if args.damping_hold else "")
                      + (f" {trial[0]} ×{trial[1]:g} |" if args.trial_rule else "")
                      + (f" {cap} |" if args.trial_newton else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
