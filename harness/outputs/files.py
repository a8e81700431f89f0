"""Writing outputs so that a failed run never leaves a half-written file, a mixed set, or an old verdict.

- A set of files (a report's pages, json and summary with its JUnit) is
  replaced as a whole or not at all (:func:`write_atomic`): every file is
  written beside its destination under a temporary name first, then each is
  moved into place; where one cannot be, those already moved are put back as
  they were. The pages of an earlier report that the new one has not (a case
  not run this time, studies skipped) go in the same step
  (:func:`superseded`), so no page of another run stays beside this one's.
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
REPORT_FILES = ("report.html", "report.json", "summary.md")  # what `mjharness run` writes into --out, always
CASE_PAGES = "cases"  # and a page per case in this folder, NAME.html
STUDIES_PAGE, AUDIT_PAGE, BACKENDS_PAGE = "studies.html", "audit.html", "backends.html"
INERTIA_PAGE = "inertia.html"
PAGES = (STUDIES_PAGE, AUDIT_PAGE, BACKENDS_PAGE, INERTIA_PAGE)  # and these where the run has them


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


def report_pages(out: Path | str) -> list[Path]:
    """The report's pages in ``out`` now besides :data:`REPORT_FILES`: its other pages and its case pages."""
    out = Path(out)
    return [p for p in (out / name for name in PAGES) if p.is_file()] + sorted(
        p for p in (out / CASE_PAGES).glob("*.html") if p.is_file())


def superseded(out: Path | str, files: Mapping[Path, str]) -> list[Path]:
    """The pages of the report in ``out`` that ``files``, a new report, does not replace: to be removed with its
    writing (``write_atomic(files, remove=...)``), so that the directory holds one run's pages only."""
    new = {Path(p).resolve() for p in files}
    return [p for p in report_pages(out) if p.resolve() not in new]


def write_atomic(files: Mapping[Path, str], *, remove: Iterable[Path] = ()) -> list[Path]:
    """Write every file or none, and remove ``remove`` with them: each text beside its destination under a
    temporary name (missing folders created), then all moved into place and the others removed; where one
    cannot be, the destinations already replaced or removed get their old files back (and the folders made
    for them go)."""
    staged: list[tuple[Path, Path]] = []
    created: list[Path] = []
    written = False
    try:
        for dest, text in files.items():
            created += _make_folder(dest.parent)
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", dir=dest.parent)
            staged.append((Path(tmp), dest))
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 would make the report private
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
        _move_all(staged, list(remove))
        written = True
    except OSError as exc:
        raise ValueError(f"cannot write {str(exc.filename or '')!r}: {exc.strerror}") from None
    finally:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        for folder in reversed(created if not written else []):
            with contextlib.suppress(OSError):
                folder.rmdir()
    return [dest for _, dest in staged]


def _make_folder(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; the folders created, outermost first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()][::-1]
    for p in missing:
        p.mkdir()
    return missing


def _move_all(staged: list[tuple[Path, Path]], remove: list[Path]) -> None:
    """Move each staged file onto its destination and set each of ``remove`` aside, keeping what each held
    until all are done; on an error, put every replaced or removed file back (and remove those that were new),
    then raise."""
    done: list[tuple[Path, Path | None]] = []  # (destination, its old file set aside, or None)
    try:
        for tmp, dest in [*staged, *((None, path) for path in remove)]:
            if dest.is_dir():
                raise IsADirectoryError(21, "Is a directory", str(dest))
            old = None
            if dest.exists():
                old = dest.with_name(f".{dest.name}.{uuid.uuid4().hex[:12]}.old")
                os.replace(dest, old)
            done.append((dest, old))
            if tmp is not None:
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
