"""The ``airmat`` command: one subcommand per workflow.

Each subcommand lives in its own module here with two functions,
``add_parser(subparsers)`` (which registers its arguments and sets
``func``) and ``run(args) -> int``. Modules import the numerical
libraries inside ``run`` so that ``airmat --help`` stays fast.
The CLI only parses arguments, calls the library, writes files and sets
the exit code: user errors (:class:`airmat.errors.InputError`) become exit
code 2 and one line on stderr.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from airmat import __version__
from airmat.errors import AirmatError, InputError
from airmat.progress import set_progress

__all__ = ["main", "build_parser"]

#: subcommand modules, in the order ``--help`` lists them
COMMANDS = ("synth", "fit", "calibrate", "design", "inflate", "retie", "validate", "gallery", "demo")

log = logging.getLogger("airmat")


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, like every other user error
        self.exit(2, f"airmat {self.prog.split()[-1]}: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="airmat", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"airmat {__version__}")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-v", "--verbose", action="count", default=0, help="debug log output")
    common.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors, no progress bars")
    common.add_argument("--seed", type=int, default=0, help="seed of every random step (default 0)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"airmat.cli.{name}")
        module.add_parser(sub, [common])
    return parser


def _configure_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else (logging.INFO if verbose == 0 else logging.DEBUG)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s: %(message)s" if verbose < 2
                                           else "%(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(level)
    # third-party chatter stays at warnings
    for noisy in ("matplotlib", "PIL", "trimesh", "numba", "fontTools", "ezdxf"):
        logging.getLogger(noisy).setLevel(logging.WARNING)


def main(argv: list[str] | None = None) -> int:
    """Run the ``airmat`` command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _configure_logging(args.verbose, args.quiet)
    set_progress(False if args.quiet else None)
    try:
        return int(args.func(args) or 0)
    except InputError as err:
        print(f"airmat {args.command}: {err.one_line()}", file=sys.stderr)
        return 2
    except AirmatError as err:  # solver failures: not the user's fault, but still one line
        print(f"airmat {args.command}: {err.one_line()}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"airmat {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        set_progress(None)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
