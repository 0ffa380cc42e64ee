"""Stripes of dashes along the principal-curvature lines on Ω (paper §3.3.2).

For each family (k1, k2) the principal lines are laid out μ₂ apart
(:mod:`airmat.design.streamlines`), then each line is cut into dashes of arc length
L repeating with period μ₁ (μ₁ ≥ L). Neighbouring lines are staggered by
half a period so that the wrinkles of neighbouring strings do not line up:
a line seeded beside its parent takes the parent's dash grid, carried over
at the seed (same orientation, arc lengths matched at the seed) and shifted
by μ₁/2. Root lines centre their dashes on the part of the line inside the
margin. Only dashes entirely inside Ω shrunk by the margin are kept.

With ``end_dashes`` a line's leftover at either end (the part inside the
margin beyond its last whole dash and one gap μ₁ − L, shorter than L) gets
one shorter dash when it is at least ``L_end_min`` long and bends as much as
a whole dash at ``kappa_min`` (mean |κ| × its length >= kappa_min × L); a line with no
whole dash gets one along its longest part inside (at most L). Such a
dash's own arc length is its L in Equation 3 (:mod:`airmat.design.string_lengths`).

SI units: metres, 1/m.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from airmat.constants import PAPER_L
from airmat.errors import InputError
from airmat.geometry.polyline import interpolate_at, points_at_fractions
from airmat.design.field import FAMILIES
from airmat.design.pattern import Dash
from airmat.design.streamlines import sample_field_grid, trace_streamlines

__all__ = ["StripeParams", "FamilyStripes", "Stripes", "check_stripe_params", "trace_stripes",
           "dash_phases", "cut_dashes"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StripeParams:
    """Pattern parameters of §3.3.1 (m, 1/m).

    Attributes
    ----------
    L : float
        Arc length of a dash: geodesic spacing of a string's ends (paper: 0.30 m).
    mu1 : float
        Period of the dashes along a line, >= L (default 0.40 m).
    mu2 : float
        Spacing of neighbouring lines (default 0.10 m).
    margin : float
        Dashes stay this far inside the mattress edge (default 0.03 m).
    step : float or None
        Integration step of the lines; default min(μ₂ / 10, 0.01 m).
    kappa_min : float
        Below this |κ| (1/m) a family needs no strings: no lines are seeded there,
        and dashes below it get no string (default 0.25 1/m, where a string is
        within a few millimetres of the flat length L − 2Δ).
    weight_min : float
        Lines stop where the direction weight is below this (umbilics, where the
        principal directions mean nothing); default 0.02.
    end_dashes : bool
        Cut a shorter dash from each line end's leftover inside the margin (beyond the whole
        dashes and one gap μ₁ − L) when it is at least ``L_end_min`` long (default False:
        leftovers stay unstrung, the edge bands of :mod:`airmat.design.coverage`).
    L_end_min : float or None
        Shortest end dash (m); None: L / 2.
    """

    L: float = PAPER_L
    mu1: float = 0.40
    mu2: float = 0.10
    margin: float = 0.03
    step: float | None = None
    kappa_min: float = 0.25
    weight_min: float = 0.0
    end_dashes: bool = False
    L_end_min: float | None = None

    @property
    def L_end_min_used(self) -> float:
        """The shortest end dash (m)."""
        return 0.5 * self.L if self.L_end_min is None else self.L_end_min

    @property
    def step_used(self) -> float:
        """The integration step (m)."""
        return self.step if self.step is not None else min(self.mu2 / 10.0, 0.01)


def check_stripe_params(params: StripeParams, width: float, height: float) -> None:
    """Raise :class:`~airmat.errors.InputError` for parameters no pattern can satisfy."""
    p = params
    for name in ("L", "mu1", "mu2", "step_used"):
        value = getattr(p, name)
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be > 0 m, got {value!r}", **{name: value})
    if not (p.margin >= 0 and 2 * p.margin < min(width, height)):
        raise InputError(f"margin {p.margin * 1e3:.0f} mm must be >= 0 and leave room on a "
                         f"{width * 1e3:.0f} x {height * 1e3:.0f} mm mattress", margin=p.margin)
    if p.mu1 < p.L:
        raise InputError(f"mu1 = {p.mu1 * 1e3:.0f} mm is shorter than L = {p.L * 1e3:.0f} mm: "
                         f"dashes of one line would overlap (need mu1 >= L)", mu1=p.mu1, L=p.L)
    room = max(width, height) - 2 * p.margin
    if p.L > room:
        raise InputError(f"L = {p.L * 1e3:.0f} mm is longer than the mattress allows: "
                         f"{max(width, height) * 1e3:.0f} mm minus 2 x {p.margin * 1e3:.0f} mm margin",
                         L=p.L, room=room)
    if p.step_used > 0.5 * p.mu2:
        raise InputError(f"step {p.step_used * 1e3:.1f} mm is too coarse for mu2 = {p.mu2 * 1e3:.0f} mm "
                         f"(need step <= mu2 / 2)", step=p.step_used)
    if p.end_dashes and not (np.isfinite(p.L_end_min_used) and 0 < p.L_end_min_used <= p.L):
        raise InputError(f"the shortest end dash must be in (0, L = {p.L * 1e3:g} mm], got "
                         f"{p.L_end_min_used * 1e3:g} mm", L_end_min=p.L_end_min_used)
    if not (p.kappa_min >= 0 and p.weight_min >= 0):
        raise InputError("kappa_min and weight_min must be >= 0", kappa_min=p.kappa_min)


@dataclass(frozen=True)
class FamilyStripes:
    """Lines and dashes of one family.

    Attributes
    ----------
    family : str
        ``"k1"`` or ``"k2"``.
    lines : StreamlineSet
        All traced lines (also those too short for a dash).
    phases : ndarray of shape (n_lines,)
        Arc length (m) of the first dash start on each line, in [0, μ₁).
    dashes : tuple of Dash
    note : str
        One line on what was traced or skipped and why.
    """

    family: str
    lines: object = field(repr=False)
    phases: np.ndarray = field(repr=False)
    dashes: tuple = field(repr=False)
    note: str = ""


@dataclass(frozen=True)
class Stripes:
    """Both families' stripes (:func:`trace_stripes`)."""

    families: tuple
    params: StripeParams

    @property
    def dashes(self) -> tuple:
        """All dashes, k1 first."""
        return tuple(d for f in self.families for d in f.dashes)

    @property
    def notes(self) -> tuple:
        """The families' notes."""
        return tuple(f.note for f in self.families)


