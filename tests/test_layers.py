"""The package's structure: the import graph has no cycle, dependencies point one way between the layers,
and an import inside a function is a lazy import kept for start-up speed, marked as such.

The graph is read from the source: every ``import`` statement, at module level and inside functions, so
a cycle hidden behind a function-local import counts too. Imports under ``if TYPE_CHECKING:`` (for
annotations only: they never run) must point down the layers too, but do not count as cycles. Layers, lowest
first, as the data flows (design: docs/design.md):

    analytic  <  harness.core  <  harness.reference  <  harness.engine  <  harness.budget  <  harness.cases  <  mjcf
      <  harness.opinions  <  harness.inertia  <  harness.families  <  harness.pipeline  <  harness.studies
      <  harness.audit  <  harness.outputs  <  harness.versions  <  harness.api, harness.pytest_plugin  <  harness.cli
      <  harness (the package's face)

A module may import from its own layer or lower ones. The budget's parts (harness.budget) sit on the engine: a
part names the variant edit it is made by (harness.engine.variants) and reads the deviations and the ``Budget``
record (harness.core); the families that make the runs and states they estimate from are above them. The model
modules (mjcf/NAME.py) are found by the case registry at run time (importlib), never imported by name.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests import exports
from tests.exports import ROOT, resolve

LAYERS = ("analytic", "harness.core", "harness.reference", "harness.engine", "harness.budget", "harness.cases", "mjcf",
          "harness.opinions", "harness.inertia", "harness.families", "harness.pipeline", "harness.studies",
          "harness.audit", "harness.outputs", "harness.versions", "harness.api", "harness.cli", "harness")
SAME_LAYER = {"harness.pytest_plugin": "harness.api", "harness.__main__": "harness.cli",
              "harness.zoo": "harness.api"}  # the zoo runs models as the API does, for the CLI's `zoo`
LAZY = "# lazy:"


def _typing_only(tree: ast.Module) -> set[int]:
    """The ids of the nodes under ``if TYPE_CHECKING:``."""
    return {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
            and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"
            for stmt in node.body for n in ast.walk(stmt)}


def _imports(module: str, path: Path, known: set[str]) -> list[tuple[str, int, bool]]:
    """(imported module of ours, line, only for type checking) for every import statement of ``module``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing = _typing_only(tree)
    found = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            target = resolve(node, module, path.name == "__init__.py")
            names = [f"{target}.{a.name}" if f"{target}.{a.name}" in known else target for a in node.names]
        for name in names:
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name and name != module:
                found.append((name, node.lineno, id(node) in typing))
    return found


def _graph(*, typing: bool = True) -> dict[str, set[str]]:
    """Module -> the modules of ours it imports (``typing``: with the imports for type checking only)."""
    modules = exports.modules()
    return {m: {t for t, _, only_typing in _imports(m, p, set(modules)) if typing or not only_typing}
            for m, p in modules.items()}


def _layer(module: str) -> int:
    module = SAME_LAYER.get(module, module)
    best = max((layer for layer in LAYERS if module == layer or module.startswith(layer + ".")), key=len)
    return LAYERS.index(best)


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle of ``graph`` (its modules in order, the first repeated at the end), or []."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str]:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return []

    for module in sorted(graph):
        if module not in state and (found := visit(module)):
            return found
    return []


def _upward(graph: dict[str, set[str]]) -> list[str]:
    return [f"{m} ({LAYERS[_layer(m)]}) imports {t} ({LAYERS[_layer(t)]})"
            for m, targets in graph.items() for t in targets if _layer(t) > _layer(m)]


def test_the_import_graph_has_no_cycle():
    cycle = _cycle(_graph(typing=False))
    assert not cycle, "import cycle: " + " -> ".join(cycle)


def test_dependencies_point_down_the_layers():
    upward = _upward(_graph())
    assert not upward, "\n".join(upward)


def test_every_harness_module_is_in_a_layer_package():
    """harness/ is grouped by role: nothing but the API face (the API, the zoo's runner beside it), the plugin and the
    entry points at its top."""
    top = sorted(m for m in exports.modules() if m.startswith("harness.") and m.count(".") == 1
                 and not (ROOT / m.replace(".", "/")).is_dir())
    assert top == ["harness.__main__", "harness.api", "harness.pytest_plugin", "harness.zoo"]


def test_an_import_inside_a_function_is_a_marked_lazy_one():
    modules = exports.modules()
    unmarked = []
    for path in modules.values():
        lines = path.read_text(encoding="utf-8").splitlines()
        tree = ast.parse("\n".join(lines))
        for f in ast.walk(tree):
            if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef):
                for node in ast.walk(f):
                    if isinstance(node, ast.Import | ast.ImportFrom) and LAZY not in lines[node.lineno - 1]:
                        unmarked.append(f"{path.relative_to(ROOT)}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    assert not unmarked, "imports inside functions without a '# lazy: why' mark:\n" + "\n".join(unmarked)


def test_the_checks_can_fail():
    """The graph reader sees real edges, and a made-up cycle (through a lazy import too) and a made-up
    upward import are found."""
    graph = _graph()
    assert "harness.reference.derivations" in graph["harness.families.bench"]  # a top-level import
    assert "harness.outputs.report" in graph["harness.cli.subcommands.run"]  # a lazy one, inside cmd_run
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) == []
    assert _upward({"harness.core.figures": {"harness.cli.commands"}}) != []
    assert _upward({"harness.cli.commands": {"harness.core.figures"}}) == []
    assert _layer("harness.pytest_plugin") == _layer("harness.api")
    node = ast.parse("from ..cli import commands\n").body[0]
    assert isinstance(node, ast.ImportFrom) and resolve(node, "harness.core.figures", False) == "harness.cli"
