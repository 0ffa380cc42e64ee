"""The fold route (airmat.design.fold_route): a dome the flat mattress cannot cover gathers into folds.

Ground truth: an ellipsoidal dome past its equator (the preset) strains the plain Ŝ to σ 0.86–1.25;
the paper built its dome with folds at σ ≥ 0.934. The search must find a Ŝ within [0.93, 1.07], say
what it costs in distance to S, count its folds as folds, and leave a constructible target alone.
"""

import importlib.resources
import json
from types import SimpleNamespace

import numpy as np
import pytest

from airmat.design.constructibility import FOLD_SHARE_MAX, constructibility
from airmat.design.design_io import read_design, write_design
from airmat.design.fold_route import (FOLD_SIGMA_BAND, cap_curvature, fold_route, folds_likely, needs_folds,
                                      total_curvature)
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.pipeline import DesignParams, design
from airmat.design.presets import preset
from airmat.forked import can_fork
from airmat.report.design import design_part

forks = pytest.mark.skipif(not can_fork(), reason="forked processes on Linux only")


@pytest.fixture(scope="module")
def dome():
    """The dome preset designed on a 40 mm Ω (the fold route at the default one takes a minute)."""
    target, mattress = preset("dome")
    return design(target, mattress, params=DesignParams(spacing=0.04), progress=False)


@pytest.fixture(scope="module")
def plain_dome():
    target, mattress = preset("dome")
    return design(target, mattress, params=DesignParams(spacing=0.04, folds=False), progress=False)


def test_the_plain_dome_fails_the_sigma_test(plain_dome):
    rep = plain_dome.approx.report
    assert needs_folds(rep)
    assert rep.sigma["min"] < FOLD_SIGMA_BAND[0] or rep.sigma["max"] > FOLD_SIGMA_BAND[1]
    assert plain_dome.fold_route is None


def test_the_dome_gathers_into_folds_within_the_papers_sigma_band(dome, plain_dome):
    route, rep = dome.fold_route, dome.approx.report
    assert route is not None and route.found
    lo, hi = FOLD_SIGMA_BAND
    assert lo <= rep.sigma["min"] and rep.sigma["max"] <= hi
    assert rep.constructible, rep.reasons
    assert rep.sigma_band == FOLD_SIGMA_BAND                 # a folded Ŝ is judged by the fold band
    assert route.trials[0].ratio == 1.0 and route.trial.ratio > 1.0
    assert route.trial.k_a1 == pytest.approx(route.trial.ratio * DesignParams().weights()["k_a1"])
    # the first trial within the band is the one chosen: every earlier one is outside it
    assert route.chosen == len(route.trials) - 1
    assert not any(t.within_band for t in route.trials[:-1])
    # the price is measured: the folded Ŝ leaves S further than the plain one, which lies on it
    plain = route.trials[0]
    assert route.trial.to_target_rms > plain.to_target_rms
    assert plain.sigma_min == pytest.approx(plain_dome.approx.report.sigma["min"])
    assert f"k_A1 × {route.trial.ratio:g}" in route.message and "mm RMS" in route.message
    assert f"{route.trial.to_target_rms * 1e3:.1f} mm RMS" in route.message
    # Ŝ leaves S by folds: heights of centimetres, not a different shape
    assert route.trial.to_target_rms < 0.01


def test_only_a_contracted_s_hat_takes_the_fold_route():
    # folds gather excess length: a Ŝ that stretches beyond the band (a saddle) keeps its verdict
    band = (0.9, 1.1)
    assert needs_folds(SimpleNamespace(sigma={"min": 0.86, "max": 1.0}, sigma_band=band))
    assert needs_folds(SimpleNamespace(sigma={"min": 0.86, "max": 1.25}, sigma_band=band))
    assert not needs_folds(SimpleNamespace(sigma={"min": 0.95, "max": 1.11}, sigma_band=band))
    assert not needs_folds(None)


def test_the_fold_route_leaves_a_constructible_target_alone():
    target, mattress = preset("vault1")
    r = design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    assert r.approx.report.constructible and r.fold_route is None and r.approx.report.folds is None


def test_design_json_keeps_the_route_and_the_folds(dome, tmp_path):
    jsonschema = pytest.importorskip("jsonschema")
    write_design(dome, tmp_path / "d")
    doc = json.loads((tmp_path / "d" / "design.json").read_text())
    schema = json.loads((importlib.resources.files("airmat") / "schemas" / "design.schema.json").read_text())
    jsonschema.Draft202012Validator(schema).validate(doc)
    assert doc["fold_route"]["found"] and doc["report"]["folds"] is not None
    from airmat.cli.info import describe_design

    assert any(line.startswith("  fold route: with k_A1 ×") for line in describe_design(doc))
    back = read_design(tmp_path / "d")
    html = design_part(back).body                       # report.html's design part, from the folder
    assert "<h3>Folds</h3>" in html and "(chosen)" in html
    assert back.fold_route.summary_mm() == dome.fold_route.summary_mm()      # rounded as in the file
    assert back.params.folds is True
    assert back.approx.report.constructible == dome.approx.report.constructible


