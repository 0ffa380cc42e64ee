"""Posterior of (Delta, d, sigma): vectorization, bounds, recovery, reproducibility."""

import logging

import numpy as np
import pytest
from scipy.integrate import quad

import airmat.calib.likelihood as lik
from airmat.errors import InputError
from airmat.calib.curve import kappa_curve, most_common_L
from airmat.calib.model import kappa1
from airmat.calib.posterior import (DEFAULT_PRIORS, least_squares_start, log_probability,
                             sample_posterior, specimen_data)

DELTA, D, L = 0.018, 0.070, 0.300


def synthetic(seed, *, sigma=0.10, se=0.03, l_over_L=None, L=L, delta=DELTA, d=D):
    """Seeded curvatures drawn from exactly the model of the posterior."""
    rng = np.random.default_rng(seed)
    ratios = np.linspace(0.3, 0.95, 12) if l_over_L is None else np.asarray(l_over_L)
    l = ratios * L
    s = np.full(l.shape, se) * rng.uniform(0.5, 1.5, l.shape)
    k = np.abs(kappa1(l, L, delta, d) + rng.normal(0.0, np.sqrt(s**2 + sigma**2)))
    return specimen_data(k, s, l, L)


def args_for(data):
    return data, DEFAULT_PRIORS.bounds(float(data.L.min())), DEFAULT_PRIORS.sigma_scale


def test_vectorized_log_prob_equals_per_walker_loop():
    data = synthetic(0)
    rng = np.random.default_rng(1)
    b = DEFAULT_PRIORS.bounds(L)
    theta = rng.uniform(b[:, 0] - 0.1 * np.ptp(b, axis=1), b[:, 1] + 0.1 * np.ptp(b, axis=1),
                        size=(40, 3))
    batch = log_probability(theta, *args_for(data))
    loop = np.array([log_probability(t[None, :], *args_for(data))[0] for t in theta])
    assert batch.shape == (40,)
    assert np.isneginf(batch).any() and np.isfinite(batch).any()
    np.testing.assert_array_equal(np.isneginf(batch), np.isneginf(loop))
    fin = np.isfinite(batch)
    np.testing.assert_allclose(batch[fin], loop[fin], rtol=1e-12, atol=0)


def test_log_prob_is_minus_inf_outside_bounds_without_evaluating_the_model(monkeypatch):
    data = synthetic(0)
    calls = []

    def spy(l, L, delta, d):
        calls.append(np.asarray(delta).size)
        return kappa1(l, L, delta, d)

    monkeypatch.setattr(lik, "kappa1", spy)
    outside = np.array([[-0.001, D, 0.1], [DELTA, 0.001, 0.1], [DELTA, D, -0.1],
                        [DELTA, 0.6, 0.1], [0.07, D, 0.1], [DELTA, D, 25.0]])
    assert np.all(np.isneginf(log_probability(outside, *args_for(data))))
    assert calls == []
    mixed = np.vstack([outside, [[DELTA, D, 0.1]]])
    out = log_probability(mixed, *args_for(data))
    assert np.isfinite(out[-1]) and np.all(np.isneginf(out[:-1]))
    assert calls == [1]  # one model call, for the one walker inside


def test_folded_normal_is_a_density_on_the_half_line():
    for mu, var in ((0.0, 0.04), (0.3, 0.09), (5.0, 0.01)):
        top = mu + 40 * np.sqrt(var)
        total, _ = quad(lambda x: np.exp(lik.folded_normal_logpdf(x, mu, var)), 0, top,
                        points=[mu], limit=200)
        assert total == pytest.approx(1.0, rel=1e-8)


def test_least_squares_start_recovers_noise_free_parameters():
    l = np.linspace(0.3, 0.95, 12) * L
    data = specimen_data(kappa1(l, L, DELTA, D), np.full(12, 0.01), l, L)
    x0, cov = least_squares_start(data, DEFAULT_PRIORS.bounds(L))
    np.testing.assert_allclose(x0[:2], [DELTA, D], rtol=1e-5)
    assert np.all(np.linalg.eigvalsh(cov) > 0)


@pytest.mark.parametrize("seed, L_m, delta, d", [(3, 0.30, 0.018, 0.070), (4, 0.25, 0.010, 0.050)])
def test_posterior_recovers_truth_inside_95_percent(seed, L_m, delta, d):
    data = synthetic(seed, L=L_m, delta=delta, d=d)
    p = sample_posterior(data, seed=seed)
    assert p.converged and p.residual <= 1.0
    assert p.n_steps >= 50 * p.tau.max()
    assert 0.15 < p.acceptance_fraction < 0.8
    assert p.delta.lo95 < delta < p.delta.hi95
    assert p.d.lo95 < d < p.d.hi95
    assert p.sigma.lo95 < 0.10 < p.sigma.hi95
    # informative: the intervals are much narrower than the priors
    assert p.delta.hi95 - p.delta.lo95 < 0.2 * 0.2 * L_m
    assert p.d.hi95 - p.d.lo95 < 0.1 * (0.5 - 0.005)
    assert p.samples.shape[1] == 3 and p.samples.shape[0] == p.log_prob.shape[0] >= 1000


