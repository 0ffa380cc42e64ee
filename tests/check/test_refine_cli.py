"""`airmat refine` and `airmat design --refine`: the refined folder, and bad input (exit 2, nothing written)."""

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from refine_case import off_case  # noqa: E402

from airmat.cli import main  # noqa: E402
from airmat.design.design_io import write_design  # noqa: E402

#: the small case with a known answer (refine_case.py), once per module
case = pytest.fixture(scope="module", name="case")(off_case)


def test_cli_refine_writes_the_refined_design_and_bad_input_writes_nothing(case, tmp_path, capsys, wrote):
    src = tmp_path / "design"
    write_design(case, src)
    bad = tmp_path / "bad"
    assert main(["refine", str(src), "--out", str(bad), "--resolution-mm", "200"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too coarse" in err[0] and not bad.exists()
    out = tmp_path / "refined"
    code = main(["refine", "-q", str(src), "--out", str(out), "--resolution-mm", "40", "--max-iter", "3"])
    assert code in (0, 3)
    doc = json.loads((out / "design.json").read_text())
    assert doc["refine"]["iterations"] == 3 and doc["refine"]["converged"] is (code == 0)
    assert doc["refine"]["alpha"] == 1e-3                   # refine's default
    assert doc["refine"]["deviation_after"]["rms_mm"] < doc["refine"]["deviation_before"]["rms_mm"]
    assert (out / "cutting_list.csv").is_file()
    # 'airmat inflate' on the folder (the re-parametrized Ŝ read back from approx_surface.ply) keeps the promise
    assert doc["refine"]["reparametrization"]["moved_rms_mm"] > 0
    text = capsys.readouterr().out
    assert "surface points moved" in text
    assert wrote(text, out) == {p.name for p in out.iterdir()}        # every file of the folder, no other
    assert f"'airmat check {out} --out DIR --resolution-mm 40'" in text
    assert main(["inflate", str(out), "--out", str(tmp_path / "inf"), "--resolution-mm", "40",
                 "--no-envelope"]) == 0
    text = capsys.readouterr().out
    assert "airmat refine" not in text    # refined lengths: no hint to refine them
    # inflated as it was refined: its open-loop lengths from the flat mattress, then on to the refined ones
    assert "refined design: its open-loop lengths inflated first" in text
    inf = json.loads((tmp_path / "inf" / "inflate.json").read_text())
    assert inf["start"]["from"] == "open-loop equilibrium" and inf["start"]["converged"] is True
    assert f"{inf['start']['iterations']} Newton iterations" in text
    assert inf["deviation"]["rms_mm"] == pytest.approx(doc["refine"]["deviation_after"]["rms_mm"], abs=0.011)
    # --single-level: every iteration at the target resolution (no coarse mesh in the block)
    one = tmp_path / "one"
    code = main(["refine", "-q", str(src), "--out", str(one), "--resolution-mm", "20", "--max-iter", "2",
                 "--single-level", "--regularization", "0.05"])
    assert code in (0, 3)
    block = json.loads((one / "design.json").read_text())["refine"]
    assert block["coarse_resolution_mm"] is None and block["alpha"] == 0.05


@pytest.mark.parametrize("argv, words", [
    (["--defect-corrections", "-1"], "--defect-corrections must be >= 0, got -1"),
    (["--defect-corrections", "1", "--single-level"], "--single-level has none"),
    (["--regularization", "0"], "--regularization must be a positive number, got 0.0"),
    (["--regularization", "nan"], "--regularization must be a positive number, got nan"),
    (["--regularization=-1e-3"], "--regularization must be a positive number, got -0.001"),
    (["--reparametrize", "-1"], "--reparametrize must be >= 0, got -1"),
])
def test_cli_refine_bad_corrections_exit_2_and_write_nothing(case, tmp_path, capsys, argv, words):
    src = tmp_path / "design"
    write_design(case, src)
    out = tmp_path / "out"
    assert main(["refine", str(src), "--out", str(out)] + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and not out.exists()


@pytest.mark.parametrize("argv, words", [
    (["--refine-defect-corrections", "-2"], "--refine-defect-corrections must be >= 0"),
    (["--refine-regularization", "inf"], "--refine-regularization must be a positive number, got inf"),
    (["--refine-reparametrize", "-1"], "--refine-reparametrize must be >= 0, got -1"),
    (["--refine-resolution-mm", "500"], "too coarse"),
])
def test_cli_design_refine_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, argv, words):
    out = tmp_path / "d"
    assert main(["design", "-q", "--preset", "vault1", "--refine", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and not out.exists()


def test_cli_design_refine_says_what_the_refinement_did(tmp_path, capsys):
    # 'airmat design --refine' prints the refine block's lines, as 'airmat refine' does
    out = tmp_path / "d"
    code = main(["design", "-q", "--preset", "vault1", "--refine", "--refine-resolution-mm", "60", "--out", str(out)])
    assert code in (0, 3)
    b = json.loads((out / "design.json").read_text())["refine"]
    text = capsys.readouterr().out
    assert f"refined in {b['iterations']} iterations" in text
    assert f"-> {b['deviation_after']['rms_mm']:.1f} mm" in text
    assert f"surface points moved {b['reparametrization']['moved_rms_mm']:.1f} mm RMS" in text
    assert b["lengths_before"] == "open-loop" and "the open-loop lengths are" in text
    # a refined design's block names its lengths as refined (one written before the field: open-loop)
    from airmat.cli.refine import refine_lines
    assert "the refined lengths are" in "\n".join(refine_lines({**b, "lengths_before": "refined"}))
    old = {k: v for k, v in b.items() if k != "lengths_before"}
    assert "the open-loop lengths are" in "\n".join(refine_lines(old))
