"""A robust point-to-surface ICP onto a triangle mesh: samples of its interior and outline, Tukey-weighted steps.

Scan points are matched to points sampled densely on the reference with interpolated normals
(:func:`sample_surface`): a point's residual is its normal distance to its nearest sample's tangent
plane or, nearest the outline (:func:`outline_samples`), its overhang beyond it, which holds the slide
along a cylinder's axis and the turn about a dome's axis that point-to-plane residuals leave free.
Residuals are weighted by Tukey's biweight with a scale annealed down a ladder (:func:`tukey_ladder`),
each level a Gauss–Newton iteration on the 6 rigid parameters (:class:`SurfaceFit`). Lengths in metres.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SurfaceFit", "sample_surface", "outline_samples", "tukey_ladder", "rodrigues", "mesh_area"]

#: ICP iterations per annealing level and in total
_MAX_ITER_LEVEL, _MAX_ITER = 50, 250
#: a level of the final ICP ends when a step moves no point by more than this share of the span
#: (10 µm on a 1 m mattress: 1 % of the 1 mm the registration must reach)
_TOL = 1e-5
#: the scan normal's largest angle from the reference's (degrees) on the last levels of the annealing
_MAX_NORMAL_DEG, _NORMAL_GATE_LEVELS = 30.0, 2


def sample_surface(vertices: np.ndarray, faces: np.ndarray, n: int, *, seed=0):
    """``n`` points on a triangle mesh, area-weighted, with its interpolated unit vertex normals.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Coordinates (m).
    faces : ndarray of shape (F, 3)
        Vertex indices, consistently oriented.
    n : int
        Points.
    seed : int or numpy Generator

    Returns
    -------
    points, normals : ndarray of shape (n, 3)
        Points (m) and unit normals (on the side the faces' winding gives).
    face : ndarray of shape (n,)
        The face each point lies on.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    rng = np.random.default_rng(seed)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    vn = np.zeros_like(v)
    for j in range(3):  # area-weighted vertex normals
        np.add.at(vn, f[:, j], cross)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), np.finfo(float).tiny)
    face = rng.choice(len(f), size=int(n), p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(int(n))), rng.random(int(n))
    bary = np.column_stack([1 - r1, r1 * (1 - r2), r1 * r2])
    pts = np.einsum("nk,nkj->nj", bary, v[f[face]])
    nrm = np.einsum("nk,nkj->nj", bary, vn[f[face]])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), np.finfo(float).tiny)
    return pts, nrm, face


def mesh_area(v, f) -> float:
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def tukey_ladder(k0: float, k_final: float) -> list:
    """Tukey scales from ``k0`` halving down to ``k_final``."""
    n = max(1, int(np.ceil(np.log2(max(k0 / k_final, 1.0)))))
    return list(k_final * 2.0 ** np.arange(n, -1, -1))


