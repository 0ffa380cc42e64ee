"""`airmat validate`: bad options exit 2 with one line and write nothing."""

import numpy as np
import pytest

from airmat.cli import main


@pytest.mark.parametrize("args,words", [
    (["--l-over-L", "0.5,x"], "comma-separated numbers"),
    (["--l-over-L", "0.5,1.2"], "(0, 1)"),
    (["--resolution-mm", "100"], "(0, 75]"),
    (["--jobs", "0"], "--jobs must be at least 1"),
    (["--L-mm", "20"], "[50, 2000]"),
    (["--L-mm", "150", "--resolution-mm", "40"], "(0, 37.5]"),
    (["--L-mm", "150", "--calibration", "somewhere"], "the calibration fixes L"),
])
def test_bad_options_exit_2_with_one_line(tmp_path, capsys, args, words):
    out = tmp_path / "validate"
    assert main(["validate", "--out", str(out)] + args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert not out.exists()


def test_the_specimen_takes_another_L(tmp_path, capsys):
    import json

    out = tmp_path / "validate"
    assert main(["validate", "--out", str(out), "--L-mm", "200", "--l-over-L", "0.7", "--resolution-mm", "50",
                 "-q"]) == 0
    doc = json.loads((out / "validate.json").read_text())
    assert doc["L_mm"] == 200 and "L = 200 mm" in doc["experiment"]
    (p,) = doc["points"]
    assert p["converged"] and p["kappa_polygon_per_m"] > 0 and p["kappa_eq3_per_m"] > 0
    # the polygon taken apart, next to Equation 3's L* and θ at L = 200 mm, l/L = 0.7
    from airmat.calib.model import bend_angle, polygon_side
    assert p["model_side_mm"] == pytest.approx(1e3 * float(polygon_side(0.14, 0.2, 0.0, 0.07)), abs=0.01)
    assert p["model_angle_deg"] == pytest.approx(float(np.degrees(bend_angle(0.14, 0.2, 0.0, 0.07))), abs=0.01)
    assert 0.8 < p["fold_side_mm"] / p["model_side_mm"] < 1.2 and 90 < p["fold_angle_deg"] < 180
    header = (out / "validate.csv").read_text().splitlines()[0].split(",")
    assert {"fold_side_mm", "model_side_mm", "fold_angle_deg", "model_angle_deg"} <= set(header)


def test_missing_calibration_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "validate"
    assert main(["validate", "--out", str(out), "--calibration", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope" in err[0], err
    assert not out.exists()


@pytest.mark.slow
def test_validate_with_a_calibration_reproduces_its_curve(tmp_path, capsys, monkeypatch, wrote):
    # synth -> calibrate -> validate --calibration: the table and the plot of both curves, each simulated
    # κ₁ within 5 % of the calibrated median at 50 mm (the map built at that resolution)
    import json

    import numpy as np

    monkeypatch.setenv("AIRMAT_CACHE", str(tmp_path / "cache"))
    assert main(["synth", str(tmp_path / "set"), "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9", "-q"]) == 0
    assert main(["calibrate", str(tmp_path / "set" / "manifest.csv"), "--out", str(tmp_path / "cal"),
                 "--walkers", "16", "--max-steps", "200", "-q"]) in (0, 3)
    out = tmp_path / "validate"
    capsys.readouterr()
    assert main(["validate", "--out", str(out), "--calibration", str(tmp_path / "cal"), "--resolution-mm", "50",
                 "--l-over-L", "0.4,0.6,0.8", "--jobs", "2"]) == 0
    printed = capsys.readouterr().out
    assert "calibrated κ₁ median" in printed and "difference" in printed
    assert wrote(printed, out) == {p.name for p in out.iterdir()} >= {"validate.json", "validate.csv", "validate.png"}
    doc = json.loads((out / "validate.json").read_text())
    k = np.array([p["kappa_section_string_face_per_m"] for p in doc["points"]])
    k_cal = np.array([p["kappa_eq3_per_m"] for p in doc["points"]])
    assert np.all(k_cal > 0) and np.all(np.abs(k / k_cal - 1) <= 0.05), k / k_cal - 1
    assert np.all(np.diff(doc["length_map"]["l_sim_mm"]) > 0) and doc["equation3"]["delta_mm"] > 0
    assert (out / "validate.png").stat().st_size > 0 and len(list((tmp_path / "cache").rglob("*.json"))) == 1
