"""airmat.check.monte_carlo: the sampled string lengths, their statistics, and the known answer of a collapsed posterior."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from airmat.check.inflation_check import check, design_strings
from airmat.check.monte_carlo import MonteCarloDraws, draw, quantile_se, summarize
from airmat.design.design_io import read_design

import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from test_inflate_cli import make_design  # noqa: E402


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """The CLI tests' two-string design: its calibration is one point (the medians of design.json), no sigma."""
    return read_design(make_design(tmp_path_factory.mktemp("mc") / "design"))


def _spread(design, *, sigma=0.5, n=50, seed=4):
    rng = np.random.default_rng(seed)
    cal = replace(design.calibration, delta=rng.normal(0.010, 0.002, n).clip(0), d=rng.normal(0.07, 0.004, n),
                  sigma=np.full(n, sigma))
    return replace(design, calibration=cal)


def test_a_collapsed_posterior_without_scatter_draws_the_median_lengths_exactly(small):
    dr = draw(small, 5, seed=7)
    assert small.calibration.n_samples == 1 and small.calibration.sigma is None
    med = design_strings(small, "median").rest
    assert dr.rest.shape == (5, 2)
    assert all(r.tobytes() == med.tobytes() for r in dr.rest)
    assert np.all(dr.sigma == 0) and "sigma = 0" in dr.sigma_source


def test_draws_are_seeded_and_scatter_with_sigma(small):
    d = _spread(small)
    a, b, c = draw(d, 40, seed=1), draw(d, 40, seed=1), draw(d, 40, seed=2)
    assert a.rest.tobytes() == b.rest.tobytes() and a.rest.tobytes() != c.rest.tobytes()
    assert a.sigma_source == "posterior"
    # the scatter is independent per string: the two strings' curvature changes are far from equal
    dk = a.kappa - a.kappa_median
    assert np.std(dk[:, 0] - dk[:, 1]) > 0.3
    # a larger curvature needs a shorter string: the length falls as kappa rises (Equation 3)
    assert np.corrcoef(a.kappa[:, 0], a.length[:, 0])[0, 1] < -0.99


def test_sigma_alone_moves_lengths_around_the_median(small):
    """A one-point posterior with sigma: the mean curvature change is about 0, its spread about sigma."""
    cal = replace(small.calibration, sigma=np.array([0.4]))
    dr = draw(replace(small, calibration=cal), 400, seed=3)
    dk = dr.kappa - dr.kappa_median
    # dk is sigma * z over 400 draws x 2 strings (800 independent normals): the mean's standard error is
    # sigma / sqrt(N), the sample standard deviation's sigma / sqrt(2 N); both held to 4 standard errors
    assert dk.size == 800
    assert abs(dk.mean()) < 4 * 0.4 / np.sqrt(dk.size)
    assert dk.std() == pytest.approx(0.4, rel=4 / np.sqrt(2 * dk.size))


class _Dev:
    def __init__(self, rms, per):
        self.rms, self.per_vertex = rms, per


def test_summary_statistics_and_sensitivity():
    rng = np.random.default_rng(0)
    k, n = 30, 200
    kappa = rng.normal(0, 1, (n, k))
    rms = 0.01 + 0.002 * kappa[:, 7] - 0.001 * kappa[:, 3] + 0.0002 * rng.normal(size=n)
    dr = MonteCarloDraws(seed=0, delta=np.zeros(n), d=np.zeros(n), sigma=np.ones(n), kappa=kappa,
                         kappa_median=np.zeros(k), length=kappa, rest=kappa, sigma_source="posterior")
    per = rng.uniform(0, 1, (n, 5))
    mc = summarize(dr, [_Dev(r, p) for r, p in zip(rms, per)], tolerance=0.01)
    idx, corr = mc.sensitive()
    assert list(idx[:2]) == [7, 3] and corr[0] > 0.8 and corr[1] < -0.3 and len(idx) == 10
    st = mc.stats()
    assert st["rms_median"] == pytest.approx(np.median(rms)) and st["rms_p95"] == pytest.approx(np.quantile(rms, 0.95))
    assert st["p_within"] == pytest.approx(np.mean(rms <= 0.01))
    # the bootstrap standard error of the median is near the asymptotic one, 1.2533 s / sqrt(n) for a normal
    assert 0.5 < st["rms_median_se"] / (1.2533 * np.std(rms) / np.sqrt(n)) < 1.6
    np.testing.assert_allclose(mc.per_vertex_q, np.quantile(per, [0.5, 0.95], axis=0))
    assert quantile_se(rms, 0.95, seed=1) > 0


