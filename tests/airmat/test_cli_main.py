"""The `airmat` dispatcher: help for every subcommand, usage errors exit 2 in one line."""

import pytest

from airmat.cli import COMMANDS, main


def test_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


@pytest.mark.parametrize("name", COMMANDS)
def test_each_subcommand_has_help_with_common_options(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for opt in ("--seed", "-v", "-q"):
        assert opt in out


def test_unknown_option_is_a_one_line_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fit", "scan.ply", "--no-such-option"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no-such-option" in err[0]
