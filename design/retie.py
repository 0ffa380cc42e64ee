"""The re-tie list from one shape to another on the same mattress: keep, re-tie, remove, add.

One mattress, many shapes: going from design A to design B, a string of A
whose two grid nodes (on the same face) are also a string of B **stays**
(re-cut or re-knotted to B's length if that differs); the other strings of
A are **re-tied** at the nodes of a string of B on the same face (one to
one, the pairs chosen to move the ends least: a linear assignment over the
summed end distances), and what is left is **removed** (A had more strings
on that face) or **added** (B has more). Strings are compared by their grid
nodes, so both designs must be tied to the same grid (``--tie-grid-mm``).
SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from airmat.errors import InputError

__all__ = ["RetieStep", "RetiePlan", "retie_plan"]

ACTIONS = ("keep", "retie", "remove", "add")


@dataclass(frozen=True)
class RetieStep:
    """One line of the re-tie list.

    Attributes
    ----------
    action : str
        ``keep``, ``retie``, ``remove`` or ``add``.
    face : str
        ``top`` or ``bottom``.
    a, b : TensionString or None
        The string in design A (None for ``add``) and in design B (None for ``remove``).
    move : float
        Summed distance its two ends move on Ω (m): 0 for ``keep``, NaN for ``remove``/``add``.
    """

    action: str
    face: str
    a: object = field(repr=False)
    b: object = field(repr=False)
    move: float = 0.0


@dataclass(frozen=True)
class RetiePlan:
    """The re-tie list from design A to design B, ordered keep, retie, remove, add."""

    steps: tuple

    def count(self, action: str) -> int:
        """Number of steps of one action."""
        return sum(1 for s in self.steps if s.action == action)

    @property
    def counts(self) -> dict:
        """``{keep, retie, remove, add}`` -> number of strings."""
        return {a: self.count(a) for a in ACTIONS}


def _key(s) -> tuple:
    """A string's face and unordered node pair."""
    ends = sorted([tuple(s.dash.a_node), tuple(s.dash.b_node)])
    return s.side, ends[0], ends[1]


def _check(strings, name: str) -> None:
    free = [s.dash.id for s in strings if s.dash.a_node is None or s.dash.b_node is None]
    if free:
        raise InputError(f"design {name} has strings with free ends ({free[0]}, ...): re-tie lists compare grid "
                         f"nodes, design both shapes with --tie-grid-mm > 0")


def _end_cost(a_strings, b_strings) -> np.ndarray:
    """(na, nb) summed distance of the ends, the better of the two orientations (m)."""
    pa = np.array([[s.dash.a, s.dash.b] for s in a_strings])            # (na, 2, 2)
    pb = np.array([[s.dash.a, s.dash.b] for s in b_strings])            # (nb, 2, 2)
    d = np.linalg.norm(pa[:, None, :, None, :] - pb[None, :, None, :, :], axis=-1)   # (na, nb, 2, 2)
    return np.minimum(d[..., 0, 0] + d[..., 1, 1], d[..., 0, 1] + d[..., 1, 0])


def retie_plan(design_a, design_b) -> RetiePlan:
    """The re-tie list from design A to design B (both :class:`~airmat.design.pipeline.DesignResult`).

    Raises
    ------
    airmat.errors.InputError
        The designs are on different mattresses, or a string has free ends.
    """
    from scipy.optimize import linear_sum_assignment

    ma, mb = design_a.approx.mattress, design_b.approx.mattress
    if not np.allclose([ma.width, ma.height], [mb.width, mb.height], atol=1e-4):
        raise InputError(f"the designs are for different mattresses: {ma.width * 1e3:.0f} x {ma.height * 1e3:.0f} "
                         f"mm and {mb.width * 1e3:.0f} x {mb.height * 1e3:.0f} mm")
    sa, sb = design_a.pattern.strings, design_b.pattern.strings
    _check(sa, "A")
    _check(sb, "B")
    b_by_key = {}
    for s in sb:
        b_by_key.setdefault(_key(s), []).append(s)
    keep, rest_a = [], []
    for s in sa:
        match = b_by_key.get(_key(s))
        if match:
            keep.append(RetieStep("keep", s.side, s, match.pop(0), 0.0))
        else:
            rest_a.append(s)
    rest_b = [s for group in b_by_key.values() for s in group]
    steps = list(keep)
    for face in ("top", "bottom"):
        fa = [s for s in rest_a if s.side == face]
        fb = sorted((s for s in rest_b if s.side == face), key=lambda s: s.dash.id)
        ia, ib = (linear_sum_assignment(_end_cost(fa, fb)) if fa and fb else (np.zeros(0, int), np.zeros(0, int)))
        cost = _end_cost(fa, fb) if fa and fb else None
        steps += [RetieStep("retie", face, fa[i], fb[j], float(cost[i, j])) for i, j in zip(ia, ib)]
        steps += [RetieStep("remove", face, fa[i], None, float("nan")) for i in sorted(set(range(len(fa))) - set(ia))]
        steps += [RetieStep("add", face, None, fb[j], float("nan")) for j in sorted(set(range(len(fb))) - set(ib))]
    order = {a: k for k, a in enumerate(ACTIONS)}
    steps.sort(key=lambda s: (order[s.action], s.face, (s.a or s.b).dash.id))
    return RetiePlan(steps=tuple(steps))
