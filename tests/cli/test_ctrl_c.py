"""Ctrl-C at any moment: one line ``airmat <cmd>: interrupted``, exit 130, nothing in --out, no worker left.

The command runs as ``python -m airmat`` in its own session; SIGINT goes to
the whole process group, as a terminal's Ctrl-C does (so ``inflate --jobs 2``
workers receive it too and must ignore it). Instants: during the imports,
during emcee's sampling, and while two inflation workers run.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from airmat.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _start(argv, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-m", "airmat", *argv, "-q"], cwd=cwd, env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _children(pid):
    """Child processes of ``pid``, started by any of its threads (Dask spawns from its event-loop thread)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return found


def _workers(pid):
    found = []
    for c in _children(pid):
        try:
            if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes():
                found.append(c)
        except OSError:
            pass
    return found


def _interrupt(proc, command, out):
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert (proc.returncode, err) == (130, f"airmat {command}: interrupted\n")
    assert not out.exists()
    assert [p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}")] == []  # no staging


@pytest.mark.parametrize("delay", [0.15, 0.5])
def test_during_the_imports(tmp_path, delay):
    proc = _start(["design", "--preset", "vault1", "--out", "out"], tmp_path)
    time.sleep(delay)
    _interrupt(proc, "design", tmp_path / "out")


@pytest.mark.slow  # about 8 s
def test_during_sampling(tmp_path):
    assert main(["synth", str(tmp_path / "set"), "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9", "-q"]) == 0
    proc = _start(["calibrate", "set/manifest.csv", "--out", "out", "--max-steps", "100000"], tmp_path)
    time.sleep(4.0)     # the scans are fitted within about a second; then emcee samples for minutes
    assert proc.poll() is None
    _interrupt(proc, "calibrate", tmp_path / "out")


@pytest.fixture(scope="module")
def design_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("d") / "design"
    assert main(["design", "--preset", "vault1", "--spacing-mm", "40", "--out", str(out), "-q"]) == 0
    return out


@pytest.mark.slow  # about 8 s
def test_during_inflate_with_two_workers(tmp_path, design_dir):
    proc = _start(["inflate", str(design_dir), "--out", "out", "--resolution-mm", "25", "--jobs", "2"], tmp_path)
    deadline, workers = time.monotonic() + 60, []
    while len(workers) < 2 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
        workers = _workers(proc.pid)
    assert len(workers) == 2
    time.sleep(1.0)     # the workers are inflating
    _interrupt(proc, "inflate", tmp_path / "out")
    time.sleep(0.5)
    assert [w for w in workers if Path(f"/proc/{w}").exists()
            and Path(f"/proc/{w}/stat").read_text().split(")")[1].split()[0] != "Z"] == []


def test_no_defunct_workers_after_a_normal_run(tmp_path, design_dir, capsys):
    before = set(_children(os.getpid()))
    assert main(["inflate", str(design_dir), "--out", str(tmp_path / "out"), "--resolution-mm", "60",
                 "--jobs", "2", "-q"]) == 0
    capsys.readouterr()
    left = [c for c in set(_children(os.getpid())) - before
            if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes() or
            Path(f"/proc/{c}/stat").read_text().split(")")[1].split()[0] == "Z"]
    assert left == []
