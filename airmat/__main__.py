"""``python -m airmat``: the SIGINT handler goes in before any heavy import (see airmat.cli.sigint)."""

import os
import sys

from airmat.cli.sigint import install

install()

try:
    from airmat.cli import main  # noqa: E402  (after the handler, on purpose)
except KeyboardInterrupt:
    command = next((a for a in sys.argv[1:] if not a.startswith("-")), None)  # not parsed yet
    print(f"airmat {command}: interrupted" if command else "airmat: interrupted", file=sys.stderr, flush=True)
    os._exit(130)  # see airmat.cli._exit_code

sys.exit(main())
