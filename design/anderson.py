"""Anderson acceleration of a fixed-point iteration x -> G(x) (type II, Walker & Ni 2011).

Used to accelerate the local-global iterations of the U_A relaxation, as in
Peng et al., "Anderson acceleration for geometry optimization and physics
simulation" (SIGGRAPH 2018): the caller keeps the energy safeguard (an
accelerated step that raises the energy is replaced by the plain G(x) and
the history is reset).
"""

from __future__ import annotations

import numpy as np

__all__ = ["AndersonAcceleration"]


class AndersonAcceleration:
    """Anderson acceleration with a window of the last ``m`` iterates.

    Parameters
    ----------
    m : int
        Window (0: no acceleration, :meth:`propose` returns G(x)).

    Examples
    --------
    A linear contraction converges in a few accelerated steps:

    >>> A = np.array([[0.9, 0.05], [0.0, 0.95]]); b = np.array([1.0, 2.0])
    >>> acc, x = AndersonAcceleration(3), np.zeros(2)
    >>> for _ in range(6):
    ...     x = acc.propose(x, A @ x + b)
    >>> np.allclose(x, np.linalg.solve(np.eye(2) - A, b))
    True
    """

    def __init__(self, m: int):
        self.m = m
        self.reset()

    def reset(self):
        """Forget the history (after a rejected step)."""
        self.df, self.dg, self.prev = [], [], None

    def propose(self, x, g):
        """Next iterate from the current x and g = G(x) (arrays of the same shape)."""
        f = (g - x).ravel()
        if self.prev is not None and self.m > 0:
            self.df.append(f - self.prev[0])
            self.dg.append(g.ravel() - self.prev[1])
            del self.df[:-self.m], self.dg[:-self.m]
        self.prev = (f, g.ravel())
        if not self.df:
            return g
        dfm = np.column_stack(self.df)
        theta = np.linalg.lstsq(dfm, f, rcond=None)[0]
        return (g.ravel() - np.column_stack(self.dg) @ theta).reshape(g.shape)
