"""The command line ``python -m tmafm.sweeps FILE [-o OUT.nc]`` (docs/sweeps.md): run the sweep
a &sweep file describes, write its NetCDF file and its plot, or summarize a NetCDF file."""

from __future__ import annotations

import argparse
import os
import stat
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

from .._namelist import shown
from ..errors import InputFileError, InputTypeError, TmafmError
from .dataset import _netcdf_bytes, read_dataset, summarize
from .files import _check_file_size, read_sweep_file, run_sweep_file


def main(argv=None) -> int:
    """``python -m tmafm.sweeps FILE [-o OUT.nc] [--workers N] [--plot PNG] [--progress]``.

    Exit status: 0 success; 2 any error (one line on stderr, nothing written: the extras the
    sweep needs, the size of its grid, and both targets (folder writable, name's extension)
    are checked before it runs); 130 on Ctrl-C (one line, nothing written), also during the
    start-up (tmafm._startup).  A warning is one line on stderr.  argparse's own usage errors
    exit 2 too."""
    from .. import _startup
    if argv is not None and (isinstance(argv, (str, bytes)) or not isinstance(argv, Sequence)
                             or not all(isinstance(a, str) for a in argv)):
        raise InputTypeError(f"argv = {shown(argv)}: must be a list of strings or None")
    try:
        # Python's SIGINT handler again, inside the try: a Ctrl-C from here on is caught below.
        _startup.started()
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning
            return _main(argv)
    except TmafmError as exc:
        print(f"tmafm.sweeps: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("tmafm.sweeps: error: not enough memory for this sweep: give fewer points",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tmafm.sweeps: interrupted", file=sys.stderr)
        return 130


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as the command prints it: one line on stderr, ``tmafm.sweeps: warning:
    <category>: <message>`` (not Python's two lines with the source line)."""
    text = " ".join(str(message).split())
    print(f"tmafm.sweeps: warning: {category.__name__}: {text}", file=sys.stderr, flush=True)


def _main(argv) -> int:
    parser = argparse.ArgumentParser(prog="python -m tmafm.sweeps",
                                     description="Run the sweep described by a &sweep file.")
    parser.add_argument("file", help="the sweep file (a &sweep namelist, docs/sweeps.md)")
    parser.add_argument("-o", "--output", help="the NetCDF file to write (default: &sweep "
                        "output, or FILE with .nc)")
    parser.add_argument("--workers", type=int, default=None, help="local threads (default: all)")
    parser.add_argument("--plot", default=None, help="the PNG to draw (default: OUTPUT.png)")
    parser.add_argument("--no-plot", action="store_true", help="write no plot")
    parser.add_argument("--progress", action="store_true", help="show a progress bar")
    parser.add_argument("--summarize", action="store_true", help="FILE is a sweep NetCDF file: "
                        "print its summary (jumps, attractors, periods) as JSON")
    args = parser.parse_args(argv)
    if args.summarize:
        import json
        print(json.dumps(summarize(read_dataset(args.file)), indent=1))
        return 0
    spec = read_sweep_file(args.file)
    out = Path(args.output or spec.get("output") or Path(args.file).with_suffix(".nc"))
    png = None if args.no_plot else Path(args.plot) if args.plot else out.with_suffix(".png")
    _check_targets(out, png, [Path(args.file), Path(spec["base"])])
    _check_extras(png is not None, args.progress)
    _check_writable(out, png)
    _check_file_size(spec)
    ds = run_sweep_file(args.file, workers=args.workers, progress=args.progress)
    # Both files are made in memory first, so a plot that fails writes no NetCDF file.
    from .._extras import netcdf_engine
    from .._safefile import write_bytes
    data = _netcdf_bytes(ds, netcdf_engine("python -m tmafm.sweeps"))
    picture = None
    if png is not None:
        from .plots import render
        picture = render(ds, png.suffix)
    existed = os.path.lexists(out)
    write_bytes(out, data, "NetCDF file")
    if picture is not None:
        try:
            write_bytes(png, picture, "plot file")
        except BaseException:
            if not existed and out.is_file():  # the NetCDF file this command created
                out.unlink()
            raise
    # Said only once both files are in place.
    print(f"wrote {out}")
    if picture is not None:
        print(f"wrote {png}")
    return 0


def _is_device(path: Path) -> bool:
    """Whether `path` is (or links to) a character device or a FIFO, written as it is."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return False
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


def _check_writable(out: Path, png) -> None:
    """Before the sweep runs: the NetCDF file's name ends in .nc and the plot's in a format
    matplotlib writes (not a PNG under another name), unless it is a device or FIFO; and a
    temporary can be made in each one's folder (tmafm._safefile.check_target)."""
    from .._safefile import check_target
    if not _is_device(out) and out.suffix.lower() != ".nc":
        raise InputFileError(f"the NetCDF file {shown(str(out))}: the name must end in .nc (-o)")
    if png is not None and not _is_device(png):
        from matplotlib.figure import Figure
        formats = sorted(Figure().canvas.get_supported_filetypes())
        if png.suffix.lower().lstrip(".") not in formats:
            raise InputFileError(f"the plot {shown(str(png))}: the name must end in a format "
                                 f"matplotlib writes ({', '.join('.' + f for f in formats)}; "
                                 f"--plot, or --no-plot)")
    check_target(out, "NetCDF file")
    if png is not None:
        check_target(png, "plot file")


def _check_extras(plot: bool, progress: bool) -> None:
    """Before the sweep runs: the modules it needs (xarray, a NetCDF writer, matplotlib for
    the plot, tqdm for --progress); MissingExtraError naming the extra otherwise."""
    from .._extras import netcdf_engine, require
    user = "python -m tmafm.sweeps"
    require("xarray", user)
    netcdf_engine(user)
    if plot:
        require("matplotlib", f"{user} (the plot; --no-plot writes none)")
    if progress:
        require("tqdm", f"{user} --progress")


def _same_file(a: Path, b: Path) -> bool:
    """Whether two names are one file: the same inode if both exist, else the same absolute
    path."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


def _check_targets(out: Path, png, inputs) -> None:
    """Before the sweep runs: the NetCDF file and the plot are neither an input (the sweep
    file, its base) nor each other, so that nothing the run read is replaced."""
    for target, what in ((out, "the NetCDF file"), (png, "the plot")):
        if target is None:
            continue
        for source in inputs:
            if _same_file(target, source):
                raise InputFileError(f"{what} {shown(str(target))} is the input "
                                     f"{shown(str(source))}: give another name (-o, --plot)")
    if png is not None and _same_file(out, png):
        raise InputFileError(f"the NetCDF file and the plot are both {shown(str(out))}: give "
                             f"another name (-o, --plot)")
