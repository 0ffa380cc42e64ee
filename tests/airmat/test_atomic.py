"""Atomic outputs: a failed run leaves nothing behind and overwrites nothing good."""

import pytest

from airmat.atomic import atomic_write_text, staged_dir


def test_staged_dir_publishes_on_success(tmp_path):
    out = tmp_path / "out"
    with staged_dir(out) as tmp:
        (tmp / "a.json").write_text("{}")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "b.csv").write_text("x\n")
        assert not out.exists()  # nothing visible before success
    assert (out / "a.json").read_text() == "{}"
    assert (out / "sub" / "b.csv").read_text() == "x\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # staging folder removed


def test_staged_dir_failure_keeps_previous_output(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.json").write_text("good")
    with pytest.raises(RuntimeError):
        with staged_dir(out) as tmp:
            (tmp / "a.json").write_text("half")
            (tmp / "new.png").write_bytes(b"\x89PNG")
            raise RuntimeError("boom")
    assert (out / "a.json").read_text() == "good"
    assert sorted(p.name for p in out.iterdir()) == ["a.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_failure_on_fresh_output_creates_nothing(tmp_path):
    out = tmp_path / "fresh"
    with pytest.raises(ValueError):
        with staged_dir(out) as tmp:
            (tmp / "x").write_text("1")
            raise ValueError
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_text_replaces_whole_file(tmp_path):
    p = tmp_path / "f.txt"
    atomic_write_text(p, "one")
    atomic_write_text(p, "two")
    assert p.read_text() == "two"
    assert [q.name for q in tmp_path.iterdir()] == ["f.txt"]


def test_outputs_are_ordinary_readable_files(tmp_path):
    import os
    import stat
    p = tmp_path / "f.txt"
    atomic_write_text(p, "x")
    with staged_dir(tmp_path / "out") as tmp:
        (tmp / "g.txt").write_text("y")
    for f in (p, tmp_path / "out" / "g.txt"):
        assert os.stat(f).st_mode & stat.S_IROTH
