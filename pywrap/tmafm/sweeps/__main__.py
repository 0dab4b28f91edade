"""``python -m tmafm.sweeps FILE [-o OUT.nc]``: the command line of tmafm.sweeps.cli."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
