"""MuJoCo-side readings: quantities the harness computes from MuJoCo's recorded fields.

A reading (an angular momentum, a contact force, a slip velocity) is a
function of fixed-size ``MjData`` fields — the ones it names in ``fields`` —
and of the state (``qpos``, ``qvel``, ``time``, always available), evaluated
over a whole run at once: arrays with a leading axis of one row per sample.
The recorders (:mod:`harness.engine.recording`) record those fields in C at every step
with the rest of the run, so a reading costs a few numpy operations per run
rather than an ``mj_forward`` and a Python call per sample; both recorders
hand a reading the same arrays, so they give the same numbers bit for bit.

``reading(model, data)`` evaluates it on one state, from an ``MjData`` after
``mj_forward`` (the seed audit, the tests).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["Reading", "fields_of"]

# Always available to a reading, from the integration state: (N,), (N, nq), (N, nv).
STATE_FIELDS: tuple[str, ...] = ("time", "qpos", "qvel")

Evaluate = Callable[[mujoco.MjModel, Mapping[str, np.ndarray]], np.ndarray]


@dataclass(frozen=True)
class Reading:
    """A quantity computed from recorded MuJoCo fields, vectorized over samples.

    Attributes:
        fields: ``MjData`` fields it needs besides ``time``, ``qpos``, ``qvel``
            (fixed-size ones: the batch recorder records them at every step).
        evaluate: ``(model, recorded) -> (N,)``, where ``recorded[f]`` has a
            leading axis of N samples, each the field after ``mj_forward``
            at that sample's state.
        description: one line, with the unit.
        about: for a projection of a subtree's angular momentum, (the subtree's root body, the site it is
            taken about): the native recorder computes that momentum in C as it steps and hands it in the
            record (:func:`harness.engine.readings.momentum.about_key`), so that it is not recomputed in numpy;
            the reading then reads the fields the momentum is made of
            (:data:`~harness.engine.readings.momentum.MOMENTUM_FIELDS`) only through it.
    """

    fields: tuple[str, ...]
    evaluate: Evaluate
    description: str
    about: tuple[str, str] | None = None

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> float:
        """The reading at ``data``'s state (``mj_forward`` must have run)."""
        return float(self.evaluate(model, recorded_at(data, self.fields))[0])


def recorded_at(data: mujoco.MjData, fields: tuple[str, ...]) -> dict[str, np.ndarray]:
    """``fields`` and the state of ``data`` as a one-sample record (leading axis of length 1)."""
    names = dict.fromkeys((*STATE_FIELDS, *fields))
    return {f: np.array(getattr(data, f), dtype=float)[None] for f in names}


def fields_of(readings: Mapping[str, Reading]) -> tuple[str, ...]:
    """Every field the readings need besides the state, each once, in first-use order."""
    return tuple(dict.fromkeys(f for r in readings.values() for f in r.fields if f not in STATE_FIELDS))
