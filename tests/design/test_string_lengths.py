"""String lengths: Equation 3 over the posterior, sides, representative κ, reach, small κ."""

import numpy as np
import pytest

from analytic_fields import cylinder_field, frame, grid_uv, saddle_field, sphere_like_field
from airmat.calib.model import kappa1, kappa_max, string_length
from airmat.design.calibration_source import CalibrationSource, default_calibration
from airmat.design.field import MattressField
from airmat.design.pattern import Dash
from airmat.design.string_lengths import dash_kappa, length_quantiles, string_pattern
from airmat.design.stripes import StripeParams, trace_stripes

P = StripeParams()
CAL = default_calibration(seed=0, n_samples=500)


def _pattern(mf, cal=CAL, **kw):
    stripes = trace_stripes(mf, P)
    return string_pattern(mf, stripes.dashes, cal, L=P.L, **kw), stripes


def _direct(kappa_abs, cal=CAL, L=P.L):
    """Reference: string_length of this one curvature over the posterior samples, then quantiles."""
    l = string_length(np.full(cal.n_samples, kappa_abs), L, cal.delta, cal.d)
    return np.percentile(l, [50, 2.5, 97.5])


@pytest.mark.parametrize("kappa, side", [(-4.0, "top"), (4.0, "bottom")])
def test_cylinder_strings_match_equation_3_over_the_posterior(kappa, side):
    pattern, stripes = _pattern(cylinder_field(kappa=kappa))
    assert len(pattern.strings) == len(stripes.dashes) > 0
    assert pattern.n_dashes["k2"] == 0 and all(s.dash.family == "k1" for s in pattern.strings)
    ref = _direct(abs(kappa))
    for s in pattern.strings:
        assert s.side == side and s.kappa == pytest.approx(kappa, rel=1e-9)
        np.testing.assert_allclose([s.l_median, s.l_lo95, s.l_hi95], ref, rtol=1e-9)
        assert s.l_lo95 < s.l_median < s.l_hi95 and not s.flags


def test_point_calibration_inverts_equation_3():
    cal = CalibrationSource(L=0.3, delta=np.array([0.018]), d=np.array([0.070]), source="test",
                            uncalibrated=True, label="point")
    for kappa in (0.8, 4.873, 12.0):
        pattern, _ = _pattern(cylinder_field(kappa=-kappa), cal=cal)
        for s in pattern.strings:
            assert s.l_median == s.l_lo95 == s.l_hi95
            assert kappa1(s.l_median, 0.3, 0.018, 0.070) == pytest.approx(kappa, rel=1e-9)


def test_representative_kappa_is_the_mean_of_n_equally_spaced_samples():
    # k1 = -2 - 4 u along u: the mean of equally spaced samples (ends included) is the midpoint value
    uv = grid_uv(0.83, 0.74, 0.05)
    n = len(uv)
    k = np.column_stack([-2.0 - 4.0 * uv[:, 0], np.zeros(n)])
    mf = MattressField(0.83, 0.74, uv, k, frame(np.zeros(n)), np.ones(n))
    dashes = trace_stripes(mf, P).dashes
    kap = dash_kappa(mf, dashes, n_points=10)
    mid = np.array([0.5 * (d.a[0] + d.b[0]) for d in dashes])
    np.testing.assert_allclose(kap, -2.0 - 4.0 * mid, rtol=1e-9)
    # a quadratic field: the mean of N samples differs from the midpoint value, as the definition says
    k2 = np.column_stack([-30.0 * (uv[:, 0] - 0.4) ** 2 - 1.0, np.zeros(n)])
    mf2 = MattressField(0.83, 0.74, uv, k2, frame(np.zeros(n)), np.ones(n))
    for n_points in (2, 10):
        kap2 = dash_kappa(mf2, dashes, n_points=n_points)
        for d, kk in zip(dashes, kap2):
            u = np.linspace(d.a[0], d.b[0], n_points)
            ref = np.mean(mf2.kappa_at(0, np.column_stack([u, np.full(n_points, d.a[1])])))
            assert kk == pytest.approx(ref, rel=1e-9)


def test_sides_follow_the_sign_convention_on_a_saddle():
    pattern, _ = _pattern(saddle_field(kappa=3.0))
    sides = {(s.dash.family, s.side) for s in pattern.strings}
    assert sides == {("k1", "bottom"), ("k2", "top")}  # k1 = +3 bends away from the top normal


def test_sphere_like_field_gives_equal_strings_in_both_families():
    pattern, _ = _pattern(sphere_like_field(kappa=3.0))
    assert pattern.count("bottom", "k1") > 0 and pattern.count("bottom", "k2") > 0
    med = {s.l_median for s in pattern.strings}
    assert max(med) - min(med) < 1e-12


