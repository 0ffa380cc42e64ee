"""PLY scans whose coordinates are named X, Y, Z read as x, y, z; a PLY without them says what it has
(calib.scan_readers.ply_points.xyz_names, calib.scan_readers.mesh_reader)."""

import numpy as np
import pytest

from airmat.errors import InputError
from calib.scan_io import read_scan


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
