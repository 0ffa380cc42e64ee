"""The registered scan against a reference surface: signed normal deviation per scan point and per vertex.

Each registered scan point is given its signed distance along the
reference's normal (positive on the side the faces' winding points to: above
the top face) from the nearest of points sampled densely on the reference
with interpolated normals; points that project outside the reference's
outline or lie farther than ``max_distance`` from it (clutter, the floor, the
sides) are not the surface and are left out. A vertex's deviation is the mean
of those of the scan points whose foot point on the reference lies within
``radius`` of it, NaN where the scan has fewer than three (a hole, the part not scanned: a stray
point above a hole is not the surface).
The same map serves both references of ``airmat correct``: Ŝ (the design's
approximation) and the prediction (the check's median inflated top face).
Lengths in metres inside; the figure and the PLY file are in millimetres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat import palette
from airmat.atomic import atomic_write_bytes
from airmat.errors import InputError
from airmat.figures import new_figure
from airmat.summary import Summarized, mm
from airmat.units import M_TO_MM

__all__ = ["DeviationMap", "deviation_map", "deviation_figure", "write_deviation_ply"]

#: fewest scan points a vertex's value needs: a stray point over a hole is not the surface
_MIN_POINTS = 3
#: colour of a vertex the scan does not cover, in the PLY file (RGBA)
_NO_DATA_RGBA = (160, 160, 160, 255)


@dataclass(frozen=True, repr=False)
class DeviationMap(Summarized):
    """Signed normal deviation of a registered scan from a reference surface.

    Attributes
    ----------
    per_point : ndarray of shape (N,)
        Signed deviation of each scan point (m); NaN for a point that is not on the surface (outside
        the outline or farther than ``max_distance``).
    per_vertex : ndarray of shape (V,)
        Mean deviation of the scan points near each reference vertex (m); NaN where there are fewer than three.
    rms, max, p95 : float
        RMS, largest absolute value and 95th percentile of the absolute value of ``per_vertex`` over
        the covered vertices (m).
    coverage : float
        Share of the reference's vertices with a value.
    rms_pct_diag : float
        ``rms`` as a percentage of the reference's bounding-box diagonal.
    radius : float
        Neighbourhood radius of a vertex (m).
    """

    per_point: np.ndarray
    per_vertex: np.ndarray
    rms: float
    max: float
    p95: float
    coverage: float
    rms_pct_diag: float
    radius: float

    def _summary(self):
        return "DeviationMap", [("rms", mm(self.rms)), ("max", mm(self.max)), ("p95", mm(self.p95)),
                                ("coverage", f"{100 * self.coverage:.0f} %"),
                                ("rms", f"{self.rms_pct_diag:.2f} % of the diagonal")]


def deviation_map(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, *, radius: float | None = None,
                  max_distance: float = 0.05, n_samples: int = 200_000, seed=0) -> DeviationMap:
    """Signed normal deviation of registered scan points from a reference mesh.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        The scan in the reference's frame (m): ``Registration.apply(scan)``.
    vertices : ndarray of shape (V, 3)
        The reference mesh (m): Ŝ's ``approx.xyz`` or the predicted inflated top face.
    faces : ndarray of shape (F, 3)
        Its triangles, consistently oriented (the deviation is positive along their normal).
    radius : float, optional
        A vertex takes the mean of the scan points whose foot point lies within this distance (m).
        Default: the mean edge length of the mesh.
    max_distance : float
        Scan points farther from the reference are not the surface (m).
    n_samples : int
        Points sampled on the reference.
    seed : int
        Seed of the sampling.

    Returns
    -------
    DeviationMap

    Examples
    --------
    >>> x, y = np.meshgrid(np.linspace(0, 0.8, 9), np.linspace(0, 0.7, 8), indexing="ij")
    >>> v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    >>> a = (np.arange(8)[:, None] * 8 + np.arange(7)).ravel()
    >>> f = np.vstack([np.column_stack([a, a + 8, a + 9]), np.column_stack([a, a + 9, a + 1])])
    >>> scan = np.column_stack([np.random.default_rng(0).uniform(0, [0.8, 0.4], (20000, 2)), np.full(20000, 2e-3)])
    >>> dev = deviation_map(scan, v, f)
    >>> round(float(np.nanmean(dev.per_vertex)) * 1e3, 3), dev.coverage   # rows of vertices up to y = 0.5 m
    (2.0, 0.75)
    """
    from pykdtree.kdtree import KDTree

    from airmat.asbuilt.spatial_order import inverse, spatial_order
    from airmat.asbuilt.surface_icp import sample_surface

    p = _shape_check(points, "points")
    v = _shape_check(vertices, "vertices")
    f = np.asarray(faces, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"faces must have shape (F, 3), got {f.shape}")
    if radius is None:
        radius = float(np.linalg.norm(v[f[:, 1]] - v[f[:, 0]], axis=1).mean())
    samples, normals, _ = sample_surface(v, f, n_samples, seed=seed)
    spacing = np.sqrt(_area(v, f) / n_samples)
    order = spatial_order(p)            # the same answers, 2-3x sooner on a scan in file order
    dist, idx = KDTree(samples).query(p[order], k=1, distance_upper_bound=max_distance + 2 * spacing)
    back = inverse(order)
    dist, idx = dist[back], idx[back]
    found = np.isfinite(dist)
    idx = np.where(found, idx, 0)
    e = p - samples[idx]
    signed = np.einsum("ij,ij->i", e, normals[idx])
    lateral = np.sqrt(np.maximum(np.einsum("ij,ij->i", e, e) - signed ** 2, 0.0))
    # a point beyond the outline has its nearest sample on the outline, off to the side
    on = found & (np.abs(signed) <= max_distance) & (lateral < 2 * spacing)
    per_point = np.where(on, signed, np.nan)
    per_vertex = _vertex_means(v, p[on] - signed[on, None] * normals[idx[on]], signed[on], radius)
    return _summarize(per_point, per_vertex, v, radius)


def _shape_check(a, what):
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{what} must have shape (N, 3), got {a.shape}")
    return a


def _area(v, f) -> float:
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def _vertex_means(vertices, feet, values, radius, k=32, min_points=_MIN_POINTS):
    """(V,) mean of ``values`` over the (up to ``k`` nearest) ``feet`` within ``radius`` of each vertex; NaN where
    fewer than ``min_points`` are."""
    from pykdtree.kdtree import KDTree

    if len(feet) == 0:
        return np.full(len(vertices), np.nan)
    k = min(k, len(feet))
    d, idx = KDTree(feet).query(vertices, k=k, distance_upper_bound=radius)
    d, idx = d.reshape(len(vertices), k), idx.reshape(len(vertices), k)
    hit = np.isfinite(d)
    vals = np.where(hit, values[np.where(hit, idx, 0)], 0.0)
    n = hit.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n >= min_points, vals.sum(axis=1) / n, np.nan)


def _summarize(per_point, per_vertex, vertices, radius) -> DeviationMap:
    covered = per_vertex[np.isfinite(per_vertex)]
    diag = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    if covered.size:
        rms, big, p95 = (float(np.sqrt(np.mean(covered ** 2))), float(np.abs(covered).max()),
                         float(np.percentile(np.abs(covered), 95)))
    else:
        rms = big = p95 = np.nan
    return DeviationMap(per_point=per_point, per_vertex=per_vertex, rms=rms, max=big, p95=p95,
                        coverage=covered.size / len(per_vertex), rms_pct_diag=100 * rms / diag, radius=float(radius))


def deviation_figure(dev: DeviationMap, vertices: np.ndarray, faces: np.ndarray, *, uv: np.ndarray | None = None,
                     title: str = "the scan against the reference"):
    """A top view of the reference coloured by the scan's deviation (mm), grey where the scan has no point.

    Parameters
    ----------
    dev : DeviationMap
    vertices : ndarray of shape (V, 3)
        The reference mesh (m).
    faces : ndarray of shape (F, 3)
    uv : ndarray of shape (V, 2), optional
        The vertices on Ω (m), as the check's deviation.png draws Ŝ; default: the vertices projected
        on their best-fit plane.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    v, f = np.asarray(vertices, dtype=float), np.asarray(faces)
    xy = _plan(v) if uv is None else np.asarray(uv, dtype=float)
    xy = xy * M_TO_MM
    fig = new_figure((8, 6))
    ax = fig.subplots()
    ax.triplot(xy[:, 0], xy[:, 1], f, color="#DDDDDD", lw=0.3)
    covered = np.all(np.isfinite(dev.per_vertex[f]), axis=1)
    if covered.any():
        lim = max(float(np.nanmax(np.abs(dev.per_vertex))) * M_TO_MM, 1e-3)
        tpc = ax.tripcolor(xy[:, 0], xy[:, 1], f[covered], np.nan_to_num(dev.per_vertex) * M_TO_MM,
                           shading="gouraud", cmap=palette.DEVIATION.matplotlib, vmin=-lim, vmax=lim)
        fig.colorbar(tpc, ax=ax, label="signed deviation of the scan along the normal (mm)")
    ax.set_aspect("equal")
    ax.set_xlabel("u (mm)" if uv is not None else "x (mm)")
    ax.set_ylabel("v (mm)" if uv is not None else "y (mm)")
    ax.set_title(f"{title}: RMS {dev.rms * M_TO_MM:.1f} mm, max {dev.max * M_TO_MM:.1f} mm, "
                 f"95 % {dev.p95 * M_TO_MM:.1f} mm\n{100 * dev.coverage:.0f} % of the vertices covered "
                 "(grey: no scan point)", fontsize=9)
    fig.tight_layout()
    return fig


