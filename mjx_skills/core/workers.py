"""Independent jobs in a pool of worker processes, each pinned to its own CPU cores.

A sweep's cells are independent training runs. On a small CPU machine one run leaves cores
idle (XLA's compiles are single-threaded, and small batched programs do not use both cores
of a 2-core machine), so `--jobs N` runs N cells at once, one per worker process. Each worker
is started fresh (`spawn`: JAX must not be forked after it started its threads). With `pin`
(`--pin`) a worker is pinned with `os.sched_setaffinity` to its share of the cores before
it imports JAX, so that two cells never share a core, and the native physics backend sizes
its thread pool from the cores the process may use (`usable_cores`). Unpinned is the
default, by measurement: a pinned worker keeps one core when the other has nothing left
to run, and sweeps end with such a tail (docs/benchmarks.md, "Speed": `benchmarks/sweep_parallel.py`
times both).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any


def usable_cores() -> int:
    """CPU cores this process may run on (its affinity mask; `os.cpu_count` elsewhere)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def core_groups(jobs: int, cores: Sequence[int] | None = None) -> list[tuple[int, ...]]:
    """`jobs` disjoint groups of the usable cores, as even as possible (a job per core when
    there are fewer cores than jobs)."""
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    if cores is None:
        cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    cores = list(cores)
    if not cores:
        return [() for _ in range(jobs)]
    if jobs >= len(cores):
        return [(cores[i % len(cores)],) for i in range(jobs)]
    size, extra = divmod(len(cores), jobs)
    groups, start = [], 0
    for i in range(jobs):
        n = size + (i < extra)
        groups.append(tuple(cores[start : start + n]))
        start += n
    return groups


def _pin(queue: Any) -> None:
    """Worker initializer: take a group of cores and run only on them."""
    cores = queue.get()
    if cores and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, cores)


def run_pool(
    fn: Callable[..., Any], calls: Sequence[tuple], jobs: int, pin: bool = False
) -> Iterator[tuple[int, Any]]:
    """Run fn(*calls[i]) in `jobs` worker processes -> (i, result) as each finishes; with
    `pin` each worker runs only on its own group of cores (`core_groups`). An exception in a
    call (or Ctrl-C) cancels the calls not yet started and is raised here once the running
    ones have finished."""
    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    for group in core_groups(jobs) if pin else [() for _ in range(jobs)]:
        queue.put(group)
    with ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_pin, initargs=(queue,)) as pool:
        pending = {pool.submit(fn, *args): i for i, args in enumerate(calls)}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield pending.pop(future), future.result()
        except BaseException:  # a failed call or Ctrl-C: start nothing more
            pool.shutdown(wait=True, cancel_futures=True)
            raise
