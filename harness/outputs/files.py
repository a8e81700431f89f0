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
- A report folder holds a manifest of the files the last run wrote there, with
  their SHA-256 (:data:`MANIFEST`). Only those, unchanged since, are ever
  replaced, removed or marked stale; a folder that is not the user's, that holds
  anything else, or where a link would lead a write out of it is refused before
  the run (:func:`check_report_folder`) unless the user forces it, and even then
  nothing else in it is removed (docs/security.md).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import tempfile
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = ["AUDIT_PAGE", "BACKENDS_PAGE", "CASE_PAGES", "FORCE", "INERTIA_PAGE", "MANIFEST", "PAGES", "REPORT_FILES",
           "STALE", "STUDIES_PAGE", "check_output", "check_report_folder", "mark_stale", "ours", "prepare_output",
           "superseded", "with_manifest", "write_atomic"]

STALE = ".stale"
REPORT_FILES = ("report.html", "report.json", "summary.md")  # what `mjharness run` writes into --out, always
CASE_PAGES = "cases"  # and a page per case in this folder, NAME.html
STUDIES_PAGE, AUDIT_PAGE, BACKENDS_PAGE = "studies.html", "audit.html", "backends.html"
INERTIA_PAGE = "inertia.html"
PAGES = (STUDIES_PAGE, AUDIT_PAGE, BACKENDS_PAGE, INERTIA_PAGE)  # and these where the run has them
MANIFEST = ".mjharness-manifest.json"  # the files the last run wrote into its folder, with their SHA-256
MANIFEST_BYTES = 1 << 20  # a manifest larger than this is not one of ours
FORCE = "--force-out"  # the run's option that writes into a folder that is not, or not only, its own


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


def _sha256(path: Path) -> str | None:
    """The SHA-256 of the regular file ``path`` (never through a link), or None."""
    try:
        if not stat.S_ISREG(path.lstat().st_mode):
            return None
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def manifest(out: Path | str) -> dict[str, str]:
    """The files an earlier run wrote into ``out`` (paths relative to it) with their SHA-256; empty where there
    is no manifest that reads as one."""
    path = Path(out) / MANIFEST
    try:
        st = path.lstat()
        if not stat.S_ISREG(st.st_mode) or st.st_size > MANIFEST_BYTES:
            return {}
        listed = json.loads(path.read_bytes()).get("files", {})
    except (OSError, ValueError, AttributeError):
        return {}
    if not isinstance(listed, dict):
        return {}
    return {k: v for k, v in listed.items() if isinstance(k, str) and isinstance(v, str) and _relative(k)}


def _relative(name: str) -> bool:
    """Whether ``name`` is a plain relative path inside the folder (no ``..``, not absolute)."""
    parts = Path(name).parts
    return bool(parts) and not Path(name).is_absolute() and ".." not in parts


def ours(out: Path | str) -> list[Path]:
    """The files in ``out`` that an earlier run wrote and that are unchanged since (a file it marked
    ``.stale`` too): the only ones a run may replace, remove or mark stale."""
    out = Path(out)
    found = []
    for name, digest in manifest(out).items():
        for path in (out / name, out / (name + STALE)):
            if _inside(out, path) and _sha256(path) == digest:
                found.append(path)
    return found


def _inside(out: Path, path: Path) -> bool:
    """Whether ``path`` is in ``out`` without passing through a link (nothing written or removed leaves it)."""
    try:
        rel = path.relative_to(out)
    except ValueError:
        return False
    probe = out
    for part in rel.parts[:-1]:
        probe = probe / part
        try:
            if not stat.S_ISDIR(probe.lstat().st_mode):
                return False
        except OSError:
            return True  # not there yet: made by the run, as a folder
    return True


