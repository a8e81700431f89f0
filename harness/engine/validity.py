"""What a compiled model must hold before anything runs: finite numbers, a usable timestep, solref in one format.

MuJoCo compiles a ``timestep="nan"``, a ``solref="nan 1"`` or a NaN gravity
(it warns that the XML contains a NaN) and then runs: a NaN timestep fails
far from its cause, a NaN solref is replaced at every constraint row by
MuJoCo's default with a warning each time (tens of thousands of lines) while
the report shows "nan". A ``solref`` mixing its two formats (timeconst and
dampratio positive, or −stiffness and −damping: XMLreference "solref") is
replaced by the default the same way. So a model is refused before running,
naming the first attribute that is wrong and what is accepted: the options,
then each element's inputs (position, mass, solref, …), then the reference
configuration.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

__all__ = ["InvalidModel", "check_model", "check_spec", "check_texts"]

# MjModel field prefixes of the elements a message names: (kind, mjtObj, the MjModel count of them)
ELEMENTS: dict[str, tuple[str, mujoco.mjtObj, str]] = {
    "body_": ("body", mujoco.mjtObj.mjOBJ_BODY, "nbody"), "jnt_": ("joint", mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
    "dof_": ("dof", mujoco.mjtObj.mjOBJ_DOF, "nv"), "geom_": ("geom", mujoco.mjtObj.mjOBJ_GEOM, "ngeom"),
    "site_": ("site", mujoco.mjtObj.mjOBJ_SITE, "nsite"), "eq_": ("equality", mujoco.mjtObj.mjOBJ_EQUALITY, "neq"),
    "pair_": ("pair", mujoco.mjtObj.mjOBJ_PAIR, "npair"),
    "actuator_": ("actuator", mujoco.mjtObj.mjOBJ_ACTUATOR, "nu"),
    "tendon_": ("tendon", mujoco.mjtObj.mjOBJ_TENDON, "ntendon"),
}
# the elements' inputs, in the order they are looked at; what MuJoCo derives from them (a subtree mass,
# an inverse weight) is finite when they are, or makes the run diverge, which its verdict says
INPUTS = ("pos", "quat", "ipos", "iquat", "mass", "inertia", "solref", "solimp", "solreffriction", "solimpfriction",
          "solref_lim", "solimp_lim", "solref_fri", "solimp_fri", "solmix", "friction", "damping", "armature",
          "stiffness", "frictionloss", "springref", "lengthspring", "range", "margin", "gap", "size", "axis",
          "data", "gear", "gravcomp", "gainprm", "biasprm", "dynprm", "ctrlrange", "forcerange", "actrange")


class InvalidModel(ValueError):
    """A compiled model holding a number MuJoCo would run with but that makes no sense."""


# attributes that name or point at something (a body called "nan" is a name, not a number)
REFERENCES = frozenset({"name", "class", "childclass", "joint", "joint1", "joint2", "body", "body1", "body2",
                        "site", "site1", "site2", "geom", "geom1", "geom2", "tendon", "tendon1", "tendon2",
                        "actuator", "mesh", "hfield", "material", "texture", "target", "objname", "refname",
                        "prefix", "plugin", "instance", "cranksite", "slidersite", "jointinparent", "key",
                        "model", "content_type", "builtin", "type", "mark", "sensor", "camera", "light",
                        "flex", "skin", "reftype", "objtype", "frame", "dir", "user"})
_NON_FINITE = re.compile(rb"(?i)nan|inf|e\s*[+]?\d{3}")
_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)
_TAG = re.compile(r"<([A-Za-z_][\w.:-]*)((?:\s+[^<>]*?)?)/?>")
_ATTRIBUTE = re.compile(r"([A-Za-z_][\w.:-]*)\s*=\s*(?:\"([^\"]*)\"|'([^']*)')")


def check_text(text: bytes) -> None:
    """:class:`InvalidModel` naming the first element of the MJCF ``text`` with a numeric attribute written
    non-finite (``nan``, ``inf``, ``1e400``). Checked as written because the spec cannot tell some of them from
    an unset value: a geom's ``mass="nan"`` reads as "unset" and silently becomes its density's mass
    (issue 45). Its includes: :func:`check_texts`."""
    if not _NON_FINITE.search(text):
        return
    # read as tags and attributes, not as strict XML: MuJoCo's parser accepts what XML does not ("--" in a
    # comment), and nothing here may refuse a model MuJoCo reads
    source = _COMMENT.sub(" ", text.decode("utf-8", errors="replace"))
    for tag, attributes in _TAG.findall(source):
        for attribute, double, single in _ATTRIBUTE.findall(attributes):
            value = double or single
            if attribute in REFERENCES or "file" in attribute:
                continue
            try:
                numbers = [float(token) for token in value.split()]
            except ValueError:
                continue
            if numbers and not all(math.isfinite(x) for x in numbers):
                name = next((d or q for a, d, q in _ATTRIBUTE.findall(attributes) if a == "name"), "")
                where = f"{tag} {name!r}" if name else f"a <{tag}> (unnamed)"
                raise InvalidModel(f"{where} {attribute} = {' '.join(value.split())!r} is not finite; accepted: "
                                   "finite numbers")


INCLUDED_MAX = 256
"""The most files :func:`check_texts` reads through ``<include>`` (a model's includes are a handful; a loop of
them is MuJoCo's to refuse)."""


def check_texts(text: bytes, folder: Path, read: Callable[[Path], bytes]) -> None:
    """:func:`check_text` of the MJCF ``text`` and of every file it ``<include>``s, recursively (their names
    relative to ``folder``, the model's, as MuJoCo resolves them; each read by ``read``, which bounds it): a
    ``mass="nan"`` in a robot's included file is as silent as in the scene."""
    pending, seen = [text], set[Path]()
    while pending:
        current = pending.pop()
        check_text(current)
        if b"<include" not in current:
            continue
        source = _COMMENT.sub(" ", current.decode("utf-8", errors="replace"))
        for tag, attributes in _TAG.findall(source):
            if tag != "include":
                continue
            name = next((d or q for a, d, q in _ATTRIBUTE.findall(attributes) if a == "file"), "")
            path = folder / name
            if not name or path in seen or len(seen) >= INCLUDED_MAX:
                continue
            seen.add(path)
            try:
                pending.append(read(path))
            except (OSError, ValueError):
                continue  # unreadable: MuJoCo's parser has said why, or will


def check_model(model: mujoco.MjModel) -> None:
    """:class:`InvalidModel` naming the first non-finite number (options, then the elements' inputs, then
    the reference configuration), a timestep that is not positive or a solref mixing its two formats."""
    options: type = type(model.opt)  # (typed: mypy takes type[Any] for unhashable)
    for name in _option_fields(options):
        value = np.asarray(getattr(model.opt, name), dtype=float)
        if not np.isfinite(value).all():
            raise _non_finite_option(name, value)
    if not model.opt.timestep > 0:
        raise InvalidModel(f"option timestep = {model.opt.timestep:g} s; accepted: a timestep > 0 s")
    model_type: type = type(model)
    present = [f for f, count in _element_fields(model_type) if count is None or getattr(model, count)]
    arrays = [getattr(model, f) for f in present]
    if not np.isfinite(np.concatenate([a.ravel() for a in arrays])).all():  # one test: it runs at every (cheap) compile
        field, values = next((f, a) for f, a in zip(present, arrays, strict=True) if not np.isfinite(a).all())
        row = int(np.argwhere(~np.isfinite(values.reshape(len(values), -1)))[0, 0])
        raise InvalidModel(f"{_where(model, field, row)} = {_shown(values[row])} is not finite; "
                           "accepted: finite numbers")
    for field, values in zip(present, arrays, strict=True):
        if "solref" in field and values.size:
            mixed = np.flatnonzero((values[:, 0] > 0) != (values[:, 1] > 0))
            if mixed.size:
                _check_solref(_where(model, field, int(mixed[0])), values[mixed[0]])


# what a spec's elements always hold (a spec marks unset attributes such as a geom's mass with NaN)
SPEC_INPUTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "bodies": ("body", ("pos", "quat", "mass", "inertia", "gravcomp")),
    "joints": ("joint", ("pos", "axis", "range", "damping", "armature", "stiffness", "frictionloss", "springref",
                         "ref", "margin", "solref_limit", "solimp_limit", "solref_friction", "solimp_friction")),
    "geoms": ("geom", ("pos", "quat", "size", "friction", "solref", "solimp", "solmix", "margin", "gap")),
    "equalities": ("equality", ("data", "solref", "solimp")),
    "pairs": ("pair", ("friction", "solref", "solimp", "solreffriction", "margin", "gap")),
}


