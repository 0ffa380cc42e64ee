"""Refinement through the equilibrium: a refinement that lands on Ŝ, its result, its bounds and its bad input."""

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from refine_case import (RESOLUTION, TRUE_SIM, moves_toward_the_true_lengths, off_case,  # noqa: E402
                         small_design)

from airmat.errors import InputError  # noqa: E402
from airmat.check.inflation_check import check, design_strings, open_loop_strings  # noqa: E402
from airmat.check.length_map import length_map  # noqa: E402
from airmat.check.refinement import RefineOptions, refine  # noqa: E402
from airmat.design.design_io import read_design, write_design  # noqa: E402
from airmat.inflation.model import Parameters  # noqa: E402

#: the small case with a known answer (refine_case.py), once per module
case = pytest.fixture(scope="module", name="case")(off_case)


@pytest.fixture(scope="module")
def refined(case):
    return refine(case, resolution=RESOLUTION, max_iter=6)


def test_refinement_lowers_the_deviation_and_the_check_reproduces_it(case, refined):
    r = refined
    assert r.iterations == 6 and r.deviation_after.rms < 0.6 * r.deviation_before.rms
    assert r.objective_after < r.objective_before
    # the lengths move toward the ones that made Ŝ (refine_case.moves_toward_the_true_lengths: closer as a
    # vector and in their common part; not a factor, which is the problem's conditioning, not a promise)
    moves_toward_the_true_lengths(r.l_simulated)
    # the check of the refined design (the open-loop equilibrium from the flat mattress, carried on to the
    # refined lengths, as the refinement went) measures what the refinement promised
    c = check(r.design, resolution=RESOLUTION, envelope=False)
    assert c.surface == r.surface == "top"
    assert c.open_loop is not None and c.open_loop.n_iter == r.open_loop_run.inflation.n_iter
    np.testing.assert_array_equal(c.open_loop.xyz, r.open_loop_run.inflation.xyz)
    assert [s.dash.id for s in r.design.open_loop] == [s.dash.id for s in case.pattern.strings]
    assert [s.l_median for s in r.design.open_loop] == [s.l_median for s in case.pattern.strings]
    assert check(case, resolution=RESOLUTION, envelope=False).open_loop is None    # not refined: from flat
    assert c.runs["median"].deviation.rms == pytest.approx(r.deviation_after.rms, rel=1e-9)
    # real lengths through the length map; the tolerance moves with the median
    lm = length_map(case.calibration)
    for old, new, l_sim in zip(case.pattern.strings, r.design.pattern.strings, r.l_simulated):
        assert new.l_median == pytest.approx(float(lm.to_real(l_sim)))
        assert new.l_hi95 - new.l_median == pytest.approx(old.l_hi95 - old.l_median)
        assert new.l_median - new.l_lo95 == pytest.approx(old.l_median - old.l_lo95)
    block = r.design.refine
    assert block["iterations"] == 6 and block["deviation_after"]["rms_mm"] == pytest.approx(
        r.deviation_after.rms * 1e3, abs=1e-3)


def test_the_pull_toward_the_open_loop_lengths_grows_with_alpha(case, refined):
    # the Tikhonov term alpha * mean((l* - l*_open)^2): a strong pull keeps the lengths near the
    # open-loop ones (and so far from the ones that made S-hat), the default lets them go; measured:
    # 2.4 mm moved against 11.0 mm, 3.3 mm RMS left against 1.4 mm (3.9 mm open loop)
    strong = refine(case, resolution=RESOLUTION, max_iter=6, alpha=1.0)
    l_open = design_strings(case).rest
    assert refined.alpha == refined.design.refine["alpha"] == 1e-3 and strong.design.refine["alpha"] == 1.0
    moved, held = (np.linalg.norm(r.l_simulated - l_open) for r in (refined, strong))
    assert held < 0.5 * moved
    assert np.linalg.norm(strong.l_simulated - TRUE_SIM) > np.linalg.norm(refined.l_simulated - TRUE_SIM)
    assert strong.deviation_after.rms > refined.deviation_after.rms


