"""Targets read from Rhino's .3dm files (airmat.design.target_3dm through airmat.design.target.load_target)."""

import numpy as np
import pytest

from airmat.design.mattress import Mattress
from airmat.design.target import load_target
from airmat.design.target_polygons import QUAD_WARP, split_quads
from airmat.errors import InputError

rhino3dm = pytest.importorskip("rhino3dm")

SMALL = Mattress(0.83, 0.74)


def _vault(nx=21, ny=18, scale=1.0):
    """An 800 x 700 mm vault of radius 500 mm as a grid (m × ``scale``) and its quads (a, b, c, d)."""
    s, v = np.meshgrid(np.linspace(-0.4, 0.4, nx), np.linspace(-0.35, 0.35, ny))
    th = s / 0.5
    p = np.column_stack([(0.5 * np.sin(th)).ravel(), v.ravel(), (0.5 * np.cos(th) - 0.5).ravel()]) * scale
    i = np.arange(nx * ny).reshape(ny, nx)
    quads = np.column_stack([i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()])
    return p, quads


def _mesh(points, quads):
    m = rhino3dm.Mesh()
    for p in points:
        m.Vertices.Add(*map(float, p))
    for q in quads:
        m.Faces.AddFace(*map(int, q))
    return m


def _write(path, objects, units=rhino3dm.UnitSystem.Millimeters, hidden=()):
    f = rhino3dm.File3dm()
    f.Settings.ModelUnitSystem = units
    for k, obj in enumerate(objects):
        attrs = rhino3dm.ObjectAttributes()
        attrs.Visible = k not in hidden
        if isinstance(obj, rhino3dm.Mesh):
            f.Objects.AddMesh(obj, attrs)
        elif isinstance(obj, rhino3dm.Brep):
            f.Objects.AddBrep(obj, attrs)
        else:
            f.Objects.AddPoint(obj, attrs)
    assert f.Write(str(path), 8)
    return path


def _area(t):
    p = t.vertices[t.faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()


def test_a_quad_mesh_in_metres_reads_in_the_files_units(tmp_path):
    p, q = _vault()
    path = _write(tmp_path / "vault.3dm", [_mesh(p, q)], units=rhino3dm.UnitSystem.Meters)
    t = load_target(path, mattress=SMALL)             # the default "mm" gives way to the file's metres
    assert t.units == "m" and t.name == "vault"
    assert len(t.vertices) == len(p) and len(t.faces) == 2 * len(q)
    np.testing.assert_allclose(np.sort(t.vertices, axis=0), np.sort(p, axis=0), atol=1e-12)
    # the vault's area, 0.8 x 0.7 m (its chords a little less)
    assert _area(t) == pytest.approx(0.8 * 0.7, rel=2e-3)
    # the triangles keep the quads' winding: every normal on the same side
    n = np.cross(*(t.vertices[t.faces][:, 1:] - t.vertices[t.faces][:, :1]).transpose(1, 0, 2))
    assert np.all(n[:, 2] > 0) or np.all(n[:, 2] < 0)


def test_units_unset_in_the_file_are_the_callers(tmp_path):
    p, q = _vault(scale=1e3)
    path = _write(tmp_path / "plain.3dm", [_mesh(p, q)], units=rhino3dm.UnitSystem.None_
                  if hasattr(rhino3dm.UnitSystem, "None_") else getattr(rhino3dm.UnitSystem, "None"))
    t = load_target(path, units="mm", mattress=SMALL)
    assert t.units == "mm" and np.ptp(t.vertices[:, 1]) == pytest.approx(0.7)


#: writes a polysurface of the vault's quads, each face with its render mesh, to argv[1]; then leaves at once: a
#: mesh given to ``BrepFace.SetMesh`` is freed twice at exit (by the face and by Python), which only writing hits
POLYSURFACE = """
import os, sys
import rhino3dm
sys.path.insert(0, {here!r})
from test_target_3dm import _mesh, _vault

p, q = _vault()
brep = rhino3dm.Brep.CreateFromMesh(_mesh(p, q), True)
keep = [_mesh(p[quad], [[0, 1, 2, 3]]) for quad in q]
for face, m in zip(brep.Faces, keep):
    face.SetMesh(m, rhino3dm.MeshType.Render)
f = rhino3dm.File3dm()
f.Settings.ModelUnitSystem = rhino3dm.UnitSystem.Meters
f.Objects.AddBrep(brep)
f.Objects.AddPoint(rhino3dm.Point3d(0, 0, 1))
ok = f.Write(sys.argv[1], 8)
sys.stdout.flush()
os._exit(0 if ok else 1)
"""


def test_a_polysurface_reads_from_its_faces_render_meshes_and_is_one_sheet(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    p, q = _vault()
    path = tmp_path / "polysurface.3dm"
    script = POLYSURFACE.format(here=str(Path(__file__).parent))
    assert subprocess.run([sys.executable, "-c", script, str(path)], timeout=120).returncode == 0
    t = load_target(path, mattress=SMALL)
    assert len(t.vertices) == len(p) and len(t.faces) == 2 * len(q)     # the faces' seams merged
    assert _area(t) == pytest.approx(0.8 * 0.7, rel=2e-3)


def test_a_surface_without_its_render_mesh_is_refused_saying_how_to_save_it(tmp_path):
    p, q = _vault()
    brep = rhino3dm.Brep.CreateFromMesh(_mesh(p, q), True)
    path = _write(tmp_path / "small.3dm", [brep])
    with pytest.raises(InputError, match="have no render mesh.*save it again from a shaded view") as err:
        load_target(path)
    assert err.value.data["n_missing"] == len(q) and err.value.path == str(path)


def test_hidden_objects_and_other_geometry_are_left_out(tmp_path):
    p, q = _vault()
    far = _mesh(p + [0, 0, 5.0], q)                   # a hidden copy 5 m above: not part of the target
    path = _write(tmp_path / "layers.3dm", [_mesh(p, q), far, rhino3dm.Point3d(0, 0, 0)],
                  units=rhino3dm.UnitSystem.Meters, hidden=(1,))
    t = load_target(path)
    assert len(t.vertices) == len(p) and t.vertices[:, 2].max() < 0.01
    only_point = _write(tmp_path / "point.3dm", [rhino3dm.Point3d(0, 0, 0)])
    with pytest.raises(InputError, match=r"no visible mesh, surface or extrusion in the file \(it holds Point\)"):
        load_target(only_point)


def test_a_warped_quad_is_refused_and_a_flat_one_split_along_its_shorter_diagonal():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    flat = split_quads(v + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0.5 * QUAD_WARP]], np.array([[0, 1, 2, 3]]))
    assert flat.shape == (2, 3)
    with pytest.raises(InputError, match="1 of 1 quads are warped") as err:
        split_quads(v + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 2 * QUAD_WARP * np.sqrt(2)]], np.array([[0, 1, 2, 3]]))
    assert err.value.data["warp"] == pytest.approx(2 * QUAD_WARP, rel=1e-3)
    kite = np.array([[0.0, 0, 0], [1, 0, 0], [1, 3, 0], [0, 1, 0]])       # diagonal 1-3 is the shorter
    assert split_quads(kite, np.array([[0, 1, 2, 3]])).tolist() == [[0, 1, 3], [1, 2, 3]]


