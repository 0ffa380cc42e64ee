"""Reading scans: every PLY encoding, meshes, units, NaN, and one clear error per bad file."""

import logging
from itertools import product

import numpy as np
import pytest
import trimesh

from airmat.errors import InputError
from airmat.calib.scan_io import MIN_POINTS, read_scan
from airmat.synthetic.ply_write import ENCODINGS, write_ply


@pytest.fixture(scope="module")
def cloud_mm():
    rng = np.random.default_rng(0)
    return rng.uniform(-300.0, 300.0, (2000, 3))


@pytest.mark.parametrize("encoding, dtype, props", list(product(
    ENCODINGS, ("float32", "float64"), ("none", "color", "confidence", "both"))))
def test_every_ply_flavour_reads_the_same_points(tmp_path, cloud_mm, encoding, dtype, props):
    rng = np.random.default_rng(1)
    colors = rng.integers(0, 256, (len(cloud_mm), 3), dtype=np.uint8) if props in ("color", "both") else None
    extra = {"confidence": rng.random(len(cloud_mm)).astype(np.float32),
             "ring": rng.integers(0, 64, len(cloud_mm)).astype(np.uint16)} \
        if props in ("confidence", "both") else None
    path = tmp_path / f"c_{encoding}_{dtype}_{props}.ply"
    write_ply(path, cloud_mm, encoding=encoding, dtype=dtype, colors=colors, extra=extra)
    assert path.read_bytes().split(b"\n")[1] == f"format {encoding} 1.0".encode()
    scan = read_scan(path)
    expected = cloud_mm.astype(dtype).astype(float) * 1e-3
    np.testing.assert_array_equal(scan.points, expected)
    assert scan.kind == "points" and scan.n_nonfinite_dropped == 0 and scan.path == str(path)


@pytest.mark.parametrize("units, factor", [("mm", 1e-3), ("m", 1.0), ("in", 0.0254)])
def test_units(tmp_path, units, factor):
    rng = np.random.default_rng(2)
    pts = rng.uniform(-5.0, 5.0, (500, 3)) * (0.05 / factor)  # about 0.3 m across in any unit
    path = tmp_path / "u.ply"
    write_ply(path, pts, dtype="float64")
    np.testing.assert_allclose(read_scan(path, units=units).points, pts * factor, rtol=1e-15)


def _cylinder_mesh(sections, R=150.0, h=400.0):
    return trimesh.creation.cylinder(radius=R, height=h, sections=sections)


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".off"])
def test_fine_mesh_gives_its_vertices(tmp_path, suffix):
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=200.0)  # 642 vertices
    path = tmp_path / f"m{suffix}"
    mesh.export(path)
    scan = read_scan(path, n_mesh_samples=100)
    assert scan.kind == "mesh"
    got = np.unique(np.round(scan.points, 9), axis=0)
    want = np.unique(np.round(mesh.vertices * 1e-3, 9), axis=0)
    np.testing.assert_allclose(got, want, atol=1e-6)  # STL/OBJ store 32-bit or printed floats


@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_coarse_mesh_is_sampled_on_its_faces(tmp_path, suffix):
    mesh = _cylinder_mesh(sections=24)
    path = tmp_path / f"coarse{suffix}"
    mesh.export(path)
    scan = read_scan(path, n_mesh_samples=5000, seed=3)
    assert scan.kind == "mesh" and len(scan.points) == 5000
    # every sample lies on the mesh (closest-point distance ~ 0)
    import igl

    d2, *_ = igl.point_mesh_squared_distance(scan.points * 1e3, np.asarray(mesh.vertices, float),
                                             np.asarray(mesh.faces, np.int64))
    assert np.sqrt(d2.max()) < 1e-3  # mm
    # area-weighted: the side (2 pi R h) holds its share of the samples
    side = np.abs(np.abs(scan.points[:, 2] * 1e3) - 200.0) > 1e-6
    share = 2 * np.pi * 150 * 400 / (2 * np.pi * 150 * 400 + 2 * np.pi * 150**2)
    assert side.mean() == pytest.approx(share, abs=0.03)
    again = read_scan(path, n_mesh_samples=5000, seed=3)
    np.testing.assert_array_equal(again.points, scan.points)


