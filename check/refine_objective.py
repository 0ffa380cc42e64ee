"""The refinement's objective: mean squared distance of the named face from Ŝ, rigid motions removed.

The named face at Ŝ's Ω points is a fixed linear map of the vertex
positions, ``F = P x`` (barycentric interpolation on the mattress grid, as
:func:`airmat.check.compare.surface_at` does), so its Jacobian is ``P`` itself.
Rigid motions are removed as the check removes them: Ŝ is aligned to the
current face by Kabsch and held fixed while the lengths move; by the
envelope theorem the gradient of ``min over (R, t)`` is the gradient at the
optimal (R, t), so holding Ŝ fixed gives the exact gradient of the
rigid-invariant objective, which equals the check's ``Deviation.rms²``. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from airmat.check.compare import SURFACES
from airmat.inflation.mesh import MattressMesh, locate

__all__ = ["face_operator", "FaceFit", "face_fit"]


def face_operator(mesh: MattressMesh, uv: np.ndarray, surface: str) -> sp.csr_matrix:
    """``P`` of shape (N, n): the named face at Ω points ``uv`` (N, 2) from the vertex positions.

    Parameters
    ----------
    mesh : MattressMesh
    uv : ndarray of shape (N, 2)
        Points on Ω (m).
    surface : {"top", "bottom", "mid"}

    Returns
    -------
    scipy.sparse.csr_matrix of shape (N, n)
        Rows sum to 1; ``P @ xyz`` (n, 3) is the face at ``uv`` (m).
    """
    if surface not in SURFACES:
        raise ValueError(f"surface {surface!r}: expected one of {SURFACES}")
    uv = np.asarray(uv, float)
    tri, bary = locate(mesh, uv)
    faces = {"top": [(mesh.top, 1.0)], "bottom": [(mesh.bottom, 1.0)],
             "mid": [(mesh.top, 0.5), (mesh.bottom, 0.5)]}[surface]
    rows = np.concatenate([np.repeat(np.arange(len(uv)), 3)] * len(faces))
    cols = np.concatenate([idx[tri].ravel() for idx, _ in faces])
    vals = np.concatenate([w * bary.ravel() for _, w in faces])
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(uv), mesh.n_vertices))


@dataclass(frozen=True)
class FaceFit:
    """The named face against Ŝ aligned onto it.

    Attributes
    ----------
    objective : float
        Mean squared distance (m²): the check's ``Deviation.rms`` squared.
    residual : ndarray of shape (3 N,)
        ``(P x - Ŝ_aligned) / sqrt(N)``, so that ``objective = |residual|²`` (m).
    target : ndarray of shape (N, 3)
        Ŝ moved rigidly onto the face (m), held fixed for the gradient.
    """

    objective: float
    residual: np.ndarray
    target: np.ndarray


def face_fit(p: sp.csr_matrix, x: np.ndarray, approx_xyz: np.ndarray, offset=None) -> FaceFit:
    """Align Ŝ onto the named face ``P x`` (Kabsch) and measure the mean squared distance.

    Parameters
    ----------
    p : scipy.sparse.csr_matrix of shape (N, n)
        From :func:`face_operator`.
    x : ndarray of shape (n, 3)
        Vertex positions (m).
    approx_xyz : ndarray of shape (N, 3)
        Ŝ's vertices (m).
    offset : ndarray of shape (N, 3), optional
        Added to the face before the alignment (m): the refinement's coarse-mesh
        correction (the fine face minus the coarse one at the start lengths).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> moved = pts @ Rotation.from_euler("z", 30, degrees=True).as_matrix().T + 5.0
    >>> round(face_fit(sp.identity(4, format="csr"), moved, pts).objective, 12)
    0.0
    """
    face = p @ x if offset is None else p @ x + offset
    s = np.asarray(approx_xyz, float)
    fc, sc = face.mean(axis=0), s.mean(axis=0)
    rot, _ = Rotation.align_vectors(face - fc, s - sc)
    target = (s - sc) @ rot.as_matrix().T + fc
    diff = face - target
    res = diff.ravel() / np.sqrt(len(s))
    return FaceFit(objective=float(res @ res), residual=res, target=target)
