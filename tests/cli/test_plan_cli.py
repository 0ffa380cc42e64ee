"""`airmat plan`: a calibration folder -> plan.json (valid against its schema), plan.csv, plan.png and a
one-screen summary; the same seed gives the same bytes; bad input exits 2 with one line and writes nothing;
with --design the plan shrinks that design's length band."""

import contextlib
import importlib.resources
import io
import json
from pathlib import Path

import numpy as np
import pytest

from airmat.cli import main


def _calibration(folder: Path, seed=0, n=2000) -> Path:
    """A calibration folder holding only the parameters and the posterior draws (as another tool would write)."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    np.savez(folder / "posterior.npz", delta_m=rng.normal(0.018, 0.004, n), d_m=rng.normal(0.070, 0.01, n),
             sigma_per_m=np.abs(rng.normal(0.1, 0.02, n)))
    (folder / "calibration.json").write_text(json.dumps(
        {"parameters": {"delta_mm": {"median": 18.0}, "d_mm": {"median": 70.0}}, "curve": {"L_mm": 300.0}}))
    return folder


@pytest.fixture(name="cal")
def _cal(tmp_path):
    return _calibration(tmp_path / "cal")


def _run(argv, capsys):
    try:
        code = main(argv + ["-q"])
    except SystemExit as exc:       # a usage error, refused by the parser
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_plan_writes_its_files_and_the_summary(cal, tmp_path, capsys, wrote):
    out = tmp_path / "plan"
    code, text, err = _run(["plan", str(cal), "--add", "2", "--out", str(out)], capsys)
    assert code == 0 and err == ""
    assert wrote(text, out) == {"plan.json", "plan.csv", "plan.png"}
    doc = json.loads((out / "plan.json").read_text())
    assert len(doc["specimens"]) == 2 and doc["target"] == "area" and doc["design"] is None
    for s in doc["specimens"]:
        assert f"l/L {s['l_over_L']:.3f}  l = {s['l_mm']:6.1f} mm" in text
    assert len((out / "plan.csv").read_text().splitlines()) == 1 + 3      # header, now, two specimens
    assert len(text.splitlines()) <= 24
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((Path(str(importlib.resources.files("airmat") / "schemas")) / "plan.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.Draft202012Validator(schema).validate(doc)


def test_same_seed_same_files(cal, tmp_path, capsys):
    for name in ("a", "b"):
        assert _run(["plan", str(cal), "--add", "2", "--seed", "3", "--out", str(tmp_path / name)], capsys)[0] == 0
    for f in ("plan.json", "plan.csv"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


@pytest.mark.parametrize("argv, words", [
    (["{missing}"], "calibration folder not found"),
    (["{cal}", "--add", "0"], "--add 0"),
    (["{cal}", "--l-over-L", "0.3,x"], "expected comma-separated numbers"),
    (["{cal}", "--l-over-L", "0.5"], "at least two ratios"),
    (["{cal}", "--l-over-L", "0.5,1.5"], "at least two ratios"),
    (["{cal}", "--kappa-se-per-m", "-1"], "--kappa-se-per-m"),
    (["{cal}", "--design", "{missing}"], "design folder not found"),
    (["{cal}", "--add", "two"], "invalid int value"),
])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(cal, tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    argv = [a.format(cal=cal, missing=tmp_path / "nowhere") for a in argv]
    code, text, err = _run(["plan", *argv, "--out", str(out)], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("airmat plan: ") and words in lines[0], err
    assert not out.exists()


def test_a_calibration_without_scatter_samples_is_refused(tmp_path, capsys):
    cal = _calibration(tmp_path / "cal")
    arrays = dict(np.load(cal / "posterior.npz"))
    del arrays["sigma_per_m"]
    np.savez(cal / "posterior.npz", **arrays)
    code, _, err = _run(["plan", str(cal), "--out", str(tmp_path / "out")], capsys)
    assert code == 2 and "scatter sigma" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_with_a_design_the_plan_shrinks_its_length_band(cal, tmp_path, capsys):
    design = tmp_path / "design"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["design", "--preset", "vault1", "--resolution-mm", "40", "--calibration", str(cal),
                     "--out", str(design), "-q"]) == 0
    out = tmp_path / "plan"
    code, text, _ = _run(["plan", str(cal), "--design", str(design), "--add", "2", "--out", str(out)], capsys)
    assert code == 0 and "length band" in text
    doc = json.loads((out / "plan.json").read_text())
    assert doc["target"] == "band" and doc["target_unit"] == "mm" and doc["design"] == str(design)
    assert doc["specimens"][-1]["predicted"] < doc["now"]
    header = (out / "plan.csv").read_text().splitlines()[0]
    assert header == "n_added,l_over_L,l_mm,planned_band_mm,evenly_spaced_band_mm"
