"""Every file input is read bounded (issue 45, point 4): a device, a FIFO or a file larger than what is read is
refused in one line with exit 2, before it is opened (a FIFO would block the open; /dev/zero grew the process
past 5 GB in seconds).

Each probe runs under an alarm: a read that hangs or grows without end fails the test instead of the machine.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from harness.cli.commands import main
from harness.core import inputs

CASE = "pendulum"


class _Hung(Exception):
    pass


@pytest.fixture
def alarm():
    def hung(*_):
        raise _Hung("the input was read without bound (or blocked)")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def fifo(tmp_path) -> Path:
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return path


@pytest.fixture
def huge(tmp_path) -> Path:
    """A sparse file one byte larger than a document may be (no disk used)."""
    path = tmp_path / "huge.json"
    with open(path, "wb") as fh:
        fh.truncate(inputs.DOCUMENT_LIMIT + 1)
    return path


def _refused(capsys, args: list[str], *words: str) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert all(w in err for w in words), err


@pytest.mark.parametrize("source", ["/dev/zero", "fifo", "huge"])
@pytest.mark.parametrize("command", ["config", "diff", "compare", "urdf-map", "mjcf"])
def test_a_device_fifo_or_huge_input_is_refused_in_one_line(command, source, fifo, huge, tmp_path, alarm, capsys):
    path = {"/dev/zero": Path("/dev/zero"), "fifo": fifo, "huge": huge}[source]
    words = {"/dev/zero": "character device", "fifo": "FIFO", "huge": "larger than"}[source]
    if command == "mjcf" and source != "huge":
        words = "pipe" if source == "fifo" else "device"
    args = {"config": ["check", CASE, "--config", str(path)],
            "diff": ["diff", str(path), str(path)],
            "compare": ["baseline", "--compare", str(path)],
            "urdf-map": ["check", CASE, "--urdf", str(tmp_path / "x.urdf"), "--urdf-map", str(path)],
            "mjcf": ["check", "--mjcf", str(path)]}[command]
    if command == "urdf-map":
        pytest.importorskip("pinocchio")
        (tmp_path / "x.urdf").write_text("<robot name='x'><link name='a'/></robot>")
    _refused(capsys, args, str(path), words)


def test_the_bound_holds_for_a_file_that_grows_after_it_was_judged(tmp_path, monkeypatch):
    path = tmp_path / "grows.toml"
    path.write_bytes(b"x" * 2000)
    monkeypatch.setattr(inputs, "check", lambda *a, **k: None)  # judged small; it is not by the time it is read
    with pytest.raises(inputs.InputFileError, match="grew past"):
        inputs.read_bytes(path, what="config", limit=1000)


def test_a_regular_file_within_the_bound_is_read(tmp_path):
    path = tmp_path / "ok.toml"
    path.write_text("a = 1\n")
    assert inputs.read_text(path, what="config") == "a = 1\n"
