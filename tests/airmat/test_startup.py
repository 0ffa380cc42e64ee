"""Light start-up: each command path loads only what it uses (checked in a fresh interpreter)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from airmat.synthetic.ply_write import write_ply
from airmat.synthetic.specimen_scan import specimen_scan

ROOT = Path(__file__).resolve().parents[2]

#: top-level packages `airmat fit` and `airmat calibrate` must never load
NOT_FOR_CALIBRATION = ("airmat.design", "airmat.inflation", "airmat.check", "airmat.synthetic", "ezdxf", "cvxopt", "igl", "pymetis")

_LOADED = """
import json, sys
def loaded():
    return sorted({".".join(n.split(".")[:2]) if n.startswith("airmat.") else n.split(".")[0] for n in sys.modules})
"""


def _fresh(code: str) -> dict:
    """Run ``code`` in a fresh interpreter (the installed airmat); return its JSON output."""
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-c", _LOADED + code], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_help_loads_no_numerical_library():
    got = _fresh("""
from airmat.cli import build_parser
build_parser().format_help()
print(json.dumps(loaded()))
""")
    assert "airmat" in got
    for name in ("numpy", "scipy", "airmat.calib", "matplotlib", *NOT_FOR_CALIBRATION):
        assert name not in got


def test_the_fit_and_calibrate_paths_import_nothing_of_the_designer_or_the_plots():
    got = _fresh("""
from airmat.cli import build_parser
build_parser()
import airmat.cli.fit, airmat.cli.calibrate, airmat.calib.cylinder_fit, airmat.calib.scan_io
import airmat.calib.calibrate, airmat.calib.calibration_io, airmat.calib.plots
from airmat.calib import calibrate, fit_cylinder, kappa1
print(json.dumps(loaded()))
""")
    assert "airmat.calib" in got and "numpy" in got      # the imports did run
    for name in ("matplotlib", "emcee", "corner", *NOT_FOR_CALIBRATION):
        assert name not in got, name


def test_airmat_fit_runs_without_the_designer_the_simulator_or_matplotlib(tmp_path):
    s = specimen_scan(4.0, n_points=8_000, arc_deg=60, seed=7)
    path = tmp_path / "specimen.ply"
    write_ply(path, s.points * 1e3)
    got = _fresh(f"""
import contextlib, io
from airmat.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main(["fit", {str(path)!r}, "-q", "--json"])
print(json.dumps({{"code": code, "kappa": json.loads(out.getvalue())["kappa_per_m"], "loaded": loaded()}}))
""")
    assert got["code"] == 0
    assert got["kappa"] == pytest.approx(4.0, rel=0.05)
    # nor scipy, scikit-image, open3d or trimesh: their imports alone would cost more than a
    # fit of a million points (docs/benchmarks.md, `bench/bench_cylinder.py`)
    for name in ("matplotlib", "emcee", "scipy", "skimage", "open3d", "trimesh", "pandas", "polars",
                 *NOT_FOR_CALIBRATION):
        assert name not in got["loaded"], name


def test_calibrate_loads_matplotlib_only_to_write_a_plot(tmp_path):
    from airmat.cli import main

    assert main(["synth", str(tmp_path / "set"), "--points", "20000", "--l-over-L", "0.3,0.5,0.7", "--seed", "4", "-q"]) == 0
    got = _fresh(f"""
from airmat.calib.calibrate import calibrate
cal = calibrate({str(tmp_path / "set" / "manifest.csv")!r}, max_steps=300, seed=0)
before = loaded()
from airmat.calib.plots import plot_curve
plot_curve(cal, {str(tmp_path / "curve.png")!r})
print(json.dumps({{"before": before, "after": loaded()}}))
""")
    assert "emcee" in got["before"]
    assert "matplotlib" not in got["before"]
    assert "matplotlib" in got["after"] and (tmp_path / "curve.png").stat().st_size > 0
    for name in NOT_FOR_CALIBRATION:
        assert name not in got["after"], name


@pytest.mark.parametrize("module, absent", [
    ("airmat.inflation.mesh", ("ezdxf", "cvxopt", "igl", "airmat.design", "airmat.check", "matplotlib")),
    ("airmat.inflation.solver", ("ezdxf", "cvxopt", "airmat.design", "airmat.check", "matplotlib")),
    ("airmat.design.mattress", ("ezdxf", "cvxopt", "airmat.inflation", "airmat.check", "matplotlib", "trimesh", "scipy")),
    ("airmat.design.pipeline", ("ezdxf", "cvxopt", "airmat.inflation", "airmat.check", "matplotlib")),
    ("airmat.check.compare", ("ezdxf", "cvxopt", "airmat.design", "matplotlib")),
    ("airmat.design", ("numpy", "ezdxf", "cvxopt", "matplotlib")),
    ("airmat.calib", ("numpy",)),
])
def test_importing_a_module_loads_none_of_the_heavy_libraries_it_does_not_use(module, absent):
    got = _fresh(f"import {module}\nprint(json.dumps(loaded()))")
    assert ".".join(module.split(".")[:2]) in got
    for name in absent:
        assert name not in got, name


def test_a_factorization_still_loads_cvxopt_on_demand():
    got = _fresh("""
import scipy.sparse as sp
from airmat.inflation.cholesky import ShiftedCholesky
before = loaded()
c = ShiftedCholesky(sp.csr_matrix([[2.0, -1.0], [-1.0, 2.0]]))
print(json.dumps({"before": before, "after": loaded(), "ok": c.factor(sp.csr_matrix([[2.0, -1.0], [-1.0, 2.0]]))}))
""")
    assert "cvxopt" not in got["before"] and "cvxopt" in got["after"] and got["ok"]


def test_a_mattress_mesh_is_still_built_with_its_edges():
    from airmat.inflation.mesh import build_mattress_mesh

    m = build_mattress_mesh(0.8, 0.4, 0.07, resolution=0.1)
    e = np.sort(m.edges, axis=1)
    assert len(np.unique(e, axis=0)) == len(e)
    # closed triangle mesh: E = 3F / 2, and V - E + F = 2 (a sphere's Euler characteristic)
    assert 2 * len(e) == 3 * len(m.faces)
    assert m.n_vertices - len(e) + len(m.faces) == 2
