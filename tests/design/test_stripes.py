"""Stripe tracer on analytic fields: straight cylinder lines, spacing, stagger, margins, circles."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from airmat.errors import InputError
from analytic_fields import (concentric_field, cylinder_field, linear_cylinder_field, saddle_field,
                             sphere_like_field)
from airmat.design.stripes import StripeParams, cut_dashes, trace_stripes

P = StripeParams()  # L 0.30, mu1 0.40, mu2 0.10, margin 0.03, step 0.01


def _along_across(angle):
    t = np.array([np.cos(angle), np.sin(angle)])
    n = np.array([-t[1], t[0]])
    return t, n


@pytest.fixture(scope="module")
def cylinder():
    return trace_stripes(cylinder_field(kappa=-4.0))


def test_cylinder_k1_lines_are_straight_along_the_bending_direction_and_mu2_apart(cylinder):
    k1, k2 = cylinder.families
    assert k1.dashes and not k2.dashes and not k2.lines.lines
    assert "needs no strings" in k2.note
    for d in k1.dashes:  # horizontal: v constant along every dash
        assert np.ptp(d.polyline[:, 1]) < 1e-9
    rows = np.unique(np.round([d.a[1] for d in k1.dashes], 9))
    np.testing.assert_allclose(np.diff(rows), P.mu2, rtol=1e-9)
    # as many rows as fit inside the margin, centred on the mattress
    expected = np.arange(0.37 - 3 * P.mu2, 0.74 - P.margin, P.mu2)
    np.testing.assert_allclose(rows, expected[expected >= P.margin], atol=1e-9)


@pytest.mark.parametrize("angle", [0.0, np.pi / 6, np.pi / 2])
def test_rotated_cylinder_lines_are_straight_spaced_and_staggered(angle):
    s = trace_stripes(cylinder_field(kappa=5.0, angle=angle))
    t, n = _along_across(angle)
    fam = s.families[0]
    assert len(fam.dashes) >= 4
    for d in fam.dashes:
        assert np.ptp(d.polyline @ n) < 1e-6 * P.L  # straight, along the k1 direction
        np.testing.assert_allclose(d.chord, P.L, rtol=1e-9)
    lines = fam.lines.lines
    across = np.array([np.mean(line.points @ n) for line in lines])
    for line in lines:
        assert np.ptp(line.points @ n) < 1e-6 * P.L
    order = np.argsort(across)
    np.testing.assert_allclose(np.diff(across[order]), P.mu2, rtol=1e-6)
    # staggered: the dash grids of neighbouring lines are half a period apart along t
    direction = np.array([np.sign((line.points[-1] - line.points[0]) @ t) for line in lines])
    grid0 = np.array([(line.points[0] @ t) * sg + ph for line, sg, ph in zip(lines, direction, fam.phases)])
    assert np.all(direction == direction[0])
    shift = np.diff(grid0[order]) % P.mu1
    np.testing.assert_allclose(shift, P.mu1 / 2, atol=1e-6)
    # and every dash starts on its line's grid
    for d in fam.dashes:
        i = next(k for k, line in enumerate(lines) if abs(np.mean(line.points @ n) - d.a @ n) < 1e-6)
        offset = (direction[i] * (d.a @ t) - grid0[i]) % P.mu1
        assert min(offset, P.mu1 - offset) < 1e-6


@pytest.fixture(scope="module")
def concentric():
    mf = concentric_field()  # one field: its interpolator (a Delaunay triangulation) is built once
    return mf, trace_stripes(mf, P)


def test_dashes_have_arc_length_L_and_stay_inside_the_margin(concentric):
    mf, s = concentric
    assert s.families[0].dashes and s.families[1].dashes
    for d in s.dashes:
        assert d.length == pytest.approx(P.L, rel=1e-9)
        seg = np.linalg.norm(np.diff(d.polyline, axis=0), axis=1)
        assert seg.max() <= P.step_used * (1 + 1e-9)
        assert np.all(mf.contains(d.polyline, P.margin))


def test_concentric_k1_lines_follow_circles_and_keep_their_distance(concentric):
    mf, s = concentric
    centre = np.array([mf.width / 2, mf.height / 2])
    h = P.step_used
    for d in s.families[0].dashes:
        rho = np.linalg.norm(d.polyline - centre, axis=1)
        # second-order tracing (and the bilinear field) drift off a circle of radius rho by O(h^2 / rho)
        assert np.ptp(rho) < h ** 2 / rho.min()
    lines = s.families[0].lines.lines
    for i, a in enumerate(lines):
        for b in lines[i + 1:]:
            dmin = np.min(np.linalg.norm(a.points[:, None] - b.points[None], axis=2))
            assert dmin >= 0.5 * P.mu2 - 2 * h  # Jobard-Lefer d_test, up to the step


def test_low_weight_stops_lines_near_the_umbilic(concentric):
    mf, _ = concentric
    s = trace_stripes(mf, StripeParams(weight_min=0.5))  # weight = rho / 0.1 m
    centre = np.array([mf.width / 2, mf.height / 2])
    for fam in s.families:
        for line in fam.lines.lines:
            rho = np.linalg.norm(line.points - centre, axis=1)
            assert rho.min() >= 0.05 - 2 * P.step_used
    assert any(fam.lines.stop_counts.get("low_weight", 0) for fam in s.families)
    assert any("umbilics" in note for note in s.notes)


def test_sphere_like_and_saddle_fields_give_both_families():
    for mf in (sphere_like_field(kappa=3.0), saddle_field(kappa=3.0)):
        s = trace_stripes(mf)
        k1, k2 = s.families
        assert k1.dashes and k2.dashes
        t1 = np.array([mf.direction_at(0, d.a[None])[0] for d in k1.dashes])
        for d, t in zip(k1.dashes, t1):
            chord = (d.b - d.a) / d.chord
            assert abs(chord @ t) == pytest.approx(1.0, abs=1e-9)  # along k1
        for d in k2.dashes:
            t = mf.direction_at(1, d.a[None])[0]
            assert abs((d.b - d.a) @ t) / d.chord == pytest.approx(1.0, abs=1e-9)


def test_small_curvature_family_is_skipped_and_said():
    s = trace_stripes(cylinder_field(kappa=0.1), StripeParams(kappa_min=0.25))
    assert not s.dashes
    assert all("needs no strings" in note for note in s.notes)


def test_lines_run_through_flat_parts_but_are_only_seeded_where_curved():
    # k1 = -2 - 6 v: |k1| >= 0.25 everywhere -> rows everywhere; with kappa_min 3 only v >= 1/6 m seeds
    mf = linear_cylinder_field()
    s = trace_stripes(mf, StripeParams(kappa_min=3.0))
    rows = np.unique(np.round([d.a[1] for d in s.families[0].dashes], 9))
    assert rows.min() >= (3.0 - 2.0) / 6.0 - 1e-9
    np.testing.assert_allclose(np.diff(rows), P.mu2, rtol=1e-9)


def test_same_input_gives_identical_dashes():
    a = trace_stripes(saddle_field())
    b = trace_stripes(saddle_field())
    assert [d.id for d in a.dashes] == [d.id for d in b.dashes]
    for da, db in zip(a.dashes, b.dashes):
        np.testing.assert_array_equal(da.polyline, db.polyline)


def test_ids_number_lines_and_dashes_from_one(cylinder):
    s = cylinder
    ids = [d.id for d in s.dashes]
    assert len(set(ids)) == len(ids)
    assert ids[0] == "k1-001-01"
    for d in s.dashes:
        fam, line, idx = d.id.split("-")
        assert (fam, int(line), int(idx)) == (d.family, d.line, d.index)


@pytest.mark.parametrize("kwargs, word", [
    (dict(mu1=0.2), "mu1"),
    (dict(L=0.9, mu1=1.0), "longer than the mattress"),
    (dict(mu2=0.0), "mu2"),
    (dict(mu2=-0.1), "mu2"),
    (dict(margin=0.5), "margin"),
    (dict(step=0.2), "step"),
])
def test_impossible_parameters_raise_input_error(kwargs, word):
    with pytest.raises(InputError, match=word):
        trace_stripes(cylinder_field(), StripeParams(**kwargs))


def test_cut_dashes_on_a_polyline_is_exact():
    pts = np.column_stack([np.linspace(0, 1.0, 101), np.zeros(101)])
    arc = pts[:, 0].copy()
    pieces = cut_dashes(pts, arc, phase=0.05, L=0.3, mu1=0.4)
    starts = [p[0, 0] for p in pieces]
    np.testing.assert_allclose(starts, [0.05, 0.45])  # 0.85 + 0.3 > 1
    for p in pieces:
        assert np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)) == pytest.approx(0.3, rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(turns=st.lists(st.floats(-0.3, 0.3), min_size=20, max_size=200),
       phase=st.floats(0.0, 0.399), L=st.floats(0.05, 0.3), extra=st.floats(0.0, 0.2))
def test_cut_dashes_invariants_on_random_polylines(turns, phase, L, extra):
    # a random smooth-ish polyline of 10 mm segments
    angle = np.cumsum(turns)
    pts = np.concatenate([[[0.0, 0.0]], 0.01 * np.cumsum(np.column_stack([np.cos(angle), np.sin(angle)]), 0)])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    mu1 = L + extra
    phase = phase % mu1
    pieces = cut_dashes(pts, arc, phase=phase, L=L, mu1=mu1)
    assert len(pieces) == max(int(np.floor((arc[-1] - L - phase) / mu1 + 1e-9)) + 1, 0)
    for k, p in enumerate(pieces):
        assert np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)) == pytest.approx(L, rel=1e-9)
        s0 = phase + k * mu1  # starts on the grid, in order, never overlapping
        np.testing.assert_allclose(p[0], [np.interp(s0, arc, pts[:, j]) for j in (0, 1)], atol=1e-12)


@pytest.mark.parametrize("mu1", [0.30, 0.40])
def test_end_dashes_fill_the_line_ends_with_shorter_dashes_inside_the_margin(mu1):
    mf = cylinder_field(kappa=-4.0)
    p = StripeParams(mu1=mu1, end_dashes=True, L_end_min=0.05)
    off = trace_stripes(mf, StripeParams(mu1=mu1))
    on = trace_stripes(mf, p)
    whole = [d for d in on.dashes if d.length == pytest.approx(p.L, rel=1e-9)]
    short = [d for d in on.dashes if d.length < p.L * (1 - 1e-9)]
    # the whole dashes are the same; the shorter ones come in addition, each within [L_end_min, L)
    assert [d.polyline.tolist() for d in whole] == [d.polyline.tolist() for d in off.dashes]
    assert short and all(p.L_end_min - 1e-9 <= d.length < p.L for d in short)
    assert all(np.all(mf.contains(d.polyline, p.margin)) for d in on.dashes)
    assert "shorter end dashes" in on.families[0].note
    # along each line the dashes keep at least the gap mu1 - L between them, numbered in order
    for line in {d.line for d in on.dashes}:
        ds = sorted((d for d in on.dashes if d.line == line), key=lambda d: d.index)
        assert [d.index for d in ds] == list(range(1, len(ds) + 1))
        for a, b in zip(ds, ds[1:]):
            gap = np.linalg.norm(b.polyline[0] - a.polyline[-1])
            assert gap >= mu1 - p.L - 1e-6


def test_end_dashes_need_a_minimum_in_range():
    with pytest.raises(InputError, match=r"shortest end dash must be in \(0, L = 300 mm\], got 400 mm"):
        trace_stripes(cylinder_field(kappa=-4.0), StripeParams(end_dashes=True, L_end_min=0.4))
