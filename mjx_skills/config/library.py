"""Building the skill library (`LibraryConfig`)."""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

from mjx_skills.config.checks import _check, check_numbers


@dataclasses.dataclass(frozen=True)
class LibraryConfig:
    """Building the skill library: skill training budgets, data collection, model fits
    (docs/skill_library.md); the thesis's values are given where ours differ."""

    transit_epochs: int = 20
    """DDPG+HER epochs of the transit skill."""
    grasp_epochs: int = 100
    """DDPG+HER epochs of the grasp skill (trained with held starts, below)."""
    transfer_epochs: int = 100
    """DDPG+HER epochs of the transfer skill."""
    grasp_held_start_prob: float = 0.5
    """Share of grasp training episodes starting with the cube held (original code: 0.5)."""
    skill_eval_episodes: int = 200
    """Fresh episodes from each skill's true start distribution that measure its success."""
    samples: int = 10_000
    """(start, goal) pairs run per skill for the models and memories (thesis: 100,000)."""
    own_start_share: float = 0.5
    """Share of those starts from the skill's own start distribution; the rest evenly from
    the other skills', where the search and PAS will ask and the skill fails."""
    collect_envs: int = 1000
    """Skill runs simulated together during collection."""
    model_hidden: tuple[int, ...] = (256, 256, 256)
    """Hidden widths of the coarse dynamics model (thesis: 3 x 1000)."""
    model_lr: float = 1e-3
    """Adam learning rate of the coarse model (thesis: 1e-5, for 3 x 1000 units)."""
    anchor: Literal["start", "goal"] = "goal"
    """What coarse predictions and recalled memories are measured from: 'start' (the thesis:
    the change from the start) or 'goal' (positions relative to the skill's goal, where a
    successful run ends). Table 5.1 for both: docs/results.md."""
    still_inputs: Literal["floor", "ignore"] = "floor"
    """Input dimensions of a skill's classifier and model that do not vary in its collected
    data (std below `skills.fit.NORM_FLOOR`, e.g. velocities where every start is placed at
    rest): 'floor' divides them by NORM_FLOOR (the original), so that a small velocity met in
    a task reads as many stds off and can throw the nets off; 'ignore' leaves them out (the
    push library's, `config.library.LIBRARY_BUILD`: with 'floor' its classifier gave pushes
    from good starts met in FetchPush a median 0.12, from its own starts 0.78)."""
    classifier_hidden: tuple[int, ...] = (50, 10)
    """Hidden widths of the success classifier (thesis: 50, 10)."""
    classifier_lr: float = 1e-3
    """Adam learning rate of the classifier (thesis: 1e-4)."""
    fit_batch: int = 256
    """Samples per gradient step of the fits (a smaller training split is one batch)."""
    fit_epochs: int = 60
    """Most passes over the training split (early stopping after `patience`, best kept)."""
    patience: int = 8
    """Passes without held-out improvement before a fit stops."""
    holdout: float = 0.1
    """Share of each skill's samples held out for early stopping and the reported errors."""
    seed: int = 0
    """Seed of skill training, collection and fits."""

    def __post_init__(self) -> None:
        check_numbers(self)
        for name in (
            "transit_epochs",
            "grasp_epochs",
            "transfer_epochs",
            "skill_eval_episodes",
            "collect_envs",
            "fit_batch",
            "fit_epochs",
            "patience",
        ):
            _check(getattr(self, name) >= 1, name, "must be >= 1")
        _check(self.samples >= 100, "samples", "must be >= 100 (a held-out split needs data)")
        _check(0.0 <= self.grasp_held_start_prob <= 1.0, "grasp_held_start_prob", "in [0, 1]")
        _check(0.0 < self.own_start_share <= 1.0, "own_start_share", "must lie in (0, 1]")
        _check(0.0 < self.holdout < 0.5, "holdout", "must lie in (0, 0.5)")
        for name in ("model_hidden", "classifier_hidden"):
            widths = getattr(self, name)
            _check(len(widths) > 0 and all(w > 0 for w in widths), name, "need >= 1 positive width")
        for name in ("model_lr", "classifier_lr"):
            _check(getattr(self, name) > 0, name, "must be > 0")


LIBRARY_BUILD: dict[str, dict[str, Any]] = {"SL_fetch_push": {"still_inputs": "ignore"}}
"""Library name -> the LibraryConfig fields its build sets where the command leaves them at
their defaults (`build_config`); the name is the library's in `skills.registry.LIBRARIES`."""


def build_config(library: str | None, config: LibraryConfig) -> LibraryConfig:
    """`config` with library `library`'s build settings (LIBRARY_BUILD) in the fields it
    leaves at their defaults."""
    default = LibraryConfig()
    own = LIBRARY_BUILD.get(library or "", {})
    return dataclasses.replace(
        config, **{f: v for f, v in own.items() if getattr(config, f) == getattr(default, f)}
    )
