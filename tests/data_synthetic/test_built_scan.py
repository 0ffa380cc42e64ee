"""airmat.synthetic.built_scan: a scan of a given mesh against its analytic truth (a plane, a sphere cap)."""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from airmat.errors import InputError
from airmat.synthetic.built_scan import CLUTTER, FLOOR, SURFACE, scan_surface

R_SPHERE = 1.0


def _grid(n=31, size=0.8):
    """A square [0, size]² of n x n vertices, triangles oriented up (+z)."""
    u, v = np.meshgrid(np.linspace(0, size, n), np.linspace(0, size, n), indexing="xy")
    uv = np.column_stack([u.ravel(), v.ravel()])
    i = np.arange(n - 1)
    a = (i[None, :] + n * i[:, None]).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    return uv, faces


@pytest.fixture(scope="module")
def plane():
    uv, faces = _grid()
    return np.column_stack([uv, np.zeros(len(uv))]), faces


@pytest.fixture(scope="module")
def cap():
    """A cap of the unit sphere centred at the origin, over a square of side 0.8 m (its top up)."""
    uv, faces = _grid()
    xy = uv - 0.4
    return np.column_stack([xy, np.sqrt(R_SPHERE ** 2 - (xy ** 2).sum(axis=1))]), faces


def test_noise_free_points_lie_on_the_surface_after_the_stated_pose(cap):
    v, f = cap
    s = scan_surface(v, f, n_points=20_000, noise=0.0, seed=1)
    x = s.to_input_frame()[s.labels == SURFACE]
    # a flat triangle inscribed in the sphere lies inside it, at most r_c²/(2R) below it (r_c: its circumradius)
    t = v[f]
    a, b, c = (np.linalg.norm(t[:, i] - t[:, j], axis=1) for i, j in ((1, 2), (2, 0), (0, 1)))
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    sag = ((a * b * c / (4 * area)) ** 2).max() / (2 * R_SPHERE)
    r = np.linalg.norm(x, axis=1)
    assert np.all(r <= R_SPHERE + 1e-12) and np.all(r >= R_SPHERE - sag * (1 + 1e-6))
    assert np.linalg.det(s.rotation) == pytest.approx(1.0) and np.abs(s.translation).max() > 0
    back, t = s.inverse()
    assert np.allclose((s.points @ back.T + t) * 1e-3, s.to_input_frame(), rtol=0, atol=1e-12)


def test_the_noise_is_the_stated_one(plane):
    v, f = plane
    s = scan_surface(v, f, n_points=20_000, noise=0.001, seed=2, floor=False, clutter=False)
    z = s.to_input_frame()[:, 2]
    # 20 000 normal draws: the sample sd is within 1 % of σ (relative sd 1/sqrt(2n) = 0.5 %)
    assert np.std(z) == pytest.approx(0.001, rel=0.02) and abs(np.mean(z)) < 5 * 0.001 / np.sqrt(len(z))


@pytest.mark.parametrize("coverage", [1.0, 0.85, 0.5])
def test_the_holes_take_the_share_of_the_area_asked_for(plane, coverage):
    v, f = plane
    s = scan_surface(v, f, n_points=20_000, noise=0.0, coverage=coverage, seed=3)
    assert s.coverage == pytest.approx(coverage, abs=1e-3)       # the last hole's radius is set to it
    # the area outside the holes, measured with fresh area-uniform points: binomial sd ~0.0016 at 1e5
    probe = np.random.default_rng(9).uniform(0, 0.8, (100_000, 2))
    probe = np.column_stack([probe, np.zeros(len(probe))])
    inside = (np.linalg.norm(probe[:, None] - s.hole_centers[None], axis=2) < s.hole_radii).any(axis=1)
    assert 1 - inside.mean() == pytest.approx(coverage, abs=0.01)
    # and no scanned point of the surface (noise-free) lies in a hole
    x = s.to_input_frame()[s.labels == SURFACE]
    assert not (np.linalg.norm(x[:, None] - s.hole_centers[None], axis=2) < s.hole_radii * (1 - 1e-9)).any()
    assert (len(s.hole_radii) == 0) == (coverage == 1.0)


