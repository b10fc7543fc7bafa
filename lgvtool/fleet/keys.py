"""Content keys of sweep tasks: what a result depends on, hashed.

A task's key is the SHA-256 of a canonical JSON of the log's content hash, the task kind, the
estimators, the settings, the seed, any extra inputs (a configuration file's hash) and the
lgvtool version. The same key means the same computation, so a finished result can be reused;
renaming or moving a log keeps its key, editing it (or upgrading lgvtool) does not.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import uuid
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from lgvtool import __version__

BLOCK = 1 << 20
"""Bytes read at a time while hashing a file (1 MiB)."""

HASH_THREADS = 4
"""Files hashed at once (hashlib releases the GIL on large blocks)."""


def file_sha256(path: str | Path, *, block: int = BLOCK) -> str:
    """Hex SHA-256 of a file's bytes, read ``block`` bytes at a time (never whole)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            data = f.read(block)
            if not data:
                break
            h.update(data)
    return h.hexdigest()


def canonical_json(data: object) -> str:
    """JSON with sorted keys and no spaces; floats that equal an integer stay floats
    (``300`` and ``300.0`` differ, as they may for a setting's type)."""
    return json.dumps(_plain(data), sort_keys=True, separators=(",", ":"), allow_nan=False)


def _plain(v: object) -> object:
    if isinstance(v, Mapping):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    return v


def task_key(
    *,
    log_sha256: str,
    kind: str,
    estimators: Sequence[str],
    settings: Mapping[str, object],
    seed: int,
    extra: Mapping[str, object] | None = None,
    version: str = __version__,
) -> str:
    """The key of one task: 64 hex digits. Estimator order does not matter."""
    doc = {
        "log_sha256": log_sha256,
        "kind": kind,
        "estimators": sorted(estimators),
        "settings": dict(settings),
        "seed": int(seed),
        "extra": dict(extra or {}),
        "lgvtool_version": version,
    }
    return hashlib.sha256(canonical_json(doc).encode()).hexdigest()


class HashCache:
    """Content hashes of files, remembered by (absolute path, size, modification time) in a
    small JSON file, so a re-run does not read every log again.

    :param path: the JSON file (created on :meth:`save`); None: remember nothing.
    """

    def __init__(self, path: str | Path | None) -> None:
        self.path = Path(path) if path is not None else None
        self._entries: dict[str, dict[str, Any]] = {}
        if self.path is not None and self.path.is_file():
            try:
                data = json.loads(self.path.read_text(encoding="utf-8"))
                if isinstance(data, dict):
                    self._entries = {k: v for k, v in data.items() if isinstance(v, dict)}
            except (OSError, ValueError):
                self._entries = {}

    def _stat(self, file: Path) -> tuple[str, int, int]:
        st = file.stat()
        return str(file.resolve()), st.st_size, st.st_mtime_ns

    def lookup(self, file: str | Path) -> str | None:
        """The remembered hash of ``file`` if it is unchanged since, else None."""
        name, size, mtime = self._stat(Path(file))
        e = self._entries.get(name)
        if e and e.get("size") == size and e.get("mtime_ns") == mtime:
            sha = e.get("sha256")
            return sha if isinstance(sha, str) else None
        return None

    def hash(self, file: str | Path) -> str:
        """The SHA-256 of ``file``: remembered, or read now and remembered."""
        sha = self.lookup(file)
        if sha is None:
            name, size, mtime = self._stat(Path(file))
            sha = file_sha256(file)
            self._entries[name] = {"size": size, "mtime_ns": mtime, "sha256": sha}
        return sha

    def hash_many(self, files: Sequence[str | Path], *, threads: int = HASH_THREADS) -> list[str]:
        """Hashes of ``files`` in order, reading the unknown ones on ``threads`` threads."""
        out: list[str | None] = [self.lookup(f) for f in files]
        todo = [i for i, sha in enumerate(out) if sha is None]
        if todo:
            stats = {i: self._stat(Path(files[i])) for i in todo}
            with ThreadPoolExecutor(max_workers=max(1, threads)) as pool:
                for i, sha in zip(todo, pool.map(lambda i: file_sha256(files[i]), todo), strict=True):
                    name, size, mtime = stats[i]
                    self._entries[name] = {"size": size, "mtime_ns": mtime, "sha256": sha}
                    out[i] = sha
        return [s for s in out if s is not None]

    def save(self) -> None:
        """Write the cache file atomically (nothing without a path)."""
        if self.path is None:
            return
        write_json_atomic(self.path, self._entries)


def json_safe(v: object) -> object:
    """A JSON-ready copy of ``v``: mappings and sequences copied, non-finite floats None."""
    if isinstance(v, Mapping):
        return {str(k): json_safe(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [json_safe(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def json_text(data: object) -> str:
    """``data`` as the JSON text the sweep's files hold (indented by one, NaN refused)."""
    return json.dumps(data, indent=1, allow_nan=False) + "\n"


def write_json_atomic(path: str | Path, data: object) -> None:
    """Write ``data`` as JSON to ``path`` through a temporary file and a rename, so a reader
    (or a re-run after a crash) never sees half a file."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        text = json_text(data)
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
