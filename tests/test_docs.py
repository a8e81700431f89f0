"""Every code example in README.md, docs/ and examples/ runs here, and what it prints is compared with what
the page shows, so that the guide cannot drift from the tool.

A fenced block's language says how it runs:

- ``console``: each ``$ COMMAND`` line runs in bash from the repository's root (the installed
  ``mjharness`` first on the PATH), its stdout and stderr together compared with the lines below it up
  to the next ``$``; ``...`` stands for any text (doctest's ELLIPSIS), runs of whitespace compare equal.
- ``pycon``: a doctest (``>>>`` lines and the output below them), from the repository's root.
- ``python`` whose first line is ``# test_NAME.py``: a test file for the ``mjharness`` pytest fixture,
  written beside copies of what it names and run by pytest; it must pass.
- ``toml``: a ``--config`` file, loaded as ``check --config`` loads it.
- ``yaml``: a CI recipe: each ``run: mjharness ...`` line's arguments must be accepted by the parser.
- ``bash``: install commands only (``pip install``, ``python3 -m venv``), which a fresh clone and CI run
  (``.ci/run``); anything else in a bash block fails here.
- untagged or ``text``: a display (a layout, a diagram), never a command or a session: a line that
  starts like one (``$ ``, ``>>> ``, ``mjharness ``) fails here.

The printed numbers are MuJoCo 4.0.0's (the version the guide documents); on another MuJoCo the examples
still run and must succeed, but their output is not compared.
"""

from __future__ import annotations

import doctest
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import mujoco
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTED_MUJOCO = "4.0.0"  # the release whose output the guide prints
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "examples").rglob("*.md")])
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
RUNS = {"console", "pycon", "python", "toml", "yaml", "bash"}
DISPLAYS = {"", "text"}
LOOKS_RUNNABLE = re.compile(r"^\s*(\$ |>>> |mjharness )")
INSTALL = re.compile(r"^(python3 -m venv \.venv && )?(\.venv/bin/)?pip install \S+( && .*)?$")


@dataclass(frozen=True)
class Block:
    page: Path
    line: int
    language: str
    text: str

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}:{self.language or 'text'}"


def blocks(page: Path) -> list[Block]:
    """The fenced code blocks of a markdown page, with the line each starts on."""
    out, lines, i = [], page.read_text().splitlines(), 0
    while i < len(lines):
        m = re.match(r"^(\s*)```(\w*)\s*$", lines[i])
        if not m:
            i += 1
            continue
        indent, start, body = len(m.group(1)), i + 1, []
        i += 1
        while i < len(lines) and not re.match(r"^\s*```\s*$", lines[i]):
            body.append(lines[i][indent:])
            i += 1
        out.append(Block(page, start, m.group(2), "\n".join(body) + "\n"))
        i += 1
    return out


ALL = [b for page in PAGES for b in blocks(page)]


def of(*languages: str) -> list:
    return [pytest.param(b, id=b.id) for b in ALL if b.language in languages]


def compare(got: str, want: str, where: str) -> None:
    if mujoco.__version__ != DOCUMENTED_MUJOCO:
        return
    checker = doctest.OutputChecker()
    if not checker.check_output(want, got, FLAGS):
        example = doctest.Example("", want)
        pytest.fail(f"{where} prints otherwise than the page shows:\n"
                    f"{checker.output_difference(example, got, FLAGS)}")


def environment() -> dict[str, str]:
    """The test's own interpreter's scripts first on the PATH (the installed ``mjharness``), no terminal."""
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "MJHARNESS_TRACEBACK")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


def sessions(text: str) -> list[tuple[str, str]]:
    """A console block's ``$ command`` lines, each with the output the page shows under it."""
    out: list[tuple[str, list[str]]] = []
    for line in text.splitlines():
        if line.startswith("$ "):
            out.append((line[2:], []))
        elif out:
            out[-1][1].append(line)
        elif line.strip():
            raise AssertionError(f"a console block starts with output, not a '$ ' command: {line!r}")
    return [(cmd, "\n".join(lines).strip("\n") + "\n" if any(s.strip() for s in lines) else "")
            for cmd, lines in out]


def test_every_page_is_found_and_every_block_has_a_known_kind():
    assert ROOT / "README.md" in PAGES and len(PAGES) > 3
    unknown = [b.id for b in ALL if b.language not in RUNS | DISPLAYS]
    assert not unknown, f"code blocks of a kind this test does not run: {unknown}"


@pytest.mark.parametrize("block", of("", "text"))
def test_a_display_holds_no_command(block):
    runnable = [line for line in block.text.splitlines() if LOOKS_RUNNABLE.match(line)]
    assert not runnable, f"{block.id}: a display block holds what reads as a command; make it a console or pycon " \
                         f"block, which this test runs: {runnable}"


