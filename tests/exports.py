"""The private boundary: each module's ``__all__`` lists the names other code uses from it, and nothing crosses it
unlisted (docs/design.md, "The public API and the private boundary"; enforced by tests/test_exports.py).

    python -m tests.exports            # every breach, one line each (what the test reports)
    python -m tests.exports --write    # write each module's __all__: what is used from it elsewhere

Read from the source (AST, no import): a name is *used* from module M when another module of harness/, analytic/
or mjcf/, a test, a benchmark or an example imports it from M (``from M import name``) or reads it off M (``M.name``,
M imported as a module), or when M is found by a protocol rather than by name (:data:`PROTOCOLS`: a system's
``build``, a backend's ``backend``, the pytest plugin's hooks). A submodule imported from its package is not a name
of the package. ``--write`` keeps what an ``__all__`` already lists and the module still defines, adds every name
used, sorts as ruff does (RUF022) and puts a new ``__all__`` after the module's imports; it never touches
``harness/__init__.py``, whose ``__all__`` is the public API, stated by hand and in docs/design.md.

A leading underscore stays inside its module: the package's code and the examples never use one across modules.
Tests and benchmarks are white-box and may: a unit test of a private helper, a monkeypatch of what a module imported
(``M.name`` read off a module is theirs to use); what they import by name (``from M import name``) of the public
names is listed like the package's own use, so ``__all__`` shows what they rely on.
"""

from __future__ import annotations

import ast
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("analytic", "harness", "mjcf")
USERS = ("tests", "benchmarks", "examples")  # code outside the package that imports from it
# white-box users: their attribute reads of a module (``releases.subprocess``, a monkeypatch's target) and their
# underscore names are not the module's interface; their ``from M import name`` of a public name is
WHITE_BOX = ("tests", "benchmarks")
FACE = "harness"  # the public API: its __all__ is written by hand (and in docs/design.md), never by --write
WRITE = "python -m tests.exports --write"
# Modules found by a protocol, not imported by name: the pattern of their module names, and the names the
# protocol reads off them (those a module defines join its __all__).
PROTOCOLS = {
    # a system (analytic/systems/__init__.py: REQUIRED, the optional SIGNED_PARAMETERS and minimal, and the
    # model's WIRING, which a user's NAME.py may declare beside its system)
    r"analytic\.systems\.[^.]+": ("PARAMETERS", "SIGNED_PARAMETERS", "MOTION", "build", "minimal",
                                  "params_from_model", "scales", "WIRING"),
    r"mjcf\.[^.]+": ("WIRING",),  # a model's wiring (harness/cases/__init__.py)
    r"harness\.engine\.backends\.[^.]+": ("backend",),  # an optional backend's factory (backends.get)
    r"harness\.budget\.[^.]+": ("PART",),  # a budget part (harness/budget/registry.py discovers them)
    # a family of figures (harness/families/__init__.py: FAMILIES, modules typed as the protocol bench.Family)
    r"harness\.families\.[^.]+": ("NAME", "owns", "names", "gated", "theory_limit", "measure", "compare"),
    # the pytest plugin (entry point pytest11): pytest reads its hooks and fixtures by name
    r"harness\.pytest_plugin": ("pytest_addoption", "pytest_report_header", "mjharness"),
    r"harness\.cli\.entry": ("entry",),  # the console script (pyproject's [project.scripts])
}


