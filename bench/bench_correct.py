"""Benchmark: the correction cycle of issue 41 (learn Δ, d and the strings' errors from a scan, correct, rebuild).

Usage::

    .venv/bin/python bench/bench_correct.py                       # vault1, saddle and vault2, refined, 1M-point scans
    .venv/bin/python bench/bench_correct.py --shapes saddle --open-loop   # the open-loop design built instead
    .venv/bin/python bench/bench_correct.py --quick               # a smoke run: saddle at 40 mm, open loop, 50 000 points

Each shape (a preset or a zoo target designed with the paper's calibration values, seed 0, and refined through the
inflation at the benchmark's resolution, as a design is before it is built; ``--open-loop``: not
refined) is built in a true world whose Δ and d lie 2 mm above the design
calibration's 95 % intervals, every string cut within ±3 mm (uniform, seeded), inflated the check's
way (:func:`airmat.asbuilt.true_world.built_world`). Its named face in Ŝ's frame is scanned (points
uniform over Ŝ's triangles of the built face, 0.5 mm Gaussian noise, seeded: the registration is
another benchmark's), :func:`airmat.asbuilt.update.update` learns the posterior and
:func:`airmat.asbuilt.correction.correct` the new lengths; the corrected design is built again in the
same world (kept strings keep their cut errors, re-cut ones get fresh ones, seeded) and its face
compared with Ŝ.

One cut-error draw decides whether one interval covers; the coverage is a frequency. The column
"coverage over N seeds" is measured with the face known exactly
(:func:`airmat.asbuilt.update.known_face_update`, no inflation: the limit the converged update
reaches), over N fresh cut-error draws of the same world, with the mean and the spread of the
estimate's error in posterior sd (a calibrated posterior: spread 1; the prior's pull: a mean
off 0). "Known face" gives that limit for the table's own draw.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from designed_preset import designed_preset  # noqa: E402
from airmat.asbuilt.correction import correct  # noqa: E402
from airmat.asbuilt.true_world import World, built_world  # noqa: E402
from airmat.asbuilt.laplace import known_face_update  # noqa: E402
from airmat.asbuilt.update import MAX_RELINEARISATIONS, update  # noqa: E402
from airmat.check.compare import deviation  # noqa: E402
from airmat.check.inflation_check import check, design_strings  # noqa: E402
from airmat.check.string_world import world_strings  # noqa: E402
from airmat.inflation.simulate import inflate, inflate_from  # noqa: E402
from airmat.units import MM  # noqa: E402

#: presets, and zoo targets of other kinds (airmat.synthetic.zoo)
SHAPES = ("vault1", "saddle", "vault2", "dome", "wave-once", "cone-r300", "hypar-0.3", "helicoid-p2000",
          "vault-catenary", "conoid")
CUT = 3 * MM
NOISE = 0.5 * MM
Z95 = 1.959963984540054


def scan(face, faces, n, rng):
    """``n`` points uniform over the triangles' barycentric coordinates, Gaussian noise (m)."""
    f = rng.integers(0, len(faces), n)
    b = rng.dirichlet(np.ones(3), n)
    return np.einsum("mi,mic->mc", b, face[faces[f]]) + rng.normal(0.0, NOISE, (n, 3))


def built_again(design, chk, corr, world, seed):
    """The corrected design built in the world: kept strings keep their cut errors, re-cut ones get fresh
    ones (uniform ±CUT, seeded), inflated the check's way. Its Deviation from Ŝ."""
    l_old = np.array([s.l_median for s in design.pattern.strings])
    fresh = np.random.default_rng(seed).uniform(-CUT, CUT, l_old.size)
    effective = np.maximum(np.where(corr.kept, l_old + world.cut_error, corr.l_real + fresh), 0.0)
    rest = world_strings(design, world.delta, world.d, cut_error=effective - l_old).rest
    strings = replace(design_strings(design, lengths=chk.lengths), rest=rest)
    inf = (inflate_from(chk.open_loop, strings) if chk.open_loop is not None
           else inflate(chk.runs["median"].inflation.mesh, strings))
    return deviation(inf, design.approx.xyz, design.approx.uv, chk.surface)


def coverage(design, truth, n_seeds):
    """Over ``n_seeds`` cut-error draws with the face known exactly: (share covered, mean z (2,), sd z (2,))."""
    k = len(design.pattern.strings)
    z = np.empty((n_seeds, 2))
    for i in range(n_seeds):             # one world per seed; each a small MAP over the chain (no inflation)
        cut = np.random.default_rng([i, 99]).uniform(-CUT, CUT, k)
        x, cov = known_face_update(design, world_strings(design, *truth, cut_error=cut).rest, cut_tolerance=CUT)
        z[i] = (x[:2] - truth) / np.sqrt(np.diag(cov[:2, :2]))
    return float(np.mean(np.all(np.abs(z) <= Z95, axis=1))), z.mean(axis=0), z.std(axis=0)


