"""The error budget: what a figure's size is made of, and what nothing explains.

Every gated figure measures how far MuJoCo is from the physics. Part of that distance is expected from the model's
own settings, and the budget names it, a part each: a module each, with its ``PART``, found by
:mod:`harness.budget.registry` (what each varies, may explain and must not absorb: its module's docstring and
``PART``, and docs/design.md's parts table), e.g. the integrator's truncation error, MuJoCo's soft constraints, a point
mass's floor inertia, a contact's margin, a constraint solver stopped short, a float32 solve stopped at its
resolution.

What remains after removing those parts from MuJoCo's run — the run extrapolated to the ideal limits, compared with
the reference — is the ``unexplained`` residual (:class:`harness.core.budget.Budget`). The verdict judges it against
the ``limit``: the sum of the uncertainties of the estimates themselves (``tolerance``: each part's own accuracy,
and what no part removes: ``roundoff``, float round-off; ``reference``, the reference's tolerance; ``convergence``,
the constraint solver's). A fault (damping, armature, a wrong coefficient) leaves a residual no part explains; a
legitimate setting (another timestep, softer constraints) moves the parts, not the residual.

Each part is a :class:`~harness.budget.part.Part`: what it varies, how its variant is made, how that variant's runs
and evaluations at the sampled states are made, its estimate over the runs and at the sampled states (from
:mod:`harness.budget.inputs`, where they come back under its name), its uncertainty with its basis, what it may
explain and what it must not absorb. The extrapolations they share are :mod:`harness.budget.extrapolation`; the
tolerances no part removes are :mod:`harness.budget.roundoff`, :mod:`harness.budget.reference` and
:mod:`harness.budget.convergence`.
"""

from harness.budget.part import Part
from harness.budget.registry import ALL, PARTS, TOLERANCES

__all__ = ["ALL", "PARTS", "TOLERANCES", "Part"]
