"""The skill-library methods' options: the look-ahead search of DDPG+HER+SL (`--search.*`) and
PAS / MPAS's meta-controller (`--pas.*`)."""

from __future__ import annotations

import dataclasses
from typing import Literal

from mjx_skills.config.checks import _check, check_numbers


@dataclasses.dataclass(frozen=True)
class SearchConfig:
    """DDPG+HER+SL: look-ahead search over the skill library as exploration (thesis ch. 5)."""

    library: str = "SL1"
    """Skills the search may use: SL1 = transit, grasp, transfer; SL2 = grasp, transfer;
    SL3 = transit, transfer (thesis Fig. 6.4); or a library of yours
    (`skills.registry.register_library`)."""
    library_dir: str = "experiments/skill_library"
    """Where the built library is (`make skills`; the thesis preset's: ..._thesis)."""
    explorer: Literal["search", "scripted", "random"] = "search"
    """What drives the exploring steps: the search, the scripted controller (an oracle), or
    a random skill (a uniformly drawn allowed skill and a goal drawn as the search draws its
    edges, with no scoring: the trivial baseline that measures what the search is worth)."""
    branching: int = 5
    """(skill, goal) pairs sampled at every node (thesis: 5)."""
    height: int = 3
    """Depth of the tree (thesis: 3): 5 + 25 + 125 edges at the defaults."""
    prune_below: float = 0.5
    """Edges whose success probability is at or below this are pruned (thesis: 0.5)."""
    skip_reached: bool = False
    """Prune edges whose skill has already reached its goal where the edge starts (it would
    end at once, a step spent for nothing; False: the thesis). The push library's preset
    (`fetch_push`) sets it: there, approach at its goal was picked over and over."""
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
        _check(
            0.0 <= self.eps_end <= self.eps_start <= 1.0,
            "eps_start",
            "need 0 <= eps_end <= eps_start <= 1",
        )
        lo, hi = self.transit_height
        _check(0.0 <= lo <= hi, "transit_height", "need 0 <= low <= high")
        _check(0.0 <= self.waypoint_share <= 1.0, "waypoint_share", "must lie in [0, 1]")
        _check(0.0 < self.search_chunk <= 1.0, "search_chunk", "must lie in (0, 1]")


@dataclasses.dataclass(frozen=True)
class PASConfig:
    """PAS / MPAS: a parameterized-action-space meta-controller over the skill library
    (thesis ch. 4). Its DDPG hyperparameters are the `--ddpg.*` group."""

    library: str = "SL1"
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
