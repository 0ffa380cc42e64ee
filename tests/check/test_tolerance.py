"""airmat.check.tolerance (and its face_linearization, tolerance_validation): the linearized tolerance against re-inflations and a Monte-Carlo of the small case."""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

sys.path.insert(0, str(Path(__file__).parent))
from refine_case import OFF, RESOLUTION, TRUE_SIM, small_design  # noqa: E402

from airmat.check.compare import deviation  # noqa: E402
from airmat.check.inflation_check import check, design_strings  # noqa: E402
from airmat.check.length_covariance import length_covariance  # noqa: E402
from airmat.check.monte_carlo import draw  # noqa: E402
from airmat.check.face_linearization import align_faces  # noqa: E402
from airmat.check.tolerance import density_at, tolerance  # noqa: E402
from airmat.check.pair_statistics import (antithetic, pair_statistics, rms_shift_se, spread_scale,  # noqa: E402
                                          variance_ratio)
import airmat.check.tolerance_validation as tv  # noqa: E402
from airmat.check.tolerance_validation import RELIABLE_ERROR, Validation  # noqa: E402
from airmat.forked import can_fork  # noqa: E402
from airmat.errors import InputError  # noqa: E402
from airmat.inflation.simulate import inflate_from  # noqa: E402

#: Monte-Carlo samples of the band test (about 0.4 s each on the small case)
K = 32
#: the three strings of the small case shortened by OFF: every one taut (a slack string's response has a
#: kink at its onset, which no first-order model follows); Ŝ is their own inflation, so e₀ = 0
LENGTHS = TRUE_SIM + OFF


@pytest.fixture(scope="module")
def case():
    design = small_design(LENGTHS, true_sim=LENGTHS)
    run = check(design, resolution=RESOLUTION, envelope=False, samples=K, seed=1)
    return design, run


@pytest.fixture(scope="module")
def linear(case):
    design, run = case
    return tolerance(design, run=run, validate=8, seed=2)


def test_the_covariance_is_what_the_monte_carlo_draws():
    """The three sources against the sample covariance of draw()'s lengths (no inflation)."""
    design = small_design(LENGTHS, true_sim=LENGTHS)
    cal = design.calibration
    design = replace(design, calibration=replace(cal, sigma=np.full(cal.n_samples, 0.3)))
    cov = length_covariance(design)
    n = 40000
    dr = draw(design, n, seed=5)
    sample = np.cov(dr.rest, rowvar=False)
    # a sample variance's relative standard error is sqrt(2 / n) (0.7 %): 5 of them, and draw() picks the
    # 200 posterior samples with replacement, so both estimate the covariance over those 200
    assert np.allclose(np.diag(cov.total), np.diag(sample), rtol=5 * np.sqrt(2 / n))
    assert np.all(cov.scatter > 0) and cov.sigma_source == "posterior"
    cut = length_covariance(design, cut_tolerance=0.002)
    assert np.allclose(cut.cut, 0.002 ** 2 / 3)          # uniform on +-2 mm, l* = l + 2Δ (slope 1)
    normal = length_covariance(design, cut_tolerance=0.002, cut_distribution="normal")
    assert np.allclose(normal.cut, 0.002 ** 2)


@pytest.mark.slow
def test_the_jacobian_is_the_limit_of_central_differences(case, linear):
    """Re-inflations at l* ± h (carried on from the median equilibrium) against A h.

    One string against its neighbours bends the face non-linearly; a central difference's remainder is
    O(h²), so halving h must cut the error about 4x (checked: at most half), and at h = 0.5 mm it is
    within 2 %. A common change of all three (the posterior's main mode) is nearly linear.
    """
    design, run = case
    med = run.runs["median"]
    strings = design_strings(design, "median", lengths=run.lengths)

    def error(dl):
        faces = [deviation(inflate_from(med.inflation, replace(strings, rest=strings.rest + s * dl)),
                           design.approx.xyz, design.approx.uv, run.surface).aligned for s in (1, -1)]
        actual = 0.5 * (faces[0] - faces[1])
        return np.linalg.norm(actual - linear.jacobian @ dl) / np.linalg.norm(actual)

    direction = np.array([0.0, -1.0, 0.5])
    coarse, fine = error(1e-3 * direction), error(0.5e-3 * direction)
    assert fine < 0.02 and fine < 0.5 * coarse, (coarse, fine)
    assert error(np.full(3, 1e-3)) < 0.02


