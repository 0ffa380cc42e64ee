"""`airmat validate`: bad options exit 2 with one line and write nothing."""

import pytest

from airmat.cli import main


@pytest.mark.parametrize("args,words", [
    (["--l-over-L", "0.5,x"], "comma-separated numbers"),
    (["--l-over-L", "0.5,1.2"], "(0, 1)"),
    (["--resolution-mm", "100"], "(0, 75]"),
    (["--jobs", "0"], "--jobs must be at least 1"),
])
def test_bad_options_exit_2_with_one_line(tmp_path, capsys, args, words):
    out = tmp_path / "validate"
    assert main(["validate", "--out", str(out)] + args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert not out.exists()
