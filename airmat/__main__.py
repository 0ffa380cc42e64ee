"""``python -m airmat``: the SIGINT handler goes in before any heavy import (see airmat.cli.sigint)."""

import sys

from airmat.cli.sigint import install

install()

try:
    from airmat.cli import main  # noqa: E402  (after the handler, on purpose)
except KeyboardInterrupt:
    print("airmat: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
