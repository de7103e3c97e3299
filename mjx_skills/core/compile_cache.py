"""JAX's persistent compilation cache, switched on in one place for the CLI and the tests.

Compiles cost 20-40 s per env program on a 2-core CPU; with the cache a second run of the
same program loads the executable from disk instead of compiling it again.

The cache only saves time, so it never stops a run: a directory that cannot be created or
written, or a JAX that refuses the settings, is one warning and the run compiles as usual.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import warnings
from pathlib import Path

ENV_VAR = "MJX_SKILLS_CACHE_DIR"
_SETTINGS = {
    # Cache every program that took noticeable time to compile, whatever its size.
    "jax_persistent_cache_min_compile_time_secs": 0.5,
    "jax_persistent_cache_min_entry_size_bytes": -1,
}
_warned = False


def cache_dir() -> Path:
    """`$MJX_SKILLS_CACHE_DIR`, else `$XDG_CACHE_HOME/mjx_skills/jax`, else ~/.cache/..."""
    if os.environ.get(ENV_VAR):
        return Path(os.environ[ENV_VAR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mjx_skills" / "jax"


def _warn_once(message: str) -> None:
    global _warned
    if not _warned:
        _warned = True
        warnings.warn(message, stacklevel=3)


def enable() -> Path | None:
    """Point JAX's persistent cache at `cache_dir()`; set MJX_SKILLS_CACHE_DIR=off to skip.
    None when skipped, or when the cache cannot be used (warned once per process; JAX's
    settings are then left as they were)."""
    if os.environ.get(ENV_VAR, "").lower() in ("off", "0", "none"):
        return None
    path, problem = "the cache directory", "cannot name it"
    try:
        path = cache_dir()
        problem = "cannot create it"
        path.mkdir(parents=True, exist_ok=True)
        problem = "cannot write in it"  # else JAX would warn at every compile
        with tempfile.TemporaryFile(dir=path):
            pass
    except (OSError, RuntimeError) as err:  # RuntimeError: Path.home() without a home
        _warn_once(
            f"no compilation cache: {path}: {problem} ({getattr(err, 'strerror', None) or err}); "
            f"every program compiles anew. Set {ENV_VAR} to a writable directory, or "
            f"{ENV_VAR}=off"
        )
        return None
    import jax

    before = {}
    try:
        for name, value in {"jax_compilation_cache_dir": str(path), **_SETTINGS}.items():
            before[name] = getattr(jax.config, name)
            jax.config.update(name, value)
    except Exception as err:  # noqa: BLE001 - whatever this JAX refuses, the run goes on
        for name, value in before.items():  # leave JAX's settings as they were
            with contextlib.suppress(Exception):
                jax.config.update(name, value)
        _warn_once(
            f"no compilation cache: JAX refused its settings ({type(err).__name__}: {err}); "
            "every program compiles anew"
        )
        return None
    return path
