"""The Fetch training-epoch table of docs/benchmarks.md's "Physics" block, from the rows of
benchmarks/results/fetch_train_epoch.jsonl (`benchmarks/fetch_train_epoch.py`); written by
`benchmarks/speed_report.py`, which tests/test_package.py checks."""

from __future__ import annotations


def fetch_train_epoch(rows: list[dict]) -> list[str]:
    """The table's lines (none without rows): per task, each backend's compile, peak memory
    and epoch, the latest row of each (task, physics)."""
    if not rows:
        return []
    latest = {(r["task"], r["physics"]): r for r in rows}
    first = rows[0]
    out = [
        "",
        f"**A Fetch training epoch on each backend** (`python benchmarks/fetch_train_epoch.py`): "
        f"DDPG+HER's smallest epoch ({first['envs']} envs x 1 cycle of 5 updates, "
        f"{first['eval_episodes']} evaluation episodes, one seed), each in a process of its "
        f"own on {first['cores']} {first['device'].upper()} cores. MJX compiles for minutes "
        "and steps slowly here: on a CPU its path shows that the programs compile and run; "
        "it is for accelerators, which have not measured it.",
        "",
        "| task | physics | compile | peak memory | epoch | env steps/s |",
        "|---|---|---|---|---|---|",
    ]
    for (task, physics), r in latest.items():
        out.append(
            f"| `{task}` | {physics} | {r['compile_s']:.0f} s | {r['peak_rss_gb']:.1f} GB | "
            f"{r['epoch_s']:.1f} s | {_rate(r['env_steps_per_s'])} |"
        )
    return out


def _rate(value: float) -> str:
    return f"{value:,.0f}" if value >= 100 else f"{value:.1f}"
