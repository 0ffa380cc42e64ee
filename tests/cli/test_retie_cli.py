"""`airmat retie`: two designs of one mattress -> the counts on screen, and with --out retie.json / .csv / .png
that agree with them; refusals exit 2 and write nothing; the design guide's example is a real run."""

import contextlib
import csv
import io
import json
import re
import shlex
import shutil
from pathlib import Path

import pytest

from airmat.cli import main
from airmat.design.retie import ACTIONS, LABELS

FAST = ["--spacing-mm", "40"]
GUIDE = Path(__file__).resolve().parents[2] / "docs" / "guide" / "design.md"


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    root = tmp_path_factory.mktemp("retie")
    paths = {}
    for name, extra in (("a", []), ("b", ["--mu2-mm", "120"]), ("free", ["--tie-grid-mm", "0"])):
        paths[name] = root / name
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            assert main(["design", "--preset", "vault1", *FAST, *extra, "--out", str(paths[name]), "-q"]) == 0
    paths["edited"] = _edited(paths["a"], root / "edited")
    return paths


def _edited(src, dst):
    """Design A with three hand-made changes to its design.json: string 0 five mm longer (re-cut +5.00),
    string 1 gone (remove), string 2's b end one grid row (20 mm) further along v (move 20.00 mm)."""
    shutil.copytree(src, dst)
    doc = json.loads((dst / "design.json").read_text())
    d0, d1, d2 = doc["dashes"][:3]
    for key in ("median", "lo95", "hi95"):
        d0["l_mm"][key] = round(d0["l_mm"][key] + 5.0, 2)
    d2["b_node"] = {**d2["b_node"], "row": d2["b_node"]["row"] + 1, "v_mm": d2["b_node"]["v_mm"] + 20.0}
    d2["b_mm"] = [d2["b_mm"][0], d2["b_mm"][1] + 20.0]
    d2["polyline_mm"] = [d2["a_mm"], d2["b_mm"]]
    doc["dashes"].remove(d1)
    (dst / "design.json").write_text(json.dumps(doc))
    return dst


def _read(out):
    doc = json.loads((out / "retie.json").read_text())
    with open(out / "retie.csv", newline="") as fh:
        return doc, list(csv.DictReader(fh))


def _printed_counts(line):
    """{action: count} from the summary line ('keep 3, re-cut 2, ...')."""
    return {a: int(re.search(rf"\b{re.escape(LABELS[a])} (\d+)", line).group(1)) for a in ACTIONS}


def test_same_design_keeps_every_string(designs, tmp_path, capsys, wrote):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["a"]), "--out", str(out)]) == 0
    doc = json.loads((out / "retie.json").read_text())
    n = len(json.loads((designs["a"] / "design.json").read_text())["dashes"])
    assert doc["counts"] == {"keep": n, "recut": 0, "move": 0, "remove": 0, "add": 0}
    assert doc["cut_tolerance_mm"] == 1.0
    printed = capsys.readouterr().out
    assert f"keep {n}, re-cut 0, move 0, remove 0, add 0 (cut tolerance 1 mm)" in printed
    assert wrote(printed, out) == {p.name for p in out.iterdir()} == {"retie.json", "retie.csv", "retie.png"}


def test_hand_made_changes_are_recut_move_and_remove(designs, tmp_path, capsys):
    a = json.loads((designs["a"] / "design.json").read_text())["dashes"]
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["edited"]), "--out", str(out)]) == 0
    doc, rows = _read(out)
    assert doc["counts"] == {"keep": len(a) - 3, "recut": 1, "move": 1, "remove": 1, "add": 0}
    step = {s["id_a"]: s for s in doc["steps"]}
    recut, move, gone = step[a[0]["id"]], step[a[2]["id"]], step[a[1]["id"]]
    assert recut["action"] == "recut" and recut["nodes_a"] == recut["nodes_b"]
    assert recut["dl_mm"] == pytest.approx(5.0, abs=0.011)    # lengths in design.json are to 0.01 mm
    assert recut["l_b_mm"] == pytest.approx(a[0]["l_mm"]["median"] + 5.0, abs=0.011)
    assert move["action"] == "move" and move["id_b"] == a[2]["id"] and move["move_mm"] == pytest.approx(20.0)
    assert gone["action"] == "remove" and gone["id_b"] is None and gone["dl_mm"] is None
    assert [r["action"] for r in rows][-3:] == ["recut", "move", "remove"]
    # the other way round: the removed string is added
    capsys.readouterr()
    assert main(["retie", str(designs["edited"]), str(designs["a"])]) == 0
    assert _printed_counts(capsys.readouterr().out) == {"keep": len(a) - 3, "recut": 1, "move": 1, "remove": 0,
                                                         "add": 1}