@dataclass(frozen=True)
class Use:
    """``name`` of module ``module`` used at ``where`` (a path relative to the root, and a line)."""

    module: str
    name: str
    where: str
    by_package: bool  # the user is a module of harness/, analytic/ or mjcf/ (not a test, benchmark or example)
    star: bool = False


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Every module of the package by name (``harness.core.figures``; a package by its ``__init__.py``)."""
    return {module_name(p, root): p for pkg in PACKAGES for p in sorted((root / pkg).rglob("*.py"))}


def _top_level(body: list[ast.stmt]) -> Iterator[ast.stmt]:
    """The statements of a module's top level, inside its ``if``/``try``/``with`` blocks too (not functions')."""
    for node in body:
        yield node
        if isinstance(node, ast.If | ast.Try | ast.With):
            for block in ("body", "orelse", "finalbody", "handlers"):
                for inner in getattr(node, block, []):
                    yield from _top_level(inner.body if isinstance(inner, ast.ExceptHandler) else [inner])


def _targets(node: ast.expr) -> Iterator[str]:
    if isinstance(node, ast.Name):
        yield node.id
    elif isinstance(node, ast.Tuple | ast.List):
        for element in node.elts:
            yield from _targets(element)
    elif isinstance(node, ast.Starred):
        yield from _targets(node.value)


def defined(tree: ast.Module) -> set[str]:
    """The names a module binds at its top level: functions, classes, assignments and imports; those imported for
    type checking only where the module's ``__getattr__`` provides them at run time (as ``harness``'s does)."""
    names: set[str] = set()
    typing_only = {id(n) for node in tree.body if isinstance(node, ast.If) and isinstance(node.test, ast.Name)
                   and node.test.id == "TYPE_CHECKING" for n in _top_level(node.body)}
    statements = list(_top_level(tree.body))
    lazy = any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in statements)
    for node in statements:
        if id(node) in typing_only and not lazy:
            continue
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names.update(n for t in node.targets for n in _targets(t))
        elif isinstance(node, ast.AnnAssign | ast.AugAssign):
            names.update(_targets(node.target))
        elif isinstance(node, ast.Import):
            names.update(a.asname or a.name.partition(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            names.update(a.asname or a.name for a in node.names if a.name != "*")
    return names


def declared(tree: ast.Module) -> tuple[list[str] | None, ast.stmt | None]:
    """The names of a module's ``__all__`` (None without one) and its statement; ValueError where it is not a
    literal list of strings."""
    for node in tree.body:
        target = node.targets[0] if isinstance(node, ast.Assign) and len(node.targets) == 1 else getattr(
            node, "target", None) if isinstance(node, ast.AnnAssign) else None
        if isinstance(target, ast.Name) and target.id == "__all__":
            value = node.value
            if not (isinstance(value, ast.List | ast.Tuple)
                    and all(isinstance(e, ast.Constant) and isinstance(e.value, str) for e in value.elts)):
                raise ValueError(f"line {node.lineno}: __all__ must be a literal list of strings")
            return [e.value for e in value.elts], node  # type: ignore[union-attr]
    return None, None


def resolve(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The module a ``from … import`` in ``module`` (a package's ``__init__`` where ``is_package``) reads from."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def uses(path: Path, module: str, known: set[str], root: Path = ROOT) -> Iterator[Use]:
    """Every name of another of ``known``'s modules that the file ``path`` (module ``module``) uses."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    by_package = module in known
    where = str(path.relative_to(root))
    white_box = where.partition("/")[0] in WHITE_BOX
    aliases: dict[str, str] = {}  # a local name bound to one of our modules -> that module
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.asname and a.name in known:
                    aliases[a.asname] = a.name
                elif not a.asname and a.name.partition(".")[0] in known:
                    aliases[a.name.partition(".")[0]] = a.name.partition(".")[0]
        elif isinstance(node, ast.ImportFrom):
            target = resolve(node, module, path.name == "__init__.py")
            if target not in known:
                continue
            for a in node.names:
                if f"{target}.{a.name}" in known:  # a submodule, not a name of the package
                    aliases[a.asname or a.name] = f"{target}.{a.name}"
                elif target != module:
                    yield Use(target, a.name, f"{where}:{node.lineno}", by_package, star=a.name == "*")
    for node in ast.walk(tree) if not white_box else ():
        if not (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load)):
            continue
        chain = [node.attr]
        base = node.value
        while isinstance(base, ast.Attribute):
            chain.insert(0, base.attr)
            base = base.value
        if not (isinstance(base, ast.Name) and base.id in aliases):
            continue
        target = aliases[base.id]
        for part in chain[:-1]:  # the longest prefix that is one of our modules
            if f"{target}.{part}" not in known:
                break
            target = f"{target}.{part}"
        else:
            name = chain[-1]
            if target != module and f"{target}.{name}" not in known and not name.startswith("__"):
                yield Use(target, name, f"{where}:{node.lineno}", by_package)
        # an attribute of an attribute (harness.cases.names().x) is not ours: only the first name after the module


def _user_files(root: Path) -> Iterator[Path]:
    for folder in USERS:
        yield from sorted((root / folder).rglob("*.py"))


def used(root: Path = ROOT) -> tuple[dict[str, Path], dict[str, dict[str, list[Use]]]]:
    """The package's modules, and for each the names used from it and where."""
    mods = modules(root)
    known = set(mods)
    found: dict[str, dict[str, list[Use]]] = {m: {} for m in mods}
    files = [(p, m) for m, p in mods.items()] + [(p, module_name(p, root)) for p in _user_files(root)]
    for path, module in files:
        for use in uses(path, module, known, root):
            found[use.module].setdefault(use.name, []).append(use)
    for module in mods:
        for pattern, names in PROTOCOLS.items():
            if re.fullmatch(pattern, module):
                for name in names:
                    found[module].setdefault(name, []).append(Use(module, name, f"protocol {pattern}", True))
    return mods, found


