"""Reading experiments/NAME.toml: the TOML, an `extends` chain merged, and the checks that
need the file's own keys (`experiments.load_experiment` builds the Experiment from them).

A variant states only what it changes: `extends = "PARENT"` takes PARENT's keys (its own
`extends` first), the variant's keys override them, and its tables (`[train]`, `[env]`,
`[library]`, `[options.METHOD.GROUP]`) are merged key by key. What an experiment is
(`description`, `group`), its cells' `label` (a variant's cells must not take its parent's
names) and a headline's `baseline` and `target` are never inherited. `unset = ["KEY",
"TABLE.KEY", ...]` drops inherited keys (dotted paths into the parent's merged keys) before
the variant's own are merged, e.g. `unset = ["options.ddpg_her.ddpg.tau"]` to take the
method's default again.

    extends = "fast"
    description = "DDPG+HER+SL+Fast's second default on container_wall"
    group = "beyond"
    tasks = ["container_wall"]
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"
GROUPS = {
    "thesis": "reproduce the thesis's figures and tables",
    "beyond": "go beyond the thesis (methods and tasks of this project)",
    "baseline": "baselines and bounds the results are set against",
    "tuning": "candidates measured to choose a default (seeds 0-4)",
    "ablation": "a default with one part removed",
    "diagnostic": "checks of the pipeline and explanations of a shortfall",
    "adhoc": "a grid given on the command line",
}
"""What an experiment is for: every file in experiments/ declares one (`group = ...`)."""

NOT_INHERITED = ("description", "group", "label", "baseline", "target")
"""Keys a variant does not take from the file it extends."""


def names() -> list[str]:
    return sorted(p.stem for p in EXPERIMENTS.glob("*.toml"))


def parent(name: str) -> str | None:
    """The experiment NAME.toml extends (its own `extends` key), or None. ValueError as
    `raw`'s for an unknown name or invalid TOML."""
    return _own(name).get("extends")


def _own(name: str, chain: tuple[str, ...] = ()) -> dict[str, Any]:
    """NAME.toml's own keys, as written. ValueError naming the file for an unknown name
    (and the experiment that extends it, the last of `chain`) or invalid TOML."""
    path = EXPERIMENTS / f"{name}.toml"
    if not path.exists():
        where = f" (extended by {chain[-1]})" if chain else ""
        raise ValueError(f"unknown experiment {name!r}{where}; valid: {', '.join(names())}")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path} is not valid TOML: {err}") from None


def merged(base: dict[str, Any], own: dict[str, Any]) -> dict[str, Any]:
    """`base` with `own` over it, tables merged key by key (a new dict)."""
    out = dict(base)
    for key, value in own.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merged(out[key], value)
        else:
            out[key] = value
    return out


def raw(name: str, chain: tuple[str, ...] = ()) -> dict[str, Any]:
    """NAME.toml's keys with its `extends` chain merged in. ValueError naming the file for an
    unknown name, invalid TOML or a loop of `extends`."""
    path = EXPERIMENTS / f"{name}.toml"
    own = _own(name, chain)
    parent = own.pop("extends", None)
    unset = own.pop("unset", [])
    if parent is None:
        if unset:
            raise ValueError(f"{path}: unset drops inherited keys, so it needs extends")
        return own
    if not isinstance(parent, str) or not parent.replace("_", "").isalnum():
        raise ValueError(f"{path}: extends must name an experiment file, got {parent!r}")
    if parent in (*chain, name):
        raise ValueError(f"{path}: extends loops: {' -> '.join((*chain, name, parent))}")
    base = raw(parent, (*chain, name))
    base = {k: v for k, v in base.items() if k not in NOT_INHERITED}
    return merged(dropped(base, unset, path), own)


def dropped(base: dict[str, Any], unset: Any, path: Path) -> dict[str, Any]:
    """`base` without the dotted keys `unset` names (a new dict; emptied tables removed).
    ValueError naming the file for a key `base` does not have."""
    if not isinstance(unset, list) or not all(isinstance(k, str) and k for k in unset):
        raise ValueError(f'{path}: unset must be a list of dotted keys, e.g. ["train.envs"]')
    if len(set(unset)) != len(unset):
        raise ValueError(f"{path}: unset names a key twice: {unset}")
    out = merged({}, base)  # a copy of every table
    for dotted in unset:
        *tables, key = dotted.split(".")
        table = out
        for name in tables:
            table = table.get(name) if isinstance(table, dict) else None
        if not isinstance(table, dict) or key not in table:
            raise ValueError(f"{path}: unset {dotted!r}: the file it extends has no such key")
        del table[key]
    return _without_empty(out)


def _without_empty(table: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in table.items():
        if isinstance(value, dict):
            value = _without_empty(value)
            if not value:
                continue
        out[key] = value
    return out


def read(name: str, known: set[str]) -> dict[str, Any]:
    """The Experiment fields of experiments/NAME.toml (`raw`), after the checks that need the
    file's own keys: keys not in `known` (the Experiment's fields), a library file's keys, a
    group, a baseline that exists. ValueError naming the file."""
    path = EXPERIMENTS / f"{name}.toml"
    fields = raw(name)
    if set(fields) - known:
        raise ValueError(
            f"{path}: unknown key(s) {sorted(set(fields) - known)}; valid: {sorted(known)}"
        )
    if fields.get("kind") == "library":
        extra = sorted(set(fields) - LIBRARY_KEYS)
        if extra:
            raise ValueError(
                f"{path}: a library experiment does not read {extra}; valid: {sorted(LIBRARY_KEYS)}"
            )
    elif set(fields) & {"samples", "library"}:
        raise ValueError(f'{path}: samples and [library] need kind = "library"')
    if "libraries" in fields and not any(
        _library_method(m) for m in fields.get("methods", ()) if isinstance(m, str)
    ):
        raise ValueError(
            f"{path}: libraries are set but no method of {fields.get('methods')} uses one"
        )
    if not isinstance(fields.get("description"), str):
        raise ValueError(f"{path}: description is missing: say what the experiment is")
    if fields.get("group") in (None, "adhoc"):
        valid = ", ".join(g for g in GROUPS if g != "adhoc")
        raise ValueError(f"{path}: group must be one of {valid} (what the experiment is for)")
    if (fields.get("baseline") or fields.get("target")) and fields.get("role") != "headline":
        raise ValueError(f'{path}: baseline and target are read for role = "headline" only')
    if fields.get("baseline") == name:
        raise ValueError(f"{path}: baseline names the experiment itself")
    if fields.get("baseline") and fields["baseline"] not in names():
        raise ValueError(
            f"{path}: baseline {fields['baseline']!r} is no experiment; valid: {', '.join(names())}"
        )
    for key in ("tasks", "methods", "libraries", "samples"):
        if key in fields:
            fields[key] = tuple(fields[key])
    return fields


def _library_method(method: str) -> bool:
    from mjx_skills import methods

    return method in methods.METHODS and methods.get(method).library_group is not None


LIBRARY_KEYS = {"description", "group", "kind", "samples", "library"}
"""What a `kind = "library"` file reads: its other keys would be dropped, so are refused."""
