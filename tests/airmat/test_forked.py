"""airmat.forked: independent tasks on forked copies of this process, the results as if run here."""

import os
import signal

import numpy as np
import pytest

from airmat.forked import ForkedMap, can_fork

forks = pytest.mark.skipif(not can_fork(), reason="ForkedMap forks on Linux only")


@forks
def test_the_results_come_back_in_order_from_the_children():
    parent = os.getpid()
    m = ForkedMap(lambda i: (i, i * i, os.getpid()), range(7), workers=3)
    assert m.forked == 3
    ticks = []
    out = m.results(on_result=lambda: ticks.append(1))
    assert [(i, sq) for i, sq, _ in out] == [(i, i * i) for i in range(7)] and len(ticks) == 7
    pids = {pid for *_, pid in out}
    assert parent not in pids and 1 <= len(pids) <= 3     # every item on a child, each claimed once


@forks
def test_a_slow_item_does_not_hold_up_the_others():
    """Items are claimed one at a time: while one child works on a slow item the other takes the rest."""
    import time

    def task(i):
        if i == 0:
            time.sleep(0.5)
        return os.getpid()

    out = ForkedMap(task, range(8), workers=2).results()
    assert out.count(out[0]) == 1 and len(set(out[1:])) == 1 and out[1] != out[0]


@forks
def test_a_closure_over_this_process_memory_and_arrays_round_trip():
    big = np.random.default_rng(0).standard_normal((200, 3))
    m = ForkedMap(lambda k: big * k, [1.0, -2.0], workers=2)
    a, b = m.results()
    assert np.array_equal(a, big) and np.array_equal(b, -2.0 * big)


@forks
def test_a_task_that_raises_raises_here_and_no_child_is_left():
    def task(i):
        if i == 4:
            raise ValueError(f"bad item {i}")
        return i

    m = ForkedMap(task, range(6), workers=2)
    children = [pid for pid, _ in m._children]
    with pytest.raises(ValueError, match="bad item 4"):
        m.results()
    for pid in children:                                   # reaped: no such child any more
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)


@forks
def test_a_child_killed_without_an_answer_has_its_tasks_run_here(caplog):
    def task(i):
        if os.getpid() != parent and i == 0:
            os.kill(os.getpid(), signal.SIGKILL)           # the first child dies in its first task
        return i + 1

    parent = os.getpid()
    with caplog.at_level("WARNING", logger="airmat.forked"):
        out = ForkedMap(task, range(4), workers=2).results()
    assert out == [1, 2, 3, 4]
    assert "died without an answer" in caplog.text


def test_one_worker_or_one_item_runs_here():
    parent = os.getpid()
    for m in (ForkedMap(lambda i: os.getpid(), range(3), workers=1), ForkedMap(lambda i: os.getpid(), [0], workers=4)):
        assert m.forked == 0 and set(m.results()) == {parent}


@forks
def test_cancel_kills_and_reaps_the_children_and_runs_nothing_here():
    import time

    ran_here = []

    def task(i):
        if os.getpid() == parent:
            ran_here.append(i)
        time.sleep(30)
        return i

    parent = os.getpid()
    m = ForkedMap(task, range(2), workers=2)
    children = [pid for pid, _ in m._children]
    started = time.perf_counter()
    m.cancel()
    assert time.perf_counter() - started < 5 and not ran_here
    for pid in children:
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)
    assert m.results() == [] and not ran_here


def test_cancel_without_children_runs_nothing():
    ran = []
    m = ForkedMap(ran.append, [1, 2], workers=1)
    m.cancel()
    assert m.results() == [] and ran == []