def _phases_from_roots(lines, root_phase: np.ndarray, mu1: float) -> np.ndarray:
    """Phase of every line given its root's: children shifted by μ₁/2 at their seed."""
    phases = np.zeros(len(lines))
    for i, line in enumerate(lines):
        if line.parent < 0:
            phases[i] = root_phase[i] % mu1
        else:
            phases[i] = (phases[line.parent] + line.s_seed - line.s_parent + 0.5 * mu1) % mu1
    return phases


def _roots(lines) -> np.ndarray:
    """Index of each line's root line."""
    root = np.arange(len(lines))
    for i, line in enumerate(lines):
        if line.parent >= 0:
            root[i] = root[line.parent]
    return root


def _count_kept(line, phases: np.ndarray, *, L: float, mu1: float, inside) -> np.ndarray:
    """Dashes of one line inside Ω minus the margin, for each candidate phase (T,) at once."""
    total = line.arclength[-1]
    starts = phases[:, None] + mu1 * np.arange(int(total // mu1) + 1)[None, :]      # (T, K)
    valid = starts + L <= total + 1e-9 * mu1
    ends = np.minimum(starts + L, total)
    a = interpolate_at(line.points, line.arclength, starts.ravel())
    b = interpolate_at(line.points, line.arclength, ends.ravel())
    out_s = line.arclength[~inside(line.points)]
    between = (np.searchsorted(out_s, ends, side="left") - np.searchsorted(out_s, starts, side="right"))
    ok = valid & inside(a).reshape(starts.shape) & inside(b).reshape(starts.shape) & (between == 0)
    return ok.sum(axis=1)


def dash_phases(lines, *, L: float, mu1: float, inside, n_trials: int = 16) -> np.ndarray:
    """Dash-grid phase of every line: children staggered by μ₁/2 from their parent.

    The phase of each root line (and so of its whole tree of children) is the
    one of ``n_trials`` evenly spaced candidates that keeps the most dashes
    inside; ties go to the candidate closest to centring the root's dashes on
    its part inside the margin.

    Parameters
    ----------
    lines : sequence of Streamline
        Parents before children.
    L, mu1 : float
        Dash length and period (m).
    inside : callable
        ``inside(points (k, 2)) -> bool (k,)``: within Ω minus the margin.
    n_trials : int
        Candidate root phases tried.

    Returns
    -------
    ndarray of shape (n,)
        Arc length of the first dash start, modulo μ₁ (m).
    """
    if not len(lines):
        return np.zeros(0)
    root = _roots(lines)
    centred = np.zeros(len(lines))
    for i in np.unique(root):
        line = lines[i]
        idx = np.flatnonzero(inside(line.points))
        s_in, s_out = (line.arclength[idx[0]], line.arclength[idx[-1]]) if len(idx) else (0.0, line.length)
        n = max(int(math.floor((s_out - s_in - L) / mu1)) + 1, 1)
        centred[i] = (s_in + 0.5 * (s_out - s_in - L - (n - 1) * mu1)) % mu1
    offsets = np.arange(n_trials) * mu1 / n_trials
    base = _phases_from_roots(lines, centred, mu1)
    per_line = np.array([_count_kept(line, (base[i] + offsets) % mu1, L=L, mu1=mu1, inside=inside)
                         for i, line in enumerate(lines)])   # (lines, trials)
    counts = np.stack([np.bincount(root, per_line[:, t], minlength=len(lines)) for t in range(n_trials)])
    distance = np.minimum(offsets, mu1 - offsets)            # from the centred phase
    best = np.lexsort((np.broadcast_to(distance[:, None], counts.shape), -counts), axis=0)[0]
    return _phases_from_roots(lines, centred + offsets[best][root], mu1)


def _dash_starts(total: float, *, phase: float, L: float, mu1: float) -> np.ndarray:
    """Arc lengths ``phase + k μ₁`` of the dashes of length L that fit on [0, total]."""
    tol = 1e-9 * mu1  # round-off in the arc length must not drop the last dash
    starts = phase + mu1 * np.arange(math.ceil(-phase / mu1), math.floor((total - L - phase + tol) / mu1) + 1)
    return starts[(starts >= 0) & (starts + L <= total + tol)]


def _piece(points: np.ndarray, arclength: np.ndarray, s0: float, s1: float) -> np.ndarray:
    """The sub-polyline between arc lengths s0 < s1, ends interpolated."""
    ends = interpolate_at(points, arclength, [s0, s1])
    inner = points[(arclength > s0) & (arclength < s1)]
    return np.concatenate([ends[:1], inner, ends[1:]])


def _inside_runs(line, inside, h: float):
    """Maximal arc-length intervals (s0, s1) of ``line`` inside, sampled every ``h`` (m)."""
    total = line.arclength[-1]
    s = np.linspace(0.0, total, max(int(math.ceil(total / h)) + 1, 2))
    ok = inside(interpolate_at(line.points, line.arclength, s))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(np.int8), [0]])))
    return [(s[a], s[b - 1]) for a, b in zip(edges[::2], edges[1::2])]