def check_spec(spec: mujoco.MjSpec) -> None:
    """:class:`InvalidModel` for a spec that did not compile, where what failed is a non-finite option, a
    non-finite input of an element (:data:`SPEC_INPUTS`) or a solref mixing its formats.

    MuJoCo before 4 runs a forward pass while compiling and fails on what it warns about ("Nan, Inf or
    huge value in QACC", "mixed solref format"), naming no attribute; this says which."""
    options: type = type(mujoco.MjModel.from_xml_string("<mujoco/>").opt)  # (typed, as in check_model)
    for name in _option_fields(options):
        value = np.asarray(getattr(spec.option, name, 0.0), dtype=float)
        if not np.isfinite(value).all():
            raise _non_finite_option(name, value)
    for kinds, (kind, attributes) in SPEC_INPUTS.items():
        for element in getattr(spec, kinds, ()):
            for attribute in attributes:
                raw = getattr(element, attribute, None)
                value = np.asarray(raw if raw is not None else 0.0, dtype=float)
                where = f"{kind} {element.name!r} {attribute}"
                if not np.isfinite(value).all():
                    raise InvalidModel(f"{where} = {_shown(value)} is not finite; accepted: finite numbers")
                if "solref" in attribute:
                    _check_solref(where, value)


def _check_solref(where: str, value: np.ndarray) -> None:
    """MuJoCo's own test (engine_core_constraint.c, getsolparam): mixed formats are replaced by the default."""
    first, second = np.ravel(value)[:2]
    if (first > 0) != (second > 0):
        raise InvalidModel(f"{where} = {_shown(value)} mixes solref's two formats (MuJoCo would replace it by its "
                           "default); accepted: timeconst and dampratio both > 0, or −stiffness and −damping "
                           "both ≤ 0")


