"""One isolated environment per MuJoCo release, built with uv and kept for the next run.

An environment holds one MuJoCo release, the harness built from the source that runs this command (from a
regular install, a source tree made of the installed packages and metadata: :func:`installed_source`), and
the harness's dependencies, with numpy and sympy pinned to the versions this interpreter has (the
reference is computed by them: pinned, it is the same in every environment, and what differs between
two environments is MuJoCo alone). Extra packages (a backend's, ``--with``) are installed beside them.

Where they live: ``$XDG_CACHE_HOME/mjharness/versions/`` (else ``~/.cache/mjharness/versions/``), one
folder per release and set of requirements (:meth:`EnvSpec.folder`), reused while present and complete.
The harness in it is reinstalled (with any dependency it gained, the release and the pins held) when the
source's hash (every file of ``analytic/``, ``harness/``, ``mjcf/`` and ``pyproject.toml``) differs from the
one it was built from;
the wheel is built once per source hash and shared by every environment. uv keeps its downloads in
its own cache (``$XDG_CACHE_HOME/uv``), so a second environment of the same packages downloads
nothing. Building is serialised per folder with a lock file, so two commands never build one folder at
once; a folder whose build did not finish has no ``complete`` marker and is rebuilt.

The check runs as ``ENV/bin/python -P -m harness``: ``-P`` keeps the working directory off the import
path, so a source checkout there cannot shadow the harness installed in the environment.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as installed_version
from pathlib import Path

from harness.versions.releases import Release

__all__ = ["BACKENDS", "SAME_RELEASE", "Builder", "EnvError", "EnvSpec", "Environment", "Shipped", "backend_packages",
           "envs_root", "find_uv", "pins", "source_hash", "source_root"]

PINNED = ("numpy", "sympy")
"""The dependencies pinned to this interpreter's versions in every environment: they compute the reference."""

SOURCE_PACKAGES = ("analytic", "harness", "mjcf")
COMPLETE = "complete"  # the marker of a finished build, holding the requirements it installed
SOURCE_MARK = "mjharness-source"  # the source hash the installed harness was built from

BACKENDS = ("c", "mjx", "mjx-f64")
"""The backends ``versions --backend`` installs (``check --backend NAME``). Warp is absent: this harness has
no Warp backend yet (issue 20)."""

MJX_NEWER_JAX = Release("3.7.0")
"""The first mujoco-mjx that runs on the newest jax. Before it MJX calls ``jnp.clip(..., a_min=...)``
(collision_driver.py), a keyword jax has since removed: mujoco-mjx 3.3.0 with jax 0.10.2 raises TypeError in
the same-state tests (tests/test_backends.py) and passes them with jax 0.7.2; the wheels of 3.7.0 … 3.17.0
have no ``a_min=`` left (3.6.0's has). mujoco-mjx requires jax unpinned, so without this uv takes the
newest."""


def backend_packages(backend: str, release: Release) -> tuple[str, ...]:
    """What ``backend`` needs beside MuJoCo ``release``: MJX, released with MuJoCo under the same number,
    and a jax it runs on (:data:`MJX_NEWER_JAX`)."""
    if backend not in ("mjx", "mjx-f64"):
        return ()
    return f"mujoco-mjx=={release}", ("jax" if release >= MJX_NEWER_JAX else "jax<0.8")

SAME_RELEASE: Mapping[str, str] = {"mjx": "mujoco-mjx", "mjx-f64": "mujoco-mjx"}
"""The backends whose package is released with MuJoCo under the same number: a MuJoCo release the package
index has no such release of (mujoco-mjx stops at 3.17.0; there is none for 4.0.0) cannot run them."""


def source_root() -> Path:
    """The source tree this harness runs from (the folder holding ``pyproject.toml`` beside ``harness/``). From
    a regular install (``pip install .``, a wheel: the packages in site-packages, no ``pyproject.toml``) the
    tree is made from what is installed (:func:`installed_source`), so the command works from any install."""
    root = Path(__file__).resolve().parents[2]
    if (root / "pyproject.toml").is_file():
        return root
    return installed_source(root, envs_root() / "installed-source")