def end_dash_intervals(line, regular: np.ndarray, *, L: float, mu1: float, L_min: float, inside,
                       h: float = 1e-3) -> list:
    """Arc-length intervals (s0, s1) of the shorter dashes at the ends of one line.

    Parameters
    ----------
    line : Streamline
    regular : ndarray of shape (k,)
        Starts (m) of the line's whole dashes kept (sorted).
    L, mu1 : float
        Dash length and period (m).
    L_min : float
        Shortest end dash (m).
    inside : callable
        ``inside(points (k, 2)) -> bool (k,)``: within Ω minus the margin.
    h : float
        Arc-length sampling of the inside test (m).

    Returns
    -------
    list of (float, float)
        Each at least ``L_min`` and at most L long; before the first whole dash (ending one gap
        μ₁ − L before it), after the last, or, on a line without whole dashes, along its longest
        part inside.
    """
    runs = _inside_runs(line, inside, h)
    if not runs:
        return []
    gap = mu1 - L
    out = []
    if not len(regular):
        s0, s1 = max(runs, key=lambda r: r[1] - r[0])
        if s1 - s0 >= L_min:
            c, half = 0.5 * (s0 + s1), 0.5 * min(L, s1 - s0)
            out.append((c - half, c + half))
        return out
    head_end, tail_start = regular[0] - gap, regular[-1] + L + gap
    for s0, s1 in runs:
        # the run the leftover lies in (up to one sample step h of round-off at its ends)
        if s0 - h <= head_end <= s1 + h and head_end - s0 >= L_min:
            out.append((max(s0, head_end - L), head_end))
        if s0 - h <= tail_start <= s1 + h and s1 - tail_start >= L_min:
            out.append((tail_start, min(s1, tail_start + L)))
    return out


def cut_dashes(points: np.ndarray, arclength: np.ndarray, *, phase: float, L: float, mu1: float):
    """Pieces of arc length L starting at ``phase + k μ₁`` that fit on a polyline.

    Parameters
    ----------
    points : ndarray of shape (k, 2)
    arclength : ndarray of shape (k,)
        Cumulative arc length of ``points`` (m).
    phase, L, mu1 : float
        Dash grid (m).

    Returns
    -------
    list of ndarray of shape (m, 2)
        Sub-polylines with interpolated ends; each has arc length L exactly.
    """
    total = arclength[-1]
    return [_piece(points, arclength, s0, min(s0 + L, total))
            for s0 in _dash_starts(total, phase=phase, L=L, mu1=mu1)]


