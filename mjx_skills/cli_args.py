"""argparse pieces shared by the commands that read a run (eval, render). Imports only the
package's leaf `config` (no mujoco), so `render` can set MUJOCO_GL before mujoco's first import."""

from __future__ import annotations

import argparse
from pathlib import Path

from mjx_skills.config import SEED_LIMIT
from mjx_skills.core import plugins


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def key_seed(text: str) -> int:
    """A seed of JAX's 32-bit PRNG keys: 0 <= seed < 2**32 (larger ones would wrap)."""
    value = int(text)
    if not 0 <= value < SEED_LIMIT:
        raise argparse.ArgumentTypeError(f"must lie in [0, 2**32), got {value}")
    return value


def run_parser(prog: str, doc: str | None, episodes: int) -> argparse.ArgumentParser:
    """RUN_DIR, --episodes and --seed (the episodes' starts), as both commands take them."""
    parser = argparse.ArgumentParser(
        prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run_dir", type=Path, help="a run directory (OUT/<task>/<method>/<time>)")
    parser.add_argument(plugins.FLAG, metavar="MODULE", help=plugins.HELP)  # taken before
    parser.add_argument("--episodes", type=positive_int, default=episodes, help="episodes per seed")
    parser.add_argument(
        "--seed", type=key_seed, default=10_000, help="seed of the episodes' starts"
    )
    return parser
