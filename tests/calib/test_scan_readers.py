"""The fast scan readers (text rows, PCD, binary PLY, LAZ, E57) give the bits of the libraries they stand in for,
and refuse what those libraries refuse."""

import numpy as np
import pytest

from airmat.errors import InputError, NotACylinderError
from airmat.calib.cylinder_fit import fit_cylinder
from airmat.calib.scan_io import read_scan
from airmat.synthetic.ply_write import write_ply
from airmat.synthetic.scan_write import write_scan
from airmat.synthetic.specimen_scan import specimen_scan


@pytest.fixture(scope="module")
def spec():
    return specimen_scan(1 / 0.3, n_points=40_000, seed=11)


@pytest.mark.parametrize("fmt", ["pts", "xyz", "txt"])
def test_fast_text_read_is_bit_identical_to_loadtxt(tmp_path, spec, fmt):
    from airmat.calib.scan_readers import read_cloud

    path = write_scan(tmp_path / f"s.{fmt}", spec.points[:3000] * 1e3, fmt)
    skip, delim = {"pts": (1, None), "xyz": (0, None), "txt": (1, ",")}[fmt]
    ref = np.loadtxt(path, skiprows=skip, delimiter=delim, usecols=(0, 1, 2))
    got = read_cloud(path).vertices
    assert got.dtype == np.float64 and np.array_equal(got, ref)


def test_text_rows_polars_refuses_go_to_loadtxt(tmp_path):
    from airmat.calib.scan_readers import read_cloud
    from airmat.calib.scan_readers.text_reader import read_columns_fast

    path = tmp_path / "n.xyz"
    path.write_text("1 2 3\nnan 5 6\n7 8 9\n")  # nan: loadtxt reads it, the caller drops it
    assert read_columns_fast(path, 0, None, 3) is None
    got = read_cloud(path).vertices
    assert np.isnan(got[1, 0]) and got[2].tolist() == [7.0, 8.0, 9.0]
    short = tmp_path / "short.xyz"
    short.write_text("1 2 3\n4 5\n7 8 9\n")  # never a silently filled value
    assert read_columns_fast(short, 0, None, 3) is None
    with pytest.raises(InputError, match="cannot parse XYZ columns"):
        read_cloud(short)
    aligned = tmp_path / "aligned.xyz"  # runs of blanks: loadtxt
    aligned.write_text("1  2 3\n4 5   6\n")
    assert read_columns_fast(aligned, 0, None, 3) is None
    assert read_cloud(aligned).vertices.tolist() == [[1, 2, 3], [4, 5, 6]]


@pytest.mark.parametrize("text", [
    "1 2 3 9\n# a comment below the first row\n4 5 6 9\n7 8 9 9\n",   # polars' second pass
    "1\t2\t3\n4\t5\t6\n7\t8\t9\n",                                 # tabs
    "1 2 3\n4 5 6\n7 8 9\n\n\n",                                       # blank lines at the end
    "1,2,3,a word\r\n4,5,6,x\r\n7,8,9,y\r\n",                         # CRLF; further columns not parsed
    "1 2 3\n4 5 6 7 8\n7 8 9 10\n",                                     # rows longer than the first
])
def test_text_layouts_polars_reads(tmp_path, text):
    from airmat.calib.scan_readers import read_cloud
    from airmat.calib.scan_readers.text_reader import _layout, read_columns_fast

    path = tmp_path / "c.txt"
    path.write_bytes(text.encode())
    layout = _layout(text.splitlines(), path)
    fast = read_columns_fast(path, layout.skip, layout.delimiter, layout.width, layout.usecols)
    want = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]
    assert fast is not None and fast.tolist() == want and fast.flags["C_CONTIGUOUS"]
    assert read_cloud(path).vertices.tolist() == want


