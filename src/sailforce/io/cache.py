"""Caches on disk (the solid's poses, the seed model's fits): each entry says what it answers, and is checked on every read.

An entry is a JSON file ``{key}.json``::

    {"format": FORMAT, "key": KEY, "inputs": {...}, "value": {...}, "sha256": ...}

with ``FORMAT`` the cache's own (``sailforce-solid-cache``, ``sailforce-fit-cache``),
``KEY`` the SHA-256 of the canonical JSON of ``inputs`` (everything
that decides the result) and ``sha256`` that of ``{key, inputs, value}``.  A
read is taken only if the file is a regular file (a symlink is never
followed), no larger than :data:`MAX_ENTRY_BYTES`, its checksum matches, its
key is its name's and its inputs' and its inputs are the request's, and its
value passes the caller's check (shapes, finite numbers, the pose).  Any other
entry is solved again and replaced, with a note saying why.  Writes go to a
temporary file in the cache folder, renamed over the entry's name itself:
a symlink there is replaced, never written through.  A cache that cannot be
written (read-only, full) keeps this process's results in memory and says so.
"""

from __future__ import annotations

import hashlib
import json
import os
import secrets
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import CacheEntryError

#: The ``format`` field of the solid's entries (:class:`sailforce.solid.cache.SolidCache`).
ENTRY_FORMAT = "sailforce-solid-cache"

#: An entry larger than this is not one of ours [bytes]: a pose's result is under 2 KB, a family fit's under 20 KB.
MAX_ENTRY_BYTES = 1 << 20

#: The cache directory when none is given: $SAIL_CACHE_DIR, else $XDG_CACHE_HOME/sailforce/<kind>.
CACHE_ENV = "SAIL_CACHE_DIR"


def default_cache_dir(kind: str) -> Path:
    """``$SAIL_CACHE_DIR``, else ``$XDG_CACHE_HOME/sailforce/<kind>`` (``~/.cache/sailforce/<kind>``)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "sailforce" / kind


def code_fingerprint() -> str:
    """SHA-256 of every source file of sailforce, by path: a cache keyed on it is never read by other code."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        root = Path(__file__).resolve().parents[1]
        digest = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        _FINGERPRINT = digest.hexdigest()
    return _FINGERPRINT


_FINGERPRINT: str | None = None

#: Results this process could not write to its cache, by (folder, key): a read-only cache still solves each pose once.
_MEMORY: dict[tuple[str, str], dict] = {}


def _canonical(value: object) -> bytes:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def canonical_json(value: dict) -> dict:
    """``value`` as it reads back from an entry (tuples become lists ...): the form to key and compare."""
    return json.loads(_canonical(value))


def cache_key(inputs: dict) -> str:
    """SHA-256 of the canonical JSON of ``inputs``."""
    return hashlib.sha256(_canonical(inputs)).hexdigest()


@dataclass
class DiskCache:
    """The cache folder (None: no cache), its entries' format, and the notes for people about what it did (damaged, unwritable)."""

    directory: Path | None
    notes: list[str] = field(default_factory=list)
    entry_format: str = ENTRY_FORMAT

    def read(self, inputs: dict, check: Callable[[dict], object]) -> object | None:
        """``check(value)`` of the entry for ``inputs``, or None when there is none or it cannot be trusted."""
        if self.directory is None:
            return None
        key = cache_key(inputs)
        remembered = _MEMORY.get((str(self.directory), key))
        path = self.directory / f"{key}.json"
        try:
            value = remembered if remembered is not None else _read_entry(path, key, inputs, self.entry_format)
            return None if value is None else check(value)
        except (CacheEntryError, ValueError, KeyError, TypeError, IndexError, OSError) as exc:
            self.notes.append(f"cache entry {path} is damaged ({exc}); solved again")
            return None

    def write(self, inputs: dict, value: dict) -> None:
        """Store ``value`` as the entry for ``inputs`` (atomically, never through a symlink)."""
        if self.directory is None:
            return
        key = cache_key(inputs)
        entry = {"format": self.entry_format, "key": key, "inputs": inputs, "value": value}
        entry["sha256"] = hashlib.sha256(_canonical(entry)).hexdigest()
        try:
            _write_entry(self.directory, f"{key}.json", _canonical(entry))
        except OSError as exc:
            if not any(n.startswith(f"the cache {self.directory}") for n in self.notes):
                self.notes.append(f"the cache {self.directory} cannot be written ({exc.strerror or exc}); "
                                  "this run's results are kept in memory only")  # fmt: skip
            _MEMORY[(str(self.directory), key)] = value


def _read_entry(path: Path, key: str, inputs: dict, entry_format: str) -> dict | None:
    try:
        handle = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        return None
    except OSError as exc:
        if os.path.islink(path):
            raise CacheEntryError("it is a symlink, which the cache never follows") from None
        raise CacheEntryError(exc.strerror or str(exc)) from None
    info = os.fstat(handle)
    if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_ENTRY_BYTES:
        os.close(handle)
        raise CacheEntryError("not a regular file" if not stat.S_ISREG(info.st_mode) else f"{info.st_size} bytes, larger than any entry")
    with os.fdopen(handle, "rb") as stream:
        data = stream.read(MAX_ENTRY_BYTES + 1)
    try:
        entry = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise CacheEntryError(f"not JSON: {exc}") from None
    if not isinstance(entry, dict) or entry.get("format") != entry_format:
        raise CacheEntryError(f"not an entry of this cache (format {entry_format})")
    claimed = entry.pop("sha256", None)
    try:
        actual = hashlib.sha256(_canonical(entry)).hexdigest()
    except (TypeError, ValueError) as exc:
        raise CacheEntryError(f"content a cache entry cannot hold ({exc})") from None
    if claimed != actual:
        raise CacheEntryError("its checksum does not match its content")
    stored = entry.get("inputs")
    if entry.get("key") != key or not isinstance(stored, dict) or cache_key(stored) != key:
        raise CacheEntryError("its key is not its name's")
    if entry["inputs"] != inputs:
        raise CacheEntryError("it answers another request")
    value = entry.get("value")
    if not isinstance(value, dict):
        raise CacheEntryError("no value")
    return value


def _write_entry(directory: Path, name: str, data: bytes) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    tmp = directory / f".{name}.{secrets.token_hex(6)}.tmp"
    handle = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, directory / name)  # replaces the name itself: a symlink there is replaced, its target untouched
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
