"""A skill registered from the user's own module (`skills.registry.register_skill`,
examples/push_skill/): the library, the search, PAS's stop rule, the stall memory and
build_library read it from its definition; bad registrations are named."""

import dataclasses
import importlib.util
import runpy
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills import build_library
from mjx_skills.config import DDPGConfig, LibraryConfig, SearchConfig
from mjx_skills.envs import registry as envs
from mjx_skills.envs.baxter import OBS_OBJECT
from mjx_skills.skills import library, lookahead, registry, run_provenance, stalls, table
from mjx_skills.skills.library import DEFAULT_DIR

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "examples" / "push_skill" / "push.py"
FOUR = ("transit", "grasp", "transfer", "push")


@pytest.fixture
def push(monkeypatch):
    """The example registered into copies of the registries (undone after the test)."""
    monkeypatch.setattr(registry, "SKILLS", dict(registry.SKILLS))
    monkeypatch.setattr(registry, "LIBRARIES", dict(registry.LIBRARIES))
    monkeypatch.setattr(envs, "ENVS", dict(envs.ENVS))
    monkeypatch.setattr(library, "_ENV_CACHE", {})  # no env of another registration kept
    return runpy.run_path(str(PUSH))


def test_bad_registrations_are_named(push):
    Push, propose = push["Push"], push["propose_push"]
    skill = registry.Skill(name="shove", env=Push, propose=propose)
    with pytest.raises(ValueError, match="'push': the name is registered already"):
        registry.register_skill(dataclasses.replace(skill, name="push"))
    with pytest.raises(ValueError, match="start 'sometimes'; valid: empty, held, any"):
        registry.register_skill(dataclasses.replace(skill, start="sometimes"))
    with pytest.raises(ValueError, match="lacks goal_from_param, terminated"):
        bare = type("Bare", (), {"param_dim": 2, "state_dims": (), "memory_dims": ()})
        registry.register_skill(dataclasses.replace(skill, env=bare))
    with pytest.raises(ValueError, match="param_dim 4; valid: 1 to 3"):
        registry.register_skill(
            dataclasses.replace(skill, env=type("W", (Push,), {"param_dim": 4}))
        )
    with pytest.raises(ValueError, match="propose must be callable"):
        registry.register_skill(dataclasses.replace(skill, propose=None))
    with pytest.raises(
        ValueError,
        match="unknown skill 'pull'; valid: transit, grasp, transfer, fetch_transit, "
        "fetch_grasp, fetch_transfer, fetch_approach, fetch_push_block, push",
    ):
        registry.register_library("SL_pull", ("transit", "pull"))
    with pytest.raises(ValueError, match="each skill once"):
        registry.register_library("SL_twice", ("push", "push"))
    with pytest.raises(ValueError, match="taken"):
        registry.register_library("SL1", ("push",))
    with pytest.raises(ValueError, match=r"unknown library 'SL9' \(--search.library"):
        registry.library_skills("SL9")
    with pytest.raises(ValueError, match="env must be a class"):
        registry.register_skill(dataclasses.replace(skill, env=Push()))
    for epochs in (0, -3, "fit_epoch", True):
        with pytest.raises(ValueError, match=f"epochs {epochs!r}; valid: a whole number"):
            registry.register_skill(dataclasses.replace(skill, epochs=epochs))
    with pytest.raises(ValueError, match="thesis_cm 'bad'"):
        registry.register_skill(dataclasses.replace(skill, thesis_cm="bad"))
    with pytest.raises(ValueError, match="imported twice"):
        registry.register_skill(dataclasses.replace(skill, name="push"))
    registry.register_skill(
        dataclasses.replace(
            skill, name="fetch_shove", env=type("F", (Push,), {"robot_name": "fetch"})
        )
    )
    with pytest.raises(ValueError, match=r"several robots \(\['baxter', 'fetch'\]\)"):
        registry.register_library("SL_mixed", ("push", "fetch_shove"))
    assert "shove" not in registry.SKILLS and "shove" not in envs.ENVS  # nothing half-registered
    assert registry.library_skills("SL_push") == FOUR
    assert registry.skills_of("baxter") == FOUR
    fetch = (*registry.LIBRARIES["SL1_fetch"], *registry.LIBRARIES["SL_fetch_push"])
    assert registry.skills_of("fetch") == (*fetch, "fetch_shove")


