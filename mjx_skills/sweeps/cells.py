"""Finished sweep cells kept with the definition that made them, so results are reused only
when the same definition would make them again.

A cell's definition is the run's whole config (method, train, env and every option group),
without what does not change results (output directory, progress bar, checkpoint period),
plus the provenance of the skill library it searched with (its git commit and scenes'
digest): a rebuilt library makes new cells. The store, `experiments/results/cells/CELL/`,
is committed: `definition.json` and the run's `metrics.jsonl` (one line per epoch per seed).
A sweep takes a stored cell whose definition matches instead of training it, so an
interrupted campaign picks up from the committed cells on a fresh clone; a stored cell of
the same name and another definition is refused with the fields that differ. A run
directory is taken for a cell under the same rule: its config.json and the library it
started with (`runner.LIBRARY`, recorded when the run began, not when it is saved) must
match, so a run trained before a skill's code changed is never stored under the new code.

`checksums.json` (written last, before the cell's directory is renamed into place) holds
the SHA-256 of the cell's other files; a stored cell is verified against it whenever it is
taken or read, and a damaged or missing file is refused, naming the cell and the file. A
cell stored before checksums were recorded is used with a warning.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
import types
from pathlib import Path
from typing import Any

from mjx_skills.core.files import read_json, read_jsonl, sha256_file, write_json_atomic
from mjx_skills.core.paths import CHECKOUT

STORE = CHECKOUT / "experiments" / "results" / "cells"
"""The committed store of the checkout the package runs from (`sweep --store` for another)."""
VOLATILE = {
    ("train", "out"),
    ("train", "progress"),
    ("train", "checkpoint_every"),
    ("train", "track"),
    ("train", "wandb_project"),
}
"""Config fields that do not change a run's results."""
FILES = ("definition.json", "metrics.jsonl", "made_by.json")
"""A stored cell's files, each with its SHA-256 in its `CHECKSUMS`."""
CHECKSUMS = "checksums.json"
log = logging.getLogger(__name__)


def run_config(args) -> dict[str, Any]:
    """A `runner.RunArgs` as config.json reads back (tuples as lists; version excluded)."""
    from mjx_skills.training.runner import config_dict

    return json.loads(json.dumps(config_dict(args)))


def _results_part(config: dict[str, Any]) -> dict[str, Any]:
    """`config` without the volatile fields and the version."""
    out = {k: v for k, v in config.items() if k != "version"}
    for group, field in VOLATILE:
        out[group] = {k: v for k, v in out.get(group, {}).items() if k != field}
    return out


def definition(cell) -> dict[str, Any]:
    """What makes a cell's results: its run config and its library's provenance."""
    from mjx_skills.skills.run_provenance import library_provenance

    config = _results_part(run_config(cell.run_args(out="", progress=False)))
    return {"config": config, "library": library_provenance(config)}


def defaults(method: str) -> dict[str, Any]:
    """The config of a run of `method` as JSON reads back, every field at its default: the
    value a migrated config (`training.schema.migrate`) that lacks a field was made at."""
    from mjx_skills import methods
    from mjx_skills.config import EnvConfig, TrainConfig

    spec = methods.get(method)
    groups = {name: dataclasses.asdict(opt) for name, opt in spec.options.items()}
    raw = {
        "train": dataclasses.asdict(TrainConfig()),
        "env": dataclasses.asdict(EnvConfig()),
        "options": groups,
    }
    return json.loads(json.dumps(raw))


def changes(old: Any, new: Any, path: str = "", default: Any = None) -> list[tuple[str, Any, Any]]:
    """(dotted path, old value, new value) wherever two JSON-like values differ. A key that
    `old` lacks and `new` holds at its value in `default` (a config field added since `old`
    was written, at the default that keeps the earlier behaviour) is no difference."""
    if isinstance(old, dict) and isinstance(new, dict):
        default = default if isinstance(default, dict) else {}
        return [
            d
            for k in sorted(set(old) | set(new))
            if k in old or k not in default or new.get(k) != default[k]
            for d in changes(old.get(k), new.get(k), f"{path}.{k}" if path else k, default.get(k))
        ]
    return [] if old == new else [(path, old, new)]


def differences(old: Any, new: Any, path: str = "", default: Any = None) -> list[str]:
    """`changes` as 'path: old != new' lines, the form refusals print."""
    return _lines(changes(old, new, path, default))


def _lines(diff: list[tuple[str, Any, Any]]) -> list[str]:
    return [f"{p}: {o!r} != {n!r}" for p, o, n in diff]


def _config_differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """`differences` of two configs, both migrated to today's layout (`training.schema`), but
    in the options the new one's method does not read (`Method.unread_now`: they cannot
    change its results)."""
    from mjx_skills.training.schema import migrate

    old, new = migrate(old), migrate(new)
    unread = _unread(new)
    diff = changes(old, new, default=defaults(new["method"]))
    return _lines([d for d in diff if d[0] not in unread])


