"""One command-line vocabulary: the output folder rule, one option name per quantity (the old names hidden,
with a note), `check` with its other name `inflate`, units in every option's help, `presets` and `info`."""

import argparse
import json

import pytest

from airmat.cli import COMMANDS, build_parser, main

#: old name -> (command, new name, an argument list with the old name, destination, parsed value)
ALIASES = {
    "--d-mm": ("synth", "--thickness-mm", ["--d-mm", "60"], "thickness_mm", 60.0),
    "--spacing-mm": ("design", "--resolution-mm", ["--preset", "vault1", "--spacing-mm", "40"], "resolution_mm", 40.0),
    "--units": ("design", "--target-units", ["t.obj", "--units", "m"], "target_units", "m"),
}


def _subparsers():
    parser = build_parser()
    return parser, parser.commands


def _visible(p):
    return [a for a in p._actions if a.help is not argparse.SUPPRESS]


def test_every_command_writes_to_an_optional_out_defaulting_to_out_command():
    _, commands = _subparsers()
    writers = {name: p for name, p in commands.items() if any("--out" in a.option_strings for a in p._actions)}
    assert {"synth", "calibrate", "design", "refine", "check", "validate", "gallery", "demo"} <= set(writers)
    for name, p in writers.items():
        out = next(a for a in p._actions if "--out" in a.option_strings)
        assert not out.required and out.metavar == "DIR", name
        if name in ("synth", "retie", "export", "report"):  # resolved by the command (synth: its old positional
            # form; retie: counts on screen without it; export, report: into the folder they read)
            continue
        canonical = "check" if name == "inflate" else name
        assert out.default == f"out/{canonical}", name
        assert f"(default out/{canonical})" in out.help, name


def test_the_default_out_folders_parse():
    parser, _ = _subparsers()
    assert parser.parse_args(["design", "--preset", "vault1"]).out == "out/design"
    assert parser.parse_args(["calibrate", "m.csv"]).out == "out/calibrate"
    assert parser.parse_args(["refine", "D"]).out == "out/refine"
    assert parser.parse_args(["check", "D"]).out == "out/check"
    assert parser.parse_args(["inflate", "D"]).out == "out/check"


def test_synth_takes_out_its_old_positional_or_the_default():
    from airmat.cli._vocabulary import notes
    from airmat.cli.synth import output_folder
    from airmat.errors import InputError

    parser, _ = _subparsers()
    args = parser.parse_args(["synth", "--out", "S"])
    assert output_folder(args) == "S" and notes(args) == []
    args = parser.parse_args(["synth", "S"])
    assert output_folder(args) == "S"
    assert notes(args) == ["airmat synth: the positional OUTDIR is deprecated, use --out S"]
    assert output_folder(parser.parse_args(["synth"])) == "out/synth"
    with pytest.raises(InputError, match="give the output folder once"):
        output_folder(parser.parse_args(["synth", "A", "--out", "B"]))


@pytest.mark.parametrize("old", sorted(ALIASES))
def test_an_old_option_name_sets_the_new_one_with_a_note_and_is_hidden(old):
    from airmat.cli._vocabulary import notes

    command, new, argv, dest, value = ALIASES[old]
    parser, commands = _subparsers()
    args = parser.parse_args([command, *argv])
    assert getattr(args, dest) == value
    assert notes(args) == [f"airmat {command}: {old} is deprecated, use {new}"]
    new_args = parser.parse_args([command, *[new if a == old else a for a in argv]])
    assert getattr(new_args, dest) == value and notes(new_args) == []
    text = commands[command].format_help()
    assert new in text and old not in text


def test_one_name_per_quantity_across_commands():
    """No visible option keeps an old name, and an option name means one destination in every command."""
    _, commands = _subparsers()
    dest_of = {}
    for name, p in commands.items():
        for action in _visible(p):
            for opt in action.option_strings:
                assert opt not in ALIASES, (name, opt)
                dest_of.setdefault(opt, set()).add(action.dest)
    assert all(len(d) == 1 for d in dest_of.values()), {k: v for k, v in dest_of.items() if len(v) > 1}
    for opt in ("--thickness-mm", "--resolution-mm", "--L-mm", "--out", "--calibration"):
        assert opt in dest_of


def test_every_option_help_names_its_unit_and_says_s_hat_one_way():
    parser, commands = _subparsers()
    units = {"_mm": "mm", "_per_m": "1/m", "_pa": "Pa"}
    for name, p in commands.items():
        for action in _visible(p):
            text = action.help or ""
            assert "S-hat" not in text, (name, action.dest)
            for suffix, unit in units.items():
                if action.dest.endswith(suffix):
                    assert unit in text, (name, action.dest, text)
    assert "S-hat" not in parser.format_help()


def test_check_is_the_command_and_inflate_its_other_name(capsys):
    parser, commands = _subparsers()
    assert parser.parse_args(["check", "D"]).func is parser.parse_args(["inflate", "D"]).func
    assert commands["check"] is commands["inflate"]
    assert parser.parse_args(["inflate", "D"]).command == "inflate"   # the stderr lines name what was typed
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "check (inflate)" in out and "airmat check D --out I" in out and "airmat inflate" not in out


