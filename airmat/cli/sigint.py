"""Ctrl-C for the command line: one line, exit code 130, at any instant.

:func:`install` runs before anything heavy is imported (``airmat/__main__``
and the start of :func:`airmat.cli.main`). Its handler records the
interrupt and raises :class:`KeyboardInterrupt`; :func:`interrupted` lets the
entry point recognise an interrupt that a library turned into another
exception (an ``ImportError`` raised while a module was half imported, a
wrapper's re-raise), and :func:`check` re-raises one that a library
swallowed (``except BaseException`` around an optional import, as trimesh
has): :func:`staged` checks before it publishes, so an interrupted run
never leaves its results in ``--out``. A SIGINT ignored by the parent shell (background jobs)
is handled too: the user asked for Ctrl-C to stop the run.
"""

from __future__ import annotations

import contextlib
import signal

__all__ = ["install", "interrupted", "ignore", "check", "staged"]

_state = {"interrupted": False}


def _handler(signum, frame):
    _state["interrupted"] = True
    raise KeyboardInterrupt


def install() -> None:
    """Make SIGINT raise KeyboardInterrupt (and remember that it came)."""
    _state["interrupted"] = False
    signal.signal(signal.SIGINT, _handler)


def interrupted() -> bool:
    """True once SIGINT arrived since :func:`install`."""
    return _state["interrupted"]


def ignore() -> None:
    """Ignore further SIGINTs (while the interrupt is being reported)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def check() -> None:
    """Raise KeyboardInterrupt if SIGINT arrived (and was perhaps swallowed by a library)."""
    if _state["interrupted"]:
        raise KeyboardInterrupt


@contextlib.contextmanager
def staged(out):
    """:func:`airmat.atomic.staged_dir`, which does not publish when SIGINT arrived meanwhile."""
    from airmat.atomic import staged_dir

    with staged_dir(out) as tmp:
        yield tmp
        check()
