"""MuJoCo, the tree reference and Pinocchio at sampled states: which one is off, where two agree.

Three independent evaluations of the same rigid-body dynamics, all in MuJoCo's coordinates (qpos, qvel,
qacc; :mod:`harness.opinions.pinocchio` for the map to Pinocchio's):

- MuJoCo: ``mj_fullM``, ``qfrc_bias``, ``qacc`` under a test force (``mj_forward``), ``qfrc_inverse``
  (``mj_inverse``) — the engine under test;
- the tree reference (:mod:`analytic.tree`): M and the forcing from the Lagrangian of the model's tree,
  differentiated exactly, in charts centred at the state (where its q̇ is MuJoCo's qvel and q̈ its qacc);
- Pinocchio built from the compiled model: CRBA, RNEA and ABA (the articulated-body algorithm, a different
  route to q̈ from a solve with M).

Every side evaluates :func:`~harness.opinions.pinocchio.rigid` of the model (no springs, dampers, actuators,
constraints or gravity compensation; gravity kept), at states drawn over the configuration space (not only
along the motion judged): each hinge anywhere in its range (else a full turn), each slide within its range
(else the model's size), balls and free joints at random orientations, velocities of the size gravity gives
over the model's size.

Tolerance (the figure's unit): a quantity's deviation between two sides, relative to its scale at the state,
over ε cond₂(M) at that state (ε = 2.2e-16). A backward-stable evaluation of M, of the bias forces or of a solve
with M errs by a small multiple of that (Higham, *Accuracy and Stability of Numerical Algorithms*, ch. 7: the
forward error of a solve is bounded by cond(M) times the backward error, a few ε per operation chain); the
limit :data:`LIMIT` allows a few of them. Two sides agree on a quantity when their deviation is within it at
every state. The gated figure ``instant.peer.QUANTITY`` is MuJoCo's distance from the nearer of the two others
at the worst state: MuJoCo passes wherever one independent peer agrees with it; the attribution (which side is
off) is reported beside it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from analytic.tree import TreeDynamics
from harness.core.errors import ModelError
from harness.core.figures import Figure, FigureName
from harness.engine.compat import full_mass_matrix
from harness.opinions import pinocchio as peer
from harness.reference.tree import charts, read_tree, refusal, start_state

__all__ = ["LIMIT", "QUANTITIES", "summary", "three_way"]

QUANTITIES = ("mass_matrix", "bias", "qacc", "inverse")
"""What the three sides compare: M, the bias forces (Coriolis, centrifugal, gravity), the forward dynamics'
qacc under a test force, and the inverse dynamics' force for a test acceleration."""

SIDES = ("MuJoCo", "tree", "Pinocchio")

EPS = float(np.finfo(float).eps)

LIMIT = 64.0
"""Agreement: a deviation within 64 ε cond₂(M) relative (the module docstring gives its basis; the largest
measured between sides that agree, and the margin, are in docs/findings/peers.md)."""

STATES = 8
"""States drawn per model: enough that every joint is seen away from its reference in several directions,
cheap beside any trajectory (one evaluation per state and side)."""

UNIT = "ε·cond(M)"

SKIPPED = f"second opinions skipped: Pinocchio is not installed ({peer.INSTALL})"


@dataclass(frozen=True)
class Agreement:
    """One quantity across the three sides.

    Attributes:
        quantity: one of :data:`QUANTITIES`.
        pairs: per pair of sides, its worst deviation over the states, in units of ε cond₂(M).
        mujoco: MuJoCo's distance from the nearer other side at the worst state (the gated figure).
        off: '' where all three agree; the side the other two agree without (MuJoCo, tree, Pinocchio);
            'none agree'; or 'undecided' (one side agrees with both others, which do not agree with each other).
    """

    quantity: str
    pairs: dict[str, float]
    mujoco: float
    off: str

    def describe(self) -> str:
        pairs = ", ".join(f"{k} {v:.2g}" for k, v in self.pairs.items())
        if not self.off:
            return f"{self.quantity}: all three agree ({pairs}; limit {LIMIT:g})"
        if self.off == "undecided":
            return f"{self.quantity}: one side agrees with both others, which disagree ({pairs}; limit {LIMIT:g})"
        if self.off == "none agree":
            return f"{self.quantity}: no two of the three agree ({pairs}; limit {LIMIT:g})"
        return f"{self.quantity}: {self.off} is off, the other two agree ({pairs}; limit {LIMIT:g})"


