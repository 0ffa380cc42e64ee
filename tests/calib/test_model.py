"""Equation 3 (airmat.calib.model) against a bracketed scalar root solve and its own inverse."""

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy.optimize import brentq

from airmat.errors import InputError
from airmat.calib.model import bend_angle, flat_length, kappa1, kappa_max, string_length

PAPER = dict(L=0.300, delta=0.018, d=0.070)


def kappa1_scalar(l, L, delta, d):
    """Reference: scipy.optimize.brentq on Equation 3 for one string."""
    if l + 2 * delta >= L:
        return 0.0
    lo = max(np.pi - L / d, 0.0)
    g = lambda th: (L - (np.pi - th) * d) * np.sin(th / 2) - (l + 2 * delta)
    theta = brentq(g, lo, np.pi, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=500)
    return 2 * np.cos(theta / 2) / (L - (np.pi - theta) * d)


@pytest.mark.parametrize("L,delta,d", [(0.3, 0.018, 0.07), (0.3, 0.0, 0.07), (0.5, 0.01, 0.1), (0.3, 0.02, 0.05)])
def test_kappa1_matches_scalar_root_solve(L, delta, d):
    ls = np.linspace(0.0, L, 41)
    ref = np.array([kappa1_scalar(l, L, delta, d) for l in ls])
    got = kappa1(ls, L, delta, d)
    bent = ref > 0
    np.testing.assert_allclose(got[bent], ref[bent], rtol=1e-10)
    np.testing.assert_array_equal(got[~bent], 0.0)


def test_kappa1_paper_value_and_flat_threshold():
    # the flat threshold l = L - 2 delta separates bent from flat
    lf = float(flat_length(PAPER["L"], PAPER["delta"]))
    assert lf == pytest.approx(0.264)
    assert kappa1(lf + 1e-6, **PAPER) == 0.0
    assert kappa1(lf - 1e-3, **PAPER) > 0.0
    assert bend_angle(PAPER["L"], **PAPER) == np.pi


def test_kappa1_decreases_monotonically_in_l():
    ls = np.linspace(0.0, 0.264, 500)
    k = kappa1(ls, **PAPER)
    assert np.all(np.diff(k) < 0)
    assert k[0] == pytest.approx(kappa_max(**PAPER))


def test_broadcast_walkers_by_specimens():
    rng = np.random.default_rng(1)
    delta = rng.uniform(0.0, 0.04, size=(32, 1))
    d = rng.uniform(0.04, 0.12, size=(32, 1))
    l = np.linspace(0.09, 0.3, 12)[None, :]
    k = kappa1(l, 0.3, delta, d)
    assert k.shape == (32, 12)
    i, j = 7, 4
    assert k[i, j] == pytest.approx(kappa1_scalar(l[0, j], 0.3, delta[i, 0], d[i, 0]), rel=1e-10)


@settings(max_examples=200, deadline=None)
@given(frac=st.floats(0.0, 1.0), L=st.floats(0.05, 2.0), delta_frac=st.floats(0.0, 0.2), d=st.floats(0.01, 0.3))
def test_inverse_of_forward_is_identity(frac, L, delta_frac, d):
    delta = delta_frac * L
    l = frac * float(flat_length(L, delta)) * 0.999
    k = kappa1(l, L, delta, d)
    assume(np.isfinite(k))  # l = delta = 0 closes the bend (kappa = inf): no inverse
    l_back = string_length(k, L, delta, d)
    assert l_back == pytest.approx(l, rel=1e-9, abs=1e-12 * L)


def test_closed_bend_is_infinite_curvature():
    assert kappa1(0.0, 0.05, 0.0, 0.25) == np.inf
    assert kappa1(0.0, 0.3, 0.0, 0.07) == pytest.approx(2 / (0.3 - np.pi * 0.07))  # L > pi d: theta = 0
    assert string_length(1e6, 0.05, 0.0, 0.25) == pytest.approx(0.0, abs=1e-6)


def test_string_length_at_the_largest_curvature_is_zero():
    kmax = kappa_max(**PAPER)
    assert string_length(kmax, **PAPER) == pytest.approx(0.0, abs=1e-9)
    assert string_length(kmax * (1 - 1e-9), **PAPER) == pytest.approx(0.0, abs=1e-6)


def test_string_length_of_zero_curvature_is_flat_threshold():
    assert string_length(0.0, **PAPER) == pytest.approx(0.264)


@pytest.mark.parametrize("kwargs,match", [
    (dict(L=0.0, delta=0.018, d=0.07), "L"),
    (dict(L=0.3, delta=0.018, d=0.0), "d"),
    (dict(L=0.3, delta=-0.001, d=0.07), "delta"),
])
def test_non_physical_parameters_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        kappa1(0.1, **kwargs)
    with pytest.raises(ValueError, match=match):
        string_length(1.0, **kwargs)


def test_unreachable_curvature_names_the_largest_reachable():
    kmax = float(kappa_max(**PAPER))
    with pytest.raises(InputError, match=f"{kmax:.4g}") as info:
        string_length([1.0, kmax * 1.5], **PAPER)
    assert info.value.data["kappa_max"].max() == pytest.approx(kmax)
    assert isinstance(info.value, ValueError)


def test_negative_inputs_raise():
    with pytest.raises(ValueError):
        string_length(-1.0, **PAPER)
    with pytest.raises(ValueError):
        kappa1(-0.01, **PAPER)


def test_polygon_side_is_the_span_less_the_wrinkles_and_gives_kappa1():
    from airmat.calib.model import bend_angle, kappa1, polygon_side

    L, delta, d = 0.3, 0.01, 0.07
    l = np.array([0.05, 0.12, 0.2, 0.27, 0.28, 0.35])          # the last two flat: l + 2 delta >= L
    theta, side = bend_angle(l, L, delta, d), polygon_side(l, L, delta, d)
    np.testing.assert_allclose(side, L - (np.pi - theta) * d, rtol=1e-15)
    bent = l + 2 * delta < L
    assert np.all(side[bent] < L) and np.all(side[~bent] == L)
    # Equation 3: the circle through the folds of a polygon of side L* and interior angle theta
    np.testing.assert_allclose(2 * np.cos(theta[bent] / 2) / side[bent], kappa1(l[bent], L, delta, d), rtol=1e-12)
    # Equation 1 on that polygon: the string is the chord of the two half sides
    np.testing.assert_allclose((l[bent] + 2 * delta) / side[bent], np.sin(theta[bent] / 2), rtol=1e-9)
