"""`airmat retie`: two designs of one mattress -> retie.json / .csv / .png; refusals exit 2 and write nothing."""

import csv
import json

import pytest

from airmat.cli import main

FAST = ["--spacing-mm", "40"]


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    root = tmp_path_factory.mktemp("retie")
    paths = {}
    for name, extra in (("a", []), ("b", ["--mu2-mm", "120"]), ("free", ["--tie-grid-mm", "0"])):
        paths[name] = root / name
        assert main(["design", "--preset", "vault1", *FAST, *extra, "--out", str(paths[name]), "-q"]) == 0
    return paths


def test_same_design_keeps_every_string(designs, tmp_path, capsys, wrote):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["a"]), "--out", str(out)]) == 0
    doc = json.loads((out / "retie.json").read_text())
    n = len(json.loads((designs["a"] / "design.json").read_text())["dashes"])
    assert doc["counts"] == {"keep": n, "retie": 0, "remove": 0, "add": 0}
    printed = capsys.readouterr().out
    assert f"keep {n} (same nodes)" in printed
    assert wrote(printed, out) == {p.name for p in out.iterdir()} == {"retie.json", "retie.csv", "retie.png"}


def test_two_shapes_account_for_every_string(designs, tmp_path):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["b"]), "--out", str(out)]) == 0
    doc = json.loads((out / "retie.json").read_text())
    na = len(json.loads((designs["a"] / "design.json").read_text())["dashes"])
    nb = len(json.loads((designs["b"] / "design.json").read_text())["dashes"])
    c = doc["counts"]
    assert c["keep"] + c["retie"] + c["remove"] == na and c["keep"] + c["retie"] + c["add"] == nb
    with open(out / "retie.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == sum(c.values())
    for r in rows:
        if r["action"] == "keep":
            assert r["nodes_a"] == r["nodes_b"] or r["nodes_a"].split("-")[::-1] == r["nodes_b"].split("-")
    assert (out / "retie.png").read_bytes()[:4] == b"\x89PNG"
    assert "NaN" not in (out / "retie.json").read_text()


def test_free_ends_are_refused_with_one_line(designs, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["retie", str(designs["a"]), str(designs["free"]), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--tie-grid-mm" in err[0]
    assert not out.exists() or not any(out.iterdir())
