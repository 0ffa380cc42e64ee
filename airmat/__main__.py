"""``python -m airmat``: a SIGINT handler goes in before any import (see airmat.cli.sigint).

Until :mod:`airmat.cli` installs its own, a plain handler turns Ctrl-C into
KeyboardInterrupt, which the ``try`` below reports as one line and exit code
130, so an interrupt while airmat.cli and its standard-library imports load
(argparse, logging) gets the same answer as one during the run.
"""

import os
import signal
import sys


def _early(signum, frame):
    raise KeyboardInterrupt


signal.signal(signal.SIGINT, _early)

try:
    from airmat.cli import main  # noqa: E402  (after the handler, on purpose)
except KeyboardInterrupt:
    command = next((a for a in sys.argv[1:] if not a.startswith("-")), None)  # not parsed yet
    print(f"airmat {command}: interrupted" if command else "airmat: interrupted", file=sys.stderr, flush=True)
    os._exit(130)  # see airmat.cli._exit_code

sys.exit(main())
