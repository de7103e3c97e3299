"""build_library resumes a skill's training run in its work directory only where the skill's
env is as it was when the run trained: an edited env trains anew, in a new run."""

from __future__ import annotations

import json
import types
from pathlib import Path

import numpy as np

from mjx_skills import build_library
from mjx_skills.config import LibraryConfig, build_config
from mjx_skills.skills import registry, work_runs


def test_a_build_resumes_only_a_run_of_the_same_skill_env(tmp_path, monkeypatch, capsys):
    config = LibraryConfig(transit_epochs=2)
    work, resumed = tmp_path / "work", []

    def trained(args):  # a finished run, made where the runner would make it
        resumed.append(args.resume)
        fresh = work / "transit" / "ddpg_her" / f"run{len(resumed)}"
        run_dir = fresh if args.resume is None else Path(args.resume)
        run_dir.mkdir(parents=True, exist_ok=True)
        epochs = args.extend_to or (args.train.epochs if args.resume is None else None)
        if epochs is not None:
            (run_dir / "config.json").write_text(json.dumps({"train": {"epochs": epochs}}))
        epochs = work_runs.planned_epochs(run_dir)
        rows = [{"epoch": e, "seed": 0, "eval_success": 0.0} for e in range(1, epochs + 1)]
        (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
        return run_dir, types.SimpleNamespace(agent={"w": np.zeros((1, 2))})

    monkeypatch.setattr(build_library, "train_and_keep", trained)
    first = build_library.train_skill("transit", config, work, progress=False)[1]
    again = build_library.train_skill("transit", config, work, progress=False)[1]
    assert resumed == [None, str(first)] and again == first

    monkeypatch.setattr(registry, "env_digest", lambda name: "edited")
    anew = build_library.train_skill("transit", config, work, progress=False)[1]
    assert resumed[-1] is None and anew != first
    assert "trained by another or unrecorded env" in capsys.readouterr().out
    # The edited env's run is the one resumed from now on; the first is kept, not reused.
    build_library.train_skill("transit", config, work, progress=False)
    assert resumed[-1] == str(anew) and (first / "metrics.jsonl").exists()
    # A run that records no env (made before the record, or killed before its end) is not
    # resumed either: nothing says which env trained it.
    (anew / work_runs.SKILL_RECORD).unlink()
    build_library.train_skill("transit", config, work, progress=False)
    assert resumed[-1] is None and "unrecorded" in capsys.readouterr().out


def test_a_build_of_more_epochs_trains_the_run_on_and_one_of_fewer_trains_anew(
    tmp_path, monkeypatch, capsys
):
    work, calls = tmp_path / "work", []

    def trained(args):
        calls.append((args.resume, args.extend_to))
        run_dir = (
            Path(args.resume) if args.resume else work / "transit" / "ddpg_her" / f"r{len(calls)}"
        )
        run_dir.mkdir(parents=True, exist_ok=True)
        epochs = args.extend_to or args.train.epochs
        (run_dir / "config.json").write_text(json.dumps({"train": {"epochs": epochs}}))
        rows = [{"epoch": e, "seed": 0} for e in range(1, epochs + 1)]
        (run_dir / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
        return run_dir, types.SimpleNamespace(agent={"w": np.zeros((1, 2))})

    monkeypatch.setattr(build_library, "train_and_keep", trained)
    first = build_library.train_skill("transit", LibraryConfig(transit_epochs=2), work, False)[1]
    # 4 epochs: the 2-epoch run trains on (it once stopped at 2 and the build said
    # 'interrupted', every time it ran)
    on = build_library.train_skill("transit", LibraryConfig(transit_epochs=4), work, False)[1]
    assert calls[-1] == (str(first), 4) and on == first
    assert work_runs.planned_epochs(first) == 4
    # 3 epochs: the 4-epoch run cannot be cut back, so a new run trains
    anew = build_library.train_skill("transit", LibraryConfig(transit_epochs=3), work, False)[1]
    assert calls[-1] == (None, None) and anew != first
    assert "trains 4 epochs, more than 3; training anew" in capsys.readouterr().out


def test_the_push_library_builds_with_still_inputs_left_out_of_its_nets():
    """A dimension constant in the collected data (velocities of starts placed at rest) is
    left out with still='ignore', the push library's build setting, unless the command sets
    the field itself; 'floor' (the default) divides it by NORM_FLOOR."""
    from mjx_skills.skills import fit

    x = np.stack([np.linspace(0.0, 1.0, 50), np.zeros(50)], axis=1)
    w = np.ones(50, np.float32)
    _, floor = fit.standardize(x, w)
    _, ignore = fit.standardize(x, w, "ignore")
    assert floor[1] == np.float32(fit.NORM_FLOOR) and ignore[1] == np.float32(fit.IGNORED)
    assert floor[0] == ignore[0] > 0.2  # a varying dimension is normalised alike
    assert 0.01 / ignore[1] < 1e-6 < 0.01 / floor[1]  # a small velocity: nothing, or 10 stds

    assert build_config("SL_fetch_push", LibraryConfig()).still_inputs == "ignore"
    assert build_config("SL1_fetch", LibraryConfig()).still_inputs == "floor"
    mine = LibraryConfig(still_inputs="ignore", samples=300)
    assert build_config(None, mine) == mine
