"""Comparison of an inflation with Ŝ: Kabsch alignment, and the realized curvature (sign, exact cases)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from airmat.calib.model import kappa1
from airmat.check.compare import deviation, realized_curvature, surface_at
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.simulate import inflate
from airmat.inflation.strings import StringSet

W, H, D = 0.6, 0.3, 0.07
V = np.array([0.075, 0.225])
A = np.column_stack([np.full(2, 0.15), V])
B = np.column_stack([np.full(2, 0.45), V])


@pytest.fixture(scope="module")
def mesh():
    return build_mattress_mesh(W, H, D, resolution=0.05)


@pytest.fixture(scope="module")
def top_strings(mesh):
    return inflate(mesh, StringSet(A, B, np.full(2, True), np.full(2, 0.2)))


def test_deviation_is_rigid_motion_invariant(top_strings):
    uv = np.random.default_rng(0).uniform([0, 0], [W, H], size=(200, 2))
    mid, _ = surface_at(top_strings, uv)
    rot = Rotation.from_rotvec([0.3, -0.2, 1.1])
    target = rot.apply(mid) + [1.0, -2.0, 0.5]
    dev = deviation(top_strings, target, uv)
    assert dev.rms < 1e-9 and dev.max < 1e-9
    bumped = target + np.outer(np.arange(200) % 2 * 2 - 1, [0, 0, 1e-3])  # +-1 mm, no rigid part
    assert deviation(top_strings, bumped, uv).rms == pytest.approx(1e-3, rel=0.05)


def test_realized_curvature_sign_follows_the_face(mesh, top_strings):
    polys = [np.stack([a, b]) for a, b in zip(A, B)]
    k_top = realized_curvature(top_strings, A, B, polys)
    bottom = inflate(mesh, StringSet(A, B, np.full(2, False), np.full(2, 0.2)))
    k_bottom = realized_curvature(bottom, A, B, polys)
    assert np.all(k_top < 0) and np.all(k_bottom > 0)
    # exact mirrors (round-off only; the rigid pins sit on the side wall at z = 0, so a pattern
    # and its top/bottom mirror image are solved along mirror paths): top <-> bottom, string by
    # string, and v -> H - v, which swaps the two strings
    np.testing.assert_allclose(k_bottom, -k_top, rtol=1e-6)
    np.testing.assert_allclose(k_top, k_top[::-1], rtol=1e-6)
    # strings of l* = 200 mm over L = 300 mm bend the mattress strongly: same order as Equation 3
    # (Delta = 0: 4.2 1/m); an isolated string concentrates its bend near the string (see validate)
    k_eq3 = kappa1(0.2, 0.3, 0.0, D)
    assert 0.5 * k_eq3 < k_bottom.min() and k_bottom.max() < 3 * k_eq3


def test_surface_at_is_mid_surface_of_the_flat_mattress(mesh):
    flat = inflate(mesh, None)
    uv = np.array([[0.1, 0.1], [0.3, 0.15], [0.55, 0.29]])
    mid, up = surface_at(flat, uv)
    np.testing.assert_allclose(up, np.tile([0, 0, 1], (3, 1)), atol=1e-2)
    assert np.ptp(mid[:, 2]) < 1e-3


def test_faces_of_the_flat_mattress_are_d_apart(mesh):
    flat = inflate(mesh, None)
    uv = np.array([[0.1, 0.1], [0.3, 0.15], [0.55, 0.29]])
    top, _ = surface_at(flat, uv, "top")
    bottom, _ = surface_at(flat, uv, "bottom")
    mid, _ = surface_at(flat, uv, "mid")
    np.testing.assert_allclose(top[:, 2] - bottom[:, 2], D, rtol=0.05)
    np.testing.assert_allclose(mid, 0.5 * (top + bottom), atol=1e-12)


def test_unknown_surface_is_an_input_error(top_strings):
    from airmat.errors import InputError

    with pytest.raises(InputError, match="side"):
        surface_at(top_strings, np.array([[0.1, 0.1]]), "side")


def test_deviation_on_a_face_names_it_and_its_alignment_moves_the_whole_mattress(top_strings):
    uv = np.random.default_rng(1).uniform([0, 0], [W, H], size=(150, 2))
    top, _ = surface_at(top_strings, uv, "top")
    rot = Rotation.from_rotvec([-0.4, 0.1, 0.7])
    target = rot.apply(top) + [0.2, 0.3, -1.0]
    dev = deviation(top_strings, target, uv, "top")
    assert dev.surface == "top" and dev.rms < 1e-9
    np.testing.assert_allclose(dev.apply(top), dev.aligned, atol=1e-12)
    np.testing.assert_allclose(dev.apply(top_strings.xyz[:5]), rot.apply(top_strings.xyz[:5]) + [0.2, 0.3, -1.0],
                               atol=1e-9)
    # the mid-surface of the bent mattress is not the top face's shape (it bends less and is
    # longer across the bend): after its own alignment it stays millimetres away (15 mm here)
    assert 0.005 < deviation(top_strings, target, uv, "mid").rms < 0.5 * D


def test_the_string_face_bends_more_than_the_free_face(mesh, top_strings):
    # top strings: the top face is the inner (string) face of the bend, the bottom face the outer one
    polys = [np.stack([a, b]) for a, b in zip(A, B)]
    k = {f: realized_curvature(top_strings, A, B, polys, f) for f in ("top", "mid", "bottom")}
    assert np.all(k["top"] < k["mid"]) and np.all(k["mid"] < k["bottom"]) and np.all(k["bottom"] < 0)
    per_dash = realized_curvature(top_strings, A, B, polys, np.array(["top", "bottom"]))
    np.testing.assert_allclose(per_dash, [k["top"][0], k["bottom"][1]])


def _bent(mesh, angle_of_u):
    """An 'inflation' whose faces are the flat mattress bent along u: the mid-line turns by
    ``angle_of_u(u)`` (rad), each face offset by ±d/2 along the normal (exact geometry, no solver)."""
    from types import SimpleNamespace

    u = np.linspace(0.0, W, 2001)
    ang = angle_of_u(u)
    # mid-line by integrating its unit tangent (cos, sin) of the turning angle over arc length u
    du = np.diff(u)
    x = np.concatenate([[0.0], np.cumsum(du * np.cos(0.5 * (ang[1:] + ang[:-1])))])
    z = np.concatenate([[0.0], np.cumsum(du * np.sin(0.5 * (ang[1:] + ang[:-1])))])
    uu, vv, zz = mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.vertices[:, 2]
    a = np.interp(uu, u, ang)
    normal = np.column_stack([-np.sin(a), np.zeros_like(a), np.cos(a)])     # up: bottom -> top
    xyz = np.column_stack([np.interp(uu, u, x), vv, np.interp(uu, u, z)]) + zz[:, None] * normal
    return SimpleNamespace(mesh=mesh, xyz=xyz)


def test_turning_reads_the_exact_curvature_of_a_bent_mattress():
    """A mattress bent into a cylinder of mid radius R: the top face reads 1/(R + d/2) exactly,
    the bottom face 1/(R - d/2), with the designer's sign (bending toward the top: negative)."""
    fine = build_mattress_mesh(W, H, D, resolution=0.01)
    R = 0.5
    inf = _bent(fine, lambda u: u / R)          # turns toward +z: the top is the inner face
    polys = [np.stack([a, b]) for a, b in zip(A, B)]
    top = realized_curvature(inf, A, B, polys, "top")
    bottom = realized_curvature(inf, A, B, polys, "bottom")
    np.testing.assert_allclose(top, -1.0 / (R - D / 2), rtol=2e-3)
    np.testing.assert_allclose(bottom, -1.0 / (R + D / 2), rtol=2e-3)
    np.testing.assert_allclose(realized_curvature(inf, A, B, polys, "top", method="circle"), top, rtol=5e-3)


