"""Judge figures against limits: pass/fail per check, with the figure beside its limit."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping

from harness.core.checks import Check
from harness.core.errors import ConfigError
from harness.core.figures import Figure, FigureName
from harness.engine.compat import known_defect, unavailable_reason
from harness.pipeline.run import CaseResult


def verdict(case: str, figures: Iterable[Figure], thresholds: Mapping[str, float], *,
            joints: frozenset[int] = frozenset(), diverged: Mapping[str, str] | None = None) -> list[Check]:
    """One Check per limit; a limit naming no measured figure is a config error, unless it belongs to
    an integrator this MuJoCo lacks (harness.engine.compat), which gives an n/a Check, or to a run that
    diverged (``diverged``: reason by run, :func:`diverged_run`), which gives a failed Check with the reason.
    ``joints``, the joint types of the model run, decide which documented defects of this MuJoCo apply."""
    by_name = {f.name: f for f in figures}
    why_diverged = {n: why for n in thresholds if n not in by_name and (why := diverged_run(n, diverged or {}))}
    missing = {n: unavailable_reason(n) for n in set(thresholds) - set(by_name) - set(why_diverged)}
    unknown = sorted(n for n, why in missing.items() if not why)
    if unknown:
        raise ConfigError(f"thresholds for case {case!r} name unmeasured figure(s) {unknown}; "
                          f"measured: {', '.join(sorted(by_name))}")
    checks = [Check(case, name, math.nan, limit, "", diverged=why_diverged[name]) if name in why_diverged
              else Check(case, name, math.nan, limit, "", note=missing[name]) if name in missing
              else Check(case, name, by_name[name].value, limit, by_name[name].unit)
              for name, limit in thresholds.items()]
    return [dataclasses.replace(c, known=why) if not c.passed and not c.diverged
            and (why := known_defect(joints, c.name)) else c for c in checks]


def diverged_run(name: str, diverged: Mapping[str, str]) -> str:
    """Why the figure ``name`` was not measured where the run it comes from diverged ('' otherwise): its
    integrator's run over the horizon (key ``INTEGRATOR``) or, for an order, that run or its ladder's
    (``converge.INTEGRATOR``)."""
    figure = FigureName(name)
    if figure.layer == "trajectory":
        return diverged.get(figure.integrator, "")
    if figure.layer == "converge":
        return diverged.get(figure.integrator, "") or diverged.get(f"converge.{figure.integrator}", "")
    return ""


def judge(result: CaseResult, thresholds: Mapping[str, float]) -> list[Check]:
    """:func:`verdict` of one case's result, with the joint types of the model it ran and its diverged runs."""
    return verdict(result.case.name, result.figures, thresholds, joints=result.joints, diverged=result.diverged)
