"""Look-ahead search decisions per second, and the search time per 50-step episode against
the thesis's (17 / 71 / 286 s at branching 5 / 10 / 15, height 3).

    python benchmarks/search.py [--library experiments/skill_library] [--searches-per-episode 15]

One JSON row per (K, batch): a decision is one env's best first edge. `episode_search_s`
is the search time one env's 50-step episode costs when `searches_per_episode` decisions
search. The default 15 is above what the training logs show at eps = 1 on pick_move: 13.6-14.9
searches per 50-step episode in epoch 1 of experiments/results/pick_move_ddpg_her_sl.jsonl
(`explore_searches` x 50), 11.5-14 in benchmarks/epoch_cost.py's `searches_share`. Every size is timed
with the default leaf states (`leaf_state="predicted"`: the coarse model on every level)
and with `leaf_state="goal"` (the last level's states are the skills' goals, no model).
The last line is the default's row for K = 5, batch 256.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import time

import jax

from mjx_skills import methods
from mjx_skills.config import SearchConfig
from mjx_skills.core import compile_cache
from mjx_skills.envs import make
from mjx_skills.skills import library, lookahead

THESIS_EPISODE_S = {5: 17.0, 10: 71.0, 15: 286.0}


def measure(lib, env, obs, goal, K: int, batch: int, leaf: str, repeats: int = 3) -> dict:
    cfg = SearchConfig(branching=K, leaf_state=leaf)
    fn = jax.jit(lambda o, g, k: lookahead.search(lib, cfg, env, o, g, k))
    o, g = obs[:batch], goal[:batch]
    t0 = time.perf_counter()
    jax.block_until_ready(fn(o, g, jax.random.PRNGKey(0)))
    compile_s = time.perf_counter() - t0
    times = []
    for i in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(o, g, jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - t0)
    return {
        "K": K,
        "batch": batch,
        "leaf_state": leaf,
        "search_s": min(times),
        "compile_s": round(compile_s, 1),
        "edges_per_env": sum(K**h for h in range(1, cfg.height + 1)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--library", default=str(library.DEFAULT_DIR))
    parser.add_argument("--searches-per-episode", type=float, default=15.0)
    parser.add_argument("--task", default="pick_move")
    args = parser.parse_args()
    compile_cache.enable()
    lib = methods.load_library(SearchConfig(library_dir=args.library))
    env = make(args.task)
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), 256))
    grid = [(5, 1), (5, 256), (10, 1), (10, 256), (15, 1), (15, 16)]
    last = None
    for (K, batch), leaf in itertools.product(grid, ("goal", "predicted")):
        row = measure(lib, env, state.obs, state.desired_goal, K, batch, leaf)
        per_decision = row["search_s"] / batch
        episode = per_decision * args.searches_per_episode
        row.update(
            decisions_per_s=round(1.0 / per_decision, 1),
            episode_search_s=round(episode, 5),
            searches_per_episode=args.searches_per_episode,
            speedup_vs_thesis=round(THESIS_EPISODE_S[K] / episode, 1),
            cores=os.cpu_count(),
            device=jax.default_backend(),
        )
        row["search_s"] = round(row["search_s"], 4)
        print(json.dumps(row), flush=True)
        if (K, batch, leaf) == (5, 256, "predicted"):  # the default search
            last = row
    print(json.dumps(last))


if __name__ == "__main__":
    main()
