"""Analytic target surfaces with exact principal curvatures, and the designer's presets.

Analytic surfaces (ground truth for tests), each a triangle mesh in metres
with faces wound so that the normals point "up" (+z at the surface's
centre), and an exact principal-curvature function:

- :func:`cylinder` (κ1 = 1/R around the axis, κ2 = 0),
- :func:`cone` (developable: κ2 = 0 along the generators, κ1 = cos α / r varying along them),
- :func:`sphere_cap` (κ1 = κ2 = 1/R),
- :func:`saddle` (hyperbolic paraboloid z = x²/(2a) − y²/(2b)).

All are graphs z = h(x, y) near their crown, so one routine
(:func:`airmat.geometry.graph_curvature.graph_curvature`) gives the exact curvatures from h's
derivatives. Curvatures are signed against the up normal (CONTRIBUTING.md): κ > 0 where
the surface bends away from it (a vault seen from above).

An :class:`AnalyticSurface` is a plain mesh (``vertices``, ``faces``, ``name``):
test and demo data that imports nothing from the designer, which accepts it as
a target (:meth:`airmat.design.target.Target.from_mesh`). The designer's presets are
in :mod:`airmat.design.presets`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from airmat.geometry.graph_curvature import graph_curvature
from airmat.geometry.grid import parametric_mesh

__all__ = ["AnalyticSurface", "cylinder", "cone", "sphere_cap", "saddle"]


@dataclass(frozen=True)
class AnalyticSurface:
    """A triangle mesh of an analytic surface, with its exact curvature.

    Attributes
    ----------
    vertices : ndarray of shape (n, 3)
        Vertex positions (m).
    faces : ndarray of shape (m, 3)
        Triangles (int64), wound so that the normals point up.
    name : str
    kind : str
    params : dict
        The surface's parameters (m).
    """

    vertices: np.ndarray = field(repr=False)
    faces: np.ndarray = field(repr=False)
    name: str
    kind: str
    params: dict
    _derivs: Callable = field(repr=False)

    def curvature(self, points: np.ndarray):
        """Exact principal curvatures at the surface points above ``points``' (x, y).

        Parameters
        ----------
        points : ndarray of shape (k, 3)
            Points on (or within a few mm of) the surface (m); only x and y are used.

        Returns
        -------
        kappa : ndarray of shape (k, 2)
            Signed principal curvatures (1/m), column 0 the larger magnitude.
        directions : ndarray of shape (k, 2, 3)
            Unit principal directions in space.
        """
        p = np.asarray(points, dtype=float)
        return graph_curvature(*self._derivs(p[:, 0], p[:, 1]))


def cylinder(radius: float = 0.3, *, length: float = 1.2, arc: float = 1.2,
             spacing: float = 0.01) -> AnalyticSurface:
    """A circular cylinder, axis along x, crown along the x axis (z = 0), normals outward.

    ``length`` along the axis and ``arc`` around it (arc length, m, centred on the crown).
    """
    r = float(radius)

    def fn(s, t):
        return np.column_stack([s, r * np.sin(t / r), r * np.cos(t / r) - r])

    def derivs(x, y):
        g = np.sqrt(np.maximum(r**2 - y**2, 1e-12 * r**2))
        return np.zeros_like(x), -y / g, np.zeros_like(x), np.zeros_like(x), -(r**2) / g**3

    v, f = parametric_mesh(fn, (-length / 2, length / 2), (-arc / 2, arc / 2), spacing=spacing)
    name = f"cylinder R{r * 1e3:.0f}mm"
    return AnalyticSurface(v, f, name, "cylinder", {"radius": r}, derivs)


def cone(r_crown: float = 0.3, half_angle: float = 0.25, *, length: float = 1.2, arc: float = 1.0,
         spacing: float = 0.01) -> AnalyticSurface:
    """A circular cone, axis along x, radius ``r_crown`` at x = 0, crown line through the origin.

    The radius is r(x) = r_crown + x tan(half_angle); κ1 = cos(half_angle) / r around the axis,
    κ2 = 0 along the generators. ``arc`` is the arc length (m) around the axis at x = 0.
    """
    rc, c = float(r_crown), float(np.tan(half_angle))
    if rc - c * length / 2 <= 0:
        raise ValueError("cone apex inside the mesh: shorten it or reduce the half angle")

    def fn(s, t):
        rad = rc + c * s
        phi = t / rc
        return np.column_stack([s, rad * np.sin(phi), rad * np.cos(phi) - rc])

    def derivs(x, y):
        rad = rc + c * x
        g = np.sqrt(np.maximum(rad**2 - y**2, 1e-12 * rad**2))
        return c * rad / g, -y / g, -(c**2) * y**2 / g**3, c * rad * y / g**3, -(rad**2) / g**3

    v, f = parametric_mesh(fn, (-length / 2, length / 2), (-arc / 2, arc / 2), spacing=spacing)
    name = f"cone r{rc * 1e3:.0f}mm"
    return AnalyticSurface(v, f, name, "cone", {"r_crown": rc, "half_angle": float(half_angle)}, derivs)


def sphere_cap(radius: float = 1.0, *, extent: float = 1.0, spacing: float = 0.01) -> AnalyticSurface:
    """A spherical cap, top at the origin, normals outward (up), over |x|, |y| ≤ extent / 2.

    Meshed as a graph over a square; keep ``extent`` well below the radius × √2.
    """
    r = float(radius)

    def height(x, y):
        return np.sqrt(np.maximum(r**2 - x**2 - y**2, 0.0)) - r

    def fn(s, t):
        return np.column_stack([s, t, height(s, t)])

    def derivs(x, y):
        g = np.sqrt(np.maximum(r**2 - x**2 - y**2, 1e-12 * r**2))
        return -x / g, -y / g, -(g**2 + x**2) / g**3, -x * y / g**3, -(g**2 + y**2) / g**3

    v, f = parametric_mesh(fn, (-extent / 2, extent / 2), (-extent / 2, extent / 2), spacing=spacing)
    name = f"sphere R{r * 1e3:.0f}mm"
    return AnalyticSurface(v, f, name, "sphere", {"radius": r}, derivs)


def saddle(a: float = 0.5, b: float = 1.0, *, extent=(1.2, 1.0), spacing: float = 0.01) -> AnalyticSurface:
    """The hyperbolic paraboloid z = x²/(2a) − y²/(2b) over |x| ≤ extent[0]/2, |y| ≤ extent[1]/2.

    At the origin κ = −1/a along x (bends toward the up normal) and +1/b along y.
    """
    a, b = float(a), float(b)

    def fn(s, t):
        return np.column_stack([s, t, s**2 / (2 * a) - t**2 / (2 * b)])

    def derivs(x, y):
        one = np.ones_like(x)
        return x / a, -y / b, one / a, 0 * one, -one / b

    v, f = parametric_mesh(fn, (-extent[0] / 2, extent[0] / 2), (-extent[1] / 2, extent[1] / 2),
                           spacing=spacing)
    name = f"saddle a{a * 1e3:.0f} b{b * 1e3:.0f}mm"
    return AnalyticSurface(v, f, name, "saddle", {"a": a, "b": b}, derivs)
