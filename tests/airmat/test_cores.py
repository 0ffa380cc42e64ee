"""How many cores a multithreaded call may use (airmat.cores)."""

import os
import subprocess
import sys
import time

import pytest

from airmat.cores import busy_elsewhere, idle_cores, usable_cores


@pytest.mark.parametrize("busy, cores, expected", [
    (0, 2, 2), (1, 2, 1), (2, 2, 1), (9, 2, 1), (0, 1, 1), (1, 8, 7), (0, 8, 8), (8, 8, 1),
])
def test_idle_cores_is_the_cores_less_the_busy_ones_between_one_and_all(busy, cores, expected):
    assert idle_cores(busy=busy, cores=cores) == expected


def test_busy_elsewhere_reads_the_runnable_count_less_this_thread(tmp_path):
    f = tmp_path / "loadavg"
    f.write_text("0.52 0.58 0.59 3/467 12345\n")
    assert busy_elsewhere(str(f), samples=2) == 2
    f.write_text("0.00 0.01 0.05 1/80 2\n")
    assert busy_elsewhere(str(f)) == 0


def test_without_a_load_file_one_core(tmp_path):
    assert busy_elsewhere(str(tmp_path / "missing")) is None
    (tmp_path / "bad").write_text("garbage\n")
    assert busy_elsewhere(str(tmp_path / "bad")) is None
    assert 1 <= usable_cores() <= (os.cpu_count() or 1)


@pytest.mark.skipif(not os.path.exists("/proc/loadavg"), reason="Linux only")
def test_a_busy_process_elsewhere_is_seen():
    before = busy_elsewhere()
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        seen = 0
        for _ in range(50):          # until the burner runs (it may start waiting for a core)
            time.sleep(0.05)
            seen = busy_elsewhere()
            if seen >= 1:
                break
        assert seen >= 1, (before, seen)
    finally:
        burner.kill()
        burner.wait()
