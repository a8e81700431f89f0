"""The public API is stated once, and every module's internals sit behind its ``__all__`` (docs/design.md, "The
public API" and "The private boundary"; the reading and the writer: tests/exports.py)."""

from __future__ import annotations

import ast
import re
import textwrap
from pathlib import Path

import harness
from tests import exports

DESIGN = exports.ROOT / "docs" / "design.md"


def _documented() -> list[str]:
    """The names docs/design.md's section "The public API" lists (each as `harness.NAME`)."""
    text = DESIGN.read_text(encoding="utf-8")
    section = text.split("\n### The public API\n", 1)[1].split("\n#", 1)[0]
    return re.findall(r"`harness\.(\w+)`", section)


def test_every_module_lists_what_is_used_from_it_and_nothing_crosses_unlisted():
    found = exports.problems()
    assert not found, "\n".join(found)


def test_the_public_api_is_the_list_in_the_docs():
    documented = _documented()
    assert len(documented) == len(set(documented)), "docs/design.md names a public name twice"
    missing = sorted(set(harness.__all__) - set(documented))
    extra = sorted(set(documented) - set(harness.__all__))
    assert not missing, f"in harness.__all__ but not in docs/design.md, 'The public API': {missing}"
    assert not extra, f"in docs/design.md, 'The public API', but not in harness.__all__: {extra}"


def test_every_public_name_exists():
    assert len(harness.__all__) == len(set(harness.__all__))
    absent = [name for name in harness.__all__ if not hasattr(harness, name)]
    assert not absent, f"harness.__all__ names what harness does not have: {absent}"
    assert dir(harness) == sorted(harness.__all__)
    tree = ast.parse(Path(harness.__file__).read_text(encoding="utf-8"))
    assert set(exports.defined(tree)) >= set(harness.__all__)  # each imported for the type checker too


def _package(root: Path, files: dict[str, str]) -> Path:
    for rel, text in {"analytic/__init__.py": "__all__: list[str] = []\n",
                      "mjcf/__init__.py": "__all__: list[str] = []\n", **files}.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(textwrap.dedent(text), encoding="utf-8")
    return root


BROKEN = {
    "harness/__init__.py": '"""The face."""\n\n__all__: list[str] = []\n',
    "harness/a.py": '''\
        """A module with a public, an unlisted and a private name."""

        import os
        from typing import TYPE_CHECKING

        if TYPE_CHECKING:
            from pathlib import Path

        __all__ = ["Path", "ghost", "shown"]


        def shown(): ...
        def hidden(): ...
        def read(): ...
        def tested(): ...
        def _private(): ...
        ''',
    "harness/b.py": '''\
        """Uses a: listed, unlisted, private, read off the module, and all of it."""

        from harness import a
        from harness.a import *
        from harness.a import _private, hidden, shown

        __all__ = ["VALUE"]

        VALUE = a.read()
        ''',
    "harness/c.py": '"""No __all__."""\n\nfrom harness.a import shown\n',
    "tests/test_a.py": '''\
        from harness import a
        from harness.a import _private, shown, tested

        a.os.getcwd()  # a monkeypatch's kind of reading: white-box, not the module's interface
        ''',
}


def test_the_check_fails_on_a_broken_package(tmp_path):
    """Each rule trips on a made-up package: a module without __all__, a listed name it does not define (or only for
    the type checker), an unlisted name imported or read off the module by the package, by a test, and an underscore
    name crossing modules."""
    root = _package(tmp_path, BROKEN)
    found = exports.problems(root)
    write = "`python -m tests.exports --write` does"
    assert sorted(found) == sorted([
        f"harness/c.py: no __all__; {write[:-5]} writes it (the names other modules use from it)",
        f"harness/a.py: __all__ names 'Path', which it does not define; remove it ({write})",  # not at run time
        f"harness/a.py: __all__ names 'ghost', which it does not define; remove it ({write})",
        f"harness/a.py: add 'hidden' to __all__ (used by harness/b.py); {write}",
        f"harness/a.py: add 'read' to __all__ (used by harness/b.py); {write}",
        f"harness/a.py: add 'tested' to __all__ (used by tests/test_a.py); {write}",
        "harness/b.py:5: uses '_private' of harness/a.py: a leading underscore is private to its module; rename it "
        "there without one (and add it to __all__), or move the code",
    ])
    # the writer fixes all but the underscore, keeps the order ruff wants, and a second run changes nothing
    assert exports.write(root) == ["harness/a.py", "harness/c.py"]
    assert [line for line in exports.problems(root) if "_private" not in line] == []
    a = ast.parse((root / "harness/a.py").read_text(encoding="utf-8"))
    assert exports.declared(a)[0] == ["hidden", "read", "shown", "tested"]
    c = (root / "harness/c.py").read_text(encoding="utf-8")
    assert c == '"""No __all__."""\n\nfrom harness.a import shown\n\n__all__: list[str] = []\n'
    assert exports.write(root) == []


def test_the_writer_places_a_new_list_after_the_imports(tmp_path):
    root = _package(tmp_path, {
        "harness/__init__.py": '__all__: list[str] = []\n',
        "harness/m.py": '''\
            """Doc."""

            from __future__ import annotations

            from typing import TYPE_CHECKING

            if TYPE_CHECKING:
                import os

            LONG = 1


            def f(): ...
            ''',
        "harness/n.py": "from harness.m import LONG, f\n\n__all__: list[str] = []\n",
    })
    assert exports.write(root) == ["harness/m.py"]
    lines = (root / "harness/m.py").read_text(encoding="utf-8").splitlines()
    assert lines[7:11] == ["    import os", "", '__all__ = ["LONG", "f"]', ""]


def test_each_protocol_names_modules_that_exist():
    """A protocol's pattern that matches no module (one moved or renamed) would leave its modules' lists short."""
    names = list(exports.modules())
    stale = [p for p in exports.PROTOCOLS if not any(re.fullmatch(p, m) for m in names)]
    assert not stale, f"tests/exports.py: PROTOCOLS patterns that match no module: {stale}"
