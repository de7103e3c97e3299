"""DDPG+HER+SL+Fast: DDPG+HER+SL made to absorb faster what its explorer shows it (beyond
the thesis).

With the scripted controller as its explorer (the oracle) DDPG+HER+SL's learner still
needs 52 epochs to reach 0.9 on pick_move: the limit is how fast the learner absorbs the
explorer's episodes, not exploration. The ingredients, each a field here so that the
report's ablations remove one at a time:

- wider networks: 3 x 256 hidden units for actor and critic (`FAST_DDPG.hidden`), the HER
  baselines' width (Plappert et al. 2018), where the thesis has 3 x 64;
- more gradient steps: `updates_per_cycle` = 400 per cycle (DDPG+HER+SL: 100);
- a shorter explorer that never quite stops: eps decays over 10 epochs to a floor of 0.03
  (`FAST_SEARCH`; DDPG+HER+SL: over 30 epochs to 0.001), so the learner's own episodes come
  sooner while a few of its decisions still follow the search. Without a floor, one or two
  of five seeds stayed stuck on container_wall (the explorer's skill motions stop reaching
  a learner that has not found the way over the wall);
- the critic picks the evaluated policy's actions (`pick`): at every step the library
  proposes `proposals` (skill, goal) edges drawn as the look-ahead search draws its first
  level (`lookahead.sample_edges`: the skills allowed here, goals around the cube or the
  task goal), each turned into an action by its skill's policy, and the task's critic
  Q(s, g, a) takes the best of them and of the actor's own action: QT-Opt's argmax of Q
  over sampled actions (Kalashnikov et al. 2018) with the library as the proposal
  distribution and the actor as one more proposal (Van de Wiele et al. 2020). No tree
  runs for it: one batch of skill-policy and critic calls per step. The learner explores
  with its actor (`pick_in_training`, the second default's, lets the pick act there too).
  In a scene of several cubes each cube gets `proposals` edges, drawn on the scene's
  projection onto (gripper, that cube) towards its own part of the goal (`propose_any`, as
  DDPG+HER+SL's search does), and the task's critic, which sees the whole scene, judges
  them all;
- averaged networks evaluated (`eval_average`): the policy evaluated (actor, critic and
  library, frozen during evaluation) reads Polyak averages of actor and critic folded in
  after each cycle, while training goes on with the online networks (`Averaged`).

The defaults are the measured best on the targets (docs/results.md); the first and second
defaults stay reachable by their options (the experiments that ran them: docs/results.md,
the DDPG+HER+SL+Fast section).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.agents import ddpg
from mjx_skills.agents.ddpg import DDPGState
from mjx_skills.config import DDPGConfig, SearchConfig, TrainConfig, check_numbers
from mjx_skills.core import optim, rollout
from mjx_skills.core.learner import Learner
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.two_objects import clear_goals, object_views, workable
from mjx_skills.methods.ddpg_her_sl import make_behaviour, make_ddpg_her_sl
from mjx_skills.skills import lookahead
from mjx_skills.skills.library import SkillLibrary

FAST_DDPG = DDPGConfig(hidden=(256, 256, 256))
"""DDPG+HER+SL+Fast's DDPG options: DDPG+HER+SL's, 3 x 256 hidden units."""
FAST_SEARCH = SearchConfig(eps_decay_epochs=10, eps_end=0.03)
"""Its explorer's options: DDPG+HER+SL's, eps decayed over 10 epochs to a floor of 0.03
(DDPG+HER+SL: over 30 epochs to 0.001; this method's first default: over 10 epochs to
0.001; its second: over 5 epochs to 0.1)."""


@dataclasses.dataclass(frozen=True)
class FastConfig:
    """What DDPG+HER+SL+Fast adds (`--fast.*`)."""

    updates_per_cycle: int = 400
    """Gradient steps per cycle (DDPG+HER+SL: 100, `--updates-per-cycle`, which this
    method does not read)."""
    pick: bool = True
    """The critic picks the evaluated policy's actions among the library's proposals (and
    the learner's too where `pick_in_training`)."""
    pick_in_training: bool = False
    """The pick also acts in training (the second default); False: only the evaluated policy
    picks, the learner explores with its actor and DDPG's noise, so the replay holds the
    actor's own actions."""
    proposals: int = 8
    """(skill, goal) edges drawn per step; each proposes its skill policy's action."""
    eval_average: float = 0.8
    """Evaluate Polyak averages of actor and critic: after each cycle's updates, averaged
    <- eval_average averaged + (1 - eval_average) online (0.8: about the last 5 cycles);
    training acts and learns with the online networks as before (what it explores with
    differs only through `--search.eps-floor-by-success`, whose floor reads the evaluated
    policy's success). 0: the online networks are evaluated (no averages kept; the second
    default). Weight averaging against DDPG's oscillating policies (Nikishin et al. 2018,
    "Improving Stability in Deep Reinforcement Learning with Weight Averaging")."""

    def __post_init__(self) -> None:
        check_numbers(self)
        for name in ("updates_per_cycle", "proposals"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not 0.0 <= self.eval_average < 1.0:
            raise ValueError(f"eval_average must lie in [0, 1), got {self.eval_average}")


def propose(
    lib: SkillLibrary, search: SearchConfig, obs: jax.Array, goal: jax.Array, key: jax.Array, n: int
) -> tuple[jax.Array, jax.Array]:
    """The library's proposals: obs (B, 25), goal (B, 3) (one cube's view and goal) ->
    actions (B, n, A) and ok (B, n) bool (False: no skill may act here). Drawn as the
    search's first level."""
    B = obs.shape[0]
    draws = lookahead._draws(key, (B, n), len(lib.names))
    skill, skill_goal, ok = lookahead.sample_edges(lib, search, obs, goal, draws)
    rows = jnp.broadcast_to(obs[:, None], (B, n, obs.shape[-1])).reshape(B * n, -1)
    action = lib.policy_action(skill.reshape(-1), rows, skill_goal.reshape(B * n, -1))
    return action.reshape(B, n, -1), ok


def propose_any(
    env: GoalEnv,
    lib: SkillLibrary,
    search: SearchConfig,
    obs: jax.Array,
    goal: jax.Array,
    key: jax.Array,
    n: int,
) -> tuple[jax.Array, jax.Array]:
    """`propose` for a scene of c cubes: obs (B, obs_dim), goal (B, 3c) -> actions
    (B, c n, A), ok (B, c n): n proposals per cube, each made on the scene's projection onto
    (gripper, that cube) towards that cube's part of the goal (`object_views`; moved
    `search.goal_clearance` clear of the other cubes, `clear_goals`), so transfer
    is proposed only for the held cube, and nothing on another cube's view while the held
    one is short of its goal (`two_objects.workable`; with `search.in_order` only on the
    first cube not at its goal)."""
    views = object_views(env, obs)  # (B, c, 25)
    B, c = views.shape[:2]
    aimed = clear_goals(env, obs, goal, search.goal_clearance).reshape(B * c, -1)
    actions, ok = propose(lib, search, views.reshape(B * c, -1), aimed, key, n)
    if c > 1:  # only on the cubes the explorers may work on (the held one first; in order)
        at_goal = env.cube_success(env.achieved_from_obs(obs), goal)
        ok = ok.reshape(B, c, n) & workable(env.grasped(views), at_goal, search.in_order)[..., None]
    return actions.reshape(B, c * n, -1), ok.reshape(B, c * n)


def pick(
    agent: DDPGState,
    lib: SkillLibrary,
    search: SearchConfig,
    obs: jax.Array,
    goal: jax.Array,
    key: jax.Array,
    n: int,
    config: DDPGConfig,
    env: GoalEnv,
) -> tuple[jax.Array, jax.Array]:
    """The critic's choice among the actor's action and the library's proposals (`n` per
    cube of `env`'s scene, `propose_any`): obs (B, obs_dim), goal (B, goal_dim) -> (action
    (B, A), proposal_taken (B,) bool). Ties go to the actor."""
    own = ddpg.act(agent, obs, goal, config)
    proposed, ok = propose_any(env, lib, search, obs, goal, key, n)
    candidates = jnp.concatenate([own[:, None], proposed], axis=1)  # (B, 1 + n, A)
    rows = lambda x: jnp.broadcast_to(x[:, None], (*candidates.shape[:2], x.shape[-1]))  # noqa: E731
    q = ddpg.q_value(agent, rows(obs), rows(goal), candidates, config)  # (B, 1 + n)
    q = jnp.where(jnp.concatenate([jnp.ones_like(ok[:, :1]), ok], axis=1), q, -jnp.inf)
    best = jnp.argmax(q, axis=1)
    action = lookahead.take_row(candidates, best)
    return action, best > 0


def make_ddpg_her_sl_fast(
    env: GoalEnv, train: TrainConfig, ddpg: DDPGConfig, search: SearchConfig, fast: FastConfig
) -> Learner[DDPGState | Averaged, SkillLibrary]:
    """DDPG+HER+SL's learner and explorer at `fast.updates_per_cycle`, the critic picking
    the learner's actions where `fast.pick`, evaluated with averaged networks where
    `fast.eval_average` (its agent then an `Averaged`)."""
    train = dataclasses.replace(train, updates_per_cycle=fast.updates_per_cycle)
    base = make_ddpg_her_sl(env, train, ddpg, search)
    n = fast.proposals
    if not fast.pick:
        return _averaging(base, fast.eval_average)

    def chosen(agent, lib):
        return lambda key, obs, goal: pick(agent, lib, search, obs, goal, key, n, ddpg, env)[0]

    def explore(agent, lib, progress):
        if search.explorer == "scripted" or not fast.pick_in_training:
            return base.explore(agent, lib, progress)  # the pick acts in evaluation only
        own = _noisy(chosen(agent, lib), ddpg)
        return make_behaviour(
            agent, lib, progress.epoch, env, search, ddpg, own=own, success=progress.success
        )

    def evaluate(agent, lib):
        return rollout.stateless(chosen(agent, lib))

    return _averaging(base._replace(explore=explore, evaluate=evaluate), fast.eval_average)


@struct.dataclass
class Averaged:
    """A DDPG agent with Polyak averages of its actor and critic (`FastConfig.eval_average`):
    training acts and learns with `agent`, evaluation with `view()`."""

    agent: DDPGState
    actor_params: dict
    critic_params: dict

    @classmethod
    def start(cls, agent: DDPGState) -> Averaged:
        """The averages started at the agent's networks."""
        return cls(agent, agent.actor_params, agent.critic_params)

    def fold(self, agent: DDPGState, weight: float) -> Averaged:
        """The new online `agent`, folded in: averages <- weight averages + (1 - weight) its
        networks, leaf by leaf."""
        mix = lambda avg, online: optim.soft_update(avg, online, 1.0 - weight)  # noqa: E731
        return Averaged(
            agent,
            mix(self.actor_params, agent.actor_params),
            mix(self.critic_params, agent.critic_params),
        )

    def view(self) -> DDPGState:
        """The agent with the averaged networks in the online ones' place."""
        return self.agent.replace(actor_params=self.actor_params, critic_params=self.critic_params)


def _averaging(learner: Learner, weight: float) -> Learner:
    """`learner` whose agent keeps Polyak averages of its networks, folded in after each
    cycle's updates, and is evaluated with them (`Averaged`); `learner` itself where weight
    is 0."""
    if not weight:
        return learner

    def update(state, buffer, fresh, key):
        agent, losses = learner.update(state.agent, buffer, fresh, key)
        return state.fold(agent, weight), losses

    return learner._replace(
        init=lambda key: Averaged.start(learner.init(key)),
        explore=lambda state, aux, progress: learner.explore(state.agent, aux, progress),
        update=update,
        evaluate=lambda state, aux: learner.evaluate(state.view(), aux),
    )


def _noisy(policy, config: DDPGConfig):
    """policy(key, obs, goal) plus DDPG's exploration noise (`ddpg.perturb`)."""

    def act(key, obs, goal):
        k_pick, k_noise = jax.random.split(key)
        return ddpg.perturb(k_noise, policy(k_pick, obs, goal), config)

    return act