def _plan(v):
    """The vertices in the principal axes of their best-fit plane (m)."""
    c = v - v.mean(axis=0)
    vt = np.linalg.svd(c, full_matrices=False)[2]
    return c @ vt[:2].T


def write_deviation_ply(path, dev: DeviationMap, vertices: np.ndarray, faces: np.ndarray) -> None:
    """The reference mesh (mm) with vertex property ``deviation_mm`` (NaN: no scan) and colours by it.

    Written atomically (:func:`airmat.atomic.atomic_write_bytes`), binary PLY.
    """
    import trimesh
    from matplotlib import colormaps

    v = np.asarray(vertices, dtype=float)
    mesh = trimesh.Trimesh(v * M_TO_MM, np.asarray(faces), process=False)
    val = dev.per_vertex * M_TO_MM
    lim = max(float(np.nanmax(np.abs(val))) if np.isfinite(val).any() else 0.0, 1e-3)
    rgba = (colormaps[palette.DEVIATION.matplotlib]((np.nan_to_num(val) + lim) / (2 * lim)) * 255).round()
    rgba = rgba.astype(np.uint8)
    rgba[~np.isfinite(val)] = _NO_DATA_RGBA
    mesh.visual.vertex_colors = rgba
    mesh.vertex_attributes["deviation_mm"] = val.astype(np.float32)
    atomic_write_bytes(path, trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=True))
