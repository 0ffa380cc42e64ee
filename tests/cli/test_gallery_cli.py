"""`airmat gallery`: designs and inflates presets into one Table-1-style table."""

import contextlib
import io
import json

import pytest

from airmat.cli import main


def test_gallery_row_matches_the_design_and_inflation_files(tmp_path):
    with contextlib.redirect_stdout(io.StringIO()) as stdout:
        assert main(["gallery", "--presets", "saddle", "--resolution-mm", "60", "--out", str(tmp_path), "-q"]) == 0
    table = (tmp_path / "gallery.md").read_text().splitlines()
    assert len(table) == 3 and table[2].startswith("| small | saddle |")
    # stdout is the same table, header first, then where the files went
    printed = stdout.getvalue().splitlines()
    assert printed[:3] == table and printed[3] == "" and printed[4].startswith("wrote ") and len(printed) == 5
    assert printed[4].endswith(f"each preset's design and inflate folders under {tmp_path} (saddle)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gallery.json", "gallery.md", "saddle"]
    design = json.loads((tmp_path / "saddle" / "design" / "design.json").read_text())
    inflate = json.loads((tmp_path / "saddle" / "inflate" / "inflate.json").read_text())
    cells = [c.strip() for c in table[2].strip("|").split("|")]
    assert cells[5] == str(len(design["dashes"]))
    rms, mx = (float(v) for v in cells[7].split("//"))
    assert rms == round(inflate["deviation"]["rms_mm"], 1) and mx == round(inflate["deviation"]["max_mm"], 1)
    assert 0 < rms < mx                                  # a real, non-zero deviation
    assert inflate["solver"]["converged"] is True


def test_gallery_refine_checks_the_refined_lengths(tmp_path):
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(["gallery", "--presets", "saddle", "--resolution-mm", "60", "--refine", "--out", str(tmp_path),
                     "-q"])
    assert code in (0, 3)                         # 3: the refinement ran out of iterations (said on stderr)
    head, _, row = (tmp_path / "gallery.md").read_text().splitlines()
    names = [c.strip() for c in head.strip("|").split("|")]
    cells = dict(zip(names, (c.strip() for c in row.strip("|").split("|"))))
    ref = json.loads((tmp_path / "gallery.json").read_text())["saddle"]["refine"]
    design = json.loads((tmp_path / "saddle" / "design" / "design.json").read_text())
    inflate = json.loads((tmp_path / "saddle" / "inflate" / "inflate.json").read_text())
    # design.json's block also keeps the open-loop strings its inflations start from; the gallery's does not
    assert len(design["refine"].pop("open_loop_dashes")) == len(design["dashes"])
    assert design["refine"] == ref and (code == 0) is ref["converged"]
    assert float(cells["open loop RMS % diag"]) == round(ref["deviation_before"]["rms_pct_diag"], 2)
    assert float(cells["RMS % diag"]) == round(inflate["deviation"]["rms_pct_diag"], 2)
    assert inflate["deviation"]["rms_mm"] == pytest.approx(ref["deviation_after"]["rms_mm"], abs=0.011)
    assert ref["deviation_after"]["rms_mm"] < ref["deviation_before"]["rms_mm"]
    assert cells["refine iterations"].split()[0] == str(ref["iterations"])


def test_unknown_preset_exits_2_with_one_line(tmp_path, capsys):
    assert main(["gallery", "--presets", "vault1,tent", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tent" in err[0]
    assert not (tmp_path / "gallery.md").exists()


def test_gallery_lists_every_preset_the_generator_has():
    from airmat.cli.gallery import PRESETS as GALLERY
    from airmat.design.presets import PRESETS

    assert GALLERY == PRESETS
