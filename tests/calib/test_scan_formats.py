"""Scanner formats written by the real libraries, coordinates, precision, and fits right or refused."""

import dataclasses
import logging

import numpy as np
import pytest

from airmat.errors import InputError, NotACylinderError
from airmat.calib.cylinder_fit import fit_cylinder
from airmat.calib.cylinder_stability import fit_cylinder_stable
from airmat.calib.scan_io import read_scan
from airmat.synthetic.ply_write import write_ply
from airmat.synthetic.scan_write import FORMATS, write_scan
from airmat.synthetic.specimen_scan import specimen_scan


def _max_nn_distance(a, b):
    from scipy.spatial import cKDTree

    return float(cKDTree(b).query(a)[0].max())


@pytest.fixture(scope="module")
def spec():
    return specimen_scan(1 / 0.3, n_points=40_000, seed=11)


@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_every_format_written_by_its_library_fits_within_half_a_percent(tmp_path, spec, fmt):
    path = write_scan(tmp_path / f"s{FORMATS[fmt]}", spec.points * 1e3, fmt, seed=1)
    scan = read_scan(path)
    assert scan.units == ("m" if fmt in ("e57", "las", "laz", "laz14") else "mm")
    assert len(scan.points) == len(spec.points) and scan.n_nonfinite_dropped == 0
    # the same points, to the file's precision (LAS: 0.01 mm; text: 1e-4 mm; float32: ~1e-7 m)
    assert _max_nn_distance(scan.points + scan.offset, spec.points) < 2e-5
    fit = fit_cylinder(scan.points, seed=0, quantization=scan.quantization, strict=True)
    assert fit.radius == pytest.approx(spec.radius, rel=0.005)


def test_multiscan_e57_applies_the_poses_and_picks_a_scan(tmp_path, spec):
    from scipy.spatial.transform import Rotation

    poses = [(Rotation.from_euler("xyz", a, degrees=True).as_matrix(), t)
             for a, t in [((0, 0, 0), (0, 0, 0)), ((10, -20, 70), (1500.0, -300.0, 800.0)),
                          ((-5, 30, 200), (-900.0, 2000.0, 100.0))]]
    path = write_scan(tmp_path / "multi.e57", spec.points * 1e3, "e57", poses=poses, seed=3)
    merged = read_scan(path)
    assert merged.n_scans == 3 and len(merged.points) == len(spec.points)
    fit = fit_cylinder(merged.points, seed=0, strict=True)
    assert fit.radius == pytest.approx(spec.radius, rel=0.005)
    parts = [read_scan(path, scan_index=k).points for k in range(3)]
    assert sum(map(len, parts)) == len(spec.points)
    # each scan, with its pose, lands on the original points
    assert _max_nn_distance(np.concatenate(parts), spec.points) < 1e-6  # pye57 stores single floats
    with pytest.raises(InputError, match="--scan-index 3 out of range: the file holds 3 scan"):
        read_scan(path, scan_index=3)


def test_georeferenced_scan_is_recentred_and_fits_as_at_the_origin(tmp_path, spec):
    utm = np.array([5e6, 4.2e6, 312.0])  # metres
    near = write_scan(tmp_path / "near.laz", spec.points * 1e3, "laz")
    far = write_scan(tmp_path / "far.laz", (spec.points + utm) * 1e3, "laz")
    a, b = read_scan(near), read_scan(far)
    np.testing.assert_allclose(b.offset, np.round(utm + 0.5 * (spec.points.min(0) + spec.points.max(0))),
                               atol=1.0)
    np.testing.assert_allclose(b.points + b.offset - utm, a.points + a.offset, atol=2e-5)
    fa, fb = (fit_cylinder(s.points, seed=0, strict=True) for s in (a, b))
    assert fb.radius == pytest.approx(fa.radius, rel=1e-4)
    assert fb.radius == pytest.approx(spec.radius, rel=0.005)


def test_float32_file_that_lost_precision_is_refused(tmp_path, spec):
    path = tmp_path / "utm_float32.ply"
    write_ply(path, (spec.points + [5e5, 4.2e6, 0.0]) * 1e3, dtype="float32")  # UTM mm in float32
    scan = read_scan(path)
    assert scan.quantization >= 0.25  # metres: float32 spacing at 4.2e9 mm is 512 mm
    with pytest.raises(InputError, match="lost precision: stored as 32-bit floats"):
        fit_cylinder(scan.points, seed=0, quantization=scan.quantization)
    ok = tmp_path / "near_float32.ply"
    write_ply(ok, spec.points * 1e3, dtype="float32")
    near = read_scan(ok)
    assert 0 < near.quantization < 1e-6
    assert fit_cylinder(near.points, seed=0, quantization=near.quantization).radius == \
        pytest.approx(spec.radius, rel=0.005)


