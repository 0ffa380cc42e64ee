"""Calibration source: the paper's default (labelled uncalibrated) and calibration folders."""

import json

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.design.calibration_source import PAPER, default_calibration, load_calibration


def test_default_is_the_paper_with_a_stated_seeded_uncertainty():
    cal = default_calibration(seed=3, n_samples=4000)
    assert cal.uncalibrated and cal.source == "paper" and "UNCALIBRATED" in cal.label
    assert cal.L == PAPER["L"]
    n = cal.n_samples
    # medians and spreads within 4 Monte-Carlo standard errors of the nominal Gaussians
    assert np.median(cal.delta) == pytest.approx(PAPER["delta"], abs=4 * 1.25 * PAPER["delta_sd"] / np.sqrt(n))
    assert np.median(cal.d) == pytest.approx(PAPER["d"], abs=4 * 1.25 * PAPER["d_sd"] / np.sqrt(n))
    assert np.std(cal.delta) == pytest.approx(PAPER["delta_sd"], rel=4 / np.sqrt(2 * n))
    assert np.std(cal.d) == pytest.approx(PAPER["d_sd"], rel=4 / np.sqrt(2 * n))
    summary = cal.summary_mm()
    assert summary["uncalibrated"] is True and summary["L_mm"] == 300.0
    assert summary["delta_mm"]["lo95"] < summary["delta_mm"]["median"] < summary["delta_mm"]["hi95"]


def test_default_is_reproducible_by_seed():
    a, b, c = default_calibration(seed=1), default_calibration(seed=1), default_calibration(seed=2)
    np.testing.assert_array_equal(a.delta, b.delta)
    assert not np.array_equal(a.delta, c.delta)


def test_default_thickness_follows_the_mattress():
    cal = default_calibration(d=0.05, n_samples=4000)
    assert np.median(cal.d) == pytest.approx(0.05, abs=5 * PAPER["d_sd"] / np.sqrt(4000))
    with pytest.raises(InputError):
        default_calibration(d=0.0)


def _write_folder(folder, *, n=5000, json_doc=None, arrays=None, seed=0):
    rng = np.random.default_rng(seed)
    delta, d = rng.normal(0.012, 0.002, n), rng.normal(0.065, 0.004, n)
    doc = {"parameters": {"delta_mm": {"median": 12.0, "lo95": 8.0, "hi95": 16.0},
                          "d_mm": {"median": 65.0, "lo95": 57.0, "hi95": 73.0}},
           "curve": {"L_mm": 250.0}}
    if json_doc is not None:
        doc = json_doc
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "calibration.json").write_text(json.dumps(doc))
    arr = {"delta_m": delta, "d_m": d, "sigma_per_m": np.abs(rng.normal(0.1, 0.01, n)), "L_m": np.float64(0.25)}
    if arrays is not None:
        arr = arrays(arr)
    with open(folder / "posterior.npz", "wb") as fh:
        np.savez(fh, **arr)
    return delta, d


def test_load_calibration_reads_samples_and_L(tmp_path):
    delta, d = _write_folder(tmp_path / "cal", n=1500)
    cal = load_calibration(tmp_path / "cal")
    assert not cal.uncalibrated and cal.L == pytest.approx(0.25)
    np.testing.assert_array_equal(cal.delta, delta)
    np.testing.assert_array_equal(cal.d, d)
    assert "calibrated" in cal.label and str(tmp_path / "cal") in cal.source
    # the scatter sigma, paired with delta and d (the Monte-Carlo check draws the three together)
    with np.load(tmp_path / "cal" / "posterior.npz") as npz:
        np.testing.assert_array_equal(cal.sigma, npz["sigma_per_m"])


def test_load_calibration_thins_evenly(tmp_path):
    delta, _ = _write_folder(tmp_path / "cal", n=10_000)
    cal = load_calibration(tmp_path / "cal", max_samples=1000)
    assert cal.n_samples == 1000
    assert cal.delta[0] == delta[0] and cal.delta[-1] == delta[-1]
    assert np.median(cal.delta) == pytest.approx(np.median(delta), abs=4 * 1.25 * 0.002 / np.sqrt(1000))
    assert load_calibration(tmp_path / "cal", max_samples=None).n_samples == 10_000


def test_L_falls_back_to_the_json(tmp_path):
    def no_L(arr):
        arr.pop("L_m")
        return arr

    _write_folder(tmp_path / "a", arrays=no_L)
    assert load_calibration(tmp_path / "a").L == pytest.approx(0.25)
    doc = {"parameters": {"delta_mm": {"median": 12}, "d_mm": {"median": 65}},
           "specimens": [{"L_mm": 300}, {"L_mm": 300}, {"L_mm": 200}]}
    _write_folder(tmp_path / "b", json_doc=doc, arrays=no_L)
    assert load_calibration(tmp_path / "b").L == pytest.approx(0.30)


@pytest.mark.parametrize("breakage, path_end, word", [
    (lambda f: (f / "calibration.json").unlink(), "calibration.json", "not found"),
    (lambda f: (f / "posterior.npz").unlink(), "posterior.npz", "not found"),
    (lambda f: (f / "calibration.json").write_text("{not json"), "calibration.json", "JSON"),
    (lambda f: (f / "calibration.json").write_text(json.dumps({"parameters": {"delta_mm": {"median": 1}}})),
     "calibration.json", "parameters.d_mm"),
    (lambda f: (f / "calibration.json").write_text(json.dumps({"curve": {}})), "calibration.json",
     "parameters.delta_mm"),
])
def test_broken_folders_raise_input_error_naming_file_and_field(tmp_path, breakage, path_end, word):
    _write_folder(tmp_path / "cal")
    breakage(tmp_path / "cal")
    with pytest.raises(InputError, match=word) as err:
        load_calibration(tmp_path / "cal")
    assert err.value.path.endswith(path_end)


@pytest.mark.parametrize("arrays, word", [
    (lambda a: {k: v for k, v in a.items() if k != "d_m"}, "'d_m'"),
    (lambda a: {**a, "delta_m": np.full_like(a["delta_m"], np.nan)}, "non-finite"),
    (lambda a: {**a, "d_m": a["d_m"][:10]}, "same length"),
    (lambda a: {**a, "L_m": np.float64(-1.0)}, "L"),
])
def test_bad_posterior_arrays(tmp_path, arrays, word):
    _write_folder(tmp_path / "cal", arrays=arrays)
    with pytest.raises(InputError, match=word):
        load_calibration(tmp_path / "cal")


def test_missing_folder(tmp_path):
    with pytest.raises(InputError, match="not found") as err:
        load_calibration(tmp_path / "nope")
    assert err.value.path == str(tmp_path / "nope")
