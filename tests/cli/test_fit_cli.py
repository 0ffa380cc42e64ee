"""`airmat fit SCAN`: a short summary on stdout, one JSON object with --json; bad input exits 2 with one stderr
line; a scan in the wrong unit is named with the --scan-units that reads it."""

import json

import numpy as np
import pytest

from airmat.cli import main
from airmat.synthetic.ply_write import write_ply
from airmat.synthetic.specimen_scan import specimen_scan

FIELDS = ("radius_mm", "kappa_per_m", "kappa_se_per_m", "axis", "inlier_fraction", "rms_mm", "arc_deg",
          "n_points", "converged")


@pytest.fixture(scope="module")
def scan_mm(tmp_path_factory):
    s = specimen_scan(4.0, n_points=30_000, arc_deg=60, seed=7)
    path = tmp_path_factory.mktemp("scans") / "specimen.ply"
    write_ply(path, s.points * 1e3, encoding="binary_big_endian", dtype="float64",
              extra={"confidence": np.ones(len(s.points), np.float32)})
    return path, s


def _run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_fit_prints_one_json_object_with_the_fields(scan_mm, capsys, tmp_path):
    path, s = scan_mm
    before = sorted(p.name for p in path.parent.iterdir())
    code, out, err = _run(["fit", str(path), "-q", "--json"], capsys)
    assert code == 0, err
    record = json.loads(out)
    for key in FIELDS:
        assert key in record
    assert record["radius_mm"] == pytest.approx(250.0, rel=0.005)
    assert abs(record["kappa_per_m"] - 4.0) < 4 * record["kappa_se_per_m"]
    assert abs(np.dot(record["axis"], s.axis)) > 0.999
    assert record["n_points"] == 30_000 and record["converged"] is True
    assert sorted(p.name for p in path.parent.iterdir()) == before  # fit writes no files


def test_scan_units_metres(tmp_path, capsys):
    s = specimen_scan(2.0, n_points=20_000, arc_deg=60, seed=8)
    path = tmp_path / "metres.ply"
    write_ply(path, s.points, dtype="float64", encoding="ascii")
    code, out, err = _run(["fit", str(path), "--scan-units", "m", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["radius_mm"] == pytest.approx(500.0, rel=0.005)
    # the same file read as millimetres is caught by its size
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "--scan-units m" in lines[0] and str(path) in lines[0]


def test_flat_specimen_has_null_radius(tmp_path, capsys):
    path = tmp_path / "flat.ply"
    write_ply(path, specimen_scan(0.0, n_points=20_000, seed=9).points * 1e3)
    code, out, err = _run(["fit", str(path), "--json"], capsys)
    assert code == 0, err
    record = json.loads(out)
    assert record["radius_mm"] is None
    assert record["kappa_per_m"] < 3 * record["kappa_se_per_m"]


@pytest.mark.parametrize("case", ["missing", "empty", "truncated", "not_a_cylinder", "bad_noise"])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, case):
    path = tmp_path / f"{case}.ply"
    extra = []
    if case == "empty":
        path.write_bytes(b"")
    elif case == "truncated":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (1000, 3)))
        path.write_bytes(path.read_bytes()[:-100])
    elif case == "not_a_cylinder":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (20_000, 3)))
    elif case == "bad_noise":
        write_ply(path, np.random.default_rng(0).uniform(-300, 300, (1000, 3)))
        extra = ["--noise-mm", "-1"]
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = _run(["fit", str(path), *extra], capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("airmat fit: ")
    assert "Traceback" not in err
    if case != "bad_noise":
        assert str(path) in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_fit_that_did_not_converge_is_an_error_naming_the_scan(scan_mm, capsys, monkeypatch):
    import dataclasses

    import airmat.calib.cylinder_fit as cf

    real = cf.full_resolution_fit

    def stopped(*args, **kwargs):                       # the last least squares ran out of iterations
        frame, final, used, n_more = real(*args, **kwargs)
        return frame, dataclasses.replace(final, converged=False, message="max_nfev reached"), used, n_more

    monkeypatch.setattr(cf, "full_resolution_fit", stopped)
    path, _ = scan_mm
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 2 and out == ""                      # never a number from a failed fit
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0]
    assert "did not converge" in lines[0] and "max_nfev reached" in lines[0]


