"""Exit codes of the ``airmat`` command, and the one "not converged" policy of every subcommand.

======  =====================================================================
code    meaning
======  =====================================================================
0       success: every solver converged, results written
1       a solver failed outright (diverged); nothing written
2       bad input (a file, an option or a combination); nothing written
3       results written, but a solver did not converge (``converged: false``
        in the JSON; one stderr line says what): kept for inspection
130     interrupted (Ctrl-C / SIGINT); nothing written
======  =====================================================================
"""

from __future__ import annotations

import sys

__all__ = ["OK", "FAILED", "BAD_INPUT", "NOT_CONVERGED", "INTERRUPTED", "not_converged"]

OK, FAILED, BAD_INPUT, NOT_CONVERGED, INTERRUPTED = 0, 1, 2, 3, 130


def not_converged(command: str, what: list[str]) -> int:
    """Report what did not converge on one stderr line; the exit code (0 if ``what`` is empty, else 3)."""
    if not what:
        return OK
    print(f"airmat {command}: not converged: {'; '.join(what)} (results written, exit code 3)",
          file=sys.stderr, flush=True)
    return NOT_CONVERGED
