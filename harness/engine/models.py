"""Finding and compiling MJCF models.

Paths resolve from the installed ``mjcf`` package, never the working
directory, so editable and regular installs behave the same. Settings are
changed through ``mujoco.MjSpec``, never by editing XML text. A compiled model
is checked before it is returned (:mod:`harness.engine.validity`): a model
with a non-finite number, a timestep that is not positive or a solref mixing
its formats is a :class:`ModelError` naming the attribute.
"""

from __future__ import annotations

import copy
import dataclasses
import enum
import functools
import hashlib
import math
import os
import re
import stat
import threading
import types
from collections import OrderedDict
from collections.abc import Callable
from importlib import resources
from pathlib import Path

import mujoco

from harness.core import inputs
from harness.core.errors import ModelError
from harness.engine import compat
from harness.engine.compat import after_compile, spec_from_file
from harness.engine.integrators import integrator_enum, integrator_name
from harness.engine.validity import InvalidModel, check_model, check_spec, check_texts

__all__ = ["SMALL_TEXTURE", "authored", "compile_model", "edit_identity", "load_spec", "mjcf_path"]


def mjcf_path(name: str) -> Path:
    """Path of the shipped model ``mjcf/NAME.xml``."""
    path = Path(str(resources.files("mjcf") / f"{name}.xml"))
    if not path.is_file():
        raise ModelError(f"no shipped model {name!r} (looked for {path})")
    return path


_PARSED: dict[tuple[str, bytes], mujoco.MjSpec] = {}
_PARSED_MAX = 64
_TEXTS: dict[str, bytes] = {}  # each file's text as last parsed: what check_text reads after compiling
_CACHES = threading.Lock()


