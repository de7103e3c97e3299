"""Files the package writes and reads back: atomic writes, JSON and JSONL readers that name
the file they refuse, and SHA-256 digests of files and of arrays.

A leaf: imports nothing of the package (and JAX only inside `tree_sha256`), so every layer
may use it.

A crash (killed process, full disk, power loss) can leave a JSONL file's last line half
written: `read_jsonl` drops exactly that line with a warning, and refuses damage anywhere
else, naming the file and the line. Whole files (JSON, CSV, results) are written with
`write_text_atomic`, so a reader sees the old file or the new one, never half of one.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import secrets
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)


def write_text_atomic(path: Path | str, text: str) -> Path:
    """Write `text` to `path` whole or not at all: a temporary sibling, fsync, `os.replace`.
    -> the path. Raises OSError where the directory is not writable."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")
    # os.open with 0o666, not mkstemp's 0o600: the file gets the umask's usual permissions.
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)  # the rename itself survives a power loss
    return path


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # a platform without directory handles (Windows): best effort
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_json_atomic(path: Path | str, value: Any, **dumps: Any) -> Path:
    """`value` as JSON (`json.dumps(value, **dumps)`) written by `write_text_atomic`."""
    return write_text_atomic(path, json.dumps(value, **dumps))


def read_json(path: Path | str) -> Any:
    """The JSON value in `path`. Raises FileNotFoundError if it is missing, and ValueError
    naming the file if it does not parse (damaged or half written)."""
    path = Path(path)
    try:
        return json.loads(path.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(
            f"{path} is damaged or half written ({err}); restore it or delete it"
        ) from None


def read_jsonl(path: Path | str, whole: bool = False) -> list[Any]:
    """One JSON value per line of `path` (blank lines skipped).

    The crash case is tolerated: a last line without its newline, or one that does not
    parse, is a half-written append; it is dropped with a warning naming the file. A line
    that does not parse anywhere else raises ValueError naming the file and line number;
    so does a cut last line with `whole` (a file written at once, never appended to, such
    as a stored cell's, is damaged if it is cut). Raises FileNotFoundError if the file is
    missing."""
    return [value for _, value in read_jsonl_lines(path, whole)]


def read_jsonl_lines(path: Path | str, whole: bool = False) -> list[tuple[str, Any]]:
    """`read_jsonl` as (the line's text without its newline, its value) pairs: what a
    writer keeps verbatim when it rewrites the file."""
    path = Path(path)
    pieces = path.read_bytes().split(b"\n")
    # The piece after the last newline: empty when the file ends with one; otherwise an
    # append cut short (no newline yet).
    tail = pieces.pop()
    out: list[tuple[str, Any]] = []
    numbered = [(n, p) for n, p in enumerate(pieces, 1) if p.strip()]
    for i, (number, piece) in enumerate(numbered):
        try:
            text = piece.decode("utf-8")
            out.append((text, json.loads(text)))
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            if i == len(numbered) - 1 and not tail.strip() and not whole:
                _dropped(path, number, f"it does not parse: {err}")
                break
            raise ValueError(
                f"{path} is damaged at line {number} ({err}); only a half-written last line "
                "is skipped, so restore the file or cut it before that line"
            ) from None
    if tail.strip() and whole:
        raise ValueError(f"{path} is damaged: its last line (line {len(pieces) + 1}) is cut")
    if tail.strip():
        _dropped(path, len(pieces) + 1, "it has no newline")
    return out


def _dropped(path: Path, number: int, why: str) -> None:
    log.warning("%s: line %d is half written (%s); reading the lines before it", path, number, why)


def sha256_file(path: Path | str) -> str:
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def leaves_sha256(leaves: list[Any]) -> str:
    """Hex SHA-256 of arrays' contents: each one's shape, dtype and bytes, in order."""
    digest = hashlib.sha256()
    for leaf in leaves:
        array = np.ascontiguousarray(np.asarray(leaf))
        digest.update(f"{array.shape}|{array.dtype.str}|".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def tree_sha256(tree: Any) -> str:
    """`leaves_sha256` of a pytree's leaves in `jax.tree.leaves` order (typed PRNG keys as
    their key data). Copies every leaf to the host."""
    import jax

    def host(leaf: Any) -> Any:
        dtype = getattr(leaf, "dtype", None)
        if dtype is not None and jax.dtypes.issubdtype(dtype, jax.dtypes.prng_key):
            return jax.random.key_data(leaf)
        return leaf

    return leaves_sha256([host(x) for x in jax.tree.leaves(tree)])
