"""Calibration end to end (synthetic scans -> fits -> posterior -> curve) and its report."""

import csv
import json

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.calibrate import Calibration, SpecimenFit, _reference_face, calibrate
from airmat.calib.curve import kappa_curve
from airmat.calib.manifest import Manifest
from airmat.calib.model import kappa1
from airmat.calib.plots import corner_figure, curve_figure, plot_corner, plot_curve
from airmat.calib.posterior import sample_posterior, specimen_data
from airmat.calib.calibration_io import calibration_dict, summary_text, write_calibration
from airmat.synthetic.calibration_set import DEFAULT_L_OVER_L, calibration_set

DELTA, D, L = 0.018, 0.070, 0.300


@pytest.fixture(scope="module")
def synthetic_set(tmp_path_factory):
    return calibration_set(tmp_path_factory.mktemp("cal") / "set", n_points=20_000, seed=1)


@pytest.fixture(scope="module")
def end_to_end(synthetic_set):
    return calibrate(synthetic_set.manifest, seed=0)


def test_end_to_end_recovers_delta_and_d(synthetic_set, end_to_end):
    cal, truth = end_to_end, synthetic_set.truth
    p = cal.posterior
    assert p.converged
    assert p.delta.lo95 < truth["delta_mm"] * 1e-3 < p.delta.hi95
    assert p.d.lo95 < truth["d_mm"] * 1e-3 < p.d.hi95
    assert p.sigma.lo95 < truth["sigma_per_m"] < p.sigma.hi95
    # each fitted curvature is within a few combined errors of its true value
    k_true = np.array([s["kappa_per_m"] for s in truth["specimens"]])
    k_fit = np.array([s.kappa for s in cal.specimens])
    se = np.array([s.kappa_se for s in cal.specimens])
    assert np.all(np.abs(k_fit - k_true) < 5 * se + 0.01 * k_true + 0.02)
    assert len(cal.specimens) == len(DEFAULT_L_OVER_L) and cal.curve.L == pytest.approx(L)
    truth_curve = kappa1(cal.curve.l_over_L * L, L, DELTA, D)
    inside = (cal.curve.lo95 <= truth_curve + 1e-9) & (truth_curve - 1e-9 <= cal.curve.hi95)
    assert inside.mean() > 0.9
    assert set(cal.timings) == {"read", "fit", "mcmc", "curve"}


@pytest.mark.slow  # refits every scan
def test_same_seed_same_calibration(synthetic_set, end_to_end):
    again = calibrate(synthetic_set.manifest, seed=0, max_steps=200)
    first = [(s.kappa, s.kappa_se) for s in end_to_end.specimens]
    assert [(s.kappa, s.kappa_se) for s in again.specimens] == first


def test_not_a_cylinder_names_the_scan(tmp_path):
    from airmat.synthetic.ply_write import write_ply

    rng = np.random.default_rng(0)
    for name in ("a.ply", "b.ply", "c.ply"):
        write_ply(tmp_path / name, rng.uniform(-200, 200, (5000, 3)))
    (tmp_path / "m.csv").write_text("scan,l_mm,L_mm\na.ply,90,300\nb.ply,150,300\nc.ply,200,300\n")
    with pytest.raises(InputError) as info:
        calibrate(tmp_path / "m.csv")
    assert info.value.path == str((tmp_path / "a.ply").resolve())


def test_reference_face_offset_is_exact():
    R, off, se = 0.2, 0.07, 0.01
    k, s = _reference_face(1 / R, se, off, "x")
    assert k == pytest.approx(1 / (R + off))
    h = 1e-6  # d(1/(1/kappa + off))/dkappa by central difference
    deriv = (1 / (1 / (1 / R + h) + off) - 1 / (1 / (1 / R - h) + off)) / (2 * h)
    assert s == pytest.approx(se * deriv, rel=1e-6)
    assert _reference_face(0.0, se, off, "x") == (0.0, se)  # flat stays flat
    with pytest.raises(InputError, match="larger than the fitted radius"):
        _reference_face(1 / R, se, -0.25, "x")


@pytest.fixture(scope="module")
def hand_made():
    """A Calibration from seeded curvatures (no scans), for the writers."""
    return hand_made_calibration()


