"""Synthetic calibration sets: truth consistent with Equation 3, formats, seeding, atomicity."""

import json
from pathlib import Path

import numpy as np
import pytest

import airmat.synthetic.specimen_scan as specimen_scan_module
from airmat.errors import InputError
from airmat.calib.manifest import read_manifest
from airmat.calib.model import kappa1
from airmat.calib.scan_io import read_scan
from airmat.synthetic.calibration_set import DEFAULT_L_OVER_L, PLY_FORMATS, calibration_set
from airmat.synthetic.specimen_scan import specimen_scan

RATIOS = (0.3, 0.5, 0.7, 0.9, 0.95, 0.6)
N = 3000


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("set") / "cal"
    return calibration_set(out, l_over_L=RATIOS, n_points=N, seed=3)


def test_defaults_are_12_specimens_with_a_flat_one():
    r = np.asarray(DEFAULT_L_OVER_L)
    assert r.size == 12 and r[0] == 0.3 and r[-1] == 0.95 and np.all(np.diff(r) > 0)
    assert np.any(r * 0.300 >= 0.300 - 2 * 0.018)


def test_manifest_and_truth_agree_with_equation_3(small_set):
    m = read_manifest(small_set.manifest)
    truth = json.loads(Path(small_set.truth_path).read_text())
    assert truth == small_set.truth
    assert m.scans == small_set.scans and len(m) == len(RATIOS)
    np.testing.assert_allclose(m.L, 0.3)
    np.testing.assert_allclose(m.l, np.round(np.array(RATIOS) * 300, 1) / 1e3)
    k_model = np.array([s["kappa_model_per_m"] for s in truth["specimens"]])
    k_true = np.array([s["kappa_per_m"] for s in truth["specimens"]])
    np.testing.assert_allclose(k_model, kappa1(m.l, 0.3, 0.018, 0.070), rtol=1e-12)
    flat = m.l >= 0.3 - 2 * 0.018
    assert flat.sum() == 2 and np.all(k_true[flat] == 0)
    ratio = k_true[~flat] / k_model[~flat]
    assert np.all(ratio != 1) and np.all(np.abs(np.log(ratio)) < 4 * 0.03)
    assert truth["sigma_per_m"] == pytest.approx(np.sqrt(np.mean((k_true - k_model) ** 2)))
    assert truth["sigma_per_m"] > 0
    assert (truth["delta_mm"], truth["d_mm"], truth["L_mm"]) == (18.0, 70.0, 300.0)


def test_scans_read_back_as_the_specimen_points(small_set):
    folder = small_set.folder
    seen = set()
    for i, name in enumerate(small_set.scans):
        head = (Path(folder) / name).read_bytes()[:400].split(b"end_header")[0].decode()
        enc, dtype, colors, extra = PLY_FORMATS[i % len(PLY_FORMATS)]
        assert f"format {enc} 1.0" in head
        assert ("property double x" if dtype == "float64" else "property float x") in head
        assert ("red" in head) == colors and all(e in head for e in extra)
        seen.add((enc, dtype))
        scan = read_scan(f"{folder}/{name}")
        kappa = small_set.truth["specimens"][i]["kappa_per_m"]
        assert scan.points.shape == (N, 3)
        # the generator's own output, rebuilt from the same seed: identical up to float32
        rebuilt = _rebuild(small_set, i, kappa)
        tol = 1e-6 * np.abs(rebuilt).max() if dtype == "float32" else 1e-12
        np.testing.assert_allclose(scan.points, rebuilt, atol=tol)
    assert len(seen) >= 5


def _rebuild(small_set, i, kappa):
    seeds = np.random.default_rng(small_set.truth["seed"])
    seeds.standard_normal(len(small_set.scans))
    scan_seeds = seeds.integers(2**31, size=len(small_set.scans))
    return specimen_scan(kappa, L=0.3, thickness=0.07, n_points=N, seed=int(scan_seeds[i])).points


def test_same_seed_same_bytes_other_seed_differs(tmp_path):
    a = calibration_set(tmp_path / "a", l_over_L=RATIOS[:3], n_points=2000, seed=5)
    calibration_set(tmp_path / "b", l_over_L=RATIOS[:3], n_points=2000, seed=5)
    c = calibration_set(tmp_path / "c", l_over_L=RATIOS[:3], n_points=2000, seed=6)
    names = list(a.scans) + ["manifest.csv", "truth.json"]
    for n in names:
        assert (tmp_path / "a" / n).read_bytes() == (tmp_path / "b" / n).read_bytes(), n
    assert (tmp_path / "a" / a.scans[0]).read_bytes() != (tmp_path / "c" / c.scans[0]).read_bytes()


def test_failure_midway_writes_nothing(tmp_path, monkeypatch):
    calls = []
    real = specimen_scan_module.specimen_scan

    def flaky(kappa, **kw):
        calls.append(kappa)
        if len(calls) == 3:
            raise InputError("boom")
        return real(kappa, **kw)

    monkeypatch.setattr(specimen_scan_module, "specimen_scan", flaky)
    out = tmp_path / "set"
    with pytest.raises(InputError, match="boom"):
        calibration_set(out, l_over_L=RATIOS, n_points=2000, seed=0)
    assert not out.exists() or not any(out.iterdir())
    assert not any(p.name.startswith(".set.staging") for p in tmp_path.iterdir())


@pytest.mark.parametrize("kwargs, match", [
    (dict(l_over_L=(0.3, 0.5)), "at least 3"),
    (dict(l_over_L=(0.3, 0.5, 1.2)), r"\(0, 1\]"),
    (dict(delta=0.2), "Delta"),
    (dict(d=0.0), "d > 0"),
    (dict(n_points=10), "too few"),
    (dict(scatter=-0.1), "scatter"),
])
def test_bad_parameters(tmp_path, kwargs, match):
    with pytest.raises(InputError, match=match):
        calibration_set(tmp_path / "x", **kwargs)
    assert not (tmp_path / "x").exists()
