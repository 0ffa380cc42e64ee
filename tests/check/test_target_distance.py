"""The inflated face's distance to the user's target S beside its deviation from Ŝ (airmat.check.compare).

Distance to a set is 1-Lipschitz, so for every vertex i of Ŝ, with F_i the aligned inflated face
at it and dev_i = |F_i − Ŝ_i|: |d_S(F_i) − d_S(Ŝ_i)| ≤ dev_i. The tests check that bound on a
developable cylinder (Ŝ on S: both distances agree within the relaxation's own distance to S) and
on a dome (Ŝ leaves S: the inflated face is at least that far from S, less its deviation).
"""

from dataclasses import replace

import numpy as np
import pytest

from airmat.check.compare import distance_to_target
from airmat.check.inflation_check import check
from airmat.check.report import TO_TARGET_NOTE, check_dict
from airmat.design.mattress import Mattress
from airmat.design.pipeline import DesignParams, design
from airmat.synthetic.zoo import by_name

#: the closest triangle is found in float32 (open3d) around S's centre: a foot may be off by that rounding (m)
FLOAT32_SLACK = 1e-5


def _checked(name, **params):
    e = by_name(name)
    d = design(e, Mattress(*e.mattress), params=DesignParams(spacing=0.04, **params), progress=False)
    return d, check(d, resolution=0.04, envelope=False)


def _approx_to_s(d):
    a = d.approx
    return distance_to_target(a.xyz, a.target, diagonal=float(np.linalg.norm(np.ptp(a.xyz, axis=0))))


@pytest.fixture(scope="module")
def cylinder():
    return _checked("cylinder-r300")


@pytest.fixture(scope="module")
def dome():
    """The plain Ŝ of a dome (no fold route): it strains the membrane beyond its band, and leaves S least."""
    return _checked("dome-r450", folds=False)


@pytest.mark.slow
def test_on_a_cylinder_the_distances_to_s_and_to_s_hat_agree_within_s_hats_distance_to_s(cylinder):
    d, c = cylinder
    med = c.runs["median"]
    dev, to_s, off = med.deviation, med.to_target, _approx_to_s(d)
    assert to_s is not None and to_s.per_vertex.shape == dev.per_vertex.shape
    assert np.all(np.abs(to_s.per_vertex - off.per_vertex) <= dev.per_vertex + FLOAT32_SLACK)
    # Ŝ of a developable target lies on S (up to its mesh): the distance to S is the deviation, within it
    assert to_s.rms <= dev.rms + off.rms + FLOAT32_SLACK
    assert off.max < 0.25 * dev.rms           # Ŝ on S: what separates the face from S is the inflation's error
    assert to_s.rms_pct_diag == pytest.approx(100 * to_s.rms / (100 * dev.rms / dev.rms_pct_diag))


@pytest.mark.slow
def test_on_a_dome_the_face_is_as_far_from_s_as_s_hat_is_less_its_deviation(dome):
    d, c = dome
    assert not d.approx.report.constructible
    med = c.runs["median"]
    dev, to_s, off = med.deviation, med.to_target, _approx_to_s(d)
    assert np.all(to_s.per_vertex >= off.per_vertex - dev.per_vertex - FLOAT32_SLACK)
    assert to_s.rms >= off.rms - dev.rms - FLOAT32_SLACK             # Minkowski on the per-vertex bound


@pytest.mark.slow
def test_inflate_json_gives_the_distance_to_s_or_a_note(cylinder):
    _, c = cylinder
    med = c.runs["median"]
    doc = check_dict(c)
    assert doc["to_target"]["rms_mm"] == pytest.approx(med.to_target.rms * 1e3, abs=1e-3)
    assert doc["to_target"]["surface"] == c.surface == doc["deviation"]["surface"]
    assert doc["deviation"]["to_target"]["max_mm"] == pytest.approx(med.to_target.max * 1e3, abs=1e-3)
    without = replace(c, runs={k: replace(r, to_target=None) for k, r in c.runs.items()})
    doc = check_dict(without)
    assert doc["to_target"] == TO_TARGET_NOTE and "to_target" not in doc["deviation"]


@pytest.mark.slow
def test_design_json_gives_s_hats_distance_to_s(cylinder):
    from airmat.design.design_io import document

    d, _ = cylinder
    assert document(d)["report"]["to_target"]["rms_mm"] == pytest.approx(_approx_to_s(d).rms * 1e3, abs=1e-3)
    assert "to_target" not in document(replace(d, approx=replace(d.approx, target=None)))["report"]


def test_distance_to_target_refuses_a_wrong_shape():
    from airmat.errors import InputError
    from types import SimpleNamespace

    tri = SimpleNamespace(vertices=np.eye(3), faces=np.array([[0, 1, 2]]))
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        distance_to_target(np.zeros((4, 2)), tri, diagonal=1.0)