@pytest.mark.slow
def test_the_linear_95_band_agrees_with_the_monte_carlo(case, linear):
    """Per-vertex 95 % quantiles of the distance from Ŝ: the model against K full samples.

    The bound is the sampling error of K samples. With e₀ = 0 and the posterior's lengths moving together
    (correlation > 0.99: one mode), a vertex's distance is |N(0, s²)|: its 95 % quantile 1.96 s has the
    density 2 φ(1.96) / s there, so the K-sample quantile's relative standard error is
    sqrt(0.95 · 0.05 / K) / (2 φ(1.96) · 1.96) = 0.17 at K = 32. One mode moves every vertex alike, so
    the median over vertices is one such error, not an average of many: 3 standard errors, plus the
    linearization error the validation measured.
    """
    design, run = case
    post = linear.covariance.posterior
    assert np.min(post / np.sqrt(np.outer(np.diag(post), np.diag(post)))) > 0.99
    assert np.abs(linear.base).max() < 1e-6       # Ŝ is the median inflation
    mc = run.monte_carlo
    rel_se = np.sqrt(0.95 * 0.05 / K) / (2 * norm.pdf(1.96) * 1.96)
    rel = np.median(np.abs(linear.per_vertex_q[1] / mc.per_vertex_q[1] - 1))
    assert rel < 3 * rel_se + abs(linear.validation.spread_error), (rel, rel_se)
    assert linear.reliable and abs(linear.validation.spread_error) < RELIABLE_ERROR
    assert np.all(linear.validation.converged)
    st, mst = linear.stats(), mc.stats()
    assert abs(st["rms_median"] / mst["rms_median"] - 1) < 3 * mst["rms_median_se"] / mst["rms_median"] + 0.05


@pytest.mark.slow
def test_the_strings_shares_sum_to_one_and_name_the_strings(linear):
    assert np.isclose(linear.share.sum(), 1.0)
    idx, share = linear.sensitive(2)
    assert len(idx) == 2 and abs(share[0]) >= abs(share[1])
    assert linear.ids == ("k1-000-01", "k1-001-01", "k1-002-01")
    assert np.all(linear.band_normal[1] >= linear.band_normal[0]) and linear.normal_sd.max() > 0
    assert "LinearTolerance" in repr(linear) and "reliable True" in repr(linear)


@pytest.mark.slow
def test_a_huge_cut_tolerance_is_unreliable_and_says_so(case):
    """±40 mm on 270-290 mm strings: lengthened strings go slack, far outside the first order.

    A slack string stops moving the face, so the pairs' spread falls short of the linear one (measured
    -23 %); a ±2 mm cut stays within the bound (the spread of a nearly linear response, measured 0 % at 0).
    """
    design, run = case
    result = tolerance(design, run=run, validate=4, cut_tolerance=0.040, seed=3)
    v = result.validation
    assert v.converged.all() and v.spread_error < -RELIABLE_ERROR and result.reliable is False
    assert "UNRELIABLE" in result.message and "spread" in result.message and "--samples" in result.message
    small = tolerance(design, run=run, validate=4, cut_tolerance=0.002, seed=3)
    assert small.reliable and abs(small.validation.spread_error) < RELIABLE_ERROR


@pytest.mark.slow
def test_not_validated_and_bad_input(case):
    design, run = case
    quick = tolerance(design, run=run, validate=0, draws=200, tolerance=0.002)
    assert quick.validation is None and quick.reliable is None and "not validated" in quick.message
    assert 0.0 <= quick.stats()["p_within"] <= 1.0
    with pytest.raises(InputError, match="no strings"):
        tolerance(replace(design, pattern=replace(design.pattern, strings=())), run=run)
    with pytest.raises(InputError, match="cut_distribution"):
        tolerance(design, run=run, validate=0, cut_distribution="triangular")
    with pytest.raises(InputError, match="validate"):
        tolerance(design, run=run, validate=-1)
    with pytest.raises(InputError, match="even"):
        tolerance(design, run=run, validate=3)


