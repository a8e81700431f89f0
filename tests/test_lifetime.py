"""Nothing orphaned: a command's worker processes end when the command ends, whatever ends it.

The command runs in a session of its own, so every process it starts (its workers and their
children) shares its process group; after the command is killed, no process of that group may be
left running (zombies, which the kernel has already ended, do not count).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.core import lifetime
from tests.conftest import without_progress


def _stat(path: Path) -> tuple[int, str, int] | None:
    """(pid, state, process group) from /proc/PID/stat, or None once the process is gone."""
    try:
        text = path.read_text()
    except OSError:
        return None
    fields = text.rsplit(")", 1)[1].split()  # after the command name, which may hold spaces
    return int(path.parent.name), fields[0], int(fields[2])


def _group(pgid: int) -> set[int]:
    """The live (not zombie) processes of process group ``pgid``."""
    found = set()
    for path in Path("/proc").glob("[0-9]*/stat"):
        stat = _stat(path)
        if stat is not None and stat[2] == pgid and stat[1] != "Z":
            found.add(stat[0])
    return found


def _wait_for(condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc; the parent-death signal is Linux's")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_workers_end_when_the_parent_is_killed(tmp_path, sig):
    out, log = tmp_path / "report", tmp_path / "stderr"
    with log.open("w") as stderr:  # a file, not a pipe: a live worker would hold a pipe open
        proc = subprocess.Popen([sys.executable, "-m", "harness.cli", "run", "spring", "atwood", "--jobs", "2",
                                 "--out", str(out)], stdout=subprocess.DEVNULL, stderr=stderr,
                                start_new_session=True)
    try:
        assert _wait_for(lambda: len(_group(proc.pid) - {proc.pid}) >= 2, timeout=120), "no workers started"
        proc.send_signal(sig)
        proc.wait(timeout=60)
        assert _wait_for(lambda: not _group(proc.pid), timeout=5), f"left running: {sorted(_group(proc.pid))}"
    finally:
        for pid in _group(proc.pid):  # what a failed test would leave behind, started by this test
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err = log.read_text()
    if sig == signal.SIGTERM:  # the command's own handling: Ctrl-C's path, exit 128 + 15
        assert proc.returncode == 143, err
        assert without_progress(err).strip() == "mjharness: terminated (SIGTERM)"  # and the cases done before
        assert not (out / "report.html").exists() and not (out / "summary.md").exists()
    else:
        assert proc.returncode == -signal.SIGKILL


def test_a_child_whose_parent_already_died_exits(tmp_path):
    """The race the parent-death signal leaves open: a parent that dies before its child asks for the
    signal. The child finds another parent and exits at once instead of waiting forever."""
    code = ("import os, sys, time; from harness.core import lifetime; "
            "time.sleep(0.5); lifetime.die_with_parent(int(sys.argv[1])); time.sleep(60)")
    started = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", code, str(os.getpid() + 10**7)], timeout=30, check=False)
    assert proc.returncode == 1 and time.monotonic() - started < 30


def test_exit_codes_are_128_plus_the_signal():
    assert lifetime.exit_code(KeyboardInterrupt()) == 130
    assert lifetime.exit_code(lifetime.Terminated(signal.SIGTERM)) == 143
