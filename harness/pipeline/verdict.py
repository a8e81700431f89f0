"""Judge figures against limits: pass/fail per check, with the figure beside its limit."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping

from harness.core.checks import Check
from harness.core.errors import ConfigError
from harness.core.figures import Figure
from harness.engine.compat import known_defect, unavailable_reason
from harness.pipeline.run import CaseResult


def verdict(case: str, figures: Iterable[Figure], thresholds: Mapping[str, float], *,
            joints: frozenset[int] = frozenset()) -> list[Check]:
    """One Check per limit; a limit naming no measured figure is a config error, unless it belongs to
    an integrator this MuJoCo lacks (harness.engine.compat), which gives an n/a Check. ``joints``, the
    joint types of the model run, decide which documented defects of this MuJoCo apply."""
    by_name = {f.name: f for f in figures}
    missing = {n: unavailable_reason(n) for n in set(thresholds) - set(by_name)}
    unknown = sorted(n for n, why in missing.items() if not why)
    if unknown:
        raise ConfigError(f"thresholds for case {case!r} name unmeasured figure(s) {unknown}; "
                          f"measured: {', '.join(sorted(by_name))}")
    checks = [Check(case, name, math.nan, limit, "", note=missing[name]) if name in missing
              else Check(case, name, by_name[name].value, limit, by_name[name].unit)
              for name, limit in thresholds.items()]
    return [dataclasses.replace(c, known=why) if not c.passed and (why := known_defect(joints, c.name)) else c
            for c in checks]


def judge(result: CaseResult, thresholds: Mapping[str, float]) -> list[Check]:
    """:func:`verdict` of one case's result, with the joint types of the model it ran."""
    return verdict(result.case.name, result.figures, thresholds, joints=result.joints)
