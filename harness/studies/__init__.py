"""Layer 4, studies: convergence orders, constraint softness, the constraint solvers, the contact settings, and
what the verdict catches (the fault catalog, its sensitivity, engine-side faults, energy injections).

Each study is a pure function of a registered case (or a model) returning frozen dataclasses: rows, fits and
verdicts, never text, HTML or plots (:mod:`harness.outputs.studies` renders them). ``run_studies`` runs the
convergence, softness and solver studies over a selection of cases (generic over the registry: softness and
solvers run on the cases they apply to).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco

from harness.cases import Case
from harness.engine.backends import Backend
from harness.families import convergence as orders
from harness.studies import softness, solvers

__all__ = ["Studies", "run_studies"]


@dataclass(frozen=True)
class Studies:
    """The studies run on a selection of cases, and how long they took (s)."""

    convergence: tuple[orders.ConvergenceStudy, ...]
    softness: tuple[softness.SoftnessStudy, ...] = ()
    solvers: tuple[solvers.SolverStudy, ...] = ()
    elapsed: float = 0.0
    mujoco_version: str = mujoco.__version__

    @property
    def passed(self) -> bool:
        """All order verdicts pass (softness and solver studies carry no verdict)."""
        return all(s.passed for s in self.convergence)

    @property
    def failures(self) -> tuple[orders.Series, ...]:
        """Failed verdicts, those explained by a documented defect of this MuJoCo included."""
        return tuple(s for st in self.convergence for s in st.verdicts if not s.passed)


def run_studies(selected: Sequence[Case], *, fast: bool = False, with_softness: bool = True,
                with_solvers: bool = True, progress: bool = False, engine: Backend | None = None) -> Studies:
    """Convergence for every case; softness for the equality-constrained ones and the solver
    comparison for the constrained ones, when asked; every run on ``engine`` (default: MuJoCo's C engine)."""
    start = time.perf_counter()

    def note(text: str) -> None:
        if progress:
            print(text, file=sys.stderr, flush=True)

    conv, soft, solv = [], [], []
    for case in selected:
        note(f"converge {case.name} ...")
        conv.append(orders.convergence_study(case, fast=fast, engine=engine))
    if with_softness:
        for case in softness.equality_cases(selected):
            note(f"softness {case.name} ...")
            soft.append(softness.softness_study(case, fast=fast, engine=engine))
    if with_solvers:
        for case in solvers.constrained_cases(selected):
            note(f"solvers {case.name} ...")
            solv.append(solvers.solver_study(case, fast=fast, engine=engine))
    return Studies(convergence=tuple(conv), softness=tuple(soft), solvers=tuple(solv),
                   elapsed=time.perf_counter() - start)
