"""`airmat synth-built`: the files against their stated truth; seeded; units; bad input exits 2 and writes nothing."""

import json

import numpy as np
import pytest
import trimesh

from airmat.calib.scan_io import read_scan
from airmat.cli import main
from airmat.design.closest_point import MeshProjector

from test_inflate_cli import make_design

NOISE_MM = 0.5
#: a small run: the two-string design at 50 mm (the strings span 300 mm), 20 000 points
SMALL = ["--resolution-mm", "50", "--points", "20000", "--noise-mm", str(NOISE_MM), "-q"]


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    return make_design(tmp_path_factory.mktemp("synth_built") / "design")


@pytest.fixture(scope="module")
def built(design, tmp_path_factory):
    out = tmp_path_factory.mktemp("synth_built_out") / "sb"
    assert main(["synth-built", str(design), "--out", str(out), "--cut-error-mm", "3", "--delta-mm", "12",
                 "--thickness-mm", "75", "--seed", "3", *SMALL]) == 0
    return out


def _to_design_mm(path, truth):
    """The scan's points, read as `airmat fit` reads them, mapped by truth.json into the design's frame (mm)."""
    t = truth["scan_to_design"]
    scan = read_scan(path, units=t["scan_units"])
    p = (scan.points + scan.offset) / {"mm": 1e-3, "m": 1.0}[t["scan_units"]]     # back in the file's unit
    return (t["mm_per_scan_unit"] * p) @ np.array(t["rotation"]).T + t["translation_mm"]


def test_synth_built_writes_the_scan_the_built_mattress_and_the_truth(built, design, capsys, wrote):
    assert {p.name for p in built.iterdir()} == {"scan.ply", "built.ply", "truth.json"}
    truth = json.loads((built / "truth.json").read_text())
    w = truth["world"]
    assert (w["delta_mm"], w["d_mm"], w["cut_tolerance_mm"], w["cut_distribution"], w["seed"]) == \
        (12.0, 75.0, 3.0, "uniform", 3)
    assert w["design_median"] == {"delta_mm": pytest.approx(10.0), "d_mm": pytest.approx(70.0)}
    errors = [s["cut_error_mm"] for s in truth["strings"]]
    assert [s["id"] for s in truth["strings"]] == ["k1-001-01", "k1-002-01"] and all(abs(e) <= 3 for e in errors)
    assert truth["inflation"]["converged"] is True and truth["resolution_mm"] == 50.0
    assert set(truth["deviation"]) >= {"surface", "rms_mm", "max_mm", "rms_pct_diag"}
    scan = truth["scan"]
    assert scan["points"] == 20_000 and scan["units"] == "mm" and scan["noise_mm"] == NOISE_MM
    assert scan["surface_points"] + scan["floor_points"] + scan["clutter_points"] == 20_000
    assert scan["coverage_achieved"] == pytest.approx(0.85, abs=1e-3)
    rot = np.array(truth["scan_to_design"]["rotation"])
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-12) and np.linalg.det(rot) == pytest.approx(1.0)


def test_the_stated_transform_maps_the_scan_onto_the_built_upper_face(built):
    truth = json.loads((built / "truth.json").read_text())
    x = _to_design_mm(built / "scan.ply", truth)
    mesh = trimesh.load(built / "built.ply", process=False)
    dist = MeshProjector(np.asarray(mesh.vertices), np.asarray(mesh.faces)).closest(x).distance
    n = truth["scan"]["surface_points"]
    # the surface points' normal noise is N(0, σ²): the closest n points hold them, 99 % within 2.6 σ (and
    # the rim's floor points, which are on the mattress's edge); a wrong transform puts them metres away
    assert np.quantile(np.sort(dist)[:n], 0.99) < 2.6 * NOISE_MM * 1.1
    floor = x[np.abs(x[:, 2] - truth["scan"]["floor_z_mm"]) < 4 * NOISE_MM]
    assert len(floor) >= truth["scan"]["floor_points"] * 0.99      # the floor is level in the design's frame


