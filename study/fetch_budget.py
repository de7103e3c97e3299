"""The learners' gradient budget beside the published DDPG+HER figures: transitions sampled
per env step (batch size x gradient updates per env step). Ours is read from a DDPG+HER
experiment's config; the published learner's from the data file's settings
(`study/published/fetch_her.toml`: `batch_size` and `env_steps_per_update`, read from the
source's configuration). A difference the Fetch section states where we fall short, not a
cause it has measured."""

from __future__ import annotations

from mjx_skills.analysis import stats
from mjx_skills.envs.registry import ENVS
from mjx_skills.sweeps.experiment_file import names
from mjx_skills.sweeps.experiments import load_experiment


def ours(name: str) -> tuple[float, int, int, int] | None:
    """(transitions per env step, batch, updates per cycle, env steps per cycle) of the
    DDPG+HER cell of experiment `name` (a label: its experiment before any colon); None
    for another method or an unknown experiment."""
    name = name.split(":")[0]
    if name not in names():
        return None
    exp = load_experiment(name)
    cell = exp.cells()[0]
    if cell.method != "ddpg_her":
        return None
    args = cell.run_args(out="", progress=False)
    batch = args.full_options()["ddpg"].batch_size
    length = args.env.episode_length or ENVS[cell.task].default_episode_length
    steps = args.train.envs * length  # one cycle: an episode of each env, then the updates
    updates = args.train.updates_per_cycle
    return batch * updates / steps, batch, updates, steps


def theirs(figure: dict) -> float | None:
    """Transitions per env step of a published figure's learner; None if the file has none."""
    if "batch_size" not in figure:
        return None
    return figure["batch_size"] / figure["env_steps_per_update"]


def sentence(name: str, figure: dict) -> str:
    """' Per env step, ...': our cell's budget beside the published learner's, or ''."""
    mine, published = ours(name), theirs(figure)
    if mine is None or published is None:
        return ""
    per, batch, updates, steps = mine
    return (
        f" Per env step, {name}'s learner samples {per:.0f} transitions ({updates} updates "
        f"of {batch} per {steps} env steps); the published one ({figure['source']}) samples "
        f"{published:.0f} "
        f"(batch {figure['batch_size']}, an update every {figure['env_steps_per_update']} "
        f"env steps), {published / per:.0f} times as many: a difference not yet tested as "
        "the cause."
    )


def best_plain(mine: list, figure: dict) -> str:
    """' Our best DDPG+HER cell there, ...': of cells `mine` ((label, env steps per epoch,
    (seeds, epochs) success) on one task), the DDPG+HER one with the highest last-5 mean,
    where it ends, and its budget beside the published learner's (`sentence`); '' if none."""
    plain = [(name, per, s) for name, per, s in mine if ours(name) is not None]
    if not plain:
        return ""
    name, per, s = max(plain, key=lambda m: stats.summarize(m[2]).last[0])
    return (
        f" Our best DDPG+HER cell there, {name}, ends at a last-5 mean of "
        f"{stats.summarize(s).last[0]:.2f} after {s.shape[1] * per:,} env steps."
        + sentence(name, figure)
    )
