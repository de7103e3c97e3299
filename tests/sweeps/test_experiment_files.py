"""Every key of an experiment file is applied or refused with the valid names; an explicit
budget is a value (hardening round 2, rows 2 and 6)."""

import dataclasses
import typing

import pytest

from mjx_skills import methods, sweep
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.sweeps.experiment_file import names
from mjx_skills.sweeps.experiments import Experiment, load_experiment

BASE = {"description": "test", "tasks": ("pick_move",), "seeds": 1, "epochs": 1}


def _experiment(**raw) -> Experiment:
    return Experiment(name="t", **{**BASE, **raw})


def _other_values(default, hint):
    """Valid-looking values of a field's type other than `default`, to try in turn."""
    if typing.get_origin(hint) is typing.Literal:
        return [v for v in typing.get_args(hint) if v != default]
    if isinstance(default, bool):
        return [not default]
    if isinstance(default, int):
        return [default + 1, default * 2, 1]
    if isinstance(default, float):
        return [round(default * 0.5, 6), round(default + 0.1, 6), 0.5, 0.25]
    if isinstance(default, tuple):
        return [tuple(type(x)(x * 2) for x in default), tuple(reversed(default))]
    return []


def _cases():
    for name, spec in methods.METHODS.items():
        for group, options in spec.options.items():
            yield from ((name, group, f.name) for f in dataclasses.fields(options))


@pytest.mark.parametrize(("method", "group", "field"), list(_cases()))
def test_every_option_key_is_applied_or_refused(method, group, field):
    """No `[options.METHOD.GROUP] field = value` is silently dropped: the cell's run takes
    the value, or the file is refused with a ValueError saying why."""
    options = methods.get(method).options[group]
    hint = typing.get_type_hints(type(options))[field]
    tried = 0
    for value in _other_values(getattr(options, field), hint):
        try:
            dataclasses.replace(options, **{field: value})
        except ValueError:
            continue  # not a valid value of this field: try the next
        tried += 1
        toml = list(value) if isinstance(value, tuple) else value
        try:
            exp = _experiment(methods=(method,), options={method: {group: {field: toml}}})
        except ValueError as err:
            assert "experiment t" in str(err)
            return
        for cell in exp.cells():
            assert getattr(cell.run_args("out").full_options()[group], field) == value
        return
    assert hint is str or not tried, f"no other valid value of {field} to try"


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        # the cases: options of a method the file does not run were dropped
        (
            {
                "methods": ("ddpg_her_sl_fast",),
                "options": {"ddpg_her_sl": {"search": {"branching": 2}}},
            },
            r"\[options.ddpg_her_sl\] sets options of a method it does not run",
        ),
        (
            {"methods": ("mpas",), "options": {"pas": {"pas": {"skill_steps": 7}}}},
            "method it does not run",
        ),
        (
            {"methods": ("ddpg_her",), "options": {"ddpg_her": {"ddpg": {"actor_lrr": 1e-3}}}},
            r"unknown \[options.ddpg_her.ddpg\] field\(s\) \['actor_lrr'\]; valid: .*actor_lr",
        ),
        (
            {"methods": ("ddpg_her",), "train": {"replay_capacity": 1e6}},
            "'replay_capacity': must be an int, got 1000000.0",
        ),
        # the same kinds elsewhere in a file
        ({"methods": ("ddpg_her",), "train": {"seeds": 3}}, r"\[train\] \['seeds'\]: set by"),
        ({"methods": ("ddpg_her",), "train": {"out": "x"}}, r"\[train\] \['out'\]: set by"),
        ({"methods": ("ddpg_her",), "train": {"progress": False}}, "--no-progress"),
        ({"methods": ("ddpg_her",), "options": {"ddpg_her": 3}}, "options.ddpg_her must be a"),
        (
            {"methods": ("ddpg_her",), "options": {"ddpg_her": {"ddpg": 3}}},
            "options.ddpg_her.ddpg must be a table of fields",
        ),
        ({"methods": ("ddpg_her", "ddpg_her")}, r"methods lists \['ddpg_her'\] more than once"),
        ({"methods": ("ddpg_her",), "tasks": ("transit", "transit")}, "tasks lists"),
        ({"methods": ()}, "methods is empty"),
        ({"methods": ("ddpg_her",), "tasks": ()}, "tasks is empty"),
        ({"methods": ("ddpg_her",), "env": {"timestepp": 0.01}}, r"valid: .*timestep"),
        ({"methods": ("ddpg_her",), "env": {"n_substeps": "30"}}, "'n_substeps': must be an int"),
        ({"methods": ("ddpg_her",), "seeds": 3.0}, "'seeds': must be an int"),
        ({"methods": "ddpg_her"}, "'methods': must be a list"),
        ({"methods": ("ddpg_her",), "libraries": ("SL2",)}, "uses a skill library"),
        (
            {
                "methods": ("ddpg_her_sl",),
                "options": {"ddpg_her_sl": {"search": {"library": "SL2"}}},
            },
            "libraries = ",
        ),
        ({"methods": ("ddpg_her",), "env": {"object_reward": True}}, "acts only where a scene"),
        (
            {
                "methods": ("ddpg_her_sl",),
                "options": {"ddpg_her_sl": {"search": {"in_order": True}}},
            },
            "--search.in-order acts only where a scene has several cubes",
        ),
        (
            {"methods": ("ddpg_her_sl_fast",), "train": {"updates_per_cycle": 7}},
            "does not read --updates-per-cycle",
        ),
        (
            {"methods": ("ddpg_her",), "options": {"ddpg_her": {"ddpg": {"hidden": [64.5]}}}},
            "'hidden': must be an int",
        ),
    ],
)
def test_a_key_that_would_be_dropped_or_mistyped_is_refused(raw, message):
    with pytest.raises(ValueError, match=message):
        _experiment(**raw)


