"""The ``airmat`` command: one subcommand per workflow.

Each subcommand lives in its own module here with two functions,
``add_parser(subparsers)`` (which registers its arguments and sets
``func``) and ``run(args) -> int``. Modules import the numerical
libraries inside ``run`` so that ``airmat --help`` stays fast.
The CLI only parses arguments, calls the library, writes files and sets
the exit code (:mod:`airmat.cli._exit`): user errors
(:class:`airmat.errors.InputError`) become exit code 2 and one line on
stderr; a solver that did not converge, exit code 3 with the results
written; Ctrl-C, one line and exit code 130 (:mod:`airmat.cli.sigint`).
"""

from __future__ import annotations

from airmat.cli import sigint

sigint.install()  # before anything else, standard library included: Ctrl-C works from the first instant

# C's decimal module (scipy.optimize imports it, seconds into a command) cannot initialize twice: a Ctrl-C during
# its first import left a second one printing a libmpdec warning on stderr before the "interrupted" line.
# Imported here, its import is over in the first milliseconds.
import decimal  # noqa: E402,F401
import argparse  # noqa: E402
import importlib  # noqa: E402
import logging  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402

from airmat import __version__  # noqa: E402
from airmat.cli._exit import BAD_INPUT, FAILED, INTERRUPTED, NOT_CONVERGED, OK  # noqa: E402
from airmat.errors import AirmatError, InputError  # noqa: E402
from airmat.progress import set_progress  # noqa: E402

__all__ = ["main", "build_parser"]

#: subcommand modules, in the order ``--help`` lists them
COMMANDS = ("synth", "synth-built", "correct", "fit", "calibrate", "plan", "design", "refine", "inflate", "retie", "export",
            "report", "validate", "gallery", "demo", "presets", "info")

log = logging.getLogger("airmat")

#: what ``airmat --help`` says above the subcommands (plain text: the module docstring is for developers)
DESCRIPTION = ("Tension-string patterns that inflate a flat drop-stitch mattress into a curved\n"
               "shell (Todo et al., IASS 2024): calibrate, design, check.")

#: what ``airmat --help`` says below them
EPILOG = f"""\
the usual order:
  airmat synth --out S                                 # or your own scans and a manifest.csv
  airmat calibrate S/manifest.csv --out C              # Equation 3's Δ and d, with their posterior
  airmat design --preset vault1 --calibration C --out D --refine    # 'airmat presets' lists them
  airmat check D --out I                               # how far the inflated mattress lands from Ŝ
  airmat info I                                        # what a folder holds: key numbers, verdict
  airmat demo                                          # all of it on synthetic data

Every command that writes files writes one folder, --out DIR (default out/COMMAND); old option
names still work, with a note on stderr.

Lengths are in mm in every file and option, curvature in 1/m. `airmat COMMAND --help` lists a
command's options. Exit codes: {OK} done; {FAILED} a solver failed outright, nothing written; {BAD_INPUT} bad
input, one line on stderr, nothing written; {NOT_CONVERGED} a solver did not converge, results written and
the reason on stderr; {INTERRUPTED} interrupted, nothing written."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, like every other user error
        self.exit(2, f"{' '.join(self.prog.split()[:2])}: {message}\n")   # "airmat" or "airmat design"

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but an unknown option is refused by its subcommand's parser, so that the
        line names the subcommand (``airmat design: unrecognized arguments: --x``), as every other
        error of that subcommand does. A command called by its other name (``inflate`` for ``check``)
        is named as it was called, in its usage and error lines."""
        commands = getattr(self, "commands", {})
        typed = next((w for w in (sys.argv[1:] if args is None else args) if w in commands), None)
        if typed is not None:
            commands[typed].prog = f"{self.prog} {typed}"
        namespace, extra = self.parse_known_args(args, namespace)
        if extra:
            sub = getattr(self, "commands", {}).get(getattr(namespace, "command", None), self)
            sub.error(f"unrecognized arguments: {' '.join(extra)}")
        return namespace


