"""The KKT solve with redundant constraint rows and through a singular configuration (issue 43): q̈ and Jᵀλ are
unique and the same as with the redundant rows left out, λ is flagged where it is not unique, and the IFToMM A02
N-four-bar (examples/four_bar_a02.xml) is integrated through the configuration where its loops lose rank."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analytic.dynamics import rank_tolerance
from analytic.solvers import solve
from analytic.tree import TreeDynamics
from harness.engine.models import compile_model
from harness.reference.tree import prepare, read_tree

FOUR_BAR = Path(__file__).resolve().parents[1] / "examples" / "four_bar_a02.xml"
PHI = -np.pi / 2  # the cranks' angle where every link is collinear


@pytest.fixture(scope="module")
def four_bar() -> TreeDynamics:
    return TreeDynamics.of(read_tree(compile_model(FOUR_BAR, edit=prepare)))


def _parallelogram(phi: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """The four-bar's state with the cranks at ``phi`` turning at ``rate``, the couplers horizontal."""
    signs = np.array([1.0, -1.0, 1.0, -1.0, 1.0])
    return phi * signs, rate * signs


def _reduced(dyn: TreeDynamics, q: np.ndarray, qd: np.ndarray, rows: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """q̈ and Jᵀλ from the KKT matrix with only ``rows`` (an independent set), solved as it stands."""
    mass, force = dyn.mass_and_forcing(q, qd)
    jac, gamma = dyn.jacobian(q)[rows], dyn.gamma(q, qd)[rows]
    n, m = dyn.n, len(rows)
    kkt = np.block([[mass, -jac.T], [jac, np.zeros((m, m))]])
    sol = np.linalg.solve(kkt, np.concatenate([force, gamma]))
    return sol[:n], jac.T @ sol[n:]


def test_redundant_rows_give_the_reduced_accelerations_and_are_flagged(four_bar):
    """A planar loop closed by connects has a zero out-of-plane row per connect: the full KKT matrix is singular
    (numpy's solve raised 'Singular matrix'), the rank-revealing solve gives the q̈ and Jᵀλ of the in-plane rows
    alone, the in-plane multipliers equal theirs, and the out-of-plane ones are flagged not unique."""
    q, qd = _parallelogram(-0.4, -1.3)
    with pytest.raises(np.linalg.LinAlgError):  # what the plain KKT solve did
        _reduced(four_bar, q, qd, list(range(6)))
    solved = four_bar.constrained(q, qd)
    qdd, generalized = _reduced(four_bar, q, qd, [0, 1, 3, 4])
    scale = np.max(np.abs(qdd))
    assert scale > 1.0  # gravity and the motion: a q̈ that is not 0
    assert np.max(np.abs(solved.qdd - qdd)) < 1e-12 * scale
    assert np.max(np.abs(solved.generalized - generalized)) < 1e-12 * np.max(np.abs(generalized))
    assert solved.rank == 4
    assert solved.unique.tolist() == [True, True, False, True, True, False]
    assert np.max(np.abs(solved.lam[[2, 5]])) < 1e-12 * np.max(np.abs(solved.lam))  # least norm: ~0 there


def test_a_row_redundant_with_another_is_flagged_and_its_total_force_kept(four_bar):
    """Not only zero rows: a constraint stated twice (the same loop closed by two connects) splits its force in
    any proportion; both copies are flagged, the total Jᵀλ is the single copy's."""
    from dataclasses import replace

    tree = four_bar.tree
    doubled = TreeDynamics.of(replace(tree, equalities=(*tree.equalities, tree.equalities[0])))
    q, qd = _parallelogram(-0.7, 0.9)
    single, twice = four_bar.constrained(q, qd), doubled.constrained(q, qd)
    assert np.max(np.abs(twice.qdd - single.qdd)) < 1e-12 * np.max(np.abs(single.qdd))
    assert np.max(np.abs(twice.generalized - single.generalized)) < 1e-12 * np.max(np.abs(single.generalized))
    assert twice.unique.tolist() == [False] * 3 + [True, True, False] + [False] * 3
    assert np.allclose(twice.lam[[0, 1]], twice.lam[[6, 7]], rtol=1e-12)  # least norm: split evenly


def test_the_singular_configuration_has_finite_accelerations_and_loses_a_rank(four_bar):
    """At the collinear pose both loops' in-plane rows lose one direction (rank 4 → 2): q̈ stays finite, the
    constraints hold to first order (J q̈ = γ on the kept directions), and the lost rows are flagged; next to it
    (1e-5 rad away) the rank is back to 4 and q̈ is the parallelogram's."""
    q, qd = _parallelogram(PHI, -3.0)
    at = four_bar.constrained(q, qd)
    assert at.rank == 2 and not np.all(at.unique[[0, 1, 3, 4]])
    assert np.all(np.isfinite(at.qdd)) and np.max(np.abs(at.qdd)) < 100.0
    residual = four_bar.jacobian(q) @ at.qdd - four_bar.gamma(q, qd)
    assert np.max(np.abs(residual)) < 1e-12 * np.max(np.abs(at.qdd))
    near = four_bar.constrained(*_parallelogram(PHI + 1e-5, -3.0))
    assert near.rank == 4
    assert np.allclose(near.qdd, near.qdd[0] * np.array([1, -1, 1, -1, 1]), rtol=1e-6)


def test_the_rank_tolerance_is_stated():
    assert rank_tolerance(6, 5) == pytest.approx(np.sqrt(6 * np.finfo(float).eps))


def test_the_four_bar_is_integrated_through_its_singular_configuration(four_bar):
    """From the benchmark's start the cranks fall through the horizontal (about 0.71 s) and on: the reference
    solve passes it, the energy (no dissipation) is kept to 1e-8 of the energy the fall releases, and the loops
    stay closed."""
    q, qd = _parallelogram(0.0, -1.0)
    sol = solve(four_bar, q0=q, qd0=qd, t_end=1.0)
    t = np.linspace(0.0, 1.0, 401)
    states = sol.state(t)
    assert states[0][:, 0].min() < PHI - 0.2  # well past the singular pose
    energy = four_bar.energy(*states)
    assert np.ptp(energy) < 1e-8 * 34.3  # mgΔh: 3 cranks' centres fall 0.5 m, 2 couplers 1 m
    assert np.max(np.abs(four_bar.position_residual(states[0]))) < 1e-9
