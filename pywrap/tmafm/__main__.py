"""``python -m tmafm INPUT.nml [-o FILE]`` runs the ``tmafm`` executable with the same arguments."""

import os
import sys

from ._exe import executable


def main() -> None:
    """Replace this process with the tmafm executable."""
    exe = executable()
    os.execv(exe, [exe, *sys.argv[1:]])


if __name__ == "__main__":
    main()
