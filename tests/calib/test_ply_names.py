"""PLY scans whose coordinates are named X, Y, Z read as x, y, z; a PLY without them says what it has
(airmat.calib.scan_readers.ply_points.xyz_names, airmat.calib.scan_readers.mesh_reader)."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.scan_io import read_scan


def _points(n=500):
    rng = np.random.default_rng(2)
    t, z = rng.uniform(0, 1.5, n), rng.uniform(0, 700, n)
    return np.c_[300 * np.sin(t), z, 300 * np.cos(t)]


def _write(path, points, names, encoding):
    head = (f"ply\nformat {encoding} 1.0\nelement vertex {len(points)}\n"
            + "".join(f"property float {n}\n" for n in names) + "end_header\n")
    if encoding == "ascii":
        body = "".join(" ".join(f"{v:.4f}" for v in row) + "\n" for row in points).encode()
    else:
        body = np.asarray(points, "<f4").tobytes()
    path.write_bytes(head.encode() + body)
    return path


@pytest.mark.parametrize("encoding", ["binary_little_endian", "ascii"])
def test_upper_case_coordinates_read_as_lower_case(tmp_path, encoding):
    p = _points()
    lower = read_scan(_write(tmp_path / "lower.ply", p, "xyz", encoding))
    upper = read_scan(_write(tmp_path / "upper.ply", p, "XYZ", encoding))
    np.testing.assert_array_equal(np.asarray(upper.points), np.asarray(lower.points))
    np.testing.assert_allclose(np.asarray(upper.points) * 1e3, p, atol=1e-3)


@pytest.mark.parametrize("encoding", ["binary_little_endian", "ascii"])
def test_a_ply_without_coordinates_says_what_it_has(tmp_path, encoding):
    path = _write(tmp_path / "px.ply", _points(), ["px", "py", "pz"], encoding)
    with pytest.raises(InputError, match=r"the PLY's vertex element has no x, y, z properties \(it has: px, py, pz\)"):
        read_scan(path)


def test_a_target_with_upper_case_coordinates_reads_as_the_lower_case_one(tmp_path):
    import trimesh

    from airmat.design.target import load_target

    u, v = np.meshgrid(np.linspace(0, 800, 9), np.linspace(0, 600, 7), indexing="ij")
    mesh = trimesh.Trimesh(np.c_[u.ravel(), v.ravel(), 100 * np.sin(np.pi * u.ravel() / 800)],
                           [[i * 7 + j, i * 7 + j + 7, i * 7 + j + 8] for i in range(8) for j in range(6)]
                           + [[i * 7 + j, i * 7 + j + 8, i * 7 + j + 1] for i in range(8) for j in range(6)],
                           process=False)
    lower = tmp_path / "lower.ply"
    mesh.export(lower)
    data = lower.read_bytes()
    end = data.index(b"end_header")
    head = data[:end]
    for c in b"xyz":
        head = head.replace(b"property float " + bytes([c]) + b"\n", b"property float " + bytes([c]).upper() + b"\n")
    assert b"property float X\n" in head
    upper = tmp_path / "upper.ply"
    upper.write_bytes(head + data[end:])
    a, b = load_target(lower), load_target(upper)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    none = tmp_path / "none.ply"
    none.write_bytes(head.replace(b"float X\n", b"float P\n") + data[end:])
    with pytest.raises(InputError, match=r"no x, y, z properties \(it has: P, Y, Z\)"):
        load_target(none)
