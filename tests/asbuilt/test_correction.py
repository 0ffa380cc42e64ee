"""airmat.asbuilt.correction: corrected lengths, the re-tie list and the corrected design.

The truth is the true world of tests/asbuilt/test_update.py: the corrected design is built in the same
world, its kept strings keeping their true cut errors and its re-cut ones getting new ones (seeded),
and inflated the check's way.
"""

from dataclasses import replace
from pathlib import Path
import sys

import numpy as np
import pytest

from airmat.asbuilt.correction import correct
from airmat.asbuilt.update import MAX_RELINEARISATIONS, update
from airmat.check.compare import deviation
from airmat.check.inflation_check import check, design_strings
from airmat.check.string_world import world_strings
from airmat.design.design_io import read_design, write_design
from airmat.design.retie import ACTIONS
from airmat.inflation.simulate import inflate, inflate_from

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_update import small_update, small_world, true_world  # noqa: E402,F401  (fixtures)

#: the workshop's cut tolerance of the built mattress and of the re-cut strings (m)
CUT = 0.003
#: the acceptance's seed of the cut errors and the scan, fixed before it was run (see the test's docstring)
SEED = 7


def built_again(design, chk, corr, world, *, seed=0):
    """The corrected design built in the world: kept strings keep their true cut errors, re-cut strings
    get new ones, uniform on ±CUT (seeded); inflated the check's way. Returns its Deviation from Ŝ."""
    l_old = np.array([s.l_median for s in design.pattern.strings])
    fresh = np.random.default_rng(seed).uniform(-CUT, CUT, l_old.size)
    effective = np.maximum(np.where(corr.kept, l_old + world.cut, corr.l_real + fresh), 0.0)
    rest = world_strings(design, world.delta, world.d, cut_error=effective - l_old).rest
    strings = replace(design_strings(design, lengths=chk.lengths), rest=rest)
    inf = (inflate_from(chk.open_loop, strings) if chk.open_loop is not None
           else inflate(chk.runs["median"].inflation.mesh, strings))
    assert inf.converged
    return deviation(inf, design.approx.xyz, design.approx.uv, chk.surface)


@pytest.fixture(scope="module")
def small_correction(small_world, small_update):
    return correct(small_world.design, small_update, check=small_world.check)


@pytest.fixture(scope="module")
def undone(small_world, small_update):
    """All the weight on the pull toward the design's rest lengths and no keeping: every string re-cut to
    give the design's own rest length."""
    return correct(small_world.design, small_update, check=small_world.check, alpha=1e9, keep_tolerance=0.0)


def test_kept_strings_keep_their_learned_length_and_the_plan_lists_every_string(small_correction, small_update,
                                                                               small_world):
    c, u = small_correction, small_update
    l_old = np.array([s.l_median for s in small_world.design.pattern.strings])
    assert np.allclose(c.l_real[c.kept], (l_old + u.error)[c.kept], atol=1e-12)
    assert np.all(c.change[c.kept] == 0)
    counts = c.plan.counts
    assert set(counts) == set(ACTIONS) and counts["keep"] + counts["recut"] == len(l_old)
    assert counts["keep"] == int(c.kept.sum())
    assert np.all(c.l_real >= 0) and np.all(c.length_sd > 0)
    s = c.design.pattern.strings
    assert np.allclose([x.l_hi95 - x.l_lo95 for x in s], 2 * 1.959963984540054 * c.length_sd)
    assert "Correction" in repr(c)
    # the toy's Ŝ is far (70 mm) from anything its two strings make; a 5 mm trust radius cannot help it
    assert c.rms_linear <= c.rms_before + 1e-3


def test_pulled_to_the_design_the_correction_undoes_the_world(undone, small_update, small_world):
    """The rest lengths the simulator needs do not depend on the world: the re-cut strings in the true
    world (no new cut error) give the design's own rest lengths, to the spread the posterior of (Δ, d)
    gives a new string's rest length (R_θ Σ R_θᵀ; its old cut error is gone)."""
    from airmat.asbuilt.chain_slopes import world_slopes

    w, c = small_world, undone
    r_theta, _, _ = world_slopes(w.design, small_update.mean, np.zeros(len(c.kept)))
    sd = np.sqrt(np.einsum("ki,ij,kj->k", r_theta, small_update.covariance, r_theta))
    assert not c.kept.any() and c.plan.counts["recut"] == len(c.kept)
    l_old = np.array([s.l_median for s in w.design.pattern.strings])
    rest = world_strings(w.design, w.delta, w.d, cut_error=c.l_real - l_old).rest
    target = design_strings(w.design, lengths=w.check.lengths).rest
    assert np.all(np.abs(rest - target) <= 4 * sd), (rest - target, sd)


def test_the_verification_inflation_lands_on_the_design_s_prediction(undone, small_world):
    """Undone, the updated world's inflation is the design's median run again (the same rest lengths,
    the same path), to the linear step's accuracy (airmat.check.tolerance_validation.RELIABLE_ERROR: 25 % of the change)."""
    c, med = undone, small_world.check.runs["median"]
    assert c.rms_verified is not None
    assert abs(c.rms_verified - med.deviation.rms) <= 0.25 * abs(c.rms_before - med.deviation.rms)


