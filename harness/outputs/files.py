"""Writing outputs so that a failed run never leaves a half-written file, a mixed set, or an old verdict.

- A set of files (a report's html, json and summary with its JUnit) is
  replaced as a whole or not at all (:func:`write_atomic`): every file is
  written beside its destination under a temporary name first, then each is
  moved into place; where one cannot be, those already moved are put back as
  they were.
- A run that fails (exit 2) or is interrupted renames the report files it
  would have written to ``NAME.stale`` (:func:`mark_stale`), so that a CI step
  that publishes the report whatever happened (``if: always()``) finds no
  earlier PASS to publish.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path

STALE = ".stale"
REPORT_FILES = ("report.html", "report.json", "summary.md")  # what `mjharness run` writes into --out


def check_output(out: Path | str) -> Path:
    """ValueError unless ``out`` is, or can be created as, a writable directory. Creates nothing,
    so a run that fails later leaves no trace."""
    out = Path(out)
    probe = out
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise ValueError(f"cannot create output directory {str(out)!r}: {str(probe)!r} is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"output directory {str(out)!r} is not writable ({str(probe)!r} is read-only)")
    return out


def prepare_output(out: Path | str) -> Path:
    """Create ``out`` if needed; ValueError if it cannot be created or written."""
    out = check_output(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create output directory {str(out)!r}: {exc.strerror}") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"output directory {str(out)!r} is not writable")
    return out


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomic(files: Mapping[Path, str]) -> list[Path]:
    """Write every file or none: each text beside its destination under a temporary name, then all moved
    into place; where one cannot be moved, the destinations already replaced get their old files back."""
    staged: list[tuple[Path, Path]] = []
    try:
        for dest, text in files.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", dir=dest.parent)
            staged.append((Path(tmp), dest))
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 would make the report private
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
        _move_all(staged)
    except OSError as exc:
        raise ValueError(f"cannot write {str(exc.filename or '')!r}: {exc.strerror}") from None
    finally:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
    return [dest for _, dest in staged]


def _move_all(staged: list[tuple[Path, Path]]) -> None:
    """Move each staged file onto its destination, keeping what each held until all are moved; on an error,
    put every replaced destination back (and remove those that were new), then raise."""
    done: list[tuple[Path, Path | None]] = []  # (destination, its old file set aside, or None)
    try:
        for tmp, dest in staged:
            if dest.is_dir():
                raise IsADirectoryError(21, "Is a directory", str(dest))
            old = None
            if dest.exists():
                old = dest.with_name(f".{dest.name}.{uuid.uuid4().hex[:12]}.old")
                os.replace(dest, old)
            done.append((dest, old))
            os.replace(tmp, dest)
    except BaseException:
        for dest, old in reversed(done):
            with contextlib.suppress(OSError):
                if old is not None:
                    os.replace(old, dest)
                else:
                    dest.unlink(missing_ok=True)
        raise
    for _, old in done:
        if old is not None:
            old.unlink(missing_ok=True)


def mark_stale(paths: Iterable[Path]) -> list[Path]:
    """Rename each existing file of ``paths`` to ``NAME.stale`` (replacing an older one): the report of an
    earlier run, which a run that failed must not leave looking like its own. Best effort: a file that
    cannot be renamed is left as it is. Returns the new names."""
    marked = []
    for path in paths:
        if path.is_file():
            stale = path.with_name(path.name + STALE)
            with contextlib.suppress(OSError):
                os.replace(path, stale)
                marked.append(stale)
    return marked