def installed_source(site: Path, to: Path) -> Path:
    """A source tree of the installed harness under ``to`` (one per installed set of files, made once): its
    packages copied from ``site`` (where they are installed), and a ``pyproject.toml`` written from the
    installed distribution's metadata (name, version, Python, dependencies and extras, scripts and entry
    points), every file of the packages their package data. Its wheel installs the same harness again, into
    each environment. ValueError where the harness is not an installed distribution at all."""
    from importlib.metadata import distribution  # lazy: only from an installed copy

    try:
        dist = distribution("mjharness")
    except PackageNotFoundError:
        raise ValueError(f"mjharness versions installs the harness into each environment, and the one in {site} is "
                         "neither a source checkout (no pyproject.toml) nor an installed distribution") from None
    missing = [p for p in SOURCE_PACKAGES if not (site / p).is_dir()]
    if missing:
        raise ValueError(f"the installed harness in {site} lacks its package(s) {', '.join(missing)}")
    record = dist.read_text("RECORD") or ""  # every installed file with its hash: another install, another tree
    tree = to / hashlib.sha256(record.encode()).hexdigest()[:16]
    with _locked(to / "lock"):
        if not (tree / "pyproject.toml").is_file():  # written last: a tree without it is unfinished
            scratch = tree.with_name(tree.name + ".tmp")
            shutil.rmtree(scratch, ignore_errors=True)
            _copy_source(site, scratch)
            (scratch / "pyproject.toml").write_text(_pyproject(dist))
            shutil.rmtree(tree, ignore_errors=True)
            scratch.rename(tree)
    return tree


def _toml(value: object) -> str:
    """A TOML string or array of strings (JSON's quoting is TOML's for these)."""
    return json.dumps(value, ensure_ascii=False)


def _pyproject(dist) -> str:
    """The ``pyproject.toml`` that builds ``dist`` (an installed distribution) again from its packages."""
    meta = dist.metadata
    plain: list[str] = []
    extras: dict[str, list[str]] = {}
    for requirement in dist.requires or []:
        spec, _, marker = requirement.partition(";")
        found = re.search(r"""extra\s*==\s*['"]([^'"]+)['"]""", marker)
        if found is None:
            plain.append(requirement.strip())
            continue
        rest = re.sub(r"""\s*(and\s+)?extra\s*==\s*['"][^'"]+['"](\s+and)?\s*""", "", marker).strip()
        extras.setdefault(found.group(1), []).append(spec.strip() + (f"; {rest}" if rest else ""))
    lines = ["[build-system]", 'requires = ["setuptools>=61"]', 'build-backend = "setuptools.build_meta"', "",
             "[project]", f"name = {_toml(meta['Name'])}", f"version = {_toml(meta['Version'])}"]
    if meta.get("Requires-Python"):
        lines.append(f"requires-python = {_toml(meta['Requires-Python'])}")
    lines.append(f"dependencies = {_toml(plain)}")
    if extras:
        lines += ["", "[project.optional-dependencies]", *(f"{_toml(k)} = {_toml(v)}" for k, v in extras.items())]
    groups: dict[str, dict[str, str]] = {}
    for ep in dist.entry_points:
        groups.setdefault(ep.group, {})[ep.name] = ep.value
    for group, points in groups.items():
        header = "[project.scripts]" if group == "console_scripts" else f"[project.entry-points.{_toml(group)}]"
        lines += ["", header, *(f"{_toml(k)} = {_toml(v)}" for k, v in points.items())]
    lines += ["", "[tool.setuptools.packages.find]", f"include = {_toml([p + '*' for p in SOURCE_PACKAGES])}", "",
              "[tool.setuptools.package-data]", '"*" = ["*", "*/*"]', ""]
    return "\n".join(lines)


