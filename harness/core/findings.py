"""A Finding: an engine function that disagrees with what it should compute, found while measuring.

Where the harness corrects or works around an engine function to take its
own measurement (``mj_jacDot`` on MuJoCo 3.3.0, :mod:`harness.engine.compat`),
the correction is not hidden: the run reports that the engine's function
disagrees, and by how much, beside the checks.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Finding"]


@dataclass(frozen=True)
class Finding:
    """An engine function's disagreement.

    Attributes:
        function: the engine function (``mj_jacDot``).
        value: the size of the disagreement, in ``unit``, on the quantity ``measure`` names.
        unit: the unit of ``value``.
        measure: what ``value`` measures.
        detail: the defect and its upstream source (a changelog entry).
    """

    function: str
    value: float
    unit: str
    measure: str
    detail: str

    def as_dict(self) -> dict[str, object]:
        return {"function": self.function, "value": self.value, "unit": self.unit, "measure": self.measure,
                "detail": self.detail}

    def describe(self) -> str:
        return f"{self.function} disagrees: {self.measure} {self.value:.3g} {self.unit} ({self.detail})"
