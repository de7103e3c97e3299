"""The checks every config dataclass runs on its values: types, finite non-negative numbers."""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from typing import Any, Literal

SEED_LIMIT = 2**32  # seeds are 32-bit JAX keys: s and s + 2**32 would be one stream


def _check(cond: bool, field: str, why: str) -> None:
    if not cond:
        raise ValueError(f"invalid config value for '{field}': {why}")


def check_numbers(config: Any) -> None:
    """Every field of `config` has its annotated type (`checked_value`), and every number (of
    a tuple too) is finite and >= 0: no config field takes NaN, an infinity or a negative."""
    hints = typing.get_type_hints(type(config))
    for field in dataclasses.fields(config):
        value = checked_value(field.name, getattr(config, field.name), hints[field.name])
        object.__setattr__(config, field.name, value)
        for v in value if isinstance(value, tuple) else (value,):
            if isinstance(v, bool) or not isinstance(v, int | float):
                continue
            _check(math.isfinite(v), field.name, f"must be finite, got {v}")
            _check(v >= 0, field.name, f"must be >= 0, got {v}")


def checked_value(field: str, value: Any, hint: Any) -> Any:
    """`value` as a field annotated `hint` holds it (ints as floats, lists as tuples), or
    ValueError naming `field`: a float for an int (1e6 for 1000000), a string for a number."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is Literal:
        _check(value in args, field, f"valid: {', '.join(map(str, args))}; got {value!r}")
        return value
    if origin is tuple:
        _check(isinstance(value, tuple | list), field, f"must be a list, got {value!r}")
        items = args[:1] * len(value) if args[-1:] == (Ellipsis,) else args
        _check(len(items) == len(value), field, f"must hold {len(items)} values, got {value!r}")
        return tuple(checked_value(field, v, h) for v, h in zip(value, items, strict=True))
    kinds = {int: (numbers.Integral, "an int"), float: (numbers.Real, "a number")}
    kinds |= {bool: (bool, "true or false"), str: (str, "a string")}
    if hint in kinds:
        kind, name = kinds[hint]
        ok = isinstance(value, kind) and (hint is bool or not isinstance(value, bool))
        _check(ok, field, f"must be {name}, got {value!r} ({type(value).__name__})")
        return hint(value)
    return value
