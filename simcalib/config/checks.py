"""Small value checks for the ``__post_init__`` of every config dataclass (one style).

Each check takes the field's key and value, returns the value normalised (``float``,
``int``, ``tuple``) and raises :class:`~simcalib.errors.ConfigError` (or
:class:`~simcalib.errors.ConfigTypeError` for a wrong type) naming the key, the received
value and what is allowed. A config writes its validation as::

    def __post_init__(self):
        set_fields(self,
                   width=check_int("width", self.width, lo=16, hi=1920),
                   fovy_deg=check_range("fovy_deg", self.fovy_deg, lo=5.0, hi=150.0))
        check_that(self.pitch_m >= self.side_m, "pitch_m", self.pitch_m, ">= side_m")

Keys are the field names; when a section is built from a scenario, the config engine
re-roots them under the section (``width`` -> ``world.cam_a.width``).
"""

from __future__ import annotations

import math
from numbers import Integral, Real
from typing import Any, Iterable, Sequence

from simcalib.errors import ConfigError, ConfigTypeError, closest

__all__ = ["check_bool", "check_in", "check_int", "check_names", "check_positive",
           "check_range", "check_that", "check_vector", "set_fields", "fail"]


def fail(key: str, value: Any, allowed: str, *, hint: str = "",
         type_error: bool = False) -> ConfigError:
    """The error for ``key`` (returned, not raised)."""
    cls = ConfigTypeError if type_error else ConfigError
    return cls(key=key, value=value, allowed=allowed, hint=hint)


def set_fields(obj, **values) -> None:
    """Store normalised values on a frozen dataclass (inside ``__post_init__``)."""
    for name, value in values.items():
        object.__setattr__(obj, name, value)


def check_that(condition: bool, key: str, value: Any, allowed: str) -> None:
    """Raise ``ConfigError(key must be <allowed>; received value)`` unless ``condition``."""
    if not condition:
        raise fail(key, value, allowed)


def _is_number(value) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def _interval(lo, hi, lo_open, hi_open) -> str:
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo:g}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {hi:g}"
    return "finite"


def check_range(key: str, value: Any, *, lo: float | None = None, hi: float | None = None,
                lo_open: bool = False, hi_open: bool = False, optional: bool = False,
                finite: bool = True) -> float | None:
    """A real number within ``[lo, hi]`` (open ends with ``lo_open``/``hi_open``); ``None``
    passes when ``optional``. The message names the violated bound and the interval."""
    if value is None and optional:
        return None
    what = "a number" + (" or null" if optional else "")
    if not _is_number(value):
        raise fail(key, value, what, type_error=True)
    v = float(value)
    if math.isnan(v) or (finite and math.isinf(v)):
        raise fail(key, value, "finite" if finite else "a number (not NaN)")
    interval = _interval(lo, hi, lo_open, hi_open)
    both = lo is not None and hi is not None
    if lo is not None and (v < lo or (lo_open and v == lo)):
        bound = _interval(lo, None, lo_open, False)
        raise fail(key, value, bound, hint=f"(allowed: {interval})" if both else "")
    if hi is not None and (v > hi or (hi_open and v == hi)):
        bound = _interval(None, hi, False, hi_open)
        raise fail(key, value, bound, hint=f"(allowed: {interval})" if both else "")
    return v


def check_positive(key: str, value: Any, *, allow_zero: bool = False,
                   optional: bool = False) -> float | None:
    """A finite number ``> 0`` (``>= 0`` with ``allow_zero``)."""
    v = check_range(key, value, optional=optional)
    if v is not None and (v < 0 or (v == 0 and not allow_zero)):
        raise fail(key, value, "finite and >= 0" if allow_zero else "finite and > 0")
    return v


def check_int(key: str, value: Any, *, lo: int | None = None, hi: int | None = None,
              optional: bool = False) -> int | None:
    """An integer (not a bool) within ``[lo, hi]``; ``None`` passes when ``optional``."""
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise fail(key, value, "an integer" + (" or null" if optional else ""),
                   type_error=True)
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise fail(key, value, "an integer " + _interval(lo, hi, False, False))
    return v


def check_bool(key: str, value: Any) -> bool:
    """``True`` or ``False`` (not 1/0, not a string)."""
    if not isinstance(value, bool):
        raise fail(key, value, "a bool (true or false)", type_error=True)
    return value


def check_in(key: str, value: Any, allowed: Iterable, *, optional: bool = False):
    """One of ``allowed`` (the message suggests the closest one)."""
    allowed = list(allowed)
    if (value is None and optional) or value in allowed:
        return value
    match = closest(value, [str(a) for a in allowed]) if isinstance(value, str) else None
    hint = f"(did you mean {match!r}?)" if match else ""
    listing = ", ".join(repr(a) for a in allowed) + (" or null" if optional else "")
    raise fail(key, value, f"one of {listing}", hint=hint)


def check_names(key: str, values: Any, allowed: Sequence | None = None, *,
                min_len: int = 1, unique: bool = True) -> tuple:
    """A list of at least ``min_len`` names (a single string counts as one), each in
    ``allowed`` when given, no repeats when ``unique``."""
    if isinstance(values, str):
        values = (values,)
    try:
        items = tuple(values)
    except TypeError:
        raise fail(key, values, "a list of names", type_error=True) from None
    if len(items) < min_len:
        raise fail(key, list(items), f"a list of at least {min_len} name"
                   f"{'s' if min_len != 1 else ''}")
    if allowed is not None:
        for item in items:
            check_in(key, item, allowed)
    if unique and len(set(items)) != len(items):
        raise fail(key, list(items), "a list without repeats")
    return items


def check_vector(key: str, value: Any, n: int = 3, *, max_norm: float | None = None,
                 what: str = "") -> tuple[float, ...]:
    """``n`` finite numbers (optionally of norm <= ``max_norm``) as a tuple of floats."""
    try:
        items = [float(v) for v in value]
        ok_types = all(_is_number(v) or hasattr(v, "dtype") for v in value)
    except (TypeError, ValueError):
        raise fail(key, value, f"{n} finite numbers", type_error=True) from None
    if not ok_types or len(items) != n or not all(math.isfinite(v) for v in items):
        raise fail(key, value, f"{n} finite numbers")
    if max_norm is not None and math.sqrt(sum(v * v for v in items)) > max_norm:
        raise fail(key, value, f"within {max_norm:g} of the origin" + (f" ({what})" if what
                                                                      else ""))
    return tuple(items)
