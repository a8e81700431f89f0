"""Writing outputs so that a failed run never leaves a half-written file."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path


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
    """Write each text beside its destination under a temporary name, then move all into place."""
    staged: list[tuple[Path, Path]] = []
    try:
        for dest, text in files.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", dir=dest.parent)
            staged.append((Path(tmp), dest))
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 would make the report private
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
        for tmp, dest in staged:
            os.replace(tmp, dest)
    except OSError as exc:
        raise ValueError(f"cannot write {str(exc.filename or '')!r}: {exc.strerror}") from None
    finally:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
    return [dest for _, dest in staged]
