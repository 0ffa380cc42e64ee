"""End to end on developable targets: σ ≈ 1, no k2 strings, k1 strings that invert the local curvature."""

import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator

from airmat.errors import InputError
from airmat.calib.model import kappa1, string_length
from airmat.synthetic.targets import cone, cylinder
from airmat.design.calibration_source import CalibrationSource
from airmat.design.mattress import Mattress
from airmat.design.design_io import OUTPUT_FILES, write_design
from airmat.design.pipeline import DesignParams, design

MATTRESS = Mattress(0.83, 0.74)
#: a point calibration (the paper's values), so that l inverts Equation 3 exactly
POINT = CalibrationSource(L=0.3, delta=np.array([0.018]), d=np.array([0.070]), source="test",
                          uncalibrated=True, label="paper point values")
PARAMS = DesignParams(spacing=0.04)  # coarse Ω mesh: fast; curvature still within a few percent
#: relative error allowed on curvature estimated from a 40 mm mesh of Ŝ (observed below 2 %)
KAPPA_RTOL = 0.03


def _dash_points_on_S(result, string, n=10):
    """The dash's N equally spaced points (as in §3.3.3) carried from Ω to Ŝ (m)."""
    poly = string.dash.polyline
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poly, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], n)
    pts = np.column_stack([np.interp(t, s, poly[:, 0]), np.interp(t, s, poly[:, 1])])
    return LinearNDInterpolator(result.approx.uv, result.approx.xyz)(pts)


@pytest.fixture(scope="module")
def cyl():
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.02)
    return surf, design(surf, MATTRESS, calibration=POINT, params=PARAMS, progress=False)


@pytest.fixture(scope="module")
def con():
    surf = cone(r_crown=0.35, half_angle=0.2, length=1.2, arc=1.0, spacing=0.02)
    return surf, design(surf, MATTRESS, calibration=POINT, params=PARAMS, progress=False)


def test_cylinder_is_developable_and_needs_only_k1_strings(cyl):
    surf, r = cyl
    sigma = r.approx.report.sigma
    assert abs(sigma["min"] - 1) < 0.005 and abs(sigma["max"] - 1) < 0.005
    assert r.approx.report.constructible
    assert r.pattern.strings and all(s.dash.family == "k1" for s in r.pattern.strings)
    assert r.pattern.n_dashes["k2"] == 0 and "needs no strings" in r.stripes.families[1].note
    # bends away from the top (up) normal: kappa > 0, strings on the bottom face
    assert all(s.side == "bottom" and s.kappa > 0 for s in r.pattern.strings)


def test_cylinder_strings_invert_the_curvature_1_over_R(cyl):
    surf, r = cyl
    k_true = 1.0 / surf.params["radius"]
    for s in r.pattern.strings:
        assert s.kappa == pytest.approx(k_true, rel=KAPPA_RTOL)
        # the ends are tied to the 20 mm grid: Equation 3 at the dash's own (snapped) L, times what
        # its free face (the top face, Ŝ itself) keeps of it on Ŝ: a developable Ŝ keeps it all
        assert s.dash.length * 0.995 <= s.free_span <= s.dash.length
        L = s.eq3_span
        assert kappa1(s.l_median, L, 0.018, 0.070) == pytest.approx(s.kappa, rel=1e-9)
        assert s.l_median == pytest.approx(float(string_length(k_true, L, 0.018, 0.070)), abs=0.005)
        # the dash runs around the axis (x): its chord on Ŝ is perpendicular to it, up to the
        # snapping of each end to the 20 mm grid (at most half a cell, 10 mm, along x)
        p = _dash_points_on_S(r, s)
        chord = p[-1] - p[0]
        assert abs(chord[0]) < 0.05 * np.linalg.norm(chord) + 2 * 0.010


