"""`airmat correct`: a synthetic as-built scan (known truth) registered, learned from and corrected; bad input."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from airmat.calib.scan_io import read_scan
from airmat.cli import main
from airmat.design.design_io import read_design, write_design

from test_inflate_cli import make_design

#: the two-string design at 50 mm (its strings span 300 mm), 20 000 points
SMALL = ["--resolution-mm", "50"]


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    """The CLI tests' two-string design with a calibration posterior of 400 samples (the update needs a spread)."""
    d = read_design(make_design(tmp_path_factory.mktemp("correct") / "design0"))
    rng = np.random.default_rng(4)
    cal = replace(d.calibration, delta=rng.normal(0.010, 0.001, 400).clip(0), d=rng.normal(0.07, 0.002, 400),
                  sigma=np.full(400, 0.05))
    out = tmp_path_factory.mktemp("correct") / "design"
    out.mkdir()
    write_design(replace(d, calibration=cal), out)
    return out


@pytest.fixture(scope="module")
def built(design, tmp_path_factory):
    out = tmp_path_factory.mktemp("correct_built") / "built"
    assert main(["synth-built", str(design), "--out", str(out), "--cut-error-mm", "3", "--delta-mm", "13",
                 "--thickness-mm", "75", "--seed", "3", "--points", "20000", "-q", *SMALL]) == 0
    return out


@pytest.fixture(scope="module")
def corrected(design, built, tmp_path_factory):
    out = tmp_path_factory.mktemp("correct_out") / "corr"
    code = main(["correct", str(design), str(built / "scan.ply"), "--out", str(out), *SMALL])
    assert code == 0                # the update converged
    return out, code


def test_correct_writes_a_design_folder_with_the_scan_s_lessons(corrected, design):
    out, _ = corrected
    names = {p.name for p in out.iterdir()}
    assert {"design.json", "correct.json", "retie.csv", "retie.json", "retie.png", "deviation_target.png",
            "deviation_prediction.png", "deviation.ply", "report.html"} <= names
    new, old = read_design(out), read_design(design)
    assert np.array_equal(new.approx.xyz, old.approx.xyz)            # Ŝ unchanged
    assert [s.dash.id for s in new.pattern.strings] == [s.dash.id for s in old.pattern.strings]
    doc = json.loads((out / "correct.json").read_text())
    assert doc["scan"] == "scan.ply" and doc["surface"] in ("top", "bottom")
    assert len(doc["strings"]) == 2 and {"error_mm", "kept", "length_mm"} <= set(doc["strings"][0])
    assert "As built" in (out / "report.html").read_text(encoding="utf-8")


def test_correct_json_matches_its_schema_and_the_schema_refuses_a_broken_one(corrected):
    """correct.json against airmat/schemas/correct.schema.json (package data); a broken copy is refused."""
    import importlib.resources

    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((importlib.resources.files("airmat") / "schemas" / "correct.schema.json").read_text())
    v = jsonschema.Draft202012Validator(schema)
    doc = json.loads((corrected[0] / "correct.json").read_text())
    assert not [e.message for e in v.iter_errors(doc)]
    for edit in (lambda d: d["registration"].pop("rms_mm"), lambda d: d.update(surface="side"),
                 lambda d: d["update"].update(delta_95_mm=[1.0])):
        broken = json.loads(json.dumps(doc))
        edit(broken)
        assert list(v.iter_errors(broken))


def test_the_registration_recovers_the_scan_s_pose(corrected, built):
    """The scan's stated pose (truth.json) and the recovered one put its points within a few mm: the
    registration fits the scan to the prediction, which the built mattress misses by the deviation."""
    out, _ = corrected
    truth = json.loads((built / "truth.json").read_text())["scan_to_design"]
    reg = json.loads((out / "correct.json").read_text())["registration"]
    s = read_scan(built / "scan.ply", specimen=False)
    p = (s.points + s.offset) * 1e3
    true = p @ np.array(truth["rotation"]).T + truth["translation_mm"]
    found = (reg["scale"] * p) @ np.array(reg["rotation"]).T + reg["translation_mm"]
    err = np.sqrt(np.mean(np.sum((true - found) ** 2, axis=1)))
    dev = json.loads((out / "correct.json").read_text())["deviation"]["to_prediction"]["rms_mm"]
    assert err < dev + 1.0, (err, dev)


def test_the_update_moves_delta_toward_the_true_world(corrected):
    """The world's Δ (13 mm) lies above the calibration's 95 % interval; the scan pulls the estimate up."""
    u = json.loads((corrected[0] / "correct.json").read_text())["update"]
    assert u["prior_delta_95_mm"][1] < 13.0
    assert u["delta_mm"] > 0.5 * sum(u["prior_delta_95_mm"])
    assert u["delta_95_mm"][0] <= 13.0 <= u["delta_95_mm"][1]


def test_a_missing_scan_and_a_scan_of_something_else_exit_2(design, tmp_path, capsys):
    assert main(["correct", str(design), str(tmp_path / "nope.ply"), "--out", str(tmp_path / "o"), *SMALL]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope.ply" in err[0]
    plate = tmp_path / "plate.xyz"
    g = np.random.default_rng(0).uniform(0, [1200, 900], (20000, 2))
    np.savetxt(plate, np.column_stack([g, np.zeros(len(g))]), fmt="%.3f")
    assert main(["correct", str(design), str(plate), "--out", str(tmp_path / "o"), *SMALL]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plate.xyz" in err[0]
    assert not (tmp_path / "o").exists()
