"""Not converged is not success: exit code 3, results written, exactly one stderr line.

The library's own warnings (MCMC, relaxation, inflation) are still logged, at
their loggers, and reach stderr only at ``-v``. Each command that can return 3
is run with its solver made to report non-convergence, as the real solver does:
a result with ``converged`` false and a WARNING at the solver's logger.
"""

import contextlib
import dataclasses
import io
import json
import logging

import pytest

from airmat.cli import main


def _run(argv, capsys):
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, capsys.readouterr().err.strip().splitlines()


def _one_line(err, command, words):
    assert len(err) == 1, err
    assert err[0].startswith(f"airmat {command}: not converged: ") and words in err[0], err
    assert err[0].endswith("(results written, exit code 3)")


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("set")
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["synth", str(root / "set"), "--points", "10000", "--l-over-L", "0.4,0.6,0.8,0.9", "-q"]) == 0
        assert main(["design", "--preset", "vault1", "--spacing-mm", "40", "--out", str(root / "design"), "-q"]) == 0
    return root


def test_calibrate_a_short_mcmc_is_exit_3_with_one_line(small_set, tmp_path, capsys, caplog):
    out = tmp_path / "cal"
    argv = ["calibrate", str(small_set / "set" / "manifest.csv"), "--out", str(out),
            "--walkers", "16", "--max-steps", "100", "--seed", "7"]
    with caplog.at_level(logging.WARNING, logger="airmat.calib.posterior"):
        code, err = _run(argv, capsys)          # a real run: 100 steps are far too few for the MCMC
    assert code == 3
    _one_line(err, "calibrate", "MCMC")
    assert any("NOT converged" in r.getMessage() for r in caplog.records if r.name == "airmat.calib.posterior")
    assert json.loads((out / "calibration.json").read_text())["diagnostics"]["converged"] is False
    code, err = _run(argv[:3] + [str(tmp_path / "cal_v")] + argv[4:] + ["-v"], capsys)
    assert code == 3 and len(err) > 1 and any(line.startswith("WARNING: MCMC NOT converged") for line in err)
    assert err[-1].startswith("airmat calibrate: not converged: ")


def test_design_an_unconverged_relaxation_is_exit_3(small_set, tmp_path, capsys, caplog, monkeypatch):
    import airmat.design.pipeline as pipeline

    real = pipeline.design

    def stopped(*args, **kwargs):
        result = real(*args, **kwargs)
        relax = dataclasses.replace(result.approx.relax, converged=False, message="stopped at 5 iterations")
        logging.getLogger("airmat.design.relax").warning("U_A relaxation not converged: %s", relax.message)
        return dataclasses.replace(result, approx=dataclasses.replace(result.approx, relax=relax))

    monkeypatch.setattr(pipeline, "design", stopped)
    out = tmp_path / "design"
    with caplog.at_level(logging.WARNING, logger="airmat.design.relax"):
        code, err = _run(["design", "--preset", "vault1", "--spacing-mm", "40", "--out", str(out)], capsys)
    assert code == 3
    _one_line(err, "design", "U_A relaxation: stopped at 5 iterations")
    assert [r.name for r in caplog.records if "not converged" in r.getMessage()] == ["airmat.design.relax"]
    assert json.loads((out / "design.json").read_text())["relaxation"]["converged"] is False


def _unconverged_check(monkeypatch):
    import airmat.check.inflation_check as ic

    real = ic.check

    def stopped(*args, **kwargs):
        result = real(*args, **kwargs)
        med = result.runs["median"]
        inf = dataclasses.replace(med.inflation, converged=False, message="Newton stopped at 3 iterations")
        logging.getLogger("airmat.inflation.solver").warning("inflation not converged: %s", inf.message)
        runs = {**result.runs, "median": dataclasses.replace(med, inflation=inf)}
        return dataclasses.replace(result, runs=runs)

    monkeypatch.setattr(ic, "check", stopped)


def test_inflate_an_unconverged_inflation_is_exit_3(small_set, tmp_path, capsys, caplog, monkeypatch):
    _unconverged_check(monkeypatch)
    out = tmp_path / "inflate"
    with caplog.at_level(logging.WARNING, logger="airmat.inflation.solver"):
        code, err = _run(["inflate", str(small_set / "design"), "--out", str(out), "--resolution-mm", "60",
                          "--no-envelope", "--jobs", "1"], capsys)
    assert code == 3
    _one_line(err, "inflate", "median string lengths: Newton stopped at 3 iterations")
    assert any(r.name == "airmat.inflation.solver" for r in caplog.records)
    doc = json.loads((out / "inflate.json").read_text())
    assert doc["converged"] is False and doc["solver"]["converged"] is False


def test_validate_an_unconverged_point_is_exit_3(tmp_path, capsys, monkeypatch):
    import airmat.check.validation as validation

    real = validation.validate_equation3

    def stopped(*args, **kwargs):
        points = real(*args, **kwargs)
        return [dataclasses.replace(points[0], converged=False, message="Newton stopped")] + list(points[1:])

    monkeypatch.setattr(validation, "validate_equation3", stopped)
    out = tmp_path / "val"
    code, err = _run(["validate", "--out", str(out), "--l-over-L", "0.5", "--resolution-mm", "75",
                      "--jobs", "1"], capsys)
    assert code == 3
    _one_line(err, "validate", "inflation at l/L = 0.5: Newton stopped")
    assert json.loads((out / "validate.json").read_text())["points"][0]["converged"] is False


@pytest.mark.slow  # one preset designed and inflated: about 10 s
def test_gallery_an_unconverged_inflation_is_exit_3(tmp_path, capsys, monkeypatch):
    _unconverged_check(monkeypatch)
    out = tmp_path / "gal"
    code, err = _run(["gallery", "--presets", "saddle", "--resolution-mm", "60", "--out", str(out), "--jobs", "1"],
                     capsys)
    assert code == 3
    _one_line(err, "gallery", "saddle: inflation with the median string lengths")
    assert json.loads((out / "gallery.json").read_text())["saddle"]["converged"] is False


@pytest.mark.slow  # the whole pipeline on small scans (without the refinement, which is not what fails here): 17 s
def test_demo_an_unconverged_inflation_is_exit_3(tmp_path, capsys, monkeypatch):
    _unconverged_check(monkeypatch)
    out = tmp_path / "demo"
    code, err = _run(["demo", "--out", str(out), "--points", "20000", "--resolution-mm", "60", "--jobs", "1",
                      "--no-refine"], capsys)
    assert code == 3
    _one_line(err, "demo", "inflation with the median string lengths")
    assert (out / "report.html").is_file()
