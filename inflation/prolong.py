"""Coarse-to-fine continuation: carry an inflated coarse mesh M′ onto a finer one.

Both meshes triangulate the same Ω, so each fine grid point lies in a coarse
Ω triangle; its top (bottom) position is the barycentric combination of that
triangle's top (bottom) positions. A side-wall vertex, half-way between the
faces at the middle of a boundary edge, gets the mean of the four face
vertices around it. The result is the start of Newton's method on the fine
mesh: the string ramp and most iterations happen on the coarse mesh, where a
factorization is several times cheaper.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from airmat.inflation.mesh import MattressMesh, locate

__all__ = ["prolong", "coarse_resolutions"]


def prolong(coarse: MattressMesh, x_coarse: np.ndarray, fine: MattressMesh) -> np.ndarray:
    """Interpolate vertex positions from ``coarse`` to ``fine`` (same Ω and thickness).

    Parameters
    ----------
    coarse : MattressMesh
    x_coarse : ndarray of shape (coarse.n_vertices, 3)
        Positions of the coarse mesh (m).
    fine : MattressMesh

    Returns
    -------
    ndarray of shape (fine.n_vertices, 3)
        Positions of the fine mesh (m).

    Examples
    --------
    >>> from airmat.inflation.mesh import build_mattress_mesh
    >>> c = build_mattress_mesh(0.8, 0.4, 0.07, resolution=0.1)
    >>> f = build_mattress_mesh(0.8, 0.4, 0.07, resolution=0.05)
    >>> bool(np.allclose(prolong(c, c.vertices, f), f.vertices))
    True
    """
    if not (np.isclose(coarse.width, fine.width) and np.isclose(coarse.height, fine.height)):
        raise ValueError("prolong: the two meshes are not on the same Ω")
    x_coarse = np.asarray(x_coarse, dtype=float)
    tri, bary = locate(coarse, fine.uv[fine.top])
    out = np.empty((fine.n_vertices, 3))
    out[fine.top] = np.einsum("kj,kjd->kd", bary, x_coarse[coarse.top][tri])
    out[fine.bottom] = np.einsum("kj,kjd->kd", bary, x_coarse[coarse.bottom][tri])
    side = np.arange(2 * len(fine.top), fine.n_vertices)
    if len(side):
        # the side-wall vertex of boundary edge (p, q) sits at the middle of its four face vertices
        nearest = cKDTree(fine.uv[fine.top]).query(fine.uv[side], k=2)[1]   # the edge's two ends
        out[side] = 0.25 * (out[fine.top[nearest[:, 0]]] + out[fine.top[nearest[:, 1]]]
                            + out[fine.bottom[nearest[:, 0]]] + out[fine.bottom[nearest[:, 1]]])
    return out


def coarse_resolutions(resolution: float, *, coarsest: float = 0.08, shortest_span: float = np.inf,
                       per_string: float = 4.0) -> list:
    """Mesh resolutions of the continuation, finest first: ``resolution`` doubled while it stays
    at most ``coarsest`` and leaves ``per_string`` edges along the shortest string (m)."""
    levels = [float(resolution)]
    while 2.0 * levels[-1] <= coarsest * (1 + 1e-9) and 2.0 * levels[-1] * per_string <= shortest_span:
        levels.append(2.0 * levels[-1])
    return levels
