"""A circle in the plane by RANSAC, vectorized over the trials (numpy only).

The same estimator as :func:`skimage.measure.ransac` with ``CircleModel``
(samples of three points, the circle through them, the largest consensus
set, ties broken by the smaller sum of squared inlier residuals, the final
circle refitted to that set by the linear (Kasa) least squares, and the
number of trials cut once ``stop_probability`` is reached), but the trials
are drawn and scored in batches, one array operation per batch instead of a
Python loop per trial, and it imports no scipy: the cylinder fit's start-up
stays small. Coordinates in any unit; the threshold in the same unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Circle", "circle_ransac", "fit_circle"]


@dataclass(frozen=True)
class Circle:
    """A circle found by :func:`circle_ransac`.

    Attributes
    ----------
    center : ndarray of shape (2,)
        Centre (the points' unit).
    radius : float
        Radius (the points' unit).
    inliers : ndarray of shape (N,), bool
        Points within the threshold of the best sampled circle.
    n_trials : int
        Samples scored.
    """

    center: np.ndarray
    radius: float
    inliers: np.ndarray
    n_trials: int


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Linear least-squares (Kasa) circle through ``points`` (N, 2), N >= 3: (centre (2,), radius)."""
    A = np.column_stack([2.0 * points, np.ones(len(points))])
    c, *_ = np.linalg.lstsq(A, np.einsum("ij,ij->i", points, points), rcond=None)
    return c[:2], float(np.sqrt(max(c[2] + c[0] ** 2 + c[1] ** 2, 0.0)))


def circle_ransac(points: np.ndarray, *, threshold: float, max_trials: int = 300,
                  stop_probability: float = 0.999, max_radius: float = np.inf, batch: int = 50,
                  seed=0) -> Circle | None:
    """The circle with the largest consensus set among ``max_trials`` three-point samples.

    Parameters
    ----------
    points : ndarray of shape (N, 2)
        Planar points, best centred and scaled to about unit spread.
    threshold : float
        Inlier distance to the circle (the points' unit).
    max_trials : int
        Samples at most.
    stop_probability : float
        Stop once a sample of three inliers has been drawn with this
        probability, at the best consensus set's inlier ratio.
    max_radius : float
        Circles larger than this (nearly collinear samples) are not models.
    batch : int
        Trials scored per array operation.
    seed : int or numpy Generator
        Seed of the sampling.

    Returns
    -------
    Circle or None
        None when no sample gave a valid circle with an inlier.

    Examples
    --------
    >>> t = np.linspace(0, 1.5, 200)
    >>> pts = np.column_stack([2 + 3 * np.cos(t), -1 + 3 * np.sin(t)])
    >>> c = circle_ransac(np.vstack([pts, [[0.0, 0.0], [5.0, 5.0]]]), threshold=0.01, seed=0)
    >>> np.round(c.center, 6).tolist(), round(c.radius, 6), int(c.inliers.sum())
    ([2.0, -1.0], 3.0, 200)
    """
    pts = np.asarray(points, dtype=float)
    n = len(pts)
    if n < 3:
        return None
    rng = np.random.default_rng(seed)
    best = (0, np.inf, None)  # (inliers, sum of squared inlier residuals, trial's inlier mask)
    done, needed = 0, max_trials
    while done < min(max_trials, needed):
        m = min(batch, max_trials - done)
        idx = rng.integers(n, size=(m, 3))
        center, radius = _circles_through(pts[idx])
        ok = (idx[:, 0] != idx[:, 1]) & (idx[:, 0] != idx[:, 2]) & (idx[:, 1] != idx[:, 2]) \
            & np.isfinite(radius) & (radius < max_radius)
        d = np.abs(np.hypot(pts[None, :, 0] - center[:, 0, None], pts[None, :, 1] - center[:, 1, None])
                   - radius[:, None])                                      # (m, N)
        inl = ok[:, None] & (d < threshold)
        count = inl.sum(axis=1)
        ssr = np.einsum("ij,ij->i", np.where(inl, d, 0.0), np.where(inl, d, 0.0))
        order = np.lexsort((ssr, -count))  # most inliers, then smallest residuals; first wins ties
        k = int(order[0])
        if count[k] > best[0] or (count[k] == best[0] and count[k] and ssr[k] < best[1]):
            best = (int(count[k]), float(ssr[k]), inl[k].copy())
        done += m
        if best[0]:
            needed = _trials_needed(best[0] / n, stop_probability)
    if best[2] is None or best[0] < 3:
        return None
    center, radius = fit_circle(pts[best[2]])
    return Circle(center=center, radius=radius, inliers=best[2], n_trials=done)


def _circles_through(tri: np.ndarray):
    """Centres (M, 2) and radii (M,) of the circles through triangles (M, 3, 2); inf when collinear."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    b, c = b - a, c - a  # relative to the first point: well conditioned
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    bb, cc = (b * b).sum(axis=1), (c * c).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (c[:, 1] * bb - b[:, 1] * cc) / d
        uy = (b[:, 0] * cc - c[:, 0] * bb) / d
    radius = np.hypot(ux, uy)
    radius[~np.isfinite(radius)] = np.inf
    return a + np.column_stack([ux, uy]), radius


def _trials_needed(inlier_ratio: float, probability: float) -> int:
    """Trials after which a sample of three inliers was drawn with ``probability``."""
    p_good = inlier_ratio ** 3
    if p_good >= 1.0:
        return 0
    if p_good <= 0.0:
        return np.iinfo(np.int64).max
    return int(np.ceil(np.log(1.0 - probability) / np.log(1.0 - p_good)))