def _line_order(lines, keep: list[int]) -> list[int]:
    """Workshop numbering: lines running mostly along u are numbered by v, others by u."""
    if not keep:
        return []
    along_u = np.mean([abs(lines[i].points[-1, 0] - lines[i].points[0, 0]) >=
                       abs(lines[i].points[-1, 1] - lines[i].points[0, 1]) for i in keep]) >= 0.5
    mid = np.array([interpolate_at(lines[i].points, lines[i].arclength, [0.5 * lines[i].length])[0]
                    for i in keep])
    primary, secondary = (mid[:, 1], mid[:, 0]) if along_u else (mid[:, 0], mid[:, 1])
    order = np.lexsort((secondary, np.round(primary, 9)))
    return [keep[k] for k in order]


def _family_stripes(mfield, family: int, params: StripeParams) -> FamilyStripes:
    name = FAMILIES[family]
    step, p = params.step_used, params
    grid = sample_field_grid(mfield, family, spacing=step)

    def inside(pts):
        return mfield.contains(pts, p.margin)

    lines = trace_streamlines(grid, separation=p.mu2, step=step, seed_margin=p.margin,
                              kappa_min=p.kappa_min, weight_min=p.weight_min)
    phases = dash_phases(lines.lines, L=p.L, mu1=p.mu1, inside=inside)
    pieces, n_end = {}, 0
    for i, line in enumerate(lines.lines):
        total = line.arclength[-1]
        starts = _dash_starts(total, phase=phases[i], L=p.L, mu1=p.mu1)
        cut = [(s0, _piece(line.points, line.arclength, s0, min(s0 + p.L, total))) for s0 in starts]
        cut = [(s0, d) for s0, d in cut if np.all(inside(d))]
        if p.end_dashes:
            kept = np.array([s0 for s0, _ in cut])
            for s0, s1 in end_dash_intervals(line, kept, L=p.L, mu1=p.mu1, L_min=p.L_end_min_used, inside=inside):
                d = _piece(line.points, line.arclength, s0, s1)
                # the bend it is cut for, |κ| × its length, at least a whole dash's at kappa_min: a shorter
                # dash of a weakly curved family would shorten its face less than the threshold means
                kappa = mfield.kappa_at(family, points_at_fractions(d, np.linspace(0.0, 1.0, 10))).mean()
                chord = float(np.linalg.norm(d[-1] - d[0]))  # the string spans its chord: at least the minimum
                if np.all(inside(d)) and abs(kappa) * (s1 - s0) >= p.kappa_min * p.L and chord >= p.L_end_min_used:
                    cut.append((s0, d))
                    n_end += 1
            cut.sort(key=lambda c: c[0])
        if cut:
            pieces[i] = [d for _, d in cut]
    dashes = []
    for number, i in enumerate(_line_order(lines.lines, sorted(pieces)), start=1):
        for k, poly in enumerate(pieces[i], start=1):
            dashes.append(Dash(id=f"{name}-{number:03d}-{k:02d}", family=name, line=number, index=k,
                               polyline=poly, length=float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))))
    kmax = float(np.nanmax(np.abs(grid.values[0]))) if np.any(np.isfinite(grid.values[0])) else 0.0
    if not lines.lines:
        note = (f"{name}: no lines: |kappa| < {p.kappa_min:g} 1/m everywhere (max {kmax:.3g} 1/m) "
                f"or no usable direction: this family needs no strings")
    else:
        stops = ", ".join(f"{k} {v}" for k, v in lines.stop_counts.items())
        note = (f"{name}: {len(lines.lines)} lines ({lines.n_roots} from fallback seeds), "
                f"{len(pieces)} with dashes, {len(dashes)} dashes"
                + (f" ({n_end} shorter end dashes, >= {p.L_end_min_used * 1e3:.0f} mm)" if p.end_dashes else "")
                + f"; line ends: {stops}")
        if lines.stop_counts.get("low_weight"):
            note += (f"; {lines.stop_counts['low_weight']} line ends stopped at umbilics (direction weight "
                     f"< {p.weight_min:g}): no strings of this family there")
    log.info(note)
    return FamilyStripes(name, lines, phases, tuple(dashes), note)


def trace_stripes(mfield, params: StripeParams = StripeParams()) -> Stripes:
    """Lay out the dashes of both families on Ω.

    Parameters
    ----------
    mfield : MattressField
        Principal curvature field on Ω (m, 1/m).
    params : StripeParams
        L, μ₁, μ₂, margin, step, kappa_min, weight_min (m, 1/m).

    Returns
    -------
    Stripes
        ``families[0]`` is k1, ``families[1]`` k2; each with its lines, dash
        phases, dashes (ids ``k1-003-02``) and a note on what was skipped.

    Raises
    ------
    airmat.errors.InputError
        For impossible parameters: μ₁ < L, L longer than the mattress, μ₂ <= 0, ...
    """
    check_stripe_params(params, mfield.width, mfield.height)
    return Stripes(tuple(_family_stripes(mfield, f, params) for f in range(len(FAMILIES))), params)
