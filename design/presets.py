"""The designer's five preset targets, analogues of the paper's shapes (Figure 6, Table 1).

Small mattress (830 × 740 mm): ``vault1`` (a vault with a sharper crown,
nearly developable), ``saddle`` (vault across, sag along: curvatures of
opposite signs), ``dome`` (an ellipsoidal dome, strongly double-curved: its plain
Ŝ cannot be made, the designer folds it, :mod:`airmat.design.fold_route`). Large mattress (2600 × 1600 mm): ``vault2``
(a wide vault, slightly double-curved), ``roof`` (freeform: a vault whose
crown sharpens and flattens along its length, over a wavy ridge).

The vaults, the saddle and the roof are "profile" surfaces: a cross-section
whose curvature falls off from the crown, κ(s) = κ0 / (1 + (s / s0)²) with s
the arc length from the crown, swept along x and lifted by a ridge line
g(x). Every target extends past the mattress so that Ω can be placed on
it. Meshes in metres, normals up (+z at the crown).
"""

from __future__ import annotations

import numpy as np

from airmat.constants import LARGE_MATTRESS, SMALL_MATTRESS
from airmat.errors import InputError
from airmat.geometry.grid import parametric_mesh
from airmat.design.mattress import Mattress
from airmat.design.target import Target

__all__ = ["preset", "profile_surface", "dome_surface", "PRESETS"]

SMALL = Mattress(*SMALL_MATTRESS)
LARGE = Mattress(*LARGE_MATTRESS)


def profile_surface(kappa0, s0: float, ridge, *, x_half: float, s_half: float, spacing: float,
                    name: str) -> Target:
    """A swept profile: cross-section curvature κ0(x) / (1 + (s / s0)²), crown lifted by ``ridge(x)``.

    Parameters
    ----------
    kappa0 : callable
        Crown curvature (1/m) of the cross-section at x (vectorized); > 0 is a vault.
    s0 : float
        Arc length (m) over which the cross-section's curvature halves.
    ridge : callable
        Height (m) of the crown line at x (vectorized).
    x_half, s_half : float
        Half extents (m) along the axis and along the cross-section's arc.
    spacing : float
        Mesh spacing (m) in (x, s).
    """
    n_s = int(np.ceil(2 * s_half / (0.25 * spacing))) + 1
    s_fine = np.linspace(-s_half, s_half, n_s)

    def fn(x, s):
        # cross-sections by cumulative trapezoids on a fine arc grid, one per distinct x
        xs, col = np.unique(x, return_inverse=True)
        theta = np.asarray(kappa0(xs), float)[:, None] * s0 * np.arctan(s_fine / s0)[None, :]
        ds = s_fine[1] - s_fine[0]

        def integral(g):
            c = np.concatenate([np.zeros((len(xs), 1)), np.cumsum(0.5 * ds * (g[:, 1:] + g[:, :-1]), 1)], 1)
            return c - c[:, [n_s // 2]]

        cy, cz = integral(np.cos(theta)), integral(-np.sin(theta))
        j = np.clip(np.searchsorted(s_fine, s) - 1, 0, n_s - 2)
        a = (s - s_fine[j]) / ds
        y = (1 - a) * cy[col, j] + a * cy[col, j + 1]
        z = (1 - a) * cz[col, j] + a * cz[col, j + 1]
        return np.column_stack([x, y, z + ridge(x)])

    vertices, faces = parametric_mesh(fn, (-x_half, x_half), (-s_half, s_half), spacing=spacing)
    return Target(vertices, faces, name=name)


def dome_surface(semi_axes, *, polar_max: float, subdivisions: int, name: str) -> Target:
    """The upper part of an ellipsoid (semi-axes a, b, c in m) down to ``polar_max`` (rad) from its top.

    Crown at the origin, normals outward.
    """
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v, f = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    keep = (v[f, 2] > np.cos(polar_max)).all(axis=1)
    f = f[keep]
    used, f = np.unique(f, return_inverse=True)
    v = v[used] * np.asarray(semi_axes, float)
    v[:, 2] -= semi_axes[2]
    return Target(v, f.reshape(-1, 3), name=name)


def _vault1():
    return profile_surface(lambda x: np.full_like(x, 5.2), 0.22, lambda x: -0.43 * x**2 / 2,
                           x_half=0.55, s_half=0.50, spacing=0.004, name="vault1")


def _saddle():
    return profile_surface(lambda x: np.full_like(x, 3.9), 0.22, lambda x: 1.4 * x**2 / 2,
                           x_half=0.55, s_half=0.50, spacing=0.004, name="saddle")


def _dome():
    return dome_surface((0.45, 0.40, 0.38), polar_max=np.radians(105), subdivisions=6, name="dome")


def _vault2():
    return profile_surface(lambda x: np.full_like(x, 3.1), 0.43, lambda x: -0.15 * x**2 / 2,
                           x_half=1.6, s_half=1.05, spacing=0.01, name="vault2")


def _roof():
    return profile_surface(lambda x: 3.3 + 1.4 * np.sin(np.pi * x / 1.6), 0.35,
                           lambda x: 0.04 * np.cos(np.pi * x), x_half=1.6, s_half=1.05,
                           spacing=0.01, name="roof")


_PRESETS = {"vault1": (_vault1, SMALL), "saddle": (_saddle, SMALL), "dome": (_dome, SMALL),
            "vault2": (_vault2, LARGE), "roof": (_roof, LARGE)}
PRESETS = tuple(_PRESETS)


def preset(name: str):
    """A preset target and its mattress (see the module docstring).

    Returns
    -------
    target : airmat.design.target.Target
    mattress : airmat.design.mattress.Mattress

    Raises
    ------
    airmat.errors.InputError
        For an unknown name (the message lists the presets).
    """
    if name not in _PRESETS:
        raise InputError(f"unknown preset {name!r}: choose one of {', '.join(PRESETS)}", preset=name)
    build, mattress = _PRESETS[name]
    return build(), mattress
