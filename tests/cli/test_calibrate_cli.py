"""`airmat synth` and `airmat calibrate`: outputs, exit codes, one-line errors, atomic output."""

import json
import os

import numpy as np
import pytest

from airmat.cli import main

RATIOS = "0.3,0.4,0.5,0.6,0.7,0.8,0.9,0.95"


@pytest.fixture(scope="module")
def synth_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "set"
    assert main(["synth", str(out), "--points", "20000", "--l-over-L", RATIOS, "--seed", "4", "-q"]) == 0
    return out


def snapshot(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_synth_twice_same_seed_same_bytes(tmp_path, capsys):
    args = ["--points", "10000", "--l-over-L", "0.3,0.6,0.9", "--seed", "7"]
    assert main(["synth", str(tmp_path / "a"), *args]) == 0
    assert "truth: Delta = 18 mm" in capsys.readouterr().out
    assert main(["synth", str(tmp_path / "b"), *args]) == 0
    a, b = snapshot(tmp_path / "a"), snapshot(tmp_path / "b")
    assert set(a) == {"manifest.csv", "truth.json", "specimen_00.ply", "specimen_01.ply",
                                "specimen_02.ply"}
    assert a == b
    assert main(["synth", str(tmp_path / "c"), *args[:-1], "8"]) == 0
    assert snapshot(tmp_path / "c")["specimen_00.ply"] != a["specimen_00.ply"]


def test_synth_options_reach_the_truth(tmp_path):
    assert main(["synth", str(tmp_path), "--points", "10000", "--l-over-L", "0.3,0.6,0.9",
                 "--delta-mm", "10", "--d-mm", "50", "--L-mm", "250", "--scatter", "0"]) == 0
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert (truth["delta_mm"], truth["d_mm"], truth["L_mm"], truth["sigma_per_m"]) == (10, 50, 250, 0)
    assert (tmp_path / "manifest.csv").read_text().splitlines()[1] == "specimen_00.ply,75,250"


@pytest.mark.parametrize("args, match", [
    (["--l-over-L", "0.3,zero,0.9"], "expected comma-separated numbers"),
    (["--l-over-L", "0.3,0.6"], "at least 3"),
    (["--thickness-mm", "-70"], "--thickness-mm: -70 mm is outside [10, 500] mm"),
    (["--d-mm", "-70"], "--thickness-mm: -70 mm is outside [10, 500] mm"),   # the old name, same check
])
def test_synth_bad_input(tmp_path, capsys, args, match):
    out = tmp_path / "set"
    assert main(["synth", str(out), "--points", "10000", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("airmat synth: ") and match in err[0]
    assert not out.exists()


def test_calibrate_writes_every_file_with_the_fields(synth_set, tmp_path, capsys, wrote):
    out = tmp_path / "cal"
    code = main(["calibrate", str(synth_set / "manifest.csv"), "--out", str(out),
                 "--truth", str(synth_set / "truth.json"), "-q"])
    assert code == 0
    stdout = capsys.readouterr().out
    assert "Delta =" in stdout and "95%" in stdout and str(out) in stdout
    assert {p.name for p in out.iterdir()} == {"calibration.json", "posterior.npz", "specimens.csv",
                                               "curve.png", "corner.png", "report.html"} == wrote(stdout, out)
    assert "κ₁(l/L)" in (out / "report.html").read_text(encoding="utf-8")
    doc = json.loads((out / "calibration.json").read_text())
    for name in ("delta_mm", "d_mm", "sigma_per_m"):
        assert set(doc["parameters"][name]) == {"median", "lo95", "hi95"}
    truth = json.loads((synth_set / "truth.json").read_text())
    assert doc["parameters"]["delta_mm"]["lo95"] < truth["delta_mm"] < doc["parameters"]["delta_mm"]["hi95"]
    assert doc["parameters"]["d_mm"]["lo95"] < truth["d_mm"] < doc["parameters"]["d_mm"]["hi95"]
    assert len(doc["specimens"]) == 8 and doc["diagnostics"]["converged"] is True
    assert {"tau", "acceptance_fraction", "n_steps", "converged"} <= set(doc["diagnostics"])
    assert {"l_over_L", "kappa_per_m", "L_mm"} <= set(doc["curve"]) and doc["seed"] == 0
    with np.load(out / "posterior.npz") as npz:
        assert {"delta_m", "d_m", "sigma_per_m", "L_m"} <= set(npz.files)
        assert npz["delta_m"].shape == npz["d_m"].shape == npz["sigma_per_m"].shape
    assert (out / "specimens.csv").read_text().startswith("scan,l_mm,L_mm,")


def bad_cases(tmp, synth_set):
    """(arguments, expected stderr fragment, the path it must name) of calibrate runs that must fail."""
    manifest = synth_set / "manifest.csv"
    bad_manifest = tmp / "bad.csv"
    bad_manifest.write_text("scan,l_mm\nspecimen_00.ply,90\n")
    not_cyl = tmp / "noise"
    not_cyl.mkdir()
    from airmat.synthetic.ply_write import write_ply
    rng = np.random.default_rng(0)
    for name in ("a.ply", "b.ply", "c.ply"):
        write_ply(not_cyl / name, rng.uniform(-200, 200, (5000, 3)))
    (not_cyl / "m.csv").write_text("scan,l_mm,L_mm\na.ply,90,300\nb.ply,150,300\nc.ply,200,300\n")
    loop = tmp / "loop"
    loop.mkdir()
    os.symlink(loop / "a.ply", loop / "b.ply")
    os.symlink(loop / "b.ply", loop / "a.ply")
    (loop / "m.csv").write_text("scan,l_mm,L_mm\na.ply,90,300\nb.ply,150,300\nc.ply,200,300\n")
    return [
        ([str(loop / "m.csv")], "line 2: scan 'a.ply' cannot be resolved", loop / "m.csv"),  # a symlink loop
        ([str(tmp / "missing.csv")], "manifest not found", tmp / "missing.csv"),
        ([str(bad_manifest)], "missing column(s) L_mm", bad_manifest),
        ([str(not_cyl / "m.csv")], "", not_cyl / "a.ply"),
        ([str(manifest), "--scan-units", "m"], "", synth_set / "specimen_00.ply"),
        ([str(manifest), "--truth", str(tmp / "nope.json")], "truth file not found", tmp / "nope.json"),
        ([str(manifest), "--walkers", "4"], "--walkers 4", None),
    ]


def test_calibrate_bad_input_exit_2_one_line_nothing_written(synth_set, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "calibration.json").write_text('{"previous": "good run"}')
    before = snapshot(out)
    for args, fragment, path in bad_cases(tmp_path, synth_set):
        code = main(["calibrate", *args, "--out", str(out), "--max-steps", "50", "-q"])
        captured = capsys.readouterr()
        err = captured.err.strip().splitlines()
        assert code == 2, (args, captured.err)
        assert len(err) == 1 and err[0].startswith("airmat calibrate: "), err
        assert fragment in err[0] and "Traceback" not in captured.err
        if path is not None:
            assert str(path.resolve()) in err[0] or str(path) in err[0], err[0]
        assert captured.out == ""
        assert snapshot(out) == before  # the previous good output is untouched
        assert not any(p.name.startswith(".out.staging") for p in tmp_path.iterdir())


def test_calibrate_without_out_writes_to_out_calibrate_and_a_missing_manifest_writes_nothing(capsys, tmp_path,
                                                                                            monkeypatch):
    # --out is optional in every command (default out/<command>); bad input still writes nothing there
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "m.csv"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "m.csv" in err[0], err
    assert not (tmp_path / "out").exists()


def test_calibrate_fit_that_did_not_converge_is_an_error_naming_the_scan(synth_set, tmp_path, capsys,
                                                                          monkeypatch):
    import dataclasses

    import airmat.calib.cylinder_fit as cf

    real = cf.full_resolution_fit

    def stopped(*args, **kwargs):
        frame, final, used, n_more = real(*args, **kwargs)
        return frame, dataclasses.replace(final, converged=False, message="max_nfev reached"), used, n_more

    monkeypatch.setattr(cf, "full_resolution_fit", stopped)
    out = tmp_path / "cal"
    code = main(["calibrate", str(synth_set / "manifest.csv"), "--out", str(out), "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and not out.exists()
    assert len(err) == 1 and "did not converge" in err[0] and "specimen_00.ply" in err[0]
