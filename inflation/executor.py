"""The one executor of independent tasks (inflations): in this process, or on Dask.

Every set of independent inflations (a check's median / lo95 / hi95 runs,
the Monte-Carlo samples, the validation's ratios, the gallery) goes through
:func:`map_shared`: ``fn(shared, item)`` for each item, results in the
order of the items.

- One task, or ``workers <= 1`` without a scheduler: one after the other in
  this process (Dask is not imported: the command line starts light).
- Otherwise on :mod:`dask.distributed`: by default a
  :class:`~distributed.LocalCluster` of ``workers`` single-threaded worker
  processes (``processes=True, threads_per_worker=1``, no dashboard, quiet
  logs), or an existing cluster at ``scheduler`` (``tcp://host:port``; the
  command line's ``--scheduler`` or ``AIRMAT_SCHEDULER``), whose workers
  must have airmat importable.

``shared`` (the mesh and the parameters) is sent to the workers once
(``client.scatter(..., broadcast=True)``), not per task. A task that raises
ends the run with its exception (re-raised here, as raised on the worker)
after the other tasks are cancelled; a progress bar counts finished tasks.
The results equal those of the serial path: same function, same inputs, no
random step in a task (the worker processes run single-threaded BLAS, as
``airmat`` sets for itself on the command line).

Ctrl-C: the local workers start with SIGINT ignored, so a terminal's Ctrl-C
(sent to the whole process group) stops only this process, which closes the
cluster and so stops the workers.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shlex
import sys
import tempfile

from airmat.errors import AirmatError, InputError, TaskError
from airmat.progress import progress, set_progress

__all__ = ["map_shared", "local_cluster", "scheduler_address", "SCHEDULER_ENV"]

log = logging.getLogger(__name__)

#: environment variable naming an existing Dask scheduler (``tcp://host:port``)
SCHEDULER_ENV = "AIRMAT_SCHEDULER"

#: the local workers' environment: single-threaded BLAS as in this process, and not Dask's default
#: MALLOC_TRIM_THRESHOLD_=65536, which makes an inflation about a third slower (bench/bench_monte_carlo.py)
_WORKER_ENV = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}

#: how long to wait for an existing scheduler to answer
CONNECT_TIMEOUT = "30s"


def scheduler_address(explicit: str | None = None) -> str | None:
    """The Dask scheduler to use: ``explicit``, else ``$AIRMAT_SCHEDULER``, else None (a local cluster).

    Examples
    --------
    >>> scheduler_address("tcp://10.0.0.1:8786")
    'tcp://10.0.0.1:8786'
    """
    if explicit:
        return str(explicit)
    return os.environ.get(SCHEDULER_ENV) or None


def _on_worker(fn, shared, item):
    """Run one task on a Dask worker: no progress bars, no log records on the worker's stderr."""
    set_progress(False)
    root = logging.getLogger()
    if not root.handlers:
        root.addHandler(logging.NullHandler())
    return fn(shared, item)


@contextlib.contextmanager
def _workers_ignore_sigint(tmp: str):
    """Worker processes spawned meanwhile start with SIGINT ignored, before their first import.

    A terminal's Ctrl-C goes to the whole process group; the workers must leave it to this
    process, which then closes the cluster. An ignored signal stays ignored across ``exec``, so the
    spawn goes through a two-line ``sh`` that ignores SIGINT and execs this Python (a blocked mask
    would not do: Dask's event-loop thread, which spawns the workers, does not keep it).
    """
    from multiprocessing import spawn

    exe = os.path.join(tmp, "python")
    with open(exe, "w") as fh:
        fh.write(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(sys.executable)} \"$@\"\n")
    os.chmod(exe, 0o700)
    old = spawn.get_executable()
    spawn.set_executable(exe)
    try:
        yield
    finally:
        spawn.set_executable(old)


def _quiet_dask_logs() -> None:
    """Dask's own log records stay off airmat's stderr: a failed task reaches the caller as its exception."""
    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    logging.getLogger("asyncio").setLevel(logging.CRITICAL)     # its event loop's, e.g. during a Ctrl-C teardown