def source_hash(root: Path) -> str:
    """SHA-256 (16 hex digits) of every file of the harness's packages and of ``pyproject.toml``, by path."""
    digest = hashlib.sha256()
    files = [root / "pyproject.toml"]
    for package in SOURCE_PACKAGES:
        files += sorted(p for p in (root / package).rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def envs_root() -> Path:
    """``$XDG_CACHE_HOME/mjharness/versions`` (else ``~/.cache/mjharness/versions``)."""
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    return (Path(base) if base else Path.home() / ".cache") / "mjharness" / "versions"


def find_uv() -> str:
    """The uv executable: the one the ``uv`` package ships (a dependency of the harness), else uv on PATH."""
    with contextlib.suppress(ImportError, FileNotFoundError):
        import uv  # lazy: only this command needs it

        return str(uv.find_uv_bin())
    found = shutil.which("uv")
    if found is None:
        raise ValueError("uv is not installed: pip install uv (mjharness versions builds its environments with it)")
    return found


def pins() -> tuple[str, ...]:
    """``numpy==X``, ``sympy==Y``: this interpreter's versions of :data:`PINNED`."""
    out = []
    for name in PINNED:
        try:
            out.append(f"{name}=={installed_version(name)}")
        except PackageNotFoundError:
            out.append(name)
    return tuple(out)


@dataclass(frozen=True)
class EnvSpec:
    """What one environment holds: a MuJoCo release and extra requirements (``{version}`` in one is the
    release), besides the harness, its dependencies and the :func:`pins`."""

    release: Release
    extras: tuple[str, ...] = ()
    pinned: tuple[str, ...] = ()
    refused: str = ""
    """Why this environment is not built (one line, e.g. the index has no mujoco-mjx of the release), or ""."""

    def requirements(self) -> tuple[str, ...]:
        """What ``uv pip install`` is given; ValueError for one that would reach it as an option (``-e``,
        ``--index-url``)."""
        found = (f"mujoco=={self.release}", *self.pinned,
                 *(e.replace("{version}", str(self.release)) for e in self.extras))
        bad = next((r for r in found if r.lstrip().startswith("-")), None)
        if bad is not None:
            raise ValueError(f"{bad!r} is not a package requirement (it would reach the installer as an option); "
                             "accepted: a requirement such as 'mujoco-mjx=={version}'")
        return found

    def folder(self, root: Path) -> Path:
        """``root/mujoco-RELEASE-pyXY-KEY``: KEY hashes the requirements, so another pin or extra package is
        another environment and the same ones find the same folder."""
        key = hashlib.sha256("\n".join(self.requirements()).encode()).hexdigest()[:10]
        return root / f"mujoco-{self.release}-py{sys.version_info[0]}{sys.version_info[1]}-{key}"


@dataclass(frozen=True)
class Environment:
    """A built environment: its folder, its interpreter, and how it was had (``built``: created now,
    ``harness``: the harness (re)installed now; ``seconds`` spent)."""

    spec: EnvSpec
    folder: Path
    built: bool
    harness: bool
    seconds: float

    @property
    def python(self) -> Path:
        return self.folder / "bin" / "python"


class EnvError(ValueError):
    """An environment that could not be built: the command and the last line uv printed."""


@dataclass(frozen=True)
class Builder:
    """Builds environments with ``uv`` under ``root`` from the source tree ``source``; ``environ`` is the
    environment uv runs with (tests point it at a fake index)."""

    uv: str
    root: Path
    source: Path
    environ: Mapping[str, str] | None = None

    def _run(self, args: Sequence[str], what: str) -> None:
        done = subprocess.run([self.uv, *args], capture_output=True, text=True, check=False,
                              env=dict(self.environ) if self.environ is not None else None)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or ["no output"])[-1]
            raise EnvError(f"{what} failed (uv exit {done.returncode}): {last.strip()}")

    def wheel(self, digest: str) -> Path:
        """The harness's wheel built from the source (once per source hash, shared by the environments)."""
        out = self.root / "wheels" / digest
        with _locked(out.with_suffix(".lock")):
            found = sorted(out.glob("mjharness-*.whl"))
            if found:
                return found[0]
            scratch = out.with_name(f"{digest}.tmp")
            shutil.rmtree(scratch, ignore_errors=True)
            tree = _copy_source(self.source, scratch / "source")
            self._run(["build", "--wheel", "--quiet", "--out-dir", str(scratch / "dist"), str(tree)],
                      f"building the harness's wheel from {self.source}")
            built = sorted((scratch / "dist").glob("mjharness-*.whl"))
            if not built:
                raise EnvError(f"building the harness's wheel from {self.source} left no mjharness-*.whl")
            out.mkdir(parents=True, exist_ok=True)
            wheel = out / built[0].name
            built[0].rename(wheel)
            shutil.rmtree(scratch, ignore_errors=True)
            return wheel

    def ensure(self, spec: EnvSpec, digest: str) -> Environment:
        """The environment of ``spec`` with the harness of source hash ``digest``: reused when complete,
        its harness reinstalled when built from another source, else built."""
        start = time.perf_counter()
        folder = spec.folder(self.root)
        with _locked(folder.with_name(folder.name + ".lock")):
            complete = (folder / COMPLETE).is_file()
            current = (folder / SOURCE_MARK).read_text().strip() if (folder / SOURCE_MARK).is_file() else ""
            if complete and current == digest:
                return Environment(spec, folder, built=False, harness=False, seconds=time.perf_counter() - start)
            wheel = self.wheel(digest)
            python = str(folder / "bin" / "python")
            if not complete:
                shutil.rmtree(folder, ignore_errors=True)
                self._run(["venv", "--quiet", "--python", sys.executable, str(folder)],
                          f"creating the environment for MuJoCo {spec.release}")
                self._run(["pip", "install", "--quiet", "--python", python, str(wheel), *spec.requirements()],
                          f"installing MuJoCo {spec.release} ({' '.join(spec.requirements())})")
                (folder / COMPLETE).write_text("\n".join(spec.requirements()) + "\n")
            else:
                # with its dependencies, the release and the pins held as they are: a dependency the new source
                # added (scipy, for the inertia audit) was missing from every environment reused
                self._run(["pip", "install", "--quiet", "--python", python, "--reinstall-package", "mjharness",
                           str(wheel), *spec.requirements()], f"reinstalling the harness for MuJoCo {spec.release}")
            (folder / SOURCE_MARK).write_text(digest + "\n")
            return Environment(spec, folder, built=not complete, harness=True, seconds=time.perf_counter() - start)


