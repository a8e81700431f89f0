"""The figure names a case can have, known without running it: what a config naming a case that is not run
is checked against.

A case that runs is judged against the figures it measured (:mod:`harness.pipeline.verdict`: a limit
naming an unmeasured figure is a config error). A case a config names but the command does not run
measured nothing, and a typo there ("RK4.positon") passed silently; it is checked here against every
name the layers can give that case: the instant, reference and convergence figures, and per documented
integrator the trajectory figures of its points, its invariants (energy and the case's MuJoCo-side
ones), its constraints (the model's equalities and the case's contact forces) and its series. The list
is a superset (a figure a case lacks on every MuJoCo, e.g. ``instant.forcing`` of a ball joint, passes
here and fails when the case runs); ``tests/test_bad_input.py`` pins that every figure a shipped case
measures is in it. It needs the model alone: no derivation, no sympy.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from harness.cases import Case
from harness.core.errors import ConfigError
from harness.core.figures import FigureName
from harness.engine.models import compile_model
from harness.layers.orders import EXPECTED_ORDER
from harness.layers.reactions import sensor_names
from harness.opinions import threeway

INSTANT = ("kinematics", "kinetic_energy", "point_acceleration", "mass_matrix", "forcing", "qacc",
           "generalized_force")
REFERENCE = ("residual", "ode_vs_dae")
TRAJECTORY = ("position", "position_final", "velocity", "generalized_force")
CONVERGE = ("order_shortfall",)


def figure_names(case: Case) -> frozenset[str]:
    """Every figure name :func:`harness.pipeline.run.run_case` can give ``case`` (see the module docstring)."""
    model = compile_model(case.mjcf)
    constraints = [*(model.equality(i).name for i in range(model.neq)), *case.mujoco_forces]
    invariants = ["energy", *case.mujoco_invariants]
    names = {FigureName.instant(q) for q in INSTANT} | {FigureName.reference(q) for q in REFERENCE}
    names |= {FigureName.instant("peer", q) for q in threeway.QUANTITIES}  # where Pinocchio is installed
    names |= {FigureName.instant(q, c) for q in ("force", "generalized_force") for c in constraints}
    reading, wrenched = sensor_names(model)
    names |= {FigureName.instant("sensor", s) for s in reading}
    names |= {FigureName.instant("interaction", b) for b in wrenched}
    for integrator in EXPECTED_ORDER:
        names |= {FigureName.trajectory(integrator, q) for q in TRAJECTORY}
        names |= {FigureName.trajectory(integrator, i) for i in invariants}
        names |= {FigureName.trajectory(integrator, "drift", i) for i in invariants}
        names |= {FigureName.trajectory(integrator, q, c) for q in ("force", "violation") for c in constraints}
        names |= {FigureName.trajectory(integrator, "series", s) for s in case.mujoco_series}
        names |= {FigureName.converge(integrator, q) for q in CONVERGE}
    return frozenset(names)


def check_config(overrides: Mapping[str, Mapping[str, float]], cases: Iterable[Case], *, source: str) -> None:
    """ConfigError naming the first figure of ``overrides`` (limits by case) that its case cannot have,
    before any case runs (a case that runs is judged against what it measured after, exactly)."""
    by_name = {c.name: c for c in cases}
    for case, limits in overrides.items():
        if case not in by_name:
            continue
        known = figure_names(by_name[case])
        unknown = sorted(set(limits) - known)
        if unknown:
            raise ConfigError(f"config {source}: thresholds for case {case!r} name unmeasured figure(s) {unknown}, "
                              f"which it does not have; its figures: {', '.join(sorted(known))}")
