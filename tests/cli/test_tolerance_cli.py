"""`airmat check --tolerance linear|samples|none`: the tolerance block of inflate.json, its line, its bad input."""

import importlib.resources
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "check"))
from refine_case import OFF, TRUE_SIM, small_design  # noqa: E402

from airmat.check.tolerance_validation import VALIDATION_SAMPLES  # noqa: E402
from airmat.cli import main  # noqa: E402
from airmat.design.design_io import write_design  # noqa: E402

SCHEMA = Path(str(importlib.resources.files("airmat") / "schemas")) / "inflate.schema.json"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The small three-string case (every string taut), written with its 200 posterior samples."""
    lengths = TRUE_SIM + OFF
    out = tmp_path_factory.mktemp("tol") / "design"
    write_design(small_design(lengths, true_sim=lengths), out)
    return out


@pytest.mark.slow
def test_the_default_check_gives_the_linear_tolerance(folder, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["check", str(folder), "--out", str(out), "--resolution-mm", "40", "--no-envelope",
                 "--tolerance-mm", "3", "--cut-tolerance-mm", "0.5", "--seed", "2"]) == 0
    doc = json.loads((out / "inflate.json").read_text())
    tol = doc["tolerance"]
    assert tol["method"] == "linear" and tol["reliable"] is True and tol["validation"]["samples"] == VALIDATION_SAMPLES
    assert tol["cut_tolerance_mm"] == 0.5 and tol["tolerance_mm"] == 3.0 and "monte_carlo" not in doc
    assert len(tol["sensitive_strings"]) == 3 and tol["band_normal_mm"]["p95"]["max"] > 0
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator(json.loads(SCHEMA.read_text())).validate(doc)
    printed = capsys.readouterr().out
    assert "tolerance (linear): 95 % band along the normal" in printed and "P(RMS <= 3 mm)" in printed


@pytest.mark.slow
def test_none_and_samples_leave_the_linear_tolerance_out(folder, tmp_path):
    assert main(["check", str(folder), "--out", str(tmp_path / "a"), "--resolution-mm", "40", "--no-envelope",
                 "--tolerance", "none", "-q"]) == 0
    assert "tolerance" not in json.loads((tmp_path / "a" / "inflate.json").read_text())
    assert main(["check", str(folder), "--out", str(tmp_path / "b"), "--resolution-mm", "40", "--no-envelope",
                 "--samples", "2", "-q"]) == 0
    doc = json.loads((tmp_path / "b" / "inflate.json").read_text())
    assert "tolerance" not in doc and doc["monte_carlo"]["samples"] == 2


@pytest.mark.parametrize("argv, message", [
    (["--tolerance", "samples"], "--tolerance samples needs --samples K"),
    (["--samples", "2", "--cut-tolerance-mm", "1"], "--cut-tolerance-mm needs the linear tolerance"),
    (["--cut-tolerance-mm", "-1"], "--cut-tolerance-mm must be >= 0"),
    (["--tolerance", "none", "--tolerance-mm", "2"], "--tolerance-mm needs --samples K > 0 or --tolerance linear"),
    (["--validation-samples", "3"], "--validation-samples must be an even count"),
    (["--samples", "2", "--validation-samples", "8"], "--validation-samples needs the linear tolerance"),
])
def test_bad_tolerance_options_exit_2_and_write_nothing(folder, tmp_path, capsys, argv, message):
    out = tmp_path / "out"
    assert main(["check", str(folder), "--out", str(out)] + argv) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_validation_samples_sets_the_full_samples(folder, tmp_path):
    """--validation-samples 0: the linear tolerance without its check (reliable unknown); its default is
    the library's (the parser keeps a literal, so that `airmat --help` imports no numpy)."""
    import argparse

    from airmat.cli.inflate import add_parser

    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(), [])
    assert parser.parse_args(["check", "x"]).validation_samples == VALIDATION_SAMPLES
    out = tmp_path / "out"
    assert main(["check", str(folder), "--out", str(out), "--resolution-mm", "40", "--no-envelope",
                 "--validation-samples", "0", "-q"]) == 0
    tol = json.loads((out / "inflate.json").read_text())["tolerance"]
    assert tol["method"] == "linear" and tol["validation"] is None and tol["reliable"] is None