def seed(text: str) -> int:
    """The ``--seed`` value: an integer in [0, 2**32), as numpy's generators take (else exit 2)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2**32), got {text!r}") from None
    if not 0 <= value < 2 ** 32:
        raise argparse.ArgumentTypeError(f"must be in [0, 2**32), got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="airmat", description=DESCRIPTION, epilog=EPILOG,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"airmat {__version__}")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-v", "--verbose", action="count", default=0,
                        help="log warnings and progress on stderr (-vv: debug); by default stderr holds only "
                             "the one line of an error or of a run that did not converge")
    common.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    common.add_argument("--seed", type=seed, default=0,
                        help="seed of every random step: an integer in [0, 2**32) (default 0)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    parser.commands = sub.choices     # name -> the subcommand's parser (its own error line)
    for name in COMMANDS:
        module = importlib.import_module(f"airmat.cli.{name.replace('-', '_')}")   # synth-built: synth_built.py
        module.add_parser(sub, [common])
    return parser


def _configure_logging(verbose: int, quiet: bool) -> None:
    """Log records of WARNING and above still reach the loggers' other handlers (tests' caplog);
    stderr shows them only at ``-v``: by default the one error or "not converged" line stands alone,
    and what the warnings said is in that line and in the results' JSON (``converged``, ``message``)."""
    level = logging.WARNING if verbose == 0 else (logging.INFO if verbose == 1 else logging.DEBUG)
    handler = logging.StreamHandler(sys.stderr)
    handler.setLevel(logging.CRITICAL + 1 if verbose == 0 else level)
    handler.setFormatter(logging.Formatter("%(levelname)s: %(message)s" if verbose < 2
                                           else "%(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [h for h in root.handlers if not _is_ours(h)] + [handler]
    handler._airmat_cli = True
    root.setLevel(level)
    # third-party chatter stays at warnings
    for noisy in ("matplotlib", "PIL", "trimesh", "numba", "fontTools", "ezdxf"):
        logging.getLogger(noisy).setLevel(logging.WARNING)


def _is_ours(handler) -> bool:
    return getattr(handler, "_airmat_cli", False)


def main(argv: list[str] | None = None) -> int:
    """Run the ``airmat`` command line; returns the exit code (:mod:`airmat.cli._exit`)."""
    sigint.install()
    return _exit_code(_main(argv), as_command=argv is None)


def _main(argv):
    words = sys.argv[1:] if argv is None else argv
    command = next((f"airmat {w}" for w in words if w in COMMANDS), "airmat")  # until the parser knows
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        command = f"airmat {args.command}"
        _configure_logging(args.verbose, args.quiet)
        set_progress(False if args.quiet else None)
        code = int(args.func(args) or 0)
        if code == OK:      # deprecated spellings: one note each; a failed run keeps its one stderr line
            from airmat.cli._vocabulary import print_notes

            print_notes(args)
        return code
    except InputError as err:
        print(f"{command}: {err.one_line()}", file=sys.stderr)
        return BAD_INPUT
    except AirmatError as err:  # solver failures: not the user's fault, but still one line
        if sigint.interrupted():
            return _interrupted(command)
        print(f"{command}: {err.one_line()}", file=sys.stderr)
        return FAILED
    except KeyboardInterrupt:
        return _interrupted(command)
    except Exception:
        if sigint.interrupted():  # a library turned the interrupt into another error
            return _interrupted(command)
        raise
    finally:
        set_progress(None)


def _interrupted(command: str) -> int:
    sigint.ignore()  # a second Ctrl-C does not interrupt the report
    print(f"{command}: interrupted", file=sys.stderr, flush=True)
    return INTERRUPTED


def _exit_code(code: int, as_command: bool) -> int:
    """``code``; run as the command, an interrupt ends the process here with 130.

    CPython remembers a KeyboardInterrupt that went through a nested
    ``PyRun_*`` call (some extension modules run code that way while they are
    imported) and, at exit, kills itself with SIGINT even though the
    interrupt was handled: the exit status would be -2, not 130.
    """
    if as_command and code == INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(INTERRUPTED)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
