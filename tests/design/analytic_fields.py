"""Analytic MattressFields on a regular grid over Ω, the ground truth of the pattern-side tests.

Fields that are constant or linear on Ω are represented exactly by the linear
interpolation of MattressField at any grid spacing, so they use a coarse grid
(fewer triangles to build); the concentric field, which is not, a fine one.
"""

from __future__ import annotations

import numpy as np

from airmat.design.field import MattressField

#: grid spacing (m) of the fields that are constant or linear on Ω
COARSE = 0.05


def grid_uv(width, height, spacing=0.02):
    """Vertices (n, 2) of a regular grid covering [0, W] x [0, H] (m)."""
    u = np.linspace(0.0, width, int(np.ceil(width / spacing - 1e-9)) + 1)
    v = np.linspace(0.0, height, int(np.ceil(height / spacing - 1e-9)) + 1)
    return np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)


def frame(angle):
    """direction (n, 2, 2): k1 along angle (rad), k2 perpendicular."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=1)


def cylinder_field(width=0.83, height=0.74, kappa=-4.0, angle=0.0, spacing=COARSE):
    """Cylinder: k1 = kappa (1/m) bending along the direction ``angle``, k2 = 0."""
    uv = grid_uv(width, height, spacing)
    n = len(uv)
    k = np.column_stack([np.full(n, kappa), np.zeros(n)])
    return MattressField(width, height, uv, k, frame(np.full(n, angle)), np.ones(n))


def linear_cylinder_field(width=0.83, height=0.74, k0=-2.0, slope=-6.0, spacing=COARSE):
    """Cone-like: k1 along u, varying linearly with v: k1 = k0 + slope * v (1/m); k2 = 0."""
    uv = grid_uv(width, height, spacing)
    n = len(uv)
    k = np.column_stack([k0 + slope * uv[:, 1], np.zeros(n)])
    return MattressField(width, height, uv, k, frame(np.zeros(n)), np.ones(n))


def sphere_like_field(width=0.83, height=0.74, kappa=3.0, spacing=COARSE):
    """Both families kappa (1/m) with directions along u and v (weight 1)."""
    uv = grid_uv(width, height, spacing)
    n = len(uv)
    k = np.full((n, 2), kappa)
    return MattressField(width, height, uv, k, frame(np.zeros(n)), np.ones(n))


def concentric_field(width=2.6, height=1.6, k1=3.0, k2=1.0, spacing=0.02):
    """k1 lines are circles around the centre of Ω, k2 lines radial; weight 0 at the centre."""
    uv = grid_uv(width, height, spacing)
    r = uv - [width / 2, height / 2]
    rho = np.hypot(r[:, 0], r[:, 1])
    angle = np.arctan2(r[:, 1], r[:, 0]) + np.pi / 2
    n = len(uv)
    k = np.column_stack([np.full(n, k1), np.full(n, k2)])
    weight = np.clip(rho / 0.1, 0.0, 1.0)
    return MattressField(width, height, uv, k, frame(angle), weight)


def saddle_field(width=0.83, height=0.74, kappa=3.0, angle=np.pi / 4, spacing=COARSE):
    """Saddle-like: k1 = +kappa along ``angle``, k2 = -0.6 kappa across it."""
    uv = grid_uv(width, height, spacing)
    n = len(uv)
    k = np.column_stack([np.full(n, kappa), np.full(n, -0.6 * kappa)])
    return MattressField(width, height, uv, k, frame(np.full(n, angle)), np.ones(n))
