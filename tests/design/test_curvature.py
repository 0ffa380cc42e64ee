"""Principal curvature per vertex (airmat.design.curvature) against exact sphere, cylinder, cone and saddle values.

The meshes' vertices lie exactly on the analytic surfaces (20 mm spacing);
the errors come from the estimator alone. Measured (interior / rim, max abs):
cylinder R 0.3 m: 0.015 / 0.032 1/m on 3.33; sphere R 0.5 m: 0.005 / 0.010 on 2;
saddle: 0.010 / 0.039 on up to 2; tolerances below are ~1.5-2× those.
"""

import numpy as np
import pytest

from airmat.synthetic.targets import cone, cylinder, saddle, sphere_cap
from airmat.design.curvature import graph_curvature, principal_curvature, rim_vertices


def _angle_deg(a, b):
    """Angle (deg) between lines a and b (k, 3)."""
    c = np.abs(np.sum(a * b, axis=-1)) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
    return np.degrees(np.arccos(np.clip(c, 0, 1)))


def _errors(surf):
    v, f = surf.vertices, surf.faces
    pc = principal_curvature(v, f)
    k_exact, d_exact = surf.curvature(v)
    rim = rim_vertices(f, len(v))
    return pc, k_exact, d_exact, rim


def test_sphere_both_families_one_over_r():
    surf = sphere_cap(0.5, extent=0.6, spacing=0.02)
    pc, k, _, rim = _errors(surf)
    assert np.allclose(k, 2.0)
    err = np.abs(pc.kappa - 2.0)
    assert err[~rim].max() < 0.01 and err[rim].max() < 0.02
    # outward (up) normals: the sphere bends away from them, so κ > 0
    assert (pc.kappa > 0).all()
    assert np.allclose(pc.normal[np.argmin(np.linalg.norm(surf.vertices, axis=1))], [0, 0, 1], atol=1e-3)


def test_cylinder_values_and_directions():
    surf = cylinder(0.3, length=1.0, arc=0.8, spacing=0.02)
    pc, k, d, rim = _errors(surf)
    assert np.allclose(k[:, 0], 1 / 0.3) and np.allclose(k[:, 1], 0, atol=1e-12)
    err = np.abs(pc.kappa - k)
    assert err[~rim].max() < 0.03 and err[rim].max() < 0.06
    ang = _angle_deg(pc.directions[:, 0], d[:, 0])
    assert ang[~rim].max() < 0.5 and ang[rim].max() < 1.0
    # k1 runs around the axis (x): perpendicular to it; k2 along it
    assert np.abs(pc.directions[:, 0, 0]).max() < 0.02
    assert np.abs(pc.directions[:, 1, 0]).min() > 0.999


def test_cone_curvature_varies_along_generators():
    surf = cone(0.3, 0.25, length=1.0, arc=0.8, spacing=0.02)
    pc, k, d, rim = _errors(surf)
    assert k[:, 0].max() / k[:, 0].min() > 2.0          # κ1 = cos α / r really varies
    rel = np.abs(pc.kappa[:, 0] - k[:, 0]) / k[:, 0]
    assert rel[~rim].max() < 0.02 and rel[rim].max() < 0.05
    assert np.abs(pc.kappa[~rim, 1]).max() < 0.05        # developable: κ2 = 0
    assert _angle_deg(pc.directions[~rim, 0], d[~rim, 0]).max() < 1.0


def test_saddle_signs_values_and_directions():
    surf = saddle(0.5, 1.0, extent=(1.0, 0.8), spacing=0.02)
    pc, k, d, rim = _errors(surf)
    # compare as sorted pairs: where |κ1| ≈ |κ2| the labels may swap
    err = np.abs(np.sort(pc.kappa, axis=1) - np.sort(k, axis=1))
    assert err[~rim].max() < 0.02 and err[rim].max() < 0.06
    centre = np.argmin(np.linalg.norm(surf.vertices[:, :2], axis=1))
    # bends toward the up normal along x (κ = -1/a), away from it along y (+1/b)
    assert pc.kappa[centre] == pytest.approx([-2.0, 1.0], abs=0.01)
    assert _angle_deg(pc.directions[centre, 0], np.array([1.0, 0, 0])) < 0.5
    distinct = np.abs(np.abs(k[:, 0]) - np.abs(k[:, 1])) > 0.3
    assert _angle_deg(pc.directions[distinct & ~rim, 0], d[distinct & ~rim, 0]).max() < 1.0


def test_sign_follows_the_reference_normal():
    surf = sphere_cap(0.5, extent=0.6, spacing=0.03)
    v, f = surf.vertices, surf.faces
    up = principal_curvature(v, f).kappa
    assert np.allclose(principal_curvature(v, f[:, ::-1]).kappa, -up)
    assert np.allclose(principal_curvature(v, f, top_normal_sign=-1).kappa, -up)


@pytest.mark.parametrize("scale", [0.1, 3.0])
def test_curvature_scales_inversely_with_size(scale):
    surf = saddle(0.5, 1.0, extent=(0.6, 0.6), spacing=0.03)
    v, f = surf.vertices, surf.faces
    k = principal_curvature(v, f).kappa
    assert np.allclose(principal_curvature(v * scale, f).kappa, k / scale, rtol=1e-8, atol=1e-9 / scale)


def test_rigid_motion_invariance():
    surf = cone(0.3, 0.25, length=0.6, arc=0.5, spacing=0.03)
    v, f = surf.vertices, surf.faces
    pc = principal_curvature(v, f)
    rot, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))
    rot *= np.sign(np.linalg.det(rot))
    moved = principal_curvature(v @ rot.T + [5.0, -2.0, 1e3], f)   # far from the origin, too
    assert np.allclose(moved.kappa, pc.kappa, atol=1e-6)
    assert _angle_deg(moved.directions[:, 0], pc.directions[:, 0] @ rot.T).max() < 1e-3


def test_graph_curvature_closed_forms():
    # a tilted plane has no curvature; a paraboloid z = -(x² + y²)/(2R) at its top has 1/R
    k, _ = graph_curvature(np.full(3, 0.4), np.full(3, -0.2), 0.0, 0.0, 0.0)
    assert np.allclose(k, 0)
    k, d = graph_curvature(0.0, 0.0, -2.0, 0.0, -0.5)
    assert k[0] == pytest.approx(2.0) and k[1] == pytest.approx(0.5)   # ordered by magnitude
    assert np.allclose(np.abs(d[0]), [1, 0, 0]) and np.allclose(np.abs(d[1]), [0, 1, 0])


def test_rim_better_than_libigl_on_a_relaxed_surface():
    """Why not igl.principal_curvature: on a relaxed Ŝ its fit is poor on the rim.

    (On noise-free meshes like the ones above libigl is as good in the interior.)
    """
    import igl

    from airmat.design.mattress import Mattress
    from airmat.design.surface import approximate_surface

    surf = cone(0.3, 0.2, length=0.9, arc=0.8, spacing=0.01)
    a = approximate_surface(surf, Mattress(0.6, 0.5), spacing=0.02, progress=False)
    k_exact, _ = surf.curvature(a.xyz)
    rim = rim_vertices(a.faces, len(a.xyz))
    ours = np.abs(a.curvature.kappa[:, 0] - k_exact[:, 0])
    _, _, pv1, pv2, _ = igl.principal_curvature(a.xyz, a.faces, radius=2)
    theirs = np.abs(np.where(np.abs(pv1) >= np.abs(pv2), pv1, pv2) - k_exact[:, 0])
    assert ours[rim].max() < 0.5 * theirs[rim].max()
    assert ours[~rim].max() < theirs[~rim].max()