def test_with_the_median_world_built_ply_is_checks_inflated_ply(design, tmp_path):
    assert main(["synth-built", str(design), "--out", str(tmp_path / "sb"), *SMALL]) == 0
    assert main(["check", str(design), "--out", str(tmp_path / "check"), "--resolution-mm", "50", "--no-envelope",
                 "--tolerance", "none", "-q"]) == 0
    ours = trimesh.load(tmp_path / "sb" / "built.ply", process=False)
    theirs = trimesh.load(tmp_path / "check" / "inflated.ply", process=False)
    assert np.array_equal(ours.faces, theirs.faces)
    assert np.abs(np.asarray(ours.vertices) - np.asarray(theirs.vertices)).max() <= 1e-6     # mm: 1e-9 m


def test_metres_and_millimetres_hold_the_same_points(design, built, tmp_path):
    assert main(["synth-built", str(design), "--out", str(tmp_path / "m"), "--cut-error-mm", "3", "--delta-mm", "12",
                 "--thickness-mm", "75", "--seed", "3", "--scan-units", "m", *SMALL]) == 0
    t_m = json.loads((tmp_path / "m" / "truth.json").read_text())
    t_mm = json.loads((built / "truth.json").read_text())
    assert t_m["scan"]["units"] == "m" and t_m["scan_to_design"]["mm_per_scan_unit"] == 1000.0
    p_m = read_scan(tmp_path / "m" / "scan.ply", units="m").points
    p_mm = read_scan(built / "scan.ply", units="mm").points
    # both read as metres; the PLY holds float32: each file rounds to its own float32 grid
    ulp = np.finfo(np.float32).eps * np.abs(p_mm).max()
    assert np.allclose(p_m, p_mm, rtol=0, atol=2 * ulp)
    assert np.allclose(_to_design_mm(tmp_path / "m" / "scan.ply", t_m), _to_design_mm(built / "scan.ply", t_mm),
                       rtol=0, atol=2 * ulp * 1e3)


def test_the_same_seed_gives_the_same_bytes_and_another_seed_another_scan(design, built, tmp_path):
    args = ["synth-built", str(design), "--cut-error-mm", "3", "--delta-mm", "12", "--thickness-mm", "75", *SMALL]
    assert main([*args, "--out", str(tmp_path / "same"), "--seed", "3"]) == 0
    for name in ("scan.ply", "built.ply", "truth.json"):
        assert (tmp_path / "same" / name).read_bytes() == (built / name).read_bytes(), name
    assert main([*args, "--out", str(tmp_path / "other"), "--seed", "4"]) == 0
    assert (tmp_path / "other" / "scan.ply").read_bytes() != (built / "scan.ply").read_bytes()
    other = json.loads((tmp_path / "other" / "truth.json").read_text())["strings"]
    assert [s["cut_error_mm"] for s in other] != [s["cut_error_mm"]
                                                  for s in json.loads((built / "truth.json").read_text())["strings"]]


@pytest.mark.parametrize("argv, words", [
    (["--cut-error-mm", "-1"], "--cut-error-mm"),
    (["--coverage", "0"], "--coverage"),
    (["--coverage", "1.5"], "--coverage"),
    (["--noise-mm", "-0.1"], "--noise-mm"),
    (["--thickness-mm", "1e6"], "--thickness-mm"),
    (["--scan-format", "las", "--scan-units", "mm"], "in metres"),
])
def test_bad_options_exit_2_in_one_line_and_write_nothing(design, tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    assert main(["synth-built", str(design), "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("airmat synth-built: ") and words in err[0]
    assert not out.exists()


def test_a_missing_design_folder_is_named_in_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["synth-built", str(tmp_path / "nowhere"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"airmat synth-built: {tmp_path / 'nowhere'}: ")
    assert not out.exists()


def test_the_help_s_scan_formats_are_the_writer_s():
    from airmat.cli.synth_built import SCAN_FORMATS
    from airmat.synthetic.scan_write import FORMATS

    assert SCAN_FORMATS == tuple(sorted(FORMATS))