@pytest.mark.slow
def test_the_mean_shift_is_the_samples_mean_and_moves_the_model(case):
    """The model is centred on e₀ + m̂, m̂ the mean change of the validation samples, and reports its RMS."""
    design, run = case
    with_shift = tolerance(design, run=run, validate=4, seed=2, tolerance=0.002)
    v = with_shift.validation
    assert v.shift.shape == with_shift.base.shape and np.abs(v.shift).max() > 0
    assert v.rms_actual.shape == (4,) and v.rms_linear.shape == (4,)
    assert v.p_within_se is not None and np.isfinite(v.rms_shift_se)
    moved = tolerance(design, run=run, validate=0, seed=2, draws=with_shift.rms.size,
                      tolerance=0.002)       # same draws of δl without the shift
    assert not np.allclose(moved.rms, with_shift.rms)
    block = with_shift.block()["validation"]
    assert block["spread_error"] == round(v.spread_error, 4) and block["mean_shift_mm"]["rms"] > 0


@pytest.mark.slow
def test_the_spread_correction_brings_the_model_to_full_samples_where_strings_slacken(case):
    """±8 mm cut errors on the three strings: a lengthened string nears its slack onset and moves the face
    less than the Jacobian says, so full samples spread less than the first-order model (their variance
    about their mean over the model's for the same δl, paired: measured 0.92 ± 0.02 on 160 samples
    carried on from the median). The validation's 32 pairs measure that ratio within the two standard
    errors' noise; the first-order model's mean squared deviation, paired on the 160 samples' own δl,
    lies above theirs by more than 3 of its standard errors (measured 3.6), the corrected one within 2 (0.1);
    and P(RMS <= T) at the samples' median RMS moves toward their 0.5 (measured 0.47 -> 0.50)."""
    design, run = case
    med, t, k = run.runs["median"], 0.008, 160
    strings = design_strings(design, "median", lengths=run.lengths)
    dr = draw(design, k, 11, lengths=run.lengths)
    cut = np.random.default_rng(12).uniform(-t, t, dr.length.shape)
    delta = run.lengths.to_simulated(np.maximum(dr.length + cut, 0.0)) - strings.rest
    faces = np.stack([deviation(inflate_from(med.inflation, replace(strings, rest=strings.rest + d)), design.approx.xyz,
                                design.approx.uv, run.surface).aligned for d in delta])
    changes = faces - med.deviation.aligned                 # e₀ = 0 here: the changes are the deviations
    raw, fixed = (tolerance(design, run=run, validate=64, seed=2, cut_tolerance=t, spread_correction=c)
                  for c in (False, True))
    v = fixed.validation
    pred = np.einsum("nck,sk->snc", fixed.jacobian, delta)
    dc, pc = changes - changes.mean(axis=0), pred - pred.mean(axis=0)
    num, den = np.sum(dc ** 2, axis=(1, 2)), np.sum(pc ** 2, axis=(1, 2))
    r_mc = num.sum() / den.sum()
    se_mc = np.std(num - r_mc * den, ddof=1) / np.sqrt(k) / den.mean()
    assert 1 - r_mc > 3 * se_mc, (r_mc, se_mc)                       # the nonlinearity is there
    assert abs(v.variance_ratio - r_mc) < 3 * np.hypot(v.variance_ratio_se, se_mc), (v.variance_ratio, r_mc)
    assert raw.validation.spread_scale == 1.0 and v.spread_scale < 1.0

    def excess(scale):          # the model's mean squared deviation minus the samples', paired on their δl
        d = (np.mean(np.sum((v.shift + scale * pred) ** 2, axis=2), axis=1)
             - np.mean(np.sum(changes ** 2, axis=2), axis=1))
        return d.mean(), d.std(ddof=1) / np.sqrt(k)
    (before, se), (after, se_after) = excess(1.0), excess(v.spread_scale)
    assert before > 3 * se and abs(after) < 2 * se_after, (before, se, after, se_after)
    T = float(np.median(np.sqrt(np.mean(np.sum(changes ** 2, axis=2), axis=1))))
    p_raw, p_fixed = (float(np.mean(m.rms <= T)) for m in (raw, fixed))
    assert abs(p_fixed - 0.5) < abs(p_raw - 0.5), (p_raw, p_fixed)
    assert np.allclose(fixed.normal_sd, v.spread_scale * raw.normal_sd)
    assert fixed.block()["validation"]["spread_scale"] == round(v.spread_scale, 4)


