"""`airmat inflate`: files and fields on a small design folder; bad input exits 2 and writes nothing."""

import json

import numpy as np
import pytest

from airmat.cli import main
from design.mattress import Mattress, triangulate_mattress
from design.surface_io import write_approx_surface


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


def test_inflate_writes_files_with_the_fields(tmp_path, capsys):
    design = make_design(tmp_path / "design")
    out = tmp_path / "out"
    assert main(["inflate", str(design), "--out", str(out), "--resolution-mm", "50"]) == 0
    doc = json.loads((out / "inflate.json").read_text())
    assert set(doc["deviation"]) >= {"rms_mm", "max_mm", "rms_pct_diag"}
    assert set(doc["envelope"]) == {"lo95", "hi95"}
    for run in doc["envelope"].values():
        assert set(run) >= {"rms_mm", "max_mm"}
    assert doc["solver"]["converged"] is True
    assert set(doc["solver"]) >= {"converged", "iterations", "residual", "seconds"}
    assert [d["id"] for d in doc["dashes"]] == ["k1-001-01", "k1-002-01"]
    # top strings bend toward the top face: negative curvature, shorter strings (lo95) bend more
    kap = np.array([d["kappa_realized_per_m"] for d in doc["dashes"]])
    lo = np.array([d["kappa_realized_lo95_per_m"] for d in doc["dashes"]])
    assert np.all(kap < 0) and np.all(lo < kap)
    assert (out / "inflated.ply").stat().st_size > 0 and (out / "deviation.png").stat().st_size > 0
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Inflation check" in page and "k1-002-01" in page and "did NOT converge" not in page
    assert "deviation from S-hat" in capsys.readouterr().out


@pytest.mark.parametrize("case,words", [
    ("missing_folder", "not found"),
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
        return {k: _without_times(v) for k, v in doc.items() if "seconds" not in k}
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

