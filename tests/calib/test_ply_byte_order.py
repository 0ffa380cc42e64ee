"""A binary PLY whose body was written in the other byte order than its header says is refused, saying so
(airmat.calib.scan_readers.ply_header)."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.scan_io import read_scan
from airmat.calib.scan_readers.ply_header import check_ply_complete
from airmat.design.target import load_target


def _cloud(n=3000):
    """Points on a 300 mm cylinder (mm)."""
    rng = np.random.default_rng(1)
    t, z = rng.uniform(0, 1.5, n), rng.uniform(0, 700, n)
    return np.c_[300 * np.sin(t), z, 300 * np.cos(t)]


def _ply(path, points, *, header_order, data_order, ctype="float", faces=None):
    """A binary PLY of ``points`` (and triangles) whose header says ``header_order`` ('<' or '>') while its
    body is written in ``data_order``."""
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[header_order]
    code = {"float": "f4", "double": "f8"}[ctype]
    head = (f"ply\nformat {fmt} 1.0\nelement vertex {len(points)}\nproperty {ctype} x\nproperty {ctype} y\n"
            f"property {ctype} z\n")
    body = np.asarray(points, data_order + code).tobytes()
    if faces is not None:
        head += f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
        rows = np.zeros(len(faces), [("n", "u1"), ("i", data_order + "i4", 3)])
        rows["n"], rows["i"] = 3, faces
        body += rows.tobytes()
    path.write_bytes((head + "end_header\n").encode() + body)
    return path


@pytest.mark.parametrize("ctype", ["float", "double"])
@pytest.mark.parametrize("header_order, data_order", [(">", "<"), ("<", ">")])
def test_a_scan_in_the_other_byte_order_is_refused_saying_which(tmp_path, ctype, header_order, data_order):
    points = _cloud()
    path = _ply(tmp_path / "scan.ply", points, header_order=header_order, data_order=data_order, ctype=ctype)
    written = {"<": "binary_little_endian", ">": "binary_big_endian"}[data_order]
    with pytest.raises(InputError, match=f"do not read as coordinates in the header's byte order .* the file "
                                         f"was written {written}") as err:
        read_scan(path)
    assert err.value.path == path or err.value.path == str(path)
    x, y, z = points[0]
    assert f"({x:.4g}, {y:.4g}, {z:.4g})" in str(err.value)   # the first vertex, read the right way


@pytest.mark.parametrize("ctype", ["float", "double"])
@pytest.mark.parametrize("order", ["<", ">"])
def test_a_scan_in_its_own_byte_order_passes_and_reads(tmp_path, ctype, order):
    points = _cloud()
    path = _ply(tmp_path / "scan.ply", points, header_order=order, data_order=order, ctype=ctype)
    assert check_ply_complete(path) is False   # binary, whole, the right order
    got = read_scan(path)
    assert np.allclose(np.asarray(got.points) * 1e3, points.astype(np.float32 if ctype == "float" else float),
                       atol=1e-3)


def test_a_target_in_the_other_byte_order_is_refused(tmp_path):
    u, v = np.meshgrid(np.linspace(0, 800, 9), np.linspace(0, 600, 7), indexing="ij")
    vertices = np.c_[u.ravel(), v.ravel(), 100 * np.sin(np.pi * u.ravel() / 800)]
    idx = np.arange(63).reshape(9, 7)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    good = _ply(tmp_path / "good.ply", vertices, header_order=">", data_order=">", faces=faces)
    assert len(load_target(good).faces) == len(faces)
    bad = _ply(tmp_path / "bad.ply", vertices, header_order=">", data_order="<", faces=faces)
    with pytest.raises(InputError, match="the file was written binary_little_endian; fix the header's 'format'"):
        load_target(bad)


def test_a_scan_that_starts_with_nan_rows_is_left_to_the_reader(tmp_path):
    """A structured scanner pads missing points with NaN: they read as coordinates in neither order, so the
    byte-order check says nothing (the reader drops them)."""
    points = _cloud()
    points[:1200] = np.nan
    path = _ply(tmp_path / "padded.ply", points, header_order="<", data_order="<")
    assert check_ply_complete(path) is False