def test_the_check_takes_the_verification_as_its_median_run_only_when_it_is_that_run(refined):
    r = refined
    reused = check(r.design, resolution=RESOLUTION, envelope=False, known=r.known_runs)
    fresh = check(r.design, resolution=RESOLUTION, envelope=False)
    assert reused.runs["median"].inflation.xyz is r.verification.inflation.xyz       # not inflated again
    assert reused.open_loop.xyz is r.open_loop_run.inflation.xyz                      # nor its start
    assert fresh.runs["median"].inflation.xyz is not r.verification.inflation.xyz
    assert fresh.open_loop.xyz is not r.open_loop_run.inflation.xyz
    np.testing.assert_array_equal(fresh.open_loop.xyz, reused.open_loop.xyz)
    np.testing.assert_array_equal(fresh.runs["median"].inflation.xyz, reused.runs["median"].inflation.xyz)
    assert reused.runs["median"].deviation.rms == fresh.runs["median"].deviation.rms == r.deviation_after.rms
    # another run than the known one is inflated: other parameters, another mesh, other lengths
    for kw in ({"params": Parameters(pressure=0.9 * Parameters().pressure)}, {"resolution": 0.03},
               {"known": dataclasses.replace(r.verification, tol=1e-8)}):
        other = check(r.design, **{"resolution": RESOLUTION, "envelope": False, "known": r.verification, **kw})
        assert other.runs["median"].inflation.xyz is not r.verification.inflation.xyz
    shifted = dataclasses.replace(r.verification, strings=dataclasses.replace(
        r.verification.strings, rest=r.verification.strings.rest + 1e-4))
    mesh, start = r.verification.inflation.mesh, open_loop_strings(r.design)
    assert not shifted.stands_for(design_strings(r.design), mesh, Parameters(), 1e-6, start)
    assert r.verification.stands_for(design_strings(r.design), mesh, Parameters(), 1e-6, start)
    # the same strings from another start (the flat mattress) are another run
    assert not r.verification.stands_for(design_strings(r.design), mesh, Parameters(), 1e-6)
    assert r.open_loop_run.stands_for(start, mesh, Parameters(), 1e-6)


def test_the_refined_design_carries_s_hat_reparametrized_and_none_keeps_it_as_designed(case, refined):
    # by default one round moves Ŝ's points along Ŝ into the metric the face realizes (airmat.check.reparametrize);
    # the refined design carries that Ŝ, which the check compared with above (the deviation it reproduces)
    r = refined
    rep = r.reparametrization
    assert r.reparametrize_rounds == 1 and rep is not None
    np.testing.assert_array_equal(r.design.approx.xyz, rep.xyz)
    moved = np.linalg.norm(rep.xyz - case.approx.xyz, axis=1)
    assert rep.moved_max == pytest.approx(moved.max()) and 0 < rep.moved_max < 0.01
    assert rep.off_rms < 0.1 * rep.moved_rms               # along Ŝ, not off it (measured 0.05 against 0.8 mm)
    b = r.design.refine["reparametrization"]
    assert b["rounds"] == 1 and b["moved_max_mm"] == pytest.approx(rep.moved_max * 1e3, abs=1e-3)
    assert b["deviation_before"]["rms_mm"] == pytest.approx(r.deviation_before_reparametrized.rms * 1e3, abs=1e-3)
    # 0 rounds: Ŝ as designed, and nothing about it in the block
    r0 = refine(case, resolution=RESOLUTION, max_iter=6, reparametrize=0)
    np.testing.assert_array_equal(r0.design.approx.xyz, case.approx.xyz)
    assert r0.reparametrization is None and r0.design.refine["reparametrization"] is None
    assert r0.iterations == 6 and r0.deviation_after.rms < r0.deviation_before.rms
    with pytest.raises(InputError, match="reparametrize must be 0 or more"):
        refine(case, resolution=RESOLUTION, reparametrize=-1)


