"""Ctrl-C inside library code that must not be cut mid-call (a third-party loop that would print a trace).

:func:`deferred_interrupt` holds a SIGINT back while a block runs and lets
the block give it way at safe points (``pending.check()``): emcee's
likelihood wrapper, for one, prints a traceback for any exception raised
inside the likelihood, KeyboardInterrupt included. Off the main thread
(where signal handlers cannot be set) the block runs unchanged.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["deferred_interrupt", "Pending"]


class Pending:
    """Whether a SIGINT arrived inside :func:`deferred_interrupt`; :meth:`check` raises it."""

    def __init__(self):
        self.arrived = False

    def check(self) -> None:
        """Raise :class:`KeyboardInterrupt` now if a SIGINT arrived."""
        if self.arrived:
            raise KeyboardInterrupt


@contextlib.contextmanager
def deferred_interrupt():
    """Hold SIGINT back inside the block; raise it at ``pending.check()`` or at the block's end.

    Yields
    ------
    Pending

    Examples
    --------
    >>> with deferred_interrupt() as pending:
    ...     pending.check()            # nothing arrived: no effect
    >>> pending.arrived
    False
    """
    pending = Pending()
    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = signal.getsignal(signal.SIGINT)

    def hold(signum, frame):
        pending.arrived = True
        if callable(previous):  # tell the previous handler's owner (it records the interrupt), quietly
            try:
                previous(signum, frame)
            except KeyboardInterrupt:
                pass

    signal.signal(signal.SIGINT, hold)
    try:
        yield pending
    finally:
        signal.signal(signal.SIGINT, previous)
    pending.check()