def test_the_undone_mattress_in_the_true_world_is_back_near_the_prediction(undone, small_world):
    """Built again in the true world with new cut errors for every string, it is nearer the design's
    median run than the mattress as built was."""
    w, med = small_world, small_world.check.runs["median"].deviation.aligned
    after = built_again(w.design, w.check, undone, w, seed=5)

    def off(dev):
        return float(np.sqrt(np.mean(np.sum((dev.aligned - med) ** 2, axis=1))))
    assert off(after) < 0.5 * off(w.built), (off(after), off(w.built))


def test_the_corrected_design_is_a_design_folder(small_correction, tmp_path):
    """write_design writes it (airmat check, synth-built and export read such a folder); Ŝ is unchanged."""
    c = small_correction
    write_design(c.design, tmp_path / "corrected")
    back = read_design(tmp_path / "corrected")
    assert np.allclose([s.l_median for s in back.pattern.strings], c.l_real, atol=1e-5)    # files: 0.01 mm
    assert np.allclose(back.approx.xyz, c.design.approx.xyz, atol=1e-6)
    assert back.refine is not None and "as-built correction" in back.refine["method"]


@pytest.mark.slow
def test_vault1_learned_and_corrected(tmp_path):
    """The physical loop's acceptance on vault1 (refined): a world with Δ and d outside the calibration's 95 %
    interval and cut errors ±3 mm. Measured numbers are printed (pytest -s).

    One draw of the cut errors, so the coverage criterion holds with a probability, not surely: a Bayesian
    95 % interval covers a world in the tail of its prior less often than 95 % of the draws (the prior pulls
    the estimate toward itself). With the face known exactly (:func:`airmat.asbuilt.update.known_face_update`,
    the limit the converged update reaches: within 0.4 posterior sd of it on seed 41) the intervals of both
    Δ and d cover this world for 96 % of 200 seeds (``bench/bench_correct.py`` measures it).
    Seed 41 is one of the others: even with the face known exactly its intervals miss (Δ by 2.6, d by 2.0
    posterior sd). The seed here, 7 (the guide's ``synth-built`` example), was fixed before it was ever run,
    and is not to be replaced by one that passes: a failure is a draw in those 4 % or a fault of the update,
    which the bench's coverage tells apart."""
    import airmat

    design = airmat.make_design(*airmat.preset("vault1"))
    design = airmat.refine(design, resolution=0.020).design
    chk = check(design, resolution=0.020, envelope=False)
    cal = design.calibration
    (dl, dh), (tl, th) = np.percentile(cal.delta, [2.5, 97.5]), np.percentile(cal.d, [2.5, 97.5])
    lo, hi = np.array([dl, tl]), np.array([dh, th])          # the prior's 95 % intervals of (Δ, d)
    delta, d = hi + 0.002                                    # both 2 mm above them
    rng = np.random.default_rng(SEED)
    cut = rng.uniform(-CUT, CUT, len(design.pattern.strings))
    world = true_world(design, chk, delta, d, cut, seed=SEED, n=200000)
    u = update(design, world.points, check=chk, cut_tolerance=CUT, max_relinearisations=MAX_RELINEARISATIONS,
               seed=SEED)
    c = correct(design, u, check=chk)
    after = built_again(design, chk, c, world, seed=42)
    diag = float(np.linalg.norm(np.ptp(design.approx.xyz, axis=0)))
    print(f"\nvault1: truth delta {delta * 1e3:.2f} mm, d {d * 1e3:.2f} mm; prior 95 % delta "
          f"{lo[0] * 1e3:.2f}..{hi[0] * 1e3:.2f}, d {lo[1] * 1e3:.2f}..{hi[1] * 1e3:.2f}")
    print(f"linearisations {u.iterations}, converged {u.converged}; ", end="")
    print(f"updated 95 %: delta {u.interval95[0, 0] * 1e3:.2f}..{u.interval95[1, 0] * 1e3:.2f}, "
          f"d {u.interval95[0, 1] * 1e3:.2f}..{u.interval95[1, 1] * 1e3:.2f}; {u.message}; {u.seconds:.1f} s")
    print(f"face RMS from S-hat: built {world.built.rms * 1e3:.2f} mm, corrected {after.rms * 1e3:.2f} mm "
          f"({100 * after.rms / diag:.2f} % of the diagonal, reduction {100 * (1 - after.rms / world.built.rms):.0f} %);"
          f" {c.plan}")
    truth = np.array([delta, d])
    criteria = {"the updated 95 % intervals cover the true delta and d":
                np.all((u.interval95[0] <= truth) & (truth <= u.interval95[1])),
                "they are narrower than the calibration's": np.all(u.interval95[1] - u.interval95[0] < hi - lo),
                "the corrected face's RMS from S-hat is at least 60 % smaller": after.rms <= 0.4 * world.built.rms,
                "and within 1.0 % of S-hat's diagonal": after.rms <= 0.01 * diag}
    assert all(criteria.values()), [name for name, ok in criteria.items() if not ok]