def test_a_refined_designs_envelope_and_samples_are_carried_on_from_its_open_loop(refined):
    # lo95 / hi95 and the Monte-Carlo samples start where the median does: the open-loop equilibrium
    # (a few Newton steps each, not a whole inflation with its ramp and coarse meshes)
    r = refined
    c = check(r.design, resolution=RESOLUTION, samples=2, seed=0, known=r.known_runs)
    base = r.open_loop_run.inflation
    assert c.converged and c.open_loop.xyz is base.xyz
    for key in ("lo95", "hi95"):
        inf = c.runs[key].inflation
        assert inf.stages == 1 and 0 < inf.n_iter < base.n_iter
    assert c.monte_carlo.converged.all() and np.all(c.monte_carlo.rms > 0)
    # the same samples inflated from the flat mattress are other runs (the design's open loop forgotten)
    flat = check(dataclasses.replace(r.design, open_loop=None), resolution=RESOLUTION, envelope=False)
    assert flat.open_loop is None and flat.runs["median"].inflation.stages > 1


def test_a_refined_design_refined_again_starts_where_its_check_lands(case, refined):
    # its open loop stays the first one, its first inflation is its check's median run (the open loop
    # from the flat mattress, carried on to the refined lengths): the deviation it starts from is the
    # one the first refinement promised
    again = refine(refined.design, resolution=RESOLUTION, max_iter=2)
    assert again.lengths_before == "refined"
    assert again.deviation_before.rms == pytest.approx(refined.deviation_after.rms, rel=1e-9)
    np.testing.assert_array_equal(again.open_loop_run.inflation.xyz, refined.open_loop_run.inflation.xyz)
    assert [s.l_median for s in again.design.open_loop] == [s.l_median for s in case.pattern.strings]
    assert again.deviation_after.rms <= again.deviation_before.rms


def test_the_checks_tolerance_is_the_inflations_default():
    import inspect

    from airmat.inflation.simulate import INFLATE_TOL
    from airmat.inflation.simulate import inflate as inflate_fn
    assert inspect.signature(inflate_fn).parameters["tol"].default == INFLATE_TOL
    assert RefineOptions().tol == INFLATE_TOL   # the verification the check reuses


def test_refine_block_round_trips_through_the_design_folder(refined, tmp_path):
    write_design(refined.design, tmp_path)
    doc = json.loads((tmp_path / "design.json").read_text())
    assert set(doc["refine"]) >= {"converged", "iterations", "seconds", "deviation_before", "deviation_after"}
    assert set(doc["refine"]["deviation_after"]) >= {"rms_mm", "rms_pct_diag"}
    back = read_design(tmp_path)
    assert back.refine == {k: v for k, v in doc["refine"].items() if k != "open_loop_dashes"}
    # the open-loop strings its check starts from: every original string (0.01 mm in the file)
    assert [s.dash.id for s in back.open_loop] == [e["id"] for e in doc["refine"]["open_loop_dashes"]] == \
        [s.dash.id for s in refined.design.open_loop]
    np.testing.assert_allclose([s.l_median for s in back.open_loop],
                               [s.l_median for s in refined.design.open_loop], atol=1e-5)
    assert "open_loop_dashes" not in json.dumps(read_design(tmp_path).refine)
    # a refined folder written before the open loop was kept: checked from the flat mattress, as then
    older = {**doc, "refine": {k: v for k, v in doc["refine"].items() if k != "open_loop_dashes"}}
    (tmp_path / "design.json").write_text(json.dumps(older))
    assert read_design(tmp_path).open_loop is None and read_design(tmp_path).refine == older["refine"]
    (tmp_path / "design.json").write_text(json.dumps({**doc, "refine": {**doc["refine"], "open_loop_dashes": 3}}))
    with pytest.raises(InputError, match="refine.open_loop_dashes' must be a list"):
        read_design(tmp_path)
    broken = [{k: v for k, v in e.items() if k != "a_mm"} for e in doc["refine"]["open_loop_dashes"]]
    (tmp_path / "design.json").write_text(json.dumps({**doc, "refine": {**doc["refine"], "open_loop_dashes": broken}}))
    with pytest.raises(InputError, match="refine.open_loop_dashes: dash .* lacks field 'a_mm'"):
        read_design(tmp_path)
    # Ŝ as the refinement left it (re-parametrized), float32 mm in approx_surface.ply
    np.testing.assert_allclose(back.approx.xyz, refined.design.approx.xyz, atol=1e-5)
    got = [s.l_median for s in back.pattern.strings]
    np.testing.assert_allclose(got, [s.l_median for s in refined.design.pattern.strings], atol=1e-5)


