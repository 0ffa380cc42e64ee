"""`airmat fit SCAN`: one JSON object on stdout; bad input exits 2 with one stderr line."""

import json

import numpy as np
import pytest

from airmat.cli import main
from data_synthetic.ply_write import write_ply
from data_synthetic.specimen_scan import specimen_scan

FIELDS = ("radius_mm", "kappa_per_m", "kappa_se_per_m", "axis", "inlier_fraction", "rms_mm", "arc_deg",
          "n_points", "converged")


@pytest.fixture(scope="module")
def scan_mm(tmp_path_factory):
    s = specimen_scan(4.0, n_points=30_000, arc_deg=60, seed=7)
    path = tmp_path_factory.mktemp("scans") / "specimen.ply"
    write_ply(path, s.points * 1e3, encoding="binary_big_endian", dtype="float64",
              extra={"confidence": np.ones(len(s.points), np.float32)})
    return path, s


def _run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_fit_prints_one_json_object_with_the_fields(scan_mm, capsys, tmp_path):
    path, s = scan_mm
    before = sorted(p.name for p in path.parent.iterdir())
    code, out, err = _run(["fit", str(path), "-q"], capsys)
    assert code == 0, err
    record = json.loads(out)
    for key in FIELDS:
        assert key in record
    assert record["radius_mm"] == pytest.approx(250.0, rel=0.005)
    assert abs(record["kappa_per_m"] - 4.0) < 4 * record["kappa_se_per_m"]
    assert abs(np.dot(record["axis"], s.axis)) > 0.999
    assert record["n_points"] == 30_000 and record["converged"] is True
    assert sorted(p.name for p in path.parent.iterdir()) == before  # fit writes no files


def test_scan_units_metres(tmp_path, capsys):
    s = specimen_scan(2.0, n_points=20_000, arc_deg=60, seed=8)
    path = tmp_path / "metres.ply"
    write_ply(path, s.points, dtype="float64", encoding="ascii")
    code, out, err = _run(["fit", str(path), "--scan-units", "m"], capsys)
    assert code == 0, err
    assert json.loads(out)["radius_mm"] == pytest.approx(500.0, rel=0.005)
    # the same file read as millimetres is caught by its size
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "--scan-units m" in lines[0] and str(path) in lines[0]


def test_flat_specimen_has_null_radius(tmp_path, capsys):
    path = tmp_path / "flat.ply"
    write_ply(path, specimen_scan(0.0, n_points=20_000, seed=9).points * 1e3)
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 0, err
    record = json.loads(out)
    assert record["radius_mm"] is None
    assert record["kappa_per_m"] < 3 * record["kappa_se_per_m"]


@pytest.mark.parametrize("case", ["missing", "empty", "truncated", "not_a_cylinder", "bad_noise"])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, case):
    path = tmp_path / f"{case}.ply"
    extra = []
    if case == "empty":
        path.write_bytes(b"")
    elif case == "truncated":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (1000, 3)))
        path.write_bytes(path.read_bytes()[:-100])
    elif case == "not_a_cylinder":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (20_000, 3)))
    elif case == "bad_noise":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (1000, 3)))
        extra = ["--noise-mm", "-1"]
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = _run(["fit", str(path), *extra], capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("airmat fit: ")
    assert "Traceback" not in err
    if case != "bad_noise":
        assert str(path) in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_fit_that_did_not_converge_exits_3_with_one_line_naming_the_scan(scan_mm, capsys, monkeypatch):
    import dataclasses

    import calib.cylinder_fit as cf

    real = cf.full_resolution_fit

    def stopped(*args, **kwargs):                       # the last least squares ran out of iterations
        frame, final, used, n_more = real(*args, **kwargs)
        return frame, dataclasses.replace(final, converged=False, message="max_nfev reached"), used, n_more

    monkeypatch.setattr(cf, "full_resolution_fit", stopped)
    path, _ = scan_mm
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 3                                    # the "not converged" policy (airmat.cli._exit)
    assert json.loads(out)["converged"] is False
    warnings = [ln for ln in err.splitlines() if "not converged" in ln]
    assert len(warnings) == 1 and str(path) in warnings[0] and "max_nfev reached" in warnings[0]
    assert warnings[0].startswith("airmat fit: not converged: ")
