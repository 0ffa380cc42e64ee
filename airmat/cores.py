"""How many CPU cores a multithreaded call may use: the ones no other process keeps busy now.

A library call that splits its work over threads (open3d's closest-point
query) is faster with every core on an idle machine but slower when the
cores are already busy (the threads wait on each other), as when the tests
or the gallery run one process per core. So the caller asks, when it starts
and now and then while it runs, how many cores the other processes leave
idle: Linux's count of runnable threads (``/proc/loadavg``) less this
process's own, the fewest of a few quick readings (a passing spike is not a
busy core). Elsewhere the answer is one core. Threads never change a
result here, only its time.
"""

from __future__ import annotations

import os
import time

__all__ = ["usable_cores", "busy_elsewhere", "idle_cores"]

#: readings of the runnable count, 1 ms apart; the fewest counts
SAMPLES = 5


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity; ``os.cpu_count()`` where that is unknown), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def busy_elsewhere(path: str = "/proc/loadavg", samples: int = SAMPLES) -> int | None:
    """Threads of other processes running or ready to run now; None where the system does not say.

    The fourth field of ``/proc/loadavg`` ("runnable/total") counts every runnable thread,
    this one (which is reading it) included; the fewest of ``samples`` readings 1 ms apart,
    less one.
    """
    counts = []
    for i in range(max(1, samples)):
        try:
            with open(path) as f:
                counts.append(int(f.read().split()[3].split("/")[0]))
        except (OSError, ValueError, IndexError):
            return None
        if i + 1 < samples:
            time.sleep(0.001)
    return max(0, min(counts) - 1)


def idle_cores(busy: int | None = None, cores: int | None = None, samples: int = SAMPLES) -> int:
    """Cores the other processes leave idle: the usable cores less the busy ones, between 1 and all.

    Parameters
    ----------
    busy : int, optional
        Cores kept busy by other processes; default :func:`busy_elsewhere` (and one core
        where the system does not say: one thread is never slower than many on a busy machine).
    cores : int, optional
        Usable cores; default :func:`usable_cores`.
    samples : int, default SAMPLES
        Readings of :func:`busy_elsewhere` when ``busy`` is not given.

    Returns
    -------
    int
        Between 1 and ``cores``.

    Examples
    --------
    >>> idle_cores(busy=0, cores=2), idle_cores(busy=1, cores=2), idle_cores(busy=5, cores=2)
    (2, 1, 1)
    """
    cores = usable_cores() if cores is None else int(cores)
    if busy is None:
        busy = busy_elsewhere(samples=samples)
        if busy is None:
            return 1
    return int(min(cores, max(1, cores - int(busy))))
