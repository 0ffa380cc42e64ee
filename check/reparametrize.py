"""Ŝ re-parametrized in the metric the inflated named face realizes: the same surface, other points.

The check compares the named face with Ŝ point by point through Ω
(:func:`airmat.check.compare.deviation`). Which point of Ω Ŝ puts where comes from
the designer's model of the named face's metric (:mod:`airmat.design.face_metric`:
Ω's lengths, shortened by 1 / (1 + d κ) under the face's own strings). The
simulated face realizes a somewhat different metric (the saddle's top face
shortens along u by 0.92–0.94 where the model says 0.89–0.95,
bench_face_strain in docs/decisions.md), so part of the deviation is a slide along
the surface, not a distance from it: the refined saddle lies 13.8 mm RMS
from Ŝ point to point but 9.8 mm from Ŝ's nearest points.

:func:`reparametrize` moves Ŝ's vertices along Ŝ's own surface so that its
edges take the lengths the inflated face gives them: U_A
(:func:`airmat.design.relax.relax_from`) with those lengths as A1 rest lengths and
A2 pulling onto the old Ŝ (continued across its rim by the rim faces'
planes, :meth:`airmat.design.closest_point.MeshProjector.closest_extended`). The
shape the user asked for is kept (the report gives how far the new Ŝ lies
from the old one's surface); the correspondence becomes the mattress's.
The refinement (:func:`airmat.check.refinement.refine`) alternates it with its
Gauss–Newton iterations. SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.geometry.topology import mesh_edges

__all__ = ["Reparametrization", "realized_ratio", "reparametrize"]


@dataclass(frozen=True)
class Reparametrization:
    """Ŝ moved along its surface into a realized metric.

    Attributes
    ----------
    xyz : ndarray of shape (n, 3)
        The new Ŝ (m), at the same Ω points as the old one.
    moved_rms, moved_max : float
        How far its vertices moved (m): mostly along the surface.
    off_rms, off_max : float
        Distance of the new vertices from the old Ŝ's surface (m): what the relaxation's
        balance of A1 against A2 leaves off it.
    converged : bool
        Whether the relaxation met its tolerance.
    iterations : int
    """

    xyz: np.ndarray
    moved_rms: float
    moved_max: float
    off_rms: float
    off_max: float
    converged: bool
    iterations: int

    def summary_mm(self) -> dict:
        """``{"moved_rms_mm", "moved_max_mm", "off_surface_rms_mm", "off_surface_max_mm"}``."""
        return {"moved_rms_mm": round(self.moved_rms * 1e3, 3), "moved_max_mm": round(self.moved_max * 1e3, 3),
                "off_surface_rms_mm": round(self.off_rms * 1e3, 3),
                "off_surface_max_mm": round(self.off_max * 1e3, 3)}


def realized_ratio(face_xyz, uv, faces) -> np.ndarray:
    """Length of each edge of Ω on a realized face over its length on Ω.

    Parameters
    ----------
    face_xyz : ndarray of shape (n, 3)
        The face at Ω's vertices ``uv`` (m).
    uv : ndarray of shape (n, 2)
        Ω's vertices (m).
    faces : ndarray of shape (m, 3)

    Returns
    -------
    ndarray of shape (e,)
        One ratio per edge of ``mesh_edges(faces)``.

    Examples
    --------
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> face = np.column_stack([uv * [0.9, 1.0], np.zeros(3)])
    >>> np.round(realized_ratio(face, uv, np.array([[0, 1, 2]])), 4).tolist()
    [0.9, 1.0, 0.9513]
    """
    face_xyz, uv = np.asarray(face_xyz, float), np.asarray(uv, float)
    e = mesh_edges(np.asarray(faces))
    flat = np.linalg.norm(uv[e[:, 1]] - uv[e[:, 0]], axis=1)
    return np.linalg.norm(face_xyz[e[:, 1]] - face_xyz[e[:, 0]], axis=1) / flat


def reparametrize(approx_xyz, uv, faces, face_xyz, *, start=None, projector=None,
                  max_iter: int = 1000) -> Reparametrization:
    """Move Ŝ along its own surface into the metric of a realized face.

    Parameters
    ----------
    approx_xyz : ndarray of shape (n, 3)
        Ŝ (m).
    uv, faces : ndarray of shape (n, 2), (m, 3)
        Ω's triangulation (m), Ŝ's.
    face_xyz : ndarray of shape (n, 3)
        The realized face at the same Ω points (m), in any rigid position.
    start : ndarray of shape (n, 3), optional
        Where the relaxation starts (m), e.g. the last round's Ŝ; default ``approx_xyz``.
        The surface it stays on and the distances moved are ``approx_xyz``'s.
    projector : airmat.design.closest_point.MeshProjector, optional
        Onto Ŝ's surface; default one built on ``approx_xyz``.
    max_iter : int
        Of the relaxation.

    Returns
    -------
    Reparametrization
    """
    from airmat.design.closest_point import MeshProjector
    from airmat.design.relax import relax_from

    x0 = np.asarray(approx_xyz, float)
    faces = np.asarray(faces)
    projector = MeshProjector(x0, faces) if projector is None else projector
    e = mesh_edges(faces)
    face_xyz = np.asarray(face_xyz, float)
    rest = np.linalg.norm(face_xyz[e[:, 1]] - face_xyz[e[:, 0]], axis=1)        # the face's own edge lengths
    x, it, converged, _, _ = relax_from(x0 if start is None else start, uv, faces, projector, rest=rest, max_iter=max_iter)
    moved = np.linalg.norm(x - x0, axis=1)
    off = projector.closest_extended(x).distance
    return Reparametrization(xyz=x, moved_rms=float(np.sqrt(np.mean(moved ** 2))), moved_max=float(moved.max()),
                             off_rms=float(np.sqrt(np.mean(off ** 2))), off_max=float(off.max()),
                             converged=bool(converged), iterations=int(it))
