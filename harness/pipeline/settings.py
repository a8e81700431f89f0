"""The settings a case ran with, as a typed object: what the report lists, what verdicts read, what differs from
the shipped model.

:class:`RunSettings` is built once per case by the run (:func:`harness.pipeline.run.run_case`) and read by
attribute everywhere (the verdict reads ``integrators``, the requirements ``integrator``); its
:meth:`~RunSettings.as_dict` is the flat mapping report.json (docs/report-json.md) and the report's settings table
show, key for key as they always were.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np

from harness.engine.integrators import integrator_name

__all__ = ["ModelSettings", "RunSettings", "authored_differences", "changed_settings"]


@dataclass(frozen=True)
class ModelSettings:
    """The settings of a compiled model that matter for a comparison: its options, each equality's softness and
    each contact pair's."""

    timestep: float
    integrator: str
    solver: str
    iterations: int
    tolerance: float
    cone: str
    impratio: float
    noslip_iterations: int
    equalities: Mapping[str, Mapping[str, list[float]]] = field(default_factory=dict)
    """By equality: its ``solref`` and ``solimp``."""
    pairs: Mapping[str, Mapping[str, list[float]]] = field(default_factory=dict)
    """By contact pair: its ``solref``, ``solimp``, ``friction`` and ``margin``."""

    @classmethod
    def of(cls, model: mujoco.MjModel) -> ModelSettings:
        equalities = {}
        for i in range(model.neq):
            eq = model.equality(i)
            equalities[eq.name] = {"solref": [float(x) for x in eq.solref], "solimp": [float(x) for x in eq.solimp]}
        pairs = {}
        for i in range(model.npair):
            pair = model.pair(i)
            pairs[pair.name] = {key: [float(x) for x in np.atleast_1d(getattr(pair, key))]
                                for key in ("solref", "solimp", "friction", "margin")}
        return cls(timestep=float(model.opt.timestep), integrator=integrator_name(model),
                   solver=mujoco.mjtSolver(int(model.opt.solver)).name.removeprefix("mjSOL_"),
                   iterations=int(model.opt.iterations), tolerance=float(model.opt.tolerance),
                   cone=mujoco.mjtCone(int(model.opt.cone)).name.removeprefix("mjCONE_"),
                   impratio=float(model.opt.impratio), noslip_iterations=int(model.opt.noslip_iterations),
                   equalities=equalities, pairs=pairs)

    def as_dict(self) -> dict[str, object]:
        """The flat mapping the report shows: the options by name, ``equality.NAME.solref`` and the like."""
        out: dict[str, object] = {
            "timestep": self.timestep, "integrator": self.integrator, "solver": self.solver,
            "iterations": self.iterations, "tolerance": self.tolerance, "cone": self.cone,
            "impratio": self.impratio, "noslip_iterations": self.noslip_iterations}
        for name, values in self.equalities.items():
            out |= {f"equality.{name}.{key}": value for key, value in values.items()}
        for name, values in self.pairs.items():
            out |= {f"pair.{name}.{key}": value for key, value in values.items()}
        return out


@dataclass(frozen=True)
class RunSettings:
    """The settings a case ran with.

    Attributes:
        model: the model's settings (:class:`ModelSettings`).
        mjcf: the model file run.
        horizon, settle: the horizon, and when force and MuJoCo-only figures start counting (s).
        params: the system's parameters as read from the model.
        q0, qd0: the initial state, by analytic coordinate.
        integrators: the integrators run.
        recorder: how MuJoCo's runs were recorded (:func:`harness.engine.recording.recorder`).
        changed: every setting or parameter that differs from the shipped model,
            ``{name: {"shipped": a, "tested": b}}``.
        projected: what the initial state's projection onto the constraints moved.
        tree: for a model judged against its own tree, what the tree covers and how its horizon was chosen.
        families: what the families add (``peers``: the second opinions' comparison).
        recorder_fallbacks: where the recorder handed runs to the loop, one line each.
        compat: what this MuJoCo lacks and how it is shown, one line each.
        backend: on a backend other than C, its name, precision and what it skipped or adapted.
    """

    model: ModelSettings
    mjcf: str
    horizon: float
    settle: float
    params: Mapping[str, float]
    q0: Mapping[str, float]
    qd0: Mapping[str, float]
    integrators: tuple[str, ...]
    recorder: str
    changed: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    projected: tuple[str, ...] = ()
    tree: Mapping[str, object] | None = None
    families: Mapping[str, object] = field(default_factory=dict)
    recorder_fallbacks: tuple[str, ...] = ()
    compat: tuple[str, ...] = ()
    backend: Mapping[str, object] | None = None

    @property
    def integrator(self) -> str:
        """The model's own integrator."""
        return self.model.integrator

    @property
    def peers(self) -> Mapping[str, object] | None:
        """The second opinions' comparison (:mod:`harness.opinions.threeway`), where it ran."""
        found = self.families.get("peers")
        return found if isinstance(found, Mapping) else None

    def as_dict(self) -> dict[str, object]:
        """The flat mapping of report.json's ``settings`` and the report's settings table, in its order."""
        out = self.model.as_dict() | {
            "mjcf": self.mjcf, "horizon": self.horizon, "settle": self.settle, "params": dict(self.params),
            "q0": dict(self.q0), "qd0": dict(self.qd0), "integrators": list(self.integrators),
            "recorder": self.recorder}
        if self.changed:
            out["changed"] = {k: dict(v) for k, v in self.changed.items()}
        if self.projected:
            out["projected"] = list(self.projected)
        if self.tree is not None:
            out["tree"] = dict(self.tree)
        out |= self.families
        if self.recorder_fallbacks:
            out["recorder_fallbacks"] = list(self.recorder_fallbacks)
        if self.compat:
            out["compat"] = list(self.compat)
        if self.backend is not None:
            out["backend"] = dict(self.backend)
        return out