@pytest.mark.parametrize("cls", [TrainConfig, EnvConfig])
def test_every_field_refuses_a_value_of_another_type(cls):
    hints = typing.get_type_hints(cls)
    for field in dataclasses.fields(cls):
        default = getattr(cls(), field.name)
        wrong = "x" if not isinstance(default, str) else 3
        with pytest.raises(ValueError, match=f"'{field.name}'"):
            cls(**{field.name: wrong})
        if hints[field.name] is int:
            with pytest.raises(ValueError, match=f"'{field.name}': must be an int"):
                cls(**{field.name: default + 0.5})


def test_a_library_file_refuses_keys_it_does_not_read(tmp_path, monkeypatch):
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    (tmp_path / "lib.toml").write_text(
        'description = "x"\nkind = "library"\nsamples = [200]\nseeds = 3\n'
    )
    with pytest.raises(ValueError, match=r"does not read \['seeds'\]"):
        load_experiment("lib")
    (tmp_path / "train.toml").write_text(
        'description = "x"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\nsamples = [200]\n'
    )
    with pytest.raises(ValueError, match="kind"):
        load_experiment("train")


def test_every_committed_experiment_file_is_valid():
    for name in names():
        load_experiment(name)


@pytest.mark.parametrize("flag", ["--seeds", "--epochs", "--jobs"])
@pytest.mark.parametrize("value", ["0", "-1"])
def test_an_explicit_budget_is_a_value(flag, value, tmp_path, capsys):
    """Row 6: `--seeds 0` ran the experiment's own budget (`x or default`)."""
    with pytest.raises(SystemExit):
        sweep.main(["--experiment", "smoke", flag, value, "--estimate"])
    assert flag in capsys.readouterr().err
    with pytest.raises(ValueError, match="seeds and epochs must be >= 1"):
        load_experiment("smoke").with_budget(seeds=0)
    assert (
        load_experiment("smoke").with_budget(epochs=None).epochs == load_experiment("smoke").epochs
    )


def test_a_headline_names_an_existing_baseline_and_a_target_within_its_budget(
    tmp_path, monkeypatch
):
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    body = 'description = "t"\ngroup = "beyond"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\n'
    body += 'role = "headline"\nseed = 100\n'
    cases = {
        'baseline = "nowhere"\n': "baseline 'nowhere' is no experiment; valid: ",
        "target = { level = 0.9 }\n": "target: give level and epoch",
        "target = { level = 1.5, epoch = 3 }\n": r"level must be in \(0, 1\]",
        "target = { level = 0.9, epoch = 60 }\n": r"epoch must be 1 \.\. 50",
    }
    for i, (line, message) in enumerate(cases.items()):
        (tmp_path / f"e{i}.toml").write_text(line + body)
        with pytest.raises(ValueError, match=message):
            load_experiment(f"e{i}")
    (tmp_path / "ok.toml").write_text(
        'baseline = "e0"\ntarget = { level = 0.9, epoch = 30 }\n' + body
    )
    assert load_experiment("ok").target == {"level": 0.9, "epoch": 30}


