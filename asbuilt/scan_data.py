"""Registered scan points reduced to normal displacements at Ŝ's vertices: the as-built update's data.

Data: registered scan points in Ŝ's frame (m). Each point is projected onto the
predicted aligned named face (Ŝ's triangulation at the prediction's aligned
vertices); its signed distance along the face normal is spread to the three
corners by its barycentric weights, which gives each covered Ŝ vertex v an
observed normal displacement y_v (the weighted mean) and a weight W_v (points'
worth). Points beyond the rim are dropped.
At most :data:`MAX_POINTS` points are used (:func:`scan_subset`, a seeded random subset). SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError

__all__ = ["ScanData", "scan_data", "scan_subset", "MIN_WEIGHT", "MAX_POINTS"]

#: a vertex is covered when the points spread onto it are worth at least this many points
MIN_WEIGHT = 1.0
#: scan points used at most (a seeded random subset beyond): about 120 per vertex of vault1's Ŝ, whose
#: mean normal distance then has a scan noise of 0.05 mm for 0.5 mm per point, below the model's error;
#: projecting a million points costs 2.9 s per linearisation, 200 000 a fifth of that
MAX_POINTS = 200_000


@dataclass(frozen=True)
class ScanData:
    """Registered scan points reduced to Ŝ's vertices (m).

    Attributes
    ----------
    observed : ndarray of shape (N,)
        Weighted mean signed normal distance of the points around each vertex from the
        predicted face (0 where not covered) (m).
    weight : ndarray of shape (N,)
        Points' worth spread onto each vertex (sum of barycentric weights).
    covered : ndarray of shape (N,) of bool
    point_sd : float
        The points' scatter about their vertex's mean (m).
    n_points, n_used : int
        Points given, points used (not beyond the rim, finite).
    """

    observed: np.ndarray
    weight: np.ndarray
    covered: np.ndarray
    point_sd: float
    n_points: int
    n_used: int


def scan_data(points, face_xyz, faces) -> ScanData:
    """The registered scan points as normal displacements at the face's vertices (see the module docstring).

    Parameters
    ----------
    points : ndarray of shape (M, 3)
        Scan points in Ŝ's frame (m).
    face_xyz : ndarray of shape (N, 3)
        The predicted aligned face at Ŝ's vertices (m).
    faces : ndarray of shape (F, 3)
        Ŝ's triangles.

    Returns
    -------
    ScanData
    """
    from trimesh.triangles import points_to_barycentric

    from airmat.asbuilt.spatial_order import spatial_order
    from airmat.design.closest_point import MeshProjector

    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"scan points: expected an array of shape (M, 3), got {points.shape}")
    n = len(face_xyz)
    finite = points[np.all(np.isfinite(points), axis=1)]
    # in spatial order: the closest-point queries about 2x sooner (airmat.asbuilt.spatial_order); the sums below
    # do not depend on the points' order but for their last bits
    finite = finite[spatial_order(finite)]
    near = MeshProjector(face_xyz, faces).closest(finite)
    ok = ~near.on_rim & np.all(np.isfinite(near.points), axis=1)
    p, cp, f = finite[ok], near.points[ok], near.face[ok]
    tri = face_xyz[faces[f]]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    r = np.einsum("ij,ij->i", p - cp, normal)
    w = np.clip(points_to_barycentric(tri, cp), 0.0, 1.0)
    idx, w = faces[f].ravel(), w.ravel()
    weight = np.bincount(idx, w, minlength=n)
    total = np.bincount(idx, w * np.repeat(r, 3), minlength=n)
    observed = np.divide(total, weight, out=np.zeros(n), where=weight > 0)
    scatter = np.bincount(idx, w * (np.repeat(r, 3) - observed[idx]) ** 2, minlength=n)
    point_sd = float(np.sqrt(scatter.sum() / max(weight.sum(), 1e-300)))
    covered = weight >= MIN_WEIGHT
    return ScanData(observed=np.where(covered, observed, 0.0), weight=weight, covered=covered,
                    point_sd=point_sd, n_points=len(points), n_used=int(ok.sum()))


def scan_subset(points, max_points, seed) -> np.ndarray:
    """The scan points (M, 3) checked, and at most ``max_points`` of them (a seeded random subset, in order)."""
    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"scan points: expected an array of shape (M, 3), got {points.shape}")
    if max_points is not None and len(points) > max_points:
        keep = np.random.default_rng([seed, 2]).choice(len(points), size=int(max_points), replace=False)
        points = points[np.sort(keep)]
    return points