def changed_settings(shipped: Mapping[str, object], tested: Mapping[str, object]) -> dict[str, dict[str, object]]:
    """Every setting or parameter whose value differs between the shipped model and the one tested:
    ``{name: {"shipped": a, "tested": b}}`` (a name only one has shows None on the other side)."""
    return {k: {"shipped": shipped.get(k), "tested": tested.get(k)}
            for k in dict.fromkeys([*shipped, *tested]) if shipped.get(k) != tested.get(k)}


_SETTINGS_OF = {"option": {"timestep", "integrator", "solver", "iterations", "tolerance", "cone", "impratio",
                            "noslip_iterations"},
                "equality": {"solref", "solimp"}, "pair": {"solref", "solimp", "friction", "margin"}}
"""Attributes :class:`ModelSettings` lists already, by the element kind (equalities of every type)."""


def _element_key(element: ET.Element, parent: str, index: int) -> str:
    """An element's label: its kind and name where it has one (MuJoCo's names are unique per kind), else its
    parent's label and its place among its kind there."""
    name = element.get("name")
    if name is not None:
        return f"{element.tag} {name!r}"
    own = element.tag + (f"[{index}]" if index else "")
    return f"{parent}/{own}" if parent and parent != "mujoco" else own


def _covered(element: ET.Element, parent: ET.Element | None, attribute: str) -> bool:
    kind = "equality" if parent is not None and parent.tag == "equality" else element.tag
    return attribute in _SETTINGS_OF.get(kind, set())


def authored_differences(shipped: str, tested: str) -> dict[str, dict[str, object]]:
    """Every attribute of every element in which two models as MuJoCo writes them differ
    (:func:`harness.engine.models.authored`): ``{"mjcf: ELEMENT ATTRIBUTE": {"shipped": a, "tested": b}}``
    ("default": MuJoCo's; an element one lacks: ``{"mjcf: ELEMENT": "absent" / "present"}``), less what
    :class:`ModelSettings` lists. Compared as written, so a joint's added damping, a geom's margin or a new
    body shows however the model was changed."""
    out: dict[str, dict[str, object]] = {}

    def children(element: ET.Element | None, label: str) -> dict[str, ET.Element]:
        found: dict[str, ET.Element] = {}
        counts: dict[str, int] = {}
        for child in element if element is not None else ():
            index = counts.get(child.tag, 0)
            counts[child.tag] = index + 1
            found[_element_key(child, label, index)] = child
        return found

    def walk(a: ET.Element | None, b: ET.Element | None, label: str, parent: ET.Element | None) -> None:
        if a is None or b is None:
            out[f"mjcf: {label}"] = {"shipped": "absent" if a is None else "present",
                                     "tested": "absent" if b is None else "present"}
            return
        for attribute in dict.fromkeys([*a.attrib, *b.attrib]):
            if a.get(attribute) != b.get(attribute) and not _covered(a, parent, attribute):
                out[f"mjcf: {label} {attribute}"] = {"shipped": a.get(attribute, "default"),
                                                     "tested": b.get(attribute, "default")}
        ca, cb = children(a, label), children(b, label)
        for key in dict.fromkeys([*ca, *cb]):
            walk(ca.get(key), cb.get(key), key, a)

    root_a, root_b = ET.fromstring(shipped), ET.fromstring(tested)
    walk(root_a, root_b, "mujoco", None)
    return out