def test_build_library_names_the_skills_it_can_build(push, monkeypatch):
    assert build_library.SkillsArgs().names() == FOUR
    assert build_library.SkillsArgs(skills=("push", "grasp")).names() == ("push", "grasp")
    with pytest.raises(ValueError, match="from the baxter skills transit, grasp, transfer, push"):
        build_library.SkillsArgs(skills=("push", "fly")).names()
    fetch = build_library.SkillsArgs(robot="fetch")  # every Fetch skill: two scenes
    with pytest.raises(ValueError, match=r"several scenes \(pick_and_place, push\); .* --library"):
        fetch.names()
    assert fetch.directory() == Path("experiments/skill_library_fetch")
    assert build_library.SkillsArgs().directory() == Path("experiments/skill_library")
    monkeypatch.setitem(envs.ROBOTS, "ur5", object)
    with pytest.raises(ValueError, match="--robot ur5: no skill is registered for it"):
        build_library.SkillsArgs(robot="ur5").names()


def _states(n: int) -> tuple[jax.Array, jax.Array]:
    """n pick_move starts (empty gripper) and their goals."""
    env = envs.make("pick_move", physics="native")
    s = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), n))
    return s.obs, s.desired_goal


def test_the_search_proposes_push_goals_on_the_table_towards_the_task_goal(push):
    lib = library.empty_like(FOUR, DDPGConfig(), LibraryConfig(), memory_size=2)
    cfg = SearchConfig(branching=64, height=1, object_goal_noise=0.01)
    obs, goal = _states(8)
    draws = lookahead.level_draws(
        lookahead.draw_edges(lookahead.env_keys(jax.random.PRNGKey(1), 8), cfg, 4), 0, 64
    )
    skill, goals, ok = lookahead.sample_edges(lib, cfg, obs, goal, draws)
    skill, goals = np.asarray(skill), np.asarray(goals)
    pushes = skill == FOUR.index("push")
    assert np.asarray(ok).all() and {0, 1, 3} == set(np.unique(skill))  # empty grip: no transfer
    obj = np.asarray(obs)[:, None, OBS_OBJECT].repeat(64, 1)[pushes]
    step = goals[pushes] - obj
    toward = (np.asarray(goal)[:, None].repeat(64, 1)[pushes] - obj)[:, :2]
    np.testing.assert_allclose(step[:, 2], 0.0, atol=1e-6)  # along the table
    assert (np.linalg.norm(step[:, :2], axis=-1) <= push["REACH"] + 0.015).all()
    assert (np.sum(step[:, :2] * toward, -1) > 0).mean() > 0.9  # towards the task goal
    allowed = np.asarray(library.allowed_skills(FOUR, jnp.array([False, True])))
    assert allowed.tolist() == [[True, True, False, True], [False, False, True, False]]
    assert list(np.asarray(stalls.moving(FOUR, jnp.arange(4)))) == [True, False, True, True]
    assert list(np.asarray(library.carries_object(FOUR))) == [False, False, True, False]


def test_a_library_with_the_push_skill_is_built_loaded_and_searched(push, tmp_path, monkeypatch):
    """build_library --skills push (1 epoch, 100 runs): trained, collected and fitted as the
    thesis's skills are; the loaded library serves the search; no thesis figure for push."""
    monkeypatch.setitem(
        registry.SKILLS, "push", dataclasses.replace(registry.SKILLS["push"], epochs=1)
    )
    tiny = LibraryConfig(samples=100, collect_envs=100, fit_epochs=2, skill_eval_episodes=4)
    args = build_library.SkillsArgs(
        config=tiny, skills=("push",), out=str(tmp_path / "lib"), progress=False
    )
    out = build_library.build(args)
    manifest = library.read_manifest(out)
    assert list(manifest["models"]) == ["push"] and manifest["samples"]["push"]["total"] == 100
    assert manifest["dims"]["push"]["param_dim"] == 2
    length = envs.make("push").episode_length  # one epoch of 16 episodes; runs of <= length
    assert manifest["env_steps"]["train"] == {"push": 16 * length}
    assert 0 < manifest["env_steps"]["collect"]["push"] <= 100 * length
    # its training run's wall: within this process's time for the skill (training + eval)
    assert 0 < manifest["train_wall_s"]["push"] <= manifest["timings_s"]["train_push_s"] + 0.1
    lib, _ = library.load(out)
    assert lib.names == ("push",)
    registry.register_library("push_only", ("push",))
    obs, goal = _states(4)
    found = lookahead.search(
        library.subset(lib, "push_only"),
        SearchConfig(),
        envs.make("pick_move"),
        obs,
        goal,
        jax.random.PRNGKey(0),
    )
    assert (
        np.asarray(found.skill).tolist() == [0, 0, 0, 0]
        and np.isfinite(np.asarray(found.goal)).all()
    )
    (row,) = table.table_rows(out)
    assert row["skill"] == "push" and row["thesis_memory_cm"] == "" and row["thesis_model_cm"] == ""


