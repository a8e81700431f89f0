"""A Figure is one named, dimensioned number the harness measures and may gate.

Figure names are typed (:class:`FigureName`): every module builds them with
its constructors and reads their parts through its attributes; nothing else
splits a name on dots. The text form, which config files, limits, reports and
baselines use, is

==========  ===================================  ===========================
layer       text                                 example
==========  ===================================  ===========================
instant     ``instant.QUANTITY[.DETAIL]``        ``instant.force.rod``
reference   ``reference.QUANTITY[.DETAIL]``      ``reference.ode_vs_dae``
trajectory  ``INTEGRATOR.QUANTITY[.DETAIL]``     ``RK4.drift.energy``
converge    ``converge.INTEGRATOR.QUANTITY``     ``converge.RK4.order_shortfall``
==========  ===================================  ===========================

A DETAIL names a constraint, an invariant or a series (``rod``, ``energy``,
``slip``), so no part may contain a dot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["Figure", "FigureName", "max_abs"]

Layer = Literal["instant", "reference", "trajectory", "converge"]
_PREFIXED = ("instant", "reference")  # layers whose text starts with the layer's own name


class FigureName(str):
    """A figure's name: the text itself (so it is a dict key, a JSON string, a config key) with its
    parts parsed once: :attr:`layer`, :attr:`integrator` ('' outside the trajectory and converge
    layers), :attr:`quantity` and :attr:`detail` ('' when absent).

    ``FigureName("RK4.force.rod")`` parses (ValueError for a malformed name); the constructors
    :meth:`instant`, :meth:`reference`, :meth:`trajectory` and :meth:`converge` build one from parts.
    """

    layer: Layer
    integrator: str
    quantity: str
    detail: str

    def __new__(cls, text: str) -> FigureName:
        if isinstance(text, FigureName):
            return text
        parts = str(text).split(".")
        if any(not p for p in parts) or not 2 <= len(parts) <= 3:
            raise ValueError(f"malformed figure name {text!r}; accepted: LAYER.QUANTITY[.DETAIL] "
                             "(instant, reference), INTEGRATOR.QUANTITY[.DETAIL] or "
                             "converge.INTEGRATOR.QUANTITY")
        self = super().__new__(cls, text)
        if parts[0] == "converge":
            if len(parts) != 3:
                raise ValueError(f"malformed figure name {text!r}; accepted: converge.INTEGRATOR.QUANTITY")
            self.layer, self.integrator, self.quantity, self.detail = "converge", parts[1], parts[2], ""
        elif parts[0] in _PREFIXED:
            self.layer, self.integrator = parts[0], ""  # type: ignore[assignment]
            self.quantity, self.detail = parts[1], parts[2] if len(parts) == 3 else ""
        else:
            self.layer, self.integrator = "trajectory", parts[0]
            self.quantity, self.detail = parts[1], parts[2] if len(parts) == 3 else ""
        return self

    def __reduce__(self):  # pickled as its text (workers send figures back to the parent)
        return (FigureName, (str(self),))

    @classmethod
    def _of(cls, *parts: str) -> FigureName:
        for p in parts:
            if p and "." in p:
                raise ValueError(f"a figure name part may not contain a dot, got {p!r}")
        return cls(".".join(p for p in parts if p))

    @classmethod
    def instant(cls, quantity: str, detail: str = "") -> FigureName:
        """Layer 2, at sampled states: ``instant.QUANTITY[.DETAIL]``."""
        return cls._of("instant", quantity, detail)

    @classmethod
    def reference(cls, quantity: str, detail: str = "") -> FigureName:
        """The reference's own quality: ``reference.QUANTITY[.DETAIL]``."""
        return cls._of("reference", quantity, detail)

    @classmethod
    def trajectory(cls, integrator: str, quantity: str, detail: str = "") -> FigureName:
        """Layer 3, a run of one integrator against the reference: ``INTEGRATOR.QUANTITY[.DETAIL]``."""
        if integrator in (*_PREFIXED, "converge"):
            raise ValueError(f"{integrator!r} is a layer, not an integrator")
        return cls._of(integrator, quantity, detail)

    @classmethod
    def converge(cls, integrator: str, quantity: str) -> FigureName:
        """Layer 4, an integrator's convergence: ``converge.INTEGRATOR.QUANTITY``."""
        return cls._of("converge", integrator, quantity)

    @property
    def measure(self) -> str:
        """``QUANTITY[.DETAIL]``: what the figure measures, whichever integrator (``drift.energy``,
        ``force.rod``)."""
        return f"{self.quantity}.{self.detail}" if self.detail else self.quantity

    @property
    def group(self) -> str:
        """What a report groups the figure under: its integrator in the trajectory layer, else its layer."""
        return self.integrator if self.layer == "trajectory" else self.layer


@dataclass(frozen=True)
class Figure:
    """A measured value: ``name`` (see :class:`FigureName`), its ``unit`` and what it measures."""

    name: FigureName
    value: float
    unit: str
    description: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", FigureName(self.name))

    def as_dict(self) -> dict[str, object]:
        return {"value": self.value, "unit": self.unit, "description": self.description}


def max_abs(values) -> float:
    """max |values| over every entry (0 for an empty array)."""
    arr = np.asarray(values, dtype=float)
    return float(np.max(np.abs(arr))) if arr.size else 0.0
