"""Lazy package exports: every public name resolves to its submodule's object, on first use."""

import importlib
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from airmat.lazy import attach

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("airmat.calib", "airmat.design", "airmat.design.export", "airmat.inflation", "airmat.check",
            "airmat.synthetic", "airmat.report")


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_resolves_and_is_listed(package):
    pkg = importlib.import_module(package)
    assert len(pkg.__all__) == len(set(pkg.__all__)) > 0
    listed = dir(pkg)
    for name in pkg.__all__:
        value = getattr(pkg, name)
        assert name in listed
        assert not isinstance(value, types.ModuleType), name   # the object, not a submodule of that name
        home = getattr(value, "__module__", None)
        if home is not None and isinstance(value, type | types.FunctionType):
            assert home.startswith(package + "."), (name, home)
    with pytest.raises(AttributeError, match="no_such_name"):
        getattr(pkg, "no_such_name")


def test_star_import_and_from_import():
    ns = {}
    exec("from airmat.calib import *", ns)
    import airmat.calib as calib
    from airmat.calib import kappa1
    from airmat.calib.model import kappa1 as direct

    assert kappa1 is direct and ns["kappa1"] is direct
    assert set(calib.__all__) <= set(ns)


def test_a_public_name_that_is_also_a_submodule_stays_the_function_whichever_is_imported_first():
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    code = """
import json, types
import airmat.calib.calibrate                     # the submodule first: Python binds it on the package
import airmat.calib
from airmat.calib import calibrate
print(json.dumps([isinstance(airmat.calib.calibrate, types.FunctionType), calibrate is airmat.calib.calibrate,
                  airmat.calib.calibrate.__module__]))
"""
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    assert json.loads(out) == [True, True, "airmat.calib.calibrate"]


def test_attach_refuses_a_name_listed_twice():
    mod = types.ModuleType("lazy_probe")
    sys.modules["lazy_probe"] = mod
    try:
        with pytest.raises(ValueError, match="two submodules"):
            attach("lazy_probe", {"a": ["x"], "b": ["x"]})
    finally:
        del sys.modules["lazy_probe"]


def _fresh(code: str):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_open3d_comes_without_its_visualization_until_that_is_used():
    # the designer's closest points and a PCD round trip need open3d's geometry and I/O only; its
    # visualization package pulls dash, plotly and IPython (0.4 s), loaded on first use instead
    got = _fresh("""
import json, sys, tempfile, os
import numpy as np
from airmat.design.closest_point import MeshProjector
p = MeshProjector(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
point = p.closest(np.array([[0.2, 0.2, 1.0]])).points.round(6).tolist()
from airmat.lazy import import_open3d
o3d = import_open3d()
path = os.path.join(tempfile.mkdtemp(), "a.pcd")
o3d.io.write_point_cloud(path, o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.eye(3))))
back = np.asarray(o3d.io.read_point_cloud(path).points).tolist()
before = sorted(m for m in ("dash", "plotly", "IPython") if m in sys.modules)
draw = callable(o3d.visualization.draw_plotly)          # first use: the real package
import open3d.visualization as vis
print(json.dumps([point, back, before, draw, vis is o3d.visualization, "dash" in sys.modules,
                  hasattr(vis, "Visualizer")]))
""")
    assert got == [[[0.2, 0.2, 0.0]], np.eye(3).tolist(), [], True, True, True, True]


def test_a_submodule_of_the_deferred_visualization_imports():
    got = _fresh("""
import json, sys
from airmat.lazy import import_open3d
o3d = import_open3d()
import open3d.visualization.draw_plotly as dp
from open3d.visualization import to_mitsuba
print(json.dumps([callable(dp.draw_plotly), callable(to_mitsuba), type(o3d.visualization).__name__]))
""")
    assert got == [True, True, "module"]


def test_open3d_imported_first_is_returned_as_it_is():
    got = _fresh("""
import json, open3d
from airmat.lazy import import_open3d
print(json.dumps([import_open3d() is open3d, type(open3d.visualization).__name__]))
""")
    assert got == [True, "module"]
