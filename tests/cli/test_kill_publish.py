"""Kill `airmat synth` at many instants: its folder is always the whole old result or the whole new one.

A subprocess rewrites a folder that holds a previous good run (another
seed) and is killed with SIGKILL or interrupted with SIGINT: before the
computation, during it, and inside the publish step, which the test widens:
the subprocess runs ``python -m airmat`` through a small ``-c`` wrapper that
replaces the publish's swap (``airmat.atomic._swap_uninterrupted``) with one
that sleeps just before and just after it, inside the output's lock, as the
swap itself is. After each kill the folder must equal, byte for byte, the
old run or the new one; the staging folders a killed run leaves are gone
after the next run.
"""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from airmat.cli import main

ROOT = Path(__file__).resolve().parents[2]
ARGS = ["--points", "10000", "-q"]
WINDOW = 1.0  # s slept before and after the swap when aiming at the publish step

#: ``python -c SLOW_PUBLISH DELAY ARGS...`` runs ``python -m airmat ARGS...`` with DELAY seconds of sleep
#: just before and just after the publish's swap (where the kills aim); the product has no such hook
SLOW_PUBLISH = """
import runpy, sys, time
import airmat.atomic as atomic
delay = float(sys.argv.pop(1))
swap = atomic._swap_uninterrupted
def slowed(*args, **kwargs):
    time.sleep(delay)
    swap(*args, **kwargs)
    time.sleep(delay)
atomic._swap_uninterrupted = slowed
runpy.run_module("airmat", run_name="__main__", alter_sys=True)
"""


def snapshot(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def refs(tmp_path_factory):
    """The old run (seed 0, as a folder to copy) and the new run's files (seed 1)."""
    base = tmp_path_factory.mktemp("refs")
    assert main(["synth", str(base / "old"), *ARGS, "--seed", "0"]) == 0
    assert main(["synth", str(base / "new"), *ARGS, "--seed", "1"]) == 0
    old, new = snapshot(base / "old"), snapshot(base / "new")
    assert len(old) == 14 and old.keys() == new.keys() and old != new
    return base / "old", old, new


def _staging(out):
    return set(out.parent.glob(f".{out.name}.staging-*"))


def _start(out, delay=None):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    run = ["-c", SLOW_PUBLISH, str(delay)] if delay else ["-m", "airmat"]
    return subprocess.Popen([sys.executable, *run, "synth", str(out), *ARGS, "--seed", "1"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _wait(proc, ready, what):
    deadline = time.monotonic() + 60
    while not ready():
        assert proc.poll() is None, f"the run ended before {what}: {proc.stderr.read()}"
        assert time.monotonic() < deadline, f"no {what} within 60 s"
        time.sleep(0.005)


def _trial(out, refs, sig, when):
    """Reset ``out`` to the old run, start the new one, signal it at ``when``; returns (code, stderr, state).

    ``when``: seconds after the start, or ``"computing"`` (its staging folder
    appeared), ``"before swap"`` (the staged result is complete: inside the
    first publish sleep) or ``"after swap"`` (``out`` is the new result: inside
    the second one).
    """
    old_dir, old, new = refs
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(old_dir, out)
    before = _staging(out)
    proc = _start(out, delay=None if isinstance(when, float) else WINDOW)
    try:
        if isinstance(when, float):
            time.sleep(when)
        elif when == "computing":
            _wait(proc, lambda: _staging(out) - before, "staging began")
        elif when == "before swap":
            _wait(proc, lambda: any((s / "truth.json").exists() for s in _staging(out) - before),
                  "the staged result was complete")
            time.sleep(0.1)
        else:
            _wait(proc, lambda: (out / "truth.json").read_bytes() == new["truth.json"], "the swap")
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    state = snapshot(out)
    assert state == old or state == new, f"{out} is a mix after signal {sig} at {when!r}"
    return proc.returncode, err, ("old" if state == old else "new")


def _next_run_sweeps(out, refs):
    proc = _start(out)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert snapshot(out) == refs[2]
    assert _staging(out) == set()


def test_kill_then_interrupt_inside_the_publish_step(tmp_path, refs):
    out = tmp_path / "out"
    assert _trial(out, refs, signal.SIGKILL, "before swap")[2] == "old"
    assert _staging(out), "a killed run leaves its staging folder behind"
    code, err, got = _trial(out, refs, signal.SIGINT, "after swap")
    assert (code, err, got) == (130, "airmat synth: interrupted\n", "new")
    assert _staging(out) == set()  # this run removed the killed run's folder, and its own


@pytest.mark.slow
def test_sigkill_after_the_swap_and_sigint_before_it(tmp_path, refs):
    out = tmp_path / "out"
    assert _trial(out, refs, signal.SIGKILL, "after swap")[2] == "new"
    assert _staging(out), "the old result waits in the staging folder for the next run"
    code, err, got = _trial(out, refs, signal.SIGINT, "before swap")
    assert (code, err, got) == (130, "airmat synth: interrupted\n", "old")
    assert _staging(out) == set()
    _next_run_sweeps(out, refs)


@pytest.mark.slow
def test_sigkill_sweep_over_the_whole_run(tmp_path, refs):
    out = tmp_path / "out"
    t0 = time.monotonic()
    _next_run_sweeps(out, refs)
    runtime = time.monotonic() - t0
    delays = [round(runtime * f, 3) for f in (0.02, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2)]
    seen = []
    for when in delays + ["computing", "before swap", "after swap"]:
        seen.append(_trial(out, refs, signal.SIGKILL, when)[2])
    assert seen[-2:] == ["old", "new"]
    assert "old" in seen[:3], "the earliest kills should come before the publish"
    _next_run_sweeps(out, refs)


@pytest.mark.slow
def test_sigint_while_computing(tmp_path, refs):
    out = tmp_path / "out"
    code, err, got = _trial(out, refs, signal.SIGINT, "computing")
    assert (code, err, got) == (130, "airmat synth: interrupted\n", "old")
    assert _staging(out) == set()
