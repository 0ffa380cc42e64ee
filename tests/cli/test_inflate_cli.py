"""`airmat inflate`: files and fields on a small design folder; bad input exits 2 and writes nothing."""

import json

import numpy as np
import pytest

from airmat.cli import main
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.surface_io import write_approx_surface


def _dash(i, side, v_mm, l_mm):
    return {"id": f"k1-{i:03d}-01", "family": "k1", "side": side, "a_mm": [150.0, v_mm], "b_mm": [450.0, v_mm],
            "polyline_mm": [[150.0, v_mm], [300.0, v_mm], [450.0, v_mm]], "L_mm": 300.0, "kappa_per_m": -4.0,
            "l_mm": {"median": l_mm, "lo95": l_mm - 3, "hi95": l_mm + 3}, "flags": []}


def make_design(folder, dashes=None, drop=None):
    folder.mkdir(parents=True, exist_ok=True)
    doc = {"mattress": {"width_mm": 600.0, "height_mm": 300.0, "thickness_mm": 70.0},
           "calibration": {"delta_mm": {"median": 10.0, "lo95": 8.0, "hi95": 12.0}},
           "dashes": dashes if dashes is not None else [_dash(1, "top", 75.0, 180.0), _dash(2, "top", 225.0, 180.0)]}
    if drop:
        node = doc
        *path, last = drop.split(".")
        for key in path:
            node = node[key]
        del node[last]
    (folder / "design.json").write_text(json.dumps(doc))
    m = Mattress(0.6, 0.3, 0.07)
    uv, faces = triangulate_mattress(m, spacing=0.05)
    xyz = np.column_stack([uv, -1.0 * (uv[:, 0] - 0.3) ** 2])  # a gentle vault along u (bends toward the top)
    write_approx_surface(folder, xyz, uv, faces, width=0.6, height=0.3)
    return folder


def test_inflate_writes_files_with_the_fields(tmp_path, capsys, wrote):
    design = make_design(tmp_path / "design")
    out = tmp_path / "out"
    assert main(["inflate", str(design), "--out", str(out), "--resolution-mm", "50"]) == 0
    doc = json.loads((out / "inflate.json").read_text())
    assert set(doc["deviation"]) >= {"rms_mm", "max_mm", "rms_pct_diag"}
    assert set(doc["envelope"]) == {"lo95", "hi95"}
    for run in doc["envelope"].values():
        assert set(run) >= {"rms_mm", "max_mm"}
    assert doc["solver"]["converged"] is True
    assert set(doc["solver"]) >= {"converged", "iterations", "residual"}
    assert doc["converged"] is True and set(doc["timings_s"]) == {"median", "lo95", "hi95"}
    assert doc["start"] == {"from": "flat"}       # not refined: every run from the flat mattress
    assert [d["id"] for d in doc["dashes"]] == ["k1-001-01", "k1-002-01"]
    # top strings bend toward the top face: negative curvature, shorter strings (lo95) bend more
    kap = np.array([d["kappa_realized_per_m"] for d in doc["dashes"]])
    lo = np.array([d["kappa_realized_lo95_per_m"] for d in doc["dashes"]])
    assert np.all(kap < 0) and np.all(lo < kap)
    assert (out / "inflated.ply").stat().st_size > 0 and (out / "deviation.png").stat().st_size > 0
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Inflation check" in page and "k1-002-01" in page and "did NOT converge" not in page
    printed = capsys.readouterr().out
    assert wrote(printed, out) == {p.name for p in out.iterdir()}   # every file, no other
    assert "deviation from Ŝ (bottom face)" in printed
    assert f"'airmat refine {design} --out DIR'" in printed      # open-loop lengths: where to go next
    # top strings only: the named face is the bottom one (it keeps its length); every face for reference
    dev = doc["deviation"]
    assert dev["surface"] == doc["surface"] == "bottom"
    assert set(dev["surfaces"]) == {"top", "bottom", "mid"}
    assert dev["surfaces"]["bottom"]["rms_mm"] == dev["rms_mm"]
    assert all("kappa_realized_free_per_m" in d for d in doc["dashes"])
    _check_inflated_3dm(out / "inflated.3dm", design, doc)


def _check_inflated_3dm(path, design, doc):
    """inflated.3dm: the design's layers plus the aligned shapes, in Ŝ's frame (within the deviation)."""
    import rhino3dm

    from airmat.design.design_io import read_design

    model = rhino3dm.File3dm.Read(str(path))
    assert model.Settings.ModelUnitSystem == rhino3dm.UnitSystem.Millimeters
    layers = {model.Layers.FindIndex(i).Index: model.Layers.FindIndex(i) for i in range(len(model.Layers))}
    by_path = {layer.FullPath: layer for layer in layers.values()}
    assert by_path["inflated::median"].Visible and not by_path["inflated::lo95"].Visible
    meshes = {layers[o.Attributes.LayerIndex].FullPath: o.Geometry for o in model.Objects
              if layers[o.Attributes.LayerIndex].FullPath in ("S_hat", "inflated::median")}
    s_hat = read_design(design).approx.xyz * 1000
    med = np.array([[p.X, p.Y, p.Z] for p in meshes["inflated::median"].Vertices])
    assert med.shape == s_hat.shape
    # in Ŝ's frame: each vertex within the largest deviation of the check (not the simulation's coordinates)
    assert np.linalg.norm(med - s_hat, axis=1).max() <= doc["deviation"]["max_mm"] + 0.01
    curves = [o for o in model.Objects if o.Attributes.Name in {d["id"] for d in doc["dashes"]}]
    assert len(curves) == 2 * len(doc["dashes"])


