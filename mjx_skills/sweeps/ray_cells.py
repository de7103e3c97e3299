"""A sweep's cells as Ray tasks (`python -m mjx_skills.sweep --ray ADDRESS`; the `ray` extra)."""

from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path

from tqdm.auto import tqdm

from mjx_skills.sweeps.cell import Cell


def check_ray_address(address: str, timeout_s: float = 5.0) -> None:
    """Fail fast, naming the address, when nothing listens there ('local' starts one)."""
    if address in ("local", "auto"):
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        with socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout_s):
            return
    except (OSError, ValueError) as err:
        raise SystemExit(f"error: cannot reach the Ray cluster at {address!r}: {err}") from None


def run_cells_ray(
    run_cell: Callable[..., str], cells: list[Cell], dirs: list[Path], address: str, store: Path
) -> list[str]:
    """`run_cell(cell, cell_dir, progress, store)` of every cell as a Ray task (1 CPU each)
    -> their results' directories, in the cells' order."""
    check_ray_address(address)
    try:
        import ray
    except ImportError:
        raise SystemExit("error: --ray needs Ray: pip install -e '.[ray]'") from None
    ray.init(
        address=None if address == "local" else address,
        include_dashboard=False,
        log_to_driver=False,
        ignore_reinit_error=True,
    )
    task = ray.remote(num_cpus=1)(run_cell)
    pending = {
        task.remote(c, str(d), False, str(store)): c for c, d in zip(cells, dirs, strict=True)
    }
    done_dirs: dict[Cell, str] = {}
    with tqdm(total=len(cells), desc="cells", unit="cell") as bar:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            cell = pending.pop(ready[0])
            done_dirs[cell] = ray.get(ready[0])
            bar.set_postfix_str(cell.name)
            bar.update(1)
    return [done_dirs[c] for c in cells]