def load_spec(path: Path | str) -> mujoco.MjSpec:
    """The spec of the MJCF file ``path``, a fresh one each call (the caller edits it)."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"cannot read MJCF {str(path)!r}: {_not_a_file(path)}; accepted: an MJCF (XML) file")
    try:
        inputs.check(path, what="MJCF", limit=inputs.MODEL_LIMIT)
    except inputs.InputFileError as exc:
        raise ModelError(str(exc)) from None
    try:
        return _parsed(str(path))
    except Exception as exc:  # MuJoCo raises ValueError with the parser's message
        raise ModelError(f"invalid MJCF {str(path)!r}: {_one_line(exc)}") from None


def _parsed(path: str) -> mujoco.MjSpec:
    """``spec_from_file`` (MjSpec.from_file, with fallbacks for an older MuJoCo), or a copy of the spec parsed
    before from the same path and the same text: a run compiles its model's file again for every variant, and
    parsing costs as much as compiling. Parsed anew where another file's text enters the parse (an <include>),
    where this MuJoCo needs the fallbacks (they record and warn per parse), or lacks ``MjSpec.copy``."""
    try:
        text = inputs.read_bytes(path, what="MJCF", limit=inputs.MODEL_LIMIT)  # bounded, whatever it became
    except OSError:
        text = b"<include"  # unreadable here: the parser says why
    with _CACHES:  # variants are compiled side by side (harness.families.runs)
        return _parsed_text(path, text)


def _parsed_text(path: str, text: bytes) -> mujoco.MjSpec:
    _TEXTS.pop(path, None)
    _TEXTS[path] = text
    if len(_TEXTS) > _PARSED_MAX:
        del _TEXTS[next(iter(_TEXTS))]
    if b"<include" in text or compat.missing_flags() or not hasattr(mujoco.MjSpec, "copy"):
        return spec_from_file(path)
    key = (path, text)
    if key not in _PARSED:
        if len(_PARSED) >= _PARSED_MAX:
            del _PARSED[next(iter(_PARSED))]
        _PARSED[key] = spec_from_file(path)
    return _PARSED[key].copy()


def authored(path: Path | str, *, timestep: float | None = None,
             edit: Callable[[mujoco.MjSpec], None] | None = None) -> str:
    """The model of ``path`` (with ``edit`` and ``timestep`` applied, as :func:`compile_model` applies them) as
    MuJoCo writes it (``MjSpec.to_xml``: every element, each attribute that differs from MuJoCo's default):
    what two models differ in is what their texts differ in (:func:`harness.pipeline.settings.authored_differences`).
    Image textures are written flat (:func:`flat_textures`), on both sides alike: drawn, never simulated."""
    spec = load_spec(path)
    # the compiles (the edit's, if it compiles, and the one below) generate the named textures small; the text
    # has each as written, or as the edit set it
    shrunk = small_textures(spec, named_only=True)
    flat_textures(spec)  # nor image files decoded (to_xml compiles again after any change: they stay flat here)
    if edit is not None:
        edit(spec)
    if timestep is not None:
        spec.option.timestep = timestep
    spec.compile()
    for texture in spec.textures:
        written, small = shrunk.get(texture.name, (None, None))
        if written is not None and (texture.width, texture.height) == small:
            texture.width, texture.height = written
    return spec.to_xml()


COMPILED_MAX = 32
"""How many compiled models :func:`compile_model` keeps (least recently used dropped first)."""
COMPILED_BYTES = 512 * 2**20
"""How many bytes of compiled models it keeps at most (``MjModel.nbuffer``): a robot's meshes make a model tens of
MB (Menagerie's Panda: 35 MB)."""
_COMPILED: OrderedDict[tuple, tuple[tuple, mujoco.MjModel]] = OrderedDict()
COMPILES = {"compiled": 0, "reused": 0}
"""How many models :func:`compile_model` compiled and how many it handed out again (tests, benchmarks)."""


def compile_model(
    path: Path | str,
    *,
    integrator: str | None = None,
    timestep: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
) -> mujoco.MjModel:
    """Compile ``path`` with a spec edit and optional integrator/timestep overrides (applied after the
    edit, so that they hold whatever the edit sets), for simulation: its generated textures are made small
    (:func:`small_textures`) and those read from image files flat (:func:`flat_textures`).

    A variant is compiled once: it is kept (a copy of it) and from then on a copy is handed out, as long as the
    file (and every file it includes or reads a mesh, height field or skin from) is unchanged on disk and the
    integrator, timestep and edit are equal (:func:`edit_identity`; an edit without a stable identity, such as a
    closure, is compiled every time). Copies, since callers may change a model in place. Bounded:
    :data:`COMPILED_MAX` models, :data:`COMPILED_BYTES` bytes. The edit's leading part (a tree case's
    preparation) is applied once per model, whatever variants follow it (:func:`_prepared`)."""
    key = _variant_key(path, integrator, timestep, edit)
    if key is None:
        COMPILES["compiled"] += 1
        return _compiled(path, integrator=integrator, timestep=timestep, edit=edit)[1]
    with _CACHES:
        compiling = _COMPILING.setdefault(key, threading.Lock())
    with compiling:  # variants are compiled side by side: one thread compiles each, those asking meanwhile wait
        try:
            kept = _kept(key)
            if kept is not None:
                COMPILES["reused"] += 1
                return kept
            spec, model = _compiled(path, integrator=integrator, timestep=timestep, edit=edit)
            COMPILES["compiled"] += 1
            # kept also as the variants that name the integrator or timestep it compiled with: the same model,
            # asked for so by a caller that read them off it (the model's own step, h/1 of a ladder)
            named = {(*key[:2], i, t, key[4]) for i in (key[2], integrator_name(model))
                     for t in (key[3], _identity(float(model.opt.timestep)))}
            _keep((key, *sorted(named - {key}, key=repr)), spec, model, path)
            return model
        finally:
            with _CACHES:
                _COMPILING.pop(key, None)


_COMPILING: dict[tuple, threading.Lock] = {}  # the variants being compiled now, each by one thread


def _kept(key: tuple) -> mujoco.MjModel | None:
    """A copy of the model kept as ``key``, None where none is or its files changed on disk since."""
    with _CACHES:
        entry = _COMPILED.get(key)
        if entry is not None:
            _COMPILED.move_to_end(key)
    return copy.copy(entry[1]) if entry is not None and _identities(entry[0]) == entry[0] else None


def _keep(keys: tuple[tuple, ...], spec: mujoco.MjSpec, model: mujoco.MjModel, path: Path | str) -> None:
    """Keep a copy of ``model`` under each of its variant's ``keys``, with the identities of the files it was read
    from."""
    if int(model.nbuffer) > COMPILED_BYTES:
        return
    entry = (_read_from(spec, path), copy.copy(model))
    with _CACHES:
        for key in keys:
            _COMPILED[key] = entry
            _COMPILED.move_to_end(key)
        while len({id(e) for e in _COMPILED.values()}) > COMPILED_MAX or \
                sum(int(m.nbuffer) for _, m in {id(e): e for e in _COMPILED.values()}.values()) > COMPILED_BYTES:
            _COMPILED.popitem(last=False)


def _compiled(path: Path | str, *, integrator: str | None, timestep: float | None,
              edit: Callable[[mujoco.MjSpec], None] | None) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    spec, rest = _prepared(path, edit)
    if rest is not None:
        rest(spec)
    if integrator is not None:
        spec.option.integrator = integrator_enum(integrator)
    if timestep is not None:
        if not timestep > 0:
            raise ValueError(f"timestep must be positive, got {timestep}")
        spec.option.timestep = timestep
    try:
        model = spec.compile()
    except Exception as exc:
        try:
            check_spec(spec)  # what a MuJoCo that fails on it while compiling does not name
        except InvalidModel as invalid:
            raise ModelError(f"invalid MJCF {str(path)!r}: {invalid}") from None
        raise ModelError(f"invalid MJCF {str(path)!r}: {_one_line(exc)}") from None
    try:
        check_model(model)
        # then what the compiled model cannot show: a number written non-finite that the spec took for unset
        # (a geom's mass="nan" becomes its density's mass)
        check_texts(_TEXTS.get(str(path), b""), Path(path).parent,
                    lambda p: inputs.read_bytes(p, what="MJCF", limit=inputs.MODEL_LIMIT))
    except InvalidModel as exc:
        raise ModelError(f"invalid MJCF {str(path)!r}: {exc}") from None
    after_compile(model, str(path))  # fallbacks for an older MuJoCo (harness.compat)
    return spec, model


_PREPARED: OrderedDict[tuple, tuple[tuple, mujoco.MjSpec]] = OrderedDict()
_PREPARED_MAX = 4  # a spec compiled once (isolate's) holds its meshes: Menagerie's Panda's, 50 MB
PREPARED = {"prepared": 0, "reused": 0}
"""How many specs :func:`_prepared` made with their leading edit applied, and how many it copied again."""


def _prepared(path: Path | str, edit: Callable[[mujoco.MjSpec], None] | None
              ) -> tuple[mujoco.MjSpec, Callable[[mujoco.MjSpec], None] | None]:
    """The spec of ``path`` with its textures made small and flat and the leading part of ``edit`` applied, and
    what of ``edit`` is left to apply (None: nothing). The leading part is ``edit`` itself, or the first of a
    composed edit's parts (``edits``: :class:`harness.engine.variants.Composed`): a tree case's
    :class:`~harness.reference.tree.TreeEdit`, which every variant of its model gets first and which compiles
    the model to find what to switch off. A copy of the spec made so before is handed out where the file (and
    each file it includes or reads a mesh, height field or skin from) is unchanged on disk and the leading part
    is equal (:func:`edit_identity`), so that part runs once per model and process, not once per variant; made
    anew where that cannot be told (as :func:`compile_model`'s own keeping)."""
    parts = getattr(edit, "edits", None)
    lead, rest = (parts[0], (parts[1] if len(parts) == 2 else dataclasses.replace(edit, edits=parts[1:]))) \
        if isinstance(parts, tuple) and parts and dataclasses.is_dataclass(edit) else (edit, None)
    key = _prepared_key(path, lead)
    if key is not None:
        with _CACHES:
            entry = _PREPARED.get(key)
            if entry is not None:
                _PREPARED.move_to_end(key)
        if entry is not None and _identities(entry[0]) == entry[0]:
            PREPARED["reused"] += 1
            with _CACHES:  # copied one thread at a time, as _parsed copies; and what check_text reads after
                _TEXTS.pop(str(path), None)  # compiling: this text, unchanged on disk
                _TEXTS[str(path)] = key[1]
                return entry[1].copy(), rest
    spec = load_spec(path)
    small_textures(spec)
    flat_textures(spec)
    if lead is not None:
        lead(spec)
    if key is None:
        return spec, rest
    PREPARED["prepared"] += 1
    files = _read_from(spec, path)
    with _CACHES:
        _PREPARED[key] = (files, spec)
        while len(_PREPARED) > _PREPARED_MAX:
            _PREPARED.popitem(last=False)
        return spec.copy(), rest


def _prepared_key(path: Path | str, lead: Callable[[mujoco.MjSpec], None] | None) -> tuple | None:
    """What makes a prepared spec of ``path`` (its resolved path, its text, the leading edit), or None where it
    cannot be kept: an edit without a stable identity, an unreadable file, an older MuJoCo's per-parse fallbacks
    or one without ``MjSpec.copy``."""
    identity = edit_identity(lead)
    if identity is None or compat.missing_flags() or not hasattr(mujoco.MjSpec, "copy"):
        return None
    try:
        text = inputs.read_bytes(path, what="MJCF", limit=inputs.MODEL_LIMIT)
    except (OSError, inputs.InputFileError):
        return None
    return (str(Path(path).resolve()), text, identity)


def _variant_key(path: Path | str, integrator: str | None, timestep: float | None,
                 edit: Callable[[mujoco.MjSpec], None] | None) -> tuple | None:
    """What makes a variant of ``path``'s model, or None where it cannot be told (never reused then): an
    edit without a stable identity, a file that cannot be read, an older MuJoCo's per-parse fallbacks."""
    identity = edit_identity(edit)
    if identity is None or compat.missing_flags():
        return None
    try:
        text = inputs.read_bytes(path, what="MJCF", limit=inputs.MODEL_LIMIT)
    except (OSError, inputs.InputFileError):
        return None
    return (str(Path(path).resolve()), hashlib.sha256(text).hexdigest(), integrator,
            _identity(timestep), identity)


def _read_from(spec: mujoco.MjSpec, path: Path | str) -> tuple:
    """The identities (:func:`_identities`) of every file ``spec`` was read from: ``path``, the files it includes,
    and those it reads a mesh, height field or skin from: what a model kept from it depends on."""
    resolved = Path(path).resolve()
    return _identities(tuple(sorted({str(resolved), *_included(resolved), *_assets(spec, resolved.parent)})))


def _identities(paths: tuple) -> tuple:
    """Each file of ``paths`` (or of the identities given) with its identity on disk now: (size, mtime_ns,
    inode), None where it is absent."""
    out: list[tuple[str, tuple[int, int, int] | None]] = []
    for item in paths:
        name = item[0] if isinstance(item, tuple) else item
        try:
            st = os.stat(name)
            out.append((name, (st.st_size, st.st_mtime_ns, st.st_ino)))
        except OSError:
            out.append((name, None))
    return tuple(out)


_INCLUDE = re.compile(rb"<include\s[^>]*?file\s*=\s*[\"']([^\"']+)[\"']")


def _included(path: Path, depth: int = 0) -> list[str]:
    """The files ``path`` includes, recursively (as MuJoCo resolves them: against the including model's
    folder), whether or not they exist."""
    try:
        text = inputs.read_bytes(path, what="MJCF", limit=inputs.MODEL_LIMIT)
    except (OSError, inputs.InputFileError):
        return []
    out = []
    for name in _INCLUDE.findall(text):
        included = (path.parent / os.fsdecode(name)).resolve()
        out.append(str(included))
        if depth < 16 and included != path:
            out.extend(_included(included, depth + 1))
    return out


def _assets(spec: mujoco.MjSpec, folder: Path) -> list[str]:
    """The files the compiled ``spec`` read its meshes, height fields and skins from (each where MuJoCo looks
    for it: the compiler's meshdir or assetdir, or the model's folder)."""
    dirs = [d for d in (getattr(spec.compiler, "meshdir", ""), getattr(spec.compiler, "assetdir", "")) if d]
    out: list[str] = []
    for element in (*spec.meshes, *spec.hfields, *spec.skins):
        name = getattr(element, "file", "")
        if name:
            out.extend(str((folder / d / name).resolve()) for d in dirs)
            out.append(str((folder / name).resolve()))
    return out


def edit_identity(edit: object) -> tuple | None:
    """A value that is equal for two spec edits exactly when they make the same change, or None where that
    cannot be told (a closure, a lambda, a bound method, an object with mutable state): None edits, module-level
    functions, ``functools.partial`` of such with equal arguments, and frozen dataclasses (such as
    :class:`harness.engine.variants.Composed`) of equal fields."""
    return ("none",) if edit is None else _identity(edit)


_PLAIN = (bool, int, float, str, bytes, type(None), enum.Enum)


def _identity(value: object) -> tuple | None:
    if isinstance(value, _PLAIN):
        return (type(value), value)
    if isinstance(value, (tuple, frozenset)):
        parts = [_identity(v) for v in (sorted(value, key=repr) if isinstance(value, frozenset) else value)]
        return None if any(p is None for p in parts) else (type(value), tuple(parts))
    if isinstance(value, types.FunctionType):
        module_level = value.__closure__ is None and "<" not in value.__qualname__
        return ("function", value) if module_level else None
    if isinstance(value, functools.partial):
        parts = [_identity(value.func), _identity(value.args),
                 _identity(tuple(sorted(value.keywords.items())))]
        return None if any(p is None for p in parts) else ("partial", *parts)
    if dataclasses.is_dataclass(value) and not isinstance(value, type) \
            and type(value).__dataclass_params__.frozen:  # type: ignore[attr-defined]
        parts = [_identity(getattr(value, f.name)) for f in dataclasses.fields(value)]
        return None if any(p is None for p in parts) else ("dataclass", type(value), tuple(parts))
    return None


SMALL_TEXTURE = 8
"""The largest side, in texels, :func:`small_textures` leaves a generated texture."""


def small_textures(spec: mujoco.MjSpec, *, named_only: bool = False) -> dict[str, tuple[tuple[int, int],
                                                                                      tuple[int, int]]]:
    """Every texture MuJoCo generates (``builtin``: a gradient sky, a checker floor) made at most
    :data:`SMALL_TEXTURE` texels a side, its aspect kept (a skybox's six faces stay six). Textures are drawn,
    never simulated: nothing the harness measures reads them, and generating them dominates compiling a model
    such as dm_control's (an 800 × 800 sky, compiled again for every variant). A picture of the model
    (:mod:`harness.outputs.stills`) compiles the file itself, textures as written.

    ``named_only``: only the textures with a name. Returns each named texture changed: its (width, height)
    as written and as made."""
    changed = {}
    for texture in spec.textures:
        if texture.builtin == mujoco.mjtBuiltin.mjBUILTIN_NONE or texture.width < 1 or texture.height < 1 \
                or (named_only and not texture.name):
            continue
        written = (int(texture.width), int(texture.height))
        common = math.gcd(*written)
        aspect = (written[0] // common, written[1] // common)
        k = max(1, min(common, SMALL_TEXTURE // max(aspect)))
        texture.width, texture.height = aspect[0] * k, aspect[1] * k
        if texture.name:
            changed[texture.name] = (written, (aspect[0] * k, aspect[1] * k))
    return changed


def flat_textures(spec: mujoco.MjSpec) -> list[tuple[mujoco.MjsTexture, tuple]]:
    """Every texture read from an image file (``file``, ``cubefiles``) made a flat one of
    :data:`SMALL_TEXTURE` texels a side, its name kept (the materials that use it still compile). As for
    :func:`small_textures`, textures are drawn, never simulated; a robot's photographs are not small: ANYmal C's
    21 PNG files decode to 244 MB in every compiled variant (its check held several at once, 6.6 GB at its peak)
    and take 3.6 s of each compile.
    Returns each texture changed with what it was (file, cubefiles, builtin, width, height)."""
    was = []
    for texture in spec.textures:
        if texture.file or any(texture.cubefiles):
            was.append((texture, (texture.file, list(texture.cubefiles), texture.builtin, texture.width,
                                  texture.height)))
            texture.file = ""
            texture.cubefiles = [""] * len(texture.cubefiles)
            texture.builtin = mujoco.mjtBuiltin.mjBUILTIN_FLAT
            texture.width = texture.height = SMALL_TEXTURE
    return was


def _not_a_file(path: Path) -> str:
    """What ``path``, which is not a regular file, is instead."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return "no such file"
    except OSError as exc:
        return exc.strerror or "cannot be read"
    if stat.S_ISDIR(mode):
        return "it is a directory"
    kinds = {stat.S_ISCHR: "a character device", stat.S_ISBLK: "a block device", stat.S_ISFIFO: "a pipe",
             stat.S_ISSOCK: "a socket"}
    return f"it is {next((k for test, k in kinds.items() if test(mode)), 'not a regular file')}, not a file"


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())