@pytest.mark.parametrize("fmt, units, words", [
    ("las", None, ("not a specimen scan", "LAS format is in m")),          # a 5.6 km aerial tile
    ("xyz", None, ("not a specimen scan", "any other unit")),               # 5.6e6 numbers in any unit
])
def test_extent_no_specimen_has_is_refused_without_a_misleading_hint(tmp_path, fmt, units, words):
    rng = np.random.default_rng(4)
    scale = 5.6e6 if fmt == "las" else 5.6e9
    tile = rng.uniform(0, 1, (3000, 3)) * [scale / 1.5, scale / 1.5, scale / 100]
    path = write_scan(tmp_path / f"tile{FORMATS[fmt]}", tile, fmt)
    with pytest.raises(InputError) as exc:
        read_scan(path, units=units)
    line = exc.value.one_line()
    assert "--scan-units" not in line and "are the coordinates" not in line
    for w in words:
        assert w in line


def test_cm_units(tmp_path, spec):
    path = write_scan(tmp_path / "cm.xyz", spec.points * 1e2, "xyz")
    scan = read_scan(path, units="cm")
    assert fit_cylinder(scan.points, seed=0).radius == pytest.approx(spec.radius, rel=0.005)


@pytest.mark.parametrize("text, n", [
    ("3\n1 2 3 10 1 2 3\n4 5 6 10 1 2 3\n7 8 9 10 1 2 3\n", 3),          # .pts count line
    ("//X,Y,Z,R\n1,2,3,4\n4,5,6,4\n7,8,9,4\n", 3),                     # CloudCompare header
    ("x;y;z\n1;2;3\n4;5;6\n", 2),                                       # semicolons, names
    ("# comment\n1 2 3\n4 5 6\n", 2),
])
def test_text_layouts(tmp_path, text, n):
    from airmat.calib.scan_readers import read_cloud

    path = tmp_path / "c.txt"
    path.write_text(text)
    raw = read_cloud(path)
    assert raw.vertices.shape == (n, 3) and raw.vertices[0].tolist() == [1.0, 2.0, 3.0]


def test_pcd_organized_cloud_with_nan(tmp_path, spec):
    pts = spec.points * 1e3
    pts[::7] = np.nan
    path = write_scan(tmp_path / "org.pcd", pts, "pcd_binary")
    scan = read_scan(path)
    assert scan.n_nonfinite_dropped == len(pts[::7])


def test_unreadable_scan_and_face_index_out_of_range(tmp_path, spec):
    path = tmp_path / "locked.ply"
    write_ply(path, spec.points[:1000] * 1e3)
    import builtins

    real_open = builtins.open

    def denied(file, *args, **kw):  # as os.chmod(path, 0) for a non-root user
        if str(file) == str(path):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *args, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(builtins, "open", denied)
        with pytest.raises(InputError, match="cannot read: Permission denied"):
            read_scan(path)
    bad = tmp_path / "faces.ply"
    v = "\n".join(f"{x} {y} {z}" for x, y, z in spec.points[:200] * 1e3)
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 200\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                   f"end_header\n{v}\n3 0 1 999\n")
    with pytest.raises(InputError, match="face vertex index out of range"):
        read_scan(bad)


def test_missing_texture_leaks_no_loader_log(tmp_path, spec, caplog):
    path = tmp_path / "tex.ply"
    v = "\n".join(f"{x} {y} {z}" for x, y, z in spec.points[:300] * 1e3)
    path.write_text("ply\nformat ascii 1.0\ncomment TextureFile missing.png\nelement vertex 300\n"
                    "property float x\nproperty float y\nproperty float z\n" f"end_header\n{v}\n")
    with caplog.at_level(logging.DEBUG):
        read_scan(path)
    assert not [r for r in caplog.records if r.name.startswith("trimesh") and r.levelno >= logging.WARNING]


