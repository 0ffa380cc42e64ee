"""A target is one open sheet (airmat.design.target_pieces): several sheets and closed solids are refused."""

import numpy as np
import pytest
import trimesh
from scipy.spatial.distance import cdist

from airmat.errors import InputError
from airmat.design.mattress import Mattress
from airmat.design.target import load_target
from airmat.design.target_pieces import check_one_sheet, sheet_pieces

SMALL = Mattress(0.83, 0.74)


def _sheet(nx, ny, x0=0.0, x1=800.0, y0=0.0, y1=700.0):
    """A vault-like sheet (mm) over [x0, x1] × [y0, y1], (nx × ny) vertices, normals up."""
    x, y = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
    v = np.column_stack([x.ravel(), y.ravel(), -4e-4 * (x.ravel() - 400) ** 2])
    i = np.arange(nx * ny).reshape(ny, nx)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    return v, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _join(*meshes):
    vs, fs, n = [], [], 0
    for v, f in meshes:
        vs.append(v)
        fs.append(f + n)
        n += len(v)
    return np.vstack(vs), np.vstack(fs)


def _write(tmp_path, name, v, f):
    path = tmp_path / name
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


def test_one_sheet_is_one_piece():
    v, f = _sheet(21, 19)
    sheet, n = sheet_pieces(v, f, gap=1.0)
    assert n == 1 and not sheet.any()


@pytest.mark.parametrize("offset_mm, what", [(2000.0, "a copy beside it"), (5.0, "both faces of a thickened sheet")])
def test_two_sheets_are_refused_with_their_gap(tmp_path, offset_mm, what):
    v, f = _sheet(21, 19)
    path = _write(tmp_path, "two.ply", *_join((v, f), (v + [0, 0, offset_mm], f)))
    with pytest.raises(InputError, match="the target is 2 separate sheets \\(50 %, 50 % of its area") as err:
        load_target(path, mattress=SMALL)
    assert err.value.path == str(path)
    assert err.value.data["n_sheets"] == 2
    assert err.value.data["gap_mm"] == pytest.approx(cdist(v, v + [0, 0, offset_mm]).min(), rel=1e-9)
    assert err.value.data["gap_mm"] <= offset_mm


def test_a_small_stray_piece_is_refused_and_its_share_given():
    v, f = _sheet(21, 19)
    speck = (np.array([[0, 0, 300.0], [10, 0, 300], [0, 10, 300]]), np.array([[0, 1, 2]]))
    v2, f2 = _join((v, f), speck)
    share = 50.0 / (trimesh.Trimesh(v, f).area + 50.0)  # the speck is 50 mm²
    with pytest.raises(InputError, match=rf"2 separate sheets \(100 %, {100 * share:.3g} % of its area") as err:
        check_one_sheet(v2 * 1e-3, f2)
    assert err.value.data["gap_mm"] == pytest.approx(cdist(v, speck[0]).min(), rel=1e-9)


def test_unwelded_patches_are_one_sheet(tmp_path):
    """Four patches with their own copies of the seam vertices, moved by 1e-4 mm so that merging does not
    weld them, and two of them meshed at other densities (T-junctions along the seams)."""
    patches = [_sheet(11, 10, 0, 400, 0, 350), _sheet(21, 10, 400, 800, 0, 350),
               _sheet(11, 7, 0, 400, 350, 700), _sheet(11, 10, 400, 800, 350, 700)]
    rng = np.random.default_rng(0)
    patches = [(v + rng.uniform(-1e-4, 1e-4, v.shape), f) for v, f in patches]
    v, f = _join(*patches)
    assert sheet_pieces(v, f, gap=1e-9)[1] == 4  # not welded, not touching at zero gap
    assert sheet_pieces(v, f, gap=1e-3)[1] == 1
    t = load_target(_write(tmp_path, "patches.obj", v, f), mattress=SMALL)
    assert len(t.faces) == len(f)


def test_a_seam_gap_wider_than_the_tolerance_splits(tmp_path):
    left, right = _sheet(11, 10, 0, 400, 0, 700), _sheet(11, 10, 403, 800, 0, 700)  # a 3 mm slit
    v, f = _join(left, right)
    with pytest.raises(InputError, match="2 separate sheets") as err:
        load_target(_write(tmp_path, "slit.ply", v, f), mattress=SMALL)
    assert err.value.data["gap_mm"] == pytest.approx(3.0, abs=0.05)


def test_a_closed_surface_is_refused(tmp_path):
    box = trimesh.creation.box(extents=[800, 700, 70])
    with pytest.raises(InputError, match="closed surface .*no boundary edge") as err:
        load_target(_write(tmp_path, "box.stl", box.vertices, box.faces), mattress=SMALL)
    assert err.value.data["closed"] is True
    # the same box written with each face's own vertices (an unwelded export) is welded by the loader first
    tri = box.vertices[box.faces].reshape(-1, 3)
    with pytest.raises(InputError, match="closed surface"):
        load_target(_write(tmp_path, "box_soup.obj", tri, np.arange(len(tri)).reshape(-1, 3)), mattress=SMALL)


def test_an_open_box_is_one_sheet():
    box = trimesh.creation.box(extents=[800, 700, 70])
    up = box.face_normals[:, 2] > 0.5
    check_one_sheet(box.vertices * 1e-3, box.faces[~up])  # the lid removed: a tray, open


def test_pieces_that_meet_only_at_t_junctions_are_one_sheet():
    """No vertex of the right patch coincides with one of the left patch (the nearest are 25 mm apart), but
    every one on the seam lies on a boundary edge of the left patch."""
    left, right = _sheet(5, 8, 0, 400, 0, 700), _sheet(5, 14, 400, 800, 25, 675)
    v, f = _join(left, right)
    assert cdist(left[0], right[0]).min() == pytest.approx(25.0)
    assert sheet_pieces(v, f, gap=0.7)[1] == 1
    assert sheet_pieces(v, f, gap=0.7)[0].tolist() == [0] * len(f)


def test_a_long_rim_edge_joins_a_fine_sheet_at_its_t_junctions():
    """A fine patch (4 mm edges) whose seam vertices lie on one 800 mm edge of a coarse two-triangle patch: one
    sheet; a far copy of the coarse patch stays a sheet of its own."""
    fine = _sheet(101, 176, 0, 400, 0, 700)
    quad = np.array([[400, -50, 0], [800, -50, 0], [800, 750, 0], [400, 750, 0.0]])
    coarse = (quad, np.array([[0, 1, 2], [0, 2, 3]]))
    v, f = _join(fine, coarse)
    sheet, n = sheet_pieces(v, f, gap=0.5)
    assert n == 1
    v3, f3 = _join(fine, coarse, (quad + [0, 0, 300], coarse[1]))
    sheet, n = sheet_pieces(v3, f3, gap=0.5)
    assert n == 2 and sheet[-1] != sheet[0] and sheet[-3] == sheet[0]
