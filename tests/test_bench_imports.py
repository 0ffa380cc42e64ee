"""Every benchmark script imports: a rename inside the package must not leave a bench/ script broken."""

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"


def _bench_module(name, monkeypatch):
    """bench/NAME.py imported as the scripts import (bench/ and the repository on the path)."""
    monkeypatch.syspath_prepend(str(BENCH))
    monkeypatch.syspath_prepend(str(BENCH.parent))
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)            # top level only: main() runs under __name__ == "__main__"
    return module


@pytest.mark.parametrize("path", sorted(BENCH.glob("*.py")), ids=lambda p: p.name)
def test_the_benchmark_script_imports(path, monkeypatch):
    assert _bench_module(path.stem, monkeypatch).__doc__


@pytest.mark.parametrize("extra", [[], pytest.param(["--draws", "2"], marks=pytest.mark.slow)],
                         ids=["table", "draws"])
def test_the_refinement_benchmark_runs_its_table(extra, monkeypatch, capsys):
    """bench_refine.py's own main() end to end, on a coarse mesh and one iteration (a few seconds): its row
    loop once lost a field to a new option and no run of the script caught it."""
    bench = _bench_module("bench_refine", monkeypatch)
    code = bench.main(["--presets", "vault1", "--resolution-mm", "40", "--max-iter", "1",
                       "--trial-newton", "20", *extra])
    rows = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| vault1 ")]
    assert code in (0, None) and len(rows) == 1
    assert rows[0].rstrip().endswith("| 20 |")       # the last column: the trial budget of that row