def test_turning_sees_a_bend_concentrated_at_the_string_ends_where_the_circle_does_not():
    """The paper's polygon (Figure 4b): flat between the wrinkles at the string ends, all the turn at
    the ends. Over a dash from wrinkle to wrinkle the face turns by the two half-corners; the circle
    through the dash's ends and middle sees a straight side."""
    fine = build_mattress_mesh(W, H, D, resolution=0.01)
    corner = 0.6                                 # rad at each wrinkle, u = 0.15 and 0.45 (the dash ends)
    width = 0.02                                 # the wrinkle's extent along u (m)
    ramp = lambda u, c: np.clip((u - c) / width + 0.5, 0.0, 1.0)   # noqa: E731
    inf = _bent(fine, lambda u: -corner * (ramp(u, 0.15) + ramp(u, 0.45)))
    polys = [np.stack([a, b]) for a, b in zip(A, B)]
    top = realized_curvature(inf, A, B, polys, "top")
    # half of each corner lies on the dash: the face turns by one corner over its arc, which is the
    # dash's 0.3 m plus what the convex top face gains around the two half-corners, (d/2) * corner
    np.testing.assert_allclose(top, corner / (0.3 + 0.5 * D * corner), rtol=2e-3)
    # the circle sees the straight side, plus a little of the corners' rounding by the offset (12 %)
    assert np.all(np.abs(realized_curvature(inf, A, B, polys, "top", method="circle")) < 0.15 * top)