def check_report_folder(out: Path | str, *, force: bool = False) -> Path:
    """ValueError, in one line, unless the run may write its report into ``out``: a folder of the user's (or
    one it can create) holding nothing but an earlier run's files (:func:`ours`) and no link where the
    report writes (its ``cases`` folder). ``force`` (the user's :data:`FORCE`) lets a folder that is not the
    user's, or holds other files, be written into; a link is refused whatever. Creates nothing."""
    out = Path(out)
    if out.is_symlink() and not out.exists():
        raise ValueError(f"--out {str(out)!r} is a link to {os.readlink(out)!r}, which does not exist; give a "
                         "folder")
    check_output(out)
    if not out.exists():
        return out
    pages = out / CASE_PAGES
    if pages.is_symlink() or (pages.exists() and not pages.is_dir()):
        raise ValueError(f"--out {str(out)!r}: {str(pages)!r} is not a folder of its own (a link or a file); "
                         "the report writes its case pages there and never through a link: remove it or give "
                         "another --out")
    if force:
        return out
    if out.stat().st_uid != os.geteuid():
        raise ValueError(f"--out {str(out)!r} is not your folder (owned by uid {out.stat().st_uid}); give a "
                         f"folder of yours, or {FORCE} to write into it anyway (nothing else in it is removed)")
    known = {*ours(out), out / MANIFEST, pages}  # as out / NAME, never resolved: a link is never ours
    entries = [*out.iterdir(), *(pages.iterdir() if pages.is_dir() else ())]
    foreign = sorted(str(p.relative_to(out)) for p in entries if p not in known)
    if foreign:
        shown = ", ".join(repr(f) for f in foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise ValueError(f"--out {str(out)!r} holds files no earlier mjharness run wrote there ({shown}); give an "
                         f"empty or new folder, or {FORCE} to write beside them (they are never removed)")
    return out


def with_manifest(out: Path | str, files: Mapping[Path, str]) -> dict[Path, str]:
    """``files`` and the manifest of those of them inside ``out`` (:data:`MANIFEST`), to be written with them; the
    files an earlier run wrote there and that are still as it wrote them stay listed (a zoo's table written beside a
    report leaves the report's files the runs' own)."""
    out = Path(out)
    kept = {str(p.relative_to(out)) for p in ours(out) if not p.name.endswith(STALE)}
    listed = {name: digest for name, digest in manifest(out).items() if name in kept}
    for path, text in files.items():
        with contextlib.suppress(ValueError):
            listed[str(Path(path).relative_to(out))] = hashlib.sha256(text.encode("utf-8")).hexdigest()
    return {**files, out / MANIFEST: json.dumps({"format": 1, "files": dict(sorted(listed.items()))}, indent=1)
            + "\n"}


def report_pages(out: Path | str) -> list[Path]:
    """The report's pages in ``out`` now besides :data:`REPORT_FILES` that an earlier run wrote (:func:`ours`):
    its other pages and its case pages."""
    out = Path(out)
    return [p for p in ours(out) if not p.name.endswith(STALE) and (
        (p.parent == out / CASE_PAGES and p.suffix == ".html") or (p.parent == out and p.name in PAGES))]


def superseded(out: Path | str, files: Mapping[Path, str]) -> list[Path]:
    """The pages of the report in ``out`` that ``files``, a new report, does not replace: to be removed with its
    writing (``write_atomic(files, remove=...)``), so that the directory holds one run's pages only. Only pages
    an earlier run wrote, unchanged since (:func:`ours`): nothing else is ever removed."""
    new = {Path(p).resolve() for p in files}
    return [p for p in report_pages(out) if p.resolve() not in new]


def write_atomic(files: Mapping[Path, str | bytes], *, remove: Iterable[Path] = ()) -> list[Path]:
    """Write every file or none, and remove ``remove`` with them: each text (or bytes: a picture) beside its
    destination under a temporary name (missing folders created), then all moved into place and the others
    removed; where one cannot be, the destinations already replaced or removed get their old files back (and the
    folders made for them go)."""
    staged: list[tuple[Path, Path]] = []
    created: list[Path] = []
    written = False
    dest = None
    try:
        for dest, text in files.items():
            created += _make_folder(dest.parent)
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", dir=dest.parent)
            staged.append((Path(tmp), dest))
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 would make the report private
            if isinstance(text, bytes):
                with os.fdopen(fd, "wb") as raw:
                    raw.write(text)
            else:
                with os.fdopen(fd, "w", encoding="utf-8") as fh:
                    fh.write(text)
        _move_all(staged, list(remove))
        written = True
    except OSError as exc:  # a full disk names no file: the one being written then is named
        raise ValueError(f"cannot write {str(exc.filename or dest or '')!r}: {exc.strerror or exc}") from None
    finally:
        for staged_tmp, _ in staged:
            staged_tmp.unlink(missing_ok=True)
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