def test_tiny_cloud_message_speaks_in_points(spec):
    with pytest.raises(NotACylinderError, match="too few points"):
        fit_cylinder(spec.points[:120], seed=0)


def test_noise_hint_names_the_option(spec, monkeypatch):
    import airmat.calib.cylinder_fit as cf

    real = cf.local_noise

    def too_low(*args, **kw):  # the estimate a stereo/RGB-D scan gets: far below its real noise
        est = real(*args, **kw)
        return dataclasses.replace(est, sigma=est.sigma / 20)

    monkeypatch.setattr(cf, "local_noise", too_low)
    with pytest.raises(NotACylinderError, match="estimated noise.*pass --noise-mm"):
        fit_cylinder(spec.points, seed=0, max_rms_rel=0.0)
    monkeypatch.setattr(cf, "local_noise", real)
    with pytest.raises(NotACylinderError) as exc:  # a noise the user gave: no hint to give it
        fit_cylinder(spec.points, seed=0, noise=1e-5, max_rms_rel=0.0)
    assert "given noise" in str(exc.value) and "--noise-mm" not in str(exc.value)


def test_seed_disagreement_widens_or_refuses(spec, monkeypatch):
    import airmat.calib.cylinder_stability as cs

    real = cs.fit_cylinder
    calls = []

    def shifted(points, *, seed=0, **kw):
        fit = real(points, seed=seed, **kw)
        calls.append(seed)
        bump = {1: 0.0, 2: 0.01, 3: 0.2}[len(calls)] * fit.kappa  # 1 %, then 20 % on the third
        return dataclasses.replace(fit, kappa=fit.kappa + bump)

    monkeypatch.setattr(cs, "fit_cylinder", shifted)
    with pytest.raises(NotACylinderError, match="unstable fit: seeds give R ="):
        fit_cylinder_stable(spec.points, seed=0, n_seeds=3)
    calls.clear()
    wide = fit_cylinder_stable(spec.points, seed=0, n_seeds=2)  # 0 then 1 %: widened
    assert wide.n_seeds == 2 and wide.kappa_spread == pytest.approx(0.01 * wide.kappa, rel=1e-6)
    assert wide.kappa_se >= wide.kappa_spread


def test_seeds_agree_on_a_clean_scan(spec):
    fit = fit_cylinder_stable(spec.points, seed=0, n_seeds=3)
    assert fit.n_seeds == 3 and fit.kappa_spread < 3 * fit.kappa_se * 1.5
    assert fit.kappa_se == fit_cylinder(spec.points, seed=0).kappa_se  # not widened


def test_check_fits_use_all_of_a_small_scan_and_25k_of_a_large_one(monkeypatch):
    import airmat.calib.cylinder_stability as cs

    assert [cs.check_subset_size(n) for n in (40_000, 100_000, 100_001, 1_280_000)] == \
        [40_000, 50_000, 25_000, 25_000]
    real, sizes = cs.fit_cylinder, []

    def counted(points, **kw):
        sizes.append(len(points))
        return real(points, **kw)

    monkeypatch.setattr(cs, "fit_cylinder", counted)
    big = specimen_scan(5.0, n_points=120_000, seed=5)
    fit = fit_cylinder_stable(big.points, seed=0, n_seeds=3)
    assert sorted(sizes) == [25_000, 25_000, 120_000] and fit.n_seeds == 3  # the checks run in a thread
    assert fit.kappa_spread < 0.001 * fit.kappa  # a clean scan: the small checks agree to 0.1 %
    assert abs(fit.kappa - 5.0) < 0.001 * 5.0


def test_check_fits_in_a_thread_give_the_same_bits_as_one_after_the_other(monkeypatch):
    import airmat.calib.cylinder_stability as cs

    big = specimen_scan(4.0, n_points=110_000, arc_deg=70.0, seed=6)
    threaded = fit_cylinder_stable(big.points, seed=2, n_seeds=3, n_check_points=25_000)
    monkeypatch.setattr(cs, "LARGE_SCAN", 10**9)  # the small-scan path: sequential
    serial = fit_cylinder_stable(big.points, seed=2, n_seeds=3, n_check_points=25_000)
    assert threaded.n_seeds == serial.n_seeds == 3 and threaded.kappa_spread > 0
    for field in dataclasses.fields(serial):
        a, b = getattr(threaded, field.name), getattr(serial, field.name)
        assert np.array_equal(a, b), field.name
