"""Where cases are discovered: the shipped models, users' directories (``--systems DIR``) and installed packages.

Every source has the shipped layout, one name per system:

- ``NAME.py``: the analytic system, as ``analytic/systems/NAME.py`` (the protocol of
  :mod:`analytic.systems`); it may also declare the model's ``WIRING``, as ``mjcf/NAME.py`` does;
- ``NAME.xml``: its MJCF model, one case per model, as ``mjcf/NAME.xml``;
- ``NAME.limits.toml``: the case's limits, as ``mjcf/NAME.limits.toml`` (without one the case is judged
  by the default rule, :func:`harness.pipeline.limits.default_limits`).

A user's directory is given to a command (``--systems DIR``), to :func:`harness.api.validate`
(``systems=``) or to the pytest fixture; an installed package declares its own in the entry point group
:data:`GROUP` (``[project.entry-points."mjharness.systems"] mine = "my_pkg.systems"``, naming a package
whose directory has the layout). A source's directory joins the search path of :mod:`analytic.systems`
(its ``__path__``), so ``NAME.py`` is imported as ``analytic.systems.NAME`` and derived, cached and solved
exactly as a shipped system: one mechanism discovers both.

Bad input is a ValueError in one line naming what is wrong and what is accepted: a directory that is
missing or holds no model, a module that cannot be imported (its file and the exception's message), a
name that two sources both define (both named), an entry point that cannot be loaded.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from importlib import metadata, resources
from pathlib import Path
from types import ModuleType

import analytic.systems

__all__ = ["GROUP", "SHIPPED", "Source", "check_collisions", "current", "directory_source", "module", "use", "using"]

GROUP = "mjharness.systems"
"""The entry point group an installed package names its systems' package in."""
LAYOUT = "NAME.py (the analytic system), NAME.xml (its MJCF), optionally NAME.limits.toml"
SHIPPED_MODELS = "mjcf"


@dataclass(frozen=True)
class Source:
    """One place cases are discovered from.

    Attributes:
        label: how messages name it (``the systems directory DIR``, ``entry point mine = my_pkg.systems``).
        models: the directory of its ``NAME.xml`` (and ``NAME.limits.toml``).
        systems: the directory of its systems' modules (``NAME.py``): ``models`` itself but for the shipped
            source, whose systems are ``analytic/systems/`` and whose wiring is ``mjcf/NAME.py``.
    """

    label: str
    models: Path
    systems: Path

    @property
    def shipped(self) -> bool:
        return self.label == SHIPPED.label

    def model_files(self) -> list[Path]:
        return sorted(p for p in self.models.iterdir() if p.suffix == ".xml" and p.is_file())

    def module_names(self) -> list[str]:
        """The systems' (and wiring) modules here, as :mod:`analytic.systems` lists them (no leading ``_``)."""
        return sorted(p.stem for p in self.systems.glob("*.py") if not p.stem.startswith("_"))

    def names(self) -> set[str]:
        """Every name this source defines: its models' and its modules'."""
        return {p.stem for p in self.model_files()} | set(self.module_names())


def _shipped() -> Source:
    models = Path(str(resources.files(SHIPPED_MODELS)))
    return Source(label="the shipped cases (mjcf/, analytic/systems/)", models=models,
                  systems=Path(next(iter(analytic.systems.__path__))))


SHIPPED = _shipped()


def directory_source(path: str | os.PathLike) -> Source:
    """The source of a user's directory; ValueError where it is missing, not a directory, or holds no model."""
    given = Path(path)
    accepted = f"accepted: a directory holding {LAYOUT}"
    if not given.exists():
        raise ValueError(f"systems directory {str(path)!r}: no such directory; {accepted}")
    if not given.is_dir():
        raise ValueError(f"systems directory {str(path)!r} is not a directory; {accepted}")
    where = given.resolve()
    source = Source(label=f"the systems directory {where}", models=where, systems=where)
    if not source.model_files():
        raise ValueError(f"systems directory {str(path)!r} holds no model (NAME.xml); {accepted}")
    return source


def _package_source(entry: metadata.EntryPoint) -> Source:
    dist = getattr(entry, "dist", None)
    label = f"entry point {entry.name} = {entry.value} ({GROUP}" + (
        f", package {dist.name})" if dist is not None else ")")
    accepted = f"accepted: a package (a directory with __init__.py) holding {LAYOUT}"
    try:
        module = entry.load()
    except Exception as exc:  # whatever the user's package raises: one line naming it
        raise ValueError(f"{label} cannot be loaded: {_one_line(exc)}; {accepted}") from None
    paths = list(getattr(module, "__path__", []) or [])
    if not isinstance(module, ModuleType) or not paths:
        raise ValueError(f"{label} names {type(module).__name__} {getattr(module, '__name__', '')!r}, not a "
                         f"package; {accepted}")
    where = Path(paths[0]).resolve()
    source = Source(label=label, models=where, systems=where)
    if not source.model_files():
        raise ValueError(f"{label}: its package {where} holds no model (NAME.xml); {accepted}")
    return source