def test_nonfinite_points_are_dropped_counted_and_logged(tmp_path, cloud_mm, caplog):
    pts = cloud_mm.copy()
    pts[[3, 10, 11]] = np.nan
    pts[20, 1] = np.inf
    path = tmp_path / "organized.ply"
    write_ply(path, pts, encoding="binary_little_endian", dtype="float32")
    with caplog.at_level(logging.WARNING, logger="airmat.calib.scan_io"):
        scan = read_scan(path)
    assert scan.n_nonfinite_dropped == 4
    assert len(scan.points) == len(pts) - 4 and np.isfinite(scan.points).all()
    assert any("dropped 4 of 2000" in r.getMessage() for r in caplog.records)


def _assert_input_error(path, *words, **kw):
    with pytest.raises(InputError) as exc:
        read_scan(path, **kw)
    assert exc.value.path == str(path)
    line = exc.value.one_line()
    assert "\n" not in line and str(path) in line
    for w in words:
        assert w in line
    return exc.value


def test_missing_file(tmp_path):
    _assert_input_error(tmp_path / "nope.ply", "no such file")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.ply"
    path.write_bytes(b"")
    _assert_input_error(path, "empty")


def test_no_vertices(tmp_path):
    path = tmp_path / "zero.ply"
    path.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                     b"property float z\nend_header\n")
    _assert_input_error(path, "no points")


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize("cut", [0.5, 0.999])
def test_truncated_ply(tmp_path, cloud_mm, encoding, cut):
    full = tmp_path / "full.ply"
    write_ply(full, cloud_mm, encoding=encoding)
    data = full.read_bytes()
    path = tmp_path / "cut.ply"
    path.write_bytes(data[:int(len(data) * cut)])
    _assert_input_error(path)


def test_garbage_and_unsupported(tmp_path):
    path = tmp_path / "garbage.ply"
    path.write_bytes(b"this is not a ply file\n")
    _assert_input_error(path, "not a PLY")
    other = tmp_path / "scan.abc"
    other.write_bytes(b"xx")
    _assert_input_error(other, "unsupported", ".e57", ".laz", ".pcd")
    e57 = tmp_path / "scan.e57"
    e57.write_bytes(b"xx")
    _assert_input_error(e57, "cannot parse E57 file")


def test_too_few_points(tmp_path, cloud_mm):
    path = tmp_path / "few.ply"
    pts = cloud_mm[:MIN_POINTS + 5].copy()
    pts[:10] = np.nan
    write_ply(path, pts)
    err = _assert_input_error(path, f"only {MIN_POINTS - 5} finite points", str(MIN_POINTS))
    assert err.data["n_points"] == MIN_POINTS - 5


def test_metres_read_as_millimetres_is_caught(tmp_path, cloud_mm):
    path = tmp_path / "metres.ply"
    write_ply(path, cloud_mm * 1e-3)  # a 1 m scan written in metres
    _assert_input_error(path, "are the coordinates in metres? pass --scan-units m")
    assert len(read_scan(path, units="m").points) == len(cloud_mm)


def test_absurdly_large_scan_is_caught(tmp_path, cloud_mm):
    path = tmp_path / "huge.ply"
    write_ply(path, cloud_mm)  # mm numbers read as metres: 1000 m across
    _assert_input_error(path, "m read in m", "--scan-units mm", units="m")


def test_unknown_unit(tmp_path, cloud_mm):
    path = tmp_path / "c.ply"
    write_ply(path, cloud_mm)
    _assert_input_error(path, "unknown scan unit", units="furlong")