def _public(name: str) -> bool:
    return not name.startswith("_") or (name.startswith("__") and name.endswith("__"))


def problems(root: Path = ROOT) -> list[str]:
    """Every breach of the boundary, one actionable line each."""
    mods, found = used(root)
    lines = []
    for module, path in mods.items():
        rel = path.relative_to(root)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        try:
            names, _ = declared(tree)
        except ValueError as exc:
            lines.append(f"{rel}: {exc}")
            continue
        bound = defined(tree)
        if names is None:
            lines.append(f"{rel}: no __all__; `{WRITE}` writes it (the names other modules use from it)")
            names = []
        for name in names:
            if name not in bound:
                lines.append(f"{rel}: __all__ names {name!r}, which it does not define; remove it (`{WRITE}` does)")
        for name, where in sorted(found[module].items()):
            package_users = [u for u in where if u.by_package]
            if where[0].star:
                continue  # `from M import *` takes __all__ and nothing else: it cannot reach past it
            if not _public(name):
                for u in package_users:
                    lines.append(f"{u.where}: uses {name!r} of {rel}: a leading underscore is private to its module; "
                                 f"rename it there without one (and add it to __all__), or move the code")
            elif name not in names and name in bound:
                users = ", ".join(sorted({u.where.partition(':')[0] for u in where}))
                lines.append(f"{rel}: add {name!r} to __all__ (used by {users}); `{WRITE}` does")
    return lines


def sort_key(name: str) -> tuple[int, str]:
    """ruff's order for ``__all__`` (RUF022, isort style): constants, then classes, then everything else."""
    return (0 if name.isupper() and len(name) > 1 else 1 if name[:1].isupper() else 2, name)


def render(names: list[str]) -> str:
    if not names:
        return "__all__: list[str] = []"
    quoted = [f'"{n}"' for n in names]
    lines, line = [], "__all__ = ["
    indent = " " * len(line)
    for i, q in enumerate(quoted):
        piece = q + ("]" if i == len(quoted) - 1 else ",")
        if len(line) + len(piece) + 1 > 120 and line.strip() not in ("__all__ = [", ""):
            lines.append(line.rstrip())
            line = indent
        line += piece + ("" if i == len(quoted) - 1 else " ")
    lines.append(line)
    return "\n".join(lines)


def _after_imports(tree: ast.Module) -> int:
    """The line after which a new ``__all__`` goes: the module's leading docstring and imports (those under ``if
    TYPE_CHECKING:`` or ``try:`` included)."""
    def import_only(node: ast.stmt) -> bool:
        if isinstance(node, ast.Import | ast.ImportFrom):
            return True
        if isinstance(node, ast.If | ast.Try):
            inner = list(_top_level([node]))[1:]
            return all(isinstance(n, ast.Import | ast.ImportFrom | ast.Pass) for n in inner)
        return False

    end = 0
    for i, node in enumerate(tree.body):
        docstring = i == 0 and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
        if not (docstring or import_only(node)):
            break
        end = node.end_lineno or node.lineno
    return end


def write(root: Path = ROOT) -> list[str]:
    """Write each module's ``__all__`` (but the face's); the files changed."""
    mods, found = used(root)
    changed = []
    for module, path in mods.items():
        if module == FACE:
            continue
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        names, node = declared(tree)
        bound = defined(tree)
        wanted = {n for n in names or [] if n in bound} | {n for n in found[module] if _public(n) and n in bound
                                                         and not found[module][n][0].star}
        new = render(sorted(wanted, key=sort_key))
        lines = text.splitlines(keepends=True)
        if node is not None:  # replaced in place, a comment after it kept
            old = "".join(lines[node.lineno - 1:node.end_lineno])
            tail = lines[node.end_lineno - 1][node.end_col_offset:]  # after the statement (ASCII before it)
            if tail.strip():  # a comment after it goes above it: the list may grow to the line's end
                new = tail.strip() + "\n" + new
            if old == new + "\n":
                continue
            lines[node.lineno - 1:node.end_lineno] = [new + "\n"]
        else:
            at = _after_imports(tree)
            lines[at:at] = ["\n", new + "\n"] if at else [new + "\n", "\n"]
        path.write_text("".join(lines), encoding="utf-8")
        changed.append(str(path.relative_to(root)))
    return changed


def main(argv: list[str]) -> int:
    if argv == ["--write"]:
        for path in write():
            print(f"wrote __all__ of {path}")
        argv = []
    if argv:
        print(__doc__, file=sys.stderr)
        return 2
    found = problems()
    print("\n".join(found) or "every module's __all__ lists what is used from it, and nothing crosses it unlisted")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
