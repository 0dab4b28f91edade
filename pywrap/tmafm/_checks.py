"""Argument checks shared by the public functions that take arrays of numbers (tmafm.analysis,
tmafm.observe.steady_test): one message and one exception type for the same mistake."""

from __future__ import annotations

import numpy as np

from ._namelist import shown
from .errors import InputError

__all__ = ["real_array"]


def real_array(what: str, name: str, value, ndim: int | tuple[int, ...]) -> np.ndarray:
    """`value` as finite real numbers of `ndim` dimensions (one of them, if a tuple), with at
    least one value; InputError naming `what` and `name` otherwise."""
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError("not numbers")
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"{what}: {name} must be real numbers: {shown(str(exc))[1:-1]}") from None
    dims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    if array.ndim not in dims or not np.all(np.isfinite(array)):
        raise InputError(f"{what}: {name} must be finite numbers of "
                         f"{' or '.join(map(str, dims))} dimension(s), got shape {array.shape}")
    if 0 in array.shape:
        raise InputError(f"{what}: {name} has no values (shape {array.shape})")
    return array
