"""Register a scan of the built mattress onto its predicted top face: any frame, m or mm, floor and clutter.

The scan's unit is read from its size: its robust extent (the diagonal of the
1 %..99 % percentile box along its principal axes) is compared with the
reference's; about 1x means the scan is in the reference's unit, about 1/1000x
that a file in metres was read as millimetres (``scale`` 1000), anything else
is refused. The floor is found on a voxel grid by the calibration's support
plane search (:func:`airmat.calib.support_plane.find_support_planes`), which
only accepts a plane the rest of the scene lies above (a curved top face's
tangent slab or a secant through it is not a support) and gives a flat
specimen back; its points are dropped. The global start needs no guess: the
principal axes of the largest connected part of what remains are matched to the
reference's in the 8 proper ways (two orders of the in-plane axes, four sign
choices), and each start is refined by ICP. The best start (most points within
``inlier_distance``) is refined on every remaining voxel point by a robust ICP:
point-to-plane residuals against points sampled densely on the reference with
interpolated normals, plus the overhang of points beyond the reference's
outline (which holds the slide along a cylinder's axis and the turn about a
dome's axis: point-to-plane alone leaves them free, only the outline fixes
them), weighted by Tukey's biweight with a scale annealed from a quarter of the
reference's diagonal down to ``inlier_distance``.

A scan that does not fit is refused: fewer than ``min_inlier_share`` of the
points over the predicted shape within ``inlier_distance`` of it, an RMS above
``max_rms``, or less than ``min_coverage`` of the shape seen. A shape with a
symmetry (a rectangle of a cylinder, a saddle, a dome) fits equally well in
several poses; ``n_equivalent`` counts them, and the scan then needs a marker
or a start (``init``) to tell them apart. Lengths in metres.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.calib.point_normals import normals_knn
from airmat.errors import InputError
from airmat.summary import Summarized

__all__ = ["Registration", "register", "robust_extent", "sample_surface", "ALTERNATIVE_SHARE"]

log = logging.getLogger(__name__)

#: extent ratios (reference / scan) accepted for each unit factor: a scan may cover part of the
#: mattress (smaller) or hold the floor around it (larger)
_UNIT_RATIOS = {1.0: (0.2, 5.0), 1000.0: (200.0, 5000.0)}
#: scan points the final ICP works on (a random subset of larger scans)
_N_FINE = 40_000
#: scan points the starts' ICP works on, its iterations per level and its step tolerance (share of the span)
_N_START, _START_ITER_LEVEL, _START_TOL = 1500, 10, 1e-5
#: points sampled on the reference for the starts' ICP
_N_COARSE_SAMPLES = 20_000
#: ICP iterations per annealing level and in total
_MAX_ITER_LEVEL, _MAX_ITER = 50, 250
#: a level of the final ICP ends when a step moves no point by more than this share of the span
#: (10 µm on a 1 m mattress: 1 % of the 1 mm the registration must reach)
_TOL = 1e-5
#: a start's pose is an alternative (:attr:`Registration.alternatives`) when it keeps at least this share of the
#: best start's inliers: on vault1 built at Δ = 22, d = 75 mm (its design's medians 17.9, 69.8 mm) with ±3 mm
#: ties (``docs/guide/correct.md``'s example) the true pose's start holds 14 488 inliers within 30 mm of the
#: median prediction, the half-turned one 14 637 (99 %), the next distinct pose 6 851 (47 %)
ALTERNATIVE_SHARE = 0.9
#: the scan normal's largest angle from the reference's (degrees) on the last levels of the annealing
_MAX_NORMAL_DEG, _NORMAL_GATE_LEVELS = 30.0, 2


@dataclass(frozen=True, repr=False)
class Registration(Summarized):
    """A scan registered onto a reference surface: ``x_ref = rotation @ (scale * x_scan) + translation``.

    Attributes
    ----------
    rotation : ndarray of shape (3, 3)
        Proper rotation.
    translation : ndarray of shape (3,)
        Translation (m, in the reference's frame).
    scale : float
        The unit factor detected: 1 (the scan is in the reference's unit) or 1000 (a scan in metres
        read as millimetres).
    rms : float
        RMS of the inliers' signed distances to the reference (m).
    inlier_share : float
        Share of the scan points over the reference (projecting inside its outline) that lie within
        the inlier distance of it.
    coverage : float
        Share of the reference's area that has a registered scan point near it.
    n_used : int
        Voxel points the final ICP used (the inliers).
    converged : bool
        Whether the last ICP level stopped on its step tolerance.
    iterations : int
        ICP iterations of the chosen start, all levels.
    n_equivalent : int
        Starts that ended in a distinct pose fitting as well as the best: 1 when the pose is unique,
        more on a symmetric shape.
    message : str
        What was detected and removed, in words.
    alternatives : tuple of (ndarray of shape (3, 3), ndarray of shape (3,))
        Other distinct poses (rotation, translation (m), after the unit factor) whose starts hold at least
        :data:`ALTERNATIVE_SHARE` of the best one's inliers, most inliers first: starts (``init``) to try
        when the pose kept proves wrong later (a built mattress that differs from its prediction can fit
        the half-turned pose of a near-symmetric shape slightly better than the true one).
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    rms: float
    inlier_share: float
    coverage: float
    n_used: int
    converged: bool
    iterations: int
    n_equivalent: int
    message: str
    alternatives: tuple = ()

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Scan points (N, 3), in the scan's unit, mapped into the reference's frame (m)."""
        return (self.scale * np.asarray(points, dtype=float)) @ self.rotation.T + self.translation

    def _summary(self):
        return "Registration", [("rms", f"{self.rms * 1e3:.2f} mm"), ("inliers", f"{100 * self.inlier_share:.0f} %"),
                                ("coverage", f"{100 * self.coverage:.0f} %"), ("scale", f"{self.scale:g}"),
                                ("converged", self.converged), ("poses", self.n_equivalent)]


def robust_extent(points: np.ndarray) -> float:
    """Diagonal of the 1 %..99 % percentile box of ``points`` along their principal axes (their unit).

    Examples
    --------
    >>> pts = np.random.default_rng(0).uniform(0, 1, (5000, 3)) * [0.8, 0.7, 0.0]   # 1.063 m, 2 % in the tails
    >>> round(robust_extent(pts), 2), round(robust_extent(pts @ [[0, 1, 0], [1, 0, 0], [0, 0, 1]] * 1e3), -1)
    (1.09, 1090.0)
    """
    pts = np.asarray(points, dtype=float)
    pts = pts[:: max(1, len(pts) // 200_000)]
    local = pts - pts.mean(axis=0)
    _, _, vt = np.linalg.svd(local[:: max(1, len(local) // 20_000)], full_matrices=False)
    lo, hi = np.percentile(local @ vt.T, [1, 99], axis=0)
    return float(np.linalg.norm(hi - lo))


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


def register(scan_points: np.ndarray, reference_vertices: np.ndarray, reference_faces: np.ndarray, *, seed=0,
             units: str = "auto", voxel: float | None = None, inlier_distance: float = 0.015,
             min_inlier_share: float = 0.8, max_rms: float | None = None, min_coverage: float = 0.5,
             n_reference_samples: int = 200_000, remove_floor: bool = True,
             init: tuple | None = None, local: bool = False, name: str = "the scan") -> Registration:
    """Register a scan onto a reference surface (the predicted inflated top face), robustly.

    Parameters
    ----------
    scan_points : ndarray of shape (N, 3)
        The scan as read (:func:`airmat.calib.scan_io.read_scan`: metres, or metres / 1000 for a
        file in metres read as millimetres), in any frame, with floor and clutter.
    reference_vertices : ndarray of shape (V, 3)
        The reference mesh (m).
    reference_faces : ndarray of shape (F, 3)
        Its triangles, consistently oriented.
    seed : int
        Seed of the reference sampling and the floor's RANSAC.
    units : {"auto", "same", "m-as-mm"}
        ``"auto"`` detects the unit factor from the extents; the others force 1 or 1000.
    voxel : float, optional
        Voxel edge (m) the scan is downsampled to. Default: 1/150 of the reference's diagonal.
    inlier_distance : float
        A point within this distance of the reference is an inlier (m); also the final Tukey scale.
    min_inlier_share, min_coverage : float
        Refuse the scan below these shares (see :class:`Registration`).
    max_rms : float, optional
        Refuse the scan above this inlier RMS (m). Default: ``inlier_distance / 3`` (points spread evenly
        within ``inlier_distance`` have an RMS of ``inlier_distance / sqrt(3)``).
    n_reference_samples : int
        Points sampled on the reference.
    remove_floor : bool
        Search the support plane and drop its points.
    init : (rotation, translation), optional
        A start (after the unit factor) instead of the principal-axes starts.
    local : bool
        With ``init``: no annealed search from it (whose first Tukey scale, a quarter of the diagonal, lets a
        1 500-point subset carry the pose centimetres away) and no final level at twice ``inlier_distance`` (whose
        optimum lies degrees from the last one's), only the final ICP at ``inlier_distance``. For a start within
        about ``inlier_distance`` of the pose: the same scan registered before onto a nearby reference.
    name : str
        The scan's name in error messages.

    Returns
    -------
    Registration

    Raises
    ------
    airmat.errors.InputError
        Shapes wrong, unit ambiguous, or the scan does not match the reference (the numbers in
        ``err.data``).
    """
    scan = _check_points(scan_points, "scan_points")
    ref_v = _check_points(reference_vertices, "reference_vertices")
    ref_f = np.asarray(reference_faces)
    if ref_f.ndim != 2 or ref_f.shape[1] != 3:
        raise InputError(f"reference_faces must have shape (F, 3), got {ref_f.shape}")
    max_rms = inlier_distance / 3 if max_rms is None else float(max_rms)
    fit = _Fit(ref_v, ref_f, n_reference_samples, seed)
    diag = float(np.linalg.norm(ref_v.max(axis=0) - ref_v.min(axis=0)))
    scale = _unit_factor(scan, fit.pts, units, name)
    voxel = diag / 150 if voxel is None else float(voxel)
    cloud = _prepare(scan * scale, voxel, remove_floor=remove_floor, seed=seed, name=name)
    pts, normals = cloud.voxels, cloud.voxel_normals
    starts = [init] if init is not None else _pca_starts(_largest_part(pts, 3 * voxel), fit.pts)
    ladder = _ladder(0.25 * diag, inlier_distance)
    local = init is not None and local
    if local:
        trials = [(np.asarray(init[0], dtype=float), np.asarray(init[1], dtype=float), 0, True)]
    else:
        pick = np.random.default_rng(seed).permutation(len(pts))[:_N_START]
        coarse = _Fit(ref_v, ref_f, _N_COARSE_SAMPLES, seed)   # the starts need no fine reference
        trials = [coarse.icp(pts[pick], *start, ladder, normals=normals[pick], max_iter_level=_START_ITER_LEVEL,
                             tol=_START_TOL) for start in starts]
    inliers = np.array([fit.inliers(pts, r, t, inlier_distance) for r, t, *_ in trials])
    best = int(np.argmax(inliers.sum(axis=1)))
    n_eq = _n_equivalent(trials, inliers, best, pts, inlier_distance)
    alternatives = _alternatives(trials, inliers.sum(axis=1), best, pts, inlier_distance)
    # the final fit on scan points, not voxel centroids: a centroid lies up to half a voxel inside the
    # mattress's outline, which would leave the slide the outline fixes that much slack
    rot, trans, iters, converged = fit.icp(cloud.points, *trials[best][:2], ladder[-1:] if local else ladder[-2:],
                                           normals=cloud.normals)
    reg = Registration(rotation=rot, translation=trans, scale=scale, converged=converged,
                       iterations=iters + trials[best][2], n_equivalent=n_eq, message=cloud.message,
                       alternatives=alternatives,
                       **_assess(fit, cloud.points @ rot.T + trans, inlier_distance, voxel))
    _refuse_mismatch(reg, name, inlier_distance, min_inlier_share, max_rms, min_coverage)
    if n_eq > 1:
        log.warning("%s: %d poses fit the reference equally well (a symmetric shape): the one kept may be "
                    "any of them; mark the scan or give a start", name, n_eq)
    return reg


@dataclass(frozen=True)
class _Cloud:
    """The scan off the floor: voxel centroids and a random subset of its points, with normals."""

    voxels: np.ndarray
    voxel_normals: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    message: str


def _prepare(scan, voxel, *, remove_floor, seed, name) -> _Cloud:
    """Voxel centroids (their normals from their 12 neighbours), the floor removed, and up to
    ``_N_FINE`` scan points off the floor, each with its voxel's normal."""
    from airmat.calib.voxel_grid import voxel_moments

    inverse, _, pts, _ = voxel_moments(scan, voxel)
    normals = normals_knn(pts, 12)
    keep = _off_floor(pts, normals, voxel, seed) if remove_floor else np.ones(len(pts), dtype=bool)
    if np.count_nonzero(keep) < 50:
        raise InputError(f"{name} holds too few points off the floor ({np.count_nonzero(keep)} voxels of "
                         f"{voxel * 1e3:.1f} mm): is it a scan of the mattress?", n_points=int(np.count_nonzero(keep)))
    raw = np.flatnonzero(keep[inverse])
    raw = np.sort(np.random.default_rng(seed).permutation(raw)[:_N_FINE])
    message = (f"{len(scan)} points, {len(pts)} voxels of {voxel * 1e3:.1f} mm, "
               f"{np.count_nonzero(~keep)} on or below the floor")
    return _Cloud(voxels=pts[keep], voxel_normals=normals[keep], points=scan[raw], normals=normals[inverse[raw]],
                  message=message)


def _check_points(a, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or len(a) < 3:
        raise InputError(f"{what} must have shape (N, 3) with N >= 3, got {a.shape}")
    finite = np.isfinite(a).all(axis=1)
    return a if finite.all() else a[finite]


def _area(v, f) -> float:
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def _unit_factor(scan, ref_pts, units: str, name: str) -> float:
    """1 or 1000, from the ratio of the robust extents; refuse a ratio neither explains."""
    if units == "same":
        return 1.0
    if units == "m-as-mm":
        return 1000.0
    if units != "auto":
        raise InputError(f"units must be 'auto', 'same' or 'm-as-mm', got {units!r}")
    e_scan, e_ref = robust_extent(scan), robust_extent(ref_pts)
    ratio = e_ref / max(e_scan, np.finfo(float).tiny)
    for factor, (lo, hi) in _UNIT_RATIOS.items():
        if lo <= ratio <= hi:
            return factor
    raise InputError(f"{name}'s size does not tell its unit: its extent is {e_scan * 1e3:.4g} mm, the predicted "
                     f"shape's {e_ref * 1e3:.4g} mm (ratio {ratio:.3g}; about 1 for a scan in millimetres, about "
                     "1000 for one in metres); give the scan's unit or crop it to the mattress",
                     scan_extent=e_scan, reference_extent=e_ref, ratio=ratio)


def _off_floor(pts, normals, voxel, seed) -> np.ndarray:
    """(N,) bool: the voxel points neither on a support plane (the floor) nor below it.

    :func:`~airmat.calib.support_plane.find_support_planes` accepts only a plane the rest of the
    scene lies on one side of and rejects the tangent slab of a curved surface; a flat top face
    it gives back as the specimen. What lies beyond the plane, away from most points, goes too.
    """
    from airmat.calib.support_plane import find_support_planes

    found = find_support_planes(pts, threshold=voxel, normals=normals, seed=seed)
    keep = np.ones(len(pts), dtype=bool)
    for plane in found.supports:
        d = plane.distance(pts)
        far = np.abs(d) > 3 * voxel
        side = np.sign(np.median(d[far])) if far.any() else 1.0
        keep &= d * side > voxel
    return keep


def _largest_part(pts, eps):
    """The largest connected part of ``pts`` at distance ``eps`` (the mattress without the clutter beside it)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts).query_pairs(eps, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts)))
    _, label = connected_components(graph, directed=False)
    return pts[label == np.argmax(np.bincount(label))]


def _pca_starts(src, ref):
    """The 8 proper rotations taking the principal axes of ``src`` onto those of ``ref``, with translations."""
    cs, cr = src.mean(axis=0), ref.mean(axis=0)
    es = np.linalg.svd(src - cs, full_matrices=False)[2]  # rows: axes by decreasing variance
    er = np.linalg.svd(ref[:: max(1, len(ref) // 20_000)] - cr, full_matrices=False)[2]
    starts = []
    for order in ((0, 1, 2), (1, 0, 2)):
        for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            a = es[list(order)] * np.array([s1, s2, 1.0])[:, None]
            a[2] = np.cross(a[0], a[1])
            rot = er.T @ a
            rot = rot if np.linalg.det(rot) > 0 else er.T @ (a * [[1], [1], [-1]])
            starts.append((rot, cr - rot @ cs))
    return starts


def _ladder(k0: float, k_final: float) -> list:
    """Tukey scales from ``k0`` halving down to ``k_final``."""
    n = max(1, int(np.ceil(np.log2(max(k0 / k_final, 1.0)))))
    return list(k_final * 2.0 ** np.arange(n, -1, -1))


class _Fit:
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
        self.spacing = float(np.sqrt(_area(vertices, faces) / len(pts)))
        self.n_interior = len(pts)   # the first samples; the outline's follow
        bpts, bnrm, bout = _outline_samples(vertices, faces, self.spacing / 4)
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
        d_rot = _rodrigues(x[:3])
        return d_rot, c + x[3:] - d_rot @ c, float(np.linalg.norm(x[:3]))


def _outline_samples(vertices, faces, step):
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


def _rodrigues(w):
    angle = float(np.linalg.norm(w))
    if angle < 1e-15:
        return np.eye(3)
    k = _skew(w / angle)
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _same_pose(pts, a, b, tol) -> bool:
    """Whether the poses ``a`` and ``b`` ((rotation, translation) each) place every point of ``pts`` within ``tol``
    of each other."""
    return bool(np.abs(pts @ (a[0] - b[0]).T + (a[1] - b[1])).max() < tol)


def _n_equivalent(trials, inliers, best, pts, inlier_distance) -> int:
    """Distinct poses among the starts that fit as well as the best (1: the pose is unique).

    A pose fits as well when its inliers (``inliers[i]``, a mask over ``pts``) are as many as the
    best's within the scatter of a paired count (three standard deviations of the points that are
    inliers of one pose only); two poses are the same when they place every point within
    ``inlier_distance`` of each other.
    """
    poses = []
    for (r, t, *_), mask in zip(trials, inliers):
        only_best = np.count_nonzero(inliers[best] & ~mask)
        only_this = np.count_nonzero(mask & ~inliers[best])
        if only_best - only_this > 3 * np.sqrt(only_best + only_this) + 1:
            continue
        if not any(_same_pose(pts, (r, t), other, inlier_distance) for other in poses):
            poses.append((r, t))
    return max(1, len(poses))


def _alternatives(trials, counts, best, pts, inlier_distance) -> tuple:
    """The distinct poses other than the best's among the starts with at least :data:`ALTERNATIVE_SHARE` of its
    inlier count ``counts[best]``, most inliers first: ((rotation, translation), ...). Two poses are the same
    when they place every point of ``pts`` within ``inlier_distance`` of each other."""
    kept = [trials[best][:2]]
    for i in np.argsort(-counts, kind="stable"):
        r, t = trials[i][:2]
        if counts[i] < ALTERNATIVE_SHARE * counts[best]:
            break
        if not any(_same_pose(pts, (r, t), other, inlier_distance) for other in kept):
            kept.append((r, t))
    return tuple(kept[1:])


def _assess(fit, p, inlier_distance, voxel) -> dict:
    """RMS, inlier share and coverage of the registered voxel points ``p`` (N, 3)."""
    from pykdtree.kdtree import KDTree

    r, over = fit.distances(p)
    inl = over & (np.abs(r) < inlier_distance)
    rms = float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else np.inf
    probe = fit.pts[:fit.n_interior:10]
    near = KDTree(p[inl]).query(probe, distance_upper_bound=1.5 * voxel)[0] if np.count_nonzero(inl) > 1 else \
        np.full(len(probe), np.inf)
    return {"rms": rms, "inlier_share": float(np.count_nonzero(inl) / max(np.count_nonzero(over), 1)),
            "coverage": float(np.mean(np.isfinite(near))), "n_used": int(np.count_nonzero(inl))}


def _refuse_mismatch(reg, name, inlier_distance, min_share, max_rms, min_coverage):
    data = {"inlier_share": reg.inlier_share, "rms": reg.rms, "coverage": reg.coverage}
    mm = inlier_distance * 1e3
    if reg.inlier_share < min_share:
        raise InputError(f"{name} does not match this design: only {100 * reg.inlier_share:.0f} % of its points over "
                         f"the predicted shape lie within {mm:.0f} mm of it (at least {100 * min_share:.0f} % "
                         "needed): a scan of another design, or of the wrong side?", **data)
    if reg.rms > max_rms:
        raise InputError(f"{name} does not match this design: its points within {mm:.0f} mm of the predicted shape "
                         f"scatter by {reg.rms * 1e3:.1f} mm RMS (at most {max_rms * 1e3:.1f} mm): a scan of "
                         "another design, or a noisy scan?", **data)
    if reg.coverage < min_coverage:
        raise InputError(f"{name} covers only {100 * reg.coverage:.0f} % of the predicted shape (at least "
                         f"{100 * min_coverage:.0f} % needed): scan more of the mattress's top face, or it is not "
                         "this design", **data)
