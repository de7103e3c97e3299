"""Look-ahead search over the skill library (thesis ch. 5): a fixed-shape tree per env.

From the current state, every node samples `branching` (skill, goal) pairs: transfer only
when the cube is held, else transit or grasp (restricted to the library in use; each
skill's start condition and goal proposer come from its definition, `skills.registry`):
transit goals just above the object, grasp goals its lift height, transfer goals near the
task goal. Each edge is scored in one batched call per level for all envs and nodes at once:
the classifier's success probability (edges at or below `prune_below` are pruned), the
skill's critic value Q^i(s, g, pi^i(s, g)), and the next state from the coarse model (or
memory; on the last level optionally the skill's goal itself, `leaf_state`). A path's
utility is U = sum_c gamma^c Q_c + gamma^C v(leaf); every node of the tree may end a path.
Optionally some transfer goals are waypoints anywhere in reach, and edges through obstacles
the explorer remembered are pruned (`stalls.py`). The search returns the first (skill,
goal) of the best path per env, and flags envs whose every first edge was pruned.

`search_where` runs it only for the envs that decide to search, pooled over the seeds and
in chunks (`search_chunk`), and not at all at a step where no env of any seed searches:
each env draws its edges from its own key, so an env's result does not depend on which
other envs search with it.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.config import SearchConfig
from mjx_skills.core import rollout
from mjx_skills.core.types import GoalEnv
from mjx_skills.skills import registry, stalls
from mjx_skills.skills.library import SkillLibrary


@struct.dataclass
class SearchResult:
    skill: jax.Array
    """(B,) int32 index into the library of the best path's first skill."""
    goal: jax.Array
    """(B, 3) its goal."""
    all_pruned: jax.Array
    """(B,) bool: no first edge survived the classifier (the caller falls back)."""
    utility: jax.Array
    """(B,) the best path's utility (-inf where all pruned)."""


