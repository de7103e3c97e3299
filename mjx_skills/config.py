"""Frozen configuration dataclasses, one docstring per field (parsed by tyro on the CLI).

Defaults follow the thesis (Table 6.1) and the original code where the thesis is silent;
each departure is said in the field's docstring. A leaf module: it imports nothing from the
package (task and method names are checked where envs and methods are made).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from typing import Any, Literal

SEED_LIMIT = 2**32  # seeds are 32-bit JAX keys: s and s + 2**32 would be one stream


def _check(cond: bool, field: str, why: str) -> None:
    if not cond:
        raise ValueError(f"invalid config value for '{field}': {why}")


def check_numbers(config: Any) -> None:
    """Every field of `config` has its annotated type (`checked_value`), and every number (of
    a tuple too) is finite and >= 0: no config field takes NaN, an infinity or a negative."""
    hints = typing.get_type_hints(type(config))
    for field in dataclasses.fields(config):
        value = checked_value(field.name, getattr(config, field.name), hints[field.name])
        object.__setattr__(config, field.name, value)
        for v in value if isinstance(value, tuple) else (value,):
            if isinstance(v, bool) or not isinstance(v, int | float):
                continue
            _check(math.isfinite(v), field.name, f"must be finite, got {v}")
            _check(v >= 0, field.name, f"must be >= 0, got {v}")


def checked_value(field: str, value: Any, hint: Any) -> Any:
    """`value` as a field annotated `hint` holds it (ints as floats, lists as tuples), or
    ValueError naming `field`: a float for an int (1e6 for 1000000), a string for a number."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is Literal:
        _check(value in args, field, f"valid: {', '.join(map(str, args))}; got {value!r}")
        return value
    if origin is tuple:
        _check(isinstance(value, tuple | list), field, f"must be a list, got {value!r}")
        items = args[:1] * len(value) if args[-1:] == (Ellipsis,) else args
        _check(len(items) == len(value), field, f"must hold {len(items)} values, got {value!r}")
        return tuple(checked_value(field, v, h) for v, h in zip(value, items, strict=True))
    kinds = {int: (numbers.Integral, "an int"), float: (numbers.Real, "a number")}
    kinds |= {bool: (bool, "true or false"), str: (str, "a string")}
    if hint in kinds:
        kind, name = kinds[hint]
        ok = isinstance(value, kind) and (hint is bool or not isinstance(value, bool))
        _check(ok, field, f"must be {name}, got {value!r} ({type(value).__name__})")
        return hint(value)
    return value


