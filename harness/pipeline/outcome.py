"""A run's outcome: the verdicts of every case, and what decides the exit code.

Two questions, answered apart (the report shows both, the exit code says which failed):

- **is MuJoCo right?** Every gated check, by its budget or its limit. A check
  that fails with the signature of a documented defect of this MuJoCo is a
  failure too (shown as a known defect, with the reason); only a user who
  accepts known defects (``--accept-known-defects``, or ``accept_known_defects =
  true`` in the config) lets the run pass the gate despite it.
- **are these settings good enough?** Where the user stated the accuracy they
  need (``--require``), each requirement against the figures of each model's
  own integrator (:mod:`harness.pipeline.require`).

Exit codes: :data:`EXIT_OK` both hold; :data:`EXIT_FAIL` a check fails (it
decides, whatever the requirements); :data:`EXIT_UNFIT` every check passes but
a requirement is not met.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from harness.core.checks import Check, gate
from harness.core.findings import Finding
from harness.pipeline.require import Fitness, Requirement, judge_fitness

__all__ = ["EXIT_UNFIT", "Outcome", "outcome_of"]

EXIT_OK, EXIT_FAIL, EXIT_UNFIT = 0, 1, 3


@dataclass(frozen=True)
class Outcome:
    """Every case's checks, its fitness for the stated requirements and the engine findings of its run."""

    checks: Mapping[str, Sequence[Check]]
    fitness: Mapping[str, Sequence[Fitness]] = field(default_factory=dict)
    findings: Mapping[str, Sequence[Finding]] = field(default_factory=dict)
    requirements: tuple[Requirement, ...] = ()
    accept_known_defects: bool = False

    @property
    def all_checks(self) -> list[Check]:
        return [c for cs in self.checks.values() for c in cs]

    @property
    def passed(self) -> bool:
        """Every check passes (a known defect is a failure here, accepted or not)."""
        return all(c.passed for c in self.all_checks)

    @property
    def known_defects(self) -> list[Check]:
        return [c for c in self.all_checks if c.known]

    @property
    def gate_passed(self) -> bool:
        """The gate: every check passes, or fails only as an accepted known defect."""
        return gate(self.all_checks, accept_known_defects=self.accept_known_defects)

    @property
    def unmet(self) -> list[Fitness]:
        return [f for fs in self.fitness.values() for f in fs if not f.met]

    @property
    def fit(self) -> bool:
        """Every stated requirement met (true where none was stated)."""
        return not self.unmet

    @property
    def exit_code(self) -> int:
        if not self.gate_passed:
            return EXIT_FAIL
        return EXIT_OK if self.fit else EXIT_UNFIT

    def case_passed(self, case: str) -> bool:
        return all(c.passed for c in self.checks.get(case, ()))


def outcome_of(results: Sequence, checks: Mapping[str, Sequence[Check]], *,
               requirements: Sequence[Requirement] = (), accept_known_defects: bool = False) -> Outcome:
    """The outcome of ``results`` (CaseResult) judged as ``checks``, with their fitness for
    ``requirements`` and their findings."""
    return Outcome(checks=dict(checks),
                   fitness={r.case.name: judge_fitness(r, requirements) for r in results} if requirements else {},
                   findings={r.case.name: tuple(r.findings) for r in results if r.findings},
                   requirements=tuple(requirements), accept_known_defects=accept_known_defects)
