"""Judge a case's figures: each gated figure by its error budget or its fixed limit, and a failure
matched, narrowly, against the documented defects of this MuJoCo.

A failure counts as a known defect only when the figure shows the defect's
signature, so that a new regression in the same figures is not absorbed:

- the defect applies (this MuJoCo predates its fix, the integrator and a joint
  type of the model are the ones it affects: :func:`harness.engine.compat.applicable_defect`);
- the integrator's observed convergence order (the converge layer's fit) is the
  order the defect degrades it to, within the order tolerance;
- for a trajectory figure, the budget computed at that order explains it: the
  size the degraded order predicts is the size measured.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from harness.core.checks import Check
from harness.core.errors import ConfigError
from harness.core.figures import Figure, FigureName
from harness.engine.compat import applicable_defect, unavailable_reason
from harness.engine.integrators import DOCUMENTED_INTEGRATORS
from harness.families.convergence import ORDER_TOLERANCE
from harness.pipeline.limits import Limit
from harness.pipeline.run import CaseResult

__all__ = ["judge"]


def defect_signature(result: CaseResult, name: FigureName) -> str:
    """The known defect a failed figure of ``result`` shows the signature of, with the evidence, or ''."""
    defect = applicable_defect(result.joints, name.integrator) if name.integrator else None
    if defect is None:
        return ""
    observed = result.orders.get(name.integrator, math.nan)
    if not abs(observed - defect.order) <= ORDER_TOLERANCE:
        return ""
    evidence = f"observed order {observed:.2f}"
    if name.layer == "trajectory":
        at_order = result.defect_budgets.get(name)
        if at_order is None or not at_order.passed:
            return ""
        evidence += (f", and at order {defect.order:g} the budget explains the figure (unexplained "
                     f"{at_order.unexplained:.2g} ≤ {at_order.limit:.2g})")
    return f"{defect.reason}; {evidence}"


def judge(result: CaseResult, limits: Mapping[str, Limit]) -> list[Check]:
    """One Check per limit of ``result``'s case.

    A ``budget`` limit judges the figure's unexplained residual against the limit its budget computes;
    a ``theory`` or ``user`` limit the figure itself against its value. Every figure of an integrator run beyond
    its stability limit at the model's step (:mod:`harness.families.stability`, from the reference's
    linearization, not the engine's) is n/a with that statement: the method's limit, not MuJoCo's defect; a run
    that diverges inside the limit stays a failure. A limit naming no measured
    figure is a config error, unless it belongs to an integrator this MuJoCo lacks (n/a) or one the run
    left out (not judged).
    """
    case = result.case.name
    by_name: dict[str, Figure] = {f.name: f for f in result.figures}
    ran = set(result.settings.integrators)
    checks = []
    unknown = []
    beyond = {k: s.statement() for k, s in result.stability.items() if s.beyond}
    for name, limit in limits.items():
        figure_name = FigureName(name)
        if figure_name.integrator in beyond:  # the method's limit, not MuJoCo's defect: n/a, never pass or fail
            figure = by_name.get(name)
            why = beyond[figure_name.integrator]
            if ran_away := diverged_run(name, result.diverged):
                why += f"; its run {ran_away}"
            checks.append(Check(case, figure_name, figure.value if figure else math.nan, math.nan,
                                figure.unit if figure else "", note=why))
            continue
        if name not in by_name:
            why_diverged = diverged_run(name, result.diverged)
            if why_diverged:
                checks.append(Check(case, figure_name, math.nan, math.nan, "", diverged=why_diverged))
                continue
            why = unavailable_reason(name) or result.unmeasured.get(name, "")
            if why:
                checks.append(Check(case, figure_name, math.nan, math.nan, "", note=why))
            elif figure_name.integrator in DOCUMENTED_INTEGRATORS and figure_name.integrator not in ran:
                continue  # an integrator this run was asked to leave out (any other name is unknown: an error)
            else:
                unknown.append(name)
            continue
        figure = by_name[name]
        if limit.basis == "budget":
            budget = result.budgets.get(name)
            if budget is None:
                why = result.diverged.get(f"budget.{figure_name.integrator}", "") or "no budget was computed"
                checks.append(Check(case, figure_name, figure.value, math.nan, figure.unit, diverged=why))
                continue
            check = Check(case, figure_name, figure.value, budget.limit, figure.unit, budget=budget)
        else:
            assert limit.value is not None  # a theory's or a user's limit has its value (Limit checks)
            check = Check(case, figure_name, figure.value, float(limit.value), figure.unit)
        if not check.passed and (known := defect_signature(result, figure_name)):
            check = Check(case, figure_name, check.value, check.threshold, check.unit, known=known,
                          budget=check.budget)
        checks.append(check)
    if unknown:
        raise ConfigError(f"limits for case {case!r} name unmeasured figure(s) {sorted(unknown)}; "
                          f"measured: {', '.join(sorted(by_name))}")
    return checks


def diverged_run(name: str, diverged: Mapping[str, str]) -> str:
    """Why the figure ``name`` was not measured where the run it comes from diverged ('' otherwise): its
    integrator's run over the horizon (key ``INTEGRATOR``) or a run of the figure's own (the balance's, by its
    name) or, for an order, that run or its ladder's (``converge.INTEGRATOR``); an instantaneous figure the model
    made unmeasurable, by its own name."""
    figure = FigureName(name)
    if figure.layer == "trajectory":  # its integrator's run, or a run of its own (the balance's model as it is)
        return diverged.get(figure.integrator, "") or diverged.get(name, "")
    if figure.layer == "converge":
        return diverged.get(figure.integrator, "") or diverged.get(f"converge.{figure.integrator}", "")
    return diverged.get(name, "")
