"""The re-tie list from one shape to another on the same mattress: keep, re-cut, move, remove, add.

One mattress, many shapes: going from design A to design B, each string of A
falls in one of five categories a crew can act on.

==========  ==================================================================
``keep``    B has a string at the same two grid nodes (same face), and its
            length differs by at most the cut tolerance: leave it.
``recut``   same nodes, but the length changes by more than the cut
            tolerance: untie, cut (or re-knot) to B's length, tie back.
``move``    no string of B at its nodes: re-tie it at the nodes of a string
            of B on the same face (and cut it to that string's length).
``remove``  A has more strings on that face than B needs: take it off.
``add``     B has more strings on that face: a new string.
==========  ==================================================================

Strings at the same nodes are paired first; the others are paired one to one
per face, chosen to move the ends least (a linear assignment over the summed
end distances). Strings are compared by their grid nodes, so both designs
must be tied to the same grid (``--tie-grid-mm``). SI units (m).

The cut tolerance defaults to :data:`CUT_TOLERANCE` (1 mm): a string whose
length changes by less than that is not worth untying (the cutting list
gives lengths to 0.01 mm, the calibration's 95 % interval is several mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from airmat.constants import CUT_TOLERANCE
from airmat.errors import InputError

# numpy and scipy load inside the functions

__all__ = ["RetieStep", "RetiePlan", "retie_plan", "counts_text", "ACTIONS", "LABELS", "CUT_TOLERANCE"]

#: the categories, in workshop order
ACTIONS = ("keep", "recut", "move", "remove", "add")
#: how each category is written for people (screen, figure legend)
LABELS = {"keep": "keep", "recut": "re-cut", "move": "move", "remove": "remove", "add": "add"}


@dataclass(frozen=True)
class RetieStep:
    """One line of the re-tie list.

    Attributes
    ----------
    action : str
        One of :data:`ACTIONS`.
    face : str
        ``top`` or ``bottom``.
    a, b : TensionString or None
        The string in design A (None for ``add``) and in design B (None for ``remove``).
    move : float
        Summed distance its two ends move on Ω (m): 0 for ``keep`` and ``recut``, NaN for
        ``remove``/``add``.
    """

    action: str
    face: str
    a: object = field(repr=False)
    b: object = field(repr=False)
    move: float = 0.0

    @property
    def dl(self) -> float:
        """Length change B − A of the string (m); NaN for ``remove``/``add``."""
        if self.a is None or self.b is None:
            return math.nan
        return float(self.b.l_median - self.a.l_median)


@dataclass(frozen=True)
class RetiePlan:
    """The re-tie list from design A to design B, ordered as :data:`ACTIONS`.

    Attributes
    ----------
    steps : tuple of RetieStep
    cut_tolerance : float
        The cut tolerance the steps were sorted with (m).
    """

    steps: tuple
    cut_tolerance: float = CUT_TOLERANCE

    def count(self, action: str) -> int:
        """Number of steps of one action."""
        return sum(1 for s in self.steps if s.action == action)

    @property
    def counts(self) -> dict:
        """``{keep, recut, move, remove, add}`` -> number of strings."""
        return {a: self.count(a) for a in ACTIONS}

    def __repr__(self) -> str:
        return f"<RetiePlan: {counts_text(self.counts)} (cut tolerance {self.cut_tolerance * 1e3:g} mm)>"


def counts_text(counts: dict) -> str:
    """The counts as people read them, in workshop order.

    Examples
    --------
    >>> counts_text({"keep": 3, "recut": 2, "move": 1, "remove": 0, "add": 4})
    'keep 3, re-cut 2, move 1, remove 0, add 4'
    """
    return ", ".join(f"{LABELS[a]} {counts[a]}" for a in ACTIONS)


def _key(s) -> tuple:
    """A string's face and unordered node pair."""
    ends = sorted([tuple(s.dash.a_node), tuple(s.dash.b_node)])
    return s.side, ends[0], ends[1]


def _check(strings, name: str) -> None:
    free = [s.dash.id for s in strings if s.dash.a_node is None or s.dash.b_node is None]
    if free:
        raise InputError(f"design {name} has strings with free ends ({free[0]}, ...): re-tie lists compare grid "
                         f"nodes, design both shapes with --tie-grid-mm > 0")


