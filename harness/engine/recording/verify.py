"""Whether a recorded run can be trusted: MuJoCo's warnings, and the check against a fresh ``mj_forward``.

MuJoCo's warnings: ``mj_step`` checks the state around its forward (``mj_checkPos/Vel/Acc``: a huge or
non-finite value is a warning, and the data is reset); every recorder makes the same checks and turns a
warning into SimulationDiverged at the time of the state that raised it (:func:`check_warnings`).

The check: the recorders in C shift or recompute what MuJoCo computed and make the rest themselves (in
numpy, or as the native recorder steps), which holds only while their arithmetic is MuJoCo's and the
readings'. So every native or batch run is compared with a
fresh ``mj_forward`` at one sample mid-run, bit for bit (:func:`differences`); where only the
equalities recovered from recorded fields differ, they are read per state instead, and any other
mismatch (another MuJoCo's arithmetic) hands the whole run to the loop. Each fallback is noted in
:data:`FALLBACKS` (``harness.engine.recording.notes()``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from harness.core.errors import SimulationDiverged
from harness.engine.integrators import integrator_name
from harness.engine.probe import Probe
from harness.engine.readings.momentum import about_at
from harness.engine.recording.assemble import Run, evaluate_readings, plan, source_velocity
from harness.engine.recording.equalities import block, read_equalities, rows, signed
from harness.engine.recording.scratch import STATE, Record

__all__ = ["FALLBACKS", "check_warnings", "checked_forward", "checked_run"]

# every time this process's native or batch recorder fell back to reading per sample or to the loop, and why
FALLBACKS: list[str] = []


def check_warnings(counts: np.ndarray, at: float) -> None:
    """SimulationDiverged at time ``at`` naming every MuJoCo warning whose count in ``counts`` is above zero."""
    raised = [mujoco.mjtWarning(i).name for i in range(len(counts)) if counts[i] > 0]
    if raised:
        raise SimulationDiverged(", ".join(raised), at)


def checked_forward(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """mj_forward between the checks mj_step makes around it: a huge or non-finite qpos, qvel or
    qacc raises a MuJoCo warning (and resets the data), which the caller turns into SimulationDiverged."""
    mujoco.mj_checkPos(model, data)
    mujoco.mj_checkVel(model, data)
    mujoco.mj_forward(model, data)
    mujoco.mj_checkAcc(model, data)


def differences(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe, run: Run,
                momenta: Mapping[tuple[str, str], np.ndarray] | None = None) -> list[str]:
    """What differs from a fresh mj_forward at one sample mid-run (a shifted or, for RK4, a recomputed
    record), bit for bit: every recorded field (energy and qfrc_constraint are copies or sums of them), the
    points' positions and velocities, the recovered equalities and the subtree momenta ``momenta`` the
    recorder computed (against numpy's arithmetic on that forward); empty when nothing does."""
    k = len(run.states) // 2
    mujoco.mj_setState(model, data, run.states[k], STATE)
    mujoco.mj_forward(model, data)
    # (what, fresh, recorded) for everything checked
    pairs = [(f"field {f!r}", getattr(data, f), values[k]) for f, values in run.fields.items()]
    for p, source in zip(probe.points, plan(model, probe).sources, strict=True):
        pairs += [(f"position of {p!r}", source.position(data), run.positions[p][k]),
                  (f"velocity of {p!r}", source_velocity(model, data, source), run.velocities[p][k])]
    pairs += [(f"angular momentum of {body!r} about {site!r}", about_at(model, data, body, site), total[:, k])
              for (body, site), total in (momenta or {}).items()]
    for c in probe.constraints:
        force, pos = block(model, data, c, probe.sign(c))
        pairs += [(f"equality {c!r}", force, run.lam[c][k]), (f"equality {c!r}", pos, run.viol[c][k])]
    if _all_equal(pairs):
        return []
    return list(dict.fromkeys(what for what, fresh, recorded in pairs if not np.array_equal(fresh, recorded)))


def _all_equal(pairs: Sequence[tuple[str, object, object]]) -> bool:
    """Whether both arrays of every pair are equal, as np.array_equal says (same shape, equal elements: NaN
    differs), all pairs taken at once: one comparison per run rather than one per array."""
    fresh, recorded = [np.asarray(p[1]) for p in pairs], [np.asarray(p[2]) for p in pairs]
    if any(a.shape != b.shape for a, b in zip(fresh, recorded, strict=True)):
        return False
    return bool((np.concatenate([a.ravel() for a in fresh]) == np.concatenate([b.ravel() for b in recorded])).all())


def checked_run(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, rec: Record, lam: dict[str, np.ndarray],
                viol: dict[str, np.ndarray], timings: dict[str, float],
                velocities: dict[str, np.ndarray] | None = None,
                momenta: dict[tuple[str, str], np.ndarray] | None = None,
                positions: dict[str, np.ndarray] | None = None) -> Run | None:
    """A run recorded in C, assembled, its readings evaluated and checked against a fresh mj_forward (both
    recorders in C); ``lam``/``viol``: the equalities already read per state, signed; ``velocities``: the
    points' (else assembled from the recorded fields), and ``positions`` (else copied from them); ``momenta``: the
    subtree momenta the readings project, by (body, site), where the recorder computed them. None where the
    check sends the run back to the loop."""
    states, fields = rec.states, rec.fields
    # a sum is finite only if every term is (MuJoCo's own checks would have warned long before an
    # overflow); the row-by-row look, only to say where
    if not np.isfinite(states.sum()):
        finite = np.isfinite(states).all(axis=1)
        if not finite.all():
            raise SimulationDiverged("non-finite state", float(states[np.argmin(finite), 0]))
    run = Run.from_record(model, probe, states, fields, velocities, positions)
    run.lam |= lam
    run.viol |= viol
    clock = time.perf_counter()
    run.readings = evaluate_readings(model, probe, run.t, states[:, 1:1 + model.nq],
                                     states[:, 1 + model.nq:1 + model.nq + model.nv], fields, momenta)
    timings["readings"] = time.perf_counter() - clock
    recovered = list(run.lam)
    _read_at_states(model, data, probe, run, [c for c in probe.constraints if c not in run.lam])
    bad = differences(model, data, probe, run, momenta)
    wrong = [c for c in recovered if f"equality {c!r}" in bad]
    if wrong and len(wrong) == len(bad):  # only the recovered equalities: read them per sample instead
        FALLBACKS.append(f"{_label(model)}: efc_force/efc_pos recovered from qfrc_constraint and qpos differed "
                         f"from a fresh mj_forward for {wrong}; read per sample instead")
        _read_at_states(model, data, probe, run, wrong)
        bad = differences(model, data, probe, run, momenta)
    if bad:
        FALLBACKS.append(f"{_label(model)}: the batch recorder's {', '.join(bad)} differed from a fresh "
                         "mj_forward; recorded with the loop instead")
        return None
    return run


def _read_at_states(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe, run: Run,
                    equalities: Sequence[str]) -> None:
    """The equalities ``equalities`` after mj_forward at every recorded state, as the loop recorder
    reads them."""
    if not equalities:
        return
    n = len(run.states)
    lam = {c: rows(model, c, n) for c in equalities}
    viol = {c: rows(model, c, n) for c in equalities}
    read_equalities(model, data, run.states, lam, viol)
    for c in equalities:
        run.lam[c], run.viol[c] = signed(probe.sign(c), lam[c], viol[c])


def _label(model: mujoco.MjModel) -> str:
    return f"{integrator_name(model)} at h = {model.opt.timestep:g} s"