def _non_finite_option(name: str, value: np.ndarray) -> InvalidModel:
    accepted = "a timestep > 0 s" if name == "timestep" else "finite numbers"
    return InvalidModel(f"option {name} = {_shown(value)} is not finite; accepted: {accepted}")


def _shown(value: np.ndarray) -> str:
    flat = np.atleast_1d(value).ravel()
    text = " ".join(f"{float(x):g}" for x in flat)
    return text if flat.size == 1 else f"[{text}]"


@functools.cache
def _option_fields(options: type) -> tuple[str, ...]:
    """The floating-point fields of MjOption (scalars and vectors), in name order."""
    probe = mujoco.MjModel.from_xml_string("<mujoco/>").opt
    return tuple(n for n in dir(options) if not n.startswith("_")
                 and np.asarray(getattr(probe, n)).dtype.kind == "f")


@functools.cache
def _element_fields(model_type: type) -> tuple[tuple[str, str | None], ...]:
    """The floating-point MjModel fields holding the elements' :data:`INPUTS` (in that order), each with
    the count of its elements (a field of an element the model has none of is not looked at), then the
    reference configurations."""
    probe = mujoco.MjModel.from_xml_string("<mujoco/>")
    fields = [(n, count) for n in dir(model_type) for prefix, (_, _, count) in ELEMENTS.items()
              if n.startswith(prefix) and n.removeprefix(prefix) in INPUTS
              and isinstance(getattr(probe, n, None), np.ndarray) and getattr(probe, n).dtype.kind == "f"]
    fields.sort(key=lambda f: (INPUTS.index(f[0].split("_", 1)[1]), f[0]))
    return (*fields, *((n, None) for n in ("qpos0", "qpos_spring") if hasattr(probe, n)))


def _where(model: mujoco.MjModel, field: str, row: int) -> str:
    """``equality 'rod' solref`` for row ``row`` of MjModel field ``field``."""
    for prefix, (kind, obj, _) in ELEMENTS.items():
        if field.startswith(prefix):
            if kind == "dof":
                kind, obj, row = "joint", mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[row])
            name = mujoco.mj_id2name(model, obj, row)
            return f"{kind} {repr(name) if name else f'#{row}'} {field.removeprefix(prefix)}"
    return f"{field} (entry {row})"
