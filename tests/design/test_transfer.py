"""Carrying Ŝ's curvature field onto Ω (airmat.design.transfer).

Ŝ here is Ω wrapped exactly (isometrically) onto analytic surfaces, so the
expected field on Ω is known in closed form.
"""

import numpy as np
import pytest

from airmat.design.curvature import principal_curvature
from airmat.design.field import MattressField
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.transfer import direction_weight, face_jacobians, transfer_to_mattress

R = 0.4
M = Mattress(0.6, 0.5)


def _wrap_cylinder(uv, angle):
    """Ω wrapped on a cylinder of radius R whose bending runs along ``angle`` (rad) on Ω."""
    b = np.array([np.cos(angle), np.sin(angle)])        # bending direction on Ω
    a = np.array([-np.sin(angle), np.cos(angle)])       # axis direction on Ω
    centred = uv - uv.mean(axis=0)
    s, t = centred @ b, centred @ a
    # (-t, ...) keeps Ω's counter-clockwise faces facing up: the top normal is outward
    return np.column_stack([-t, R * np.sin(s / R), R * np.cos(s / R) - R])


def _field(xyz, uv, faces, **kw):
    pc = principal_curvature(xyz, faces)
    return transfer_to_mattress(xyz, uv, faces, pc.kappa, pc.directions, width=M.width, height=M.height, **kw)


def _line_angle_deg(d, expected):
    c = np.abs(d @ expected)
    return np.degrees(np.arccos(np.clip(c, 0, 1)))


@pytest.mark.parametrize("angle_deg", [90.0, 30.0])
def test_cylinder_k1_is_the_bending_line(angle_deg):
    uv, faces = triangulate_mattress(M, spacing=0.02)
    phi = np.radians(angle_deg)
    f = _field(_wrap_cylinder(uv, phi), uv, faces)
    assert isinstance(f, MattressField)
    assert f.kappa.shape == (len(uv), 2) and f.direction.shape == (len(uv), 2, 2)
    # k1 runs straight along the bending direction everywhere, k2 along the axis
    assert _line_angle_deg(f.direction[:, 0], [np.cos(phi), np.sin(phi)]).max() < 1.0
    assert np.allclose(np.sum(f.direction[:, 0] * f.direction[:, 1], axis=1), 0, atol=1e-12)
    assert np.allclose(np.linalg.norm(f.direction, axis=2), 1)
    assert np.abs(f.kappa[:, 0] - 1 / R).max() < 0.03          # 2.5 1/m within 1.2 %
    assert np.abs(f.kappa[:, 1]).max() < 0.03
    assert f.weight.min() > 0.9                                  # anisotropic: reliable everywhere
    # MattressField's interpolation agrees at an interior point
    p = np.array([[0.31, 0.22]])
    assert _line_angle_deg(f.direction_at(0, p), [np.cos(phi), np.sin(phi)])[0] < 1.0


def test_face_jacobians():
    uv, faces = triangulate_mattress(M, spacing=0.05)
    rot, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    for xyz, tol in ((np.column_stack([uv, np.zeros(len(uv))]) @ rot.T + [1.0, 2, 3], 1e-12),  # rigid
                     (_wrap_cylinder(uv, 0.3), 2e-3)):                                       # wrapped
        jac = face_jacobians(xyz, uv, faces)
        p, q = xyz[faces], uv[faces]
        for i, j in ((1, 0), (2, 0), (2, 1)):   # J maps every edge of Ŝ's triangle onto Ω's
            assert np.allclose(np.einsum("fij,fj->fi", jac, p[:, i] - p[:, j]), q[:, i] - q[:, j], atol=1e-12)
        # an isometry up to the chords' shortening: J Jᵀ = I
        assert np.abs(jac @ np.swapaxes(jac, 1, 2) - np.eye(2)).max() < tol
        normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        assert np.abs(np.einsum("fij,fj->fi", jac, normals)).max() < 1e-12   # normals map to 0


def test_sphere_umbilic_gives_equal_families_and_zero_weight():
    uv, faces = triangulate_mattress(M, spacing=0.025)
    c = uv - uv.mean(axis=0)
    rs = 1.0                                    # a graph over Ω close to a sphere of radius 1 m
    xyz = np.column_stack([c, np.sqrt(rs**2 - (c**2).sum(axis=1)) - rs])
    f = _field(xyz, uv, faces)
    assert np.allclose(f.kappa, 1 / rs, atol=0.03)
    assert f.weight.max() < 0.01
    # the filled-in line field is smooth: neighbouring vertices' lines differ little
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]])
    assert np.percentile(_pair_angles(f.direction[e[:, 0], 0], f.direction[e[:, 1], 0]), 95) < 5


def _pair_angles(a, b):
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(a * b, axis=1)), 0, 1)))


def test_umbilic_patch_takes_the_surrounding_direction():
    """Directions at a flat (umbilic) spot are filled in from the reliable surroundings."""
    uv, faces = triangulate_mattress(M, spacing=0.02)
    xyz = _wrap_cylinder(uv, np.pi / 2)
    pc = principal_curvature(xyz, faces)
    kappa, dirs = pc.kappa.copy(), pc.directions.copy()
    spot = np.linalg.norm(uv - [0.3, 0.25], axis=1) < 0.06
    kappa[spot] = 1.0                                            # umbilic: both families equal
    dirs[spot] = np.array([[1.0, 0, 0], [0, 1.0, 0]])            # and a meaningless direction
    f = transfer_to_mattress(xyz, uv, faces, kappa, dirs, width=M.width, height=M.height)
    assert f.weight[spot].max() == 0.0
    assert _line_angle_deg(f.direction[spot, 0], [0.0, 1.0]).max() < 10.0


def test_direction_weight():
    k = np.array([[3.0, 0.0], [1.0, 1.0], [2.0, -2.0], [0.5, 0.0]])
    w = direction_weight(k, 0.5)
    # a = |κ1 − κ2|: 0 only at the umbilic; the saddle point κ = ±2 is told apart by the signs
    assert w[0] == pytest.approx(9 / 9.25) and w[1] == 0 and w[2] == pytest.approx(16 / 16.25)
    assert w[3] == pytest.approx(0.5)


def test_deterministic():
    uv, faces = triangulate_mattress(M, spacing=0.03)
    xyz = _wrap_cylinder(uv, 0.7)
    a, b = _field(xyz, uv, faces), _field(xyz, uv, faces)
    assert np.array_equal(a.direction, b.direction) and np.array_equal(a.kappa, b.kappa)
