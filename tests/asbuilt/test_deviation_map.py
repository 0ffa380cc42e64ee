"""The deviation map recovers a known bump on a curved reference; the PNG and the PLY are written."""

import numpy as np
import pytest
import trimesh

from airmat.asbuilt.deviation_map import deviation_figure, deviation_map, write_deviation_ply
from airmat.errors import InputError

#: a vault of radius 1 m over 800 x 700 mm (axis along y), and a Gaussian bump of 5 mm, 60 mm wide, on it
RADIUS, WIDTH, HEIGHT = 1.0, 0.8, 0.7
BUMP, BUMP_WIDTH, BUMP_AT = 5e-3, 0.06, (0.1, -0.05)
NOISE = 0.5e-3


def vault(n=(41, 36)):
    """The vault's mesh (m), normals up (outward)."""
    xs, ys = np.linspace(-WIDTH / 2, WIDTH / 2, n[0]), np.linspace(-HEIGHT / 2, HEIGHT / 2, n[1])
    x, y = (a.ravel() for a in np.meshgrid(xs, ys, indexing="ij"))
    v = np.column_stack([x, y, np.sqrt(RADIUS ** 2 - x ** 2) - RADIUS])
    i, j = np.meshgrid(np.arange(n[0] - 1), np.arange(n[1] - 1), indexing="ij")
    a = (i * n[1] + j).ravel()
    f = np.vstack([np.column_stack([a, a + n[1], a + n[1] + 1]), np.column_stack([a, a + n[1] + 1, a + 1])])
    return v, f


def bump(x, y):
    return BUMP * np.exp(-((x - BUMP_AT[0]) ** 2 + (y - BUMP_AT[1]) ** 2) / (2 * BUMP_WIDTH ** 2))


def bumped_scan(n=60_000, seed=0, x_min=-0.25):
    """Points on the vault displaced along its normal by the bump, with noise, none at x < ``x_min``, and clutter."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(x_min, WIDTH / 2, n)
    y = rng.uniform(-HEIGHT / 2, HEIGHT / 2, n)
    normal = np.column_stack([x, np.zeros(n), np.sqrt(RADIUS ** 2 - x ** 2)]) / RADIUS
    on = np.column_stack([x, y, np.sqrt(RADIUS ** 2 - x ** 2) - RADIUS])
    pts = on + normal * (bump(x, y) + rng.normal(0, NOISE, n))[:, None]
    clutter = rng.uniform([-0.4, -0.35, 0.1], [0.4, 0.35, 0.3], (500, 3))   # well above the surface
    return np.vstack([pts, clutter]), x, y


def test_recovers_a_known_bump():
    v, f = vault()
    pts, x, y = bumped_scan()
    dev = deviation_map(pts, v, f, seed=0)
    truth = bump(v[:, 0], v[:, 1])
    covered = np.isfinite(dev.per_vertex)
    # the scan covers x >= -0.25 (the vertices within a radius of it too); the rest is NaN
    assert np.all(covered[v[:, 0] > -0.24]) and not np.any(covered[v[:, 0] < -0.25 - dev.radius])
    # a vertex averages ~60 points of 0.5 mm noise over a disc of one edge (20 mm) where the bump
    # (60 mm wide) bends by less than 5 % of its height: a tolerance of 0.1 mm + 5 % of the bump
    err = dev.per_vertex[covered] - truth[covered]
    assert np.abs(err).max() < 0.1e-3 + 0.05 * BUMP
    assert dev.max == pytest.approx(BUMP, rel=0.05)
    assert dev.coverage == pytest.approx(np.mean(covered))
    assert dev.rms_pct_diag == pytest.approx(100 * dev.rms / np.linalg.norm(np.ptp(v, axis=0)))
    # clutter is not the surface; the points on it are
    assert np.isnan(dev.per_point[-500:]).all() and np.isfinite(dev.per_point[:-500]).all()
    # per point: the bump plus the noise
    np.testing.assert_allclose(dev.per_point[:-500], bump(x, y), atol=5 * NOISE)


def test_sign_follows_the_reference_normal():
    v, f = vault()
    pts, _, _ = bumped_scan(n=20_000, seed=1)
    up, down = deviation_map(pts, v, f), deviation_map(pts, v, f[:, ::-1])
    at = np.argmin(np.hypot(v[:, 0] - BUMP_AT[0], v[:, 1] - BUMP_AT[1]))   # the vertex under the bump's top
    # the reversed faces sample other points on the same triangles: equal up to the noise's mean
    assert up.per_vertex[at] == pytest.approx(BUMP, abs=NOISE)
    assert down.per_vertex[at] == pytest.approx(-BUMP, abs=NOISE)


def test_figure_and_ply(tmp_path):
    v, f = vault()
    pts, _, _ = bumped_scan(n=20_000, seed=2)
    dev = deviation_map(pts, v, f)
    from airmat.figures import save_png

    png = save_png(deviation_figure(dev, v, f, title="scan against the prediction"), tmp_path / "d.png", dpi=60)
    assert png.read_bytes()[:4] == b"\x89PNG"
    write_deviation_ply(tmp_path / "d.ply", dev, v, f)
    back = trimesh.load(tmp_path / "d.ply", process=False)
    np.testing.assert_allclose(back.vertices, v * 1e3, rtol=1e-6)
    values = back.metadata["_ply_raw"]["vertex"]["data"]["deviation_mm"]
    np.testing.assert_allclose(values, dev.per_vertex * 1e3, rtol=1e-6, atol=1e-6)  # float32, NaN where uncovered
    colours = back.visual.vertex_colors
    assert np.all(colours[~np.isfinite(dev.per_vertex), :3] == 160)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.ply", "d.png"]   # no temporary left behind


@pytest.mark.slow
def test_registered_scan_end_to_end():
    """A moved, bumped scan registered onto the vault: the bump comes back in the map (the rigid part
    the registration absorbs is a fraction of the bump's volume)."""
    from scipy.spatial.transform import Rotation

    from airmat.asbuilt.registration import register

    v, f = vault()
    pts, _, _ = bumped_scan(n=30_000, seed=3, x_min=-WIDTH / 2)
    rot = Rotation.random(random_state=3).as_matrix()
    moved = pts @ rot.T + [1.0, -2.0, 0.5]
    reg = register(moved, v, f, seed=0, remove_floor=False)
    dev = deviation_map(reg.apply(moved), v, f)
    truth = bump(v[:, 0], v[:, 1])
    covered = np.isfinite(dev.per_vertex)
    # the vault alone is symmetric: the pose may be its mirror turn, but the bump then sits mirrored;
    # compare with the one that fits
    mirrored = bump(-v[:, 0], -v[:, 1])
    err = min(np.abs(dev.per_vertex[covered] - t[covered]).max() for t in (truth, mirrored))
    assert err < 0.2 * BUMP


def test_bad_shapes_are_refused():
    v, f = vault(n=(5, 5))
    with pytest.raises(InputError, match=r"points must have shape \(N, 3\)"):
        deviation_map(np.zeros((4, 2)), v, f)
    with pytest.raises(InputError, match=r"faces must have shape \(F, 3\)"):
        deviation_map(v, v, f[:, :2])