def test_a_wider_cut_tolerance_keeps_the_recut_string(designs, capsys):
    assert main(["retie", str(designs["a"]), str(designs["edited"]), "--cut-tolerance-mm", "5.5"]) == 0
    counts = _printed_counts(capsys.readouterr().out)
    assert counts["recut"] == 0 and counts["move"] == 1


def test_summary_csv_and_json_agree(designs, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["b"]), "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()[0]
    doc, rows = _read(out)
    na = len(json.loads((designs["a"] / "design.json").read_text())["dashes"])
    nb = len(json.loads((designs["b"] / "design.json").read_text())["dashes"])
    c = doc["counts"]
    assert printed.startswith(f"airmat retie: {na} strings -> {nb}: ")
    assert _printed_counts(printed) == c == {a: sum(r["action"] == a for r in rows) for a in ACTIONS}
    paired = c["keep"] + c["recut"] + c["move"]
    assert paired + c["remove"] == na and paired + c["add"] == nb
    assert [r["action"] for r in rows] == sorted((r["action"] for r in rows), key=ACTIONS.index)
    for r, s in zip(rows, doc["steps"]):
        assert {k: (v or None) for k, v in r.items()} == {k: (None if s[k] is None else
                                                              f"{s[k]:.2f}" if k.endswith("_mm") else s[k])
                                                          for k in r}
        if r["action"] in ("keep", "recut"):
            assert r["nodes_a"] == r["nodes_b"] and float(r["move_mm"]) == 0.0
            assert (abs(float(r["dl_mm"])) <= 1.0) == (r["action"] == "keep")
        if r["action"] == "move":
            assert r["nodes_a"] != r["nodes_b"]
    assert (out / "retie.png").read_bytes()[:4] == b"\x89PNG"
    assert "NaN" not in (out / "retie.json").read_text()


def test_without_out_the_counts_are_printed_and_nothing_written(designs, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = {p: p.stat().st_mtime_ns for d in ("a", "b") for p in designs[d].iterdir()}
    assert main(["retie", str(designs["a"]), str(designs["b"]), "--seed", "7"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("airmat retie: ") and "wrote" not in out and "--seed is ignored" in out
    assert list(tmp_path.iterdir()) == []
    assert {p: p.stat().st_mtime_ns for d in ("a", "b") for p in designs[d].iterdir()} == before


@pytest.mark.parametrize("argv,words", [
    (["free"], "--tie-grid-mm"),
    (["b", "--cut-tolerance-mm", "-1"], "--cut-tolerance-mm"),
    (["b", "--cut-tolerance-mm", "nan"], "--cut-tolerance-mm"),
])
def test_refusals_exit_2_with_one_line_and_write_nothing(designs, tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs[argv[0]]), *argv[1:], "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]
    assert not out.exists() or not any(out.iterdir())


def _guide_example():
    """The design guide's retie example: its commands, the printed lines and the CSV rows it shows."""
    text = GUIDE.read_text(encoding="utf-8").split("## Re-tying between two designs", 1)[1]
    blocks = re.findall(r"```(\w+)\n(.*?)```", text, re.S)
    commands = [ln for ln in blocks[0][1].splitlines() if ln.startswith("airmat ")]
    return commands, blocks[1][1].splitlines(), blocks[2][1].splitlines()


@pytest.mark.slow  # two full-resolution designs: about 15 s
def test_the_design_guide_example_is_a_real_run(tmp_path, monkeypatch):
    commands, printed, csv_rows = _guide_example()
    assert [c.split()[1] for c in commands] == ["design", "design", "retie"]
    monkeypatch.chdir(tmp_path)
    for cmd in commands[:-1]:
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(shlex.split(cmd)[1:] + ["-q"]) == 0
    with contextlib.redirect_stdout(io.StringIO()) as buf:
        assert main(shlex.split(commands[-1])[1:]) == 0
    assert buf.getvalue().splitlines() == printed
    out = Path(shlex.split(commands[-1])[-1])
    real = (tmp_path / out / "retie.csv").read_text().splitlines()
    assert csv_rows[0] == real[0] and set(csv_rows[1:]) <= set(real[1:])
    assert re.search(rf"among its {len(real) - 1} rows", GUIDE.read_text(encoding="utf-8"))