def test_a_note_is_printed_when_the_run_succeeds_and_a_failure_keeps_its_one_line(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "s"), "--points", "10000", "--l-over-L", "0.5,0.7,0.9", "--d-mm", "60",
                 "-q"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == ["airmat synth: --d-mm is deprecated, use --thickness-mm",
                   f"airmat synth: the positional OUTDIR is deprecated, use --out {tmp_path / 's'}"]
    assert json.loads((tmp_path / "s" / "truth.json").read_text())["d_mm"] == 60
    assert main(["synth", "--out", str(tmp_path / "t"), "--d-mm", "1e6", "-q"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["airmat synth: --thickness-mm: 1e+06 mm is outside [10, 500] mm"]


def test_presets_lists_every_preset_with_its_sizes(capsys):
    from airmat.cli.presets import DESCRIPTIONS
    from airmat.design.presets import PRESETS

    assert tuple(DESCRIPTIONS) == PRESETS
    assert main(["presets"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("name") and "mattress W x H x thickness (mm)" in out[0]
    rows = {line.split()[0]: line for line in out[1:len(PRESETS) + 1]}
    assert list(rows) == list(PRESETS)
    assert rows["vault1"].split("  ")[1].strip() == "830 x 740 x 70"
    assert "2600 x 1600 x 70" in rows["roof"]


def _write(path, doc):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc))


CAL = {"parameters": {"delta_mm": {"median": 17.4, "lo95": 16.8, "hi95": 18.4},
                      "d_mm": {"median": 73.2, "lo95": 68.5, "hi95": 76.7},
                      "sigma_per_m": {"median": 0.01, "lo95": 0.0, "hi95": 0.05}},
       "specimens": [{"scan": "a.ply", "fit_converged": True}] * 4, "manifest": "set/manifest.csv",
       "diagnostics": {"converged": True, "n_steps": 900}}
DESIGN = {"name": "vault1", "uncalibrated": True, "mattress": {"width_mm": 830, "height_mm": 740, "thickness_mm": 70},
          "report": {"constructible": True, "reasons": []},
          "summary": {"strings": {"top": {"k1": 0, "k2": 0}, "bottom": {"k1": 21, "k2": 20}}},
          "relaxation": {"converged": True}}
REFINE = {"converged": True, "iterations": 14, "resolution_mm": 20.0,
          "deviation_before": {"rms_mm": 12.9, "max_mm": 30.0, "rms_pct_diag": 1.27},
          "deviation_after": {"rms_mm": 7.4, "max_mm": 20.0, "rms_pct_diag": 0.73}}
CHECK = {"design": "out/design", "resolution_mm": 20.0, "mesh_vertices": 5000, "dashes": [{}] * 41,
         "deviation": {"rms_mm": 7.4, "max_mm": 21.0, "rms_pct_diag": 0.73, "surface": "bottom"},
         "envelope": {"lo95": {"rms_mm": 7.7, "max_mm": 22.0, "rms_pct_diag": 0.76}}, "converged": False}


def test_info_names_each_kind_of_folder_with_its_numbers_and_verdict(tmp_path, capsys):
    _write(tmp_path / "cal" / "calibration.json", CAL)
    _write(tmp_path / "design" / "design.json", DESIGN)
    _write(tmp_path / "refined" / "design.json", {**DESIGN, "refine": REFINE})
    _write(tmp_path / "check" / "inflate.json", CHECK)
    (tmp_path / "set").mkdir()
    (tmp_path / "set" / "manifest.csv").write_text("scan,l_mm,L_mm\na.ply,100,300\nb.ply,200,300\n")

    def info(name):
        assert main(["info", str(tmp_path / name)]) == 0
        return capsys.readouterr().out

    out = info("cal")
    assert "calibration (calibration.json)" in out and "Δ = 17.4 mm [16.8, 18.4]" in out
    assert "d = 73.2 mm" in out and "MCMC converged: yes" in out
    out = info("design")
    assert ": design (design.json)" in out and "830 x 740 x 70 mm" in out and "UNCALIBRATED" in out
    assert "41 strings" in out and "verdict: constructible: yes; converged: yes" in out
    out = info("refined")
    assert "refined design" in out and "1.27 % of the diagonal" in out
    assert "deviation 0.73 % of the diagonal (simulated); converged: yes" in out
    out = info("check")
    assert "check (inflate.json)" in out and "bottom face from Ŝ: 0.73 % of the diagonal (RMS 7.4 mm" in out
    assert "verdict: deviation 0.73 % of the diagonal; converged: NO" in out
    assert "2 specimen scans" in info("set")
    out = info(".")                       # a folder of output folders (demo's): each one
    assert "5 output folders" in out and out.count("verdict:") == 4


@pytest.mark.parametrize("case", ["missing", "file", "empty", "bad_json"])
def test_info_refuses_what_is_no_output_folder_in_one_line(tmp_path, capsys, case):
    path = tmp_path / "x"
    if case == "file":
        _write(path / "design.json", DESIGN)
        path = path / "design.json"
    elif case == "empty":
        path.mkdir()
    elif case == "bad_json":
        path.mkdir()
        (path / "design.json").write_text("{not json")
    assert main(["info", str(path)]) == 2
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert cap.out == "" and len(lines) == 1 and lines[0].startswith(f"airmat info: {path}")
    assert {"missing": "no such folder", "file": "give the folder that holds it", "empty": "holds no output",
            "bad_json": "cannot read"}[case] in lines[0]


def test_every_command_is_registered():
    _, commands = _subparsers()
    assert {"presets", "info", "check"} <= set(commands) and {"presets", "info"} <= set(COMMANDS)