def test_the_check_of_a_collapsed_posterior_equals_its_median_run(small):
    """sigma = 0 and a one-point posterior: every sample is the median run, so are the quantiles."""
    res = check(small, resolution=0.05, envelope=False, samples=3, seed=5, tolerance=0.05)
    med, mc = res.runs["median"], res.monte_carlo
    assert mc.rms.tolist() == [med.deviation.rms] * 3
    assert mc.per_vertex_q[0].tobytes() == med.deviation.per_vertex.tobytes()
    assert mc.per_vertex_q[1].tobytes() == med.deviation.per_vertex.tobytes()
    assert mc.stats()["rms_p95_se"] == 0.0 and mc.stats()["p_within"] == float(med.deviation.rms <= 0.05)
    assert mc.sensitive()[0].size == 0          # no spread: no string moves the shape


def test_a_check_with_samples_puts_its_band_in_inflated_3dm_and_the_report(small, tmp_path):
    """The API end to end: check(samples=K) -> write_check's inflated.3dm layer and report.html's band."""
    import rhino3dm

    from airmat.check.report import write_check
    from airmat.design.export.rhino import band_colours
    from airmat.report.page import report_html

    res = check(_spread(small), resolution=0.05, envelope=False, samples=6, seed=5, tolerance=0.05)
    q95 = res.monte_carlo.per_vertex_q[1]
    assert np.ptp(q95) > 0
    write_check(res, tmp_path)
    model = rhino3dm.File3dm.Read(str(tmp_path / "inflated.3dm"))
    layers = {model.Layers.FindIndex(i).Index: model.Layers.FindIndex(i) for i in range(len(model.Layers))}
    (obj,) = [o for o in model.Objects if layers[o.Attributes.LayerIndex].FullPath == "monte_carlo::p95"]
    assert not layers[obj.Attributes.LayerIndex].Visible
    mesh = obj.Geometry
    got = np.array([tuple(mesh.VertexColors[i])[:3] for i in range(mesh.VertexColors.Count)])
    np.testing.assert_array_equal(got, band_colours(q95 * 1000)[0])
    pts = np.array([[p.X, p.Y, p.Z] for p in mesh.Vertices])
    np.testing.assert_allclose(pts, small.approx.xyz * 1000, atol=1e-3)           # Ŝ itself
    text = dict(obj.Attributes.GetUserStrings())
    assert float(text["colour_high_mm"]) == pytest.approx(q95.max() * 1000, abs=0.006)
    html = report_html(check=res)
    assert html.count('Plotly.newPlot("check-band"') == 1 and 'id="monte-carlo-stats"' in html
    assert "<td>samples</td><td>6</td>" in html and 'id="monte-carlo-strings"' in html


def test_two_processes_write_the_same_check_files(small, tmp_path):
    """With workers the figure is drawn on a forked process beside the other files (Linux): the same bytes,
    inflated_bands.ply included."""
    from airmat.check.report import write_check

    res = check(_spread(small), resolution=0.05, envelope=False, samples=2, seed=5)
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir(), two.mkdir()
    assert write_check(res, one) == write_check(res, two, workers=2)
    names = sorted(p.name for p in one.iterdir())
    assert names == sorted(p.name for p in two.iterdir()) and "deviation.png" in names and "inflated_bands.ply" in names
    for name in names:
        assert (one / name).read_bytes() == (two / name).read_bytes(), name
