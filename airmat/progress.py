"""Progress bars that show only when stderr is a terminal (tqdm behind a switch)."""

from __future__ import annotations

import sys
from typing import Iterable, TypeVar

__all__ = ["progress", "progress_enabled", "set_progress"]

T = TypeVar("T")
_FORCE: bool | None = None


def set_progress(enabled: bool | None) -> None:
    """Force progress bars on or off (``None``: on when stderr is a terminal)."""
    global _FORCE
    _FORCE = enabled


def progress_enabled() -> bool:
    """Whether progress bars are shown now."""
    if _FORCE is not None:
        return _FORCE
    return sys.stderr.isatty()


def progress(iterable: Iterable[T] | None = None, *, total: int | None = None,
             desc: str | None = None, unit: str = "it"):
    """A tqdm bar over ``iterable`` when enabled, else a silent stand-in.

    The stand-in supports the parts of the tqdm API airmat uses:
    iteration, ``update``, ``set_postfix_str`` and the context protocol.
    """
    if progress_enabled():
        from tqdm.auto import tqdm

        return tqdm(iterable, total=total, desc=desc, unit=unit, leave=False,
                    dynamic_ncols=True, file=sys.stderr)
    return _NoBar(iterable)


class _NoBar:
    def __init__(self, iterable):
        self._it = iterable

    def __iter__(self):
        return iter(self._it if self._it is not None else ())

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        pass

    def set_postfix_str(self, s="", refresh=True):
        pass

    def close(self):
        pass
