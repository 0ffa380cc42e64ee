"""The named face linearized in the simulated rest lengths: one Jacobian at an equilibrium.

At an equilibrium (the median run's) the adjoint gives ``dx/dl* = -H⁻¹ ∂g/∂l*``
(:mod:`airmat.check.adjoint`: one factorization of the Hessian, one back-substitution per
string); the named face at Ŝ's points is ``P x`` (:func:`airmat.check.refine_objective.face_operator`), turned into
Ŝ's frame by the median run's alignment. The check aligns every run to Ŝ again
(Kabsch), so a change of the face counts only up to a rigid motion: each column
of the Jacobian loses its least-squares infinitesimal rigid motion at the aligned
points (the linearized Kabsch; the term of the median's own residual is dropped,
second order in the deviation over the size of Ŝ). So a change δl* of the
simulated rest lengths moves the deviation vector of Ŝ's vertex v, e_v = aligned − Ŝ,
to e_v + A_v δl*, with A of shape (N, 3, k).

Used by the linear tolerance (:mod:`airmat.check.tolerance`) and the as-built update
(:mod:`airmat.asbuilt.update`). SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.check.adjoint import equilibrium_jacobian, factor_equilibrium, rest_derivative
from airmat.check.refine_objective import face_operator
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import block_pattern
from airmat.inflation.model import Parameters, build_model
from airmat.inflation.solver import rigid_pins

__all__ = ["Linearization", "linearize", "face_jacobian", "remove_rigid", "align_faces"]


def remove_rigid(points: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Each column's displacement field less its least-squares infinitesimal rigid motion.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Where the displacements sit (m).
    columns : ndarray of shape (N, 3, k)
        Displacement fields (any unit).

    Returns
    -------
    ndarray of shape (N, 3, k)
        Orthogonal to every translation and rotation about the points' centroid.

    Examples
    --------
    >>> p = np.random.default_rng(0).normal(size=(10, 3))
    >>> spin = np.cross([0.0, 0.0, 1.0], p - p.mean(axis=0)) + [1.0, 2.0, 3.0]
    >>> bool(np.allclose(remove_rigid(p, spin[:, :, None]), 0))
    True
    """
    p = np.asarray(points, float) - np.mean(points, axis=0)
    n = len(p)
    basis = np.zeros((n, 3, 6))
    basis[:, :, :3] = np.eye(3)
    for c in range(3):
        basis[:, :, 3 + c] = np.cross(np.eye(3)[c], p)
    g = basis.reshape(3 * n, 6)
    a = np.asarray(columns, float).reshape(3 * n, -1)
    coef, *_ = np.linalg.lstsq(g, a, rcond=None)
    return (a - g @ coef).reshape(columns.shape)


@dataclass(frozen=True)
class Linearization:
    """The median equilibrium's model, factored once: what the Jacobian and the validation solves share.

    Attributes
    ----------
    model : airmat.inflation.energy.Model
        U_B with the strings at their median rest lengths.
    assembler : airmat.inflation.assembly.Assembler
        The sparse pattern with the solver's pinned DOFs removed.
    fixed : ndarray of shape (6,)
        The pinned flat DOF indices (:func:`airmat.inflation.solver.rigid_pins`).
    dx : ndarray of shape (3 n, k)
        dx/dl* of every DOF (m/m).
    face : ndarray of shape (N, 3, k)
        A, the aligned named face's change per rest length, rigid motions removed (m/m).
    operator : scipy.sparse.csr_matrix of shape (N, n)
        The named face at Ŝ's points from the vertex positions (:func:`face_operator`).
    """

    model: object
    assembler: object
    fixed: np.ndarray
    dx: np.ndarray
    face: np.ndarray
    operator: object


def linearize(design, run, strings, surface: str, params: Parameters = Parameters()) -> Linearization:
    """The adjoint linearization of the named face at the median run (see :class:`Linearization`).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    run : airmat.check.inflation_check.CheckRun
        The median run: its equilibrium and its alignment to Ŝ.
    strings : airmat.inflation.strings.StringSet
        The strings it was inflated with (rest lengths l*, m).
    surface : str
        The named face.
    params : Parameters

    Returns
    -------
    Linearization
    """
    inf = run.inflation
    mesh, x = inf.mesh, inf.xyz
    model = build_model(mesh, strings, params)
    fixed = rigid_pins(mesh.uv, mesh.top)
    asm = build_assembler(block_pattern(model), model.n_vertices, fixed)
    factor = factor_equilibrium(model, x, asm)
    dx = equilibrium_jacobian(factor, rest_derivative(model.springs[-1], x, mesh.thickness))   # (3n, k)
    k = len(strings.rest)
    p = face_operator(mesh, design.approx.uv, surface)
    face = (p @ dx.reshape(len(x), 3 * k)).reshape(-1, 3, k)
    face = np.einsum("ij,njk->nik", run.deviation.rotation, face)
    return Linearization(model, asm, fixed, dx, remove_rigid(run.deviation.aligned, face), p)


def face_jacobian(design, run, strings, surface: str, params: Parameters = Parameters()) -> np.ndarray:
    """A: the aligned named face's change per simulated rest length, rigid motions removed (Ŝ's frame),
    shape (N, 3, k) at Ŝ's N vertices (m/m): the ``face`` of :func:`linearize` (same parameters)."""
    return linearize(design, run, strings, surface, params).face


def align_faces(faces: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Each face rigidly aligned onto the target (Kabsch, as :func:`airmat.check.compare.deviation`).

    Parameters
    ----------
    faces : ndarray of shape (S, N, 3)
        Points corresponding to the target's (m).
    target : ndarray of shape (N, 3)
        (m).

    Returns
    -------
    ndarray of shape (S, N, 3)
        R_s (face_s − its centroid) + the target's centroid, R_s the proper rotation of least squares.

    Examples
    --------
    >>> t = np.random.default_rng(1).normal(size=(6, 3))
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> moved = t @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + 2.0
    >>> bool(np.allclose(align_faces(moved[None], t)[0], t))
    True
    """
    f = np.asarray(faces, float)
    t = np.asarray(target, float)
    fc, tc = f - f.mean(axis=1, keepdims=True), t - t.mean(axis=0)
    u, _, vt = np.linalg.svd(np.einsum("snc,nd->scd", fc, tc))            # H = U S Vᵀ, R = V D Uᵀ
    sign = np.ones((len(f), 3))
    sign[:, 2] = np.sign(np.linalg.det(u) * np.linalg.det(vt))
    rot = np.einsum("sji,sj,skj->sik", vt, sign, u)
    return np.einsum("sik,snk->sni", rot, fc) + t.mean(axis=0)
