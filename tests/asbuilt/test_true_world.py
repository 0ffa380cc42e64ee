"""airmat.asbuilt.true_world: a design built in a true world, against check's median run and the world's truth."""

from dataclasses import replace
from pathlib import Path
import sys

import numpy as np
import pytest

from airmat.asbuilt.true_world import World, built_world, draw_cut_errors, median_world, truth_dict
from airmat.check.inflation_check import check
from airmat.check.string_world import world_strings
from airmat.design.design_io import read_design
from airmat.errors import InputError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from test_inflate_cli import make_design  # noqa: E402

#: the small design's strings are 300 mm apart at the ends: 50 mm resolves them (4 edges and more)
RES = 0.05
C = 0.003       # the workshop's ±3 mm


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return read_design(make_design(tmp_path_factory.mktemp("true_world") / "design"))


@pytest.fixture(scope="module")
def first(small):
    return built_world(small, median_world(small, cut_tolerance=C), resolution=RES, seed=1)


def test_the_median_world_without_cut_errors_is_checks_median_run(small):
    built = built_world(small, median_world(small), resolution=RES)
    run = check(small, resolution=RES, envelope=False).runs["median"]
    # same mesh, same strings, same solver path: the same equilibrium (1e-9 m: far below any mesh edge)
    assert np.abs(built.inflation.xyz - run.inflation.xyz).max() <= 1e-9
    assert np.abs(built.xyz - run.deviation.apply(run.inflation.xyz)).max() <= 1e-9
    assert built.surface == run.deviation.surface and built.deviation.rms == pytest.approx(run.deviation.rms, abs=1e-9)
    assert np.all(built.world.cut_error == 0) and built.inflation_converged


def test_the_built_strings_are_the_worlds(small, first):
    e = first.world.cut_error
    assert e.shape == (2,) and np.all(np.abs(e) <= C) and np.any(e != 0)
    assert first.world.ids == ("k1-001-01", "k1-002-01") and first.world.seed == 1
    l_med = np.array([s.l_median for s in small.pattern.strings])
    assert np.allclose(first.real_length, l_med + e, rtol=0, atol=1e-15)
    w = world_strings(small, first.world.delta, first.world.d, cut_error=e)
    assert np.array_equal(first.strings.rest, w.rest) and first.strings.ids == first.world.ids
    assert np.array_equal(first.xyz, first.deviation.apply(first.inflation.xyz))


def test_the_upper_face_looks_up_and_is_a_face_of_the_mattress(first):
    tri = first.xyz[first.upper_triangles]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert n[:, 2].sum() > 0
    mesh = first.inflation.mesh
    face = mesh.top if first.upper_face == "top" else mesh.bottom
    assert set(np.unique(first.upper_triangles)) == set(face.tolist())


def test_cut_errors_are_uniform_within_c_or_normal_with_c_their_95_interval_and_seeded():
    e = draw_cut_errors(20_000, C, seed=3)
    assert np.all(np.abs(e) <= C)
    # the variance of U(-c, c) is c^2/3; 20 000 draws: its relative standard error is ~0.9 %
    assert np.var(e) == pytest.approx(C ** 2 / 3, rel=0.05)
    assert np.array_equal(e, draw_cut_errors(20_000, C, seed=3))
    assert not np.array_equal(e, draw_cut_errors(20_000, C, seed=4))
    n = draw_cut_errors(20_000, C, seed=3, distribution="normal")
    assert np.mean(np.abs(n) <= C) == pytest.approx(0.95, abs=0.01)    # binomial sd 0.0015
    assert np.all(draw_cut_errors(5, 0.0, seed=3) == 0)
    with pytest.raises(InputError):
        draw_cut_errors(5, -C)


def test_recut_keeps_the_kept_strings_errors_and_draws_fresh_ones_for_the_others(small, first):
    fresh = draw_cut_errors(2, C, seed=2)
    second = built_world(small, first.world, resolution=RES, seed=2, recut=np.array([True, False]))
    assert second.world.cut_error[0] == fresh[0] and second.world.cut_error[1] == first.world.cut_error[1]
    assert (second.world.delta, second.world.d) == (first.world.delta, first.world.d)
    # nothing re-cut: the world's own errors, hence the first build again (no random step in the solver)
    again = built_world(small, first.world, resolution=RES, seed=99, recut=np.zeros(2, bool))
    assert np.array_equal(again.world.cut_error, first.world.cut_error)
    assert np.array_equal(again.xyz, first.xyz)


