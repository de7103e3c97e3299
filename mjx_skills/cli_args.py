"""argparse pieces shared by the commands that read a run (eval, render). Imports nothing
of the package, so `render` can set MUJOCO_GL before mujoco's first import."""

from __future__ import annotations

import argparse
from pathlib import Path


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def run_parser(prog: str, doc: str | None, episodes: int) -> argparse.ArgumentParser:
    """RUN_DIR, --episodes and --seed (the episodes' starts), as both commands take them."""
    parser = argparse.ArgumentParser(
        prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run_dir", type=Path, help="a run directory (OUT/<task>/<method>/<time>)")
    parser.add_argument("--episodes", type=positive_int, default=episodes, help="episodes per seed")
    parser.add_argument("--seed", type=int, default=10_000, help="seed of the episodes' starts")
    return parser
