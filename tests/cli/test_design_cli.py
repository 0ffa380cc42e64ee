"""`airmat design`: files, summary, reproducibility, calibration, and bad input (exit 2, nothing written)."""

import json

import numpy as np
import pytest
import trimesh

from airmat.cli import main
from airmat.design.design_io import OUTPUT_FILES
from airmat.synthetic.targets import cylinder

FILES = set(OUTPUT_FILES) | {"report.html"}
FAST = ["--spacing-mm", "40"]


@pytest.fixture(scope="module")
def cylinder_obj(tmp_path_factory):
    """A developable target (cylinder R 400 mm) as an OBJ file in mm."""
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.03)
    path = tmp_path_factory.mktemp("targets") / "cyl.obj"
    mesh = trimesh.Trimesh(surf.vertices * 1e3, surf.faces, process=False)
    path.write_text(trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False))
    return path


def _calibration_folder(folder, *, drop=None):
    rng = np.random.default_rng(5)
    folder.mkdir(parents=True, exist_ok=True)
    doc = {"parameters": {"delta_mm": {"median": 10.0, "lo95": 9.0, "hi95": 11.0},
                          "d_mm": {"median": 60.0, "lo95": 58.0, "hi95": 62.0}},
           "curve": {"L_mm": 300.0}}
    if drop:
        del doc["parameters"][drop]
    (folder / "calibration.json").write_text(json.dumps(doc))
    with open(folder / "posterior.npz", "wb") as fh:
        np.savez(fh, delta_m=rng.normal(0.010, 0.0005, 800), d_m=rng.normal(0.060, 0.001, 800),
                 sigma_per_m=np.full(800, 0.1), L_m=np.float64(0.3))
    return folder


def test_design_of_a_target_file_writes_everything_and_is_reproducible(cylinder_obj, tmp_path, capsys, wrote):
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--out", str(a)]) == 0
    out = capsys.readouterr().out
    assert "UNCALIBRATED" in out and "constructible: yes" in out and str(a) in out
    assert {p.name for p in a.iterdir()} == FILES
    assert wrote(out, a) == FILES                  # the summary names every file written, no other
    doc = json.loads((a / "design.json").read_text())
    assert doc["uncalibrated"] is True and doc["mattress"] == {"width_mm": 830.0, "height_mm": 740.0,
                                                                "thickness_mm": 70.0}
    assert doc["dashes"] and {d["family"] for d in doc["dashes"]} == {"k1"}
    assert {d["side"] for d in doc["dashes"]} == {"bottom"}
    assert f"bottom face: {len(doc['dashes']):3d} k1 strings" in out
    tt = doc["report"]["to_target"]            # Ŝ's distance to S, as design.json has it
    line = f"Ŝ to your target S: RMS {tt['rms_mm']:.1f} mm ({tt['rms_pct_diag']:.2f}% of the diagonal)"
    assert line in out
    over = tt["over_target"]
    assert ("over S (" in out) == (over["share"] < 1.0)
    from airmat.cli.design import summary_text            # a target smaller than Ŝ: the part over S is given too

    half = {**doc, "report": {**doc["report"], "to_target": {**tt, "over_target": {**over, "share": 0.5, "rms_mm": 0.2}}}}
    assert "; over S (50% of Ŝ, the rest beyond its rim): RMS 0.2 mm" in summary_text(half, a)
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--out", str(b)]) == 0
    for name in sorted(FILES):                  # design.3dm too: airmat.design.export.rhino_stable
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_calibration_folder_is_used_and_labelled(cylinder_obj, tmp_path, capsys):
    cal = _calibration_folder(tmp_path / "cal")
    out = tmp_path / "out"
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--calibration", str(cal),
                 "--out", str(out)]) == 0
    assert "UNCALIBRATED" not in capsys.readouterr().out
    doc = json.loads((out / "design.json").read_text())
    assert doc["uncalibrated"] is False and doc["calibration"]["source"] == str(cal)
    assert doc["calibration"]["delta_mm"]["median"] == pytest.approx(10.0, abs=0.2)
    # a tight posterior gives tight tolerances: a few millimetres
    widths = [d["l_mm"]["hi95"] - d["l_mm"]["lo95"] for d in doc["dashes"]]
    assert 0 < max(widths) < 6.0
    assert "UNCALIBRATED" not in (out / "pattern.svg").read_text()


def test_parameters_reach_the_files(cylinder_obj, tmp_path, capsys):
    out = tmp_path / "out"
    # free ends (--tie-grid-mm 0): every dash keeps L exactly
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--L-mm", "250", "--mu1-mm", "300",
                 "--mu2-mm", "150", "--margin-mm", "40", "--tie-grid-mm", "0", "--out", str(out), "-q"]) == 0
    doc = json.loads((out / "design.json").read_text())
    p = doc["parameters"]
    assert (p["L_mm"], p["mu1_mm"], p["mu2_mm"], p["margin_mm"]) == (250.0, 300.0, 150.0, 40.0)
    assert p["face_metric"] is True and doc["report"]["metric"] == {"face": "flat", "min_ratio": 1.0}
    # L = 250 mm is not the (paper) calibration's 300 mm: the summary says the lengths are extrapolated
    assert "warning: L = 250 mm differs from the calibration's L = 300 mm" in capsys.readouterr().out
    for d in doc["dashes"]:
        assert d["L_mm"] == pytest.approx(250.0, abs=0.01)
        poly = np.array(d["polyline_mm"])
        assert poly.min() >= 40.0 - 0.01 and np.all(poly <= [830 - 40 + 0.01, 740 - 40 + 0.01])


