"""airmat as users install it: one import root in the wheel, dependencies with wheels on every platform
its users are on, and the wheel working from a clean virtual environment outside the repository."""

import glob
import os
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: where architects and lab researchers run it (uv's target triples); Python 3.10-3.12
PLATFORMS = ("x86_64-pc-windows-msvc", "aarch64-apple-darwin", "x86_64-apple-darwin", "x86_64-manylinux_2_35")
PYTHONS = ("3.10", "3.11", "3.12")

#: the stage folders at the repository root and the package each installs as
FOLDERS = {"calib": "airmat/calib", "design": "airmat/design", "inflation": "airmat/inflation",
           "check": "airmat/check", "report": "airmat/report", "data_synthetic": "airmat/synthetic",
           "asbuilt": "airmat/asbuilt",
           "airmat": "airmat"}


def _dependencies() -> list:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["dependencies"]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel built from this tree's tracked files (in an isolated build environment, as pip builds it).

    Built from a copy, so the build leaves nothing in the repository, and a file the wheel needs that
    is not tracked is missed here as it would be on a fresh clone.
    """
    import shutil

    src, out = tmp_path_factory.mktemp("src"), tmp_path_factory.mktemp("wheel")
    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, tracked.decode().split("\0")):
        if (ROOT / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(src)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    (path,) = glob.glob(str(out / "airmat-*.whl"))
    return Path(path)


@pytest.mark.slow
def test_the_wheel_installs_only_airmat_with_every_module_and_the_schemas(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"airmat", wheel.name.split("-py3")[0] + ".dist-info"}
    # every module of the tree is in the wheel, under its airmat.* name
    for folder, package in FOLDERS.items():
        tracked = subprocess.run(["git", "ls-files", "--", f"{folder}/*.py"], cwd=ROOT, capture_output=True,
                                 text=True, check=True).stdout.split()
        assert tracked, folder
        for py in tracked:
            assert f"{package}/{Path(py).relative_to(folder).as_posix()}" in names, py
    schemas = {Path(n).name for n in names if n.startswith("airmat/schemas/")}
    assert schemas == {p.name for p in (ROOT / "airmat" / "schemas").glob("*.schema.json")} and schemas


@pytest.mark.slow
def test_every_dependency_has_a_binary_wheel_for_the_users_platforms(tmp_path):
    # pip evaluates environment markers for the machine it runs on whatever --platform says; uv resolves
    # for the target platform, markers included, against the package index
    reqs = tmp_path / "requirements.in"
    reqs.write_text("\n".join(_dependencies()) + "\n", encoding="utf-8")
    uv = Path(sysconfig.get_path("scripts")) / "uv"
    env = {**os.environ, "UV_NO_PROGRESS": "1"}
    # the resolutions wait on the index, not the CPU: run them all at once
    procs = {(platform, python): subprocess.Popen(
        [str(uv), "pip", "compile", str(reqs), "--python-platform", platform, "--python-version", python,
         "--only-binary", ":all:", "--no-header", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        for platform in PLATFORMS for python in PYTHONS}
    for (platform, python), proc in procs.items():
        stdout, stderr = proc.communicate(timeout=600)
        assert proc.returncode == 0, f"{platform}, Python {python}:\n{stderr[-3000:]}"
        pinned = {line.split("==")[0].lower() for line in stdout.splitlines() if "==" in line}
        assert {"numpy", "scipy", "emcee", "trimesh", "scikit-image", "cvxopt"} <= pinned
        assert ("open3d-cpu" if "linux" in platform else "open3d") in pinned, (platform, python)


def _venv_with_the_wheel(wheel: Path, where: Path) -> Path:
    """A new virtual environment outside the repository with the wheel installed (no editable airmat).

    The wheel goes in with ``--no-deps``; its dependencies are the ones this interpreter has installed,
    reached through a path file (a plain path line: the editable airmat's own path file there is not
    processed), so the test does not download a gigabyte of wheels again.
    """
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                               capture_output=True, text=True, check=True).stdout.strip())
    (site / "_airmat_test_dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n", encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps",
                          str(wheel)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return venv


@pytest.fixture(scope="module")
def clean_venv(wheel, tmp_path_factory) -> Path:
    """A virtual environment outside the repository with only the wheel's airmat."""
    return _venv_with_the_wheel(wheel, tmp_path_factory.mktemp("clean"))


def _runner(venv: Path, work: Path):
    """Run a command in ``work`` with the clean environment's bin first on PATH; return its stdout."""
    work.mkdir(exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"

    def run(*cmd):
        out = subprocess.run(list(cmd), cwd=work, env=env, capture_output=True, text=True, timeout=900)
        assert out.returncode == 0, f"{cmd}:\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}"
        return out.stdout
    return run


@pytest.mark.slow
def test_the_wheel_runs_from_a_clean_virtualenv_outside_the_repository(clean_venv, tmp_path):
    venv = clean_venv
    run = _runner(venv, tmp_path / "work")

    run("airmat", "synth", "specimens", "--seed", "1")
    fit = run("airmat", "fit", "specimens/specimen_00.ply")
    assert "radius" in fit
    code = """
import json, sys, airmat
import airmat.calib, airmat.synthetic
target, mattress = airmat.preset("vault1")
try:
    import calib
    leaked = True
except ImportError:
    leaked = False
print(json.dumps({"airmat": airmat.__file__, "calib": airmat.calib.__file__, "synthetic": airmat.synthetic.__file__,
                  "target": repr(target), "leaked": leaked,
                  "facade": all(callable(getattr(airmat, n)) for n in airmat.__all__ if n != "__version__")}))
"""
    import json

    got = json.loads(run(str(venv / "bin" / "python"), "-c", code).strip().splitlines()[-1])
    for key in ("airmat", "calib", "synthetic"):
        assert got[key].startswith(str(venv)), got      # the wheel's copy, not the repository's
    assert got["target"].startswith("<Target vault1:") and not got["leaked"] and got["facade"]


@pytest.mark.slow
def test_the_readme_python_example_runs_from_the_clean_virtualenv_and_writes_what_it_says(clean_venv, tmp_path):
    import re

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    assert "import airmat" in code
    stdout = _runner(clean_venv, tmp_path)(str(clean_venv / "bin" / "python"), "-c", code)
    # print(checked): the check's short summary, one line, with each run's deviation from Ŝ
    line = stdout.strip().splitlines()[-1]
    assert line.startswith("<DesignCheck: median ") and " lo95 " in line and " hi95 " in line, line
    assert len(line) < 400
    pct = float(re.search(r"median [0-9.]+ mm RMS, [0-9.]+ mm max \(([0-9.]+) % of the diagonal\)", line).group(1))
    assert 0 < pct <= 1.0          # a refined design lands within 1 % of the diagonal from Ŝ
    out = tmp_path / "out" / "design"
    for name in ("design.json", "pattern.dxf", "design.3dm", "cutting_list.csv", "report.html"):
        assert (out / name).stat().st_size > 0, name
    # the README shows the output it prints
    assert line in text
