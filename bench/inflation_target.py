"""The speed target of one inflation (2 s small, 10 s large mattress at 20 mm), and how far two equilibria of one mesh lie apart."""

from __future__ import annotations

import numpy as np

from airmat.units import MM

#: one inflation at 20 mm on this 2-core machine at most (s): the small mattress, the large one
SMALL_S, LARGE_S = 2.0, 10.0

#: two ways of solving give "the same equilibrium" within this (mm)
SAME_MM = 0.1


def seconds_target(mattress) -> float:
    """The target (s) for ``mattress``: the small one (under 1 m wide) or the large one."""
    return SMALL_S if mattress.width < 1.0 else LARGE_S


def largest_gap_mm(a, b) -> float:
    """The largest distance (mm) between the vertices of two inflations of one mesh."""
    return float(np.max(np.linalg.norm(a.xyz - b.xyz, axis=1))) / MM
