"""Files written from Python follow the executable's output rules (docs/reliability.md#output).

A missing path or a regular file is written under a new temporary ``.NAME.partial-XXXXXXXXXX``
in the same folder (``O_CREAT|O_EXCL|O_NOFOLLOW``: never an existing file or link), synced,
and renamed over NAME: the file is complete under its name or absent, and has the permissions
``open(2)`` gives a new file (0666 less the umask).  A character device or a FIFO (``/dev/null``,
also through a symbolic link) is written directly and stays what it is.  A directory, a symbolic
link to a file or to nothing, a socket or a block device is refused.  Every failure, and an
interruption (KeyboardInterrupt), removes the temporary; OSErrors become InputFileError.

Signals: on the main thread, a SIGTERM, SIGHUP or SIGINT whose action is to kill the process
(SIG_DFL: Python's own SIGINT handler raises KeyboardInterrupt instead) is caught while a
write runs, the temporaries are removed, and the signal is then delivered again with its
default action, so the process still dies of it, leaving no ``.partial`` file.  A signal that
comes while the temporary is created or renamed waits for that step to end.  A FIFO with no
reader is waited for after a line on stderr saying so.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import signal
import stat
import string
import sys
import tempfile
import threading
from pathlib import Path
from typing import Callable

from ._namelist import shown
from .errors import InputFileError, InputTypeError

__all__ = ["write_bytes", "write_with", "write_text", "save_figure", "check_target"]

_ALPHABET = string.ascii_letters + string.digits
_DIRECT, _REPLACE = "direct", "replace"


def as_path(path, what: str = "output file") -> Path:
    """`path` (a str or an os.PathLike) as a Path; InputTypeError for anything else."""
    try:
        raw = os.fspath(path)
        result = Path(path)
    except TypeError:
        raise InputTypeError(f"{what} name must be a str or an os.PathLike, not "
                             f"{type(path).__name__}") from None
    if isinstance(raw, str) and raw.endswith(os.sep):
        # Path('out/') is Path('out'): the slash, which asks for a folder, would be dropped.
        raise InputFileError(f"{what} {shown(raw)} ends in {os.sep}: give a file name")
    return result


def _target(path: Path, what: str) -> str:
    """How `path` is written: _REPLACE (a temporary and a rename) or _DIRECT (a device or a
    FIFO); InputFileError for anything that must not be written."""
    name = shown(str(path))
    if not str(path):
        raise InputFileError(f"{what}: the file name is empty")
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return _REPLACE
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte, a file in the path
        raise InputFileError(f"cannot write {what} {name}: "
                             f"{getattr(exc, 'strerror', None) or exc}") from None
    if stat.S_ISLNK(mode):
        try:
            target = os.stat(path).st_mode
        except OSError:
            target = 0
        if stat.S_ISCHR(target) or stat.S_ISFIFO(target):
            return _DIRECT
        raise InputFileError(f"{what} {name} is a symbolic link; tmafm replaces only regular "
                             f"files: give the path it points to")
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return _DIRECT
    if stat.S_ISDIR(mode):
        raise InputFileError(f"{what} {name} is a directory")
    if not stat.S_ISREG(mode):
        raise InputFileError(f"{what} {name} is not a regular file, a character device or a FIFO")
    if not os.access(path, os.W_OK):
        raise InputFileError(f"{what} {name} exists and is not writable")
    return _REPLACE


def check_target(path, what: str = "output file") -> Path:
    """Before the work that makes a file: whether `path` can be written by the rules above.  A
    device or FIFO is accepted as it is; for a file, a temporary is created in its folder and
    removed, as the executable does before a run (a missing folder, a read-only or full file
    system without a free inode, a directory target: InputFileError).  Returns the path."""
    path = as_path(path, what)
    if _target(path, what) == _DIRECT:
        return path
    with _Guard() as guard, guard.held():
        try:
            fd, temporary = _create_temporary(path)
        except OSError as exc:
            raise InputFileError(f"cannot write {what} {shown(str(path))}: {exc.strerror}") from None
        os.close(fd)
        os.unlink(temporary)
    return path


class _Signalled(BaseException):
    """A terminating signal came while a file was being written (raised by _Guard)."""

    def __init__(self, signo: int):
        super().__init__(signo)
        self.signo = signo


class _Guard:
    """While a write runs on the main thread: SIGTERM, SIGHUP and SIGINT left at their default
    action (which kills the process at once, past every ``finally``) raise _Signalled instead,
    except inside ``held()`` (creating or renaming the temporary), where they wait for its end.
    On leaving, the previous actions are restored and a signal that came is delivered again:
    the process dies of it as it would have, with no temporary left."""

    _SIGNALS = ("SIGTERM", "SIGHUP", "SIGINT")

    def __init__(self):
        self.pending = None
        self.holding = False
        self.previous = {}

    def _handler(self, signo, frame):
        self.pending = signo
        if not self.holding:
            raise _Signalled(signo)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for name in self._SIGNALS:
                signo = getattr(signal, name, None)
                if signo is not None and signal.getsignal(signo) == signal.SIG_DFL:
                    self.previous[signo] = signal.signal(signo, self._handler)
        return self

    @contextlib.contextmanager
    def held(self):
        """Signals wait until the block ends (then _Signalled, if one came)."""
        self.holding = True
        try:
            yield
        finally:
            self.holding = False
        if self.pending is not None:
            raise _Signalled(self.pending)

    def __exit__(self, kind, value, traceback):
        for signo, action in self.previous.items():
            signal.signal(signo, action)
        if self.pending is not None and self.previous:
            signal.raise_signal(self.pending)  # the default action: the process ends here
        return False


def _create_temporary(path: Path) -> tuple[int, Path]:
    """A new, empty file next to `path`, created exclusively: (descriptor, name)."""
    base = path.name.encode("utf-8", "surrogateescape")[:200].decode("utf-8", "ignore")
    for _ in range(100):
        suffix = "".join(secrets.choice(_ALPHABET) for _ in range(10))
        temporary = path.with_name(f".{base}.partial-{suffix}")
        try:
            fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW
                         | getattr(os, "O_CLOEXEC", 0), 0o666)
        except FileExistsError:
            continue
        return fd, temporary
    raise FileExistsError(17, "no unused temporary name")


def _write_all(fd: int, data) -> None:
    view = memoryview(data).cast("B")
    while view:
        view = view[os.write(fd, view):]


def _replace(path: Path, fill: Callable[[int, Path], None], what: str, guard: _Guard) -> None:
    """Create the temporary, let `fill` write it (given its descriptor and name), sync it and
    rename it over `path`; remove it on any failure or interruption (a signal: `guard`)."""
    temporary = None
    renamed = False
    try:
        with guard.held():
            try:
                fd, temporary = _create_temporary(path)
            except OSError as exc:
                raise InputFileError(f"cannot write {what} {shown(str(path))}: "
                                     f"{exc.strerror}") from None
        try:
            fill(fd, temporary)
            os.fsync(fd)
        finally:
            os.close(fd)
        with guard.held():
            os.replace(temporary, path)
            renamed = True
    except BaseException as exc:
        if temporary is not None and not renamed:
            try:
                os.unlink(temporary)
            except OSError:
                pass
        if isinstance(exc, OSError):
            raise InputFileError(f"writing {what} {shown(str(path))} failed: "
                                 f"{exc.strerror or exc}") from None
        raise


def _sync_name(name: Path) -> None:
    fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _open_direct(path: Path) -> int:
    """Open a device or FIFO for writing; a FIFO with no reader is waited for, after a line on
    stderr saying so (never a silent hang)."""
    flags = os.O_WRONLY | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno != errno.ENXIO:  # ENXIO: a FIFO with no reader yet
            raise
        print(f"tmafm: waiting for a reader of the FIFO {shown(str(path))} (the output goes "
              f"there; Ctrl-C stops)", file=sys.stderr, flush=True)
        return os.open(path, flags)
    os.set_blocking(fd, True)
    return fd


def _direct(path: Path, data, what: str) -> None:
    try:
        fd = _open_direct(path)
        try:
            _write_all(fd, data)
        finally:
            os.close(fd)
    except OSError as exc:
        raise InputFileError(f"writing {what} {shown(str(path))} failed: "
                             f"{exc.strerror or exc}") from None


def write_bytes(path, data, what: str = "output file") -> Path:
    """Write `data` (bytes) to `path` by the rules above; return the path."""
    path = as_path(path, what)
    with _Guard() as guard:
        if _target(path, what) == _DIRECT:
            _direct(path, data, what)
        else:
            _replace(path, lambda fd, _: _write_all(fd, data), what, guard)
    return path


def write_with(path, writer: Callable[[Path], None], what: str = "output file") -> Path:
    """Write `path` with `writer(name)`, a function that writes a whole file by its name (a
    NetCDF or PNG writer), by the rules above; return the path."""
    path = as_path(path, what)
    with _Guard() as guard:
        if _target(path, what) == _DIRECT:
            # A device or FIFO: the writer works on a private file, whose bytes are then copied
            # (the private folder goes on any exception, a signal's included: guard).
            with tempfile.TemporaryDirectory() as folder:
                scratch = Path(folder) / path.name
                writer(scratch)
                with open(scratch, "rb") as source:
                    data = source.read()
            _direct(path, data, what)
        else:
            # The writer opens the temporary by name (our own new file, never a link) and may
            # replace it: it is synced by name too.
            _replace(path, lambda fd, name: (writer(name), _sync_name(name)), what, guard)
    return path


def write_text(path, text: str, what: str = "output file") -> Path:
    """Write `text` (UTF-8) to `path` by the rules above; return the path."""
    return write_bytes(path, text.encode("utf-8", "surrogateescape"), what)


def save_figure(fig, path, what: str = "plot file", **options) -> Path:
    """``fig.savefig(path, **options)`` by the rules above (the format from the name's suffix,
    as savefig picks it, PNG otherwise); return the path."""
    import io
    suffix = as_path(path, what).suffix.lower()[1:]
    buffer = io.BytesIO()
    fig.savefig(buffer, format=suffix if suffix in fig.canvas.get_supported_filetypes() else "png",
                **options)
    return write_bytes(path, buffer.getvalue(), what)
