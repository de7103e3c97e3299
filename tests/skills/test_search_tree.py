"""The batched tree search equals a brute-force enumeration of every path of the hand-built
library (tests.fakes.KnownLibrary)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.config import SearchConfig
from mjx_skills.skills import lookahead
from tests.fakes import KnownLibrary, states


@dataclasses.dataclass(frozen=True)
class PruneByGoalLibrary(KnownLibrary):
    """Edges whose goal lies at y > -0.2 are pruned wherever they are in the tree; memory
    recall lands 2 cm short of the goal in x (so model and memory trees differ)."""

    def success_prob(self, skill, obs, goal):
        return jnp.where(goal[:, 1] > -0.2, 0.1, 0.9)

    def recall(self, skill, obs, goal):
        return KnownLibrary.next_state(self, skill, obs, goal.at[:, 0].add(-0.02))


def _visit(lib, cfg, env, e, goal, draws, state, level, node, u, disc, first, alive, found):
    """One node of env e's tree: score its b edges as `search` does, one at a time, and
    recurse. found: {"best": (utility, skill, goal), "hidden": best utility under a pruned
    edge}."""
    b = cfg.branching
    step = lib.next_state if cfg.lookahead_next == "model" else lib.recall
    start = sum(b**i for i in range(level))
    mine = tuple(x[e : e + 1, start + node] for x in draws)
    skills, goals, ok = lookahead.sample_edges(lib, cfg, state[None], goal[e : e + 1], mine)
    for c in range(b):
        sk, g = skills[:, c], goals[:, c]
        prob = float(lib.success_prob(sk, state[None], g)[0])
        valid = alive and bool(ok[0, c]) and prob > cfg.prune_below
        u2 = u + disc * float(lib.q(sk, state[None], g)[0])
        nxt = step(sk, state[None], g)[0]
        leaf = u2 + disc * cfg.gamma * float(lookahead.leaf_value(cfg, env, nxt, goal[e]))
        f = first or (int(sk[0]), np.asarray(g[0]))
        if valid and leaf > found["best"][0]:
            found["best"] = (leaf, *f)
        if not valid:
            found["hidden"] = max(found["hidden"], leaf)
        if level + 1 < cfg.height:
            _visit(
                lib,
                cfg,
                env,
                e,
                goal,
                draws,
                nxt,
                level + 1,
                node * b + c,
                u2,
                disc * cfg.gamma,
                f,
                valid,
                found,
            )


def brute_force(lib, cfg, env, obs, goal, key) -> list[tuple[float, int, np.ndarray, bool]]:
    """Every path of every env's tree, enumerated one edge at a time with the same draws:
    per env (best utility, its first skill, first goal, whether some pruned edge had a
    descendant that would have beaten it)."""
    draws = lookahead.draw_edges(lookahead.env_keys(key, obs.shape[0]), cfg, len(lib.names))
    out = []
    for e in range(obs.shape[0]):
        found = {"best": (-np.inf, -1, None), "hidden": -np.inf}
        _visit(lib, cfg, env, e, goal, draws, obs[e], 0, 0, 0.0, 1.0, None, True, found)
        out.append((*found["best"], found["hidden"] > found["best"][0]))
    return out


@pytest.mark.parametrize(
    ("height", "next_from", "leaf"),
    [
        (2, "model", "distance"),
        (3, "model", "distance"),
        (3, "memory", "reward"),
    ],
)
def test_the_tree_search_equals_a_brute_force_enumeration_of_every_path(
    env, height, next_from, leaf
):
    """Utilities, discounting at depth, memory vs model next states and both leaf values,
    against every path enumerated by hand; an edge the classifier prunes never leads to the
    chosen path, even where one of its descendants would score best."""
    cfg = SearchConfig(branching=3, height=height, lookahead_next=next_from, leaf_value=leaf)
    lib = PruneByGoalLibrary()
    obs, goal = states(6, held=False)
    held, _ = states(6, held=True)
    obs = jnp.concatenate([obs[:3], held[:3]])  # transit/grasp trees and transfer trees
    key = jax.random.PRNGKey(7)
    found = lookahead.search(lib, cfg, env, obs, goal, key)
    want = brute_force(lib, cfg, env, obs, goal, key)
    for e, (u, skill, g, _) in enumerate(want):
        if not np.isfinite(u):
            assert bool(found.all_pruned[e])
            continue
        assert float(found.utility[e]) == pytest.approx(u, rel=1e-4, abs=1e-4)
        assert int(found.skill[e]) == skill
        np.testing.assert_allclose(found.goal[e], g, atol=1e-5)
    # The pruning mattered: somewhere a pruned edge's subtree held a better path.
    assert any(h for *_, h in want)
