"""Strings tied to the mattress's grid: each dash's ends snapped to grid nodes (paper §2.1).

The mattress carries a square grid mesh of pitch g on its faces (20 mm in the
paper) and strings are tied to its nodes. Node (row, col) sits at
(u, v) = (col · g, row · g) on Ω, rows and columns counted from 0 at Ω's
origin, the same on both faces (the bottom face is seen from above, as in
design.json). Each end moves to its nearest node inside the mattress; the
dash's interior follows the two ends' displacements blended linearly in arc
length, and its length L is recomputed on the new polyline. Two dashes that
share an end share its node. SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from airmat.errors import InputError

__all__ = ["TieGridReport", "snap_dashes", "grid_node"]


@dataclass(frozen=True)
class TieGridReport:
    """How much snapping to the grid moved the dashes.

    Attributes
    ----------
    grid : float
        Grid pitch g (m); 0 when the ends are free.
    end_shift : ndarray of shape (n, 2)
        Distance each dash's ends a, b moved (m).
    length_change : ndarray of shape (n,)
        L after minus L before, per dash (m).
    """

    grid: float
    end_shift: np.ndarray = field(repr=False)
    length_change: np.ndarray = field(repr=False)

    def summary_mm(self) -> dict:
        """``{grid_mm, end_shift_mm {mean, max}, dL_mm {mean, max_abs}}`` for design.json (mm)."""
        s, dl = self.end_shift * 1e3, self.length_change * 1e3
        return {"grid_mm": round(self.grid * 1e3, 3),
                "end_shift_mm": {"mean": round(float(s.mean()), 2) if s.size else 0.0,
                                 "max": round(float(s.max()), 2) if s.size else 0.0},
                "dL_mm": {"mean": round(float(dl.mean()), 2) if dl.size else 0.0,
                          "max_abs": round(float(np.abs(dl).max()), 2) if dl.size else 0.0}}


def grid_node(points: np.ndarray, grid: float, width: float, height: float) -> np.ndarray:
    """Nearest grid node inside the mattress of each point.

    Parameters
    ----------
    points : ndarray of shape (k, 2)
        Points on Ω (m).
    grid : float
        Pitch g > 0 (m).
    width, height : float
        Ω's size (m).

    Returns
    -------
    ndarray of shape (k, 2), int
        (row, col) of the node; it sits at (col · g, row · g).

    Examples
    --------
    >>> grid_node(np.array([[0.031, 0.009], [0.829, 0.74]]), 0.02, 0.83, 0.74).tolist()
    [[0, 2], [37, 41]]
    """
    if not grid > 0:
        raise InputError(f"the tie grid pitch must be > 0, got {grid!r}")
    points = np.asarray(points, float).reshape(-1, 2)
    # nodes at most (1e-9 g) beyond the edge count as inside: 740 / 20 is 37 rows up to rounding
    n_col, n_row = np.floor(np.array([width, height]) / grid + 1e-9).astype(int)
    col = np.clip(np.rint(points[:, 0] / grid), 0, n_col).astype(int)
    row = np.clip(np.rint(points[:, 1] / grid), 0, n_row).astype(int)
    return np.column_stack([row, col])


def _arc_fraction(polys: list, counts: np.ndarray) -> np.ndarray:
    """Arc-length fraction t in [0, 1] of every point of the concatenated polylines."""
    pts = np.concatenate(polys)
    owner = np.repeat(np.arange(len(polys)), counts)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    starts = np.cumsum(counts) - counts
    seg = np.concatenate([[0.0], seg])
    seg[starts] = 0.0                                     # no segment across two dashes
    s = np.cumsum(seg)
    s -= s[starts][owner]
    total = s[np.cumsum(counts) - 1][owner]
    return np.divide(s, total, out=np.zeros_like(s), where=total > 0)


def snap_dashes(dashes, *, grid: float, width: float, height: float):
    """Snap each dash's two ends to the nearest grid nodes; L recomputed on the moved polyline.

    Parameters
    ----------
    dashes : sequence of Dash
    grid : float
        Pitch g (m); 0 keeps the ends free (dashes returned unchanged).
    width, height : float
        Ω's size (m).

    Returns
    -------
    dashes : tuple of Dash
        With ``a_node``/``b_node`` (row, col) set and ``length`` the arc length of the new polyline.
    report : TieGridReport

    Examples
    --------
    >>> from airmat.design.pattern import Dash
    >>> d = Dash("k1-001-01", "k1", 1, 1, np.array([[0.101, 0.203], [0.399, 0.207]]), 0.298)
    >>> (s,), rep = snap_dashes([d], grid=0.02, width=0.83, height=0.74)
    >>> s.polyline.round(6).tolist(), s.a_node, s.b_node, round(s.length, 6)
    ([[0.1, 0.2], [0.4, 0.2]], (10, 5), (10, 20), 0.3)
    """
    dashes = tuple(dashes)
    if grid == 0 or not dashes:
        return dashes, TieGridReport(float(grid), np.zeros((len(dashes), 2)), np.zeros(len(dashes)))
    if not grid > 0:
        raise InputError(f"--tie-grid-mm must be >= 0 (0: free ends), got {grid * 1e3!r}")
    polys = [d.polyline for d in dashes]
    counts = np.array([len(p) for p in polys])
    ends = np.stack([np.array([p[0] for p in polys]), np.array([p[-1] for p in polys])], axis=1)  # (n, 2, 2)
    nodes = grid_node(ends.reshape(-1, 2), grid, width, height).reshape(-1, 2, 2)
    snapped = nodes[..., ::-1] * grid                     # (row, col) -> (u, v)
    move = snapped - ends                                 # (n, 2 ends, 2)
    owner = np.repeat(np.arange(len(dashes)), counts)
    t = _arc_fraction(polys, counts)[:, None]
    pts = np.concatenate(polys) + (1.0 - t) * move[owner, 0] + t * move[owner, 1]
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    last = np.cumsum(counts) - 1
    length = np.add.reduceat(np.concatenate([seg, [0.0]]) * ~np.isin(np.arange(len(pts)), last), last - counts + 1)
    parts = np.split(pts, np.cumsum(counts)[:-1])
    out = tuple(replace(d, polyline=p, length=float(L), a_node=tuple(int(x) for x in n[0]),
                        b_node=tuple(int(x) for x in n[1]))
                for d, p, L, n in zip(dashes, parts, length, nodes))
    report = TieGridReport(float(grid), np.linalg.norm(move, axis=2),
                           length - np.array([d.length for d in dashes]))
    return out, report
