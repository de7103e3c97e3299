"""Config dataclasses read back from their JSON form (a run's config.json, a library's
manifest): the inverse of `dataclasses.asdict` followed by a JSON round trip."""

from __future__ import annotations

import dataclasses
import typing
from typing import Any


def from_dict(cls: type, raw: dict[str, Any]) -> Any:
    """Rebuild a (nested) config dataclass from its `dataclasses.asdict` form, as read back
    from JSON: lists become tuples, nested dataclasses are rebuilt, unknown keys are refused
    (ValueError listing the valid fields), values are checked by the class (`config`)."""
    if not isinstance(raw, dict):
        raise ValueError(f"{cls.__name__}: expected a table of fields, got {raw!r}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(raw) - names)
    if unknown:
        raise ValueError(f"{cls.__name__} has no field(s) {unknown}; valid: {sorted(names)}")
    values = {}
    for name, value in raw.items():
        kind = hints[name]
        if dataclasses.is_dataclass(kind) and isinstance(value, dict):
            value = from_dict(kind, value)
        elif isinstance(value, list):
            value = tuple(value)
        values[name] = value
    return cls(**values)
