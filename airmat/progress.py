"""Progress bars that show on a terminal and in a Jupyter notebook (``tqdm.auto`` behind a switch).

Two kinds: :func:`progress` counts items (scans, MCMC steps, inflations), and
:func:`residual_progress` shows an iterative solver's way to its tolerance, in
decades of the residual, so that its bar fills when the solver converges
(an iteration count against a cap does not say how far the solver is).
"""

from __future__ import annotations

import sys
from typing import Iterable, TypeVar

__all__ = ["progress", "residual_progress", "progress_enabled", "set_progress"]

import math

T = TypeVar("T")
_FORCE: bool | None = None


def set_progress(enabled: bool | None) -> None:
    """Force progress bars on or off (``None``: on when stderr is a terminal)."""
    global _FORCE
    _FORCE = enabled


def _in_notebook() -> bool:
    """Whether this runs in a Jupyter kernel (where stderr is no terminal but widgets show bars)."""
    shell = sys.modules.get("IPython") and getattr(sys.modules["IPython"], "get_ipython", lambda: None)()
    return type(shell).__name__ == "ZMQInteractiveShell"


def progress_enabled() -> bool:
    """Whether progress bars are shown now: forced by :func:`set_progress`, else on a terminal or in a notebook."""
    if _FORCE is not None:
        return _FORCE
    return sys.stderr.isatty() or _in_notebook()


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


def residual_progress(tol: float, *, desc: str):
    """A bar that fills as a residual falls from its first value to ``tol`` (log scale).

    Parameters
    ----------
    tol : float
        The residual at which the solver stops (> 0).
    desc : str
        The bar's label.

    Returns
    -------
    context manager
        Its ``residual(value)`` moves the bar to ``log10(first / value)`` decades of
        ``log10(first / tol)``; a silent stand-in when bars are off.

    Examples
    --------
    >>> with residual_progress(1e-6, desc="solve") as bar:
    ...     for r in (1.0, 1e-3, 1e-7):
    ...         bar.residual(r)
    >>> round(_ResidualBar(1e-6, None).fraction(1.0, 1e-3), 3)
    0.5
    """
    return _ResidualBar(tol, progress(total=1000, desc=desc, unit="‰") if progress_enabled() else None)


class _ResidualBar:
    def __init__(self, tol: float, bar):
        self.tol, self.bar, self.first = float(tol), bar, None

    @staticmethod
    def fraction(first: float, value: float, tol: float = 1e-6) -> float:
        """Share of the decades from ``first`` down to ``tol`` covered at ``value``, in [0, 1]."""
        if not (math.isfinite(first) and math.isfinite(value)):
            return 0.0                  # a diverging residual: no progress (a bar never raises)
        if not (first > tol > 0 and value > 0):
            return 1.0 if value <= tol else 0.0
        return min(1.0, max(0.0, math.log10(first / value) / math.log10(first / tol)))

    def residual(self, value: float) -> None:
        value = float(value)
        if self.first is None:
            self.first = value
        if self.bar is not None:
            done = round(1000 * self.fraction(self.first, value, self.tol))
            if done > self.bar.n:
                self.bar.update(done - self.bar.n)
            self.bar.set_postfix_str(f"residual {value:.2e} → {self.tol:.0e}")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()
        return False
