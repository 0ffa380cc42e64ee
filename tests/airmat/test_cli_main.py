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
    assert len(err) == 1 and err[0].startswith("airmat fit: ") and "no-such-option" in err[0]


def test_a_missing_or_unknown_subcommand_is_named_once(capsys):
    for argv in ([], ["nosuch"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("airmat: ") and "COMMAND" in err[0]


def test_the_help_examples_parse_and_the_exit_codes_are_the_real_ones(capsys):
    """Every `airmat ...` line of `airmat --help`'s epilog is a valid command line, and the exit codes it
    lists are the ones the commands return."""
    from airmat.cli import EPILOG, build_parser
    from airmat.cli._exit import BAD_INPUT, FAILED, INTERRUPTED, NOT_CONVERGED, OK

    with pytest.raises(SystemExit):
        main(["--help"])
    assert EPILOG.splitlines()[-1] in capsys.readouterr().out
    examples = [ln.split("#")[0].split()[1:] for ln in EPILOG.splitlines() if ln.strip().startswith("airmat ")]
    assert len(examples) == 6
    parser = build_parser()
    for argv in examples:
        args = parser.parse_args(argv)            # exits 2 on a line that does not parse
        assert args.command == argv[0]
    text = " ".join(EPILOG.split())
    for code, words in ((OK, "done"), (FAILED, "a solver failed outright"), (BAD_INPUT, "bad input"),
                        (NOT_CONVERGED, "a solver did not converge"), (INTERRUPTED, "interrupted")):
        assert f"{code} {words}" in text
