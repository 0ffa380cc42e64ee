"""A mesh or scan file cut short is refused before a library reads part of it (airmat.calib.scan_readers.cut_short)."""

import numpy as np
import pytest
import trimesh

from airmat.errors import InputError
from airmat.calib.scan_readers.cut_short import check_complete
from airmat.design.target import load_target

#: (suffix, trimesh export options)
FORMATS = [("ply", {"encoding": "binary"}), ("ply", {"encoding": "ascii"}), ("off", {}),
           ("stl", {}), ("stl", {"file_type": "stl_ascii"}), ("obj", {})]


def _surface():
    """A 0.8 × 0.6 m grid surface, gently curved, in mm: a small target."""
    u, v = np.meshgrid(np.linspace(0, 800, 13), np.linspace(0, 600, 11), indexing="ij")
    z = 100 * np.sin(np.pi * u / 800)
    vertices = np.column_stack([u.ravel(), v.ravel(), z.ravel()])
    idx = np.arange(13 * 11).reshape(13, 11)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return trimesh.Trimesh(vertices, np.r_[np.c_[a, b, c], np.c_[a, c, d]], process=False)


def _write(tmp_path, suffix, options, name="whole"):
    opts = dict(options)
    data = _surface().export(file_type=opts.pop("file_type", suffix), **opts)
    path = tmp_path / f"{name}.{suffix}"
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


@pytest.mark.parametrize("suffix, options", FORMATS)
def test_a_whole_file_passes_and_reads(tmp_path, suffix, options):
    path = _write(tmp_path, suffix, options)
    check_complete(path)
    assert len(load_target(path).faces) == 240


@pytest.mark.parametrize("suffix, options", FORMATS)
@pytest.mark.parametrize("keep", [0.3, 0.7, 0.98, -2])
def test_a_file_cut_short_is_refused_naming_the_file(tmp_path, suffix, options, keep):
    whole = _write(tmp_path, suffix, options).read_bytes().rstrip(b"\n")
    n = len(whole) + keep if keep < 0 else int(len(whole) * keep)   # -2: inside the last number
    path = tmp_path / f"cut.{suffix}"
    path.write_bytes(whole[:n])
    with pytest.raises(InputError, match="truncated") as err:
        check_complete(path)
    assert err.value.path == str(path)
    with pytest.raises(InputError, match="truncated"):
        load_target(path)


@pytest.mark.parametrize("suffix, options", [("ply", {"encoding": "ascii"}), ("off", {})])
def test_a_text_file_cut_at_a_line_break_is_refused_by_its_counts(tmp_path, suffix, options):
    whole = _write(tmp_path, suffix, options).read_bytes()
    cut = whole[:whole.rindex(b"\n", 0, int(0.9 * len(whole))) + 1]   # whole rows, some faces missing
    path = tmp_path / f"cut.{suffix}"
    path.write_bytes(cut)
    with pytest.raises(InputError, match=r"declares .*(rows|faces)"):
        check_complete(path)


def test_a_binary_ply_of_triangles_and_quads_is_not_taken_for_a_cut_one(tmp_path):
    # the first face a quad, the others triangles: shorter than "every face as long as the first"
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], float)
    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n"
              b"property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n"
              b"end_header\n")
    body = (v.astype("<f4").tobytes() + bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes()
            + bytes([3]) + np.array([1, 4, 2], "<i4").tobytes())
    path = tmp_path / "mixed.ply"
    path.write_bytes(header + body)
    check_complete(path)   # not refused: the reader decides
    path.write_bytes(header + body[:-3])
    with pytest.raises(InputError, match="unexpected length|truncated"):
        load_target(path)   # cut, and the reader still refuses it


def test_off_with_counts_on_its_first_line_and_comments(tmp_path):
    path = tmp_path / "t.off"
    path.write_text("OFF 3 1 0\n# a comment\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    check_complete(path)
    path.write_text("OFF 3 1 0\n# a comment\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n")
    with pytest.raises(InputError, match="last face row has 3 values, expected 4"):
        check_complete(path)


def test_an_obj_without_a_final_line_break_is_refused_with_what_to_do(tmp_path):
    path = tmp_path / "t.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3")
    with pytest.raises(InputError, match="ends inside a line.*add one"):
        check_complete(path)
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    check_complete(path)


def test_a_scan_cut_short_is_refused_by_the_scan_reader(tmp_path):
    from airmat.calib.scan_io import read_scan

    whole = _write(tmp_path, "obj", {}).read_bytes()
    path = tmp_path / "scan.obj"
    path.write_bytes(whole[:len(whole) // 2 + 3])
    with pytest.raises(InputError, match="truncated OBJ"):
        read_scan(path)


def _cloud():
    """2000 points on a 300 mm cylinder, mm."""
    rng = np.random.default_rng(0)
    t, z = rng.uniform(0, 1.5, 2000), rng.uniform(0, 700, 2000)
    return np.c_[300 * np.sin(t), z, 300 * np.cos(t)]


def _write_cloud(tmp_path, suffix):
    p, path = _cloud(), tmp_path / f"whole.{suffix}"
    if suffix == "xyz":
        np.savetxt(path, p, fmt="%.3f")
    elif suffix == "pcd":
        head = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                f"WIDTH {len(p)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(p)}\nDATA ascii\n")
        path.write_text(head + "".join(f"{x:.3f} {y:.3f} {z:.3f}\n" for x, y, z in p))
    else:
        import laspy
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales, header.offsets = [1e-4] * 3, [0, 0, 0]
        las = laspy.LasData(header)
        las.x, las.y, las.z = (p / 1e3).T
        las.write(str(path))
    return path


@pytest.mark.parametrize("suffix", ["xyz", "pcd", "las"])
@pytest.mark.parametrize("keep", [0.3, 0.98, -2])
def test_a_point_cloud_cut_short_is_refused(tmp_path, suffix, keep):
    from airmat.calib.scan_io import read_scan

    whole = _write_cloud(tmp_path, suffix)
    assert len(read_scan(whole).points) == 2000
    data = whole.read_bytes().rstrip(b"\n")
    path = tmp_path / f"cut.{suffix}"
    n = len(data) + keep if keep < 0 else int(len(data) * keep)
    n -= data[n - 1:n] == b"\n"   # inside a line: a columns file cut at a line's end looks whole (documented)
    if suffix == "xyz" and data[n:n + 1] == b"\n":
        n -= 2   # a whole last row without its line break is complete too (as long as the row before it)
    path.write_bytes(data[:n])
    with pytest.raises(InputError, match=f"truncated {suffix.upper()}") as err:
        read_scan(path)
    assert err.value.path == str(path)


@pytest.mark.parametrize("sep", [" ", "  "])
def test_an_ascii_pcd_cut_at_a_line_break_is_refused_by_its_count(tmp_path, sep):
    # one blank: polars reads the rows and the reader counts them; two: polars refuses the layout and
    # open3d reads it, which pads a short body with zeros up to POINTS unless the rows are counted first
    data = _write_cloud(tmp_path, "pcd").read_bytes()
    body = data.index(b"DATA ascii\n") + len(b"DATA ascii\n")
    data = data[:body] + data[body:].replace(b" ", sep.encode())
    path = tmp_path / "cut.pcd"
    path.write_bytes(data[:data.rindex(b"\n", 0, len(data) // 2) + 1])
    from airmat.calib.scan_io import read_scan

    with pytest.raises(InputError, match=r"(read \d+ of 2000 points|declares 2000 points, the file has \d+ rows)"):
        read_scan(path)