@pytest.mark.parametrize("block", of("bash"))
def test_a_bash_block_only_installs(block):
    for line in block.text.splitlines():
        command = line.split("#")[0].strip()
        assert not command or INSTALL.match(command), f"{block.id}: {command!r} is not an install command; " \
                                                      "show a command as a console block, which this test runs"


@pytest.mark.slow  # runs the guide's commands, each a whole check: with the slow tests, which CI runs
@pytest.mark.parametrize("block", of("console"))
def test_console_example(block):
    for command, want in sessions(block.text):
        done = subprocess.run(["bash", "-c", command], cwd=ROOT, env=environment(), stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, timeout=600)  # as a terminal shows both
        got = done.stdout
        assert "Traceback" not in got, f"{block.id}: `{command}` crashed:\n{got}"
        if "echo" not in command:  # a command whose exit the page does not print must succeed
            assert done.returncode == 0, f"{block.id}: `{command}` exited {done.returncode}:\n{got}"
        compare(got, want, f"{block.id}: `{command}`")


@pytest.mark.slow  # runs the guide's commands, each a whole check: with the slow tests, which CI runs
@pytest.mark.parametrize("block", of("pycon"))
def test_python_session(block, monkeypatch):
    monkeypatch.chdir(ROOT)
    test = doctest.DocTestParser().get_doctest(block.text, {}, block.id, str(block.page), block.line)
    checker = doctest.OutputChecker() if mujoco.__version__ == DOCUMENTED_MUJOCO else _AnyOutput()
    runner = doctest.DocTestRunner(checker=checker, optionflags=FLAGS)
    report: list[str] = []
    runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)


class _AnyOutput(doctest.OutputChecker):
    """On another MuJoCo the examples must run without error; their printed numbers are 4.0.0's."""

    def check_output(self, want, got, optionflags):
        return True


@pytest.mark.slow  # runs the guide's commands, each a whole check: with the slow tests, which CI runs
@pytest.mark.parametrize("block", of("python"))
def test_pytest_example(block, tmp_path):
    first = block.text.splitlines()[0]
    m = re.fullmatch(r"# (test_\w+\.py)", first.strip())
    assert m, f"{block.id}: a python block must start with '# test_NAME.py' (it is run as that test file)"
    for path in re.findall(r"\"((?:examples|mjcf)/[\w./-]+\.xml)\"", block.text):  # the models it names, as given
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / path, tmp_path / path)
    (tmp_path / m.group(1)).write_text(block.text)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", m.group(1)],
                          cwd=tmp_path, env=environment(), capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{block.id}: the example test fails:\n{done.stdout}\n{done.stderr}"
    assert re.search(r"\b\d+ passed\b", done.stdout), done.stdout


@pytest.mark.parametrize("block", of("toml"))
def test_config_example(block, tmp_path):
    from harness.pipeline.limits import load_limits

    path = tmp_path / "mjharness.toml"
    path.write_text(block.text)
    load_limits(path)  # an unknown key, case or figure, or a bad value, raises


@pytest.mark.parametrize("block", of("yaml"))
def test_ci_recipe(block):
    from harness.cli.commands import _parser

    commands = re.findall(r"run:\s*(mjharness .*?)\s*(?:#.*)?$", block.text, flags=re.M)
    assert commands, f"{block.id}: a CI recipe with no mjharness command"
    for command in commands:
        _parser().parse_args(shlex.split(command)[1:])  # argparse exits 2 on what it does not accept


def indented_code(page: Path) -> list[int]:
    """The lines where an indented (unfenced) code block starts: markdown shows it as code, this test
    could not tell how to run it. A list item's continuation is not one."""
    starts, fenced, lines = [], False, page.read_text().splitlines()
    for i, line in enumerate(lines):
        if re.match(r"^\s*```", line):
            fenced = not fenced
            continue
        if fenced or not line.startswith("    ") or not line.strip() or i == 0 or lines[i - 1].strip():
            continue
        before = next((b for b in reversed(lines[:i]) if b.strip()), "")
        if not re.match(r"^(\s|[-*+] |\d+\. |\|)", before):
            starts.append(i + 1)
    return starts


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_example_hides_in_an_indented_block(page):
    assert not indented_code(page), f"{page.relative_to(ROOT)}: indented code blocks at lines {indented_code(page)}; " \
                                    "fence them with a language (console, pycon, ...) so that this test runs them"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_leads_to_a_file(page):
    links = re.findall(r"\]\(([^)\s#]+)(?:#[^)]*)?\)", page.read_text())
    missing = [link for link in links if "://" not in link and not (page.parent / link).exists()]
    assert not missing, f"{page.relative_to(ROOT)} links to what does not exist: {missing}"