@functools.cache
def installed() -> tuple[Source, ...]:
    """The sources installed packages declare in :data:`GROUP`, in the order of their names; their directories
    join the search path of :mod:`analytic.systems`."""
    entries = sorted(metadata.entry_points(group=GROUP), key=lambda e: (e.name, e.value))
    found = tuple(_package_source(e) for e in entries)
    _search((*found, *_given))
    return found


def _one_line(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}".rstrip(": ")


def _shipped_names() -> dict[str, str]:
    """Each shipped name with what it is (a case, a system), for a collision's message."""
    names = {n: f"the shipped system analytic/systems/{n}.py" for n in SHIPPED.module_names()}
    names |= {p.stem: f"the shipped case mjcf/{p.name}" for p in SHIPPED.model_files()}
    return names


def check_collisions(sources: Iterable[Source]) -> None:
    """ValueError naming both sources where a user's name is shipped or given by another source."""
    seen = _shipped_names()
    for source in sources:
        for name in sorted(source.names()):
            if name in seen:
                raise ValueError(f"the name {name!r} of {source.label} is already {seen[name]}; accepted: names "
                                 "that no other source defines (rename the files of one)")
        seen |= {n: f"defined by {source.label}" for n in source.names()}


def _import(source: Source, name: str) -> ModuleType:
    """``analytic.systems.NAME`` from ``source`` (ValueError naming the file and the exception's message)."""
    file = source.systems / f"{name}.py"
    module_name = f"{analytic.systems.__name__}.{name}"
    try:
        return importlib.import_module(module_name)
    except Exception as exc:  # whatever the user's module raises on import: one line naming it
        sys.modules.pop(module_name, None)
        raise ValueError(f"cannot import {file} ({source.label}): {_one_line(exc)}; accepted: a module "
                         f"importable as {module_name}, defining {', '.join(analytic.systems.REQUIRED)}") from None


def module(source: Source, name: str) -> ModuleType | None:
    """The module ``NAME.py`` of a user's ``source`` (None where it has none), imported where it joined the search
    path of :mod:`analytic.systems` (:func:`active`)."""
    if name not in source.module_names():
        return None
    return _import(source, name)


def _forget(names: Iterable[str], sources: Iterable[Source]) -> None:
    """Drop from this process what was loaded for a same-named system from another file (an earlier call's
    directory): the module, and the derivations and solutions made from it, which are keyed by name."""
    files = {n: s.systems / f"{n}.py" for s in sources for n in s.module_names()}
    stale = []
    for name in names:
        loaded = sys.modules.get(f"{analytic.systems.__name__}.{name}")
        if loaded is not None and Path(str(getattr(loaded, "__file__", ""))).resolve() != files.get(name):
            stale.append(name)
    if not stale:
        return
    from harness.reference import derivations, solutions  # lazy: only where a name changed its file

    for name in stale:
        sys.modules.pop(f"{analytic.systems.__name__}.{name}", None)
    analytic.systems.load.cache_clear()
    derivations.clear_caches()
    solutions.clear_caches()


_BASE_PATH = tuple(analytic.systems.__path__)
_given: tuple[Source, ...] = ()


def _search(sources: Iterable[Source]) -> None:
    """The search path of :mod:`analytic.systems`: its own directory, then each source's."""
    analytic.systems.__path__[:] = [*_BASE_PATH, *dict.fromkeys(str(s.systems) for s in sources)]


def given() -> tuple[Source, ...]:
    """The users' directories in use (:func:`use`)."""
    return _given


def current() -> tuple[Source, ...]:
    """Every source of users' systems in use: the installed packages', then the directories given."""
    return (*installed(), *_given)


def use(directories: Iterable[str | os.PathLike]) -> tuple[Source, ...]:
    """Discover the systems of ``directories`` as well as the shipped and installed ones, from now on (the
    CLI's ``--systems``); their sources. Their directories, and the installed packages', join the search path
    of :mod:`analytic.systems`, and what was loaded under one of their names from another file (an earlier
    call's directory) is forgotten. ValueError for a directory that is missing or holds no model."""
    global _given
    chosen: dict[Path, Source] = {s.models: s for s in installed()}
    for path in directories:
        source = directory_source(path)
        chosen.setdefault(source.models, source)  # the same directory twice (or installed) is one source
    for s in installed():
        chosen.pop(s.models)
    _given = tuple(chosen.values())
    sources = (*installed(), *_given)
    _search(sources)
    _forget({n for s in sources for n in s.module_names()}, sources)
    return _given


@contextlib.contextmanager
def using(directories: Iterable[str | os.PathLike]) -> Iterator[tuple[Source, ...]]:
    """:func:`use` while the block runs (:func:`harness.api.validate`'s ``systems=``), then the directories in
    use before."""
    before = [s.models for s in _given]
    chosen = use(directories)
    try:
        yield chosen
    finally:
        use(before)