def test_a_library_name_or_a_built_library_without_its_skills_is_refused_before_a_run(push):
    """`--search.library SL_push` against the committed three-skill library, or an unknown
    library name, is refused by `methods.check_task` (before any run directory), naming the
    option and what to build."""
    from mjx_skills import methods

    with pytest.raises(
        ValueError, match="--search.library SL_push needs the skills .*without push"
    ):
        methods.check_task("ddpg_her_sl", "pick_move", {"search": SearchConfig(library="SL_push")})
    with pytest.raises(ValueError, match=r"unknown library 'SL4' \(--search.library"):
        methods.check_task("ddpg_her_sl", "pick_move", {"search": SearchConfig(library="SL4")})
    methods.check_task("ddpg_her_sl", "pick_move", {"search": SearchConfig(library="SL2")})


def test_a_proposer_of_the_wrong_shape_is_named(push, monkeypatch):
    flat = lambda env, cfg, edges: edges.obs[:, :3]  # noqa: E731  (N, 3), not (N, b, 3)
    monkeypatch.setitem(
        registry.SKILLS, "push", dataclasses.replace(registry.SKILLS["push"], propose=flat)
    )
    lib = library.empty_like(FOUR, DDPGConfig(), LibraryConfig(), memory_size=2)
    cfg = SearchConfig(height=1)
    obs, goal = _states(2)
    draws = lookahead.level_draws(
        lookahead.draw_edges(lookahead.env_keys(jax.random.PRNGKey(1), 2), cfg, 4), 0, cfg.branching
    )
    with pytest.raises(
        ValueError, match=r"skill 'push': its proposer returned goals of shape \(2, 3\)"
    ):
        lookahead.sample_edges(lib, cfg, obs, goal, draws)


def test_a_result_with_the_users_skills_depends_on_their_definitions(push, monkeypatch):
    """A stored cell's definition records a user library's skills (settings and a digest of
    the proposer's and env's source): a changed proposer is a different definition; the
    thesis's libraries record nothing more (every stored cell is still found)."""
    assert registry.fingerprint("SL1") is None
    before = registry.fingerprint("SL_push")
    assert set(before) == set(FOUR) and before["push"]["start"] == "'empty'"
    other = dataclasses.replace(registry.SKILLS["push"], propose=lambda env, cfg, e: e.noise)
    monkeypatch.setitem(registry.SKILLS, "push", other)
    assert registry.fingerprint("SL_push")["push"]["propose"] != before["push"]["propose"]
    config = {"options": {"search": {"library": "SL_push", "library_dir": str(DEFAULT_DIR)}}}
    assert run_provenance.library_provenance(config)["skills"] == registry.fingerprint("SL_push")
    config["options"]["search"]["library"] = "SL1"
    assert set(run_provenance.library_provenance(config)) == {"commit", "scenes"}


def test_an_edited_base_class_of_a_users_skill_env_is_a_different_definition(
    push, monkeypatch, tmp_path
):
    """The env's digest covers its base classes of the user's own code (not the package's,
    which no stored result records): the same subclass over an edited base differs; the
    same source loaded from another file does not."""

    def env_with(reach: float) -> type:
        name = f"users_skill_{len(list(tmp_path.iterdir()))}"
        path = tmp_path / f"{name}.py"
        path.write_text(f"class Base:\n    reach = {reach}\n\n\nclass Mine(Base):\n    pass\n")
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        monkeypatch.setitem(sys.modules, name, module)
        spec.loader.exec_module(module)
        return module.Mine

    def digest(env: type) -> str:
        monkeypatch.setitem(
            registry.SKILLS, "push", dataclasses.replace(registry.SKILLS["push"], env=env)
        )
        return registry.fingerprint("SL_push")["push"]["env"]

    first = digest(env_with(0.1))
    assert digest(env_with(0.1)) == first
    assert digest(env_with(0.2)) != first
