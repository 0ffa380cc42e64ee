"""Progress bars: on a terminal or in a notebook, and a solver's bar fills as its residual reaches tolerance."""

import sys
import types

import pytest

from airmat import progress as progress_module
from airmat.progress import progress_enabled, residual_progress, set_progress


@pytest.fixture(autouse=True)
def _unforced():
    set_progress(None)
    yield
    set_progress(None)


def test_a_jupyter_kernel_shows_bars_though_stderr_is_no_terminal(monkeypatch):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    assert not progress_enabled()
    ZMQInteractiveShell = type("ZMQInteractiveShell", (), {})
    fake = types.ModuleType("IPython")
    fake.get_ipython = lambda: ZMQInteractiveShell()
    monkeypatch.setitem(sys.modules, "IPython", fake)
    assert progress_enabled()
    TerminalInteractiveShell = type("TerminalInteractiveShell", (), {})   # IPython in a terminal: no widgets
    fake.get_ipython = lambda: TerminalInteractiveShell()
    assert not progress_enabled()


@pytest.mark.parametrize("first, value, tol, expected", [
    (1.0, 1.0, 1e-6, 0.0), (1.0, 1e-3, 1e-6, 0.5), (1.0, 1e-6, 1e-6, 1.0), (1.0, 1e-9, 1e-6, 1.0),
    (1.0, 10.0, 1e-6, 0.0),                 # a residual that grew: no negative progress
    (1e-7, 1e-7, 1e-6, 1.0),                # already below tolerance at the start
    (1.0, float("inf"), 1e-6, 0.0), (float("inf"), 1.0, 1e-6, 0.0), (1.0, float("nan"), 1e-6, 0.0),
])
def test_the_residual_bar_counts_decades_to_tolerance(first, value, tol, expected):
    assert progress_module._ResidualBar.fraction(first, value, tol) == pytest.approx(expected)


def test_the_residual_bar_fills_monotonically_and_ends_full(capsys):
    set_progress(True)
    with residual_progress(1e-8, desc="solve") as bar:
        seen = []
        for r in (1.0, 1e-2, 1e-1, 1e-5, 1e-9):     # a Newton residual need not fall every iteration
            bar.residual(r)
            seen.append(bar.bar.n)
    assert seen == sorted(seen) and seen[0] == 0 and seen[-1] == bar.bar.total == 1000
    assert "residual 1.00e-09" in capsys.readouterr().err


def test_the_inflation_solver_reports_its_residual_on_the_bar(capsys):
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.simulate import inflate

    set_progress(True)
    inf = inflate(build_mattress_mesh(0.3, 0.2, 0.05, resolution=0.05), None)
    err = capsys.readouterr().err
    assert inf.converged and "residual" in err and "100%" in err
