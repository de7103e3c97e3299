"""JAX's persistent compilation cache, switched on in one place for the CLI and the tests.

Compiles cost 20-40 s per env program on a 2-core CPU; with the cache a second run of the
same program loads the executable from disk instead of compiling it again.
"""

from __future__ import annotations

import os
from pathlib import Path

ENV_VAR = "MJX_SKILLS_CACHE_DIR"


def cache_dir() -> Path:
    """`$MJX_SKILLS_CACHE_DIR`, else `$XDG_CACHE_HOME/mjx_skills/jax`, else ~/.cache/..."""
    if os.environ.get(ENV_VAR):
        return Path(os.environ[ENV_VAR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mjx_skills" / "jax"


def enable() -> Path | None:
    """Point JAX's persistent cache at `cache_dir()`; set MJX_SKILLS_CACHE_DIR=off to skip."""
    if os.environ.get(ENV_VAR, "").lower() in ("off", "0", "none"):
        return None
    import jax

    path = cache_dir()
    path.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(path))
    # Cache every program that took noticeable time to compile, whatever its size.
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return path
