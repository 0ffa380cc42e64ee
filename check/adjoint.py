"""Sensitivity of the inflated equilibrium to the strings' rest lengths (the adjoint method).

At an equilibrium of U_B the free forces vanish, ``g(x, l*) = 0``; moving
the strings' simulated rest lengths ``l*`` moves the equilibrium by
``dx/dl* = -H⁻¹ ∂g/∂l*`` (implicit function theorem), with ``H`` the Newton
Hessian of U_B on the free degrees of freedom (the solver's pinned ones do
not move). A scalar objective ``J(x)`` then has the gradient
``dJ/dl* = -(∂g/∂l*)ᵀ H⁻¹ ∂J/∂x``: one back-substitution with the factor of
``H`` (:func:`adjoint_gradient`); the whole Jacobian ``dx/dl*`` costs one
back-substitution per string (:func:`equilibrium_jacobian`), for a
Gauss–Newton step. ``H`` is factored once at the equilibrium with the
solver's own sparse Cholesky (:class:`~airmat.inflation.cholesky.ShiftedCholesky`,
CHOLMOD).

A string is a tension-only spring of stiffness ``k = EA / max(l*, d)`` and
smoothed onset width ``w = c_w max(l*, d)`` (:func:`airmat.inflation.model.build_model`):
its force along ``r̂`` is ``k f(|r| - l*; w)``, so ``∂g/∂l*`` has the three
terms ``k' f + k (-∂f/∂s + ∂f/∂w w')`` times the end weights times ``r̂``;
a slack string contributes 0. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from airmat.inflation.assembly import Assembler
from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.energy import Model, Springs, hessian_blocks, smoothing_blocks, spring_profile

__all__ = ["rest_derivative", "EquilibriumFactor", "factor_equilibrium", "equilibrium_jacobian",
           "adjoint_gradient"]


def rest_derivative(s: Springs, x: np.ndarray, thickness: float) -> sp.csc_matrix:
    """``∂g/∂l*``: how the force on every DOF changes with each string's rest length.

    Parameters
    ----------
    s : Springs
        The external strings (tension-only, :func:`airmat.inflation.strings.attach_strings`), with
        ``k = EA / max(l*, d)`` and ``smooth = c_w max(l*, d)``.
    x : ndarray of shape (n, 3)
        Vertex positions (m).
    thickness : float
        d (m): below it a string's stiffness and onset no longer scale with l*.

    Returns
    -------
    scipy.sparse.csc_matrix of shape (3 n, k)
        Column q: d(grad U_B)/d l*_q on the flat DOFs (3 vertex + coordinate) (N/m).
    """
    r = np.einsum("sk,skc->sc", s.coef, x[s.idx])
    length = np.linalg.norm(r, axis=1)
    rhat = r / np.maximum(length, 1e-300)[:, None]
    w = np.broadcast_to(np.asarray(s.smooth, float), length.shape)
    stretch = length - s.rest
    _, f, df = spring_profile(stretch, w, s.compression)
    z = stretch                                  # a string (compression 0): the switch is [0, 2w]
    ws = np.maximum(w, 1e-300)
    df_dw = np.where(z >= 2.0 * w, -1.0, np.where(z <= 0, 0.0, -z ** 2 / (4 * ws ** 2)))
    scaled = s.rest > thickness                  # k and w scale with l* only above d
    dk = np.where(scaled, -s.stiffness / np.maximum(s.rest, 1e-300), 0.0)
    dw = np.where(scaled, w / np.maximum(s.rest, 1e-300), 0.0)
    dforce = dk * f + s.stiffness * (-df + df_dw * dw)          # d(k f)/d l*, (k,)
    vals = s.coef[:, :, None] * (dforce[:, None] * rhat)[:, None, :]   # (k, 6, 3)
    rows = 3 * s.idx[:, :, None] + np.arange(3)
    cols = np.broadcast_to(np.arange(len(length))[:, None, None], rows.shape)
    return sp.csc_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * len(x), len(length)))


@dataclass(frozen=True)
class EquilibriumFactor:
    """The Newton Hessian at an equilibrium, factored, with what maps DOFs to it.

    Attributes
    ----------
    chol : ShiftedCholesky
        Factor of ``H + shift I`` on the free DOFs.
    free : ndarray of shape (n_free,)
        Flat DOF index of each row.
    shift : float
        Diagonal shift that was needed for a positive definite factor (0 at a
        strict minimum) (N/m).
    n_dofs : int
        3 n.
    """

    chol: ShiftedCholesky
    free: np.ndarray
    shift: float
    n_dofs: int


def factor_equilibrium(model: Model, x: np.ndarray, assembler: Assembler,
                       chol: ShiftedCholesky | None = None) -> EquilibriumFactor:
    """Factor the exact Hessian of U_B at ``x`` (an equilibrium), on ``assembler``'s free DOFs.

    Parameters
    ----------
    model : Model
    x : ndarray of shape (n, 3)
        Equilibrium positions (m).
    assembler : Assembler
        The CSR pattern of the model with the pinned DOFs removed.
    chol : ShiftedCholesky, optional
        Reuse its ordering and symbolic analysis (same pattern).

    Returns
    -------
    EquilibriumFactor
        At a stable equilibrium H is positive definite; otherwise the smallest
        shift of 1e-10 × 10^j times the mean diagonal that makes it so is used.
    """
    h = assembler.assemble(hessian_blocks(model, x) + [smoothing_blocks(model)])
    chol = chol if chol is not None else ShiftedCholesky(h, assembler.free // 3)
    scale = float(np.mean(np.abs(h.diagonal())))
    mu = 0.0
    for j in range(12):
        if chol.factor(h, mu):
            return EquilibriumFactor(chol, assembler.free, mu, 3 * model.n_vertices)
        mu = 1e-10 * scale * 10.0 ** j
    raise RuntimeError("the Hessian at the equilibrium stays indefinite: not a stable equilibrium")


def equilibrium_jacobian(factor: EquilibriumFactor, dg_drest: sp.spmatrix) -> np.ndarray:
    """``dx/dl* = -H⁻¹ ∂g/∂l*`` on every DOF (pinned ones 0): one back-substitution per string.

    Parameters
    ----------
    factor : EquilibriumFactor
    dg_drest : sparse matrix of shape (3 n, k)
        From :func:`rest_derivative`.

    Returns
    -------
    ndarray of shape (3 n, k)
        Dimensionless (m per m).
    """
    rhs = -np.asarray(dg_drest.tocsr()[factor.free].toarray())
    out = np.zeros((factor.n_dofs, rhs.shape[1]))
    out[factor.free] = factor.chol.solve(rhs)
    return out


def adjoint_gradient(factor: EquilibriumFactor, dg_drest: sp.spmatrix, dj_dx: np.ndarray) -> np.ndarray:
    """``dJ/dl* = -(∂g/∂l*)ᵀ H⁻¹ ∂J/∂x``: the gradient of an objective of the equilibrium, one back-substitution.

    Parameters
    ----------
    factor : EquilibriumFactor
    dg_drest : sparse matrix of shape (3 n, k)
    dj_dx : ndarray of shape (n, 3) or (3 n,)
        Gradient of J with respect to the positions (J/m).

    Returns
    -------
    ndarray of shape (k,)
        (J/m).
    """
    lam = factor.chol.solve(np.asarray(dj_dx, float).reshape(-1)[factor.free])
    return -np.asarray(dg_drest.tocsr()[factor.free].T @ lam).reshape(-1)