@dataclasses.dataclass(frozen=True)
class DDPGConfig:
    """DDPG + HER hyperparameters."""

    hidden: tuple[int, ...] = (64, 64, 64)
    """Hidden layer widths of actor and critic (thesis: 3 x 64)."""
    layer_norm: bool = True
    """LayerNorm after each hidden layer (the original code uses it)."""
    actor_lr: float = 1e-3
    """Adam learning rate of the actor (Table 6.1: 1e-4; 1e-3, as the HER baselines, learned
    transit faster here: docs/methods.md, "Hyperparameters")."""
    critic_lr: float = 1e-3
    """Adam learning rate of the critic (Table 6.1)."""
    gamma: float = 0.98
    """Discount factor (Table 6.1)."""
    tau: float = 0.05
    """Soft target update per gradient step, target <- (1 - tau) target + tau online (Table
    6.1's 1e-3 is too slow at our updates, docs/methods.md; HER baselines: 0.05 per cycle)."""
    batch_size: int = 128
    """Transitions per gradient step (Table 6.1)."""
    noise_sigma: float = 0.2
    """Std of the Gaussian exploration noise on actions in [-1, 1] (Table 6.1)."""
    random_eps: float = 0.2
    """Share of uniformly random exploration actions (original code: 20 %)."""
    action_l2: float = 1.0
    """Weight of the L2 penalty on the actor's pre-noise actions (HER's)."""
    clip_target: bool = True
    """Clip critic targets to [-1 / (1 - gamma), 0], the range of sparse -1/0 returns."""
    norm_clip: float = 5.0
    """Normalised observations and goals are clipped to [-norm_clip, norm_clip]."""
    norm_eps: float = 1e-2
    """Floor of the normaliser's std, so constant inputs do not blow up."""
    her_strategy: Literal["future", "final", "episode", "none"] = "future"
    """Hindsight goal strategy: a later step ('future'), the last step ('final'), any step
    of the episode ('episode'), or no relabelling ('none')."""
    relabel_prob: float = 0.8
    """Share of sampled transitions whose goal is relabelled (future k = 4 -> 0.8)."""
    n_step: int = 1
    """Critic targets from n-step returns (`her.sample_batch`); 1: one-step TD, the thesis's."""
    critics: int = 1
    """Critics side by side (2: TD3's clipped double Q); Q read anywhere is their minimum."""
    architecture: Literal["mlp", "deep_sets"] = "mlp"
    """'deep_sets': actor and critic take the scene as the set of its cubes' views (gripper,
    cube k, goal k), one encoder shared by all, summed (`nets.DeepSet`); 'mlp': the whole."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(len(self.hidden) > 0 and all(h > 0 for h in self.hidden), "hidden",
               "need >= 1 positive width")  # fmt: skip
        for name in ("actor_lr", "critic_lr", "batch_size", "n_step", "norm_clip", "critics"):
            _check(getattr(self, name) > 0, name, "must be > 0")
        _check(0.0 < self.gamma < 1.0, "gamma", "must lie in (0, 1)")
        _check(0.0 < self.tau <= 1.0, "tau", "must lie in (0, 1]")
        _check(0.0 <= self.random_eps <= 1.0, "random_eps", "must lie in [0, 1]")
        _check(0.0 <= self.relabel_prob <= 1.0, "relabel_prob", "must lie in [0, 1]")
        _check(self.norm_eps > 0, "norm_eps", "must be > 0 (the floor of a std)")
        _check(self.architecture == "mlp" or len(self.hidden) > 1, "hidden", "deep_sets: >= 2")


Physics = Literal["auto", "native", "mjx"]
PHYSICS = typing.get_args(Physics)  # the backends (`envs.physics.make_backend`), named once
Library = Literal["SL1", "SL2", "SL3"]
LIBRARIES = typing.get_args(Library)
"""The thesis's skill libraries by name (their skills: `skills.library.LIBRARIES`)."""


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """Simulation and control settings shared by every Baxter env."""

    physics: Physics = "auto"
    """Physics backend: 'native' (MuJoCo C via mujoco.rollout, the CPU default), 'mjx'
    (accelerators) or 'auto' (native on a CPU, mjx on a GPU/TPU)."""
    timestep: float = 0.005
    """Physics timestep in s. The thesis uses 0.002 x 75 substeps; a held cube stays put at
    0.005 s (tests/test_physics.py) and 2.5x fewer substeps make every env step cheaper."""
    n_substeps: int = 30
    """Substeps per env step: 0.005 s x 30 = 0.15 s, the thesis's control period."""
    solver_iterations: int = 20
    """Solver iterations (MuJoCo's default: 100; 20 converge for a four-contact grasp)."""
    ls_iterations: int = 10
    """Line-search iterations of the solver."""
    action_scale: float = 0.05
    """End-effector displacement in m for an action of 1 (thesis: 5 cm)."""
    settle_substeps: int = 40
    """Substeps a reset lets the weld carry the gripper from home to its start (0.2 s)."""
    grasp_settle_substeps: int = 30
    """Substeps a reset closes the fingers for tasks that start with the cube held."""
    posture_stiffness: float = 5.0
    """Stiffness (N m / rad) of the weak joint springs toward the home posture (they keep
    the redundant arm out of joint limits)."""
    max_qvel: float = 100.0
    """A joint speed above this (or a NaN) counts as diverged physics: the env is reset."""
    native_threads: int = 0
    """Threads of the native backend's rollout pool; 0 = one per core."""
    episode_length: int = 0
    """Env steps per episode; 0 = the task's default from the thesis."""
    distance_threshold: float = 0.0
    """Success tolerance in m; 0 = the task's default (3 cm for most tasks)."""
    held_start_prob: float = 0.0
    """Share of training resets starting with the cube closed in the fingers where it lies
    (the original code trains grasp with 0.5, HER's trick); evaluation never does."""
    goal_start_prob: float = 0.0
    """Share of training resets of several-cube tasks with one cube (whose goal rests on a
    surface) starting at its goal: a reverse curriculum (Florensa et al. 2017). Evaluation
    never does; one-cube tasks refuse it."""
    object_reward: bool = False
    """Several cubes: the step-wise sparse reward (Li et al. 2020), minus the share of cubes
    not at their goals (-1, -0.5, 0), instead of -1 until all are. Success is unchanged."""
    single_goal: bool = False
    """One desired goal for every episode, the mean of the task's goal distribution: the
    thesis's PAS baseline after its reference [21] (docs/results.md). Off: the thesis's."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(self.timestep > 0, "timestep", "must be > 0")
        for name in ("n_substeps", "solver_iterations", "ls_iterations", "settle_substeps",
                     "grasp_settle_substeps"):  # fmt: skip
            _check(getattr(self, name) >= 1, name, "must be >= 1")
        _check(self.action_scale > 0, "action_scale", "must be > 0")
        for name in ("held_start_prob", "goal_start_prob"):
            _check(0.0 <= getattr(self, name) <= 1.0, name, "must lie in [0, 1]")
        _check(self.max_qvel > 0, "max_qvel", "must be > 0")

    def for_evaluation(self) -> EnvConfig:
        """This config without its training-only starts (held, goal): evaluation's."""
        return dataclasses.replace(self, held_start_prob=0.0, goal_start_prob=0.0)


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """One training run: task, method, budget, seeds and where results go."""

    task: str = "pick_move"
    """Env to train on (see mjx_skills.envs.ENVS; checked where the env is made)."""
    epochs: int = 50
    """Epochs to train; 1 epoch = envs x cycles episodes of interaction (thesis: 16)."""
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
    eval_episodes: int = 20
    """Evaluation episodes per epoch with the frozen deterministic policy (thesis: 20)."""
    replay_capacity: int = 1_000_000
    """Replay buffer capacity in transitions (Table 6.1: 1e6)."""
    checkpoint_every: int = 10
    """Save the whole run state every N epochs (and on Ctrl-C and at the end)."""
    out: str = "runs"
    """Results go to OUT/<task>/<method>/<timestamp>/."""
    progress: bool = True  # draw a progress bar

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(bool(self.task), "task", "must name an env")
        _check(self.seeds < SEED_LIMIT, "seeds", "must be < 2**32 (32-bit keys)")
        _check(self.seed + self.seeds <= SEED_LIMIT, "seed", "seed + seeds over 2**32 (keys)")
        for name in ("epochs", "seeds", "envs", "cycles", "eval_episodes", "checkpoint_every",
                     "updates_per_cycle", "replay_capacity"):  # fmt: skip
            _check(getattr(self, name) >= 1, name, "must be >= 1")


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
        for name in ("transit_epochs", "grasp_epochs", "transfer_epochs", "skill_eval_episodes",
                     "collect_envs", "fit_batch", "fit_epochs", "patience"):  # fmt: skip
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


