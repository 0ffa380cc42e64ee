"""`airmat export` (a design folder's workshop files, made again, in place or into --out) and `airmat report`
(report.html rebuilt from a design, calibration or check folder's files)."""

import json
import re
import shutil
import zlib
from pathlib import Path

import numpy as np
import pytest

from airmat.cli import main

#: what write_design writes and export leaves alone unless asked
ALL_FILES = ("design.json", "approx_surface.ply", "approx_surface.obj", "target.ply", "calibration_samples.npz",
             "pattern.svg", "pattern.dxf", "cutting_list.csv", "preview.png", "design.3dm")


@pytest.fixture(scope="module")
def refined(tmp_path_factory):
    """A refined design folder as 'airmat refine' writes it (coarse meshes, two Gauss-Newton steps: fast)."""
    from airmat.check.refinement import refine
    from airmat.design.design_io import write_design
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset

    target, mattress = preset("vault1")
    result = design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    folder = tmp_path_factory.mktemp("refined") / "D"
    folder.mkdir()
    write_design(refine(result, resolution=0.04, max_iter=2).design, folder)
    return folder


@pytest.fixture
def folder(refined, tmp_path):
    """A private copy of the refined design folder, its files' times kept."""
    return Path(shutil.copytree(refined, tmp_path / "D"))


def _state(folder, skip=()):
    """Every file of ``folder`` (hidden ones too) -> (bytes, mtime in ns), but those named in ``skip``."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(Path(folder).iterdir())
            if p.name not in skip}


def _pdf_text(data: bytes) -> str:
    """The text drawn on the PDF's pages: matplotlib kerns each glyph, ``[(k) 0.1 (1) ...] TJ``."""
    streams = []
    for s in re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            streams.append(zlib.decompress(s))
        except zlib.error:
            continue
    runs = re.findall(rb"\[(.*?)\]\s*TJ", b"\n".join(streams), re.S)
    return "\n".join(b"".join(re.findall(rb"\(((?:\\.|[^\\)])*)\)", r)).decode("latin-1") for r in runs)


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_export_makes_the_workshop_files_of_a_refined_design_and_touches_nothing_else(folder, capsys, wrote):
    from airmat.design.export.pdf import tile_grid
    from airmat.design.export.svg import page_size

    doc = json.loads((folder / "design.json").read_text())
    assert doc.get("refine") and not (folder / "pattern_A4.pdf").exists()   # refined; no PDF yet
    made = {"pattern_A4.pdf", "pattern.dxf", "cutting_list.csv", "design.3dm"}   # the default set
    before = _state(folder, skip=made)
    dxf, csv = (folder / "pattern.dxf").read_bytes(), (folder / "cutting_list.csv").read_bytes()
    assert main(["export", str(folder)]) == 0
    assert wrote(capsys.readouterr().out, folder) == made
    assert _state(folder, skip=made) == before                  # bytes and times of every other file
    assert (folder / "pattern.dxf").read_bytes() == dxf and (folder / "cutting_list.csv").read_bytes() == csv
    pdf = (folder / "pattern_A4.pdf").read_bytes()
    cols, rows = tile_grid(page_size(doc), "A4")
    assert len(re.findall(rb"/Type /Page\b", pdf)) == cols * rows > 0
    text = _pdf_text(pdf)
    ids = [d["id"] for d in doc["dashes"]]
    assert ids and all(i in text for i in ids)
    # the refined lengths, as the cutting list gives them (0.1 mm on the drawing)
    assert all(f"{d['l_mm']['median']:.1f}" in text for d in doc["dashes"])


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_export_dxf_rewrites_it_byte_for_byte_and_nothing_else(folder, capsys, wrote):
    original = (folder / "pattern.dxf").read_bytes()
    (folder / "pattern.dxf").write_bytes(b"stale")
    before = _state(folder, skip=("pattern.dxf",))
    assert main(["export", str(folder), "--dxf"]) == 0
    assert wrote(capsys.readouterr().out, folder) == {"pattern.dxf"}
    assert (folder / "pattern.dxf").read_bytes() == original
    assert _state(folder, skip=("pattern.dxf",)) == before      # no staging folder left either


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_export_out_writes_a_folder_with_just_those_files(folder, tmp_path, capsys, wrote):
    before = _state(folder)
    out = tmp_path / "workshop"
    assert main(["export", str(folder), "--csv", "--dxf", "--out", str(out)]) == 0
    assert wrote(capsys.readouterr().out, out) == {"cutting_list.csv", "pattern.dxf"}
    assert sorted(p.name for p in out.iterdir()) == ["cutting_list.csv", "pattern.dxf"]
    for name in ("cutting_list.csv", "pattern.dxf"):
        assert (out / name).read_bytes() == (folder / name).read_bytes()
    assert _state(folder) == before


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_a_failed_export_leaves_the_old_files(folder, monkeypatch, capsys):
    import airmat.design.export as export
    from airmat.errors import AirmatError

    def fail(*args, **kwargs):
        raise AirmatError("the writer failed")

    (folder / "pattern.dxf").write_bytes(b"old")
    monkeypatch.setattr(export, "write_cutting_list", fail)     # after the DXF was made
    before = _state(folder)
    assert main(["export", str(folder), "--dxf", "--csv"]) == 1
    assert capsys.readouterr().err.strip() == "airmat export: the writer failed"
    assert _state(folder) == before