def test_the_floor_lies_under_the_surface_outside_its_footprint_and_the_clutter_stands_on_it(cap):
    v, f = cap
    s = scan_surface(v, f, n_points=20_000, noise=0.0, seed=4)
    x = s.to_input_frame()
    counts = np.bincount(s.labels, minlength=3)
    assert counts.tolist() == [14_200, 5000, 800]        # the default 25 % floor, 4 % clutter
    floor = x[s.labels == FLOOR]
    assert s.floor_z == pytest.approx(v[:, 2].min())
    assert np.allclose(floor[:, 2], s.floor_z, rtol=0, atol=1e-12)      # the pose's round trip rounds
    assert np.all(Delaunay(v[:, :2]).find_simplex(floor[:, :2]) < 0)       # not under the cap
    assert np.all(x[s.labels == CLUTTER][:, 2] >= s.floor_z - 1e-12)


def test_millimetres_and_metres_are_the_same_scan(plane):
    v, f = plane
    mm = scan_surface(v, f, n_points=5000, units="mm", seed=5)
    m = scan_surface(v, f, n_points=5000, units="m", seed=5)
    assert mm.units == "mm" and m.units == "m"
    assert np.allclose(m.points * 1e3, mm.points, rtol=1e-12, atol=1e-9)
    assert np.allclose(mm.to_input_frame(), m.to_input_frame(), rtol=0, atol=1e-12)


def test_the_same_seed_gives_the_same_scan_and_another_seed_another(plane):
    v, f = plane
    a, b = (scan_surface(v, f, n_points=5000, seed=6) for _ in range(2))
    assert np.array_equal(a.points, b.points) and np.array_equal(a.labels, b.labels)
    assert not np.array_equal(a.points, scan_surface(v, f, n_points=5000, seed=7).points)


def test_a_given_pose_is_the_one_applied(plane):
    v, f = plane
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    s = scan_surface(v, f, n_points=5000, noise=0.0, rotation=rot, translation=[1.0, 2.0, 3.0], units="m",
                     seed=8, floor=False, clutter=False)
    assert np.allclose(s.points, s.to_input_frame() @ rot.T + [1.0, 2.0, 3.0], rtol=0, atol=1e-12)
    still = scan_surface(v, f, n_points=5000, noise=0.0, pose=False, units="m", seed=8, floor=False, clutter=False)
    assert np.all(still.points[:, 2] == 0)


def test_the_incidence_thins_a_steep_surface(plane):
    """Triangles turned away from the scanner get max(n_z, 0.25) of the density of those facing it."""
    v, f = plane
    tilted = v.copy()
    tilted[:, 2] = np.where(v[:, 0] > 0.4, (v[:, 0] - 0.4) * np.tan(np.radians(75)), 0.0)
    s = scan_surface(tilted, f, n_points=50_000, noise=0.0, floor=False, clutter=False, coverage=1.0, pose=False,
                     seed=10, units="m")
    steep = s.points[:, 0] > 0.4 + 1e-3
    flat = s.points[:, 0] < 0.4 - 0.03
    # per unit area: the steep half has 1/cos(75°) the area, at 0.26 of the density
    area_steep = 0.8 * 0.4 / np.cos(np.radians(75))
    ratio = (steep.sum() / area_steep) / (flat.sum() / (0.8 * 0.37))
    assert ratio == pytest.approx(np.cos(np.radians(75)), rel=0.1)


@pytest.mark.parametrize("kwargs, match", [({"coverage": 0.0}, "coverage"), ({"coverage": 1.2}, "coverage"),
                                           ({"noise": -1e-3}, "noise"), ({"units": "in"}, "unit"),
                                           ({"n_points": 50}, "n_points"), ({"rotation": np.eye(3) * 2}, "rotation"),
                                           ({"floor_fraction": 0.95}, "floor_fraction")])
def test_bad_options_are_refused(plane, kwargs, match):
    v, f = plane
    with pytest.raises(InputError, match=match):
        scan_surface(v, f, **{"n_points": 1000, **kwargs})


def test_bad_meshes_are_refused(plane):
    v, f = plane
    with pytest.raises(InputError, match="vertices have shape"):
        scan_surface(v[:, :2], f)
    with pytest.raises(InputError, match="faces have shape"):
        scan_surface(v, f + len(v))
