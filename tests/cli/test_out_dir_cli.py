"""Every subcommand checks its output folder before computing anything: exit 2, one line, nothing touched.

Each case also carries a second bad argument that the command would only
notice later (a missing input, a bad option): the error must still be the
one about ``--out``, which shows the check comes first.
"""

import pytest

from airmat.cli import main

# (command line with OUT for the output folder, a later mistake on it)
COMMANDS = {
    "synth": ["synth", "OUT", "--l-over-L", "x"],
    "calibrate": ["calibrate", "missing/manifest.csv", "--out", "OUT"],
    "design": ["design", "missing.obj", "--mattress", "830x740", "--out", "OUT"],
    "inflate": ["inflate", "missing_design", "--out", "OUT"],
    "validate": ["validate", "--out", "OUT", "--l-over-L", "2"],
    "demo": ["demo", "--out", "OUT", "--points", "-1"],
    "gallery": ["gallery", "--out", "OUT", "--presets", "nope"],
}


def _run(argv, out, capsys):
    code = main([str(out) if a == "OUT" else a for a in argv] + ["-q"])
    cap = capsys.readouterr()
    return code, cap.err


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_out_that_is_a_file(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "result.txt"
    out.write_text("keep me")
    code, err = _run(COMMANDS[command], out, capsys)
    assert code == 2
    assert err == f"airmat {command}: {out}: exists and is not a folder; give a folder for the output\n"
    assert out.read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.txt"]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_out_below_a_file(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "f").write_text("keep me")
    out = tmp_path / "f" / "run"
    code, err = _run(COMMANDS[command], out, capsys)
    assert code == 2
    assert err == f"airmat {command}: {out}: cannot create the folder: {tmp_path / 'f'} is a file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_out_may_not_hold_an_input(tmp_path, capsys):
    design = tmp_path / "design"
    design.mkdir()
    (design / "design.json").write_text("{}")
    code, err = _run(["inflate", str(design), "--out", "OUT"], design, capsys)
    assert code == 2
    assert err.startswith(f"airmat inflate: {design}: holds the input {design};") and err.count("\n") == 1
    code, err = _run(["calibrate", str(design / "design.json"), "--out", "OUT"], design, capsys)
    assert code == 2 and err.count("\n") == 1 and "holds the input" in err
    assert [p.name for p in design.iterdir()] == ["design.json"]


def test_out_may_not_be_the_working_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.txt").write_text("keep me")
    code, err = _run(["synth", "OUT", "--points", "10000"], ".", capsys)
    assert code == 2
    assert err.startswith("airmat synth: .: is the working folder or contains it;") and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]