def _bad_folders(tmp_path):
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "empty").mkdir()
    return {"missing": tmp_path / "missing", "a file": tmp_path / "a_file", "not a design": tmp_path / "empty"}


@pytest.mark.parametrize("case", ["missing", "a file", "not a design"])
@pytest.mark.parametrize("command", ["export", "report"])
def test_a_bad_folder_is_exit_2_and_one_line_naming_it(command, case, tmp_path, capsys):
    bad = _bad_folders(tmp_path)[case]
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main([command, str(bad)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith(f"airmat {command}: {bad}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert not (bad.is_dir() and any(bad.iterdir()))


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_report_of_a_design_folder_names_the_design_and_its_strings(folder, capsys):
    doc = json.loads((folder / "design.json").read_text())
    before = _state(folder)
    assert main(["report", str(folder)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"  wrote report.html to {folder}"
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert f"airmat refine: {doc['name']}" in html and f"{len(doc['dashes'])} strings" in html
    assert _state(folder, skip=("report.html",)) == before      # report.html was not there before


def _calibration(folder):
    """A calibration of three specimens with a known posterior (seeded): Δ about 18 mm, d about 70 mm."""
    from airmat.calib.calibrate import Calibration, SpecimenFit
    from airmat.calib.calibration_io import write_calibration
    from airmat.calib.curve import kappa_curve
    from airmat.calib.manifest import Manifest
    from airmat.calib.posterior import ParamSummary, Posterior

    rng = np.random.default_rng(1)
    n = 2000
    samples = np.column_stack([rng.normal(0.018, 0.001, n), rng.normal(0.07, 0.003, n),
                               np.abs(rng.normal(0.1, 0.02, n))])
    scans = ("a.ply", "b.ply", "c.ply")
    man = Manifest(path=str(folder / "manifest.csv"), scans=scans, scan_paths=scans, l=np.array([0.1, 0.2, 0.25]),
                   L=np.full(3, 0.3), surface_offset=np.zeros(3))
    specimens = tuple(SpecimenFit(scan=s, path=s, l=l, L=0.3, surface_offset=0.0, kappa=k, kappa_se=0.05,
                                  radius=1 / k if k else np.inf, inlier_fraction=0.9, rms=0.001, arc_deg=80.0,
                                  n_points=1000, fit_converged=True)
                      for s, l, k in zip(scans, man.l, (9.0, 4.0, 0.0)))
    post = Posterior(samples=samples, log_prob=rng.normal(size=n), delta=ParamSummary.of(samples[:, 0]),
                     d=ParamSummary.of(samples[:, 1]), sigma=ParamSummary.of(samples[:, 2]),
                     start=np.array([0.018, 0.07, 0.1]), tau=np.array([12.0, 14.0, 20.0]), acceptance_fraction=0.4,
                     n_steps=1000, n_walkers=32, burn=100, thin=5, converged=True, n_iter=1000, residual=0.9,
                     message="ok")
    cal = Calibration(manifest=man, specimens=specimens, posterior=post, curve=kappa_curve(samples, 0.3, n_grid=11),
                      kappa_model=np.array([9.1, 4.2, 0.1]), seed=7, timings={"fit": 1.0})
    write_calibration(cal, folder)
    return cal


def test_report_of_a_calibration_folder_shows_delta_and_d(tmp_path, capsys):
    cal = _calibration(tmp_path / "C")
    assert main(["report", str(tmp_path / "C"), "--out", str(tmp_path / "R")]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in (tmp_path / "R").iterdir()) == ["report.html"]
    assert not (tmp_path / "C" / "report.html").exists()        # --out: the calibration folder is left alone
    html = (tmp_path / "R" / "report.html").read_text(encoding="utf-8")
    p = cal.posterior
    assert "Δ slip (mm)" in html and "d thickness (mm)" in html
    assert f"{p.delta.median * 1e3:.2f}" in html and f"{p.d.median * 1e3:.2f}" in html


@pytest.mark.slow      # the refined design folder (about 20 s, once per module)
def test_report_of_a_check_folder_takes_its_design_and_the_numbers_of_inflate_json(folder, tmp_path, capsys):
    doc = json.loads((folder / "design.json").read_text())
    dev = {"rms_mm": 12.3, "max_mm": 45.6, "rms_pct_diag": 1.11, "surface": "top"}
    check = tmp_path / "I"
    check.mkdir()
    (check / "inflate.json").write_text(json.dumps({
        "design": str(folder), "resolution_mm": 40.0, "mesh_vertices": 999, "deviation": dev, "envelope": {},
        "solver": {"converged": True, "iterations": 7, "residual": 1e-9}, "timings_s": {"median": 1.0},
        "dashes": [{"id": d["id"], "kappa_target_per_m": 1.0, "kappa_realized_per_m": 1.0} for d in doc["dashes"]],
        "converged": True}))
    assert main(["report", str(check)]) == 0
    assert "check's numbers" in capsys.readouterr().out
    html = (check / "report.html").read_text(encoding="utf-8")
    assert f"airmat check: {doc['name']}" in html and f"{len(doc['dashes'])} strings" in html
    assert "RMS 12.3 mm" in html and "999 vertices" in html
