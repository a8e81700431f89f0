"""The error budget: what a figure's size is made of, and what nothing explains.

Every gated figure measures how far MuJoCo is from the physics. Part of that distance is expected from the model's
own settings, and the budget names it, a part each (a module each, the one list in :mod:`harness.budget.registry`):

- ``integration``: the integrator's truncation error at the model's timestep (Richardson: the same run at h/2 and
  the integrator's documented order);
- ``softness``: MuJoCo's soft constraints (solref/solimp), from runs with every constraint's effective softness
  scaled (by ½, or by 2 where it is already at MuJoCo's stiffest), extrapolated to the rigid limit;
- ``floors``: a point mass's tiny rotational inertia (MuJoCo needs some), from a run with it doubled, extrapolated
  to zero;
- ``margin``: a contact pair's margin (the contact pushes before it touches), from the sampled states with every
  margin doubled (instantaneous figures only);
- ``solver``: where the model's constraint solver stops short of the solution (CG or PGS at their iteration cap),
  the difference a converged solve makes;
- ``stop``: on a float32 backend, where its solver stopped at float32's resolution, the difference the solve
  completed in float64 makes.

What remains after removing those parts from MuJoCo's run — the run extrapolated to the ideal limits, compared with
the reference — is the ``unexplained`` residual (:class:`harness.core.budget.Budget`). The verdict judges it against
the ``limit``: the sum of the uncertainties of the estimates themselves (``tolerance``: each part's own accuracy,
and what no part removes: ``roundoff``, float round-off; ``reference``, the reference's tolerance; ``convergence``,
the constraint solver's). A fault (damping, armature, a wrong coefficient) leaves a residual no part explains; a
legitimate setting (another timestep, softer constraints) moves the parts, not the residual.

Each part is a :class:`~harness.budget.part.Part`: what it varies, how its variant is made, its estimate over the
runs and at the sampled states (from :mod:`harness.budget.inputs`), its uncertainty with its basis, what it may
explain and what it must not absorb. The extrapolations they share are :mod:`harness.budget.extrapolation`; the
tolerances no part removes are :mod:`harness.budget.roundoff`, :mod:`harness.budget.reference` and
:mod:`harness.budget.convergence`.
"""

from harness.budget.part import Part
from harness.budget.registry import ALL, PARTS, TOLERANCES

__all__ = ["ALL", "PARTS", "TOLERANCES", "Part"]
