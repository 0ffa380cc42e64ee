"""Evenly spaced streamlines of a line field on Ω (Jobard & Lefer 1997).

Principal-curvature lines are integral curves of a *line* field (a direction
without a sign). :func:`trace_streamlines` lays them out d_sep apart:

- a line is integrated with fixed-step RK2 (midpoint) in both directions
  from its seed, each interpolated direction flipped to agree with the
  previous step; it stops when it leaves Ω, comes closer than
  ``d_test = test_ratio * d_sep`` to another line (or to itself: closed
  lines), reaches a singularity of the line field or a region where the
  direction weight is below ``weight_min``;
- new seeds are placed d_sep beside every accepted line, on both sides, and
  traced when they are at least ``seed_ratio * d_sep`` from every line;
- when no candidate is left, a regular grid of fallback seeds d_sep apart,
  taken from the centre of Ω outwards, starts new lines in regions not
  reached yet.

Seeds are only placed where the family's |κ| is at least ``kappa_min``
(elsewhere the family needs no strings); lines may run on through such
regions. The field is first resampled in one batch onto a regular grid over
Ω (:func:`sample_field_grid`), so each integration step is a single
``scipy.ndimage.map_coordinates`` call. Distances to other lines come from
a ``scipy.spatial.cKDTree`` of their points. SI units: metres, 1/m.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import map_coordinates
from scipy.spatial import cKDTree

from airmat.geometry.polyline import arc_length, interpolate_at

__all__ = ["FieldGrid", "Streamline", "StreamlineSet", "sample_field_grid", "grid_values",
           "trace_streamlines"]

_KAPPA, _C2, _S2, _WEIGHT = range(4)


@dataclass(frozen=True)
class FieldGrid:
    """One family's field on a regular grid over Ω = [0, W] × [0, H].

    Attributes
    ----------
    width, height : float
        W and H (m).
    du, dv : float
        Grid spacing along u and v (m).
    values : ndarray of shape (4, nv, nu)
        Channels: signed κ (1/m), cos 2φ, sin 2φ (the doubled-angle line
        direction) and the direction weight; NaN outside the field's samples.
    """

    width: float
    height: float
    du: float
    dv: float
    values: np.ndarray = field(repr=False)


def sample_field_grid(mfield, family: int, *, spacing: float) -> FieldGrid:
    """Resample family ``family`` of a :class:`~airmat.design.field.MattressField` on a grid.

    Parameters
    ----------
    mfield : MattressField
    family : int
        0 for k1, 1 for k2.
    spacing : float
        Largest grid spacing (m); the grid has nodes on all four sides of Ω.
    """
    W, H = float(mfield.width), float(mfield.height)
    nu, nv = int(math.ceil(W / spacing)) + 1, int(math.ceil(H / spacing)) + 1
    u, v = np.linspace(0.0, W, nu), np.linspace(0.0, H, nv)
    pts = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    kappa = mfield.kappa_at(family, pts)
    d = mfield.direction_at(family, pts)
    c2, s2 = d[:, 0] ** 2 - d[:, 1] ** 2, 2.0 * d[:, 0] * d[:, 1]
    weight = mfield.weight_at(pts)
    values = np.stack([kappa, c2, s2, weight]).reshape(4, nv, nu)
    return FieldGrid(W, H, W / (nu - 1), H / (nv - 1), values)


def grid_values(grid: FieldGrid, pts) -> np.ndarray:
    """Bilinear values (k, 4) of the grid channels at points (k, 2) on Ω (m)."""
    p = np.asarray(pts, dtype=float).reshape(-1, 2)
    k = len(p)
    coords = np.empty((3, 4 * k))
    coords[0] = np.repeat(np.arange(4), k)
    coords[1] = np.tile(p[:, 1] / grid.dv, 4)
    coords[2] = np.tile(p[:, 0] / grid.du, 4)
    return map_coordinates(grid.values, coords, order=1, mode="nearest").reshape(4, k).T


@dataclass(frozen=True)
class Streamline:
    """One traced line.

    Attributes
    ----------
    points : ndarray of shape (k, 2)
        Polyline on Ω (m), ``step`` apart.
    arclength : ndarray of shape (k,)
        Cumulative arc length (m), 0 at ``points[0]``.
    parent : int
        Index of the line it was seeded beside, -1 for a root line.
    s_parent, s_seed : float
        Arc length (m) on the parent where the seed was placed, and of the seed on this line;
        the line is oriented like its parent there.
    stops : tuple of str
        Why the line ended at its start and at its end.
    """

    points: np.ndarray = field(repr=False)
    arclength: np.ndarray = field(repr=False)
    parent: int
    s_parent: float
    s_seed: float
    stops: tuple

    @property
    def length(self) -> float:
        """Total arc length (m)."""
        return float(self.arclength[-1])


@dataclass(frozen=True)
class StreamlineSet:
    """Result of :func:`trace_streamlines`.

    Attributes
    ----------
    lines : tuple of Streamline
        In creation order (a parent always precedes its children).
    stop_counts : dict
        How many line ends stopped for each reason (``boundary``, ``near_line``,
        ``self``, ``singular``, ``low_weight``, ``max_length``).
    n_roots : int
        Lines started from fallback seeds.
    """

    lines: tuple
    stop_counts: dict
    n_roots: int


def _value1(grid: FieldGrid, u: float, v: float) -> np.ndarray:
    """Bilinear channel values (4,) at one point (the per-step hot path of the tracer)."""
    iu, iv = u / grid.du, v / grid.dv
    coords = np.array([[0.0, 1.0, 2.0, 3.0], [iv, iv, iv, iv], [iu, iu, iu, iu]])
    return map_coordinates(grid.values, coords, order=1, mode="nearest")


def _direction(vals, prev):
    """Unit direction from doubled-angle values, oriented like ``prev``."""
    half = 0.5 * math.atan2(vals[_S2], vals[_C2])
    du, dv = math.cos(half), math.sin(half)
    if du * prev[0] + dv * prev[1] < 0.0:
        du, dv = -du, -dv
    return du, dv


def _field_stop(vals, opts) -> str | None:
    """Reason the field is unusable at a point, or None."""
    k, c2, s2, w = (float(x) for x in vals)
    if not (math.isfinite(k) and math.isfinite(c2) and math.isfinite(s2) and math.isfinite(w)):
        return "boundary"
    if w < opts["weight_min"]:
        return "low_weight"
    if math.hypot(c2, s2) < opts["singular_tol"]:
        return "singular"
    return None


def _too_close(q, pts, d2) -> bool:
    return len(pts) > 0 and float(np.min(np.einsum("ij,ij->i", pts - q, pts - q))) < d2


def _trace_half(grid, seed, d0, tree, prior, opts):
    """Integrate from ``seed`` along ``d0``; returns (points (k, 2) incl. seed, stop reason)."""
    h, W, H, n_max = opts["step"], grid.width, grid.height, opts["max_steps"]
    pts = np.empty((n_max + 1, 2))
    pts[0] = seed
    prior_pts, prior_s = prior
    n_guard, d_test, d_test2 = int(opts["guard"] / h), opts["d_test"], opts["d_test"] ** 2
    prev, n, reason = d0, 1, "max_length"
    while n <= n_max:
        pu, pv = pts[n - 1]
        v1 = _value1(grid, pu, pv)
        if n > 1 and (stop := _field_stop(v1, opts)):
            n, reason = n - 1, stop  # the last point is unusable: drop it
            break
        k1 = _direction(v1, prev)
        k2 = _direction(_value1(grid, pu + 0.5 * h * k1[0], pv + 0.5 * h * k1[1]), k1)
        q = np.array([pu + h * k2[0], pv + h * k2[1]])
        if not (0.0 <= q[0] <= W and 0.0 <= q[1] <= H):
            reason = "boundary"
            break
        if tree is not None and tree.query(q, distance_upper_bound=d_test)[0] < d_test:
            reason = "near_line"
            break
        if _too_close(q, pts[:max(n - n_guard, 0)], d_test2) or \
                _too_close(q, prior_pts[n * h + prior_s > opts["guard"]], d_test2):
            reason = "self"
            break
        pts[n] = q
        prev, n = k2, n + 1
    return pts[:n].copy(), reason


def _trace_line(grid, seed, d0, tree, opts):
    """Both halves from ``seed`` (d0 sets the orientation); points ordered along d0."""
    back, stop_b = _trace_half(grid, seed, (-d0[0], -d0[1]), tree, (np.empty((0, 2)), np.empty(0)), opts)
    s_back = np.arange(len(back)) * opts["step"]
    fwd, stop_f = _trace_half(grid, seed, d0, tree, (back, s_back), opts)
    pts = np.concatenate([back[::-1], fwd[1:]])
    arc = arc_length(pts)
    return pts, arc, float(arc[len(back) - 1]), (stop_b, stop_f)


def _candidates(line: Streamline, sep: float, every: float) -> tuple[np.ndarray, np.ndarray]:
    """Seeds ``sep`` beside the line on both sides, every ``every`` of arc length: (points, s on line)."""
    s = np.arange(0.0, line.length + 1e-12, every)
    base = interpolate_at(line.points, line.arclength, s)
    tangent = interpolate_at(np.gradient(line.points, axis=0), line.arclength, s)
    tu, tv = tangent[:, 0], tangent[:, 1]
    norm = np.hypot(tu, tv)
    normal = np.stack([-tv, tu], axis=1) / norm[:, None]
    pts = np.stack([base + sep * normal, base - sep * normal], axis=1).reshape(-1, 2)
    return pts, np.repeat(s, 2)


def _seed_ok(grid, pts, opts) -> np.ndarray:
    """Vectorized pre-check of candidate seeds: inside Ω minus the margin, field usable, |κ| large enough."""
    m, W, H = opts["seed_margin"], grid.width, grid.height
    inside = (pts[:, 0] >= m) & (pts[:, 0] <= W - m) & (pts[:, 1] >= m) & (pts[:, 1] <= H - m)
    vals = grid_values(grid, pts)
    with np.errstate(invalid="ignore"):
        ok = (np.all(np.isfinite(vals), axis=1) & (np.abs(vals[:, _KAPPA]) >= opts["kappa_min"])
              & (vals[:, _WEIGHT] >= opts["weight_min"])
              & (np.hypot(vals[:, _C2], vals[:, _S2]) >= opts["singular_tol"]))
    return inside & ok


def _root_direction(vals):
    """Root lines point along +u when mostly horizontal, +v when mostly vertical (dashes read a -> b)."""
    du, dv = _direction(vals, (1.0, 0.0))
    if abs(dv) > abs(du) and dv < 0:
        du, dv = -du, -dv
    return du, dv


def _fallback_seeds(grid, sep: float, margin: float) -> np.ndarray:
    """Regular grid of seeds ``sep`` apart inside Ω minus the margin, from the centre outwards."""
    W, H = grid.width, grid.height
    nu, nv = max(int((W - 2 * margin) / sep), 0), max(int((H - 2 * margin) / sep), 0)
    u = W / 2 + sep * (np.arange(nu + 1) - nu / 2)
    v = H / 2 + sep * (np.arange(nv + 1) - nv / 2)
    pts = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    r = np.hypot(pts[:, 0] - W / 2, pts[:, 1] - H / 2)
    return pts[np.lexsort((pts[:, 1], pts[:, 0], np.round(r / sep, 6)))]


class _Tracer:
    """The growing set of lines and the tree of their points (real state: lines are added one by one)."""

    def __init__(self, grid, opts):
        self.grid, self.opts = grid, opts
        self.lines: list[Streamline] = []
        self.tree = None
        self._pts: list[np.ndarray] = []

    def far_from_lines(self, p, dist) -> bool:
        return self.tree is None or not np.isfinite(self.tree.query(p, distance_upper_bound=dist)[0])

    def add(self, seed, d0, parent=-1, s_parent=0.0) -> int | None:
        pts, arc, s_seed, stops = _trace_line(self.grid, seed, d0, self.tree, self.opts)
        if len(pts) < 2:
            return None
        self.lines.append(Streamline(pts, arc, parent, float(s_parent), s_seed, stops))
        self._pts.append(pts)
        self.tree = cKDTree(np.concatenate(self._pts))
        return len(self.lines) - 1

    def grow(self, first: int) -> None:
        """Breadth-first: seed beside every line from ``first`` on, including lines added meanwhile."""
        i, o = first, self.opts
        while i < len(self.lines):
            line = self.lines[i]
            cand, s_on = _candidates(line, o["separation"], o["candidate_every"])
            ok = _seed_ok(self.grid, cand, o)
            tangent = np.gradient(line.points, axis=0)
            for p, s in zip(cand[ok], s_on[ok]):
                if not self.far_from_lines(p, o["seed_ratio"] * o["separation"]):
                    continue
                t = (np.interp(s, line.arclength, tangent[:, 0]), np.interp(s, line.arclength, tangent[:, 1]))
                d0 = _direction(grid_values(self.grid, p)[0], t)
                self.add(p, d0, parent=i, s_parent=s)
            i += 1


def trace_streamlines(grid: FieldGrid, *, separation: float, step: float, seed_margin: float = 0.0,
                      kappa_min: float = 0.0, weight_min: float = 0.0, test_ratio: float = 0.5,
                      seed_ratio: float = 0.95, singular_tol: float = 0.5) -> StreamlineSet:
    """Evenly spaced streamlines of a grid line field (Jobard–Lefer).

    Parameters
    ----------
    grid : FieldGrid
        The family's field on Ω (:func:`sample_field_grid`).
    separation : float
        d_sep, the spacing of neighbouring lines (m).
    step : float
        Integration step (m), well below ``separation``.
    seed_margin : float
        Seeds lie at least this far inside Ω (m).
    kappa_min : float
        Seeds need |κ| >= kappa_min (1/m).
    weight_min : float
        Lines stop, and seeds are refused, where the direction weight is below this.
    test_ratio : float
        A line stops closer than ``test_ratio * separation`` to another line.
    seed_ratio : float
        A seed is traced only when at least ``seed_ratio * separation`` from every line.
    singular_tol : float
        Lines stop where the bilinear doubled-angle vector is shorter than this
        (neighbouring grid directions disagree: a singularity of the line field).

    Returns
    -------
    StreamlineSet
    """
    W, H = grid.width, grid.height
    d_test = test_ratio * separation
    opts = dict(step=step, separation=separation, d_test=d_test, guard=3.0 * d_test,
                seed_ratio=seed_ratio, seed_margin=seed_margin, kappa_min=kappa_min,
                weight_min=weight_min, singular_tol=singular_tol, candidate_every=0.25 * separation,
                max_steps=int(math.ceil(4.0 * (W + H) / step)))
    tracer = _Tracer(grid, opts)
    seeds = _fallback_seeds(grid, separation, seed_margin)
    ok = _seed_ok(grid, seeds, opts) if len(seeds) else np.zeros(0, bool)
    n_roots = 0
    for p in seeds[ok]:
        if not tracer.far_from_lines(p, separation):
            continue
        first = tracer.add(p, _root_direction(grid_values(grid, p)[0]))
        if first is not None:
            n_roots += 1
            tracer.grow(first)
    stops = Counter(s for line in tracer.lines for s in line.stops)
    return StreamlineSet(tuple(tracer.lines), dict(sorted(stops.items())), n_roots)
