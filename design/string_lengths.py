"""String lengths with tolerances from the calibration posterior (paper §3.3.3).

Each dash gets a representative curvature, the mean of its family's field at
N equally spaced points along it (ends included). Its sign picks the face
(κ < 0 → ``top``, κ > 0 → ``bottom``: the string goes on the concave face,
CONTRIBUTING.md), its magnitude the length through Equation 3,
l = string_length(|κ|, L, Δ, d), evaluated for every posterior sample of
(Δ, d) in one vectorized call; the median is the length to cut and the
2.5–97.5 % interval its tolerance.

- A dash with |κ| below ``kappa_min`` (or κ = 0, where l would be the flat
  length L − 2Δ) gets no string; it is counted, not emitted.
- Where a posterior sample cannot reach |κ| even with l = 0 (|κ| > kappa_max
  of that sample), that sample's l is clipped to 0; when more than 2.5 % of
  the samples are clipped the string is flagged ``beyond_reach`` (its lo95,
  perhaps its median, is 0).
- A dash whose chord is much shorter than its arc length (a line curving
  strongly on Ω) is flagged ``curved``: the string pulls along the chord.
  One whose chord is below half its arc length (a line curling on Ω, as
  principal lines do in a folded Ŝ) gets no string: its two ties are not
  a span Equation 3 speaks of. It is counted and named in a note.
- Given Ŝ, Equation 3's span is the string's free face's length between the
  ties on Ŝ, at most the dash's length (:mod:`airmat.design.free_face`), not the dash's
  length on Ω: where Ŝ compresses that face, the string is shorter.

SI units: metres, 1/m.
"""

from __future__ import annotations

import logging

import numpy as np

from airmat.geometry.polyline import points_at_fractions
from airmat.calib.model import flat_length, kappa_max, string_length
from airmat.design.face_metric import strings_named_face
from airmat.design.field import FAMILIES
from airmat.design.free_face import free_face_ratio
from airmat.design.pattern import Pattern, TensionString

__all__ = ["dash_kappa", "length_quantiles", "string_pattern", "CURL_NOTE", "CURL_CHORD_RATIO"]

log = logging.getLogger(__name__)

#: a dash whose chord is shorter than this fraction of its arc length is flagged "curved"
CURVED_CHORD_RATIO = 0.95
#: a dash whose chord is shorter than this fraction of its arc length gets no string (a semicircle's is 2/π = 0.64)
CURL_CHORD_RATIO = 0.5
#: the words of the pattern's note on curled dashes (the command's summary and the report find it by them)
CURL_NOTE = "dashes curl on the mattress"


def dash_kappa(mfield, dashes, *, n_points: int = 10) -> np.ndarray:
    """Representative signed curvature (1/m) of each dash.

    Parameters
    ----------
    mfield : MattressField
    dashes : sequence of Dash
    n_points : int
        Number of equally spaced points along each dash, ends included (>= 2).

    Returns
    -------
    ndarray of shape (len(dashes),)
        Mean of the dash's family curvature at those points (1/m), all dashes
        in one batched field evaluation per family.
    """
    n_points = int(n_points)
    if n_points < 2:
        raise ValueError(f"n_points must be >= 2, got {n_points}")
    out = np.zeros(len(dashes))
    t = np.linspace(0.0, 1.0, n_points)
    for f, name in enumerate(FAMILIES):
        idx = [i for i, d in enumerate(dashes) if d.family == name]
        if not idx:
            continue
        pts = np.concatenate([points_at_fractions(dashes[i].polyline, t) for i in idx])
        out[idx] = mfield.kappa_at(f, pts).reshape(len(idx), n_points).mean(axis=1)
    return out


def length_quantiles(kappa_abs, L: float, delta, d):
    """String-length median and 95 % interval over posterior samples, clipping the unreachable.

    Parameters
    ----------
    kappa_abs : ndarray of shape (n,)
        |κ| of each string (1/m).
    L : float or ndarray of shape (n,)
        Geodesic spacing of the string's ends (m), one for all or one per string.
    delta, d : ndarray of shape (s,)
        Posterior samples of Δ and d (m).

    Returns
    -------
    quantiles : ndarray of shape (3, n)
        Rows: median, lo95, hi95 of l (m).
    unreachable : ndarray of shape (n,)
        Fraction of samples whose kappa_max is below |κ| (clipped to l = 0).
    """
    kappa_abs = np.asarray(kappa_abs, dtype=float)[:, None]
    L = np.asarray(L, float).reshape(-1, 1) if np.ndim(L) else float(L)
    delta, d = np.asarray(delta, float)[None, :], np.asarray(d, float)[None, :]
    kmax = kappa_max(L, delta, d)                       # (1, s): per-sample reach
    over = kappa_abs > kmax
    l = string_length(np.minimum(kappa_abs, kmax), L, delta, d)  # (n, s), one vectorized call
    l = np.where(over, 0.0, l)
    q = np.percentile(l, [50.0, 2.5, 97.5], axis=1)
    return q, over.mean(axis=1)