def test_fit_reads_a_multiscan_e57_and_a_georeferenced_laz(tmp_path, capsys):
    from scipy.spatial.transform import Rotation

    from airmat.synthetic.scan_write import write_scan

    s = specimen_scan(4.0, n_points=30_000, arc_deg=60, seed=7)
    poses = [(np.eye(3), np.zeros(3)), (Rotation.from_euler("z", 60, degrees=True).as_matrix(),
                                        np.array([2000.0, 0.0, 500.0]))]
    e57 = write_scan(tmp_path / "two.e57", s.points * 1e3, "e57", poses=poses)
    code, out, err = _run(["fit", str(e57), "-q", "--json"], capsys)
    assert code == 0, err
    rec = json.loads(out)
    assert rec["n_scans"] == 2 and rec["scan_units"] == "m" and rec["n_points"] == len(s.points)
    assert rec["radius_mm"] == pytest.approx(250.0, rel=0.005)
    code, out, err = _run(["fit", str(e57), "--scan-index", "5"], capsys)
    assert code == 2 and "--scan-index 5 out of range" in err and str(e57) in err
    utm = np.array([5e6, 4.2e6, 300.0])
    laz = write_scan(tmp_path / "utm.laz", (s.points + utm) * 1e3, "laz")
    code, out, err = _run(["fit", str(laz), "-q", "--json"], capsys)
    assert code == 0, err
    rec = json.loads(out)
    assert rec["radius_mm"] == pytest.approx(250.0, rel=0.005)
    assert rec["offset_mm"][0] == pytest.approx(5e9, rel=1e-6)
    # the axis passes through the file's (georeferenced) coordinates: the centre is within reach
    assert np.linalg.norm(np.array(rec["center_mm"]) - utm * 1e3) < 2000


def test_fit_scan_units_cm(tmp_path, capsys):
    from airmat.synthetic.scan_write import write_scan

    s = specimen_scan(4.0, n_points=30_000, arc_deg=60, seed=7)
    path = write_scan(tmp_path / "cm.xyz", s.points * 1e2, "xyz")
    code, out, err = _run(["fit", str(path), "--scan-units", "cm", "-q", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["radius_mm"] == pytest.approx(250.0, rel=0.005)


def test_a_refused_sparse_scan_says_it_may_be_too_sparse(tmp_path, capsys):
    """A synthetic set of 2000 points per scan (below synth's 10 000): its specimen 04 is refused for the
    normals' scatter, and the message says that so few points may be why; the same specimen at 10 000
    points fits."""
    from airmat.synthetic.calibration_set import calibration_set

    calibration_set(tmp_path / "sparse", n_points=2000, seed=0)
    code, _, err = _run(["fit", str(tmp_path / "sparse" / "specimen_04.ply")], capsys)
    assert code == 2
    assert "normals do not lie in a plane" in err
    assert "only 2000 points on the specimen: so few give noisy normals, a denser scan (at least 5000) may fit" in err
    calibration_set(tmp_path / "dense", n_points=10_000, seed=0)
    code, _, err = _run(["fit", str(tmp_path / "dense" / "specimen_04.ply")], capsys)
    assert code == 0, err


def test_fit_prints_a_human_summary_by_default(scan_mm, capsys):
    """Without --json: a few lines (radius mm, κ ± se 1/m, inliers, arc, converged), the same numbers as the JSON."""
    path, _ = scan_mm
    code, out, err = _run(["fit", str(path), "-q"], capsys)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == f"airmat fit: {path} (points in mm)" and len(lines) == 6
    code, js, _ = _run(["fit", str(path), "-q", "--json"], capsys)
    rec = json.loads(js)
    assert f"radius     {rec['radius_mm']:.1f} mm" in out
    assert f"κ          {rec['kappa_per_m']:.3f} ± {rec['kappa_se_per_m']:.3f} 1/m" in out
    assert f"inliers    {rec['n_inliers']} of the " in out and f"arc        {rec['arc_deg']:.1f}°" in out
    assert lines[-1].startswith("  converged  yes (")
    with pytest.raises(ValueError):
        json.loads(out)


@pytest.mark.parametrize("fmt,suffix", [("e57", ".e57"), ("laz", ".laz")])
def test_a_scan_written_in_millimetres_where_the_format_says_metres_names_the_unit(tmp_path, capsys, fmt, suffix):
    """An E57 or LAZ whose numbers are millimetres (the formats fix metres): refused with the extent it would have
    in millimetres and the --scan-units that reads it; with that option it fits."""
    from airmat.synthetic.scan_write import write_scan

    pytest.importorskip("pye57" if fmt == "e57" else "laspy")
    s = specimen_scan(4.0, n_points=20_000, arc_deg=60, seed=7)
    path = write_scan(tmp_path / f"in_mm{suffix}", s.points * 1e6, fmt)   # file metres holding millimetres
    code, out, err = _run(["fit", str(path)], capsys)
    assert code == 2 and out == ""
    line = err.strip()
    assert "\n" not in line and str(path) in line
    extent_m = float(line.split("extent ")[1].split(" m")[0])
    assert "not a specimen scan (20 mm to 50 m)" in line and "format is in m" in line
    assert line.endswith(f"; read as millimetres it is {extent_m / 1e3:.3g} m: pass --scan-units mm"), line
    code, out, err = _run(["fit", str(path), "--scan-units", "mm", "--json", "-q"], capsys)
    assert code == 0, err
    assert json.loads(out)["radius_mm"] == pytest.approx(250.0, rel=0.005)
