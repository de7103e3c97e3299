"""sweep --list: every experiment grouped by what it is for, with its stored cells; a file
that cannot be read is named and the rest still listed."""

import pytest

from mjx_skills import sweep
from mjx_skills.sweeps.experiment_file import names
from mjx_skills.sweeps.experiments import load_experiment


def test_the_list_groups_every_experiment_by_what_it_is_for(capsys):
    from mjx_skills.sweeps.experiment_file import GROUPS

    sweep.main(["--list"])
    lines = capsys.readouterr().out.splitlines()
    headings = [line.split(":")[0] for line in lines if not line.startswith(" ")]
    assert headings == [g for g in GROUPS if any(load_experiment(n).group == g for n in names())]
    listed = [line.split()[0] for line in lines if line.startswith(" ")]
    assert sorted(listed) == names()
    under, group = {}, None
    for line in lines:
        if not line.startswith(" "):
            group = line.split(":")[0]
        else:
            under[line.split()[0]] = (group, line.split()[1])
    assert under["fig6_3"] == ("thesis", "16/16")
    assert under["headline_fast"][0] == "beyond" and under["smoke"][0] == "diagnostic"


def test_the_list_counts_a_library_sweep_stored_when_its_table_holds_the_rows(tmp_path):
    """A library sweep's libraries are not stored, their Table 5.1 rows are: each sample
    count with rows in the committed NAME.csv counts as stored."""
    from mjx_skills.sweeps.listing import cost_text

    exp = load_experiment("table5_1")  # samples 10k and 30k
    store = tmp_path / "cells"
    assert cost_text(exp, 1, store) == (0, "-")
    (tmp_path / "table5_1.csv").write_text("skill,samples\ntransit,10000\ngrasp,10000\n")
    assert cost_text(exp, 1, store) == (1, "-")
    (tmp_path / "table5_1.csv").write_text("skill,samples\ntransit,10000\ntransit,30000\n")
    assert cost_text(exp, 1, store) == (2, "done")


def test_an_experiment_file_must_say_what_it_is_for(tmp_path, monkeypatch):
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    body = 'description = "t"\ntasks = ["transit"]\nmethods = ["ddpg_her"]\n'
    (tmp_path / "a.toml").write_text(body)
    with pytest.raises(ValueError, match="group must be one of thesis, beyond, baseline"):
        load_experiment("a")
    (tmp_path / "b.toml").write_text(body + 'group = "misc"\n')
    with pytest.raises(ValueError, match="unknown group 'misc'; valid: thesis"):
        load_experiment("b")
    (tmp_path / "c.toml").write_text(body + 'group = "diagnostic"\n')
    assert load_experiment("c").group == "diagnostic"


def test_the_list_names_a_file_it_cannot_read_and_lists_the_rest(tmp_path, monkeypatch, capsys):
    from mjx_skills.sweeps import experiment_file

    monkeypatch.setattr(experiment_file, "EXPERIMENTS", tmp_path)
    body = 'group = "diagnostic"\nmethods = ["ddpg_her"]\n'
    (tmp_path / "good.toml").write_text(f'description = "g"\ntasks = ["transit"]\n{body}')
    (tmp_path / "mine.toml").write_text(f'description = "m"\ntasks = ["lift"]\n{body}')
    sweep.main(["--list", "--store", str(tmp_path / "store")])
    out = capsys.readouterr().out
    assert "mine: cannot be read: " in out and "unknown task 'lift'" in out and "--import" in out
    assert "  good " in out
