import sys

from airmat.cli import main

sys.exit(main())