def test_a_string_already_right_stays_and_never_worse_than_open_loop():
    r = refine(small_design(TRUE_SIM), resolution=RESOLUTION, max_iter=3)
    assert r.deviation_after.rms <= r.deviation_before.rms
    np.testing.assert_allclose(r.l_simulated, TRUE_SIM, atol=2e-3)


@pytest.mark.parametrize("what, words", [("none", "no strings"), ("coarse", "too coarse"),
                                         ("samples", "posterior samples")])
def test_bad_input_is_refused_before_any_work(case, what, words):
    d, res = case, RESOLUTION
    if what == "none":
        d = dataclasses.replace(case, pattern=dataclasses.replace(case.pattern, strings=()))
    elif what == "coarse":
        res = 0.2
    else:
        cal = dataclasses.replace(case.calibration, delta=np.zeros(0), d=np.zeros(0))
        d = dataclasses.replace(case, calibration=cal)
    with pytest.raises(InputError, match=words):
        refine(d, resolution=res)


def test_dropping_strings_recomputes_the_coverage(tmp_path):
    """A refined pattern that lost strings reports its own coverage (in memory), or says it is not known
    (a design read from its folder keeps no curvature field)."""
    from airmat.check.refined_design import refined_design
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset

    target, mattress = preset("vault1")
    d = design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    strings = d.pattern.strings
    fam = np.array([s.dash.family for s in strings])
    line = np.array([s.dash.line for s in strings])
    # drop every k1 string of the three middle lines: a band with no k1 string
    k1_lines = np.unique(line[fam == "k1"])
    mid = k1_lines[len(k1_lines) // 2 - 1: len(k1_lines) // 2 + 2]
    dropped = (fam == "k1") & np.isin(line, mid)
    assert dropped.any()
    l_real = np.array([s.l_median for s in strings])
    r = refined_design(d, l_real, dropped, np.zeros(len(strings), bool))
    before, after = d.pattern.coverage["k1"], r.pattern.coverage["k1"]
    # the dropped dashes leave a band the design traced but no longer strings (a weak band; measured
    # 57.8 -> 114.5 mm against the 80 mm limit, gap p95 89.9 -> 124.4 mm)
    assert after["gap_p95_mm"] > before["gap_p95_mm"] and after["gap_max_mm"] >= before["gap_max_mm"]
    assert after["weak_band_max_mm"] > after["limit_mm"] >= before["weak_band_max_mm"]
    assert r.pattern.coverage["k2"] == d.pattern.coverage["k2"]      # k2 strings untouched
    assert any(n.startswith("after the refinement:") for n in r.pattern.notes)
    # from the folder: not known, and said
    write_design(d, tmp_path / "d")
    back = read_design(tmp_path / "d")
    rb = refined_design(back, l_real, dropped, np.zeros(len(strings), bool))
    assert rb.pattern.coverage is None and any("coverage of the refined pattern is not known" in n
                                               for n in rb.pattern.notes)
    write_design(rb, tmp_path / "rb")                                 # a null coverage is a valid file
    assert read_design(tmp_path / "rb").pattern.coverage is None


def test_the_refinement_shows_its_iterations_on_a_progress_bar(case, capsys):
    # a bar over the Gauss–Newton iterations with the current RMS, when progress bars are on (a terminal)
    from airmat.progress import set_progress
    set_progress(True)
    try:
        r = refine(case, resolution=0.04, max_iter=2)
    finally:
        set_progress(None)
    err = capsys.readouterr().err
    assert "refine on the 40 mm mesh" in err and "RMS" in err
    # one bar per Gauss–Newton stage (its count starts at 0): their last counts add up to the iterations
    import re

    counts = [int(n) for n in re.findall(r"refine on the 40 mm mesh: +\d+%\|[^|]*\| (\d+)/\d+", err)]
    finals = [a for a, b in zip(counts, counts[1:] + [0]) if b == 0 and a > 0]
    assert sum(finals) == r.iterations == 2, counts


def test_a_refinement_out_of_iterations_counts_them_all(case):
    # two coarse iterations and one at the resolution: the message counts the three, not the last stage's one
    r = refine(case, resolution=0.02, max_iter=3, fine_iter=1)
    assert r.iterations == 3 and not r.converged
    assert r.message == "not converged after 3 iterations"


@pytest.mark.parametrize("already", [False, True])
def test_lengths_that_verify_worse_are_not_kept_and_the_message_names_what_is(case, monkeypatch, already):
    # the verification of the refined lengths made worse on purpose (every string 20 mm shorter): the given
    # lengths are kept, converged=False, and the message names them (the open-loop ones, or a refined
    # design's own when a refined design is refined again)
    import airmat.check.refinement as refinement

    calls, inflate_from = [], refinement.inflate_from

    def worse_verification(start, strings, **kw):
        calls.append(kw)
        return inflate_from(start, dataclasses.replace(strings, rest=strings.rest - 0.02), **kw)

    monkeypatch.setattr(refinement, "inflate_from", worse_verification)
    given = dataclasses.replace(case, refine={"converged": True}) if already else case
    r = refine(given, resolution=RESOLUTION, max_iter=2)
    assert len(calls) == 1 and not r.converged
    np.testing.assert_array_equal(r.l_simulated, np.clip(design_strings(case).rest, *refinement.length_bounds(
        case, design_strings(case))))
    assert r.deviation_after == r.deviation_before and r.dropped == r.flagged == ()
    name = "refined" if already else "open-loop"
    assert f"not better than the {name}" in r.message and f"the {name} lengths are kept" in r.message
    assert r.lengths_before == r.block()["lengths_before"] == name


@pytest.mark.slow
def test_a_refinement_misled_by_the_coarse_mesh_tries_again_until_it_lands_closer(caplog):
    # the symmetric saddle κ = ±2 1/m (the zoo's hypar-1.0-k2): the coarse iterations' lengths wrinkle the fine
    # mesh and inflate farther from Ŝ than the open loop (1.54 % of the diagonal), with defect corrections too;
    # with every iteration on the target mesh they land closer, and that is what the refinement returns
    import logging

    from airmat.check.refinement import FALLBACK_CORRECTIONS
    from airmat.design.mattress import Mattress
    from airmat.design.pipeline import design
    from airmat.synthetic.zoo import by_name

    e = by_name("hypar-1.0-k2")
    d = design(e, Mattress(*e.mattress), progress=False)
    with caplog.at_level(logging.INFO, logger="airmat.check.refinement"):
        r = refine(d, resolution=0.02)
    tries = [m for m in caplog.messages if "again with" in m]
    assert len(tries) == 2 and f"{FALLBACK_CORRECTIONS} defect corrections" in tries[0]
    assert "every iteration on the target mesh" in tries[1]
    assert r.coarse_resolution is None and r.corrections == ()
    assert r.converged and r.deviation_after.rms < 0.8 * r.deviation_before.rms