@dataclass(frozen=True)
class ThreeWay:
    """The three-way comparison of one model (``skipped``: why it did not run, '' where it did).

    Attributes:
        states: how many states were compared.
        conditioning: the largest cond₂(M) over them.
        agreements: one per quantity of :data:`QUANTITIES`.
    """

    states: int = 0
    conditioning: float = math.nan
    agreements: tuple[Agreement, ...] = ()
    skipped: str = ""

    def lines(self) -> list[str]:
        """What the check prints: one line where skipped, else one per quantity."""
        if self.skipped:
            return [self.skipped]
        head = (f"second opinions: MuJoCo, the tree reference and Pinocchio at {self.states} states "
                f"(cond(M) up to {self.conditioning:.2g}; deviations in ε cond(M))")
        return [head, *(f"  {a.describe()}" for a in self.agreements)]

    def figures(self) -> list[Figure]:
        """The gated figures ``instant.peer.QUANTITY``: MuJoCo's distance from its nearer peer (none where
        skipped)."""
        return [Figure(FigureName.instant("peer", a.quantity), a.mujoco, UNIT,
                       f"MuJoCo's {a.quantity.replace('_', ' ')} at {self.states} sampled states against the nearer "
                       "of the tree reference and Pinocchio, in ε cond(M)"
                       + (f" ({a.off} is off)" if a.off else "")) for a in self.agreements]

    def as_dict(self) -> dict[str, object]:
        if self.skipped:
            return {"skipped": self.skipped}
        return {"states": self.states, "conditioning": self.conditioning, "limit": LIMIT,
                "agreements": {a.quantity: {"pairs": a.pairs, "mujoco": a.mujoco, "off": a.off, "said": a.describe()}
                               for a in self.agreements}}