def run(shape, resolution, n_points, seed, n_seeds, refined=True):
    design = designed_preset(shape, refine_at=resolution if refined else None)
    chk = check(design, resolution=resolution, envelope=False)
    cal = design.calibration
    lo = np.array([np.percentile(cal.delta, 2.5), np.percentile(cal.d, 2.5)])
    hi = np.array([np.percentile(cal.delta, 97.5), np.percentile(cal.d, 97.5)])
    truth = hi + 2 * MM
    built = built_world(design, World(delta=truth[0], d=truth[1], cut_tolerance=CUT), resolution=resolution,
                        seed=seed)
    points = scan(built.deviation.aligned, design.approx.faces, n_points, np.random.default_rng([seed, 1]))
    t0 = time.perf_counter()
    u = update(design, points, check=chk, cut_tolerance=CUT, max_relinearisations=MAX_RELINEARISATIONS, seed=seed)
    c = correct(design, u, check=chk)
    seconds = time.perf_counter() - t0
    after = built_again(design, chk, c, built.world, [seed, 2])
    kf, kf_cov = known_face_update(design, built.lengths.rest, cut_tolerance=CUT)
    share, zm, zs = coverage(design, truth, n_seeds)
    diag = float(np.linalg.norm(np.ptp(design.approx.xyz, axis=0)))
    iv = u.interval95
    covers = (iv[0] <= truth) & (truth <= iv[1])
    kf_half = Z95 * np.sqrt(np.diag(kf_cov[:2, :2]))
    before = built.deviation.rms
    one = built.inflation.seconds
    m = design.mattress
    cells = [f"{shape}{' (refined)' if refined else ' (open loop)'}", f"{m.width / MM:.0f} x {m.height / MM:.0f}",
             f"{truth[0] / MM:.2f} / {truth[1] / MM:.2f}"]
    cells += [f"{iv[0, j] / MM:.2f}..{iv[1, j] / MM:.2f} ({'yes' if covers[j] else 'no'})" for j in range(2)]
    cells += [f"{(kf[j] - kf_half[j]) / MM:.2f}..{(kf[j] + kf_half[j]) / MM:.2f}" for j in range(2)]
    cells += [f"{100 * share:.0f} % ({n_seeds}); z {zm[0]:+.2f} ± {zs[0]:.2f} / {zm[1]:+.2f} ± {zs[1]:.2f}"]
    cells += [f"{(hi[j] - lo[j]) / MM:.1f} → {(iv[1, j] - iv[0, j]) / MM:.2f}" for j in range(2)]
    cells += [f"{before / MM:.2f} → {after.rms / MM:.2f}", f"{100 * after.rms / diag:.2f} %",
              f"{100 * (1 - after.rms / before):.0f} %", f"{c.plan.counts['keep']} / {c.plan.counts['recut']}",
              f"{u.iterations}", "yes" if u.converged else f"no ({u.message.split(': ')[-1]})",
              f"{u.seconds:.1f} + {c.seconds:.1f}", f"{one:.1f}", f"{seconds / one:.1f}x"]
    return cells


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="+", default=["vault1", "saddle", "vault2"], choices=SHAPES)
    ap.add_argument("--open-loop", action="store_true", help="build the open-loop designs (not refined)")
    ap.add_argument("--resolution", type=float, default=20.0, help="mesh edge length (mm, default 20)")
    ap.add_argument("--points", type=int, default=1_000_000, help="scan points (default 1 000 000)")
    ap.add_argument("--seed", type=int, default=7, help="the cut errors' and the scan's seed (default 7)")
    ap.add_argument("--coverage-seeds", type=int, default=200, help="cut-error draws of the coverage (default 200)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: saddle at 40 mm, open loop, 50 000 points, 20 draws")
    args = ap.parse_args(argv)
    shapes, res, n, n_seeds = ((["saddle"], 40.0, 50_000, 20) if args.quick else
                               (args.shapes, args.resolution, args.points, args.coverage_seeds))
    print("| shape | mattress (mm) | true Δ / d (mm) | updated 95 % Δ (covers) | updated 95 % d (covers) "
          "| known face 95 % Δ | known face 95 % d | coverage over N seeds (known face); z of Δ / d "
          "| 95 % width Δ: calibration → updated (mm) | 95 % width d (mm) | RMS from Ŝ before → after (mm) "
          "| after (% diag) | reduction | kept / re-cut | linearisations | converged | update + correction (s) "
          "| one inflation (s) | ratio |")
    print("|" + "---|" * 19)
    for shape in shapes:
        print("| " + " | ".join(run(shape, res * MM, n, args.seed, n_seeds, refined=not (args.open_loop or args.quick)))
              + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