def hand_made_calibration(max_steps=300):
    rng = np.random.default_rng(2)
    l = np.array(DEFAULT_L_OVER_L) * L
    se = np.full(l.size, 0.02)
    k = np.abs(kappa1(l, L, DELTA, D) + rng.normal(0, np.hypot(se, 0.1)))
    k[-1] = 0.0  # a fit that found the flat specimen exactly flat: radius inf
    post = sample_posterior(specimen_data(k, se, l, L), seed=0, max_steps=max_steps)
    names = tuple(f"s{i}.ply" for i in range(l.size))
    m = Manifest(path="m.csv", scans=names, scan_paths=names, l=l, L=np.full(l.size, L),
                 surface_offset=np.zeros(l.size))
    specs = tuple(SpecimenFit(scan=n, path=n, l=li, L=L, surface_offset=0.0, kappa=ki, kappa_se=0.02,
                              radius=1 / ki if ki > 0 else np.inf, inlier_fraction=0.9, rms=5e-4,
                              arc_deg=90.0, n_points=1000, fit_converged=True)
                  for n, li, ki in zip(names, l, k))
    curve = kappa_curve(post.samples, L, n_grid=21)
    return Calibration(manifest=m, specimens=specs, posterior=post, curve=curve,
                       kappa_model=kappa1(l, L, post.delta.median, post.d.median), seed=0,
                       timings={"read": 0.0, "fit": 0.0, "mcmc": 1.0, "curve": 0.1})


def test_report_files_and_fields(tmp_path, hand_made):
    cal = hand_made
    truth = {"delta_mm": 18.0, "d_mm": 70.0, "sigma_per_m": 0.1}
    files = write_calibration(cal, tmp_path, truth=truth)
    assert [f.name for f in files] == ["calibration.json", "posterior.npz", "specimens.csv"]
    doc = json.loads((tmp_path / "calibration.json").read_text())
    for name, scale, p in (("delta_mm", 1e3, cal.posterior.delta), ("d_mm", 1e3, cal.posterior.d),
                           ("sigma_per_m", 1.0, cal.posterior.sigma)):
        assert doc["parameters"][name] == pytest.approx(
            {"median": p.median * scale, "lo95": p.lo95 * scale, "hi95": p.hi95 * scale})
    assert {"tau", "acceptance_fraction", "n_steps", "converged"} <= doc["diagnostics"].keys()
    assert doc["curve"]["L_mm"] == pytest.approx(300.0) and len(doc["curve"]["l_over_L"]) == 21
    assert set(doc["curve"]["kappa_per_m"]) == {"median", "lo68", "hi68", "lo95", "hi95"}
    spec_keys = {"scan", "l_mm", "L_mm", "kappa_per_m", "kappa_se_per_m", "radius_mm",
                 "inlier_fraction", "rms_mm", "arc_deg"}
    assert all(spec_keys <= s.keys() for s in doc["specimens"])
    assert doc["specimens"][-1]["radius_mm"] is None  # flat: no finite radius, valid JSON
    assert {"priors", "seed", "airmat_version", "truth"} <= doc.keys()
    with np.load(tmp_path / "posterior.npz") as npz:
        assert {"delta_m", "d_m", "sigma_per_m", "L_m"} <= set(npz.files)
        np.testing.assert_array_equal(npz["d_m"], cal.posterior.samples[:, 1])
        assert float(npz["L_m"]) == pytest.approx(L)
    rows = list(csv.DictReader((tmp_path / "specimens.csv").read_text().splitlines()))
    assert len(rows) == 12 and float(rows[0]["l_mm"]) == pytest.approx(90.0)
    assert calibration_dict(cal)["specimens"][0]["kappa_per_m"] == pytest.approx(float(rows[0]["kappa_per_m"]))
    assert "Delta =" in summary_text(cal, tmp_path) and str(tmp_path) in summary_text(cal, tmp_path)


def test_plots_are_written(tmp_path, hand_made):
    cal = hand_made
    truth = {"delta_mm": 18.0, "d_mm": 70.0, "sigma_per_m": 0.1}
    for path in (plot_curve(cal, tmp_path / "curve.png", truth=truth),
                 plot_corner(cal.posterior, tmp_path / "corner.png", truths=truth),
                 plot_curve(cal, tmp_path / "curve2.png")):
        data = path.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_plot_functions_return_the_figure_the_writers_save(tmp_path, hand_made):
    import io

    from matplotlib.figure import Figure

    truth = {"delta_mm": 18.0, "d_mm": 70.0, "sigma_per_m": 0.1}
    for fig, path, dpi in ((curve_figure(hand_made, truth=truth), plot_curve(hand_made, tmp_path / "c.png",
                                                                              truth=truth), 120),
                           (corner_figure(hand_made.posterior), plot_corner(hand_made.posterior,
                                                                            tmp_path / "k.png"), 110)):
        assert isinstance(fig, Figure)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi)
        assert buf.getvalue() == path.read_bytes()
    curve = curve_figure(hand_made, truth=truth)
    assert any(t.startswith("truth") for t in curve.axes[0].get_legend_handles_labels()[1])
    assert len(corner_figure(hand_made.posterior).axes) == 9      # 3 x 3 corner grid