def _unread(config: dict[str, Any]) -> set[str]:
    """Dotted paths ('options.fast.proposals', 'train.updates_per_cycle') of the fields that
    `config`'s method does not read with its option groups."""
    from mjx_skills import methods

    spec = methods.get(config["method"])
    groups = {g: types.SimpleNamespace(**config["options"][g]) for g in spec.options}
    return {
        f"options.{path}" if path.split(".")[0] in spec.options else path
        for path in spec.unread_now(groups)
    }


def run_differences(run_dir: Path, cell) -> list[str]:
    """How a run directory differs from what `cell` would write ([] = same): its config.json,
    and the library it started with (`runner.LIBRARY`; a run that searched with a library but
    recorded none started before runs recorded it, and is a difference)."""
    from mjx_skills.training.runner import LIBRARY

    new = definition(cell)
    diff = _config_differences(
        _results_part(read_json(Path(run_dir) / "config.json")), new["config"]
    )
    if new["library"] is None:
        return diff
    if not (Path(run_dir) / LIBRARY).exists():
        return [*diff, "library: not recorded by the run (it started before runs recorded it)"]
    return diff + differences(read_json(Path(run_dir) / LIBRARY), new["library"], "library")


def stored(cell, store: Path = STORE) -> Path | None:
    """The stored metrics of `cell` if its definition matches; None if not stored. A stored
    cell of the same name and another definition raises ValueError naming the fields; a
    damaged one (`verify`) raises ValueError naming the file."""
    where = store / cell.name
    if not (where / "definition.json").exists() and not (where / CHECKSUMS).exists():
        return None
    verify(where)
    old, new = read_json(where / "definition.json"), definition(cell)
    diff = _config_differences(old["config"], new["config"])
    diff += differences(old["library"], new["library"], "library")
    if diff:
        raise ValueError(
            f"the stored cell {where} was made by another definition ({'; '.join(diff[:6])}); "
            f"delete that directory to train the cell again, or change the cell's name"
        )
    return where


def save(cell, run_dir: Path, store: Path = STORE) -> Path:
    """Keep a finished cell's metrics beside its definition (written whole or not at all).
    The library part is the one the run recorded when it started (`runner.LIBRARY`), so a
    skill's code changed while it trained makes a stored cell that the new code refuses."""
    from mjx_skills.skills.library import provenance
    from mjx_skills.training.runner import LIBRARY

    where = store / cell.name
    tmp = where.with_name(f".{where.name}.partial")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    shutil.copyfile(Path(run_dir) / "metrics.jsonl", tmp / "metrics.jsonl")
    meta = {**definition(cell), "made_by": provenance()}
    if (Path(run_dir) / LIBRARY).exists():
        meta["library"] = read_json(Path(run_dir) / LIBRARY)
    (tmp / "definition.json").write_text(
        json.dumps({k: meta[k] for k in ("config", "library")}, indent=1, sort_keys=True)
    )
    (tmp / "made_by.json").write_text(json.dumps(meta["made_by"], indent=1))
    write_checksums(tmp)
    shutil.rmtree(where, ignore_errors=True)
    tmp.rename(where)
    return where


FIX = "restore it (git checkout) or delete the directory to train the cell again"


def write_checksums(where: Path) -> Path:
    """Record the SHA-256 of a stored cell's `FILES` in its `CHECKSUMS` (atomically)."""
    sums = {name: sha256_file(where / name) for name in FILES}
    return write_json_atomic(where / CHECKSUMS, sums, indent=1, sort_keys=True)


def verify(where: Path, names: tuple[str, ...] = FILES) -> None:
    """Check a stored cell's files `names` against its `CHECKSUMS`. Raises ValueError naming
    the cell directory and the file that is missing or damaged; a cell without checksums
    (stored before they were recorded) passes with a warning."""
    if not (where / CHECKSUMS).exists():
        why = f"has no {CHECKSUMS} (stored before checksums were recorded)"
        log.warning("stored cell %s %s: its files are used unverified", where, why)
        return
    sums = read_json(where / CHECKSUMS)
    fix = FIX
    for name in names:
        if not (where / name).exists():
            raise ValueError(f"the stored cell {where} is damaged: {name} is missing; {fix}")
        if sums.get(name) != sha256_file(where / name):
            raise ValueError(
                f"the stored cell {where} is damaged: {name} does not match its checksum in "
                f"{CHECKSUMS}; {fix}"
            )


def read_stored_metrics(where: Path) -> list[dict]:
    """A stored cell's metrics.jsonl rows, verified first (`verify`: ValueError naming the
    cell and file when damaged)."""
    verify(where, ("metrics.jsonl",))
    try:  # a stored cell is copied whole: a cut line is damage, even without checksums
        return read_jsonl(where / "metrics.jsonl", whole=True)
    except ValueError as err:
        raise ValueError(f"the stored cell {where} is damaged: {err}; {FIX}") from None
