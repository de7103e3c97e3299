"""One training run's budget, seeds and output (`TrainConfig`)."""

from __future__ import annotations

import dataclasses

from mjx_skills.config.checks import SEED_LIMIT, _check, check_numbers


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """One training run: task, method, budget, seeds and where results go."""

    task: str = "pick_move"
    """Env to train on (see mjx_skills.envs.ENVS; checked where the env is made)."""
    epochs: int = 100
    """Epochs to train; 1 epoch = envs x cycles episodes of interaction (thesis: 16). The
    default is the thesis's figures' budget, as `make train` (EPOCHS=100)."""
    seeds: int = 1
    """Independent seeds trained in one program (a vmap axis over the whole run)."""
    seed: int = 0
    """First seed; seeds are seed, seed + 1, ..."""
    envs: int = 4
    """Episodes collected in parallel per cycle."""
    cycles: int = 4
    """Collect-then-train cycles per epoch (envs x cycles = 16 episodes, as the thesis)."""
    updates_per_cycle: int = 100
    """Gradient steps after each cycle's episodes (original code: 40 x 20 cycles; 100 x 4
    learned transit fastest here)."""
    random_steps: int = 0
    """Env steps at the start of training whose executed actions are uniform random in
    [-1, 1] instead of the method's (mrl's initial_explore, 10,000 in its Fetch benchmark;
    SB3's learning_starts acts so too), counted per cycle: a cycle that starts below it is
    random throughout. The method's behaviour still runs beside, so its records (skill
    calls) count as if it had acted. 0: none, as the thesis."""
    eval_episodes: int = 20
    """Evaluation episodes per epoch with the frozen deterministic policy (thesis: 20)."""
    replay_capacity: int = 1_000_000
    """Replay buffer capacity in transitions (Table 6.1: 1e6)."""
    checkpoint_every: int = 10
    """Save the whole run state every N epochs (and on Ctrl-C and at the end)."""
    out: str = "runs"
    """Results go to OUT/<task>/<method>/<timestamp>/."""
    progress: bool = True  # draw a progress bar
    track: bool = False
    """Also log to Weights & Biases (the track extra: `pip install -e '.[track]'`, or `pip
    install wandb`; WANDB_MODE=offline keeps it local)."""
    wandb_project: str = "mjx_skills"
    """The W&B project `track` logs to."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(bool(self.task), "task", "must name an env")
        _check(bool(self.wandb_project), "wandb_project", "must name a W&B project")
        _check(0 <= self.random_steps <= 2**30, "random_steps", "must lie in [0, 2**30] env steps")
        _check(self.seeds < SEED_LIMIT, "seeds", "must be < 2**32 (32-bit keys)")
        _check(self.seed + self.seeds <= SEED_LIMIT, "seed", "seed + seeds over 2**32 (keys)")
        for name in (
            "epochs",
            "seeds",
            "envs",
            "cycles",
            "eval_episodes",
            "checkpoint_every",
            "updates_per_cycle",
            "replay_capacity",
        ):
            _check(getattr(self, name) >= 1, name, "must be >= 1")