def test_a_file_that_is_not_a_3dm_is_refused(tmp_path):
    path = tmp_path / "fake.3dm"
    path.write_bytes(b"solid not a rhino file\n" * 10)
    with pytest.raises(InputError, match="cannot read the target as 3DM") as err:
        load_target(path)
    assert err.value.path == str(path)


def test_the_design_command_reads_a_3dm_target(tmp_path, capsys):
    from airmat.cli import main

    p, q = _vault()
    path = _write(tmp_path / "vault.3dm", [_mesh(p, q)], units=rhino3dm.UnitSystem.Meters)
    assert main(["design", str(path), "--mattress", "830x740", "--resolution-mm", "40", "--out", str(tmp_path / "d"),
                 "-q"]) == 0
    assert (tmp_path / "d" / "design.json").is_file()
    brep = rhino3dm.Brep.CreateFromMesh(_mesh(p, q), True)
    bad = _write(tmp_path / "small.3dm", [brep])
    assert main(["design", str(bad), "--mattress", "830x740", "--out", str(tmp_path / "e"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "small.3dm" in err[0] and "render mesh" in err[0]
    assert not (tmp_path / "e").exists()


def test_without_rhino3dm_a_3dm_is_refused_saying_what_to_export(tmp_path, monkeypatch):
    import sys

    p, q = _vault()
    path = _write(tmp_path / "vault.3dm", [_mesh(p, q)])
    monkeypatch.setitem(sys.modules, "rhino3dm", None)          # as where no wheel exists
    with pytest.raises(InputError, match="needs rhino3dm.*export the target as OBJ") as err:
        load_target(path)
    assert err.value.path == str(path)


#: an arc of 800 mm chord and 160 mm rise extruded 700 mm, with a 41 x 36 render mesh, to argv[1] (mm); then leaves
#: at once (see POLYSURFACE)
EXTRUSION = """
import os, sys
import numpy as np
import rhino3dm as r

arc = r.Arc(r.Point3d(-400, 0, 0), r.Point3d(0, 0, 160), r.Point3d(400, 0, 0)).ToNurbsCurve()
ext = r.Extrusion.Create(arc, 700.0, False)
t0, t1 = arc.Domain.T0, arc.Domain.T1
pts = [arc.PointAt(t0 + x * (t1 - t0)) for x in np.linspace(0, 1, 41)]
mesh = r.Mesh()
for j in range(36):
    for p in pts:
        mesh.Vertices.Add(p.X, p.Y + 700.0 * j / 35, p.Z)
for j in range(35):
    for i in range(40):
        a = j * 41 + i
        mesh.Faces.AddFace(a, a + 1, a + 42, a + 41)
ext.SetMesh(mesh, r.MeshType.Render)
f = r.File3dm()
f.Settings.ModelUnitSystem = r.UnitSystem.Millimeters
f.Objects.AddExtrusion(ext)
ok = f.Write(sys.argv[1], 8)
sys.stdout.flush()
os._exit(0 if ok else 1)
"""


def test_an_extrusion_reads_from_its_render_mesh(tmp_path):
    import subprocess
    import sys

    path = tmp_path / "extrusion.3dm"
    assert subprocess.run([sys.executable, "-c", EXTRUSION, str(path)], timeout=120).returncode == 0
    t = load_target(path, mattress=SMALL)
    assert t.units == "mm" and len(t.vertices) == 41 * 36 and len(t.faces) == 2 * 40 * 35
    np.testing.assert_allclose(np.ptp(t.vertices, axis=0), [0.8, 0.7, 0.16], atol=1e-9)