@pytest.mark.slow  # two full chains
def test_flat_specimens_inform_delta():
    ratios = np.array([0.3, 0.36, 0.42, 0.48, 0.54, 0.6, 0.66, 0.72, 0.78, 0.89, 0.92, 0.95])
    data = synthetic(5, l_over_L=ratios)
    flat = ratios * L >= L - 2 * DELTA
    assert flat.sum() == 3
    bent = specimen_data(data.kappa[~flat], data.kappa_se[~flat], data.l[~flat], data.L[~flat])
    with_flat = sample_posterior(data, seed=0)
    without = sample_posterior(bent, seed=0)
    width = lambda p: p.delta.hi95 - p.delta.lo95  # noqa: E731
    assert with_flat.delta.lo95 < DELTA < with_flat.delta.hi95
    assert width(with_flat) < width(without)


def test_flat_specimen_likelihood_penalizes_a_delta_that_would_bend_it():
    # one flat specimen (l = 0.9 L): it stays flat for Delta >= 0.05 L = 15 mm
    l = np.array([0.27, 0.09, 0.15])
    data = specimen_data([0.0, kappa1(0.09, L, DELTA, D), kappa1(0.15, L, DELTA, D)],
                         [0.02, 0.02, 0.02], l, L)
    deltas = np.array([0.010, 0.013, 0.0155, 0.018, 0.025])
    theta = np.column_stack([deltas, np.full(5, D), np.full(5, 0.01)])
    lp = log_probability(theta, *args_for(data))
    flat_part = lik.folded_normal_logpdf(0.0, kappa1(0.27, L, deltas, D), 0.02**2 + 0.01**2)
    assert np.all(np.diff(flat_part[:3]) > 0) and flat_part[2] == flat_part[3] == flat_part[4]
    assert lp[3] == lp.max()  # the truth


def test_seeded_runs_are_reproducible():
    data = synthetic(6)
    a = sample_posterior(data, seed=11, max_steps=150)
    b = sample_posterior(data, seed=11, max_steps=150)
    c = sample_posterior(data, seed=12, max_steps=150)
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.log_prob, b.log_prob)
    assert not np.array_equal(a.samples, c.samples)


def test_short_chain_is_flagged_not_converged(caplog):
    data = synthetic(7)
    with caplog.at_level(logging.WARNING, logger="airmat.calib.posterior"):
        p = sample_posterior(data, seed=0, max_steps=60, chunk=30)
    assert not p.converged and p.residual > 1.0 and p.n_steps == 60 == p.n_iter
    assert "NOT converged" in p.message
    assert any("NOT converged" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("kwargs, match", [
    (dict(kappa=[1.0, -1.0, 2.0]), "kappa >= 0"),
    (dict(kappa_se=[0.1, 0.0, 0.1]), "kappa_se > 0"),
    (dict(l=[0.1, 0.4, 0.2]), "l <= L"),
    (dict(kappa=[1.0, np.nan, 2.0]), "non-finite"),
    (dict(kappa=[1.0, 2.0], kappa_se=[0.1, 0.1], l=[0.1, 0.2]), "parameters"),
    (dict(kappa_se=[0.1, 0.1]), "entries"),
])
def test_specimen_data_rejects_bad_input(kwargs, match):
    base = dict(kappa=[1.0, 2.0, 3.0], kappa_se=[0.1, 0.1, 0.1], l=[0.1, 0.15, 0.2], L=0.3)
    base.update(kwargs)
    with pytest.raises(InputError, match=match):
        specimen_data(**base)


def test_too_few_walkers_is_an_input_error():
    with pytest.raises(InputError, match="walkers"):
        sample_posterior(synthetic(0), n_walkers=4)


def test_curve_bands_are_ordered_and_match_the_model_at_the_truth():
    rng = np.random.default_rng(0)
    samples = np.column_stack([rng.normal(DELTA, 0.001, 3000), rng.normal(D, 0.003, 3000),
                               np.full(3000, 0.1)])
    c = kappa_curve(samples, L, n_grid=41, max_draws=1500, seed=0)
    assert c.n_draws == 1500 and c.l_over_L[0] == 0 and c.l_over_L[-1] == 1
    assert np.all(c.lo95 <= c.lo68) and np.all(c.lo68 <= c.median)
    assert np.all(c.median <= c.hi68) and np.all(c.hi68 <= c.hi95)
    truth = kappa1(c.l_over_L * L, L, DELTA, D)
    bent = c.l_over_L < 0.8
    assert np.all(np.abs(c.median[bent] - truth[bent]) < 0.02 * truth[bent])
    assert c.median[-1] == 0.0 and c.hi95[-1] == 0.0  # l = L is flat for any Delta >= 0
    assert most_common_L([0.3, 0.25, 0.3, 0.25, 0.3]) == 0.3
