"""What the signal functions take, checked alike: arrays of real samples and positive quantities given as numbers.

The command line's values (text) are read by :mod:`bearingtwin.checks`; these functions take arrays and numbers.
"""

from __future__ import annotations

import numpy as np

from bearingtwin.errors import BearingTwinError


def as_signal(x, name: str = "x") -> np.ndarray:
    """``x`` as float64 signals along its last axis: real numbers (no bool, no complex), at least 2 samples, finite;
    refused in one line naming ``name`` otherwise."""
    x = np.asarray(x)
    if not np.issubdtype(x.dtype, np.number) or np.iscomplexobj(x):
        raise BearingTwinError(f"{name} must be a real numeric array (got dtype {x.dtype})")
    if x.ndim < 1 or x.shape[-1] < 2:
        raise BearingTwinError(f"{name} needs at least 2 samples along its last axis (got shape {x.shape})")
    x = x.astype(np.float64, copy=False)
    if not np.all(np.isfinite(x)):
        raise BearingTwinError(f"{name} contains NaN or infinite values")
    return x


def as_record(x, name: str = "signal", reader: str = "") -> np.ndarray:
    """``x`` as :func:`as_signal` takes it, and one 1-D record: for what reads a whole record at once (its
    spectrum's resolution, its speed over time), refused otherwise naming ``name`` and the ``reader``."""
    x = as_signal(x, name)
    if x.ndim != 1:
        raise BearingTwinError(f"{name} must be one 1-D record{f' for {reader}' if reader else ''} (got shape {x.shape})")
    return x


def check_positive(value, name: str = "fs", what: str = "sampling rate in Hz") -> None:
    """Refuse a sampling rate (or another positive quantity, ``what``) that is not a positive, finite real number.

    A numpy scalar or 0-d array (a rate read from an ``.npz``) passes as it is, so the caller's
    arithmetic stays bit for bit what it was; a bool (``True`` would be 1 Hz) or a number's text
    does not: these functions take arrays, and only the command line reads a rate from text.
    """
    number = np.asarray(value)
    if number.ndim != 0 or number.dtype.kind not in "iuf" or not (np.isfinite(number) and number > 0):
        raise BearingTwinError(f"{name} must be a positive {what} (got {value!r})")