@dataclasses.dataclass(frozen=True)
class SearchConfig:
    """DDPG+HER+SL: look-ahead search over the skill library as exploration (thesis ch. 5)."""

    library: Library = "SL1"
    """Skills the search may use: SL1 = transit, grasp, transfer; SL2 = grasp, transfer;
    SL3 = transit, transfer (thesis Fig. 6.4)."""
    library_dir: str = "experiments/skill_library"
    """Where the built library is (`make skills`; the thesis preset's: ..._thesis)."""
    explorer: Literal["search", "scripted"] = "search"
    """What drives the exploring steps: the search, or the scripted controller (an oracle)."""
    branching: int = 5
    """(skill, goal) pairs sampled at every node (thesis: 5)."""
    height: int = 3
    """Depth of the tree (thesis: 3): 5 + 25 + 125 edges at the defaults."""
    prune_below: float = 0.5
    """Edges whose success probability is at or below this are pruned (thesis: 0.5)."""
    lookahead_next: Literal["model", "memory"] = "model"
    """Next state of an edge: the coarse dynamics model or memory retrieval."""
    leaf_state: Literal["predicted", "goal"] = "predicted"
    """Last level's states: predicted (`lookahead_next`) or 'goal' (each skill ends at its goal)."""
    leaf_value: Literal["distance", "reward"] = "distance"
    """Value of a path's last state: minus its distance to the task goal in units of the
    task's success threshold (the original code) or the task's sparse reward (the text)."""
    gamma: float = 0.98
    """Discount of later edges' values along a path."""
    object_goal_noise: float = 0.03
    """Transit goals are sampled within +- this (m) of the object in x and y (thesis: 3 cm)."""
    transit_height: tuple[float, float] = (0.03, 0.045)
    """... and this far above its centre (m): where the grasp skill starts."""
    transfer_goal_noise: float = 0.03
    """Transfer goals are sampled within +- this (m) of the task goal."""
    waypoint_share: float = 0.3
    """Share of transfer goals drawn anywhere in its goal box (waypoints; 0: the thesis)."""
    stall_memory: int = 8
    """Obstacles remembered per episode where a skill stalled (0: the thesis; skills/stalls.py)."""
    stall_step: float = 0.003
    """A running transit/transfer whose gripper moved less than this (m) in one step, short
    of its goal, has stalled: it ends, and the obstacle is remembered ..."""
    stall_ahead: float = 0.03
    """... this far (m) beyond the gripper towards the skill's goal ..."""
    stall_radius: float = 0.03
    """... and prunes edges whose straight path passes within this (m) of it."""
    search_chunk: float = 0.25
    """Envs searched at once, as a share of all envs of all seeds (>= 1 env), so that a step
    costs only its deciding envs' search; 1: all."""
    skill_steps: int = 10
    """w: a searched skill runs until it terminates or for this many steps (thesis: 10)."""
    eps_start: float = 1.0
    """Probability of exploring with the search at a decision, at epoch 0 (thesis: 1.0)."""
    eps_end: float = 0.001
    """... decaying linearly to this (thesis: 0.001) ..."""
    eps_decay_epochs: int = 30
    """... over this many epochs."""
    eps_floor_by_success: bool = False
    """eps_end x (1 - the previous epoch's eval success): kept while a seed fails (False: fixed)."""
    grasp_reach: float = 0.0
    """Grasp's initiation set (m): > 0, grasp starts only this near the cube; 0: anywhere."""
    goal_clearance: float = 0.0
    """Several cubes: each cube's goal as the explorers aim it, moved this far (m, xy) clear
    of the other cubes (`two_objects.clear_goals`); 0: the task's goals as they are."""
    in_order: bool = False
    """Several cubes: the explorers work on the first cube not at its goal only (False: any)."""

    def __post_init__(self) -> None:
        check_numbers(self)
        for name in ("branching", "height", "skill_steps", "eps_decay_epochs"):
            _check(getattr(self, name) >= 1, name, "must be >= 1")
        _check(0.0 <= self.prune_below < 1.0, "prune_below", "must lie in [0, 1)")
        _check(0.0 < self.gamma <= 1.0, "gamma", "must lie in (0, 1]")
        _check(0.0 <= self.eps_end <= self.eps_start <= 1.0, "eps_start",
               "need 0 <= eps_end <= eps_start <= 1")  # fmt: skip
        lo, hi = self.transit_height
        _check(0.0 <= lo <= hi, "transit_height", "need 0 <= low <= high")
        _check(0.0 <= self.waypoint_share <= 1.0, "waypoint_share", "must lie in [0, 1]")
        _check(0.0 < self.search_chunk <= 1.0, "search_chunk", "must lie in (0, 1]")


