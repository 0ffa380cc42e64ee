"""Leave the string-end grooves out of a cylinder fit: consensus over arc bands.

The wrinkles at the string ends (paper §2.2, Figure 2) are dips of several
millimetres along lines across the strip, i.e. parallel to the axis. In
bins of arc position (each spanning the whole width) they show as bands
whose median residual departs from zero, all to the same side (dips), and
their flanks fade into the surface too gently for any robust loss to
ignore: a groove flank at the end of a short arc looks like curvature.

So the bands are judged against the best *circle*, not against the
current fit: near a fit, a change of the cross-section circle (offset
along the normal, rotation about the axis, curvature) moves the median
residual of band ``b`` by ``Jbar_b . c``, with ``Jbar_b`` the band's mean
Jacobian columns. A RANSAC over the bands (every hypothesis from three
bands, vectorized) finds the largest set of bands one circle explains to
within a fraction of the noise; the other bands are the grooves. Band
medians are precise (hundreds of points each), so even shallow flanks are
caught. Lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from airmat.calib.cylinder_lsq import CylinderFrame, arc_position, residuals_and_jacobian

__all__ = ["GrooveBands", "groove_bands"]


@dataclass(frozen=True)
class GrooveBands:
    """Outcome of :func:`groove_bands`.

    Attributes
    ----------
    excluded : ndarray of shape (N,), bool
        Points in bands the consensus circle does not explain.
    n_bands : int
        Bands with enough points to be judged.
    n_excluded_bands : int
        Of those, the ones left out.
    lo, hi : float
        Arc-position range the bands divide equally (m).
    bad : ndarray of shape (B,), bool
        The excluded bands.
    """

    excluded: np.ndarray
    n_bands: int
    n_excluded_bands: int
    lo: float = 0.0
    hi: float = 0.0
    bad: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def classify(self, points: np.ndarray, frame: CylinderFrame) -> np.ndarray:
        """(M,) bool: which of other ``points`` fall in the excluded bands (same, or a nearby, frame)."""
        if not self.bad.any():
            return np.zeros(len(points), dtype=bool)
        return self.classify_arc(arc_position(points, frame))

    def classify_arc(self, s: np.ndarray) -> np.ndarray:
        """(M,) bool: which arc positions ``s`` (m, :func:`airmat.calib.cylinder_lsq.arc_position`) fall in
        the excluded bands."""
        if not self.bad.any():
            return np.zeros(len(s), dtype=bool)
        return self.bad[_band_index(s, self.lo, self.hi, len(self.bad))]


def groove_bands(points: np.ndarray, frame: CylinderFrame, *, sigma: float, seed=0,
                 n_bins: int = 60, min_per_bin: int = 30, tol_sigmas: float = 0.2,
                 n_trials: int = 300, min_consensus: float = 0.4, max_runs: int = 6,
                 one_sided: float = 0.25,
                 grow: float = 0.3) -> GrooveBands:
    """Points in arc bands that one cylinder cross-section does not explain.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Points near the fitted surface (m).
    frame : CylinderFrame
        The current fit.
    sigma : float
        Noise standard deviation (m).
    seed : int or numpy Generator
        Seed of the RANSAC samples.
    n_bins : int
        Bands along the arc (fewer when there are few points).
    min_per_bin : int
        Bands with fewer points are not judged (and kept).
    tol_sigmas : float
        A band fits the consensus when its median is within
        ``max(4 standard errors, tol_sigmas * sigma)`` of the prediction.
    n_trials : int
        RANSAC hypotheses.
    min_consensus : float
        When the best consensus holds less than this share of the points,
        nothing is excluded (no clear groove structure).
    one_sided : float
        Grooves dip to one side of the surface: the bands departing to the
        other side may hold at most this fraction of the points of those
        departing to the main side (noise at the tolerance), else nothing is
        excluded. Only the main side's bands are excluded.
    max_runs : int
        Grooves are a few isolated bands (one per string end in view); when
        the excluded bands form more runs than this, the deviations are
        spread over the surface (wrinkles, a slightly different shape) and
        nothing is excluded.
    grow : float
        Each run of excluded bands is widened by this fraction of its
        length on both sides (the flanks).

    Returns
    -------
    GrooveBands
    """
    n = len(points)
    none = GrooveBands(excluded=np.zeros(n, dtype=bool), n_bands=0, n_excluded_bands=0)
    nb = int(min(n_bins, n // (4 * min_per_bin)))
    if nb < 8:
        return none
    e, Jt = residuals_and_jacobian(points, frame)
    # cross-section moves only: offset along the normal, rotation about the axis, curvature
    cols = np.column_stack([Jt[3], frame.axis @ Jt[:3], Jt[4]])
    s = arc_position(points, frame)
    lo, hi = (float(q) for q in np.quantile(s[::max(len(s) // 50_000, 1)], [0.001, 0.999]))
    b = _band_index(s, lo, hi, nb)
    counts = np.bincount(b, minlength=nb)
    valid = counts >= min_per_bin
    med, jbar = _band_stats(e, cols, b, nb, valid)
    tol = np.maximum(4 * 1.2533 * sigma / np.sqrt(np.maximum(counts, 1)), tol_sigmas * sigma)[valid]
    w = counts[valid]
    inl, dev = _ransac(med, jbar, tol, w, np.random.default_rng(seed), n_trials)
    if w[inl].sum() < min_consensus * w.sum():
        return none
    # grooves are dips: their bands depart to one side; departures to both sides are a
    # face that is simply not this cylinder (wrinkles, another shape)
    up, down = w[~inl & (dev > 0)].sum(), w[~inl & (dev < 0)].sum()
    if min(up, down) > one_sided * max(up, down):
        return none
    side = ~inl & (np.sign(dev) == (1 if up >= down else -1))
    bad = np.zeros(nb, dtype=bool)
    bad[np.flatnonzero(valid)[side]] = True
    if _count_runs(_dilate_runs(bad, 0.0)) > max_runs:  # gaps of up to two bands closed
        return none
    bad = _dilate_runs(bad, grow)
    return GrooveBands(excluded=bad[b], n_bands=int(valid.sum()), n_excluded_bands=int(bad.sum()),
                       lo=lo, hi=hi, bad=bad)


def _band_index(s, lo, hi, nb):
    return np.clip(((s - lo) / max(hi - lo, np.finfo(float).tiny) * nb).astype(np.int64), 0, nb - 1)


def _count_runs(bad: np.ndarray) -> int:
    """Number of maximal runs of True."""
    return int(np.count_nonzero(np.diff(np.concatenate([[0], bad.astype(np.int8)])) == 1))


def _dilate_runs(bad: np.ndarray, grow: float) -> np.ndarray:
    """Widen every run of excluded bands by ``grow`` times its length on each side (at least one band).

    A groove's flanks fade below the tolerance gradually; the part just
    outside the detected run still dips and, next to the end of an arc,
    would pass for curvature.
    """
    out = bad.copy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):  # a handful of runs
        pad = max(1, int(np.ceil(grow * (stop - start))))
        out[max(start - pad, 0):stop + pad] = True
    return out


def _band_stats(e, cols, b, nb, valid):
    """Median residual and mean Jacobian columns of the valid bands."""
    counts = np.bincount(b, minlength=nb)
    by_e = np.argsort(e)  # by residual, then by band (a stable radix sort of the small band numbers)
    srt = e[by_e][np.argsort(b[by_e].astype(np.int16), kind="stable")]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])[valid]
    c = counts[valid]
    med = 0.5 * (srt[start + (c - 1) // 2] + srt[start + c // 2])  # np.median of each band
    jbar = np.stack([np.bincount(b, cols[:, j], nb) for j in range(cols.shape[1])], axis=1)
    jbar = jbar[valid] / counts[valid, None]
    return med, jbar


def _ransac(med, jbar, tol, w, rng, n_trials):
    """Bands of the largest (point-weighted) consensus, refined once by least squares.

    Returns the (B,) inlier mask and the (B,) signed departures from the consensus.
    """
    B = len(med)
    triples = rng.random((n_trials, B)).argsort(axis=1)[:, :3]
    A = jbar[triples]                                # (T, 3, 3)
    rhs = med[triples]                               # (T, 3)
    scale = np.abs(A).max(axis=(1, 2), keepdims=True)
    ok = np.abs(np.linalg.det(A / scale)) > 1e-9
    coef = np.zeros((n_trials, 3))
    coef[ok] = np.linalg.solve(A[ok], rhs[ok][..., None])[..., 0]
    inl = np.abs(med[None, :] - coef @ jbar.T) < tol[None, :]
    score = np.where(ok, (inl * w).sum(axis=1), -1)
    k = int(np.argmax(score))
    best, dev = inl[k], med - jbar @ coef[k]
    if best.sum() >= 3:  # refit on the consensus and take its inliers
        c, *_ = np.linalg.lstsq(jbar[best] * np.sqrt(w[best, None]), med[best] * np.sqrt(w[best]), rcond=None)
        dev = med - jbar @ c
        best = np.abs(dev) < tol
    return best, dev
