"""Ctrl-C while ``python -m tmafm.sweeps`` starts: one line and exit status 130, as once the
command runs (tmafm.sweeps.cli), not Python's traceback and death by SIGINT.

Python imports the package ``tmafm`` (numpy, the core's extension) and ``tmafm.sweeps`` before
the command's ``main`` starts.  This module, imported first by ``tmafm/__init__.py``, installs a
SIGINT handler for that start-up only, when this process is ``python -m tmafm.sweeps`` and
SIGINT still has Python's own handler; ``main`` puts Python's handler back (``started``), and
from then on the command catches the KeyboardInterrupt itself.  Any other use of the package
is untouched.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

__all__ = ["started"]

#: The module run by ``python -m`` whose start-up is covered.
COMMAND = "tmafm.sweeps"


def _is_command(argv) -> bool:
    """Whether the interpreter's own arguments run ``python -m tmafm.sweeps``."""
    argv = list(argv or ())
    k = 1
    while k < len(argv):
        arg = argv[k]
        if arg == "-m":
            return k + 1 < len(argv) and argv[k + 1] == COMMAND
        if arg.startswith("-m"):
            return arg[2:] == COMMAND
        if arg == "-c" or not arg.startswith("-"):
            return False  # a script or -c: no -m comes after it
        k += 2 if arg in ("-W", "-X") else 1  # the options that take the next argument
    return False


def _interrupted(signo, frame) -> None:
    """SIGINT during the start-up: nothing was made yet; one line, and exit 130."""
    try:
        print("tmafm.sweeps: interrupted", file=sys.stderr, flush=True)
    finally:
        os._exit(130)


def _install() -> None:
    if (_is_command(getattr(sys, "orig_argv", ())) and threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, _interrupted)


def started() -> None:
    """The command runs: Python's SIGINT handler (KeyboardInterrupt) again, if ours is set."""
    if threading.current_thread() is threading.main_thread() \
            and signal.getsignal(signal.SIGINT) is _interrupted:
        signal.signal(signal.SIGINT, signal.default_int_handler)


_install()