def test_kept_errors_are_found_by_string_id(small, first):
    swapped = replace(first.world, cut_error=first.world.cut_error[::-1], ids=first.world.ids[::-1])
    again = built_world(small, swapped, resolution=RES, recut=np.zeros(2, bool))
    assert np.array_equal(again.world.cut_error, first.world.cut_error)
    unknown = replace(first.world, ids=("x", "y"))
    with pytest.raises(InputError, match="not in the world"):
        built_world(small, unknown, resolution=RES, recut=np.zeros(2, bool))


@pytest.mark.parametrize("recut", [np.array([True]), np.array([1, 0]), np.zeros((2, 1), bool)])
def test_a_recut_mask_of_the_wrong_kind_is_refused(small, first, recut):
    with pytest.raises(InputError, match="recut must be a boolean mask"):
        built_world(small, first.world, resolution=RES, recut=recut)


def test_keeping_strings_of_a_world_never_built_is_refused(small):
    with pytest.raises(InputError, match="no cut errors"):
        built_world(small, median_world(small), resolution=RES, recut=np.zeros(2, bool))


@pytest.mark.parametrize("kwargs", [{"delta": -0.001, "d": 0.07}, {"delta": 0.01, "d": 0.0},
                                    {"delta": 0.01, "d": 0.07, "cut_tolerance": -C},
                                    {"delta": 0.01, "d": 0.07, "distribution": "cauchy"},
                                    {"delta": 0.01, "d": 0.07, "cut_error": np.zeros(2), "ids": ("a",)}])
def test_a_world_that_cannot_be_is_refused(kwargs):
    with pytest.raises(InputError):
        World(**kwargs)


def test_another_world_bends_the_strings_otherwise(small, first):
    other = built_world(small, replace(first.world, delta=first.world.delta + 0.005), resolution=RES,
                        recut=np.zeros(2, bool))
    assert np.all(np.abs(other.lengths.kappa - first.lengths.kappa) > 0.01)      # 1/m
    assert np.abs(other.xyz - first.xyz).max() > 1e-3                         # m


def test_the_truth_is_in_mm(small, first):
    doc = truth_dict(first, small)
    assert doc["world"]["delta_mm"] == pytest.approx(first.world.delta * 1e3)
    assert doc["world"]["design_median"]["d_mm"] == pytest.approx(np.median(small.calibration.d) * 1e3)
    rows = doc["strings"]
    assert [r["id"] for r in rows] == list(first.world.ids)
    for r, e, rest in zip(rows, first.world.cut_error, first.strings.rest):
        assert r["cut_error_mm"] == pytest.approx(e * 1e3) and r["rest_mm"] == pytest.approx(rest * 1e3)
        assert r["l_real_mm"] == pytest.approx(r["l_design_mm"] + r["cut_error_mm"])
    assert doc["inflation"]["converged"] is True and doc["deviation"]["surface"] == first.surface
    assert "BuiltMattress" in repr(first) and "Δ" in repr(first)


def test_a_refined_design_is_built_from_its_open_loop_equilibrium_as_check_inflates_it(small):
    """A design with open-loop strings (here its own, shortened by 2 mm: another path) takes check's route."""
    open_loop = [replace(s, l_median=s.l_median - 0.002) for s in small.pattern.strings]
    refined = replace(small, open_loop=open_loop)
    built = built_world(refined, median_world(refined), resolution=RES)
    run = check(refined, resolution=RES, envelope=False)
    assert built.open_loop is not None and run.open_loop is not None
    assert np.abs(built.open_loop.xyz - run.open_loop.xyz).max() <= 1e-9
    assert np.abs(built.inflation.xyz - run.runs["median"].inflation.xyz).max() <= 1e-9


def test_the_correction_cycle_builds_the_corrected_design_in_the_same_world(small, first):
    """synth-built -> correct -> synth-built: new lengths, the same world, fresh errors for the re-cut strings only."""
    strings = small.pattern.strings
    corrected = replace(small, pattern=replace(small.pattern, strings=[replace(strings[0], l_median=strings[0].l_median
                                                                               + 0.004), strings[1]]))
    second = built_world(corrected, first.world, resolution=RES, seed=5, recut=np.array([True, False]))
    e = second.world.cut_error
    assert e[1] == first.world.cut_error[1] and e[0] == draw_cut_errors(2, C, seed=5)[0]
    assert second.real_length[0] == pytest.approx(strings[0].l_median + 0.004 + e[0], abs=1e-15)
    assert second.real_length[1] == first.real_length[1]
    assert second.strings.rest[1] == first.strings.rest[1] and second.strings.rest[0] != first.strings.rest[0]
