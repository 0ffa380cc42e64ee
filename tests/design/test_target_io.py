"""Loading and validating target meshes (airmat.design.target)."""

import numpy as np
import pytest
import trimesh

from airmat.errors import InputError
from airmat.design.mattress import Mattress
from airmat.design.target import Target, check_scale, load_target

SMALL = Mattress(0.83, 0.74)


def _grid_mesh(n=6, size_mm=1000.0):
    """A gently curved (n × n)-vertex sheet in mm, normals up."""
    s = np.linspace(0, size_mm, n)
    x, y = np.meshgrid(s, s)
    v = np.column_stack([x.ravel(), y.ravel(), 1e-4 * (x.ravel() - 500) ** 2])
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return v, f


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off"])
def test_each_format_loads_in_metres(tmp_path, ext):
    v, f = _grid_mesh()
    path = tmp_path / f"sheet.{ext}"
    trimesh.Trimesh(v, f, process=False).export(path)
    t = load_target(path, mattress=SMALL)
    assert t.name == "sheet"
    assert len(t.faces) == len(f)
    assert len(t.vertices) == len(v)  # STL's per-triangle copies are merged
    # same geometry, in metres (order may differ after merging)
    assert np.allclose(np.sort(t.vertices, axis=0), np.sort(v * 1e-3, axis=0), atol=1e-9)
    assert t.bbox_diagonal == pytest.approx(np.linalg.norm(np.ptp(v, axis=0)) * 1e-3, rel=1e-6)


def test_units_option(tmp_path):
    v, f = _grid_mesh()
    path = tmp_path / "sheet.ply"
    trimesh.Trimesh(v * 1e-3, f, process=False).export(path)
    t = load_target(path, units="m")
    assert np.ptp(t.vertices[:, 0]) == pytest.approx(1.0)
    with pytest.raises(InputError, match="unknown units"):
        load_target(path, units="furlong")


def test_missing_and_unsupported(tmp_path):
    with pytest.raises(InputError, match="not found") as err:
        load_target(tmp_path / "nope.obj")
    assert err.value.path.endswith("nope.obj")
    (tmp_path / "a.dxf").write_text("0\nEOF\n")
    with pytest.raises(InputError, match="unsupported target format"):
        load_target(tmp_path / "a.dxf")


@pytest.mark.parametrize("ext, message", [("ply", "not a PLY file"), ("off", "not an OFF file")])
def test_garbage_is_unreadable(tmp_path, ext, message):
    path = tmp_path / f"bad.{ext}"
    path.write_bytes(b"garbage\x00\x01 not a mesh\n")
    with pytest.raises(InputError, match=message) as err:
        load_target(path)
    assert err.value.path == str(path)


@pytest.mark.parametrize("ext", ["obj", "stl"])
def test_empty_mesh(tmp_path, ext):
    path = tmp_path / f"empty.{ext}"
    path.write_bytes(b"")
    with pytest.raises(InputError, match="empty mesh") as err:
        load_target(path)
    assert err.value.path == str(path)


def test_point_cloud_is_empty_mesh(tmp_path):
    path = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).normal(size=(20, 3))).export(path)
    with pytest.raises(InputError, match="empty mesh"):
        load_target(path)


QUADS = {
    "obj": "v 0 0 0\nv 1000 0 0\nv 1000 1000 0\nv 0 1000 0\nv 2000 0 0\nv 2000 1000 0\n"
           "f 1 2 3 4\nf 2 5 6 3\n",
    "off": "OFF\n6 2 0\n0 0 0\n1000 0 0\n1000 1000 0\n0 1000 0\n2000 0 0\n2000 1000 0\n"
           "4 0 1 2 3\n4 1 4 5 2\n",
    "ply": "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
           "0 0 0\n1000 0 0\n1000 1000 0\n0 1000 0\n2000 0 0\n2000 1000 0\n4 0 1 2 3\n4 1 4 5 2\n",
}


@pytest.mark.parametrize("ext", ["obj", "ply", "off"])
def test_flat_quads_are_split_along_their_shorter_diagonal(tmp_path, ext):
    path = tmp_path / f"quads.{ext}"
    path.write_text(QUADS[ext])
    t = load_target(path)
    assert len(t.faces) == 4 and len(t.vertices) == 6
    p = t.vertices[t.faces]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert 0.5 * np.linalg.norm(cross, axis=1).sum() == pytest.approx(2.0)       # two 1 m squares
    assert np.all(cross[:, 2] > 0)                                                # the quads' winding kept