def test_cone_strings_follow_the_local_curvature(con):
    surf, r = con
    assert abs(r.approx.report.sigma["min"] - 1) < 0.005 and abs(r.approx.report.sigma["max"] - 1) < 0.005
    assert r.pattern.strings and all(s.dash.family == "k1" for s in r.pattern.strings)
    kappas = []
    for s in r.pattern.strings:
        k_true = float(np.mean(surf.curvature(_dash_points_on_S(r, s))[0][:, 0]))
        assert s.kappa == pytest.approx(k_true, rel=KAPPA_RTOL)
        # a developable Ŝ keeps its free face's length: Equation 3 at (nearly) the dash's span
        assert s.dash.length * 0.995 <= s.free_span <= s.dash.length
        assert kappa1(s.l_median, s.eq3_span, 0.018, 0.070) == pytest.approx(s.kappa, rel=1e-9)
        kappas.append(k_true)
    assert np.ptp(kappas) > 0.2 * np.mean(kappas)  # the test sees a real variation along the cone


def test_impossible_parameters_fail_before_any_work():
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.05)
    with pytest.raises(InputError, match="mu1"):
        design(surf, MATTRESS, params=DesignParams(mu1=0.2), progress=False)
    with pytest.raises(InputError, match="longer than the mattress"):
        design(surf, Mattress(0.32, 0.25), params=DesignParams(), progress=False)


def test_write_design_writes_every_file(cyl, tmp_path):
    _, r = cyl
    doc = write_design(r, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(OUTPUT_FILES)
    assert doc["report"]["constructible"] is True and doc["summary"]["strings"]["top"] == {"k1": 0, "k2": 0}
    assert doc["parameters"]["L_mm"] == 300.0 and doc["calibration"]["source"] == "test"


@pytest.mark.parametrize("fixture", ["cyl", "con"])
def test_string_ends_sit_on_the_20mm_grid_and_L_is_their_span(fixture, request):
    _, r = request.getfixturevalue(fixture)
    assert r.params.tie_grid == 0.02 and r.pattern.tie_grid.grid == 0.02
    for s in r.pattern.strings:
        d = s.dash
        for end, node in ((d.a, d.a_node), (d.b, d.b_node)):
            np.testing.assert_allclose(end, [node[1] * 0.02, node[0] * 0.02], atol=1e-12)
        arc = np.linalg.norm(np.diff(d.polyline, axis=0), axis=1).sum()
        assert d.length == pytest.approx(arc, rel=1e-12)
        # snapping moves an end by at most half a cell diagonal, so L by at most one diagonal
        assert abs(d.length - 0.3) <= 0.02 * np.sqrt(2) + 0.005
    shift = r.pattern.tie_grid.end_shift
    assert shift.max() <= 0.01 * np.sqrt(2) + 1e-12 and shift.mean() > 0


def test_free_ends_keep_L_and_equation_3_at_L():
    """With free ends and the paper's rule (--dash-span) every string is Equation 3 at L exactly."""
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.05)
    r = design(surf, MATTRESS, calibration=POINT, params=DesignParams(spacing=0.04, tie_grid=0.0,
                                                                      free_face_span=False), progress=False)
    assert r.pattern.strings
    for s in r.pattern.strings:
        assert s.dash.a_node is None and s.dash.b_node is None and s.free_span is None
        assert kappa1(s.l_median, 0.3, 0.018, 0.070) == pytest.approx(s.kappa, rel=1e-9)
        # free ends: the dash runs exactly around the axis (x), its chord on Ŝ perpendicular to it
        p = _dash_points_on_S(r, s)
        chord = p[-1] - p[0]
        assert abs(chord[0]) < 0.05 * np.linalg.norm(chord)


def test_negative_tie_grid_is_refused():
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.05)
    with pytest.raises(InputError, match="tie grid"):
        design(surf, MATTRESS, params=DesignParams(tie_grid=-0.02), progress=False)


def test_a_span_other_than_the_calibrations_is_said(cyl, caplog):
    """Equation 3 is calibrated at the calibration's L; a design at another L says its lengths are
    extrapolated (in the notes that design.json and the drawings carry, and as a warning)."""
    _, at_L = cyl
    assert not any("extrapolated" in n for n in at_L.pattern.notes)
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.05)
    with caplog.at_level("WARNING", logger="airmat.design.pipeline"):
        r = design(surf, MATTRESS, calibration=POINT, params=DesignParams(spacing=0.04, L=0.2), progress=False)
    (note,) = [n for n in r.pattern.notes if "extrapolated" in n]
    assert "L = 200 mm" in note and "L = 300 mm" in note and "airmat validate --L-mm" in note
    assert any("extrapolated" in m for m in caplog.messages)
