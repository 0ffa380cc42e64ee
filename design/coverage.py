"""How well the strings cover the part of Ω that needs them: the unstrung bands, and why they are empty.

A point of Ω needs a family's strings where that family's curvature
|κ| is at least ``kappa_min``. Its *gap* is its distance on Ω to the nearest
string of that family (a string is its dash's polyline). With lines μ₂ apart
and dashes end to end, a point inside the pattern is at most about μ₂ / 2
across and L / 2 along from a string; a larger gap is a band left unstrung.

Each such point is classified by where its band lies:

- **edge band**: the point is closer to the mattress's edge than to any string
  of its family (its gap exceeds its distance to Ω's boundary) and its gap is
  at most L plus twice the margin. The band lies between the last string and
  the edge, where no whole dash of arc length L fits (the tracer keeps dashes ``margin`` inside the edge and cuts them only
  at length L). Shorter dashes would need Equation 3 at a shorter L, which a
  calibration made with one L does not cover, so the band stays empty and the
  pattern's notes say so.
- **weak band**: a dash of the family passes within ``limit`` of the point,
  but no string: the dash's mean κ is below ``kappa_min`` (κ is small along
  it, or changes sign: an inflection), so the length step gave it none.
- **interior gap**: anything else, a real hole in the pattern (an umbilic
  where the principal directions mean nothing, a line the tracer stopped, a
  band along the edge wide enough for a dash).

SI units inside (m); :meth:`Coverage.summary_mm` gives the design.json block (mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from airmat.geometry.polyline import points_at_fractions
from airmat.design.field import FAMILIES

__all__ = ["FamilyCoverage", "Coverage", "pattern_coverage"]

#: points per dash polyline when measuring distances to it
_SAMPLES = 61


@dataclass(frozen=True)
class FamilyCoverage:
    """One family's coverage (m).

    Attributes
    ----------
    n_need : int
        Sample points of Ω where the family's |κ| >= kappa_min.
    gap_p95, gap_max : float
        95th percentile and maximum of their distance to the nearest string of the family
        (inf when the family needs strings but has none; 0 when it needs none).
    interior_gap_max : float
        The largest gap of any other point (a hole in the pattern).
    weak_band_max : float
        The largest gap of a point near a dash that got no string (its mean κ below the threshold).
    weak_kappa : float
        The median |κ| (1/m) of the points in weak bands wider than ``limit`` (nan when none).
    edge_band_max : float
        The largest gap of a point that is closer to the edge than to any string, in a band
        too narrow for a whole dash (gap at most L + 2 margins).
    limit : float
        The gap a covered point stays within: μ₂ plus the edge margin (a band bounded by
        strings on both sides is then at most twice that wide, one along the edge once).
    """

    n_need: int
    gap_p95: float
    gap_max: float
    interior_gap_max: float
    edge_band_max: float
    limit: float
    weak_band_max: float = 0.0
    weak_kappa: float = float("nan")

    @property
    def covered(self) -> bool:
        """True when no interior point that needs the family is farther than ``limit`` from its strings."""
        return bool(self.interior_gap_max <= self.limit)


@dataclass(frozen=True)
class Coverage:
    """Coverage of both families (``families['k1' | 'k2']``) and the notes it gives.

    ``end_dashes``: the pattern cut shorter dashes from the line ends (an edge band's note then does not
    suggest them)."""

    families: dict
    L: float
    end_dashes: bool = False

    def notes(self) -> tuple:
        """One note per family with an unstrung band wider than its limit, saying why it is empty."""
        out = []
        for fam, c in self.families.items():
            if c.n_need == 0:
                continue
            if not np.isfinite(c.gap_max):
                out.append(f"{fam}: no string although {c.n_need} points of the mattress need one "
                           f"(|kappa| above the threshold)")
                continue
            if c.edge_band_max > c.limit:
                out.append(f"{fam}: a band up to {c.edge_band_max * 1e3:.0f} mm wide along the mattress edge has "
                           f"no {fam} string: no whole dash of L = {self.L * 1e3:.0f} mm fits between the last "
                           f"string and the edge, and Equation 3 is calibrated at that L only"
                           + ("" if self.end_dashes else
                              "; --end-dashes (DesignParams(end_dashes=True)) cuts shorter dashes there, which "
                              "strongly curved targets need (docs/guide/design.md)"))
            if c.weak_band_max > c.limit:
                out.append(f"{fam}: up to {c.weak_band_max * 1e3:.0f} mm from a {fam} string where |kappa| is above "
                           f"the threshold (median {c.weak_kappa:.2f} 1/m): the dashes there get no string because "
                           f"their mean kappa is below it (kappa is small or changes sign along them)")
            if c.interior_gap_max > c.limit:
                out.append(f"{fam}: an unstrung gap of {c.interior_gap_max * 1e3:.0f} mm in the pattern where "
                           f"|kappa| is above the threshold (covered points stay within {c.limit * 1e3:.0f} mm "
                           f"of a string): the tracer found no line there")
        return tuple(out)

    def summary_mm(self) -> dict:
        """The ``coverage`` block of design.json's summary (mm)."""
        def mm(x):
            return round(float(x) * 1e3, 1) if np.isfinite(x) else None
        return {fam: {"need_points": int(c.n_need), "gap_p95_mm": mm(c.gap_p95), "gap_max_mm": mm(c.gap_max),
                      "interior_gap_max_mm": mm(c.interior_gap_max), "edge_band_max_mm": mm(c.edge_band_max),
                      "weak_band_max_mm": mm(c.weak_band_max),
                      "limit_mm": mm(c.limit), "covered": c.covered}
                for fam, c in self.families.items()}