def test_inflated_ply_overlays_the_approx_surface(tmp_path):
    # inflated.ply is in approx_surface's frame: its bottom face, read back at Ŝ's Ω points,
    # lies on Ŝ within the reported RMS (the same rigid motion, so the same distances)
    import trimesh

    from airmat.check.compare import surface_at
    from airmat.design.surface_io import read_approx_surface
    from airmat.inflation.mesh import build_mattress_mesh

    design = make_design(tmp_path / "design")
    out = tmp_path / "out"
    assert main(["inflate", str(design), "--out", str(out), "--resolution-mm", "50", "--no-envelope"]) == 0
    doc = json.loads((out / "inflate.json").read_text())
    ply = trimesh.load(out / "inflated.ply", process=False)
    mesh = build_mattress_mesh(0.6, 0.3, 0.07, resolution=0.05)
    assert len(ply.vertices) == mesh.n_vertices

    class Read:
        pass
    inf = Read()
    inf.mesh, inf.xyz = mesh, np.asarray(ply.vertices) * 1e-3
    xyz, uv, _ = read_approx_surface(design / "approx_surface.ply")
    face, _ = surface_at(inf, uv, "bottom")
    dist = np.linalg.norm(face - xyz, axis=1) * 1e3
    assert np.sqrt(np.mean(dist ** 2)) == pytest.approx(doc["deviation"]["rms_mm"], abs=0.01)
    assert dist.max() == pytest.approx(doc["deviation"]["max_mm"], abs=0.01)


@pytest.mark.parametrize("case,words", [
    ("missing_folder", "not found"),
    ("the_json_file", "is a file: give the folder that holds design.json ("),
    ("no_json", "design.json"),
    ("missing_field", "mattress.thickness_mm"),
    ("outside", "k1-009-01"),
    ("coarse", "too coarse"),
    ("fine", "limit 200000"),
    ("no_surface", "approx_surface.ply"),
    ("jobs", "--jobs"),
])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, case, words):
    folder = tmp_path / "design"
    args = []
    if case == "no_json":
        folder.mkdir()
    elif case == "the_json_file":          # the file given for its folder
        make_design(folder)
        folder = folder / "design.json"
    elif case == "missing_field":
        make_design(folder, drop="mattress.thickness_mm")
    elif case == "outside":
        make_design(folder, dashes=[_dash(9, "top", 400.0, 180.0)])
    elif case == "coarse":
        make_design(folder)
        args = ["--resolution-mm", "100"]
    elif case == "fine":
        make_design(folder)
        args = ["--resolution-mm", "1"]
    elif case == "jobs":
        make_design(folder)
        args = ["--jobs", "0"]
    elif case == "no_surface":
        make_design(folder)
        (folder / "approx_surface.ply").unlink()
    out = tmp_path / "out"
    out.mkdir()
    (out / "inflate.json").write_text("previous good output")
    assert main(["inflate", str(folder), "--out", str(out)] + args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert [p.name for p in out.iterdir()] == ["inflate.json"]
    assert (out / "inflate.json").read_text() == "previous good output"


def _without_times(doc):
    """inflate.json without its wall-clock times."""
    if isinstance(doc, dict):
        return {k: _without_times(v) for k, v in doc.items() if k != "timings_s"}
    if isinstance(doc, list):
        return [_without_times(v) for v in doc]
    return doc


def test_runs_in_worker_processes_give_the_same_files(tmp_path, capsys):
    """--jobs 2 runs median / lo95 / hi95 in two processes: the same numbers and mesh as --jobs 1."""
    design = make_design(tmp_path / "design")
    docs, plys = [], []
    for jobs in ("1", "2"):
        out = tmp_path / f"out{jobs}"
        assert main(["inflate", str(design), "--out", str(out), "--resolution-mm", "50", "--jobs", jobs]) == 0
        docs.append(json.loads((out / "inflate.json").read_text()))
        plys.append((out / "inflated.ply").read_bytes())
    assert _without_times(docs[0]) == _without_times(docs[1])
    assert plys[0] == plys[1]
    lo, hi = (docs[0]["envelope"][k]["rms_mm"] for k in ("lo95", "hi95"))
    assert lo != hi                                      # three different runs, not one copied



def test_strings_on_both_faces_name_the_face_opposite_the_larger_bending(tmp_path):
    # one top string (|kappa| 4 1/m) and one bottom string bending twice as much over the same span:
    # the top face keeps its length best, so it is the named face
    bottom = dict(_dash(2, "bottom", 225.0, 150.0), kappa_per_m=8.0)
    design = make_design(tmp_path / "design", dashes=[_dash(1, "top", 75.0, 180.0), bottom])
    out = tmp_path / "out"
    assert main(["inflate", str(design), "--out", str(out), "--resolution-mm", "50", "--no-envelope"]) == 0
    doc = json.loads((out / "inflate.json").read_text())
    assert doc["deviation"]["surface"] == "top"
    kap = {d["side"]: d for d in doc["dashes"]}
    # each dash measured on the named (top) face and on the face opposite its own string; with the
    # designer's sign (positive: bends away from the top) the top face always reads less than the
    # bottom face, whichever way the mattress bends there (the inner face bends more)
    assert kap["top"]["kappa_realized_per_m"] < kap["top"]["kappa_realized_free_per_m"]
    assert kap["bottom"]["kappa_realized_per_m"] == kap["bottom"]["kappa_realized_free_per_m"] > 0