def test_flat_metric_reaches_the_file(cylinder_obj, tmp_path):
    out = tmp_path / "out"
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--flat-metric", "--out", str(out),
                 "-q"]) == 0
    doc = json.loads((out / "design.json").read_text())
    assert doc["parameters"]["face_metric"] is False and doc["report"]["metric"]["face"] == "flat"


def test_ends_are_tied_to_the_grid_in_every_file(cylinder_obj, tmp_path, capsys):
    import csv

    out = tmp_path / "out"
    assert main(["design", str(cylinder_obj), "--mattress", "830x740", *FAST, "--out", str(out)]) == 0
    assert "ends tied to the 20 mm grid" in capsys.readouterr().out
    doc = json.loads((out / "design.json").read_text())
    assert doc["parameters"]["tie_grid_mm"] == 20.0
    tg = doc["summary"]["tie_grid"]
    assert tg["grid_mm"] == 20.0 and 0 < tg["end_shift_mm"]["max"] <= 14.15 and tg["dL_mm"]["max_abs"] <= 28.3
    with open(out / "cutting_list.csv", newline="") as fh:
        rows = {r["id"]: r for r in csv.DictReader(fh)}
    for d in doc["dashes"]:
        for end in ("a", "b"):
            node = d[f"{end}_node"]
            assert d[f"{end}_mm"] == pytest.approx([20.0 * node["col"], 20.0 * node["row"]], abs=0.01)
            assert [node["u_mm"], node["v_mm"]] == d[f"{end}_mm"]
            assert rows[d["id"]][f"{end}_node"] == f"R{node['row']}C{node['col']}"


def _mesh_file(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


BAD_MESHES = {
    "empty.obj": "# nothing here\n",
    "quad.obj": "v 0 0 0\nv 1000 0 0\nv 1000 800 100\nv 0 800 300\nf 1 2 3 4\n",     # warped: either diagonal
    "nonmanifold.obj": ("v 0 0 0\nv 1000 0 0\nv 500 800 0\nv 500 -800 0\nv 500 0 800\n"
                        "f 1 2 3\nf 2 1 4\nf 1 2 5\n"),
    "nan.obj": "v 0 0 0\nv 1000 0 0\nv nan 800 0\nf 1 2 3\n",
}


@pytest.mark.parametrize("name", sorted(BAD_MESHES))
def test_bad_meshes_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, name):
    target = _mesh_file(tmp_path, name, BAD_MESHES[name])
    _check_refused(tmp_path, capsys, ["design", target, "--mattress", "830x740"], name)


def test_units_slip_is_refused(tmp_path, capsys):
    surf = cylinder(radius=0.4, length=1.2, arc=1.0, spacing=0.05)
    path = tmp_path / "metres.stl"
    trimesh.Trimesh(surf.vertices, surf.faces).export(path)  # metres, read as mm
    _check_refused(tmp_path, capsys, ["design", str(path), "--mattress", "830x740"], "smaller")


@pytest.mark.parametrize("args, word", [
    (["--preset", "castle"], "castle"),
    (["--preset", "vault1", "--mattress", "830by740"], "--mattress"),
    (["--preset", "vault1", "--mattress", "0x740"], "--mattress"),
    (["--preset", "vault1", "--mu1-mm", "200"], "mu1"),
    (["--preset", "vault1", "--L-mm", "900", "--mu1-mm", "1000"], "longer than the mattress"),
    (["--preset", "vault1", "--mu2-mm", "0"], "mu2"),
    (["--preset", "vault1", "--tie-grid-mm", "-20"], "--tie-grid-mm"),
    (["--preset", "vault1", "--jobs", "0"], "--jobs must be at least 1"),
    (["--preset", "vault1", "--end-dashes", "--L-end-min-mm", "400"], "shortest end dash must be in (0, L = 300 mm]"),
    (["--preset", "vault1", "--L-end-min-mm", "100"], "--L-end-min-mm needs --end-dashes"),
    (["--preset", "vault1", "--calibration", "CAL_MISSING_FIELD"], "parameters.d_mm"),
    (["--preset", "vault1", "--calibration", "NO_SUCH_DIR"], "not found"),
    (["TARGET_FILE", "--preset", "vault1"], "either"),
    ([], "either"),
    (["TARGET_FILE"], "--mattress"),
])
def test_bad_arguments_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, cylinder_obj, args, word):
    cal = _calibration_folder(tmp_path / "cal", drop="d_mm")
    swap = {"CAL_MISSING_FIELD": str(cal), "NO_SUCH_DIR": str(tmp_path / "nope"), "TARGET_FILE": str(cylinder_obj)}
    _check_refused(tmp_path, capsys, ["design", *[swap.get(a, a) for a in args]], word)


def _check_refused(tmp_path, capsys, argv, word):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("previous run")
    code = main([*argv, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("airmat design: ") and word in err[0], err
    assert [p.name for p in out.iterdir()] == ["keep.txt"]
    assert (out / "keep.txt").read_text() == "previous run"
    assert not [p for p in tmp_path.iterdir() if ".staging-" in p.name]


def test_help_lists_the_options(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["design", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    for option in ("--preset", "--mattress", "--calibration", "--mu1-mm", "--mu2-mm", "--L-mm", "--out",
                   "--flat-metric"):
        assert option in text