def _quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker with its stderr on /dev/null (no-op when it runs).

    An interrupted command ends with ``os._exit`` (:mod:`airmat.cli`), before the nannies'
    queues are collected; the tracker would then add a "leaked semaphore" warning to the one
    line that an interrupt prints.
    """
    from multiprocessing import resource_tracker

    saved, null = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


@contextlib.contextmanager
def _client(workers: int, scheduler: str | None):
    """A dask.distributed Client on ``scheduler`` or on a new quiet LocalCluster of ``workers`` processes."""
    if scheduler is not None:
        from distributed import Client

        _quiet_dask_logs()
        try:
            client = Client(scheduler, set_as_default=False, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"no Dask scheduler reachable at {scheduler}: {exc}") from None
        try:
            yield client
        finally:
            client.close()
        return
    from distributed import Client

    with local_cluster(workers) as cluster:
        client = Client(cluster, set_as_default=False)
        try:
            yield client
        finally:
            client.close()


@contextlib.contextmanager
def local_cluster(workers: int):
    """A quiet :class:`distributed.LocalCluster` of ``workers`` single-threaded worker processes.

    On 127.0.0.1, no dashboard, Dask's logs off, the workers ignoring SIGINT from their start
    (:func:`_workers_ignore_sigint`) with the environment ``_WORKER_ENV``; closed on exit.
    """
    import dask
    from distributed import LocalCluster

    _quiet_dask_logs()
    _quiet_resource_tracker()
    with tempfile.TemporaryDirectory(prefix="airmat-dask-") as tmp, _workers_ignore_sigint(tmp):
        with dask.config.set({"distributed.worker.daemon": True, "logging.distributed": "critical",
                              "distributed.worker.multiprocessing-method": "spawn",
                              "distributed.nanny.pre-spawn-environ": _WORKER_ENV}):
            # no dashboard; the scheduler's own HTTP routes on a free local port, not on 8787 (its
            # default), which another cluster or program may hold: two runs at once must not collide
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.CRITICAL,
                                   host="127.0.0.1", worker_dashboard_address=None,
                                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
    try:
        yield cluster
    finally:
        with contextlib.suppress(Exception):
            cluster.close(timeout=10)


def _raise_task_error(future):
    """Raise a failed task's exception: airmat's own as raised on the worker, any other as a TaskError."""
    exc = future.exception()
    if isinstance(exc, AirmatError):
        raise exc
    raise TaskError(f"a task failed on a Dask worker: {type(exc).__name__}: {exc}") from exc


def map_shared(fn, shared, items, *, workers: int = 1, scheduler: str | None = None,
               desc: str = "run", unit: str = "run") -> list:
    """``[fn(shared, item) for item in items]``, in this process or on Dask.

    Parameters
    ----------
    fn : callable
        ``fn(shared, item) -> result``; a module-level function (the workers import it).
    shared : object
        Sent to every worker once (picklable).
    items : sequence
        One task each (picklable).
    workers : int
        Local worker processes (1 without ``scheduler``: serial, in this process).
    scheduler : str, optional
        Address of an existing Dask scheduler; then ``workers`` is ignored.
    desc, unit : str
        Label of the progress bar.

    Returns
    -------
    list
        ``fn``'s results in the order of ``items``.

    Raises
    ------
    airmat.errors.AirmatError
        The first failed task's exception, after the others are cancelled: an airmat error
        as raised on the worker, any other wrapped in :class:`~airmat.errors.TaskError`
        (serial runs raise it unwrapped).
    airmat.errors.InputError
        No scheduler at ``scheduler``.

    Examples
    --------
    >>> map_shared(lambda s, x: s * x, 10, [1, 2, 3])
    [10, 20, 30]
    """
    items = list(items)
    if scheduler is None and (workers <= 1 or len(items) <= 1):
        return [fn(shared, it) for it in progress(items, desc=desc, unit=unit)]
    from distributed import as_completed

    n = min(workers, len(items))
    where = scheduler if scheduler is not None else f"{n} processes"
    with _client(n, scheduler) as client:
        futures = []
        try:
            shared_f = client.scatter(shared, broadcast=True, hash=False)
            futures = [client.submit(_on_worker, fn, shared_f, it, pure=False) for it in items]
            with progress(total=len(futures), desc=f"{desc} ({where})", unit=unit) as bar:
                for f in as_completed(futures, loop=client.loop):
                    if f.status == "error":
                        _raise_task_error(f)
                    bar.update(1)
            return client.gather(futures)
        except BaseException:
            # Ctrl-C or a failed task: cancel the rest (the cluster then closes)
            with contextlib.suppress(Exception):
                client.cancel(futures, force=True)
            raise