@pytest.mark.skipif(not can_fork(), reason="the validation's samples fork on Linux only")
def test_the_validation_samples_on_forked_processes_are_the_same_bits(case, monkeypatch):
    """With workers, the validation's samples run on forked processes (airmat.forked.ForkedMap), each sample
    from its own δ with the Newton system reset: the same samples, shift, scale and model draws as in one process."""
    design, run = case
    forked = []
    original = tv.ForkedMap.__init__

    def counting(self, fn, items, workers):
        original(self, fn, items, workers)
        forked.append(self.forked)
    monkeypatch.setattr(tv.ForkedMap, "__init__", counting)
    one = tolerance(design, run=run, validate=6, seed=3, tolerance=0.002)
    two = tolerance(design, run=run, validate=6, seed=3, tolerance=0.002, workers=2)
    assert forked == [0, 2]
    a, b = one.validation, two.validation
    assert np.array_equal(a.converged, b.converged) and a.converged.all()
    assert np.array_equal(a.shift, b.shift) and np.array_equal(a.rms_actual, b.rms_actual)
    assert a.spread_scale == b.spread_scale and np.array_equal(one.rms, two.rms)


def test_p_is_vouched_for_by_the_upper_bound_of_its_standard_error():
    """The P check uses the χ² upper 95 % bound of the pairs' standard error: 2 pairs (1 degree of
    freedom) multiply it by 1/sqrt(χ²₀.₀₅(1)) = 15.95, 4 pairs by sqrt(3/0.3518) = 2.92 (exact values)."""
    def val(samples, se):
        z = np.zeros(samples)
        return Validation(samples=samples, seed=0, relative_error=0.3, spread_error=0.01, shift=np.zeros((3, 3)),
                          rms_shift_se=0.001, rms_actual=z, rms_linear=z, converged=np.ones(samples, bool),
                          p_within_se=se)
    assert np.isclose(val(4, 0.01).p_within_bound, 0.01 / np.sqrt(0.003932140000019526), rtol=1e-6)
    assert np.isclose(val(8, 0.01).p_within_bound, 0.01 * np.sqrt(3 / 0.35184631774927144), rtol=1e-6)
    assert not val(4, 0.01).reliable and "up to 0.16" in val(4, 0.01).why
    assert val(8, 0.01).reliable and val(8, 0.01).why == ""
    assert val(4, None).reliable and np.isnan(val(4, None).p_within_bound)      # no T: nothing to vouch for


