"""Independent tasks on forked copies of this process, started now, their results collected later.

Some independent work is too short to pay for a worker pool (the linear tolerance's
validation samples: 16 equilibria of a few hundred milliseconds on the model this process
already holds), yet long enough that a second core halves it. A forked child starts in a
millisecond with everything this process has built (the model, the factorization's
ordering, the loaded libraries), so :class:`ForkedMap` forks up to ``workers`` children,
each of which claims the next item not yet claimed (a counter in shared memory: a child
whose items converge quickly takes more of them), runs ``fn`` on it and sends the result
back through a pipe, while this process goes on with other work; :meth:`ForkedMap.results`
then collects them, as they come (a progress bar can count them), in the order of the items.

The results are those of ``[fn(item) for item in items]`` in this process: the same
function on the same memory, no random step shared between items (each task must depend
on its own item only). Forking is used on Linux only (macOS forbids it after its system
frameworks have started threads; Windows has no fork); elsewhere, with one worker or one
item, :meth:`ForkedMap.results` runs the tasks here, one after the other.

A child runs without progress bars or log records and dies with the default action on
Ctrl-C; a task that raises re-raises its exception here; a child that dies without an
answer (killed, out of memory) has its items run here instead, with a warning.
"""

from __future__ import annotations

import logging
import os
import pickle
import signal
import sys

import numpy as np

__all__ = ["ForkedMap", "can_fork"]

log = logging.getLogger(__name__)


def can_fork() -> bool:
    """Whether :class:`ForkedMap` forks here (Linux with ``os.fork``)."""
    return sys.platform.startswith("linux") and hasattr(os, "fork")


def _frame(obj) -> bytes:
    """``obj`` pickled behind its 8-byte length."""
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    return len(data).to_bytes(8, "little") + data


def _child(fn, items, claim, fd) -> None:
    """The forked child: claim the next item (``claim()``: its index, or None when all are claimed), run ``fn``
    on it and write ``(index, "ok", result)`` to ``fd`` (a length-prefixed pickle), until none is left; on an
    exception write ``(index, "error", exc)`` and stop. Exits without running this process's exit handlers."""
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        from airmat.progress import set_progress

        set_progress(False)
        logging.disable(logging.CRITICAL)
        with os.fdopen(fd, "wb") as out:
            while (i := claim()) is not None:
                try:
                    frame = _frame((i, "ok", fn(items[i])))
                except BaseException as exc:       # noqa: BLE001 - every failure goes back to the parent
                    try:
                        frame = _frame((i, "error", exc))
                    except Exception:              # noqa: BLE001 - an exception that does not pickle
                        frame = _frame((i, "error", RuntimeError(f"{type(exc).__name__}: {exc}")))
                    out.write(frame)
                    break
                out.write(frame)
                out.flush()
        code = 0
    finally:
        os._exit(code)


class _Counter:
    """The next unclaimed item, shared by the forked children (a lock-guarded integer in shared memory)."""

    def __init__(self, n: int):
        import multiprocessing

        self._next = multiprocessing.get_context("fork").Value("q", 0)
        self._n = n

    def __call__(self) -> int | None:
        with self._next.get_lock():
            i = self._next.value
            if i >= self._n:
                return None
            self._next.value = i + 1
        return i


class ForkedMap:
    """``[fn(item) for item in items]``, started on up to ``workers`` forked children now.

    Parameters
    ----------
    fn : callable
        ``fn(item)``: its result must pickle. Closures are fine (the children are forks).
    items : sequence
    workers : int
        Children at most (no more than the items); below 2, or where :func:`can_fork` is
        False, nothing is forked and :meth:`results` runs the tasks in this process.

    Attributes
    ----------
    forked : int
        Children started.

    Examples
    --------
    >>> m = ForkedMap(lambda x: x * x, [1, 2, 3], workers=2)
    >>> m.results()
    [1, 4, 9]
    """

    def __init__(self, fn, items, workers: int):
        self._fn, self._items = fn, list(items)
        self._children = []                   # (pid, read end)
        parts = min(int(workers), len(self._items))
        if parts < 2 or not can_fork():
            self.forked = 0
            return
        self._claim = _Counter(len(self._items))
        for _ in range(parts):
            read, write = os.pipe()
            pid = os.fork()
            if pid == 0:                      # pragma: no cover - runs in the child, which never returns
                os.close(read)
                _child(self._fn, self._items, self._claim, write)
            os.close(write)
            self._children.append((pid, read))
        self.forked = len(self._children)

    def results(self, on_result=None) -> list:
        """The results in the order of the items (waits for the children).

        Parameters
        ----------
        on_result : callable, optional
            Called with no argument as each result comes in (a progress bar's ``update``).

        Raises
        ------
        Exception
            The first exception a task raised (in a child or here).
        """
        tick = on_result if on_result is not None else (lambda: None)
        if not self._children:
            out = []
            for item in self._items:
                out.append(self._fn(item))
                tick()
            return out
        import selectors

        out, got = [None] * len(self._items), np.zeros(len(self._items), bool)
        buffers = {read: bytearray() for _, read in self._children}
        pids = dict((read, pid) for pid, read in self._children)
        error = None
        try:
            with selectors.DefaultSelector() as sel:
                for read in buffers:
                    sel.register(read, selectors.EVENT_READ)
                while error is None and sel.get_map():
                    for key, _ in sel.select():
                        read = key.fd
                        chunk = os.read(read, 1 << 20)
                        if not chunk:                 # the child is done (or died)
                            sel.unregister(read)
                            os.close(read)
                            os.waitpid(pids[read], 0)
                            self._children = [c for c in self._children if c[1] != read]
                            continue
                        buf = buffers[read]
                        buf += chunk
                        while len(buf) >= 8 and len(buf) >= 8 + int.from_bytes(buf[:8], "little"):
                            size = int.from_bytes(buf[:8], "little")
                            i, status, value = pickle.loads(bytes(buf[8:8 + size]))
                            del buf[:8 + size]
                            if status == "error":
                                error = value
                                break
                            out[i], got[i] = value, True
                            tick()
                        if error is not None:
                            break
        finally:
            self._stop()
        if error is not None:
            raise error
        if not got.all():
            missing = np.flatnonzero(~got)
            log.warning("a forked worker died without an answer: %d tasks run here", len(missing))
            for i in missing:
                out[i] = self._fn(self._items[i])
                tick()
        return out

    def cancel(self) -> None:
        """Give the results up: the children still running are killed and reaped, and nothing runs here."""
        self._stop()
        self._items = []

    def _stop(self) -> None:
        """Kill and reap the children still running (after an error or an interruption here)."""
        for pid, read in self._children:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(pid, 0)
            try:
                os.close(read)
            except OSError:                   # closed already by an interrupted read
                pass
        self._children = []

    def __del__(self):
        if getattr(self, "_children", None):
            self._stop()