def _end_cost(a_strings, b_strings):
    """(na, nb) ndarray: summed distance of the ends, the better of the two orientations (m)."""
    import numpy as np

    pa = np.array([[s.dash.a, s.dash.b] for s in a_strings])            # (na, 2, 2)
    pb = np.array([[s.dash.a, s.dash.b] for s in b_strings])            # (nb, 2, 2)
    d = np.linalg.norm(pa[:, None, :, None, :] - pb[None, :, None, :, :], axis=-1)   # (na, nb, 2, 2)
    return np.minimum(d[..., 0, 0] + d[..., 1, 1], d[..., 0, 1] + d[..., 1, 0])


def _same_nodes(sa, sb, cut_tolerance: float) -> tuple[list, list, list]:
    """Steps of the strings of A whose nodes B also uses (keep or recut); A's and B's other strings."""
    b_by_key = {}
    for s in sb:
        b_by_key.setdefault(_key(s), []).append(s)
    # a change printed as exactly the tolerance is kept, whatever the rounding of mm -> m
    limit = cut_tolerance * (1 + 1e-9)
    steps, rest_a = [], []
    for s in sa:
        match = b_by_key.get(_key(s))
        if match:
            b = match.pop(0)
            action = "keep" if abs(b.l_median - s.l_median) <= limit else "recut"
            steps.append(RetieStep(action, s.side, s, b, 0.0))
        else:
            rest_a.append(s)
    return steps, rest_a, [s for group in b_by_key.values() for s in group]


def _paired_by_face(rest_a, rest_b) -> list:
    """Move, remove and add steps: A's and B's unpaired strings, one to one per face by least movement."""
    import numpy as np
    from scipy.optimize import linear_sum_assignment

    steps = []
    for face in ("top", "bottom"):
        fa = [s for s in rest_a if s.side == face]
        fb = sorted((s for s in rest_b if s.side == face), key=lambda s: s.dash.id)
        ia, ib, cost = np.zeros(0, int), np.zeros(0, int), None
        if fa and fb:
            cost = _end_cost(fa, fb)
            ia, ib = linear_sum_assignment(cost)
        steps += [RetieStep("move", face, fa[i], fb[j], float(cost[i, j])) for i, j in zip(ia, ib)]
        steps += [RetieStep("remove", face, fa[i], None, math.nan) for i in sorted(set(range(len(fa))) - set(ia))]
        steps += [RetieStep("add", face, None, fb[j], math.nan) for j in sorted(set(range(len(fb))) - set(ib))]
    return steps


def retie_plan(design_a, design_b, *, cut_tolerance: float = CUT_TOLERANCE) -> RetiePlan:
    """The re-tie list from design A to design B (both :class:`~airmat.design.pipeline.DesignResult`).

    Parameters
    ----------
    design_a, design_b : DesignResult
        The shape now and the next shape, on the same mattress and tie grid.
    cut_tolerance : float, keyword-only
        Largest length change (m) for which a string at the same nodes is kept as it is;
        default :data:`CUT_TOLERANCE` (1 mm).

    Returns
    -------
    RetiePlan
        Every string of A and of B once, ordered by action (:data:`ACTIONS`), face and id.

    Raises
    ------
    airmat.errors.InputError
        The designs are on different mattresses, a string has free ends, or the
        tolerance is negative or not finite.
    """
    import numpy as np

    if not (math.isfinite(cut_tolerance) and cut_tolerance >= 0):
        raise InputError(f"the cut tolerance must be a finite length >= 0 m, got {cut_tolerance!r}")
    ma, mb = design_a.approx.mattress, design_b.approx.mattress
    if not np.allclose([ma.width, ma.height], [mb.width, mb.height], atol=1e-4):
        raise InputError(f"the designs are for different mattresses: {ma.width * 1e3:.0f} x {ma.height * 1e3:.0f} "
                         f"mm and {mb.width * 1e3:.0f} x {mb.height * 1e3:.0f} mm")
    sa, sb = design_a.pattern.strings, design_b.pattern.strings
    _check(sa, "A")
    _check(sb, "B")
    steps, rest_a, rest_b = _same_nodes(sa, sb, cut_tolerance)
    steps += _paired_by_face(rest_a, rest_b)
    order = {a: k for k, a in enumerate(ACTIONS)}
    steps.sort(key=lambda s: (order[s.action], s.face, (s.a or s.b).dash.id))
    return RetiePlan(steps=tuple(steps), cut_tolerance=float(cut_tolerance))