@dataclasses.dataclass(frozen=True)
class PASConfig:
    """PAS / MPAS: a parameterized-action-space meta-controller over the skill library
    (thesis ch. 4). Its DDPG hyperparameters are the `--ddpg.*` group."""

    library: Library = "SL1"
    """Skills the meta-controller chooses from (as for DDPG+HER+SL)."""
    library_dir: str = "experiments/skill_library"
    """Where the built library is (`make skills`; the thesis preset's: ..._thesis)."""
    hindsight: bool = False
    """Relabel meta transitions with the achieved goal at the end of a later meta step of
    the same episode (MPAS, approach 1); off: the task's own goal only (PAS, baseline 2)."""
    relabel_prob: float = 0.8
    """Share of sampled meta transitions relabelled when `hindsight` is on."""
    skill_steps: int = 20
    """A chosen skill runs until it reaches its goal or for this many env steps."""
    drop_distance: float = 0.04
    """Transfer also stops once the cube is this far (m) from the gripper: dropped."""
    critic: Literal["joint", "per_skill"] = "per_skill"
    """'per_skill': Q(s, g, k, goal_k) on the chosen skill's goal alone (the thesis's outlook,
    MP-DQN; `agents.mpdqn`); 'joint': one critic over every skill's score and parameters, the actor
    bounded by inverting gradients (the thesis, after Hausknecht & Stone; `--preset thesis`,
    compared in docs/results.md)."""
    terminal_at_goal: bool = True
    """A meta transition that reaches the goal ends the meta-level return (thesis: silent)."""
    updates_per_cycle: int = 40
    """Meta-controller gradient steps per cycle (the HER code's 40: tens of meta transitions)."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(0.0 <= self.relabel_prob <= 1.0, "relabel_prob", "must lie in [0, 1]")
        for name in ("skill_steps", "updates_per_cycle"):
            _check(getattr(self, name) >= 1, name, "must be >= 1")
        _check(self.drop_distance > 0, "drop_distance", "must be > 0")
