"""The string pattern's data: dashes on Ω and the tension strings tied along them.

A :class:`Dash` is a piece of arc length L of a principal-curvature line on
Ω (paper §3.3.2); a :class:`TensionString` adds the face it is tied on and
its length with the calibration's 95 % interval (§3.3.3). Everything is in
SI: metres on Ω, 1/m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Dash", "TensionString", "Pattern"]


@dataclass(frozen=True)
class Dash:
    """A stripe of arc length L along a principal-curvature line on Ω.

    Attributes
    ----------
    id : str
        ``"<family>-<line>-<dash>"``, e.g. ``"k1-003-02"`` (lines numbered across
        the stripes, dashes along each line, both from 1).
    family : str
        ``"k1"`` or ``"k2"``.
    line, index : int
        Line number and dash number along the line (from 1).
    polyline : ndarray of shape (m, 2)
        Points of the dash on Ω (m), from end ``a`` to end ``b``.
    length : float
        Arc length of ``polyline`` (m), the geodesic spacing L of the string ends.
    a_node, b_node : (int, int) or None
        (row, col) of the mattress's grid node each end is tied to
        (:mod:`airmat.design.tie_grid`), None for free ends.
    """

    id: str
    family: str
    line: int
    index: int
    polyline: np.ndarray = field(repr=False)
    length: float
    a_node: tuple | None = None
    b_node: tuple | None = None

    @property
    def a(self) -> np.ndarray:
        """First end (2,) on Ω (m)."""
        return self.polyline[0]

    @property
    def b(self) -> np.ndarray:
        """Second end (2,) on Ω (m)."""
        return self.polyline[-1]

    @property
    def chord(self) -> float:
        """Straight distance |b - a| (m); equals ``length`` for a straight dash."""
        return float(np.linalg.norm(self.b - self.a))


@dataclass(frozen=True)
class TensionString:
    """A string tied between the ends of a dash.

    Attributes
    ----------
    dash : Dash
    kappa : float
        Representative signed curvature of the dash (1/m): mean of the field at
        N equally spaced points along it.
    side : str
        ``"top"`` (κ < 0) or ``"bottom"`` (κ > 0): the concave face.
    l_median, l_lo95, l_hi95 : float
        String length (m): posterior median and 95 % interval (the tolerance).
    flags : tuple of str
        ``"beyond_reach"`` when more than 2.5 % of the posterior cannot reach
        |κ| even at l = 0 (those samples are clipped to l = 0).
    free_span : float or None
        The span (m) Equation 3 was evaluated at: the length the string's free face has
        between the ties on Ŝ, at most the dash's length (:mod:`airmat.design.free_face`);
        None: the dash's length.
    """

    dash: Dash
    kappa: float
    side: str
    l_median: float
    l_lo95: float
    l_hi95: float
    flags: tuple = ()
    free_span: float | None = None

    @property
    def eq3_span(self) -> float:
        """The span L (m) of Equation 3 for this string: ``free_span``, else the dash's length."""
        return float(self.dash.length if self.free_span is None else self.free_span)


@dataclass(frozen=True)
class Pattern:
    """All strings of a design, and what was left out.

    Attributes
    ----------
    strings : tuple of TensionString
        Ordered by family, line and dash.
    L : float
        Geodesic spacing of string ends (m).
    n_dashes : dict
        Dashes cut per family ``{"k1": int, "k2": int}``.
    n_no_string : dict
        Dashes per family whose |κ| is too small to need a string.
    notes : tuple of str
        What the tracer and the length step skipped and why.
    tie_grid : airmat.design.tie_grid.TieGridReport or None
        Grid pitch and how far snapping the ends to it moved them; None when not known.
    coverage : dict or None
        How far the points that need strings lie from them, per family (mm,
        :meth:`airmat.design.coverage.Coverage.summary_mm`); None when not known.
    """

    strings: tuple
    L: float
    n_dashes: dict
    n_no_string: dict
    notes: tuple = ()
    tie_grid: object = field(default=None, repr=False, compare=False)
    coverage: dict | None = field(default=None, repr=False, compare=False)

    def count(self, side: str, family: str) -> int:
        """Number of strings on ``side`` ("top"/"bottom") of ``family`` ("k1"/"k2")."""
        return sum(1 for s in self.strings if s.side == side and s.dash.family == family)
