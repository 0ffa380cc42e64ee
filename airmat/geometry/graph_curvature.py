"""Exact principal curvatures of a graph w = h(p, q) from the derivatives of h.

Used by the jet fits of :mod:`airmat.design.curvature` (h the fitted polynomial over
a vertex's tangent plane) and by the analytic targets of
:mod:`airmat.synthetic.targets` (h the surface's height over its crown's plane).
Signs (CONTRIBUTING.md): κ > 0 where the surface bends away from the +w
normal. Lengths in metres, curvature in 1/m.
"""

from __future__ import annotations

import numpy as np

__all__ = ["graph_curvature"]


def graph_curvature(hx, hy, hxx, hxy, hyy):
    """Principal curvatures of the graph w = h(p, q), signed against the +w normal.

    Parameters
    ----------
    hx, hy, hxx, hxy, hyy : ndarray of shape (k,)
        First (dimensionless) and second (1/m) derivatives of h at k points.

    Returns
    -------
    kappa : ndarray of shape (k, 2)
        κ (1/m), > 0 where the surface bends away from the +w normal; column 0 larger |κ|.
    directions : ndarray of shape (k, 2, 3)
        Unit principal directions in (p, q, w) coordinates.
    """
    hx, hy, hxx, hxy, hyy = np.broadcast_arrays(*(np.asarray(a, float) for a in (hx, hy, hxx, hxy, hyy)))
    w = np.sqrt(1 + hx**2 + hy**2)
    first = np.stack([np.stack([1 + hx**2, hx * hy], -1), np.stack([hx * hy, 1 + hy**2], -1)], -2)
    # second fundamental form of the +w normal; our sign is its negative (bending away is > 0)
    second = -np.stack([np.stack([hxx, hxy], -1), np.stack([hxy, hyy], -1)], -2) / w[..., None, None]
    inv = np.linalg.inv(np.linalg.cholesky(first))
    lam, y = np.linalg.eigh(inv @ second @ np.swapaxes(inv, -1, -2))
    wdir = np.swapaxes(inv, -1, -2) @ y                      # columns: parameter-space directions
    d3 = np.stack([wdir[..., 0, :], wdir[..., 1, :],
                   hx[..., None] * wdir[..., 0, :] + hy[..., None] * wdir[..., 1, :]], -1)
    d3 /= np.linalg.norm(d3, axis=-1, keepdims=True)
    order = np.argsort(-np.abs(lam), axis=-1, kind="stable")
    return np.take_along_axis(lam, order, -1), np.take_along_axis(d3, order[..., None], -2)
