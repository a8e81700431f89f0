"""What the recorders reuse from run to run: MjData and the arrays a run is recorded into.

Why: a study or a budget records many short runs of models of one layout (compiled from one MJCF with other
options), and making their working space costs a share of a short rollout worth keeping (docs/findings/speed.md):
an MjData, and fresh recording arrays of a few MB, a page fault per 4 KiB when first written. So
each is kept, a few per layout, for the next run. Nothing leaks: every run sets the whole integration state it
starts from, and a Trajectory keeps copies, never these arrays.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

__all__ = ["SPARE", "STATE", "Record", "give_back_data", "keep", "take_data"]

STATE = mujoco.mjtState.mjSTATE_INTEGRATION  # what a recorded state row holds

SPARE = 4  # MjData (and recording arrays) kept for reuse, by model layout

_spare_data: dict[tuple[int, int, int, bool], mujoco.MjData] = {}


def layout(model: mujoco.MjModel) -> tuple[int, int, int] | None:
    """What MjData and scratch arrays of ``model`` share with another model's; None where MuJoCo gives
    no model signature (3.3, whose runs reuse nothing)."""
    signature = getattr(model, "signature", None)
    return None if signature is None else (int(signature), int(model.narena), int(model.nbuffer))


def keep(pool: dict, key: object, value: object, limit: int) -> None:
    """Put ``value`` in ``pool`` for the next run, dropping the oldest entries beyond ``limit``."""
    while len(pool) >= limit:
        pool.pop(next(iter(pool)))
    pool[key] = value


def take_data(model: mujoco.MjModel, *, spare: bool = False) -> mujoco.MjData:
    """A reset MjData for ``model``, reused from an earlier run of a model of the same layout (same
    signature and arena) where one was given back; ``spare``: a second one, for a helper thread."""
    shape = layout(model)
    data = None if shape is None else _spare_data.pop((*shape, spare), None)
    if data is None:
        return mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    return data


def give_back_data(model: mujoco.MjModel, data: mujoco.MjData, *, spare: bool = False) -> None:
    shape = layout(model)
    if shape is not None:
        keep(_spare_data, (*shape, spare), data, SPARE)


@dataclass
class Record:
    """Where a run in C is recorded: the integration states and ``fields``, one row per sample.

    Scratch space, reused by the next run of the same layout, length and fields: everything a
    Trajectory keeps is copied out of it."""

    states: np.ndarray                # (steps + 1, nstate)
    fields: dict[str, np.ndarray]     # (steps + 1, ...) per field, MjData's dtype
    kept: dict = field(default_factory=dict)  # what a recorder worked out for these arrays, by recorder

    @classmethod
    def take(cls, model: mujoco.MjModel, data: mujoco.MjData, steps: int, fields: Sequence[str]) -> Record:
        known = layout(model)
        spare = None if known is None else _spare_records.pop((*known, steps, tuple(fields)), None)
        if spare is not None:
            return spare
        nstate = mujoco.mj_stateSize(model, STATE)
        # MjData's types: an int field (nefc, nisland) is a C int, as the batch records it
        shapes = {f: (np.shape(getattr(data, f)), np.int32 if isinstance(getattr(data, f), int)
                      else np.asarray(getattr(data, f)).dtype) for f in fields}
        return cls(states=np.empty((steps + 1, nstate)),
                   fields={f: np.empty((steps + 1, *shape), dtype) for f, (shape, dtype) in shapes.items()})

    def give_back(self, model: mujoco.MjModel) -> None:
        shape = layout(model)
        if shape is not None:
            keep(_spare_records, (*shape, len(self.states) - 1, tuple(self.fields)), self, SPARE)


_spare_records: dict[tuple, Record] = {}
