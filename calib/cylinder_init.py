"""Initial cylinder from a downsampled specimen cloud: axis from normals, circle by RANSAC.

The normals of a cylinder lie in the plane perpendicular to its axis, so
the axis is the eigenvector of the smallest eigenvalue of the normals'
second-moment matrix. Clutter normals are isotropic and do not bias it;
they are down-weighted anyway by re-estimating from the normals within a
band around that plane (a few iterations). The ratio of the smallest to
the middle eigenvalue of the banded moments measures how well the normals
lie in a plane: near 0 for a cylinder, near 1 for a sphere cap or a box.

The points are then projected along the axis and a circle is found by
RANSAC (:func:`airmat.calib.circle_ransac.circle_ransac`, scikit-image's
estimator vectorized over the trials). A specimen
that is nearly flat (its normals spread over less than ``flat_deg``)
has no usable normal scatter; it is initialized instead from a robust
quadratic height field over its plane: the Hessian's dominant eigenvector
gives the arc direction, its eigenvalue the curvature.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import NotACylinderError
from airmat.calib.circle_ransac import circle_ransac
from airmat.calib.cylinder_lsq import CylinderFrame

__all__ = ["NormalScatter", "normal_scatter", "InitialCylinder", "initial_cylinder", "circle_init",
           "height_field_init"]


@dataclass(frozen=True)
class NormalScatter:
    """What the normals say about the axis.

    Attributes
    ----------
    axis : ndarray of shape (3,)
        Unit axis estimate.
    planarity : float
        Smallest over middle eigenvalue of the banded second moments: near 0
        when the normals lie in a plane (cylinder), near 1 for a sphere or box.
    spread_deg : float
        Angular spread of the normals around the axis, about the arc angle
        of the surface (``sqrt(12 * middle eigenvalue)``, degrees).
    in_band : float
        Fraction of the normals within the band.
    """

    axis: np.ndarray
    planarity: float
    spread_deg: float
    in_band: float


def normal_scatter(normals: np.ndarray, *, band_deg: float = 10.0, n_iter: int = 5) -> NormalScatter:
    """Axis of a cylinder from its unit normals (N, 3), robust to clutter.

    Parameters
    ----------
    normals : ndarray of shape (N, 3)
        Unit normals (their sign does not matter).
    band_deg : float
        Normals within this angle of the plane perpendicular to the axis
        enter the re-estimate.
    n_iter : int
        Re-estimation passes.

    Returns
    -------
    NormalScatter
    """
    nrm = np.asarray(normals, dtype=float)
    lam, vec = np.linalg.eigh(nrm.T @ nrm / len(nrm))
    axis = vec[:, 0]
    band = np.sin(np.radians(band_deg))
    keep = np.ones(len(nrm), dtype=bool)
    for _ in range(n_iter):
        keep = np.abs(nrm @ axis) < band
        if keep.sum() < 10:
            break
        sel = nrm[keep]
        lam, vec = np.linalg.eigh(sel.T @ sel / len(sel))
        axis = vec[:, 0]
    planarity = float(lam[0] / max(lam[1], np.finfo(float).tiny))
    spread = float(np.degrees(np.sqrt(12.0 * max(lam[1], 0.0))))
    return NormalScatter(axis=axis, planarity=planarity, spread_deg=spread, in_band=float(keep.mean()))


@dataclass(frozen=True)
class InitialCylinder:
    """Outcome of :func:`initial_cylinder`.

    Attributes
    ----------
    frame : CylinderFrame
        The initial cylinder.
    inliers : ndarray of shape (N,), bool
        Points the estimate rests on.
    scatter : NormalScatter
        What the normals said.
    nearly_flat : bool
        Initialized from the height field (normals spread below ``flat_deg``).
    flat : bool
        Nearly flat and without significant curvature: the axis is the
        footprint's short direction, not a measured one.
    """

    frame: CylinderFrame
    inliers: np.ndarray
    scatter: NormalScatter
    nearly_flat: bool
    flat: bool


def _perp_basis(axis):
    """Two unit vectors completing ``axis`` to an orthonormal frame."""
    helper = np.eye(3)[np.argmin(np.abs(axis))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def circle_init(points: np.ndarray, axis: np.ndarray, *, threshold: float, max_trials: int = 300,
                seed=0) -> tuple[CylinderFrame, np.ndarray]:
    """Circle by RANSAC in the projection along ``axis``, as a cylinder frame.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Candidate specimen points (m).
    axis : ndarray of shape (3,)
        Unit axis estimate.
    threshold : float
        RANSAC inlier distance in the projection (m).
    max_trials : int
        RANSAC samples at most.
    seed : int or numpy Generator
        Seed of the sampling.

    Returns
    -------
    frame : CylinderFrame
        Origin at the inliers' centroid pushed onto the circle, normal toward
        the axis, kappa = 1/radius.
    inliers : ndarray of shape (N,), bool

    Raises
    ------
    airmat.errors.NotACylinderError
        When RANSAC finds no circle.
    """
    e1, e2 = _perp_basis(axis)
    uv = np.column_stack([points @ e1, points @ e2])
    c_uv = uv.mean(axis=0)
    span = float(np.ptp(uv, axis=0).max()) or 1.0
    data = (uv - c_uv) / span  # centred and scaled: well conditioned anywhere
    circle = circle_ransac(data, threshold=threshold / span, max_trials=max_trials, stop_probability=0.999,
                           max_radius=1e4, seed=seed)
    if circle is None or circle.inliers.sum() < 6:
        raise NotACylinderError("no circular arc found in the cross-section along the axis")
    inliers = circle.inliers
    center = c_uv + circle.center * span
    radius = circle.radius * span
    along = float(np.mean(points[inliers] @ axis))
    c3 = center[0] * e1 + center[1] * e2 + along * axis
    m = points[inliers].mean(axis=0)
    out = m - c3 - ((m - c3) @ axis) * axis
    norm = np.linalg.norm(out)
    if norm == 0:
        raise NotACylinderError("degenerate circle: the points surround the axis")
    u = out / norm
    return CylinderFrame(origin=c3 + radius * u, normal=-u, axis=axis, kappa=1.0 / radius), inliers


def height_field_init(points: np.ndarray, *, n_trim: int = 10) -> tuple[CylinderFrame, np.ndarray, bool]:
    """Nearly flat specimen: cylinder frame from a robust quadratic height field.

    The Hessian's dominant eigenvector is the arc direction and its
    eigenvalue the initial (signed) curvature. When no curvature is
    significant (a flat specimen), the axis is the footprint's short
    direction: a strip bends along its length.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Candidate specimen points (m), mostly one nearly flat surface.
    n_trim : int
        Trimmed refits (drop residuals above 3 median absolute residuals).

    Returns
    -------
    frame : CylinderFrame
    inliers : ndarray of shape (N,), bool
        The points kept by the trimming.
    flat : bool
        No curvature is significant (three standard errors).
    """
    c = np.median(points, axis=0)
    _, _, vt = np.linalg.svd(points - c, full_matrices=False)
    keep = np.ones(len(points), dtype=bool)
    for _ in range(n_trim):  # plane, then quadric, both trimmed
        c = points[keep].mean(axis=0)
        _, _, vt = np.linalg.svd(points[keep] - c, full_matrices=False)
        r = np.abs((points - c) @ vt[2])
        new = r <= 3 * np.median(r[keep])
        if np.array_equal(new, keep):
            break
        keep = new
    uv = (points - c) @ vt[:2].T
    h = (points - c) @ vt[2]
    scale = float(np.std(uv[keep], axis=0).max()) or 1.0
    u, v = (uv / scale).T
    basis = np.column_stack([np.ones_like(u), u, v, 0.5 * u * u, u * v, 0.5 * v * v])
    for _ in range(n_trim):
        coef, *_ = np.linalg.lstsq(basis[keep], h[keep], rcond=None)
        r = np.abs(h - basis @ coef)
        new = r <= 3 * np.median(r[keep]) + np.finfo(float).tiny
        if np.array_equal(new, keep):
            break
        keep = new
    hess = np.array([[coef[3], coef[4]], [coef[4], coef[5]]]) / scale**2
    lam, vec = np.linalg.eigh(hess)
    i = int(np.argmax(np.abs(lam)))
    res = h[keep] - basis[keep] @ coef
    cov = np.linalg.pinv(basis[keep].T @ basis[keep]) * (res @ res) / max(keep.sum() - 6, 1)
    se_curv = float(np.sqrt(max(cov[3, 3], cov[5, 5]))) / scale**2
    flat = bool(abs(lam[i]) < 3 * se_curv)
    if flat:
        # no significant bending: a strip bends along its length, so take the
        # footprint's long direction (vt[0]) as the arc and the short one as axis
        vec, i = np.eye(2), 0
        lam = np.array([hess[0, 0], hess[1, 1]])
    u0, v0 = uv[keep].mean(axis=0) / scale
    grad = np.array([coef[1] + coef[3] * u0 + coef[4] * v0, coef[2] + coef[4] * u0 + coef[5] * v0]) / scale
    h0 = float(np.array([1, u0, v0, 0.5 * u0 * u0, u0 * v0, 0.5 * v0 * v0]) @ coef)
    origin = c + scale * (u0 * vt[0] + v0 * vt[1]) + h0 * vt[2]
    normal = vt[2] - grad[0] * vt[0] - grad[1] * vt[1]
    normal /= np.linalg.norm(normal)
    axis_2d = vec[:, 1 - i]
    axis = axis_2d[0] * vt[0] + axis_2d[1] * vt[1]
    axis -= (axis @ normal) * normal
    axis /= np.linalg.norm(axis)
    return CylinderFrame(origin=origin, normal=normal, axis=axis, kappa=float(lam[i])), keep, flat


def initial_cylinder(points: np.ndarray, normals: np.ndarray, *, threshold: float,
                     max_planarity: float = 0.3, flat_deg: float = 20.0, seed=0) -> InitialCylinder:
    """Initial cylinder of a downsampled specimen cloud with normals.

    Parameters
    ----------
    points, normals : ndarray of shape (N, 3)
        Downsampled candidate points (m) and their unit normals.
    threshold : float
        Circle RANSAC inlier distance (m).
    max_planarity : float
        Refuse when :attr:`NormalScatter.planarity` exceeds this (the
        normals do not lie in a plane).
    flat_deg : float
        Below this normal spread the specimen is nearly flat: height-field start.
    seed : int
        Seed of the RANSAC.

    Returns
    -------
    InitialCylinder

    Raises
    ------
    airmat.errors.NotACylinderError
        Sphere-like normals, or no circle found.
    """
    scatter = normal_scatter(normals)
    if scatter.spread_deg < flat_deg:
        frame, inliers, flat = height_field_init(points)
        return InitialCylinder(frame, inliers, scatter, nearly_flat=True, flat=flat)
    if scatter.planarity > max_planarity:
        raise NotACylinderError(
            f"normals do not lie in a plane (sphere-like): eigenvalue ratio {scatter.planarity:.2f} "
            f"> {max_planarity:g}", planarity=scatter.planarity)
    frame, inliers = circle_init(points, scatter.axis, threshold=threshold, seed=seed)
    return InitialCylinder(frame, inliers, scatter, nearly_flat=False, flat=False)
