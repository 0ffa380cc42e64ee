"""calibration.json + posterior.npz: write -> read gives the same Calibration within the files' precision."""

import numpy as np
import pytest

from airmat.calib.calibrate import Calibration, SpecimenFit
from airmat.calib.calibration_io import read_calibration, write_calibration
from airmat.calib.curve import kappa_curve
from airmat.calib.manifest import Manifest
from airmat.calib.posterior import ParamSummary, Posterior
from airmat.design.calibration_source import from_calibration, load_calibration


def _calibration(tmp_path, n=3000, seed=1):
    rng = np.random.default_rng(seed)
    samples = np.column_stack([rng.normal(0.018, 0.001, n), rng.normal(0.07, 0.003, n),
                               np.abs(rng.normal(0.1, 0.02, n))])
    L = np.array([0.3, 0.3, 0.3])
    man = Manifest(path=str(tmp_path / "manifest.csv"), scans=("a.ply", "b.ply", "c.ply"),
                   scan_paths=tuple(str(tmp_path / s) for s in ("a.ply", "b.ply", "c.ply")),
                   l=np.array([0.1, 0.2, 0.25]), L=L, surface_offset=np.zeros(3))
    specimens = tuple(SpecimenFit(scan=s, path=p, l=l, L=0.3, surface_offset=0.0, kappa=k, kappa_se=0.05,
                                  radius=1 / k if k else np.inf, inlier_fraction=0.9, rms=0.001, arc_deg=80.0,
                                  n_points=1000, fit_converged=True)
                      for s, p, l, k in zip(man.scans, man.scan_paths, man.l, (9.0, 4.0, 0.0)))
    post = Posterior(samples=samples, log_prob=rng.normal(size=n), delta=ParamSummary.of(samples[:, 0]),
                     d=ParamSummary.of(samples[:, 1]), sigma=ParamSummary.of(samples[:, 2]),
                     start=np.array([0.018, 0.07, 0.1]), tau=np.array([12.0, 14.0, 20.0]), acceptance_fraction=0.4,
                     n_steps=1000, n_walkers=32, burn=100, thin=5, converged=True, n_iter=1000, residual=0.9,
                     message="ok")
    return Calibration(manifest=man, specimens=specimens, posterior=post,
                       curve=kappa_curve(samples, 0.3, n_grid=11), kappa_model=np.array([9.1, 4.2, 0.1]), seed=7,
                       timings={"fit": 1.0})


def test_round_trip(tmp_path):
    cal = _calibration(tmp_path)
    write_calibration(cal, tmp_path / "cal")
    back = read_calibration(tmp_path / "cal")
    np.testing.assert_array_equal(back.posterior.samples, cal.posterior.samples)      # npz: exact
    np.testing.assert_array_equal(back.posterior.log_prob, cal.posterior.log_prob)
    np.testing.assert_array_equal(back.posterior.start, cal.posterior.start)
    assert back.posterior.delta == cal.posterior.delta and back.posterior.sigma == cal.posterior.sigma
    for key in ("tau", "acceptance_fraction", "residual"):
        np.testing.assert_allclose(getattr(back.posterior, key), getattr(cal.posterior, key), rtol=1e-12)
    for key in ("n_steps", "n_walkers", "burn", "thin", "converged", "message"):
        assert getattr(back.posterior, key) == getattr(cal.posterior, key)
    p0, p1 = cal.posterior.priors, back.posterior.priors
    for key in ("delta_max_fraction", "d_min", "d_max", "sigma_scale", "sigma_max"):
        assert getattr(p1, key) == pytest.approx(getattr(p0, key), rel=1e-12)
    assert back.curve.L == cal.curve.L and back.curve.n_draws == cal.curve.n_draws
    for key in ("l_over_L", "median", "lo68", "hi68", "lo95", "hi95"):
        np.testing.assert_allclose(getattr(back.curve, key), getattr(cal.curve, key), rtol=1e-12)
    assert back.manifest.path == cal.manifest.path and back.manifest.scans == cal.manifest.scans
    np.testing.assert_allclose(back.manifest.l, cal.manifest.l, rtol=1e-12)
    for s, t in zip(back.specimens, cal.specimens):
        assert (s.scan, s.path, s.n_points, s.fit_converged, s.radius == t.radius) == \
               (t.scan, t.path, t.n_points, t.fit_converged, True)
        assert s.kappa == pytest.approx(t.kappa, rel=1e-12) and s.l == pytest.approx(t.l, rel=1e-12)
    np.testing.assert_allclose(back.kappa_model, cal.kappa_model, rtol=1e-12)
    assert back.seed == cal.seed


def test_designer_source_is_the_same_from_memory_and_from_files(tmp_path):
    cal = _calibration(tmp_path)
    write_calibration(cal, tmp_path / "cal")
    mem = from_calibration(cal, source=str(tmp_path / "cal"))
    disk = load_calibration(tmp_path / "cal")
    np.testing.assert_array_equal(mem.delta, disk.delta)
    np.testing.assert_array_equal(mem.d, disk.d)
    assert (mem.L, mem.label, mem.source, mem.uncalibrated) == (disk.L, disk.label, disk.source, False)
    assert mem.n_samples == 2000                                   # thinned evenly from 3000
