"""The README's Python example runs as written, in a fresh interpreter, from an empty folder."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _example() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.search(r"```python\n(.*?)```", text, re.S).group(1)


@pytest.mark.slow
def test_the_readme_python_example_runs_and_writes_what_it_says(tmp_path):
    code = _example()
    assert "import airmat" in code
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    # print(checked): the check's short summary, one line, with each run's deviation from Ŝ
    line = run.stdout.strip().splitlines()[-1]
    assert line.startswith("<DesignCheck: median ") and " lo95 " in line and " hi95 " in line, line
    assert len(line) < 400
    rms = float(re.search(r"median ([0-9.]+) mm RMS", line).group(1))
    pct = float(re.search(r"median [0-9.]+ mm RMS, [0-9.]+ mm max \(([0-9.]+) % of the diagonal\)", line).group(1))
    assert rms > 0 and pct <= 1.0          # a refined design lands within 1 % of the diagonal from Ŝ
    out = tmp_path / "out" / "design"
    for name in ("design.json", "pattern.dxf", "design.3dm", "cutting_list.csv", "report.html"):
        assert (out / name).stat().st_size > 0, name
