"""MuJoCo-side angular momentum, from MuJoCo's own state (never via analytic coordinates).

The conserved momentum of a cyclic azimuth (``p_phi`` of the spherical
pendulum) is the component along the symmetry axis of the angular momentum
about a fixed point o of the subtree rooted at a body:

    L_o = Σ_b  L_c,b + (c − o) × P_b

over the subtree's bodies b, with (L_c,b, P_b) = cinert_b · cvel_b the body's
spatial momentum in MuJoCo's com-based frame (angular momentum about the point
c = ``subtree_com`` of b's root, and linear momentum; the product is
``mju_mulInertVec``'s, written out here over a whole run). ``cinert`` holds the
body's inertia about c (its own spin included), so this is the quantity
MuJoCo's dynamics conserves when gravity is along the axis; it is what
``mj_subtreeVel`` assembles (pinned against it in
tests/test_spherical_pendulum.py and tests/test_hoop_plane.py). The native recorder computes L_o in C
with the same operations as it steps (:attr:`harness.engine.readings.Reading.about`), checked at one sample
of every run against :func:`about_at`, this module's arithmetic on floats.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from harness.engine.readings import Reading

__all__ = ["MOMENTUM_FIELDS", "about_at", "about_key", "axial_angular_momentum", "subtree", "total_momentum"]


def subtree(model: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and every body below it."""
    inside = [body]
    for b in range(body + 1, model.nbody):  # parents precede children in MuJoCo's body order
        if int(model.body_parentid[b]) in inside:
            inside.append(b)
    return inside


# The arithmetic below is written componentwise, so that one formula serves a whole run (each component a row of
# samples, numpy) and one sample (each a float: the same IEEE operations, so the same numbers bit for bit).
Components = tuple  # three rows (N,) of samples, or three floats


