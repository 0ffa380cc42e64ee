"""The target zoo (airmat.synthetic.zoo): its coverage, determinism and exact geometry."""

import numpy as np
import pytest

from airmat.constants import LARGE_MATTRESS, SMALL_MATTRESS
from airmat.synthetic.zoo import KINDS, QUICK, by_name, names, zoo


@pytest.fixture(scope="module")
def entries():
    return zoo()


def _normals(v, f):
    p = v[f]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True), p.mean(axis=1)


def test_at_least_24_targets_every_kind_both_mattresses_and_units(entries):
    assert len(entries) >= 24
    assert len(set(names())) == len(entries)
    assert {e.kind for e in entries} == set(KINDS)
    assert {e.mattress for e in entries} == {tuple(SMALL_MATTRESS), tuple(LARGE_MATTRESS)}
    assert {e.units for e in entries} == {"mm", "m"}
    assert {e.triangulation for e in entries} == {"uniform", "irregular"}
    assert any(e.refused for e in entries) and any(not e.constructible and not e.refused for e in entries)
    assert not any(e.refused and e.constructible for e in entries)
    assert set(QUICK) <= set(names()) and len({by_name(n).kind for n in QUICK}) == len(QUICK)


def test_the_hypar_ratios_span_0_3_to_1_and_waves_change_sign_once_and_twice(entries):
    ratios = {e.params["ratio"] for e in entries if e.kind == "hypar"}
    assert min(ratios) == pytest.approx(0.3) and max(ratios) == 1.0
    assert {"wave-1", "wave-2"} <= {e.kind for e in entries}


def test_sizes_relative_to_the_mattress(entries):
    """Larger and smaller than the mattress, and beyond the designer's accepted 0.2-50 x its diagonal when refused."""
    ratio = {e.name: e.bbox_diagonal / np.hypot(*e.mattress) for e in entries}
    refused = {e.name for e in entries if e.refused}
    assert all(r < 0.2 or r > 50 for n, r in ratio.items() if n in refused)
    accepted = [r for n, r in ratio.items() if n not in refused]
    assert min(accepted) < 1 < 2 < max(accepted) and 0.2 <= min(accepted) and max(accepted) <= 50


def test_seeded_and_deterministic():
    a, b, c = zoo(seed=0), zoo(seed=0), zoo(seed=1)
    for x, y in zip(a, b):
        assert np.array_equal(x.vertices, y.vertices) and np.array_equal(x.faces, y.faces)
    irregular = [n for n, e in enumerate(a) if e.triangulation == "irregular"]
    assert irregular and all(not np.array_equal(a[n].vertices, c[n].vertices) for n in irregular)


def test_meshes_are_valid_and_face_up(entries):
    """Finite, every vertex used, no degenerate face, and the normal at the crown (the local origin) points up."""
    for e in entries:
        v, f = e.local, e.faces
        assert np.isfinite(e.vertices).all() and f.dtype == np.int64
        assert np.array_equal(np.unique(f), np.arange(len(v))), e.name
        n, c = _normals(v, f)
        area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
        assert area.min() > 1e-6 * e.spacing ** 2, e.name
        centre = np.argmin(np.linalg.norm(c, axis=1))           # every patch has its crown at the local origin
        assert n[centre, 2] > 0.5, e.name


def test_rotation_is_a_rigid_motion(entries):
    for e in entries:
        assert np.allclose(e.rotation @ e.rotation.T, np.eye(3)) and np.linalg.det(e.rotation) == pytest.approx(1)
    tilted = by_name("cylinder-r400-tilted")
    assert not np.allclose(tilted.rotation, np.eye(3)) and np.linalg.norm(tilted.offset) > 1


@pytest.mark.parametrize("name", ["cylinder-r300", "cylinder-r400-tilted", "cylinder-r350-irregular",
                                  "cylinder-r800-large", "cylinder-r300-coarse"])
def test_cylinder_vertices_at_its_radius(name):
    e = by_name(name)
    r, v = e.params["radius"], e.local
    assert np.allclose(np.hypot(v[:, 1], v[:, 2] + r), r, rtol=0, atol=1e-9 * r)


def test_cone_and_sphere_vertices_on_their_surfaces():
    e = by_name("cone-r350-steep-rotated")
    v, rc, c = e.local, e.params["r_crown"], np.tan(e.params["half_angle"])
    assert np.allclose(np.hypot(v[:, 1], v[:, 2] + rc), rc + c * v[:, 0], atol=1e-9)
    for name in ("dome-r450", "dome-r1000-large"):
        e = by_name(name)
        r = e.params["radius"]
        assert np.allclose(np.linalg.norm(e.local + [0, 0, r], axis=1), r, atol=1e-9 * r)


def _hessian_at_centre(v, radius):
    """Hessian of the quadratic z(x, y) fitted to the vertices within ``radius`` of the centre's axis."""
    near = np.hypot(v[:, 0], v[:, 1]) < radius
    x, y, z = v[near].T
    a = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    c = np.linalg.lstsq(a, z, rcond=None)[0]
    return np.array([[2 * c[0], c[1]], [c[1], 2 * c[2]]])


@pytest.mark.parametrize("name", ["hypar-0.3", "hypar-0.6", "hypar-1.0", "hypar-1.0-xy", "hypar-1.0-strong"])
def test_hypar_curvature_ratio_at_its_centre(name):
    """The vertices of a quadratic graph fit it exactly: the Hessian's eigenvalues are the centre's curvatures."""
    e = by_name(name)
    k = np.linalg.eigvalsh(_hessian_at_centre(e.local, 0.1))
    k1, k2 = k[np.argmax(np.abs(k))], k[np.argmin(np.abs(k))]
    assert abs(k2) / abs(k1) == pytest.approx(e.params["ratio"], rel=1e-6)
    assert abs(k1) == pytest.approx(e.params["k1"], rel=1e-6) and k1 * k2 < 0


def test_a_file_in_mm_is_the_same_mesh():
    """``units`` names the file's units; the mesh itself is metres (its size is the cylinder's, not 1000 x)."""
    e = by_name("cylinder-r200-mm")
    assert e.units == "mm" and 0.5 < e.bbox_diagonal < 2.0


def test_curvature_profile_bends_as_told():
    """A constant κ gives a circle's arc: the wave's integrator against the exact curve."""
    from airmat.synthetic.zoo_shapes import curvature_profile

    x_of, z_of = curvature_profile(lambda s: np.full_like(s, 2.0), (-0.5, 0.5))
    s = np.linspace(-0.5, 0.5, 11)
    assert np.allclose(x_of(s), -np.sin(2.0 * s) / 2.0, atol=1e-7)
    assert np.allclose(z_of(s), (np.cos(2.0 * s) - 1) / 2.0, atol=1e-7)


def test_unknown_name_lists_the_zoo():
    with pytest.raises(KeyError, match="cylinder-r300"):
        by_name("nope")