def test_distance_to_target_tells_the_points_over_s_from_those_beyond_its_rim():
    """A 1 m square S with a 0.4 m square hole: points above its inside, level with or above its rim are over S;
    points off its outer edge or over the hole are beyond the rim, and their distance is to the rim."""
    import trimesh

    from airmat.check.compare import distance_to_target

    s = np.linspace(0.0, 1.0, 11)
    x, y = np.meshgrid(s, s)
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i = np.arange(121).reshape(11, 11)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    centre = v[f].mean(axis=1)
    hole = (np.abs(centre[:, 0] - 0.5) < 0.2) & (np.abs(centre[:, 1] - 0.5) < 0.2)
    square = trimesh.Trimesh(v, f[~hole], process=False)
    points = np.array([[0.15, 0.15, 0.02],     # over S, 20 mm above it
                       [0.0, 0.5, 0.03],       # above the outer rim: over S, 30 mm
                       [-0.1, 0.5, 0.0],       # level with S, 100 mm beyond its outer rim
                       [0.5, 0.5, 0.0],        # in the hole's middle: 200 mm from its rim
                       [0.9, 0.9, -0.01]])     # over S, 10 mm below it
    t = distance_to_target(points, square, diagonal=1.0)
    np.testing.assert_allclose(t.per_vertex, [0.02, 0.03, 0.1, 0.2, 0.01], atol=1e-9)
    np.testing.assert_array_equal(t.over, [True, True, False, False, True])
    assert t.over_share == pytest.approx(0.6)
    assert t.over_rms == pytest.approx(np.sqrt((0.02 ** 2 + 0.03 ** 2 + 0.01 ** 2) / 3))
    assert t.over_max == pytest.approx(0.03) and t.max == pytest.approx(0.2)
    doc = t.summary_mm()
    assert doc["rms_mm"] == pytest.approx(1e3 * t.rms, abs=1e-3)
    assert doc["over_target"] == {"share": 0.6, "rms_mm": pytest.approx(1e3 * t.over_rms, abs=1e-3),
                                  "max_mm": 30.0, "rms_pct_diag": pytest.approx(100 * t.over_rms, abs=1e-4)}
    # a point set wholly over S: share 1, the same RMS as the whole
    t2 = distance_to_target(points[[0, 4]], square, diagonal=1.0)
    assert t2.over_share == 1.0 and t2.over_rms == pytest.approx(t2.rms)
