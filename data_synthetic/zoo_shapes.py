"""The zoo's building blocks: parametric surfaces in a local frame, two triangulations, a rigid motion.

Every surface is a map ``fn(s, t) -> (k, 3)`` (m) over a parameter rectangle whose
parameters are (close to) arc lengths, with X_s × X_t pointing "up" (+z at the
centre of the rectangle): the side the mattress's top face goes. Curvatures are
signed as in :mod:`airmat.synthetic.targets`: κ > 0 where the surface bends away
from the up normal (a vault seen from above).

:func:`mesh_patch` triangulates a map uniformly (Ω's alternating grid,
:func:`airmat.geometry.grid.parametric_mesh`) or irregularly (a jittered, graded
point set triangulated by Delaunay in the parameter plane, seeded);
:func:`rigid` moves a mesh by a rotation about the origin then an offset.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.spatial import Delaunay
from scipy.spatial.transform import Rotation

from airmat.geometry.grid import cell_count, parametric_mesh

__all__ = ["cylinder_map", "cone_map", "graph_map", "profile_map", "plane_curve", "curvature_profile", "helicoid_map",
           "sphere_map", "mesh_patch", "rigid", "rotation"]


def cylinder_map(radius: float):
    """Circular cylinder, axis along x at height −R, crown on the x axis: κ = 1/R across, 0 along."""
    r = float(radius)
    return lambda s, t: np.column_stack([s, r * np.sin(t / r), r * np.cos(t / r) - r])


def cone_map(r_crown: float, half_angle: float):
    """Circular cone about the x axis, radius r(x) = r_crown + x tan(half_angle); t: arc length at x = 0."""
    rc, c = float(r_crown), float(np.tan(half_angle))

    def fn(s, t):
        rad, phi = rc + c * s, t / rc
        return np.column_stack([s, rad * np.sin(phi), rad * np.cos(phi) - rc])
    return fn


def graph_map(height):
    """The graph z = height(x, y) over the parameter rectangle (s = x, t = y)."""
    return lambda s, t: np.column_stack([s, t, height(s, t)])


def profile_map(x_of, z_of):
    """A plane profile (x(t), z(t)) in the xz plane extruded along y: s along the generators (y), t along the profile.

    The generators are along y, so X_s × X_t = (0, 1, 0) × (x', 0, z') = (z', 0, −x'):
    the profile runs toward −x for the normal to point up (see :func:`curvature_profile`).
    """
    return lambda s, t: np.column_stack([x_of(t), s, z_of(t)])


def plane_curve(x, z, sigma_crown: float = 0.0):
    """A densely sampled plane curve (x, z) by its arc length σ from the point at ``sigma_crown``.

    Parameters
    ----------
    x, z : ndarray of shape (n,)
        Points along the curve (m), in order; it runs toward −x for :func:`profile_map`'s normal to point up.
    sigma_crown : float
        Arc length (m) from the first point to the point that becomes σ = 0, the origin.

    Returns
    -------
    x_of, z_of : callable
        Coordinates (m) at arc length σ (linear interpolation between the samples).
    """
    sig = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))]) - sigma_crown
    x, z = x - np.interp(0.0, sig, x), z - np.interp(0.0, sig, z)
    return (lambda t: np.interp(t, sig, x)), (lambda t: np.interp(t, sig, z))


def curvature_profile(kappa, s_range, *, n: int = 20001):
    """A plane curve by its signed curvature κ(σ) along its arc length σ, crown (σ = 0) at the origin.

    Parameters
    ----------
    kappa : callable
        κ(σ) (1/m), vectorized; > 0 bends away from the up normal.
    s_range : (float, float)
        Arc lengths (m) from the crown to the two ends (the first ≤ 0 ≤ the second).
    n : int
        Integration points (trapezoids on a uniform grid).

    Returns
    -------
    x_of, z_of : callable
        As :func:`plane_curve`: the point at arc length σ, running toward −x.
    """
    sig = np.linspace(s_range[0], s_range[1], n)
    theta = cumulative_trapezoid(kappa(sig), sig, initial=0.0)
    theta -= np.interp(0.0, sig, theta)
    x = cumulative_trapezoid(-np.cos(theta), sig, initial=0.0)
    z = cumulative_trapezoid(-np.sin(theta), sig, initial=0.0)
    return plane_curve(x, z, -s_range[0])


def helicoid_map(pitch: float):
    """Helicoid about the x axis, p = pitch (m/rad): the ruling at x turns by x / p; K = −p² / (p² + r²)²."""
    p = float(pitch)
    return lambda s, t: np.column_stack([s, t * np.cos(s / p), t * np.sin(s / p)])


def sphere_map(radius: float):
    """Sphere of radius R by longitude (s / R about y) and latitude (t / R), top at the origin, normals out."""
    r = float(radius)

    def fn(s, t):
        lon, lat = s / r, t / r
        return np.column_stack([r * np.cos(lat) * np.sin(lon), r * np.sin(lat), r * np.cos(lat) * np.cos(lon) - r])
    return fn


def _irregular_points(s_range, t_range, spacing, rng):
    """Graded, jittered points over the rectangle: denser toward the s0 end, the rim kept straight."""
    (s0, s1), (t0, t1) = s_range, t_range
    ns, nt = cell_count(s1 - s0, spacing) + 1, cell_count(t1 - t0, spacing) + 1
    a = np.linspace(0.0, 1.0, ns)
    us = s0 + (s1 - s0) * (0.6 * a + 0.4 * a ** 2)          # cells 0.6 to 1.4 times the mean along s
    vs = np.linspace(t0, t1, nt)
    s, t = (g.ravel() for g in np.meshgrid(us, vs, indexing="xy"))
    inner = (s > s0) & (s < s1) & (t > t0) & (t < t1)
    h = min((s1 - s0) / (ns - 1), (t1 - t0) / (nt - 1))
    s[inner] += rng.uniform(-0.3, 0.3, inner.sum()) * h
    t[inner] += rng.uniform(-0.3, 0.3, inner.sum()) * h
    return np.column_stack([s, t])


def mesh_patch(fn, s_range, t_range, *, spacing: float, irregular: bool = False, rng=None):
    """Triangulate ``fn`` over the parameter rectangle, normals along X_s × X_t.

    Parameters
    ----------
    fn : callable
        ``fn(s, t) -> (k, 3)`` (m).
    s_range, t_range : (float, float)
        The parameter rectangle (m of arc length, or close).
    spacing : float
        Largest grid spacing (m in parameter units); the irregular mesh's mean.
    irregular : bool
        A jittered, graded Delaunay triangulation instead of the alternating grid.
    rng : numpy.random.Generator or int, optional
        The jitter's generator (irregular only).

    Returns
    -------
    vertices : ndarray of shape (n, 3)
        (m).
    faces : ndarray of shape (m, 3), int64
    """
    if not irregular:
        return parametric_mesh(fn, s_range, t_range, spacing=spacing)
    st = _irregular_points(s_range, t_range, spacing, np.random.default_rng(rng))
    tri = Delaunay(st).simplices.astype(np.int64)
    p = st[tri]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    turn = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    tri[turn < 0] = tri[turn < 0][:, [0, 2, 1]]               # counter-clockwise in (s, t)
    keep = np.abs(turn) > 1e-9 * spacing ** 2                 # no zero-area triangle on the straight rim
    tri = tri[keep]
    used, inv = np.unique(tri, return_inverse=True)
    return fn(st[used, 0], st[used, 1]), inv.reshape(-1, 3).astype(np.int64)


def rotation(degrees_xyz) -> np.ndarray:
    """The rotation matrix (3, 3) of extrinsic x, y, z angles (degrees)."""
    return Rotation.from_euler("xyz", degrees_xyz, degrees=True).as_matrix()


def rigid(vertices, rot, offset) -> np.ndarray:
    """``rot @ v + offset`` for every vertex (m); ``rot`` of shape (3, 3), ``offset`` of shape (3,)."""
    return np.asarray(vertices, float) @ np.asarray(rot, float).T + np.asarray(offset, float)
