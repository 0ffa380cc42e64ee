"""Analytic targets and presets (airmat.synthetic.targets, airmat.design.presets)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from airmat.errors import InputError
from airmat.geometry.graph_curvature import graph_curvature
from airmat.design.presets import PRESETS, preset
from airmat.synthetic.targets import cone, cylinder, saddle, sphere_cap


def _face_normals(t):
    p = t.vertices[t.faces]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True), t.vertices[t.faces].mean(axis=1)


def test_cylinder_exact_curvature_and_mesh():
    s = cylinder(0.3, length=0.8, arc=0.8, spacing=0.02)
    v = s.vertices
    assert np.allclose(np.hypot(v[:, 1], v[:, 2] + 0.3), 0.3)          # vertices on the cylinder
    n, c = _face_normals(s)
    radial = np.column_stack([np.zeros(len(c)), c[:, 1], c[:, 2] + 0.3])
    assert (np.sum(n * radial, axis=1) > 0).all()                        # normals outward
    k, d = s.curvature(v)
    assert np.allclose(k, [1 / 0.3, 0.0])
    assert np.allclose(d[:, 0, 0], 0, atol=1e-12) and np.allclose(np.abs(d[:, 1, 0]), 1)


def test_cone_exact_curvature_varies_along_generators():
    alpha = 0.25
    s = cone(0.3, alpha, length=0.8, arc=0.6, spacing=0.02)
    v = s.vertices
    r = 0.3 + v[:, 0] * np.tan(alpha)
    assert np.allclose(np.hypot(v[:, 1], v[:, 2] + 0.3), r)             # on the cone
    k, d = s.curvature(v)
    assert np.allclose(k[:, 0], np.cos(alpha) / r) and np.allclose(k[:, 1], 0, atol=1e-9)
    # k2 runs along the generator through the apex (x = -0.3 / tan α, on the axis)
    apex = np.array([-0.3 / np.tan(alpha), 0.0, -0.3])
    gen = v - apex
    gen /= np.linalg.norm(gen, axis=1, keepdims=True)
    assert np.allclose(np.abs(np.sum(gen * d[:, 1], axis=1)), 1)


def test_sphere_cap_exact_curvature():
    s = sphere_cap(0.5, extent=0.5, spacing=0.02)
    v = s.vertices
    assert np.allclose(np.linalg.norm(v + [0, 0, 0.5], axis=1), 0.5)
    n, c = _face_normals(s)
    assert (np.sum(n * (c + [0, 0, 0.5]), axis=1) > 0).all()
    k, _ = s.curvature(v)
    assert np.allclose(k, 2.0)


def test_saddle_exact_curvature():
    s = saddle(0.5, 1.0, extent=(0.6, 0.6), spacing=0.05)
    k, d = s.curvature(np.zeros((1, 3)))
    assert k[0] == pytest.approx([-2.0, 1.0])
    assert np.allclose(np.abs(d[0, 0]), [1, 0, 0])
    v = s.vertices
    k, _ = s.curvature(v)
    w2 = 1 + (v[:, 0] / 0.5) ** 2 + (v[:, 1] / 1.0) ** 2
    assert np.allclose(k[:, 0] * k[:, 1], -1 / (0.5 * 1.0) / w2**2)    # Gaussian curvature


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=5, max_size=5))
def test_graph_curvature_invariants(h):
    hx, hy, hxx, hxy, hyy = h
    k, d = graph_curvature(np.array([hx]), np.array([hy]), hxx, hxy, hyy)
    w = np.sqrt(1 + hx**2 + hy**2)
    gauss = (hxx * hyy - hxy**2) / w**4
    mean = -((1 + hy**2) * hxx - 2 * hx * hy * hxy + (1 + hx**2) * hyy) / (2 * w**3)   # our sign
    scale = 1 + abs(hxx) + abs(hxy) + abs(hyy)
    assert k[0, 0] * k[0, 1] == pytest.approx(gauss, abs=1e-9 * scale**2)
    assert 0.5 * (k[0, 0] + k[0, 1]) == pytest.approx(mean, abs=1e-9 * scale)
    assert abs(k[0, 0]) >= abs(k[0, 1])
    # directions are unit tangents (orthogonal to the normal (-hx, -hy, 1)); orthogonal to
    # each other unless the point is an umbilic
    assert np.allclose(np.linalg.norm(d[0], axis=1), 1)
    assert np.allclose(d[0] @ np.array([-hx, -hy, 1.0]), 0, atol=1e-9)
    if abs(k[0, 0] - k[0, 1]) > 1e-6 * scale:
        assert abs(d[0, 0] @ d[0, 1]) < 1e-6


@pytest.mark.parametrize("name", PRESETS)
def test_presets_are_valid_and_larger_than_their_mattress(name):
    target, mattress = preset(name)
    assert target.name == name
    small = name in ("vault1", "saddle", "dome")
    assert (mattress.width, mattress.height) == ((0.83, 0.74) if small else (2.6, 1.6))
    assert target.face_areas.sum() > 1.3 * mattress.width * mattress.height
    n, c = _face_normals(target)
    crown = np.argmin(np.linalg.norm(c[:, :2], axis=1))                 # above the origin
    assert n[crown, 2] > 0.99                                            # normals up at the crown


def test_unknown_preset_lists_the_names():
    with pytest.raises(InputError, match="vault1, saddle, dome, vault2, roof"):
        preset("igloo")