# --- the verdict with folds, on a flat Ω with a made-up curvature -------------------------------------------------

@pytest.fixture(scope="module")
def omega():
    return triangulate_mattress(Mattress(0.6, 0.5), spacing=0.05)


def _kappa(uv, share_u):
    """|κ1| = 100 1/m on the vertices with u below ``share_u`` (m), 1 1/m elsewhere."""
    k = np.ones((len(uv), 2))
    k[uv[:, 0] < share_u, 0] = 100.0
    return k


def test_a_few_folds_are_no_reason_but_are_reported(omega):
    uv, faces = omega
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa = _kappa(uv, 0.01)                     # one column of vertices: a fold along the rim
    plain = constructibility(xyz, uv, faces, kappa)
    assert not plain.constructible and "exceeds the reachable" in plain.reasons[0] and plain.folds is None
    folded = constructibility(xyz, uv, faces, kappa, folds=True)
    assert folded.constructible and folded.reasons == []
    assert 0 < folded.folds["share"] <= FOLD_SHARE_MAX
    assert folded.folds["vertices"] == int((uv[:, 0] < 0.01).sum())
    assert folded.folds["kappa_max"] == pytest.approx(100.0)
    assert any("drape-like folds" in w for w in folded.warnings)


def test_curvature_beyond_reach_over_much_of_the_mattress_is_no_fold(omega):
    uv, faces = omega
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    rep = constructibility(xyz, uv, faces, _kappa(uv, 0.2), folds=True)
    assert not rep.constructible
    assert rep.folds["share"] > FOLD_SHARE_MAX
    assert "too much for folds" in rep.reasons[0]


# --- the search itself, on stand-in relaxations whose σ is given ---------------------------------------------------

def _stand_in(sig_lo, sig_hi, offset):
    """An ApproxSurface stand-in: a flat Ŝ ``offset`` (m) above the flat target, with σ as given."""
    uv, faces = triangulate_mattress(Mattress(0.3, 0.2), spacing=0.05)
    target = SimpleNamespace(vertices=np.column_stack([uv, np.zeros(len(uv))]), faces=faces)
    report = SimpleNamespace(sigma={"min": sig_lo, "max": sig_hi}, kappa_max=15.0)
    return SimpleNamespace(target=target, xyz=np.column_stack([uv, np.full(len(uv), offset)]), uv=uv, faces=faces,
                           report=report, curvature=SimpleNamespace(kappa=np.zeros((len(uv), 2))),
                           relax=SimpleNamespace(converged=True))


def test_the_search_stops_at_the_first_weight_within_the_band():
    tried = []
    table = {3.0: (0.90, 1.10, 0.001), 10.0: (0.95, 1.05, 0.002), 30.0: (0.97, 1.03, 0.003)}

    def relax_with(k):
        tried.append(k)
        return _stand_in(*table[k])

    approx, route = fold_route(_stand_in(0.85, 1.2, 0.0), relax_with, k_a1=1.0, ratios=(3.0, 10.0, 30.0))
    assert tried == [3.0, 10.0]
    assert route.found and route.chosen == 2 and approx.report.sigma["min"] == 0.95
    assert route.trial.to_target_rms == pytest.approx(0.002)


def test_without_a_weight_within_the_band_the_best_found_is_kept_and_said():
    table = {3.0: (0.88, 1.12, 0.001), 10.0: (0.91, 1.09, 0.002)}
    approx, route = fold_route(_stand_in(0.80, 1.25, 0.0), lambda k: _stand_in(*table[k]), k_a1=1.0,
                               ratios=(3.0, 10.0))
    assert not route.found and route.chosen == 2          # σ leaves the band least there (0.02)
    assert approx.report.sigma["max"] == 1.09
    assert route.message.startswith("no constructible Ŝ") and "× 10" in route.message


