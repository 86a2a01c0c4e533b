"""Checks of scalar arguments shared by the package's modules: one wording
for every "NAME must be ..., got ..." (TypeError for the wrong kind of
value, ValueError for one out of range). Imports nothing from the package,
so every module can use it."""

from __future__ import annotations

import math
import operator
from typing import Optional

import numpy as np

__all__ = ["as_finite", "as_finite_reals", "as_number", "as_reals", "check_choice", "check_flag",
           "check_index", "check_int", "integer_dtype", "number_dtype"]


def check_choice(name: str, value, choices) -> str:
    """``value``, one of the strings ``choices``: TypeError for what is not a
    string, ValueError for another string, both listing the choices."""
    valid = ", ".join(map(repr, choices))
    if not isinstance(value, str):
        raise TypeError(f"{name} must be one of {valid}, got {value!r}")
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; valid values are {valid}")
    return value


def check_flag(name: str, value) -> bool:
    """``value`` as a bool; TypeError unless it is one (a string such as
    "no" would otherwise count as True)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {value!r}")
    return bool(value)


def check_index(name: str, value) -> int:
    """``value`` as an int: any integer numpy's indexing takes (Python and
    numpy integers, 0-d integer arrays), not a bool; TypeError otherwise."""
    try:
        if isinstance(value, (bool, np.bool_)):
            raise TypeError
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer, got {value!r}") from None


def check_int(name: str, value, least: Optional[int] = None, most: Optional[int] = None) -> int:
    """:func:`check_index`, and ValueError outside ``least .. most`` (either
    bound may be None)."""
    n = check_index(name, value)
    if least is not None and most is not None and not least <= n <= most:
        raise ValueError(f"{name} must be in {least} .. {most}, got {n}")
    if least is not None and n < least:
        raise ValueError(f"{name} must be at least {least}, got {n}")
    if most is not None and n > most:
        raise ValueError(f"{name} must be at most {most}, got {n}")
    return n


def integer_dtype(dtype) -> bool:
    """Whether arrays of ``dtype`` hold integers: signed or unsigned, not
    bools and not timedelta64 (which numpy counts among its integers)."""
    return np.dtype(dtype).kind in "iu"


def number_dtype(dtype) -> bool:
    """Whether arrays of ``dtype`` hold real numbers: integers
    (:func:`integer_dtype`) or floats."""
    return np.dtype(dtype).kind in "iuf"


def as_number(name: str, value) -> float:
    """``value``, a real number (Python's or numpy's, not a bool or a
    timedelta64, which numpy counts among its integers), as a float:
    TypeError otherwise; a Python int beyond float range is inf (callers
    that want finite numbers refuse it with their ValueError)."""
    if isinstance(value, (bool, np.bool_, np.timedelta64)) or \
            not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # a Python int beyond float range
        return math.inf


def as_finite(name: str, value) -> float:
    """:func:`as_number`, and ValueError for NaN or an infinity."""
    x = as_number(name, value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x


def _has_bool(value) -> bool:
    """Whether ``value`` is a bool or a (nested) list or tuple holding one."""
    if isinstance(value, (bool, np.bool_)):
        return True
    return isinstance(value, (list, tuple)) and any(_has_bool(x) for x in value)


def as_reals(name: str, value, what: str) -> np.ndarray:
    """``value`` as a float64 array: TypeError (``name must be what``) unless
    it is made of real numbers -- no bools (also among numbers: numpy would
    take (0, True, 0) as integers), no strings; ValueError for a Python int
    beyond float range."""
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iufO" or _has_bool(value):  # (bools, strings, ...)
            raise TypeError
        return np.asarray(raw, dtype=np.float64)
    except OverflowError:  # a Python int beyond float range
        raise ValueError(f"{name} must be finite, got {value!r}") from None
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be {what}, got {value!r}") from None


def as_finite_reals(name: str, value, size: int, broadcast: bool = False) -> np.ndarray:
    """:func:`as_reals` as ``size`` finite numbers, a (size,) float64 array
    (``broadcast``: one number stands for all): ValueError for another
    shape, a NaN or an infinity."""
    v = as_reals(name, value, f"{size} numbers")
    if broadcast and v.ndim == 0:
        v = np.full(size, float(v))
    if v.shape != (size,):
        raise ValueError(f"{name} must be {size} numbers, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v