def _cross(a: Sequence | np.ndarray, b: Sequence | np.ndarray) -> Components:
    """a × b, componentwise."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _spatial_momentum(inert: Sequence | np.ndarray, vel: Sequence | np.ndarray) -> tuple[Components, Components]:
    """mju_mulInertVec, componentwise: (angular momentum about the com-frame origin, linear momentum), from
    cinert's 10 components and cvel's 6."""
    i, v = inert, vel
    angular = (i[0] * v[0] + i[3] * v[1] + i[4] * v[2] - i[8] * v[4] + i[7] * v[5],
               i[3] * v[0] + i[1] * v[1] + i[5] * v[2] + i[8] * v[3] - i[6] * v[5],
               i[4] * v[0] + i[5] * v[1] + i[2] * v[2] - i[7] * v[3] + i[6] * v[4])
    linear = (i[8] * v[1] - i[7] * v[2] + i[9] * v[3],
              i[6] * v[2] - i[8] * v[0] + i[9] * v[4],
              i[7] * v[0] - i[6] * v[1] + i[9] * v[5])
    return angular, linear


def _body_about(inert: Sequence | np.ndarray, vel: Sequence | np.ndarray, lever: Sequence | np.ndarray) -> Components:
    """A body's angular momentum about a point, componentwise: its own about the com-frame origin plus
    lever × its linear momentum, ``lever`` from the point to the com-frame origin."""
    angular, linear = _spatial_momentum(inert, vel)
    return tuple(a + c for a, c in zip(angular, _cross(lever, linear), strict=True))


def axial_angular_momentum(*, body: str, site: str, axis: Sequence[float] = (0.0, 0.0, 1.0),
                           frame: str | None = None) -> Reading:
    """A reading of axis · L about ``site`` of the subtree rooted at ``body`` (kg m²/s).

    ``axis`` is a world direction (normalised here), or, with ``frame``, a direction fixed in the body
    of that name, turned with it (its ``xmat`` at each sample): a symmetric top's p_ψ is its angular
    momentum about the pivot along its own symmetry axis.
    """
    unit = np.asarray(axis, dtype=float)
    if unit.shape != (3,) or not np.linalg.norm(unit) > 0:
        raise ValueError(f"axis must be a non-zero 3-vector, got {axis!r}")
    unit = unit / np.linalg.norm(unit)

    def evaluate(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
        total = _about(model, rec, body, site)
        if frame is None:
            return unit @ total
        turned = np.asarray(rec["xmat"][:, model.body(frame).id]).reshape(-1, 3, 3) @ unit  # (N, 3) world
        return np.einsum("kn,nk->n", total, turned)

    where = "" if frame is None else f" fixed in body {frame!r}"
    fields = (*MOMENTUM_FIELDS, *(() if frame is None else ("xmat",)))
    return Reading(fields=fields, evaluate=evaluate,
                   description=f"axis {unit.tolist()}{where} · angular momentum of subtree {body!r} about site "
                               f"{site!r} (kg m²/s)", about=(body, site))


# the fields L_o is made of: a reading whose momentum the recorder hands it reads them through it alone
MOMENTUM_FIELDS: tuple[str, ...] = ("site_xpos", "cinert", "cvel", "subtree_com")


def about_key(body: str, site: str) -> str:
    """Where a record may hold L_o (3, N) of the subtree rooted at ``body`` about ``site``, computed by the
    recorder (the native one computes it in C with :func:`_about`'s arithmetic, checked at one sample of every
    run against this module's)."""
    return f"angular momentum of {body} about {site}"


# the last run's angular momenta by (model, body, site): a run's readings of one subtree about one site (p_phi, L_x,
# L_y of a free body) share them. The run's record is held, so its identity is not reused while it is kept.
_memo = threading.local()


def about_at(model: mujoco.MjModel, data: mujoco.MjData, body: str, site: str) -> np.ndarray:
    """L_o (3,) of the subtree rooted at ``body`` about ``site`` at ``data``'s state (after mj_forward): the
    reading's arithmetic on one sample, in floats, bit for bit what it computes over a run."""
    origin = data.site_xpos[model.site(site).id].tolist()
    total = [0.0, 0.0, 0.0]
    for b in subtree(model, model.body(body).id):
        lever = [c - o for c, o in zip(data.subtree_com[model.body_rootid[b]].tolist(), origin, strict=True)]
        total = [t + x for t, x in zip(total, _body_about(data.cinert[b].tolist(), data.cvel[b].tolist(), lever),
                                       strict=True)]
    return np.array(total)


def _about(model: mujoco.MjModel, rec: Mapping[str, np.ndarray], body: str, site: str) -> np.ndarray:
    """L_o (3, N) of the subtree rooted at ``body`` about ``site`` over the run ``rec``, computed once per run
    (the recorder's, where it gave it: :func:`about_key`)."""
    kept: tuple[Mapping[str, np.ndarray], dict[tuple, tuple[mujoco.MjModel, np.ndarray]]] | None = \
        getattr(_memo, "run", None)
    if kept is None or kept[0] is not rec:
        kept = _memo.run = (rec, {})
    key = (id(model), body, site)
    if key not in kept[1]:
        total = rec.get(about_key(body, site))
        if total is None:
            rows = np.ascontiguousarray  # (3, N) rows of contiguous samples: fast elementwise operations
            origin = rows(rec["site_xpos"][:, model.site(site).id].T)
            total = np.zeros((3, origin.shape[1]))
            for b in subtree(model, model.body(body).id):
                lever = rows(rec["subtree_com"][:, model.body_rootid[b]].T) - origin
                total += np.stack(_body_about(rows(rec["cinert"][:, b].T), rows(rec["cvel"][:, b].T), lever))
        kept[1][key] = (model, total)  # the model held too: its id is not reused meanwhile
    return kept[1][key][1]


def _total(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every body's momentum summed: (linear, angular about the world origin), each (3, N)."""
    n = len(recorded["time"])
    linear, angular = np.zeros((3, n)), np.zeros((3, n))
    for b in range(1, model.nbody):
        spin, push = _spatial_momentum(recorded["cinert"][:, b].T, recorded["cvel"][:, b].T)
        c = recorded["subtree_com"][:, int(model.body_rootid[b])].T
        linear += np.stack(push)
        angular += np.stack(spin) + np.stack(_cross(c, push))
    return linear, angular


def _component(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray], *, which: int, k: int) -> np.ndarray:
    return _total(model, recorded)[which][k]


def total_momentum() -> dict[str, Reading]:
    """Readings of the whole model's linear momentum (``p_lin_x`` …, kg m/s) and angular momentum about the world
    origin (``p_ang_x`` …, kg m²/s), conserved by a free-floating tree without gravity: the names the tree
    reference gives the same quantities (:meth:`analytic.tree.TreeDynamics.extra_invariants`)."""
    fields = ("cinert", "cvel", "subtree_com")
    out = {}
    for k, axis in enumerate("xyz"):
        out[f"p_lin_{axis}"] = Reading(fields=fields, evaluate=functools.partial(_component, which=0, k=k),
                                       description=f"the model's linear momentum along world {axis} (kg m/s)")
        out[f"p_ang_{axis}"] = Reading(fields=fields, evaluate=functools.partial(_component, which=1, k=k),
                                       description=f"the model's angular momentum about the world origin, {axis} "
                                                   "(kg m²/s)")
    return out