def sample_edges(
    lib: SkillLibrary, cfg: SearchConfig, obs: jax.Array, task_goal: jax.Array, draws: tuple
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """`cfg.branching` (skill, goal) pairs per state: obs (N, 25), task_goal (N, 3), the
    states' random draws (`level_draws`, leading axis N) -> skill (N, b) int32, goal
    (N, b, 3), allowed (N, b) bool (False: no skill may act here)."""
    names = lib.names
    scores, noise, height, lift, way, where = draws
    allowed = lib.allowed(obs, cfg.grasp_reach)  # (N, K)
    skill = jnp.argmax(jnp.where(allowed[:, None], scores, -1.0), axis=-1).astype(jnp.int32)
    ok = jnp.take_along_axis(allowed, skill, axis=1)

    edges = registry.Edges(obs, task_goal, noise, height, lift, way, where)
    proposed = []
    for name, env in zip(names, lib.envs, strict=True):
        goal = registry.get(name).propose(env, cfg, edges)
        if goal.shape != noise.shape:
            raise ValueError(
                f"skill {name!r}: its proposer returned goals of shape {goal.shape}; "
                f"expected (N, b, 3) = {noise.shape}"
            )
        proposed.append(goal)
    goals = jnp.stack(proposed)  # (K, N, b, 3)
    goal = jnp.take_along_axis(goals, skill[None, ..., None], axis=0)[0]
    return skill, goal, ok


def take_row(x: jax.Array, k: jax.Array) -> jax.Array:
    """x (B, n, ...) at k (B,) int -> (B, ...): each batch row's k-th entry."""
    return jnp.take_along_axis(x, k.reshape(-1, 1, *([1] * (x.ndim - 2))), axis=1)[:, 0]


def _draws(key: jax.Array, lead: tuple[int, ...], k: int) -> tuple[jax.Array, ...]:
    """Random draws of edges (leading shape `lead`) from one key: skill scores (..., k),
    goal noise in [-1, 1] (..., 3), transit height share (...), grasp lift parameter in
    [-1, 1] (..., 1), waypoint coin (..., 1) and waypoint position share (..., 3)."""
    k_skill, k_noise, k_height, k_lift, k_way, k_where = jax.random.split(key, 6)
    uniform = jax.random.uniform
    return (
        uniform(k_skill, (*lead, k)),
        uniform(k_noise, (*lead, 3), minval=-1.0, maxval=1.0),
        uniform(k_height, lead),
        uniform(k_lift, (*lead, 1), minval=-1.0, maxval=1.0),
        uniform(k_way, (*lead, 1)),
        uniform(k_where, (*lead, 3)),
    )


def env_keys(key: jax.Array, n: int) -> jax.Array:
    """(n,) keys, env i's = fold_in(key, i): what `search` draws each env's tree from."""
    return jax.vmap(lambda i: jax.random.fold_in(key, i))(jnp.arange(n))


def draw_edges(keys: jax.Array, cfg: SearchConfig, n_skills: int) -> tuple[jax.Array, ...]:
    """Every edge's random draws of each env's whole tree from the env's key alone: keys
    (B,) -> `_draws` with leading shape (B, nodes, branching), nodes = the tree's inner
    nodes, level by level (1 + b + ... + b^(height - 1))."""
    b = cfg.branching
    nodes = sum(b**level for level in range(cfg.height))
    return jax.vmap(lambda key: _draws(key, (nodes, b), n_skills))(keys)


def level_draws(draws: tuple[jax.Array, ...], level: int, b: int) -> tuple[jax.Array, ...]:
    """The draws of one level's b^level nodes per env, flattened to (B * b^level, b, ...)."""
    start, n = sum(b**i for i in range(level)), b**level
    return tuple(x[:, start : start + n].reshape(-1, *x.shape[2:]) for x in draws)


def leaf_value(cfg: SearchConfig, env: GoalEnv, obs: jax.Array, task_goal: jax.Array) -> jax.Array:
    """v(leaf): (...) from predicted observations (..., 25) and task goals (..., 3)."""
    achieved = env.achieved_from_obs(obs)
    if cfg.leaf_value == "reward":
        return env.compute_reward(achieved, task_goal)
    return -jnp.linalg.norm(achieved - task_goal, axis=-1) / env.threshold


def search(
    lib: SkillLibrary,
    cfg: SearchConfig,
    env: GoalEnv,
    obs: jax.Array,
    task_goal: jax.Array,
    key: jax.Array,
    obstacles: jax.Array | None = None,
) -> SearchResult:
    """The best first edge per env: obs (B, 25), task_goal (B, 3); moving edges that pass
    near one of an env's remembered `obstacles` (B, M, 3) are pruned (`stalls.py`). Env i
    draws its tree from `env_keys(key, B)[i]` alone."""
    return search_envs(lib, cfg, env, obs, task_goal, env_keys(key, obs.shape[0]), obstacles)


def search_envs(
    lib: SkillLibrary,
    cfg: SearchConfig,
    env: GoalEnv,
    obs: jax.Array,
    task_goal: jax.Array,
    keys: jax.Array,
    obstacles: jax.Array | None = None,
) -> SearchResult:
    """`search` with one key per env, keys (B,)."""
    B, b = obs.shape[0], cfg.branching
    draws = draw_edges(keys, cfg, len(lib.names))
    next_fn = lib.next_state if cfg.lookahead_next == "model" else lib.recall
    # Level state, one row per (env, node): start with the root.
    states, alive = obs[:, None], jnp.ones((B, 1), bool)
    path_u, disc = jnp.zeros((B, 1)), jnp.ones((B, 1))
    first_skill, first_goal = jnp.zeros((B, 1), jnp.int32), jnp.zeros((B, 1, 3))
    best_u, best_skill, best_goal = [], [], []
    for level in range(cfg.height):
        n = states.shape[1]
        flat = states.reshape(B * n, -1)
        goals_rep = jnp.repeat(task_goal, n, axis=0)
        skill, goal, ok = sample_edges(lib, cfg, flat, goals_rep, level_draws(draws, level, b))
        rows = B * n * b
        s_rep = jnp.repeat(flat, b, axis=0)
        sk, g = skill.reshape(rows), goal.reshape(rows, 3)
        prob = lib.success_prob(sk, s_rep, g)
        q = lib.q(sk, s_rep, g)
        leaf_only = level == cfg.height - 1 and cfg.leaf_state == "goal"
        nxt = (lib.at_goal if leaf_only else next_fn)(sk, s_rep, g)
        shape = (B, n * b)
        valid = (
            jnp.repeat(alive, b, axis=1)
            & ok.reshape(shape)
            & (prob.reshape(shape) > cfg.prune_below)
        )
        if cfg.skip_reached:
            valid &= ~lib.reached(sk, s_rep, g).reshape(shape)
        if obstacles is not None:
            near = jnp.repeat(obstacles, n * b, axis=0)
            grip = s_rep[:, lib.layout["grip"]]
            valid &= ~stalls.blocked(near, lib.names, sk, grip, g, cfg.stall_radius).reshape(shape)
        u = jnp.repeat(path_u, b, axis=1) + jnp.repeat(disc, b, axis=1) * q.reshape(shape)
        disc = jnp.repeat(disc, b, axis=1) * cfg.gamma
        states = nxt.reshape(B, n * b, -1)
        leaf = u + disc * leaf_value(cfg, env, states, task_goal[:, None])
        if level == 0:
            first_skill, first_goal = skill.reshape(shape), goal.reshape(B, n * b, 3)
        else:
            first_skill = jnp.repeat(first_skill, b, axis=1)
            first_goal = jnp.repeat(first_goal, b, axis=1)
        best_u.append(jnp.where(valid, leaf, -jnp.inf))
        best_skill.append(first_skill)
        best_goal.append(first_goal)
        alive, path_u = valid, u
    u_all = jnp.concatenate(best_u, axis=1)
    i = jnp.argmax(u_all, axis=1)
    utility = take_row(u_all, i)
    return SearchResult(
        skill=take_row(jnp.concatenate(best_skill, axis=1), i),
        goal=take_row(jnp.concatenate(best_goal, axis=1), i),
        all_pruned=~jnp.isfinite(utility),
        utility=utility,
    )


def no_search(n: int) -> SearchResult:
    """n envs without a search: every first edge counts as pruned."""
    return SearchResult(
        skill=jnp.zeros((n,), jnp.int32),
        goal=jnp.zeros((n, 3)),
        all_pruned=jnp.ones((n,), bool),
        utility=jnp.full((n,), -jnp.inf),
    )


def random_edges(
    lib: SkillLibrary,
    cfg: SearchConfig,
    where: jax.Array,
    obs: jax.Array,
    task_goal: jax.Array,
    key: jax.Array,
) -> SearchResult:
    """The random-skill explorer (`explorer = "random"`): no search, one edge per env drawn
    as the search draws a node's edges (`sample_edges`: a skill uniform among those allowed
    here, its goal from the same distributions) and never scored. A uniform random utility
    ranks the envs' rows (so the caller's pick among the cubes of a scene is uniform too);
    rows not in `where` (B,) get no result. obs (B, obs_dim), task_goal (B, 3)."""
    B = obs.shape[0]
    keys = env_keys(key, B)
    draws = jax.vmap(lambda k: _draws(k, (1,), len(lib.names)))(keys)
    skill, goal, ok = sample_edges(lib, cfg, obs, task_goal, draws)
    valid = where & ok[:, 0]
    coin = jax.vmap(lambda k: jax.random.uniform(jax.random.fold_in(k, 1)))(keys)
    return SearchResult(
        skill=skill[:, 0],
        goal=goal[:, 0],
        all_pruned=~valid,
        utility=jnp.where(valid, coin, -jnp.inf),
    )


def search_where(
    lib: SkillLibrary,
    cfg: SearchConfig,
    env: GoalEnv,
    where: jax.Array,
    obs: jax.Array,
    task_goal: jax.Array,
    key: jax.Array,
    obstacles: jax.Array | None = None,
) -> SearchResult:
    """`search` for the envs where `where` (B,) holds; the others get `no_search`.

    Env i searches with `env_keys(key, B)[i]`, as in `search`, whatever else searches.
    Inside the trainer's vmap over seeds the envs of every seed are pooled
    (`rollout.gather_seeds`): the S x B envs' searching ones are gathered into chunks of
    ceil(`cfg.search_chunk` x S x B) and searched once for all seeds, one chunk after
    another in a `while_loop` whose trip count is not batched. So a step costs the search
    of the envs that search, and nothing where no env of any seed searches. obs
    (B, obs_dim), task_goal (B, 3), obstacles (B, M, 3) or None."""
    B = obs.shape[0]
    mine = (where, obs, task_goal, env_keys(key, B), obstacles)
    pooled = jax.tree.map(lambda x: x.reshape(-1, *x.shape[2:]), rollout.gather_seeds(mine))
    found = _search_chunks(lib, cfg, env, *pooled)
    return rollout.own_seed(jax.tree.map(lambda x: x.reshape(-1, B, *x.shape[1:]), found))


def _search_chunks(lib, cfg, env, where, obs, task_goal, keys, obstacles) -> SearchResult:
    """`search_envs` on the rows where `where` (N,) holds, in chunks; `no_search` elsewhere."""
    N = obs.shape[0]
    chunk = min(N, max(1, math.ceil(cfg.search_chunk * N)))
    count = jnp.sum(where.astype(jnp.int32))
    rounds = (count + chunk - 1) // chunk
    # The searching rows first (stable order), padded to whole chunks.
    order = jnp.argsort(~where, stable=True)
    order = jnp.concatenate([order, jnp.zeros((-N % chunk,), order.dtype)])

    def body(carry):
        r, found = carry
        rows = jax.lax.dynamic_slice_in_dim(order, r * chunk, chunk)
        valid = r * chunk + jnp.arange(chunk) < count
        part = search_envs(
            lib,
            cfg,
            env,
            obs[rows],
            task_goal[rows],
            keys[rows],
            None if obstacles is None else obstacles[rows],
        )
        at = jnp.where(valid, rows, N)  # out of range: dropped
        found = jax.tree.map(lambda f, p: f.at[at].set(p, mode="drop"), found, part)
        return r + 1, found

    start = (jnp.zeros((), rounds.dtype), no_search(N))
    return jax.lax.while_loop(lambda c: c[0] < rounds, body, start)[1]