def _copy_source(root: Path, to: Path) -> Path:
    """The files a wheel is built from (the packages, pyproject.toml and the README it names), copied to
    ``to``: a build in the source tree itself would leave ``build/`` there, whose stale copies of deleted
    modules a later build would package."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for package in SOURCE_PACKAGES:
        shutil.copytree(root / package, to / package, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        if (root / name).is_file():
            shutil.copy2(root / name, to / name)
    return to


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (created) while the block runs: one builder per folder at a time."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@dataclass(frozen=True)
class Shipped:
    """The harness's wheel as bytes, with the source hash it was built from: what a task sent to another
    node (a Ray task) carries so that the node builds its environments without a source tree of its own.
    The wheel is put under the node's ``root/wheels/DIGEST`` once; :meth:`Builder.wheel` then finds it."""

    digest: str
    name: str
    data: bytes

    @classmethod
    def of(cls, builder: Builder, digest: str) -> Shipped:
        """The wheel ``builder`` builds (or has built) for ``digest``."""
        wheel = builder.wheel(digest)
        return cls(digest, wheel.name, wheel.read_bytes())

    def builder(self, root: Path) -> Builder:
        """A builder on this node for environments under ``root``, with this wheel in place."""
        out = root / "wheels" / self.digest
        with _locked(out.with_suffix(".lock")):
            if not any(out.glob("mjharness-*.whl")):
                out.mkdir(parents=True, exist_ok=True)
                scratch = out / (self.name + ".part")
                scratch.write_bytes(self.data)
                scratch.rename(out / self.name)
        return Builder(uv=find_uv(), root=root, source=out)  # the source is never read: the wheel is there