def _boundary_distance(uv, width, height) -> np.ndarray:
    return np.minimum.reduce([uv[:, 0], width - uv[:, 0], uv[:, 1], height - uv[:, 1]])


def _distance(polylines, points):
    pts = np.concatenate([points_at_fractions(np.asarray(p, float), np.linspace(0.0, 1.0, _SAMPLES))
                          for p in polylines])
    return cKDTree(pts).query(points)[0]


def _max(x, mask) -> float:
    return float(x[mask].max()) if mask.any() else 0.0


def pattern_coverage(mfield, strings, dashes, uv, *, width: float, height: float, kappa_min: float, L: float,
                     mu2: float, margin: float, end_dashes: bool = False) -> Coverage:
    """Measure how far the points of Ω that need strings lie from them.

    Parameters
    ----------
    mfield : airmat.design.field.MattressField
        The principal-curvature field on Ω.
    strings : sequence of airmat.design.pattern.TensionString
    dashes : sequence of airmat.design.stripes.Dash
        All dashes, those that got no string included.
    uv : ndarray of shape (n, 2)
        Sample points of Ω (m), e.g. Ŝ's vertices' Ω coordinates.
    width, height : float
        The mattress (m).
    kappa_min : float
        A family needs strings where its |κ| is at least this (1/m).
    L, mu2, margin : float
        Dash arc length, line spacing and edge margin of the pattern (m).
    end_dashes : bool
        The pattern has shorter end dashes (:class:`~airmat.design.stripes.StripeParams`).

    Returns
    -------
    Coverage

    Examples
    --------
    A family that needs strings everywhere with one string along the middle
    of a 0.2 m square: the far corners are an edge band, nothing is interior.

    >>> class Field:
    ...     def kappa_at(self, f, p):
    ...         return np.full(len(p), 2.0 if f == 0 else 0.0)
    >>> class Dash:
    ...     family, polyline = "k1", np.array([[0.1, 0.0], [0.1, 0.2]])
    >>> class S:
    ...     dash = Dash()
    >>> g = np.linspace(0, 0.2, 21)
    >>> uv = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    >>> c = pattern_coverage(Field(), [S()], [S.dash], uv, width=0.2, height=0.2, kappa_min=0.25, L=0.3,
    ...                      mu2=0.05, margin=0.03)
    >>> round(c.families["k1"].gap_max, 3), c.families["k1"].interior_gap_max, c.families["k2"].n_need
    (0.1, 0.0, 0)
    """
    uv = np.asarray(uv, float)
    limit = mu2 + margin
    to_edge = _boundary_distance(uv, width, height)
    fams = {}
    for f, fam in enumerate(FAMILIES):
        kap = np.abs(mfield.kappa_at(f, uv))
        need = kap >= kappa_min
        polys = [s.dash.polyline for s in strings if s.dash.family == fam]
        if not need.any():
            fams[fam] = FamilyCoverage(0, 0.0, 0.0, 0.0, 0.0, limit)
            continue
        if not polys:
            fams[fam] = FamilyCoverage(int(need.sum()), np.inf, np.inf, np.inf, np.inf, limit)
            continue
        gap = _distance(polys, uv[need])
        near_dash = _distance([d.polyline for d in dashes if d.family == fam], uv[need]) <= limit
        # an edge band: nearer the edge than any string, and too narrow for a whole dash plus the margins
        edge = (gap > to_edge[need]) & (gap <= L + 2.0 * margin)
        weak = ~edge & near_dash
        hole = ~edge & ~near_dash
        wide_weak = weak & (gap > limit)
        fams[fam] = FamilyCoverage(int(need.sum()), float(np.percentile(gap, 95)), float(gap.max()),
                                   _max(gap, hole), _max(gap, edge), limit, _max(gap, weak),
                                   float(np.median(kap[need][wide_weak])) if wide_weak.any() else float("nan"))
    return Coverage(families=fams, L=float(L), end_dashes=bool(end_dashes))
