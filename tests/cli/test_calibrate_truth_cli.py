"""`airmat calibrate --truth truth.json`: the truth beside the posterior in the summary and on report.html."""

import json
import re

from airmat.cli import main


def test_calibrate_with_the_truth_compares_with_it(tmp_path, capsys):
    synth = tmp_path / "set"
    assert main(["synth", str(synth), "--points", "20000", "--l-over-L", "0.3,0.4,0.5,0.6,0.7,0.8,0.9,0.95",
                 "--seed", "4", "-q"]) == 0
    capsys.readouterr()
    out = tmp_path / "cal"
    assert main(["calibrate", str(synth / "manifest.csv"), "--out", str(out), "--truth",
                 str(synth / "truth.json"), "-q"]) == 0
    truth = json.loads((synth / "truth.json").read_text())
    doc = json.loads((out / "calibration.json").read_text())["parameters"]
    lines = capsys.readouterr().out.splitlines()
    for line, key in zip(lines[:2], ("delta_mm", "d_mm")):
        t, p = truth[key], doc[key]
        inside = "inside" if p["lo95"] <= t <= p["hi95"] else "OUTSIDE"
        assert re.search(rf"truth {t:.2f} mm, median - truth [+-]\d+\.\d\d, {inside} the 95% interval", line), line
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "median − truth" in html and f"truth (Δ = {truth['delta_mm']:g} mm, d = {truth['d_mm']:g} mm)" in html