def test_a_variant_states_only_what_it_changes(tmp_path, monkeypatch):
    """`extends`: the parent's keys and tables under the variant's, merged key by key;
    description, group, baseline and target never inherited; loops and unknown parents
    named."""
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    (tmp_path / "base.toml").write_text(
        'description = "b"\ngroup = "beyond"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\n'
        'seeds = 2\nrole = "headline"\nseed = 100\ntarget = { level = 0.5, epoch = 10 }\n'
        "[train]\nenvs = 2\ncycles = 3\n[options.ddpg_her.ddpg]\nbatch_size = 64\ntau = 0.1\n"
    )
    (tmp_path / "child.toml").write_text(
        'extends = "base"\ndescription = "c"\ngroup = "ablation"\nlabel = "small"\nseeds = 3\n'
        "[train]\ncycles = 1\n[options.ddpg_her.ddpg]\ntau = 0.2\n"
    )
    child = load_experiment("child")
    assert (child.description, child.group, child.label, child.seeds) == (
        "c",
        "ablation",
        "small",
        3,
    )
    assert child.tasks == ("transit",) and child.train == {"envs": 2, "cycles": 1}
    assert child.options == {"ddpg_her": {"ddpg": {"batch_size": 64, "tau": 0.2}}}
    assert child.target == {} and load_experiment("base").target["level"] == 0.5
    (tmp_path / "nogroup.toml").write_text('extends = "base"\ndescription = "n"\n')
    with pytest.raises(ValueError, match="group must be one of"):
        load_experiment("nogroup")
    (tmp_path / "a.toml").write_text('extends = "b"\ndescription = "a"\ngroup = "beyond"\n')
    (tmp_path / "b.toml").write_text('extends = "a"\ndescription = "b"\ngroup = "beyond"\n')
    with pytest.raises(ValueError, match="extends loops: a -> b -> a"):
        load_experiment("a")
    (tmp_path / "orphan.toml").write_text('extends = "gone"\ndescription = "o"\ngroup = "beyond"\n')
    with pytest.raises(ValueError, match="unknown experiment 'gone' \\(extended by orphan\\)"):
        load_experiment("orphan")


def test_a_variant_drops_inherited_keys_with_unset(tmp_path, monkeypatch):
    """`unset`: dotted keys of the parent dropped before the variant's own are merged (the
    method's default comes back); a key the parent lacks, or unset without extends, named."""
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    (tmp_path / "base.toml").write_text(
        'description = "b"\ngroup = "beyond"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\n'
        "seeds = 2\n[train]\nenvs = 2\ncycles = 3\n[options.ddpg_her.ddpg]\ntau = 0.1\n"
    )
    head = 'extends = "base"\ndescription = "c"\ngroup = "ablation"\n'
    (tmp_path / "child.toml").write_text(
        head + 'unset = ["seeds", "train.cycles", "options.ddpg_her.ddpg.tau"]\n'
    )
    child, base = load_experiment("child"), load_experiment("base")
    assert child.train == {"envs": 2} and child.options == {} and base.options != {}
    assert child.seeds != 2 and base.seeds == 2
    (tmp_path / "again.toml").write_text(head + 'unset = ["train.envs"]\n[train]\nenvs = 4\n')
    assert load_experiment("again").train == {"envs": 4, "cycles": 3}
    (tmp_path / "typo.toml").write_text(head + 'unset = ["train.env"]\n')
    with pytest.raises(ValueError, match="unset 'train.env': the file it extends has no such key"):
        load_experiment("typo")
    (tmp_path / "twice.toml").write_text(head + 'unset = ["seeds", "seeds"]\n')
    with pytest.raises(ValueError, match="unset names a key twice"):
        load_experiment("twice")
    (tmp_path / "alone.toml").write_text('description = "a"\ngroup = "beyond"\nunset = ["seeds"]\n')
    with pytest.raises(ValueError, match="unset drops inherited keys, so it needs extends"):
        load_experiment("alone")


def test_a_variant_names_its_own_cells_and_says_what_it_is(tmp_path, monkeypatch):
    """A variant never takes its parent's label (its cells would take the parent's names);
    a file without a description, or whose baseline is itself, is refused by name."""
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    body = 'group = "beyond"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\n'
    (tmp_path / "p.toml").write_text(f'description = "p"\nlabel = "parent"\n{body}')
    (tmp_path / "c.toml").write_text('extends = "p"\ndescription = "c"\ngroup = "ablation"\n')
    assert load_experiment("p").cells()[0].name != load_experiment("c").cells()[0].name
    (tmp_path / "nodesc.toml").write_text(body)
    with pytest.raises(ValueError, match="description is missing"):
        load_experiment("nodesc")
    (tmp_path / "self.toml").write_text(
        f'description = "s"\nbaseline = "self"\nrole = "headline"\nseed = 100\n{body}'
    )
    (tmp_path / "tuned.toml").write_text(f'description = "t"\nbaseline = "p"\n{body}')
    with pytest.raises(ValueError, match='read for role = "headline" only'):
        load_experiment("tuned")
    (tmp_path / "up.toml").write_text(f'extends = "../p"\ndescription = "u"\n{body}')
    with pytest.raises(ValueError, match="extends must name an experiment file"):
        load_experiment("up")
    with pytest.raises(ValueError, match="baseline names the experiment itself"):
        load_experiment("self")