def string_pattern(mfield, dashes, calibration, *, L: float, n_points: int = 10,
                   kappa_min: float = 0.25, notes=(), tie_grid=None, approx=None) -> Pattern:
    """Turn dashes into tension strings: face, length and tolerance.

    Parameters
    ----------
    mfield : MattressField
    dashes : sequence of Dash
        From :func:`airmat.design.stripes.trace_stripes` (arc length ``L``).
    calibration : CalibrationSource
        Posterior samples of Δ and d (m).
    L : float
        Geodesic spacing of string ends (m).
    n_points : int
        Field samples per dash for its representative κ.
    kappa_min : float
        Dashes with |κ| below this (1/m) get no string.
    notes : sequence of str
        Carried into the pattern (e.g. the stripe tracer's notes).
    tie_grid : airmat.design.tie_grid.TieGridReport, optional
        When the dashes' ends were snapped to the mattress's grid: each string's
        length then comes from Equation 3 at its own dash's L (``dash.length``),
        not at ``L``; the report is kept in the pattern. Without it the whole dashes
        take ``L`` and a shorter one (a line end's) its own length.
    approx : airmat.design.surface.ApproxSurface, optional
        Ŝ: Equation 3 is then evaluated at each string's free-face span on it,
        min(c, 1) times the dash's span (:func:`airmat.design.free_face.free_face_ratio`, with
        the named face of :func:`airmat.design.face_metric.strings_named_face`); None: at the dash's span.

    Returns
    -------
    Pattern
    """
    kappa = dash_kappa(mfield, dashes, n_points=n_points)
    snapped = tie_grid is not None and tie_grid.grid > 0
    own = np.array([d.length for d in dashes], float).reshape(-1)
    # free ends: the whole dashes at L exactly; a shorter dash (a line end's, StripeParams.end_dashes) at its own
    spans = own if snapped else np.where(own < float(L) * (1.0 - 1e-6), own, float(L))
    med_flat = flat_length(spans, np.median(calibration.delta))
    need = np.abs(kappa) >= max(kappa_min, 0.0)
    need &= np.abs(kappa) > 0
    curled = need & (np.array([d.chord for d in dashes], float).reshape(-1) < CURL_CHORD_RATIO * own)
    need &= ~curled
    strings, n_no = [], {name: 0 for name in FAMILIES}
    idx_need = np.flatnonzero(need)
    eq3_spans = spans.copy()
    if approx is not None and len(idx_need):
        sides = np.where(kappa[idx_need] < 0, "top", "bottom")
        share = np.abs(kappa[idx_need]) * np.array([dashes[i].chord for i in idx_need])
        named = strings_named_face(approx.report, share, sides == "top")
        c = free_face_ratio(approx.xyz, approx.uv, approx.faces, [dashes[i].polyline for i in idx_need], sides,
                            named=named, thickness=approx.mattress.thickness)
        eq3_spans[idx_need] = np.minimum(c, 1.0) * spans[idx_need]
    if len(idx_need):
        q, unreachable = length_quantiles(np.abs(kappa[need]), eq3_spans[need], calibration.delta, calibration.d)
    for j, i in enumerate(idx_need):
        dash = dashes[i]
        if q[0, j] >= med_flat[i]:  # numerically flat: no string
            need[i] = False
            continue
        flags = []
        if unreachable[j] > 0.025:
            flags.append("beyond_reach")
        if dash.chord < CURVED_CHORD_RATIO * dash.length:
            flags.append("curved")
        strings.append(TensionString(dash=dash, kappa=float(kappa[i]),
                                     side="top" if kappa[i] < 0 else "bottom",
                                     l_median=float(q[0, j]), l_lo95=float(q[1, j]), l_hi95=float(q[2, j]),
                                     flags=tuple(flags),
                                     free_span=None if approx is None else float(eq3_spans[i])))
    for i in np.flatnonzero(~need & ~curled):       # a curled dash is not one whose |κ| is too small
        n_no[dashes[i].family] += 1
    n_dashes = {name: sum(1 for d in dashes if d.family == name) for name in FAMILIES}
    extra = [f"{name}: {n_no[name]} of {n_dashes[name]} dashes need no string (|kappa| < {kappa_min:g} 1/m)"
             for name in FAMILIES if n_no[name]]
    if curled.any():
        ids = [d.id for d, c in zip(dashes, curled) if c]
        extra.append(f"{len(ids)} {CURL_NOTE} (chord below {CURL_CHORD_RATIO:g} of their length: "
                     f"{', '.join(ids[:5])}{' …' if len(ids) > 5 else ''}): no string")
        log.warning(extra[-1])
    n_beyond = sum("beyond_reach" in s.flags for s in strings)
    if n_beyond:
        extra.append(f"{n_beyond} strings are beyond reach of the calibration (l clipped to 0 for the "
                     f"posterior samples that cannot reach their curvature)")
        log.warning(extra[-1])
    return Pattern(strings=tuple(strings), L=float(L), n_dashes=n_dashes, n_no_string=n_no,
                   notes=tuple(notes) + tuple(extra), tie_grid=tie_grid)