def _states(model: mujoco.MjModel, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states over the configuration space (module docstring): qpos (count, nq), qvel (count, nv)."""
    rng = np.random.default_rng(seed)
    size = max(float(model.stat.meansize), 1e-3)
    g = float(np.linalg.norm(model.opt.gravity)) or 9.81
    qpos = np.tile(np.asarray(model.qpos0, dtype=float), (count, 1))
    qvel = np.zeros((count, model.nv))
    for j in range(model.njnt):
        kind, adr, dof = int(model.jnt_type[j]), int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
        lo, hi = (float(x) for x in model.jnt_range[j])
        limited = bool(model.jnt_limited[j]) if hasattr(model, "jnt_limited") else hi > lo
        if kind in (peer.JOINT_HINGE, peer.JOINT_SLIDE):
            if limited and hi > lo:
                qpos[:, adr] = rng.uniform(lo, hi, count)
            else:
                span = math.pi if kind == peer.JOINT_HINGE else size
                qpos[:, adr] += rng.uniform(-span, span, count)
        elif kind == peer.JOINT_BALL:
            qpos[:, adr:adr + 4] = _unit_quaternions(rng, count)
        else:
            qpos[:, adr:adr + 3] += rng.uniform(-size, size, (count, 3))
            qpos[:, adr + 3:adr + 7] = _unit_quaternions(rng, count)
        rate = math.sqrt(g / size)  # rad/s; m/s for a linear dof below
        for k in range(peer.JOINT_NDOF[kind]):
            linear = kind == peer.JOINT_SLIDE or (kind == peer.JOINT_FREE and k < 3)
            qvel[:, dof + k] = rng.standard_normal(count) * (rate * size if linear else rate)
    return qpos, qvel


def _unit_quaternions(rng: np.random.Generator, count: int) -> np.ndarray:
    quat = rng.standard_normal((count, 4))
    return quat / np.linalg.norm(quat, axis=1, keepdims=True)


def _tree_side(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tree reference's M and bias forces at (qpos, qvel), in MuJoCo's dofs (charts centred at qpos)."""
    tree = read_tree(model, chart=charts(model, qpos))
    dyn = TreeDynamics.of(tree)
    q0, qd0 = start_state(model, qpos, qvel)
    q = np.array([q0[c] for c in dyn.coordinates])
    qd = np.array([qd0[c] for c in dyn.coordinates])
    mass, forcing = dyn.mass_and_forcing(q, qd)
    order = np.empty(model.nv, dtype=int)  # the tree's coordinate index of each MuJoCo dof
    index = {c: i for i, c in enumerate(dyn.coordinates)}
    for j, joint in enumerate(tree.joints):
        for k, name in enumerate(joint.coordinates):
            order[int(model.jnt_dofadr[j]) + k] = index[name]
    return mass[np.ix_(order, order)], -forcing[order]


def three_way(model: mujoco.MjModel, *, count: int = STATES, seed: int = 0) -> ThreeWay:
    """The three-way comparison of ``model`` (a :class:`ThreeWay` with ``skipped`` set where Pinocchio is not
    installed or the tree cannot be read: one line saying why)."""
    if not peer.available():
        return ThreeWay(skipped=SKIPPED)
    why = refusal(model)
    if why:
        return ThreeWay(skipped=f"second opinions skipped: {why}")
    rigid = peer.rigid(model)
    try:
        pin = peer.build(rigid)
    except ModelError as exc:
        return ThreeWay(skipped=f"second opinions skipped: Pinocchio cannot represent the model: {exc}")
    data = mujoco.MjData(rigid)
    rng = np.random.default_rng(seed + 1)
    g = float(np.linalg.norm(rigid.opt.gravity)) or 9.81
    qposes, qvels = _states(rigid, count, seed)
    ratios: dict[str, dict[str, list[float]]] = {q: {} for q in QUANTITIES}
    conditioning = 0.0
    for qpos, qvel in zip(qposes, qvels, strict=True):
        mujoco.mj_resetData(rigid, data)
        data.qpos[:], data.qvel[:] = qpos, qvel
        mujoco.mj_forward(rigid, data)
        m_mj = full_mass_matrix(rigid, data)
        scale_m = float(np.max(np.abs(m_mj)))
        force = m_mj @ rng.standard_normal(rigid.nv) * g  # a test force giving accelerations of gravity's size
        accel = rng.standard_normal(rigid.nv) * g  # a test acceleration
        bias_mj = np.array(data.qfrc_bias)
        data.qfrc_applied[:] = force
        mujoco.mj_forward(rigid, data)
        qacc_mj = np.array(data.qacc)
        data.qfrc_applied[:] = 0.0
        data.qacc[:] = accel
        mujoco.mj_inverse(rigid, data)
        inverse_mj = np.array(data.qfrc_inverse)

        m_tree, bias_tree = _tree_side(rigid, qpos, qvel)
        sides = {
            "MuJoCo": (m_mj, bias_mj, qacc_mj, inverse_mj),
            "tree": (m_tree, bias_tree, np.linalg.solve(m_tree, force - bias_tree), m_tree @ accel + bias_tree),
            "Pinocchio": (pin.mass_matrix(qpos), pin.bias(qpos, qvel), pin.forward(qpos, qvel, force),
                          pin.inverse(qpos, qvel, accel)),
        }
        cond = float(np.linalg.cond(m_mj))
        conditioning = max(conditioning, cond)
        unit = EPS * cond
        for k, quantity in enumerate(QUANTITIES):
            values = {s: v[k] for s, v in sides.items()}
            top = max(float(np.max(np.abs(v))) for v in values.values())
            scale = {"mass_matrix": scale_m, "qacc": max(top, g)}.get(quantity, max(top, scale_m * g))
            for i, a in enumerate(SIDES):
                for b in SIDES[i + 1:]:
                    dev = float(np.max(np.abs(values[a] - values[b]))) / scale / unit
                    ratios[quantity].setdefault(f"{a}–{b}", []).append(dev if math.isfinite(dev) else math.inf)
    agreements = []
    for quantity in QUANTITIES:
        per_pair = ratios[quantity]
        pairs = {k: max(v) for k, v in per_pair.items()}
        nearest = max(min(a, b) for a, b in zip(per_pair["MuJoCo–tree"], per_pair["MuJoCo–Pinocchio"], strict=True))
        agreeing = [k for k, v in pairs.items() if v <= LIMIT]
        if len(agreeing) == 3:
            off = ""
        elif len(agreeing) == 1:
            off = next(s for s in SIDES if s not in agreeing[0].split("–"))
        elif not agreeing:
            off = "none agree"
        else:  # two pairs agree through the third side: no single side is off
            off = "undecided"
        agreements.append(Agreement(quantity=quantity, pairs=pairs, mujoco=nearest, off=off))
    return ThreeWay(states=len(qposes), conditioning=conditioning, agreements=tuple(agreements))


def summary(peers: Mapping[str, Mapping[str, object] | None]) -> list[str]:
    """What a check prints of its cases' three-way comparisons (each case's :meth:`ThreeWay.as_dict`, None where
    it did not run): one line where every case's three sides agree on everything, one per case and quantity
    where a side is off, one per case skipped for a reason of its own, and one line in all where Pinocchio is
    not installed."""
    ran = {case: doc for case, doc in peers.items() if doc is not None}
    if not ran:
        return []
    if any(doc.get("skipped") == SKIPPED for doc in ran.values()):
        return [SKIPPED]
    lines, agreeing, worst = [], [], 0.0
    for case, doc in ran.items():
        if "skipped" in doc:
            lines.append(f"{case}: {doc['skipped']}")
            continue
        agreements: Mapping[str, Mapping] = doc["agreements"]  # type: ignore[assignment]
        off = {q: a for q, a in agreements.items() if a["off"]}
        for quantity, a in off.items():
            pairs = ", ".join(f"{k} {v:.3g}" for k, v in a["pairs"].items())
            who = {"none agree": "no two of MuJoCo, the tree reference and Pinocchio agree",
                   "undecided": "one side agrees with both others, which disagree"}.get(
                a["off"], f"{a['off']} is off: the other two agree")
            lines.append(f"{case}: {quantity}: {who} ({pairs} ε·cond(M); limit {LIMIT:g})")
        if not off:
            agreeing.append(case)
            worst = max(worst, *(max(a["pairs"].values()) for a in agreements.values()))
    if agreeing:
        lines.insert(0, f"second opinions: MuJoCo, the tree reference and Pinocchio agree on M, bias forces, "
                        f"qacc and inverse dynamics in {len(agreeing)} of {len(ran)} case(s), at {STATES} states "
                        f"each (largest deviation {worst:.2g} ε·cond(M); limit {LIMIT:g})")
    return lines
