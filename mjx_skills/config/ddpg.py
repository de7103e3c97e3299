"""DDPG + HER hyperparameters (`--ddpg.*`)."""

from __future__ import annotations

import dataclasses
from typing import Literal

from mjx_skills.config.checks import _check, check_numbers


@dataclasses.dataclass(frozen=True)
class DDPGConfig:
    """DDPG + HER hyperparameters."""

    hidden: tuple[int, ...] = (64, 64, 64)
    """Hidden layer widths of actor and critic (thesis: 3 x 64)."""
    layer_norm: bool = True
    """LayerNorm after each hidden layer (the original code uses it)."""
    activation: Literal["relu", "gelu"] = "relu"
    """Hidden-layer activation of actor and critic (`nets.ACTIVATIONS`; mrl's Fetch
    benchmark: 'gelu')."""
    weight_init: Literal["lecun", "orthogonal"] = "lecun"
    """Initialisation of actor and critic (`nets.INITS`): flax's LeCun-normal, or
    'orthogonal' with output layers scaled by 0.1 (mrl's `layer_init`)."""
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
    target_update: Literal["step", "cycle"] = "step"
    """When the targets move by `tau`: after every gradient step ('step'), or once after each
    cycle's gradient steps ('cycle': the HER baselines' polyak 0.95, Plappert et al. 2018,
    with tau 0.05)."""
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
    goal_stats: Literal["desired_and_achieved", "desired"] = "desired_and_achieved"
    """Which goals of the fresh episodes the goal normaliser sees: desired and achieved (the
    HER baselines'), or the desired goals only (mrl's, whose normaliser is updated with the
    inputs the policy acts on)."""
    her_strategy: Literal["future", "final", "episode", "none"] = "future"
    """Hindsight goal strategy: a later step ('future'), the last step ('final'), any step
    of the episode ('episode'), or no relabelling ('none')."""
    relabel_prob: float = 0.8
    """Share of sampled transitions whose goal is relabelled (future k = 4 -> 0.8)."""
    relabel_actual: float = 0.0
    """Further share of sampled transitions whose goal is the desired goal of a transition
    drawn from the whole replay (mrl's "actual" goals; its Fetch benchmark's
    'futureactual_2_2' is relabel_prob 0.4, relabel_actual 0.4, the episode's own goal 0.2).
    0: none, as HER and the thesis. relabel_prob + relabel_actual <= 1."""
    warm_up: int = 0
    """No gradient step until the replay holds more than this many transitions (mrl's
    warm_up, 5000 in its Fetch benchmark); the normalisers see every episode either way.
    0: updates from the first cycle, as the thesis."""
    future_warm_up: int = 0
    """While the replay holds fewer transitions than this, every sampled goal is relabelled
    (mrl's future_warm_up, 25,000 in its Fetch benchmark), then a `relabel_prob` share.
    0: `relabel_prob` from the start, as the thesis."""
    n_step: int = 1
    """Critic targets from n-step returns (`her.sample_batch`); 1: one-step TD, the thesis's."""
    critics: int = 1
    """Critics side by side (2: TD3's clipped double Q); Q read anywhere is their minimum."""
    architecture: Literal["mlp", "deep_sets"] = "mlp"
    """'deep_sets': actor and critic take the scene as the set of its cubes' views (gripper,
    cube k, goal k), one encoder shared by all, summed (`nets.DeepSet`); 'mlp': the whole."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(
            len(self.hidden) > 0 and all(h > 0 for h in self.hidden),
            "hidden",
            "need >= 1 positive width",
        )
        for name in ("actor_lr", "critic_lr", "batch_size", "n_step", "norm_clip", "critics"):
            _check(getattr(self, name) > 0, name, "must be > 0")
        _check(0.0 < self.gamma < 1.0, "gamma", "must lie in (0, 1)")
        _check(0.0 < self.tau <= 1.0, "tau", "must lie in (0, 1]")
        _check(0.0 <= self.random_eps <= 1.0, "random_eps", "must lie in [0, 1]")
        _check(0.0 <= self.relabel_prob <= 1.0, "relabel_prob", "must lie in [0, 1]")
        _check(
            self.relabel_actual >= 0.0 and self.relabel_prob + self.relabel_actual <= 1.0 + 1e-9,
            "relabel_actual",
            f"must lie in [0, 1 - relabel_prob] = [0, {1.0 - self.relabel_prob:g}]",
        )
        _check(self.norm_eps > 0, "norm_eps", "must be > 0 (the floor of a std)")
        for name in ("warm_up", "future_warm_up"):
            _check(getattr(self, name) >= 0, name, "must be >= 0 (transitions in the replay)")
        for name in ("future_warm_up", "relabel_actual"):
            _check(
                self.her_strategy != "none" or not getattr(self, name),
                name,
                "relabels goals: needs a her_strategy other than 'none'",
            )
        _check(self.architecture == "mlp" or len(self.hidden) > 1, "hidden", "deep_sets: >= 2")