def test_a_binary_plys_quads_are_split_too(tmp_path):
    import struct

    v = np.array([[0, 0, 0], [1000, 0, 0], [1000, 1000, 0], [0, 1000, 0], [2000, 0, 0], [2000, 1000, 0]], "<f4")
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n").encode()
    path = tmp_path / "quads.ply"
    path.write_bytes(head + v.tobytes() + struct.pack("<B4i", 4, 0, 1, 2, 3) + struct.pack("<B4i", 4, 1, 4, 5, 2))
    t = load_target(path)
    assert sorted(map(sorted, t.faces.tolist())) == [[0, 1, 2], [0, 2, 3], [1, 2, 5], [1, 4, 5]]


@pytest.mark.parametrize("ext", ["obj", "ply", "off"])
def test_a_warped_quad_or_a_pentagon_is_refused_saying_so(tmp_path, ext):
    corner = {"obj": "v 0 1000 0\n", "ply": "\n0 1000 0\n", "off": "\n0 1000 0\n"}[ext]      # the first quad's alone
    warped = QUADS[ext].replace(corner, corner.replace("1000 0", "1000 100"), 1)   # 100 mm off the others' plane
    path = tmp_path / f"warped.{ext}"
    path.write_text(warped)
    with pytest.raises(InputError, match="1 of 2 quads are warped") as err:
        load_target(path)
    assert err.value.data["warp"] == pytest.approx(100 / np.hypot(1000, np.hypot(1000, 100)), rel=1e-3)
    assert err.value.path == str(path)
    penta = tmp_path / "penta.obj"
    penta.write_text("v 0 0 0\nv 1000 0 0\nv 1500 500 0\nv 1000 1000 0\nv 0 1000 0\nf 1 2 3 4 5\n")
    with pytest.raises(InputError, match="1 faces of 5 corners"):
        load_target(penta)


def test_an_obj_with_texture_indices_and_relative_corners_reads_its_own_vertices(tmp_path):
    path = tmp_path / "textured.obj"
    path.write_text("v 0 0 0\nv 1000 0 0\nv 1000 1000 0\nv 0 1000 0\nv 2000 0 0\nv 2000 1000 0\n"
                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
                    "f -6/1/1 -5/2/1 -4/3/1 -3/4/1\nf 2/2/1 5/1/1 6/4/1 3/3/1\n")
    t = load_target(path)
    assert len(t.faces) == 4 and len(t.vertices) == 6
    np.testing.assert_allclose(np.ptp(t.vertices, axis=0), [2.0, 1.0, 0.0])


def test_nan_vertices(tmp_path):
    path = tmp_path / "nan.obj"
    path.write_text("v 0 0 0\nv 1000 0 0\nv nan 1000 0\nv 0 1000 0\nf 1 2 3\nf 1 3 4\n")
    with pytest.raises(InputError, match="NaN or infinite") as err:
        load_target(path)
    assert err.value.data["n_bad"] == 1


def test_non_manifold_edges_are_counted(tmp_path):
    # three triangles on the edge (0, 1), two on the edge (0, 4)
    v = np.array([[0, 0, 0], [1000, 0, 0], [500, 800, 0], [500, -800, 0], [500, 0, 800], [0, 0, 900.0]])
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 4, 5]])
    path = tmp_path / "fin.obj"
    trimesh.Trimesh(v, f, process=False).export(path)
    with pytest.raises(InputError, match="1 non-manifold edges") as err:
        load_target(path)
    assert err.value.data["n_nonmanifold"] == 1


@pytest.mark.parametrize("ext", ["obj", "ply", "off"])
def test_faces_without_surface_are_dropped_from_a_file(tmp_path, ext):
    # a face naming a vertex twice (on two vertices only it uses), a face written twice, one written back to front:
    # their edges would be shared by more than two faces; the file reads as the mesh without them
    v, f = _grid_mesh()
    n = len(v)
    vx = np.vstack([v, [[2000.0, 0, 0], [2001.0, 0, 0]]])
    fx = np.vstack([f, [[n, n, n + 1]], f[:1], f[1:2, ::-1]])
    path = tmp_path / f"export.{ext}"
    trimesh.Trimesh(vx, fx, process=False).export(path)
    t = load_target(path)
    assert len(t.faces) == len(f) and len(t.vertices) == n
    np.testing.assert_allclose(np.sort(t.vertices[t.faces].reshape(-1, 9), axis=0),
                               np.sort(1e-3 * v[f].reshape(-1, 9), axis=0))