def test_trials_side_by_side_choose_as_one_at_a_time():
    """With workers, the next factors relax together (forked processes on Linux); the search still takes the first
    within the band, and a later trial of the same batch is dropped."""
    import os

    def relax_with(table):
        def relax(k):
            s = _stand_in(*table[k])
            s.pid = os.getpid()
            return s
        return relax

    first_in = {3.0: (0.95, 1.05, 0.001), 10.0: (0.97, 1.03, 0.002), 30.0: (0.97, 1.03, 0.003)}
    second_in = {3.0: (0.90, 1.10, 0.001), 10.0: (0.95, 1.05, 0.002), 30.0: (0.97, 1.03, 0.003)}
    for table, chosen in ((first_in, 1), (second_in, 2)):
        one = fold_route(_stand_in(0.85, 1.2, 0.0), relax_with(table), k_a1=1.0, ratios=(3.0, 10.0, 30.0))
        two = fold_route(_stand_in(0.85, 1.2, 0.0), relax_with(table), k_a1=1.0, ratios=(3.0, 10.0, 30.0), workers=2)
        assert one[1].chosen == two[1].chosen == chosen and one[1].trials == two[1].trials
        assert np.array_equal(one[0].xyz, two[0].xyz)
        assert one[0].pid == os.getpid() and (two[0].pid != os.getpid()) == can_fork()


def test_total_curvature_is_the_caps_and_a_cylinders_is_zero():
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=5)
    for z in (0.5, 0.0):                                   # caps of 60° and 90°: ∫K = 2π (1 − cos θ)
        cap = trimesh.Trimesh(sphere.vertices, sphere.faces[sphere.triangles_center[:, 2] > z])
        exact = 2 * np.pi * (1 - z)
        assert total_curvature(cap.vertices, cap.faces) == pytest.approx(exact, rel=0.06)
        assert total_curvature(cap.vertices, cap.faces) < exact          # the rim's ring is left out
    uv, faces = triangulate_mattress(Mattress(1.2, 0.7), spacing=0.05)   # a flat sheet rolled onto R = 0.3 m
    cylinder = np.column_stack([0.3 * np.sin(uv[:, 0] / 0.3), uv[:, 1], 0.3 * np.cos(uv[:, 0] / 0.3)])
    assert abs(total_curvature(cylinder, faces)) < 0.02


def test_cap_curvature_is_the_cap_whose_rim_contracts_to_sigma():
    for sigma in (0.9, 0.93, 0.97):
        theta = np.arccos(1 - cap_curvature(sigma) / (2 * np.pi))
        assert np.sin(theta) / theta == pytest.approx(sigma, abs=1e-9)
    assert cap_curvature(0.9) > cap_curvature(0.93) > cap_curvature(0.97) > 0


def test_folds_are_forecast_for_the_dome_preset_only():
    assert folds_likely(preset("dome")[0])
    for name in ("vault1", "saddle", "vault2", "roof"):
        assert not folds_likely(preset(name)[0]), name


@pytest.fixture
def started_trials(monkeypatch):
    """Every ForkedMap :func:`~airmat.design.fold_route.start_trials` returns to the designer, with its
    children's pids."""
    import airmat.design.pipeline as pipeline

    started, start = [], pipeline.start_trials

    def recording(*args, **kw):
        m = start(*args, **kw)
        started.append((m, [pid for pid, _ in m._children]))
        return m

    monkeypatch.setattr(pipeline, "start_trials", recording)
    return started


@forks
def test_the_first_trials_start_beside_the_plain_relaxation(dome, started_trials, monkeypatch):
    """Where folds are forecast, the route's first relaxations start before the plain one and the route takes
    them: the same Ŝ, route and strings as one relaxation at a time."""
    import airmat.design.fold_route as route_module

    made = []

    class Counted(route_module.ForkedMap):
        def __init__(self, *args, **kw):
            made.append(args[1])
            super().__init__(*args, **kw)

    monkeypatch.setattr(route_module, "ForkedMap", Counted)
    target, mattress = preset("dome")
    two = design(target, mattress, params=DesignParams(spacing=0.04), progress=False, workers=2)
    ((early, pids),) = started_trials
    assert len(pids) == 2 and not early._children                           # collected, reaped
    assert dome.fold_route.chosen <= 2 and made == [early._items]          # the first batch answered: no other
    assert two.fold_route.trials == dome.fold_route.trials and two.fold_route.chosen == dome.fold_route.chosen
    assert np.array_equal(two.approx.xyz, dome.approx.xyz)
    assert [s.l_median for s in two.pattern.strings] == [s.l_median for s in dome.pattern.strings]


@forks
def test_trials_started_for_nothing_are_given_up(started_trials, monkeypatch):
    """A forecast of folds that the plain Ŝ does not bear out: the started relaxations are killed, the design is
    the one of one process."""
    import os

    import airmat.design.pipeline as pipeline

    monkeypatch.setattr(pipeline, "folds_likely", lambda target: True)
    target, mattress = preset("vault1")
    params = DesignParams(spacing=0.04)
    two = design(target, mattress, params=params, progress=False, workers=2)
    one = design(target, mattress, params=params, progress=False, workers=1)
    ((_, pids),) = started_trials
    assert len(pids) == 2 and two.fold_route is None
    for pid in pids:
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)
    assert np.array_equal(two.approx.xyz, one.approx.xyz)
