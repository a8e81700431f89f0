"""Reading a file the user named, bounded: a device, a FIFO or a huge file is refused in one line.

``--config /dev/zero`` grew past 5 GB in seconds and a FIFO hung the run (issue 45): every file input
(config and limits TOML, the ``--urdf-map``, the JSON documents of ``diff`` and ``baseline``, the MJCF and
URDF texts the harness reads itself) goes through :func:`read_bytes`. The file is judged by ``stat`` before
it is opened (opening a FIFO blocks until a writer comes), must be a regular file (a link to one is fine) and
at most ``limit`` bytes, and no more than that is ever read, should it grow meanwhile.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["DOCUMENT_LIMIT", "MODEL_LIMIT", "InputFileError", "check", "read_bytes", "read_text"]

MB = 1 << 20
TEXT_LIMIT = 16 * MB  # a config, limits or map file: kilobytes in practice
DOCUMENT_LIMIT = 256 * MB  # a report.json or baseline document of many cases
MODEL_LIMIT = 256 * MB  # an MJCF or URDF text (meshes are read by MuJoCo, not here)

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


class InputFileError(ValueError):
    """A file input that is not a regular file, or is larger than what is read: one line, exit 2."""


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def check(path: Path | str, *, what: str, limit: int = TEXT_LIMIT) -> os.stat_result:
    """``path``'s stat, once judged readable as an input: InputFileError unless it is a regular file of at most
    ``limit`` bytes (OSError as ``stat`` raises it where it is missing or unreadable)."""
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise InputFileError(f"{what} {str(path)!r} is {_kind(st.st_mode)}, not a file; give a regular file")
    if st.st_size > limit:
        raise InputFileError(f"{what} {str(path)!r} is {st.st_size / MB:.1f} MB, larger than the {limit // MB} MB "
                             "read; give a smaller file")
    return st


def read_bytes(path: Path | str, *, what: str, limit: int = TEXT_LIMIT) -> bytes:
    """The bytes of the file ``path`` (:func:`check`ed first), never more than ``limit`` of them."""
    check(path, what=what, limit=limit)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0)  # (a regular file: a FIFO put in its place won't block)
    fd = os.open(path, flags)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):  # replaced since it was judged
            raise InputFileError(f"{what} {str(path)!r} is {_kind(st.st_mode)}, not a file; give a regular file")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(MB, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    finally:
        os.close(fd)
    if size > limit:
        raise InputFileError(f"{what} {str(path)!r} grew past the {limit // MB} MB read; give a smaller file")
    return b"".join(chunks)


def read_text(path: Path | str, *, what: str, limit: int = TEXT_LIMIT) -> str:
    """:func:`read_bytes` decoded as UTF-8 (UnicodeDecodeError as ``bytes.decode`` raises it)."""
    return read_bytes(path, what=what, limit=limit).decode("utf-8")