def test_arrays_with_a_face_naming_a_vertex_twice_are_refused_saying_so():
    v, f = _grid_mesh()
    with pytest.raises(InputError, match="1 of 51 faces repeat a vertex") as err:
        Target(1e-3 * v, np.vstack([f, [[0, 0, 1]]]))
    assert err.value.data["n_repeated"] == 1


def test_units_slip_says_which_units(tmp_path):
    v, f = _grid_mesh()
    path = tmp_path / "in_metres.obj"
    trimesh.Trimesh(v * 1e-3, f, process=False).export(path)  # a 1.4 m sheet written in metres
    with pytest.raises(InputError, match="looks like the file is in m, not mm") as err:
        load_target(path, mattress=SMALL)  # read as mm: 1.4 mm
    assert err.value.data["ratio"] < 0.2
    assert err.value.path == str(path)
    big = tmp_path / "in_microns.obj"
    trimesh.Trimesh(v * 1e3, f, process=False).export(big)
    with pytest.raises(InputError, match="far larger"):
        load_target(big, mattress=SMALL)


def test_check_scale_accepts_sizes_near_the_mattress():
    v, f = _grid_mesh()
    check_scale(Target(v * 1e-3, f), SMALL)  # 1.4 m diagonal on a 1.1 m mattress


def test_target_validates_arrays():
    v, f = _grid_mesh()
    with pytest.raises(InputError, match="expected \\(m, 3\\)"):
        Target(v, f[:, :2])
    with pytest.raises(InputError, match="face indices"):
        Target(v, f + len(v))
    with pytest.raises(InputError, match="empty mesh"):
        Target(np.zeros((0, 3)), np.zeros((0, 3), int))


def _two_triangles_obj(relative: bool, interleaved: bool) -> str:
    """A unit square as two triangles; corners by absolute or relative index, the fourth vertex
    before the faces or between them."""
    v = ["v 0 0 0", "v 1000 0 0", "v 0 1000 0", "v 1000 1000 0"]
    if relative and interleaved:
        return "\n".join(v[:3] + ["f -3 -2 -1"] + v[3:] + ["f -3 -1 -2"]) + "\n"
    if relative:
        return "\n".join(v + ["f -4 -3 -2", "f -3 -1 -2"]) + "\n"
    return "\n".join(v[:3] + ["f 1 2 3"] + v[3:] + ["f 2 4 3"]) + "\n"


def test_obj_relative_indices_after_more_vertices_are_refused_others_read_right(tmp_path):
    square = np.array([[0, 1, 2], [1, 3, 2]])
    for relative, interleaved in [(True, False), (False, True)]:
        path = tmp_path / f"r{relative:d}{interleaved:d}.obj"
        path.write_text(_two_triangles_obj(relative, interleaved))
        t = load_target(path)
        assert np.array_equal(t.faces, square) and len(t.vertices) == 4
    path = tmp_path / "interleaved_relative.obj"
    path.write_text(_two_triangles_obj(True, True))   # trimesh: 3 vertices, the first face twice
    with pytest.raises(InputError, match="relative .* absolute indices") as err:
        load_target(path)
    assert err.value.path == str(path)


@pytest.mark.parametrize("ext", ["ply", "stl"])
def test_float32_coordinates_far_from_the_origin_are_refused_saying_why(tmp_path, ext):
    """A georeferenced model (4200 km north, in mm) stored as 32-bit floats is rounded to 256 mm steps; the same
    model 300 m from the origin, or stored in double precision (OBJ), reads."""
    v, f = _grid_mesh(n=21, size_mm=800.0)
    far = tmp_path / f"utm.{ext}"
    trimesh.Trimesh(v + [5.0e8, 4.2e9, 1.2e5], f, process=False).export(far)
    with pytest.raises(InputError, match=r"32-bit float coordinates reach 4.2e\+09 mm from the origin, where they "
                                         r"are rounded to steps of 256 mm") as err:
        load_target(far)
    assert err.value.path == str(far) and err.value.data["float32_step"] == 256.0
    near = tmp_path / f"site.{ext}"
    trimesh.Trimesh(v + [3.0e5, 2.0e5, 1.0e4], f, process=False).export(near)
    assert len(load_target(near, mattress=SMALL).faces) == len(f)
    obj = tmp_path / "utm.obj"
    obj.write_text("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in v + [5.0e8, 4.2e9, 1.2e5])
                   + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    t = load_target(obj, mattress=SMALL)
    assert len(t.faces) == len(f) and t.bbox_diagonal == pytest.approx(np.linalg.norm(np.ptp(v, axis=0)) * 1e-3)
