"""Developable targets that do not cover the mattress: Ŝ continues S across its rim, unstrained."""

import logging

import numpy as np
import pytest

from airmat.synthetic.targets import cone, cylinder
from airmat.design.calibration_source import CalibrationSource
from airmat.design.mattress import Mattress
from airmat.design.pipeline import DesignParams, design
from airmat.design.surface import approximate_surface

MATTRESS = Mattress(0.83, 0.74)
POINT = CalibrationSource(L=0.3, delta=np.array([0.018]), d=np.array([0.070]), source="test",
                          uncalibrated=True, label="paper point values")
PARAMS = DesignParams(spacing=0.04)

TARGETS = {
    # the arc around the axis shrinks with the radius: 0.55 m at the narrow end of the mattress
    "cone, narrow end narrower than the mattress": lambda: cone(r_crown=0.3, half_angle=0.3, length=1.0,
                                                                arc=0.8, spacing=0.02),
    # 0.6 m of axis under the 0.83 m side: the mattress overhangs both ends
    "cylinder, axis shorter than the mattress": lambda: cylinder(0.4, length=0.6, arc=1.2, spacing=0.02),
    # 0.6 m of arc under the 0.74 m side: the mattress overhangs both straight rims
    "cylinder, arc shorter than the mattress": lambda: cylinder(0.4, length=1.2, arc=0.6, spacing=0.02),
}


@pytest.fixture(scope="module", params=list(TARGETS))
def overhang(request):
    surf = TARGETS[request.param]()
    return surf, design(surf, MATTRESS, calibration=POINT, params=PARAMS, progress=False)


def test_overhanging_developable_target_is_made_unstrained(overhang):
    _, r = overhang
    a = r.approx
    assert a.relax.converged and a.relax.n_iter < 100
    assert 0.995 <= a.report.sigma["min"] and a.report.sigma["max"] <= 1.005
    assert a.report.constructible and not a.report.reasons


def test_overhanging_developable_target_needs_only_k1_strings_on_one_face(overhang):
    _, r = overhang
    assert r.pattern.strings and all(s.dash.family == "k1" for s in r.pattern.strings)
    assert r.pattern.n_dashes["k2"] == 0
    assert {s.side for s in r.pattern.strings} == {"bottom"}     # bends away from the top normal


def test_the_part_off_the_target_is_a_warning_with_share_and_distance(overhang):
    _, r = overhang
    a = r.approx
    off = a.report.off_target
    assert 0.005 < off["share"] < 0.5 and 0.01 < off["max"] < 0.3
    # the largest distance beyond the rim is that of a vertex of Ŝ from S
    assert off["max"] == pytest.approx(a.relax.off_target.max())
    assert len(a.report.warnings) == 1 and "beyond the target's rim" in a.report.warnings[0]


def test_the_warning_is_logged(caplog):
    surf = TARGETS["cylinder, arc shorter than the mattress"]()
    with caplog.at_level(logging.WARNING, logger="airmat.design.surface"):
        approx = approximate_surface(surf, MATTRESS, spacing=0.04, progress=False)
    assert approx.report.constructible
    assert [r.getMessage() for r in caplog.records] == [f"Ŝ of {surf.name}: {approx.report.warnings[0]}"]


def test_the_part_on_the_target_lies_on_it(overhang):
    _, r = overhang
    a = r.approx
    on = a.relax.off_target == 0
    assert on.mean() > 0.5
    from airmat.design.closest_point import MeshProjector

    d = MeshProjector(a.target.vertices, a.target.faces).closest(a.xyz[on]).distance
    assert d.max() < 1e-3        # within 1 mm of S (40 mm mesh of Ŝ, 20 mm mesh of S)