def test_align_faces_is_the_deviations_kabsch():
    """A rotated, shifted, perturbed copy: the same aligned points as scipy's align_vectors (compare.deviation)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    target = rng.normal(size=(40, 3))
    faces = np.stack([target @ Rotation.random(random_state=s).as_matrix().T + rng.normal(size=3)
                      + 0.05 * rng.normal(size=(40, 3)) for s in range(3)])
    got = align_faces(faces, target)
    for f, g in zip(faces, got):
        rot, _ = Rotation.align_vectors(target - target.mean(0), f - f.mean(0))
        assert np.allclose(g, (f - f.mean(0)) @ rot.as_matrix().T + target.mean(0), atol=1e-12)
    mirrored = target * [1, 1, -1]       # a reflection is not a rotation: the best proper one, not the mirror
    assert not np.allclose(align_faces(mirrored[None], target)[0], target, atol=1e-3)


def test_pairs_give_the_exact_mean_of_a_quadratic_response():
    """e(δ) = A δ + ½ δᵀ Q δ (per coordinate): each pair's mean is the even part ½ δᵀ Q δ exactly, the mean of
    many pairs is ½ tr(Q Σ) within its sampling error, and a response c A δ has spread error c − 1 exactly."""
    rng = np.random.default_rng(4)
    n, k, p = 5, 3, 4000
    a = rng.normal(size=(n, 3, k))
    b = rng.normal(size=(n, 3, k, k))
    q = 0.5 * (b + b.transpose(0, 1, 3, 2))
    root = rng.normal(size=(k, k)) * 0.1
    sigma = root @ root.T
    delta = antithetic(rng.standard_normal((p, k)) @ root.T)
    assert np.allclose(delta[1::2], -delta[::2])
    lin = np.einsum("nck,sk->snc", a, delta)
    even = 0.5 * np.einsum("sk,nckl,sl->snc", delta, q, delta)
    shift, err, pairs = pair_statistics(lin + even, lin)
    assert np.allclose(pairs, even[::2])                     # the odd part cancels within each pair exactly
    exact = 0.5 * np.einsum("nckl,kl->nc", q, sigma)
    se = np.std(even[::2], axis=0) / np.sqrt(p)
    assert np.all(np.abs(shift - exact) < 4 * se + 1e-15)
    for c in (0.7, 1.0, 1.3):
        s, e, _ = pair_statistics(c * lin + 0.01, lin)
        assert np.allclose(s, 0.01) and np.isclose(e, c - 1)


def test_the_variance_ratio_of_a_cubic_response_is_its_analytic_value():
    """e(z) = a z + b z² + c z³ for z ~ N(0, 1), the model a z: the variance of e about its mean is
    |a|² + 6 a·c + 15 |c|² + 2 |b|² (E z⁴ = 3, E z⁶ = 15, Var z² = 2), so R = that over |a|². Many pairs
    recover it within 4 of their own standard errors; the standard error of 8 pairs is the scatter of
    their estimate over repetitions within the delta method's accuracy at 8 pairs (measured 0.61, hence
    the bound 0.5: a standard error computed from the wrong residual or without √p is off by 2x or more)."""
    rng = np.random.default_rng(6)
    n = 6
    a = rng.normal(size=(n, 3))
    b, c = 0.2 * rng.normal(size=(n, 3)), -0.05 * a + 0.02 * rng.normal(size=(n, 3))
    truth = 1 + (6 * np.sum(a * c) + 15 * np.sum(c * c) + 2 * np.sum(b * b)) / np.sum(a * a)
    assert abs(truth - 1) > 0.1                                    # a nonlinearity the ratio must see

    def ratio(p):
        z = antithetic(rng.standard_normal((p, 1)))[:, 0, None, None]
        return variance_ratio(a * z + b * z ** 2 + c * z ** 3, a * z)
    r, per, se = ratio(4000)
    assert abs(r - truth) < 4 * se and np.isclose(per.mean(), r)
    small = np.array([ratio(8) for _ in range(400)], dtype=object)
    sd, rms_se = np.std(small[:, 0].astype(float)), np.sqrt(np.mean(small[:, 2].astype(float) ** 2))
    assert 0.5 < rms_se / sd < 1.5, (rms_se, sd)
    r1, _, se1 = variance_ratio(np.stack([a, -a]) * 1.1, np.stack([a, -a]))       # one pair: no standard error
    assert np.isclose(r1, 1.21) and np.isnan(se1)


def test_the_spread_scale_shrinks_toward_one_by_the_standard_error():
    """sqrt(1 + w (R − 1)), w = (R − 1)² / ((R − 1)² + se²): whole when exact, half way at one se, 1 when unknown."""
    assert spread_scale(0.81, 0.0) == pytest.approx(0.9) and spread_scale(1.21, 0.0) == pytest.approx(1.1)
    assert spread_scale(0.81, 0.19) == pytest.approx(np.sqrt(1 - 0.19 / 2))
    assert spread_scale(0.81, 1.9) == pytest.approx(1.0, abs=0.01)         # ten se from nothing: barely moved
    assert spread_scale(1.0, 0.1) == 1.0 and spread_scale(float("nan"), 0.1) == 1.0
    assert spread_scale(0.81, float("nan")) == 1.0


def test_rms_shift_se_and_density():
    """Two pairs moving the RMS of a 3 m RMS base by 1 and 3 mm: se = sd/√2 of those moves."""
    base = np.zeros((4, 3))
    base[:, 2] = 3.0
    pairs = np.stack([np.zeros((4, 3)) + [0, 0, 0.001], np.zeros((4, 3)) + [0, 0, 0.003]])
    assert np.isclose(rms_shift_se(base, pairs, 0.0), np.std([0.001, 0.003], ddof=1) / np.sqrt(2))
    assert np.isnan(rms_shift_se(base, pairs[:1], 0.0))
    x = np.random.default_rng(1).normal(2.0, 0.5, 50000)
    assert abs(density_at(x, 2.0) - norm.pdf(0.0) / 0.5) < 0.02 and density_at(x, 10.0) < 1e-6


@pytest.mark.parametrize("cut, reliable", [(0.002, True), (0.040, False)])
def test_the_validation_on_the_coarse_mesh_finds_what_the_checks_own_mesh_finds(cut, reliable):
    """A 20 mm check validates on 40 mm: the same samples there and on 20 mm give the same verdict, the
    same spread error within 0.05 and the same mean shift within 15 % (measured: -0.018 / +0.005 and
    0.062 / 0.062 mm at ±2 mm; -0.344 / -0.353 and 8.6 / 7.9 mm at ±40 mm, where strings go slack)."""
    from airmat.check.face_linearization import linearize
    from airmat.check.tolerance_validation import sample_validation, validation_resolution
    from airmat.inflation.model import Parameters

    design = small_design(LENGTHS, true_sim=LENGTHS)
    run = check(design, resolution=0.02, envelope=False)
    assert validation_resolution(design, 0.02) == pytest.approx(0.04) and validation_resolution(design, 0.04) == 0.04
    coarse = tolerance(design, run=run, validate=8, seed=2, cut_tolerance=cut)
    strings = design_strings(design, "median", lengths=run.lengths)
    lin = linearize(design, run.runs["median"], strings, run.surface, Parameters())
    flat = lin.face.reshape(-1, lin.face.shape[2])
    variance = float(np.einsum("ri,ri->", flat, flat @ coarse.covariance.total))
    fine = sample_validation(design, run, strings, lin, 8, 2, coarse.covariance, Parameters(), variance)
    v = coarse.validation
    assert v.resolution == pytest.approx(0.04) and fine.resolution == pytest.approx(0.02)
    assert v.reliable is fine.reliable is reliable
    assert abs(v.spread_error - fine.spread_error) < 0.05

    def rms(shift):
        return np.sqrt(np.mean(np.sum(shift ** 2, axis=1)))
    assert rms(v.shift) == pytest.approx(rms(fine.shift), rel=0.15)
    assert coarse.block()["validation"]["resolution_mm"] == 40.0 and "40 mm mesh" in coarse.message or not reliable
    # the verdict names the spread error to 0.1 % (a small one does not read "within 0 %")
    assert f"within {100 * abs(v.spread_error):.1f} % of 8 full samples" in coarse.message or not reliable


@pytest.mark.slow
def test_the_validation_mesh_run_is_the_checks_own_continuation_carried_on():
    """The check's median run keeps its continuation's coarser solutions; the validation's run on the 40 mm mesh
    is the 40 mm one carried on to the check's tolerance (a few Newton iterations), the equilibrium a fresh
    40 mm check finds, not a second inflation."""
    from airmat.check.tolerance import _level_run
    from airmat.design.pipeline import DesignParams, design as make_design
    from airmat.design.presets import preset
    from airmat.inflation.model import Parameters

    target, mattress = preset("vault1")
    d = make_design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    run = check(d, resolution=0.02, envelope=False)
    levels = run.runs["median"].inflation.levels
    assert [round(float(np.max(m.spacing)), 4) for m, _ in levels] == [0.0377, 0.074]
    strings = design_strings(d, "median", lengths=run.lengths)
    known = _level_run(d, run, strings, 0.04, Parameters())
    fresh = check(d, resolution=0.04, envelope=False, lengths=run.lengths).runs["median"].inflation
    assert known is not None and known.inflation.converged and known.inflation.n_iter <= 5
    assert np.abs(known.inflation.xyz - fresh.xyz).max() < 1e-6            # m: the same equilibrium
    reused = check(d, resolution=0.04, envelope=False, lengths=run.lengths, known=known)
    assert reused.runs["median"].inflation.n_iter == known.inflation.n_iter   # not inflated again
    assert _level_run(d, run, strings, 0.05, Parameters()) is None          # no level on that mesh
