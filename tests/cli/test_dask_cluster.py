"""`airmat inflate --samples K --scheduler ADDRESS` on a real Dask cluster: a `dask scheduler` and one
`dask worker` started as processes on the loopback address (bounded in time, stopped at the end).

The Monte-Carlo result through the cluster equals the local one byte for byte (inflate.json without
its wall-clock timings_s, inflated.ply, inflated_bands.ply); a worker whose task raises ends the run
with one stderr line and exit status 1.
"""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from airmat.cli import main
from test_inflate_cli import make_design

ROOT = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).with_name("dask")

pytestmark = pytest.mark.skipif(not DASK.exists(), reason="the dask command is not installed")

#: a worker preload whose inflations raise (the failure test)
BOOM = '''
import airmat.inflation.simulate as simulate


def _boom(*args, **kwargs):
    raise RuntimeError("boom on the worker")


simulate.inflate = _boom
'''


class _Cluster:
    """A dask scheduler and one single-threaded dask worker on 127.0.0.1, as processes."""

    def __init__(self, folder: Path, preload: Path | None = None):
        env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
        file = folder / "scheduler.json"
        self.procs = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                        "--no-dashboard", "--scheduler-file", str(file)],
                                       env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        try:
            deadline = time.monotonic() + 60
            while not file.exists() or not file.read_text().strip():
                assert time.monotonic() < deadline and self.procs[0].poll() is None, "the scheduler did not start"
                time.sleep(0.2)
            self.address = json.loads(file.read_text())["address"]
            args = [str(DASK), "worker", self.address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                    "--host", "127.0.0.1"] + (["--preload", str(preload)] if preload else [])
            self.procs.append(subprocess.Popen(args, env=env, cwd=folder, stdout=subprocess.DEVNULL,
                                               stderr=subprocess.DEVNULL))
            from distributed import Client

            with Client(self.address, timeout="60s") as c:
                c.wait_for_workers(1, timeout=90)
        except BaseException:
            self.stop()
            raise

    def stop(self):
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


@pytest.fixture
def design_dir(tmp_path):
    """The two-string design with a posterior of 40 samples of (delta, d, sigma): samples differ."""
    folder = make_design(tmp_path / "design")
    rng = np.random.default_rng(11)
    n = 40
    np.savez(folder / "calibration_samples.npz", delta_m=rng.normal(0.010, 0.002, n).clip(0.001),
             d_m=rng.normal(0.070, 0.004, n), L_m=np.float64(0.3), sigma_per_m=np.full(n, 0.3))
    return folder


def _outputs(out: Path):
    doc = json.loads((out / "inflate.json").read_text())
    doc.pop("timings_s")
    return doc, (out / "inflated.ply").read_bytes(), (out / "inflated_bands.ply").read_bytes()


@pytest.mark.slow  # about 40 s: a cluster's start-up and 7 inflations twice
def test_the_cluster_gives_the_local_result_byte_for_byte(tmp_path, design_dir, capsys):
    argv = ["inflate", str(design_dir), "--resolution-mm", "50", "--samples", "4", "--seed", "3",
            "--tolerance-mm", "80", "-q"]
    assert main(argv + ["--out", str(tmp_path / "local"), "--jobs", "2"]) == 0
    cluster = _Cluster(tmp_path)
    try:
        assert main(argv + ["--out", str(tmp_path / "remote"), "--scheduler", cluster.address]) == 0
    finally:
        cluster.stop()
    capsys.readouterr()
    local, remote = _outputs(tmp_path / "local"), _outputs(tmp_path / "remote")
    assert local[0] == remote[0]
    assert local[1] == remote[1] and local[2] == remote[2]
    mc = local[0]["monte_carlo"]
    assert mc["samples"] == 4 and mc["seed"] == 3 and mc["sigma_source"] == "posterior"
    assert len(set(mc["rms_mm"]["per_sample"])) == 4        # the samples differ
    assert 0 <= mc["p_rms_within_tolerance"] <= 1 and len(mc["sensitive_strings"]) == 2


@pytest.mark.slow  # about 20 s
def test_a_worker_that_raises_ends_the_run_with_one_line(tmp_path, design_dir):
    preload = tmp_path / "boom_preload.py"
    preload.write_text(BOOM)
    cluster = _Cluster(tmp_path, preload=preload)
    try:
        env = {**os.environ, "PYTHONPATH": str(ROOT), "AIRMAT_SCHEDULER": cluster.address}
        proc = subprocess.run([sys.executable, "-m", "airmat", "inflate", str(design_dir), "--out",
                               str(tmp_path / "out"), "--resolution-mm", "50", "--samples", "2", "-q"],
                              env=env, capture_output=True, text=True, timeout=120)
    finally:
        cluster.stop()
    assert proc.returncode == 1
    assert proc.stderr == ("airmat inflate: a task failed on a Dask worker: RuntimeError: boom on the worker\n")
    assert not (tmp_path / "out").exists()


def test_no_scheduler_at_the_address_is_bad_input(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("airmat.inflation.executor.CONNECT_TIMEOUT", "2s")
    design = make_design(tmp_path / "design")
    assert main(["inflate", str(design), "--out", str(tmp_path / "out"), "--resolution-mm", "50",
                 "--scheduler", "tcp://127.0.0.1:9", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("airmat inflate: no Dask scheduler reachable at tcp://127.0.0.1:9") and err.count("\n") == 1
