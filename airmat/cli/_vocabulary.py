"""The vocabulary every subcommand shares: the output folder rule and the deprecated spellings.

Output folder
    Every command that writes files takes ``--out DIR``, optional, by default
    ``out/<command>`` under the working folder (``out/synth``, ``out/design``,
    ``out/check``, ...): :func:`add_out_argument`. ``synth``'s positional
    ``OUTDIR`` is still accepted (its old form).

One name per quantity
    A quantity has one option name in every command (``--thickness-mm``,
    ``--resolution-mm``, ``--scan-units``/``--target-units``, ...). The old names
    stay accepted as hidden options with the new one's destination
    (:func:`deprecated_alias`); each use leaves one note, which the command prints
    on stderr when it succeeds (:func:`notes`): a run that fails or does not
    converge keeps its one stderr line.

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(prog="airmat design")
>>> _ = p.add_argument("--resolution-mm", type=float, default=20.0, help="mesh edge length (mm)")
>>> deprecated_alias(p, "--spacing-mm", "--resolution-mm")
>>> args = p.parse_args(["--spacing-mm", "40"])
>>> args.resolution_mm, notes(args)
(40.0, ['airmat design: --spacing-mm is deprecated, use --resolution-mm'])
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["OUT_ROOT", "default_out", "add_out_argument", "deprecated_alias", "add_note", "notes", "print_notes"]

#: the folder under which every command writes by default (``out/<command>``)
OUT_ROOT = "out"

_NOTES = "_airmat_notes"


def default_out(command: str) -> str:
    """The default output folder of ``command``: ``out/<command>``."""
    return f"{OUT_ROOT}/{command}"


def add_out_argument(p, command: str, files: str, *, default: bool = True) -> None:
    """Register ``--out DIR``: optional, default ``out/<command>`` (``default=False``: None, resolved by the
    command itself, as ``synth`` does with its old positional form)."""
    p.add_argument("--out", metavar="DIR", default=default_out(command) if default else None,
                   help=f"output folder: {files} (default {default_out(command)})")


def add_note(args, text: str) -> None:
    """Keep one note (a deprecation) for stderr, printed when the command succeeds."""
    if getattr(args, _NOTES, None) is None:
        setattr(args, _NOTES, [])
    getattr(args, _NOTES).append(text)


def notes(args) -> list[str]:
    """The notes the parse and the run left on ``args``."""
    return list(getattr(args, _NOTES, None) or [])


def print_notes(args) -> None:
    """Print each note on its own stderr line."""
    for text in notes(args):
        print(text, file=sys.stderr, flush=True)


class _Deprecated(argparse.Action):
    """An old option name: stores into the new option's destination and leaves a note."""

    def __init__(self, option_strings, dest, *, new: str, store_const=False, **kwargs):
        self.new = new
        self.store_const = store_const
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, self.const if self.store_const else values)
        add_note(namespace, f"{parser.prog}: {option_string} is deprecated, use {self.new}")


def deprecated_alias(p, old: str, new: str) -> None:
    """Accept ``old`` as a hidden spelling of the registered option ``new`` (same destination, type
    and choices); its use leaves the note "``old`` is deprecated, use ``new``"."""
    target = next(a for a in p._actions if new in a.option_strings)
    flag = target.nargs == 0
    p.add_argument(old, action=_Deprecated, new=new, dest=target.dest, default=argparse.SUPPRESS,
                   help=argparse.SUPPRESS,
                   **({"nargs": 0, "const": target.const, "store_const": True} if flag else
                      {"type": target.type, "choices": target.choices, "metavar": target.metavar}))
