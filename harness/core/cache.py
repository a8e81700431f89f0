"""On-disk cache of symbolic derivations and of the numeric code made from them, shared by every
run and process.

A sympy derivation is costly (docs/findings/speed.md) and depends only on source
code, so it is stored once, as data, under the user's cache directory
(``$XDG_CACHE_HOME/mjharness`` or ``~/.cache/mjharness``) and loaded by later
runs and by parallel workers. So is the numeric code lambdified from it at a
model's parameter values (``analytic.dynamics.Compiled``; harness/reference/derivations.py).
Beside each entry the seconds it took to compute are kept, so that a scheduler
can put the costliest work first without a hand-measured table.

An entry's key is a hash of everything the result depends on: the source text
of the files that define it (the system module, ``analytic/systems/__init__.py``
and ``analytic/lagrangian.py``; for numeric code also ``analytic/dynamics.py``
and the parameter values), the sympy and Python versions and :data:`FORMAT`.
Editing a system, the Lagrangian machinery or upgrading sympy changes the key,
so a stale entry is never read; old entries are simply left behind.

An entry is a one-line JSON header, then the value as JSON data
(:mod:`harness.core.stored`: a closed vocabulary of numbers, arrays, a few
dataclasses and sympy expression trees, never a pickle), so an entry that
someone else wrote can at worst hold wrong data, never run code (docs/security.md).
The header names what the entry holds (its kind, its system's name and the full
key) and the SHA-256 of the value's bytes, so an entry whose bytes changed since
they were written by accident (a truncated or damaged file) or that holds another
entry's value (a file copied into another system's slot) is never used.

The cache is an optimisation only: an entry that cannot be read (missing,
corrupt, truncated, altered, another's, of the wrong type) or used (see
:func:`cached`) is recomputed and stored over, and a directory that cannot be
written is skipped, both silently, because the recomputed value is the
correct one. Entries are written to a temporary file and renamed into place,
so concurrent writers never leave a half-written entry.
``MJHARNESS_NO_CACHE=1`` turns the cache off.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

from harness.core import stored

__all__ = ["cache_dir", "cached", "cost", "entry_bytes", "has", "key", "load", "load_file", "source_key", "store",
           "write_atomic"]

T = TypeVar("T")
R = TypeVar("R")

FORMAT = "3"  # bump when what is stored changes shape (2: a header with identity and checksum; 3: data, no pickle)
SUFFIX = ".entry"


def cache_dir() -> Path | None:
    """Where entries live, or None when the cache is turned off."""
    if os.environ.get("MJHARNESS_NO_CACHE", "").strip() not in ("", "0"):
        return None
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    # the XDG spec: a relative path is invalid and ignored (it would put the cache wherever the run starts)
    root = Path(base) if base and os.path.isabs(base) else Path.home() / ".cache"
    return root / "mjharness"


def _sympy_release() -> bytes:
    """sympy's release file (``__version__ = "..."``), read rather than imported: a run whose entries
    are all cached never loads sympy. Where a sympy has no such file, its installed
    version from the package metadata (slower to read, still no import)."""
    spec = importlib.util.find_spec("sympy")
    if spec is not None and spec.origin is not None:
        with contextlib.suppress(OSError):
            return (Path(spec.origin).parent / "release.py").read_bytes()
    from importlib.metadata import version  # lazy: a rare fallback, and importlib.metadata is slow to import

    return version("sympy").encode()


def key(*parts: str | bytes, versions: bool = True) -> str:
    """A hex digest of ``parts`` and (``versions``) of the Python and sympy versions every entry of the user's
    cache depends on."""
    digest = hashlib.sha256()
    for part in (FORMAT, *((sys.version.split()[0], _sympy_release()) if versions else ()), *parts):
        data = part if isinstance(part, bytes) else part.encode()
        digest.update(len(data).to_bytes(8, "little"))
        digest.update(data)
    return digest.hexdigest()


def source_key(files: Iterable[Path | str], *, versions: bool = True) -> str:
    """:func:`key` of the text of ``files`` (a missing file counts as empty)."""
    texts = []
    for f in files:
        try:
            texts.append(Path(f).read_bytes())
        except OSError:
            texts.append(b"")
    return key(*(str(Path(f).name) for f in files), *texts, versions=versions)


def _path(kind: str, name: str, digest: str) -> Path | None:
    root = cache_dir()
    return None if root is None else root / kind / f"{name}-{digest[:32]}{SUFFIX}"


def cost(kind: str, name: str, digest: str) -> float | None:
    """Seconds the entry took to compute when it was stored (None if unknown): schedulers order work by it."""
    path = _path(kind, name, digest)
    if path is None:
        return None
    try:
        return float(path.with_suffix(".seconds").read_text())
    except (OSError, ValueError):
        return None


def has(kind: str, name: str, digest: str) -> bool:
    """Whether an entry is stored (a hint only: it may still turn out unreadable)."""
    path = _path(kind, name, digest)
    return path is not None and path.is_file()


def _identity(kind: str, name: str, digest: str, payload: bytes) -> dict[str, str]:
    """What an entry's header says: what it holds, and the checksum of its value's bytes."""
    return {"format": FORMAT, "kind": kind, "name": name, "key": digest,
            "sha256": hashlib.sha256(payload).hexdigest()}


def entry_bytes(kind: str, name: str, digest: str, value: object) -> bytes | None:
    """An entry's bytes: its header (what it holds, the checksum of its value's bytes), then ``value`` as
    data (:func:`harness.core.stored.dumps`); None for a value outside that vocabulary."""
    try:
        payload = stored.dumps(value)
    except (ValueError, TypeError, RecursionError):  # a value that is not plain data
        return None
    return json.dumps(_identity(kind, name, digest, payload), sort_keys=True).encode() + b"\n" + payload


def read_header(path: Path) -> dict | None:
    """The header of the entry stored at ``path`` (None if there is none that reads)."""
    try:
        with path.open("rb") as fh:
            header = json.loads(fh.readline())
    except (OSError, ValueError):
        return None
    return header if isinstance(header, dict) else None


def load(kind: str, name: str, digest: str, expected: type) -> object | None:
    """The entry, or None when it is absent, not the entry of (kind, name, digest), altered since it was
    written, or unusable for any other reason."""
    path = _path(kind, name, digest)
    return None if path is None else load_file(path, kind, name, digest, expected)


def load_file(path: Path, kind: str, name: str, digest: str, expected: type) -> object | None:
    """:func:`load` of the entry stored at ``path``, wherever it is (the package's own entries too)."""
    try:
        head, _, payload = path.read_bytes().partition(b"\n")
        if json.loads(head) != _identity(kind, name, digest, payload):
            return None  # another entry's, or bytes changed since they were written
        value = stored.loads(payload)  # data only: nothing in an entry runs
    except Exception:  # missing, unreadable, truncated, corrupt, from an incompatible version
        return None
    return value if isinstance(value, expected) else None


def write_atomic(path: Path, data: bytes) -> bool:
    """Write ``data`` to ``path`` through a temporary file renamed into place (concurrent writers never
    leave a half-written file); False, and nothing left behind, where that is not possible."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("wb", dir=path.parent, prefix=f".{path.name}.", delete=False) as fh:
            tmp = Path(fh.name)
            fh.write(data)
        os.replace(tmp, path)
        return True
    except Exception:  # read-only or full disk, a name in the way
        if tmp is not None:
            with contextlib.suppress(OSError):
                tmp.unlink()
        return False


def store(kind: str, name: str, digest: str, value: object, *, seconds: float | None = None) -> bool:
    """Write the entry atomically (and, if given, the ``seconds`` it took to compute); False where that
    is not possible."""
    path = _path(kind, name, digest)
    data = None if path is None else entry_bytes(kind, name, digest, value)
    if path is None or data is None:
        return False
    stored = write_atomic(path, data)
    if stored and seconds is not None:
        write_atomic(path.with_suffix(".seconds"), f"{seconds:.6f}".encode())
    return stored


def cached(kind: str, name: str, digest: str, compute: Callable[[], T], expected: type,
           open_: Callable[[T], R] | None = None) -> R:
    """``open_`` of the entry for (kind, name, digest) if it can be loaded and opened, else of
    ``compute()``, stored (over the entry) for next time. ``open_`` (default: the value itself) turns
    an entry into what the caller uses; an entry it raises on is unusable here (e.g. code that names
    a function this numpy lacks) and is recomputed like a corrupt one."""
    opening: Callable[[T], R] = open_ if open_ is not None else (lambda v: v)  # type: ignore[assignment,return-value]
    value = load(kind, name, digest, expected)
    if value is not None:
        try:
            return opening(value)  # type: ignore[arg-type]
        except Exception:  # unusable here: the recomputed value below is the right one
            pass
    start = time.perf_counter()
    value = compute()
    store(kind, name, digest, value, seconds=time.perf_counter() - start)
    return opening(value)
