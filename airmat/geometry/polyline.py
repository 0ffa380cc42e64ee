"""Polylines by arc length: cumulative arc length, points at given arc lengths, midpoints.

A polyline is an array (k, d) of points (m), k >= 1. The stripe tracer
(airmat.design.streamlines, airmat.design.stripes), the string lengths
(airmat.design.string_lengths) and the inflation check (airmat.check.compare) share these.
"""

from __future__ import annotations

import numpy as np

__all__ = ["arc_length", "interpolate_at", "points_at_fractions", "midpoints"]


def arc_length(points: np.ndarray) -> np.ndarray:
    """Cumulative arc length (k,) (m) of a polyline (k, d), 0 at ``points[0]``.

    Examples
    --------
    >>> arc_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])).tolist()
    [0.0, 5.0, 6.0]
    """
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def interpolate_at(points: np.ndarray, arclength: np.ndarray, s) -> np.ndarray:
    """Points (n, d) at arc lengths ``s`` (n,) (m) along a polyline, linearly between its vertices.

    Parameters
    ----------
    points : ndarray of shape (k, d)
        The polyline (m).
    arclength : ndarray of shape (k,)
        Its cumulative arc length (:func:`arc_length`), increasing.
    s : array_like of shape (n,)
        Arc lengths (m); values outside [0, total] give the end points.

    Examples
    --------
    >>> p = np.array([[0.0, 0.0], [3.0, 4.0]])
    >>> interpolate_at(p, arc_length(p), [0.0, 2.5, 9.0]).tolist()
    [[0.0, 0.0], [1.5, 2.0], [3.0, 4.0]]
    """
    return np.stack([np.interp(s, arclength, points[:, j]) for j in range(points.shape[1])], axis=1)


def points_at_fractions(points: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points (n, d) at fractions ``t`` (n,) in [0, 1] of a polyline's total arc length."""
    s = arc_length(points)
    return interpolate_at(points, s, np.asarray(t) * s[-1])


def midpoints(polylines) -> np.ndarray:
    """The point halfway along each polyline by arc length, shape (p, d) (d = 2 for no polylines).

    Parameters
    ----------
    polylines : sequence of ndarray of shape (k_i, d)
    """
    out = [points_at_fractions(np.asarray(poly, float), np.array([0.5]))[0] for poly in polylines]
    return np.asarray(out, float).reshape(len(out), -1) if out else np.zeros((0, 2))