class SurfaceFit:
    """The reference's samples (interior and outline) and a robust point-to-surface ICP against them.

    A scan point's residual is its signed normal distance to the nearest sample's tangent plane
    or, when its nearest sample is an outline sample, its outward overhang beyond the outline (if
    it lies outward). The overhang term is what fixes the slide along a cylinder's axis and the
    turn about a dome's axis, which point-to-plane residuals alone leave free; the normal distance
    of a point nearest the outline does not count, since the mattress's sides, below the outline,
    are not the top face.
    """

    def __init__(self, vertices, faces, n_samples, seed):
        from pykdtree.kdtree import KDTree

        pts, nrm, _ = sample_surface(vertices, faces, n_samples, seed=seed)
        self.spacing = float(np.sqrt(mesh_area(vertices, faces) / len(pts)))
        self.n_interior = len(pts)   # the first samples; the outline's follow
        bpts, bnrm, bout = outline_samples(vertices, faces, self.spacing / 4)
        self.pts = np.vstack([pts, bpts])
        self.nrm = np.vstack([nrm, bnrm])
        self.out = np.vstack([np.zeros_like(pts), bout])   # zero: an interior sample
        self.tree = KDTree(self.pts)

    def residuals(self, p, bound=np.inf):
        """Offsets ``e = p - q`` to the nearest samples (N, 3), their normals (N, 3), outward directions (N, 3)
        and whether a sample lies within ``bound`` (N,)."""
        d, idx = self.tree.query(p, k=1, distance_upper_bound=bound)
        found = np.isfinite(d)
        idx = np.where(found, idx, 0)
        return p - self.pts[idx], self.nrm[idx], self.out[idx], found

    def distances(self, p):
        """Signed normal distance (N,) of ``p`` from the surface (m), and whether each projects inside its outline."""
        e, n, o, _ = self.residuals(p)
        r = np.einsum("ij,ij->i", e, n)
        lateral = np.sqrt(np.maximum(np.einsum("ij,ij->i", e, e) - r ** 2, 0.0))
        return r, (lateral < 2 * self.spacing) & ~np.any(o != 0, axis=1)

    def inliers(self, pts, rot, trans, k):
        _, _, _, found = self.residuals(pts @ rot.T + trans, bound=k)
        return found

    def icp(self, pts, rot, trans, ladder, *, normals, max_iter_level=_MAX_ITER_LEVEL, tol=_TOL):
        """Tukey-weighted point-to-surface ICP, annealed over the Tukey scales ``ladder``.

        A level ends when a step moves no point by more than ``tol`` times the points' span. On the
        levels within ``_NORMAL_GATE_LEVELS`` of the last, a point whose own normal (``normals``, sign
        arbitrary) is more than ``_MAX_NORMAL_DEG`` from the reference's does not count: the
        mattress's sides and the faces of a box are not the top face.
        """
        rot, trans = np.array(rot, dtype=float), np.array(trans, dtype=float)
        span = float(np.ptp(pts, axis=0).max())
        tol = tol * span
        it, converged = 0, False
        gate_from = ladder[-1] * 2 ** _NORMAL_GATE_LEVELS
        for k in ladder:
            converged = False
            for _ in range(max_iter_level):
                it += 1
                step = self._step(pts @ rot.T + trans, k, normals @ rot.T if k < gate_from else None)
                if step is None:
                    break
                d_rot, d_t, angle = step
                rot, trans = d_rot @ rot, d_rot @ trans + d_t
                if np.linalg.norm(d_t) + span * angle < tol:
                    converged = True
                    break
            if it >= _MAX_ITER:
                break
        return rot, trans, it, converged

    def _step(self, p, k, normals=None):
        """One Gauss-Newton step of the robust objective: (rotation, translation, angle) increment, or None."""
        e, n, o, found = self.residuals(p, bound=k)
        if normals is not None:
            found &= np.abs(np.einsum("ij,ij->i", normals, n)) > np.cos(np.radians(_MAX_NORMAL_DEG))
        if np.count_nonzero(found) < 6:
            return None
        e, n, o, p = e[found], n[found], o[found], p[found]
        w = (1 - np.einsum("ij,ij->i", e, e) / k ** 2) ** 2
        c = np.average(p, axis=0, weights=w)
        q = p - c  # about the weighted centre: a well-conditioned 6x6 system
        edge = np.any(o != 0, axis=1)   # nearest to the outline: the overhang, not the height, counts
        over = np.einsum("ij,ij->i", e, o)
        hang = over > 0
        inner = ~edge
        rows = np.vstack([np.hstack([np.cross(q[inner], n[inner]), n[inner]]),
                          np.hstack([np.cross(q[hang], o[hang]), o[hang]])])
        res = np.concatenate([np.einsum("ij,ij->i", e[inner], n[inner]), over[hang]])
        wr = np.concatenate([w[inner], w[hang]])
        a = np.einsum("i,ij,ik->jk", wr, rows, rows)
        b = np.einsum("i,ij,i->j", wr, rows, res)
        # a tiny damping: directions no residual sees (a partial scan's slide along a cylinder) stay put
        x = -np.linalg.solve(a + 1e-9 * np.trace(a) * np.eye(6), b)
        d_rot = rodrigues(x[:3])
        return d_rot, c + x[3:] - d_rot @ c, float(np.linalg.norm(x[:3]))


def outline_samples(vertices, faces, step):
    """Points every ``step`` along the mesh's outline, with the surface normal and the outward in-plane direction."""
    v, f = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    third = np.concatenate([f[:, 2], f[:, 0], f[:, 1]])
    key = np.sort(edges, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    lone = count[inv.ravel()] == 1
    a, b, c = v[edges[lone, 0]], v[edges[lone, 1]], v[third[lone]]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    out = np.cross(b - a, normal)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    out *= np.sign(np.einsum("ij,ij->i", out, a - c))[:, None]   # away from the face's third vertex
    length = np.linalg.norm(b - a, axis=1)
    counts = np.maximum(1, np.ceil(length / step).astype(int))
    owner = np.repeat(np.arange(len(a)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + 0.5) / counts[owner]
    return a[owner] + t[:, None] * (b - a)[owner], normal[owner], out[owner]


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def rodrigues(w):
    angle = float(np.linalg.norm(w))
    if angle < 1e-15:
        return np.eye(3)
    k = _skew(w / angle)
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
