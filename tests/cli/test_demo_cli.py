"""`airmat demo` end to end on embedded defaults (small scans, coarse inflation)."""

import json

import pytest

from airmat.cli import main


@pytest.mark.slow
def test_demo_runs_the_whole_pipeline(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--points", "20000", "--resolution-mm", "60", "-q"]) == 0
    text = capsys.readouterr().out
    for word in ("calibration", "Delta", "design", "vault1", "inflation", "deviation", "envelope"):
        assert word in text
    cal = json.loads((out / "calibration" / "calibration.json").read_text())
    truth = json.loads((out / "synth" / "truth.json").read_text())
    assert cal["parameters"]["delta_mm"]["lo95"] <= truth["delta_mm"] <= cal["parameters"]["delta_mm"]["hi95"]
    inf = json.loads((out / "inflate" / "inflate.json").read_text())
    assert inf["solver"]["converged"]
    # a designed preset lands near its S-hat: the vault1 pattern covers the mattress in patches, and the
    # measured RMS deviation is ~3.4 % of the diagonal at 50 mm; 6 % allows the coarser 60 mm mesh
    assert inf["deviation"]["rms_pct_diag"] < 6.0
    page = (out / "report.html").read_text(encoding="utf-8")
    for title in ("<h2>Summary</h2>", "<h2>Calibration</h2>", "<h2>Design</h2>", "<h2>Inflation check</h2>"):
        assert title in page
    assert "UNCALIBRATED" not in page and page.count("plotly.js v") == 1