def test_ascii_pcd_read_as_open3d_reads_it(tmp_path, spec):
    from airmat.calib.scan_readers import pcd_reader

    pts = spec.points[:4000] * 1e3
    pts[::9] = np.nan
    path = write_scan(tmp_path / "a.pcd", pts, "pcd_ascii")
    got = pcd_reader.read(path).vertices
    assert np.array_equal(got, pcd_reader._read_open3d(path), equal_nan=True)
    odd = tmp_path / "odd.pcd"  # x y z not first nor in order, a field with COUNT 2
    odd.write_text("VERSION 0.7\nFIELDS rgb normal z x y\nSIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 2 1 1 1\n"
                   "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n9 0 0 3 1 2\n9 0 0 6 4 5\n")
    assert pcd_reader.read(odd).vertices.tolist() == [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]


@pytest.mark.parametrize("encoding", ["binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_binary_ply_cloud_read_by_numpy_as_trimesh_reads_it(tmp_path, spec, encoding, dtype):
    import trimesh

    from airmat.calib.scan_readers.ply_points import read_binary_points

    pts = spec.points[:2000] * 1e3
    path = tmp_path / "c.ply"
    write_ply(path, pts, encoding=encoding, dtype=dtype, colors=np.zeros((len(pts), 3), np.uint8))
    got = read_binary_points(path)
    assert got is not None and got.float32 == (dtype == "float32")
    assert np.array_equal(got.vertices, np.asarray(trimesh.load(path, process=False).vertices, float))
    mesh = tmp_path / "m.ply"
    trimesh.creation.box().export(mesh, encoding="binary")
    assert read_binary_points(mesh) is None  # faces: trimesh reads it
    ascii_ = tmp_path / "a.ply"
    write_ply(ascii_, pts, encoding="ascii")
    assert read_binary_points(ascii_) is None


def test_km_survey_tile_read_in_mm_is_refused(tmp_path):
    """A 4 km terrain tile in metres, read in the default mm, is 4 m across: no specimen is."""
    rng = np.random.default_rng(0)
    n = 60_000
    xy = rng.uniform(0, 4000, (n, 2))
    z = 15 * np.sin(xy[:, 0] / 700) + 8 * np.cos(xy[:, 1] / 900) + rng.normal(0, 0.05, n)
    path = tmp_path / "tile.xyz"
    np.savetxt(path, np.column_stack([xy + [512000, 5400000], z + 300]), fmt="%.3f")
    scan = read_scan(path)  # passes the read: 5.7 m is a plausible scan (a room)
    with pytest.raises(NotACylinderError, match="spans 5.* m, more than any specimen"):
        fit_cylinder(scan.points, seed=0)
    same = fit_cylinder(scan.points * 0.5, seed=0)  # the same surface at 2.8 m: a fit (a gentle cylinder)
    assert same.n_inliers > 0.5 * n


def test_km_survey_tile_cli_exit_2(tmp_path, capsys):
    from airmat.cli import main

    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 5000, (30_000, 2))
    z = 10 * np.sin(xy[:, 0] / 900) + rng.normal(0, 0.05, len(xy))
    path = tmp_path / "tile.xyz"
    np.savetxt(path, np.column_stack([xy, z]), fmt="%.3f")
    assert main(["fit", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "more than any specimen" in err[0]


def test_binary_pcd_read_by_numpy_as_open3d_reads_it(tmp_path, spec):
    from airmat.calib.scan_readers import pcd_reader

    pts = spec.points[:4000] * 1e3
    pts[::9] = np.nan
    path = write_scan(tmp_path / "b.pcd", pts, "pcd_binary")
    got = pcd_reader._read_binary(path, pcd_reader._header(path))
    assert got is not None and np.array_equal(got, pcd_reader._read_open3d(path), equal_nan=True)
    # PCL's layout: padding "_" fields, a field with COUNT 3, x y z not first
    rec = np.dtype([("rgb", "<f4"), ("n", "<f4", (3,)), ("_", "<u1", (4,)), ("z", "<f8"), ("x", "<f8"),
                    ("y", "<f8"), ("_2", "<u1", (4,))])
    body = np.zeros(3, rec)
    body["x"], body["y"], body["z"] = [1, 4, 7], [2, 5, 8], [3, 6, 9]
    head = ("VERSION 0.7\nFIELDS rgb normal _ z x y _\nSIZE 4 4 1 8 8 8 1\nTYPE F F U F F F U\n"
            "COUNT 1 3 4 1 1 1 4\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary\n").encode()
    odd = tmp_path / "odd.pcd"
    odd.write_bytes(head + body.tobytes())
    raw = pcd_reader.read(odd)
    assert raw.vertices.tolist() == [[1, 2, 3], [4, 5, 6], [7, 8, 9]] and not raw.float32
    cut = tmp_path / "cut.pcd"
    cut.write_bytes(head + body.tobytes()[:-10])
    with pytest.raises(InputError, match="truncated or corrupt"):
        read_scan(cut)


def test_compressed_pcd_read_by_lzf_as_open3d_reads_it(tmp_path, spec, monkeypatch):
    pytest.importorskip("lzf")
    import sys

    import open3d as o3d

    from airmat.calib.scan_readers import pcd_reader

    pts = spec.points[:5000] * 1e3
    pts[::11] = np.nan
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    rng = np.random.default_rng(0)
    cloud.normals = o3d.utility.Vector3dVector(rng.normal(size=pts.shape))
    cloud.colors = o3d.utility.Vector3dVector(rng.uniform(size=pts.shape))
    path = tmp_path / "c.pcd"  # fields x y z normal_x normal_y normal_z curvature rgb, one LZF block
    o3d.io.write_point_cloud(str(path), cloud, compressed=True)
    assert b"binary_compressed" in path.read_bytes()[:400]
    header = pcd_reader._header(path)
    got = pcd_reader._read_compressed(path, header)
    assert got is not None and got.shape == pts.shape
    assert np.array_equal(got, pcd_reader._read_open3d(path), equal_nan=True)
    assert np.array_equal(got, pts.astype(np.float32), equal_nan=True)  # open3d stores float32
    monkeypatch.setitem(sys.modules, "lzf", None)  # python-lzf missing: open3d reads it, same points
    assert pcd_reader._read_compressed(path, header) is None
    assert np.array_equal(pcd_reader.read(path).vertices, got, equal_nan=True)
    monkeypatch.undo()
    cut = tmp_path / "cut.pcd"
    cut.write_bytes(path.read_bytes()[:-2000])
    with pytest.raises(InputError, match="cannot parse PCD file"):
        read_scan(cut)


def test_laz14_decodes_only_the_xyz_layers_with_the_same_bits(tmp_path, spec):
    import laspy

    from airmat.calib.scan_readers import las_reader

    path = write_scan(tmp_path / "s.laz", spec.points * 1e3, "laz14", seed=2)
    full = laspy.read(str(path))
    assert full.header.point_format.id == 6 and full.intensity.max() > 0  # other layers hold data
    want = np.column_stack([np.asarray(full.x), np.asarray(full.y), np.asarray(full.z)])
    got = las_reader.read(path).vertices
    assert np.array_equal(got, want) and got.flags["C_CONTIGUOUS"]


def test_e57_invalid_points_become_nan_and_are_dropped(tmp_path, spec):
    import pye57

    pts = spec.points[:3000]
    invalid = np.zeros(len(pts), np.int8)
    invalid[::13] = 2
    path = tmp_path / "inv.e57"
    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({"cartesianX": pts[:, 0], "cartesianY": pts[:, 1], "cartesianZ": pts[:, 2],
                        "cartesianInvalidState": invalid})
    e57.close()
    scan = read_scan(path)
    assert scan.n_nonfinite_dropped == np.count_nonzero(invalid)
    assert np.array_equal(scan.points + scan.offset, pts[invalid == 0].astype(np.float32))  # pye57 writes floats


def test_an_e57_without_pye57_is_refused_saying_what_to_do(tmp_path, monkeypatch):
    # pye57 has no wheel for Intel macOS: there an E57 scan is refused with the way out, not a traceback
    import sys

    write_scan(tmp_path / "s.e57", specimen_scan(4.0, n_points=2000, seed=0).points * 1e3, "e57")
    monkeypatch.setitem(sys.modules, "pye57", None)           # import pye57 -> ImportError
    with pytest.raises(InputError, match="reading E57 needs pye57.*save the scan as PLY or LAS") as err:
        read_scan(tmp_path / "s.e57")
    assert err.value.one_line().startswith(str(tmp_path / "s.e57") + ": reading E57")