def test_beyond_reach_is_flagged_and_clipped_not_raised():
    kmax = kappa_max(P.L, CAL.delta, CAL.d)
    pattern, _ = _pattern(cylinder_field(kappa=-1.5 * kmax.max()))
    assert pattern.strings and all(s.flags == ("beyond_reach",) for s in pattern.strings)
    assert all(s.l_median == 0.0 and s.l_hi95 == 0.0 for s in pattern.strings)
    assert any("beyond reach" in n for n in pattern.notes)
    # at the posterior median reach about half the samples are clipped: flagged, lo95 = 0
    q, frac = length_quantiles(np.array([np.median(kmax)]), P.L, CAL.delta, CAL.d)
    assert frac[0] == pytest.approx(0.5, abs=0.01) and q[1, 0] == 0.0 and q[2, 0] > 0


def test_small_curvature_gets_no_string_but_is_counted():
    mf = cylinder_field(kappa=-1.0)
    stripes = trace_stripes(mf, P)
    pattern = string_pattern(mf, stripes.dashes, CAL, L=P.L, kappa_min=2.0)
    assert not pattern.strings
    assert pattern.n_no_string["k1"] == len(stripes.dashes) > 0
    assert any("need no string" in n for n in pattern.notes)


def test_curved_dash_is_flagged():
    poly = np.column_stack([0.1 * np.cos(np.linspace(0, 3.0, 61)), 0.1 * np.sin(np.linspace(0, 3.0, 61))])
    poly += [0.4, 0.37]
    length = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
    dash = Dash("k1-001-01", "k1", 1, 1, poly, length)
    pattern = string_pattern(cylinder_field(kappa=-3.0), [dash], CAL, L=length)
    assert "curved" in pattern.strings[0].flags


def test_a_dash_that_curls_on_the_mattress_gets_no_string_and_is_named():
    """A line curling on Ω (a folded Ŝ's principal lines do): a 300 mm dash whose ends lie 40 mm apart is no span
    of Equation 3. It gets no string and the note names it; a dash bent as far as a semicircle keeps its string."""
    def arc(turn, name):
        t = np.linspace(0.0, turn, 121)
        radius = 0.3 / turn
        poly = np.column_stack([radius * np.cos(t), radius * np.sin(t)]) + [0.4, 0.37]
        length = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
        return Dash(name, "k1", 1, 1, poly, length)

    curl, bend = arc(5.6, "k1-001-01"), arc(np.pi, "k1-002-01")
    assert curl.chord < 0.05 and curl.chord < 0.5 * curl.length < bend.chord
    pattern = string_pattern(cylinder_field(kappa=-3.0), [curl, bend], CAL, L=0.3)
    assert [s.dash.id for s in pattern.strings] == ["k1-002-01"] and "curved" in pattern.strings[0].flags
    assert pattern.n_no_string["k1"] == 0          # counted there are the dashes whose |κ| is too small
    assert any("curl" in n and "k1-001-01" in n for n in pattern.notes)
    assert not any("need no string" in n for n in pattern.notes)


def test_length_quantiles_is_one_batch_equal_to_per_dash_calls():
    kap = np.array([0.5, 2.0, 7.0, 10.0])
    q, frac = length_quantiles(kap, P.L, CAL.delta, CAL.d)
    for j, k in enumerate(kap):
        np.testing.assert_allclose(q[:, j], _direct(k), rtol=1e-12)
    assert np.all(frac[:3] == 0)


@pytest.mark.parametrize("snapped", [False, True])
def test_shorter_end_dashes_take_equation_3_at_their_own_span(snapped):
    from airmat.design.tie_grid import snap_dashes

    mf = cylinder_field(kappa=-4.0)
    p = StripeParams(mu1=0.30, end_dashes=True)
    dashes = trace_stripes(mf, p).dashes
    grid = None
    if snapped:
        dashes, grid = snap_dashes(dashes, grid=0.02, width=0.83, height=0.74)
    pattern = string_pattern(mf, dashes, CAL, L=p.L, tie_grid=grid)
    short = [s for s in pattern.strings if s.dash.length < p.L * (1 - 1e-6)]
    assert short
    for s in short:
        np.testing.assert_allclose([s.l_median, s.l_lo95, s.l_hi95], _direct(4.0, L=s.dash.length), rtol=1e-9)
    if not snapped:      # the whole dashes at L exactly, as before
        whole = [s for s in pattern.strings if s.dash.length >= p.L * (1 - 1e-6)]
        assert whole
        for s in whole:
            np.testing.assert_allclose([s.l_median, s.l_lo95, s.l_hi95], _direct(4.0), rtol=1e-9)


def test_the_command_and_the_report_say_which_dashes_curled(tmp_path):
    """The note on curled dashes reaches the user: a line of the command's summary and a banner of report.html."""
    import dataclasses

    from airmat.cli.design import summary_text
    from airmat.design.design_io import document
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset
    from airmat.design.string_lengths import CURL_NOTE
    from airmat.report.design import design_part

    target, mattress = preset("vault1")
    result = design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    note = f"2 {CURL_NOTE} (chord below 0.5 of their length: k1-009-01, k2-003-02): no string"
    assert not any(CURL_NOTE in n for n in result.pattern.notes)          # vault1's lines do not curl
    result = dataclasses.replace(result, pattern=dataclasses.replace(result.pattern,
                                                                     notes=result.pattern.notes + (note,)))
    assert f"  warning: {note}" in summary_text(document(result), tmp_path).splitlines()
    assert note in design_part(result).body
