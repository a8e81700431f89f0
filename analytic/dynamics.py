"""Numeric equations of motion, built once per system and parameter values from a :class:`Derivation`.

All functions accept a single state (q of shape (n,)) or a batch (shape
(N, n)) and broadcast, so a whole reference trajectory is evaluated in one
call rather than in a Python loop.

Building goes through :class:`Compiled`: every function as the Python source
sympy's ``lambdify`` writes for it, at the bound parameter values. That is
plain text, so it is cached on disk beside the derivations (harness/reference.py)
and turned back into functions with numpy alone: a run whose derivations are
cached neither imports sympy (whose loading and teardown every process would pay:
docs/findings/speed.md) nor lambdifies anything.
"""

from __future__ import annotations

import ast
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from analytic.dual import Dual

if TYPE_CHECKING:
    import sympy as sp

    from analytic.lagrangian import Derivation

__all__ = ["Array", "Compiled", "Constrained", "Dynamics", "chunk_states", "kkt_tangent", "rank_tolerance",
           "solve_kkt"]

Array = np.ndarray


CHUNK_CONFIGURATIONS = 1024
"""The most configurations one batched evaluation of a tree's equations holds (each state takes n + 2 of them, the
complex steps of its q-derivatives): a longer batch (a reference sampled on a run's grid, the 2n dual-number
columns of a Jacobian) is evaluated in chunks of states, whose arrays stay in the caches instead of being paged in
(docs/findings/bases.md, CHUNK_CONFIGURATIONS)."""


def chunk_states(n: int) -> int:
    """How many states of a system of ``n`` coordinates one batched evaluation takes (:data:`CHUNK_CONFIGURATIONS`)."""
    return max(1, CHUNK_CONFIGURATIONS // (n + 2))


def _source(exprs: sp.Matrix, args: list[sp.Symbol]) -> str:
    """The source of ``lambdify(args, entries of exprs)`` (empty for an empty matrix), every numpy
    function written ``numpy.<name>`` so that the code runs with numpy alone in its namespace."""
    import sympy as sp  # lazy: sympy, only when code is made from a derivation
    from sympy.printing.numpy import NumPyPrinter  # lazy: as above

    flat = list(exprs)
    if not flat:
        return ""
    printer = NumPyPrinter({"fully_qualified_modules": True, "inline": True, "allow_unknown_functions": False})
    return inspect.getsource(sp.lambdify(args, flat, modules="numpy", printer=printer, cse=True))


# What lambdify's numpy code is made of, and all that stored code may be (it can come from a cache
# someone else wrote): one function of plain arguments, assignments to names, and a returned list of
# arithmetic on numbers, those names and the numpy functions below. Nothing else is ever compiled.
NUMPY_FUNCTIONS = frozenset({"sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh",
                             "exp", "log", "sqrt", "abs", "sign", "fabs", "hypot", "minimum", "maximum", "amin",
                             "amax", "power", "float64"})
_NODES = (ast.Module, ast.FunctionDef, ast.arguments, ast.arg, ast.Assign, ast.Return, ast.List, ast.Tuple,
          ast.BinOp, ast.UnaryOp, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd, ast.Load,
          ast.Store, ast.Name, ast.Constant, ast.Call, ast.Attribute)
_MAX_EXPONENT = 64  # x**n with a literal n: lambdify writes small integers and halves; a huge one could hang


def _checked_source(source: str) -> ast.Module:
    """``source`` parsed, once checked to be lambdify-shaped arithmetic (see :data:`NUMPY_FUNCTIONS`);
    ValueError naming the first node that is not."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError, RecursionError) as exc:
        raise ValueError(f"stored code does not parse: {exc}") from None
    if len(tree.body) != 1 or not isinstance(tree.body[0], ast.FunctionDef) \
            or tree.body[0].name != "_lambdifygenerated":
        raise ValueError("stored code is not one lambdify function")
    fn = tree.body[0]
    spec = fn.args
    if fn.decorator_list or fn.returns or spec.vararg or spec.kwarg or spec.kwonlyargs or spec.defaults \
            or spec.posonlyargs or any(a.annotation for a in spec.args):
        raise ValueError("stored code's function is not of plain arguments")
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise ValueError(f"stored code holds a {type(node).__name__}, which lambdify's arithmetic never does")
        if isinstance(node, ast.Name) and node.id.startswith("_"):
            raise ValueError(f"stored code names {node.id!r}")
        if isinstance(node, ast.Constant) and type(node.value) not in (int, float):
            raise ValueError("stored code holds a constant that is not a number")
        if isinstance(node, ast.Attribute) and not (isinstance(node.value, ast.Name) and node.value.id == "numpy"
                                                    and node.attr in NUMPY_FUNCTIONS):
            raise ValueError(f"stored code reads an attribute other than numpy's functions: {node.attr!r}")
        if isinstance(node, ast.Name) and node.id == "numpy" and not isinstance(node.ctx, ast.Load):
            raise ValueError("stored code assigns 'numpy'")
        if isinstance(node, ast.Call) and (node.keywords or not isinstance(node.func, ast.Attribute)):
            raise ValueError("stored code calls something other than numpy's functions")
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and not _small_exponent(node.right):
            raise ValueError("stored code raises to a power that is not a small literal")
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and abs(node.value) > 10**18:
            raise ValueError("stored code holds an integer too large for lambdify's output")
    return tree


def _small_exponent(node: ast.expr) -> bool:
    """Whether ``node`` is a literal exponent of at most :data:`_MAX_EXPONENT` (a number, its negation or a
    quotient of two such, as lambdify writes rationals)."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        return _small_exponent(node.operand)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        return _small_exponent(node.left) and _small_exponent(node.right)
    return (isinstance(node, ast.Constant) and type(node.value) in (int, float)
            and abs(cast(float, node.value)) <= _MAX_EXPONENT)


def _vectorized(source: str, rows: int, cols: int) -> Callable[..., Array]:
    """The function ``source`` defines, made to broadcast over leading batch dimensions.

    lambdify's code returns constant entries as Python scalars; here every entry
    is broadcast to the batch shape, giving an array (*batch, rows, cols). The
    code names numpy functions as ``numpy.<name>`` only, so numpy is all it needs.
    """
    fn: Callable[..., Any] | None = None
    if source:
        namespace: dict[str, Any] = {"numpy": np, "__builtins__": {}}
        # only code checked to be arithmetic on numpy's functions runs, wherever it was read from
        exec(compile(_checked_source(source), "<stored dynamics>", "exec"), namespace)
        fn = namespace["_lambdifygenerated"]

    def evaluate(*values: Array) -> Array:
        if fn is not None and all(type(v) is np.float64 for v in values):  # one state: the same numbers, no
            return np.asarray(fn(*values), dtype=float).reshape(rows, cols)  # broadcasting (most of a call's cost)
        batch = np.broadcast_shapes(*(np.shape(v) for v in values))
        if fn is None:
            return np.zeros((*batch, rows, cols))
        entries = np.broadcast_arrays(*[np.asarray(e, dtype=float) for e in fn(*values)],
                                      np.zeros(batch))[:-1]
        return np.stack(entries, axis=-1).reshape(*batch, rows, cols)

    return evaluate


@dataclass(frozen=True)
class Compiled:
    """A system's numeric functions at bound parameter values, as lambdify's Python source: what a
    :class:`Dynamics` is made of, small, picklable, and loaded without sympy.

    ``functions``: (name, source, rows, cols) per quantity, source "" for an empty matrix;
    ``constraint_sizes``: the number of rows of each constraint, in ``constraint_names`` order.
    """

    coordinates: tuple[str, ...]
    constraint_names: tuple[str, ...]
    point_names: tuple[str, ...]
    cyclic: tuple[str, ...]
    params: tuple[tuple[str, float], ...]
    functions: tuple[tuple[str, str, int, int], ...]
    constraint_sizes: tuple[int, ...] = ()
    body_names: tuple[str, ...] = ()

    @classmethod
    def of(cls, derivation: Derivation, params: Mapping[str, float]) -> Compiled:
        """Substitute the parameter values into every quantity and lambdify it (needs sympy)."""
        import sympy as sp  # lazy: sympy; a run with cached code never gets here

        s = derivation.system
        missing = {p.name for p in s.params} - set(params)
        if missing:
            raise ValueError(f"params missing values for {sorted(missing)}; system {s.name!r} needs "
                             f"{sorted(p.name for p in s.params)}")
        values = {p: float(params[p.name]) for p in s.params}
        n = len(s.q)
        point_pos = sp.Matrix([[e for e in s.points[k]] for k in s.points]) if s.points else sp.zeros(0, 3)
        point_vel = sp.Matrix([[sum(sp.diff(e, qi) * vi for qi, vi in zip(s.q, s.qd, strict=True))
                                for e in s.points[k]] for k in s.points]) if s.points else sp.zeros(0, 3)
        # ∂x/∂q stacked point by point (3 rows each), and the velocity-product part of ẍ,
        # q̇ᵀ ∂²x/∂q² q̇ = (∂ẋ/∂q) q̇
        point_jac = sp.Matrix([[sp.diff(e, qi) for qi in s.q] for k in s.points for e in s.points[k]]) \
            if s.points else sp.zeros(0, n)
        point_bias = point_vel.applyfunc(
            lambda v: sum(sp.diff(v, qi) * vi for qi, vi in zip(s.q, s.qd, strict=True)))
        bodies = list(s.bodies.values())
        nb = len(bodies)
        com = sp.Matrix([list(b.com) for b in bodies]) if bodies else sp.zeros(0, 3)
        com_jac = sp.Matrix.vstack(*[b.com.jacobian(list(s.q)) for b in bodies]) if bodies else sp.zeros(0, n)
        com_vel = (com_jac * sp.Matrix(s.qd)) if bodies else sp.zeros(0, 1)
        momentum = sp.Matrix.vstack(*[b.angular_momentum(s.q, s.qd) for b in bodies]) if bodies \
            else sp.zeros(0, 1)
        # the rates d/dt = (∂/∂q̇) q̈ + (∂/∂q) q̇ of the com velocity and of L_c, both linear in q̈;
        # row 3i + k is body i's component k
        body_terms = {
            "body_mass": sp.Matrix([[b.mass] for b in bodies]) if bodies else sp.zeros(0, 1),
            "body_com": com,
            "body_com_jac": com_jac,
            "body_com_bias": (com_vel.jacobian(list(s.q)) * sp.Matrix(s.qd)).reshape(nb, 3) if bodies
            else sp.zeros(0, 3),
            "body_momentum_jac": momentum.jacobian(list(s.qd)) if bodies else sp.zeros(0, n),
            "body_momentum_bias": (momentum.jacobian(list(s.q)) * sp.Matrix(s.qd)).reshape(nb, 3) if bodies
            else sp.zeros(0, 3),
        }
        symbolic = {
            **body_terms,
            "mass_matrix": derivation.mass_matrix,
            "forcing": derivation.forcing,
            "jacobian": derivation.jacobian if s.constraints else sp.zeros(0, n),
            "gamma": derivation.gamma,
            "velocity_residual": derivation.constraint_rows,
            "position_residual": derivation.holonomic_residual,
            "energy": sp.Matrix([derivation.energy]),
            "momenta": derivation.momenta,
            "points": point_pos,
            "point_velocities": point_vel,
            "point_jacobians": point_jac,
            "point_bias": point_bias,
        }
        args = [*s.q, *s.qd]
        functions = []
        for name, exprs in symbolic.items():
            bound = sp.Matrix(exprs).subs(values)
            functions.append((name, _source(bound, args), *bound.shape))
        return cls(
            coordinates=tuple(c.name for c in s.q),
            constraint_names=tuple(c.name for c in s.constraints),
            constraint_sizes=tuple(c.size for c in s.constraints),
            point_names=tuple(s.points),
            cyclic=tuple(c.name for c in derivation.cyclic),
            params=tuple((p.name, float(params[p.name])) for p in s.params),
            functions=tuple(functions),
            body_names=tuple(s.bodies),
        )


@dataclass(frozen=True)
class Dynamics:
    """Numeric M, F, J, γ, energy, momenta and observables at bound parameter values.

    Shapes: q, qd are (..., n); matrices come back (..., rows, cols) and
    vectors (..., k). Constraint quantities (J, γ, λ, residuals) have one
    entry per constraint row; ``constraint_names`` name the constraints, each
    a block of ``constraint_sizes`` rows (one for most: a connect has three),
    and :meth:`by_constraint` splits a row-indexed array into them.
    """

    coordinates: tuple[str, ...]
    constraint_names: tuple[str, ...]
    point_names: tuple[str, ...]
    cyclic: tuple[str, ...]
    params: Mapping[str, float]
    _funcs: Mapping[str, Callable[..., Array]]
    constraint_sizes: tuple[int, ...] = ()
    body_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.constraint_sizes:
            object.__setattr__(self, "constraint_sizes", (1,) * len(self.constraint_names))
        if len(self.constraint_sizes) != len(self.constraint_names) or min(self.constraint_sizes, default=1) < 1:
            raise ValueError(f"constraint_sizes {self.constraint_sizes} do not fit the constraints "
                             f"{self.constraint_names}")

    @classmethod
    def build(cls, derivation: Derivation, params: Mapping[str, float]) -> Dynamics:
        """Substitute the parameter values into every quantity, lambdify it, and load the result."""
        return cls.load(Compiled.of(derivation, params))

    @classmethod
    def load(cls, compiled: Compiled) -> Dynamics:
        """The functions ``compiled`` holds, with numpy alone."""
        return cls(
            coordinates=compiled.coordinates,
            constraint_names=compiled.constraint_names,
            point_names=compiled.point_names,
            cyclic=compiled.cyclic,
            params=dict(compiled.params),
            _funcs={name: _vectorized(src, rows, cols) for name, src, rows, cols in compiled.functions},
            constraint_sizes=compiled.constraint_sizes,
            body_names=compiled.body_names,
        )

    def checked(self) -> Dynamics:
        """Self, once every function has run at one state (a NameError or TypeError in loaded code
        shows here rather than mid-run); the values are not judged."""
        q = np.ones(self.n)
        with np.errstate(all="ignore"):
            for fn in self._funcs.values():
                fn(*q, *q)
        return self

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def rows(self) -> int:
        """The number of constraint rows (the length of λ)."""
        return sum(self.constraint_sizes)

    @property
    def blocks(self) -> dict[str, slice]:
        """Each constraint's rows, as a slice of the row-indexed arrays (λ, J, residuals)."""
        ends = np.cumsum((0, *self.constraint_sizes))
        return {c: slice(int(a), int(b)) for c, a, b in zip(self.constraint_names, ends[:-1], ends[1:], strict=True)}

    @property
    def row_labels(self) -> tuple[str, ...]:
        """A label per row: the constraint's name, or ``NAME[I]`` for row I of a block."""
        return tuple(c if k == 1 else f"{c}[{i}]" for c, k in zip(self.constraint_names, self.constraint_sizes,
                                                                   strict=True) for i in range(k))

    def by_constraint(self, rows: Array) -> dict[str, Array]:
        """A row-indexed array (..., rows) split into its constraints: (...) for a one-row constraint,
        (..., k) for a block of k rows (the convention of every multiplier and violation by name)."""
        rows = np.asarray(rows)
        return {c: rows[..., s.start] if s.stop - s.start == 1 else rows[..., s] for c, s in self.blocks.items()}

    def _call(self, key: str, q: Array, qd: Array) -> Array:
        q = np.asarray(q, dtype=float)
        qd = np.asarray(qd, dtype=float)
        if q.ndim == qd.ndim == 1:  # one state: its entries, numpy scalars, as moveaxis would give them
            return self._funcs[key](*q, *qd)
        return self._funcs[key](*np.moveaxis(q, -1, 0), *np.moveaxis(qd, -1, 0))

    def mass_matrix(self, q: Array) -> Array:
        return self._call("mass_matrix", q, np.zeros_like(q))

    def forcing(self, q: Array, qd: Array) -> Array:
        return self._call("forcing", q, qd)[..., 0]

    def jacobian(self, q: Array) -> Array:
        return self._call("jacobian", q, np.zeros_like(q))

    def gamma(self, q: Array, qd: Array) -> Array:
        return self._call("gamma", q, qd)[..., 0]

    def position_residual(self, q: Array) -> Array:
        """f(q) per constraint row (0 for Pfaffian rows)."""
        return self._call("position_residual", q, np.zeros_like(q))[..., 0]

    def velocity_residual(self, q: Array, qd: Array) -> Array:
        """J q̇ + b per constraint row."""
        return self._call("velocity_residual", q, qd)[..., 0]

    def energy(self, q: Array, qd: Array) -> Array:
        return self._call("energy", q, qd)[..., 0, 0]

    def momenta(self, q: Array, qd: Array) -> Array:
        return self._call("momenta", q, qd)[..., 0]

    def mass_and_forcing(self, q: Array, qd: Array) -> tuple[Array, Array]:
        """M(q) and F(q, q̇) together (a dynamics that shares work between them computes them at once)."""
        return self.mass_matrix(q), self.forcing(q, qd)

    @property
    def velocity_polynomial(self) -> bool:
        """Whether q̈ at a fixed q is a polynomial of degree ≤ 3 in q̇ (what lets the stiff solver differentiate it
        in q̇ exactly: :func:`analytic.solvers.state_jacobian`); not claimed for a derived system's forces."""
        return False

    def extra_invariants(self, q: Array, qd: Array) -> dict[str, Array]:
        """Conserved quantities beyond the energy and the cyclic momenta, by name (none for a derived system)."""
        return {}

    def points(self, q: Array) -> Array:
        """World positions, shape (..., npoints, 3), in ``point_names`` order."""
        return self._call("points", q, np.zeros_like(q))

    def point_velocities(self, q: Array, qd: Array) -> Array:
        return self._call("point_velocities", q, qd)

    def point_jacobians(self, q: Array) -> Array:
        """∂x/∂q per point, shape (..., npoints, 3, n)."""
        jac = self._call("point_jacobians", q, np.zeros_like(q))
        return jac.reshape(*jac.shape[:-2], len(self.point_names), 3, self.n)

    def point_accelerations(self, q: Array, qd: Array, qdd: Array) -> Array:
        """World accelerations ẍ = (∂x/∂q) q̈ + q̇ᵀ(∂²x/∂q²)q̇, shape (..., npoints, 3)."""
        qdd = np.asarray(qdd, dtype=float)
        return np.einsum("...pij,...j->...pi", self.point_jacobians(q), qdd) + self._call("point_bias", q, qd)

    def body_masses(self) -> Array:
        """Each body's mass, shape (nbodies,), in ``body_names`` order."""
        return self._call("body_mass", np.zeros(self.n), np.zeros(self.n))[..., 0]

    def body_coms(self, q: Array) -> Array:
        """Each body's centre of mass in the world, shape (..., nbodies, 3)."""
        return self._call("body_com", q, np.zeros_like(q))

    def body_accelerations(self, q: Array, qd: Array, qdd: Array) -> Array:
        """Each body's centre-of-mass acceleration c̈ = (∂c/∂q) q̈ + (∂ċ/∂q) q̇, shape (..., nbodies, 3)."""
        jac = self._call("body_com_jac", q, np.zeros_like(q))
        jac = jac.reshape(*jac.shape[:-2], len(self.body_names), 3, self.n)
        return np.einsum("...bij,...j->...bi", jac, np.asarray(qdd, dtype=float)) + self._call("body_com_bias", q, qd)

    def body_momentum_rates(self, q: Array, qd: Array, qdd: Array) -> Array:
        """Each body's dL_c/dt, the rate of its world angular momentum about its centre of mass
        (∂L_c/∂q̇) q̈ + (∂L_c/∂q) q̇, shape (..., nbodies, 3); zero for a point mass."""
        jac = self._call("body_momentum_jac", q, qd)
        jac = jac.reshape(*jac.shape[:-2], len(self.body_names), 3, self.n)
        return (np.einsum("...bij,...j->...bi", jac, np.asarray(qdd, dtype=float))
                + self._call("body_momentum_bias", q, qd))

    def accelerations(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)
                      ) -> tuple[Array, Array]:
        """q̈ and λ from the KKT system [[M, −Jᵀ], [J, 0]] [q̈; λ] = [F; γ] (:meth:`constrained`: solved
        rank-revealingly, λ the least-norm multipliers where rows are redundant).

        ``stabilization`` = (α, β) adds Baumgarte terms −α(Jq̇+b) − βf(q) to γ;
        they vanish on the constraint manifold, so they change only drift.
        """
        solved = self.constrained(q, qd, stabilization=stabilization)
        return solved.qdd, solved.lam

    def constraint_terms(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)
                         ) -> tuple[Array, Array]:
        """J(q) and the right-hand side γ − α(Jq̇ + b) − βf(q) of the constraint rows of the KKT system."""
        jac = self.jacobian(q)
        alpha, beta = stabilization
        gamma = self.gamma(q, qd)
        if alpha or beta:
            gamma = gamma - alpha * self.velocity_residual(q, qd) - beta * self.position_residual(q)
        return jac, gamma

    def kkt_terms(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)
                  ) -> tuple[Array, Array, Array | None, Array | None]:
        """M, F and, where the system has constraint rows, J and γ − α(Jq̇ + b) − βf (else None, None): the KKT
        system's blocks (:meth:`constrained`), in one method so that a system can compute them from shared work."""
        mass, force = self.mass_and_forcing(q, qd)
        if self.rows == 0:
            return mass, force, None, None
        return (mass, force, *self.constraint_terms(q, qd, stabilization=stabilization))

    def constrained(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)) -> Constrained:
        """q̈, λ, Jᵀλ and which multipliers are unique, from the KKT system (:func:`solve_kkt`).

        Dual-number states (:attr:`dual_states`: :class:`~analytic.dual.Dual`) give q̈ as a dual number, its
        tangent exact (:func:`kkt_tangent`)."""
        if not (isinstance(q, Dual) or isinstance(qd, Dual)):
            q = np.asarray(q, dtype=float)
            qd = np.asarray(qd, dtype=float)
        mass, force, jac, gamma = self.kkt_terms(q, qd, stabilization=stabilization)
        if any(isinstance(x, Dual) for x in (mass, force, jac, gamma)):
            return kkt_tangent(mass, force, jac, gamma)
        return solve_kkt(mass, force, jac, gamma)

    @property
    def dual_states(self) -> bool:
        """Whether :meth:`accelerations` takes :class:`~analytic.dual.Dual` states (q̈'s exact derivative, what
        :func:`analytic.solvers.state_jacobian` uses); not a derived system's (its code is compiled for floats)."""
        return False


def solve_kkt(mass: Array, force: Array, jac: Array | None, gamma: Array | None) -> Constrained:
    """q̈, λ, Jᵀλ and which multipliers are unique, from the KKT system [[M, −Jᵀ], [J, 0]] [q̈; λ] = [F; γ]
    (see :class:`Constrained`); ``jac`` None where there are no constraint rows.

    Where J (weighted by M⁻¹ᐟ²: J_w = J L⁻ᵀ, M = L Lᵀ) has full row rank at every state, the KKT matrix is
    solved as it stands (LU); otherwise, at the states where it has not, in J_w's singular vectors: only the
    directions whose singular value exceeds :func:`rank_tolerance` × the largest are constraints, the others
    are redundant rows (a planar loop's out-of-plane ones) or a singular configuration's lost direction, so
    q̈ and Jᵀλ stay unique and finite and λ is the least-norm multiplier vector."""
    m, n = 0 if jac is None else jac.shape[-2], mass.shape[-1]
    batch = force.shape[:-1]
    if m == 0:
        qdd = np.linalg.solve(mass, force[..., None])[..., 0]
        return Constrained(qdd=qdd, lam=np.zeros((*batch, 0)), generalized=np.zeros_like(qdd),
                           unique=np.ones((*batch, 0), dtype=bool), rank=np.zeros(batch, dtype=int))
    try:
        chol = np.linalg.cholesky(mass)
    except np.linalg.LinAlgError:  # M only semi-definite (a massless coordinate the constraints hold): no
        chol = None  # weighting; the KKT matrix as it stands, which constraints that fix it make regular
    assert jac is not None and gamma is not None  # m > 0: the constraint rows and their right-hand side
    if chol is not None:
        weighted = np.swapaxes(np.linalg.solve(chol, np.swapaxes(jac, -1, -2)), -1, -2)  # J L⁻ᵀ, (..., m, n)
        s = np.linalg.svd(weighted, compute_uv=False)  # the singular values alone first: most models' J is regular
        keep = s > rank_tolerance(m, n) * s[..., :1]  # (..., min(m, n)), descending
        rank = np.sum(keep, axis=-1)
        unique = np.ones((*batch, m), dtype=bool)
        if not np.all(rank == m):
            u, s, _ = np.linalg.svd(weighted, full_matrices=True)
            # a row's unit vector with a part in the left null space (U's columns past the rank): λ not unique
            null = np.concatenate([~keep, np.ones((*batch, m - keep.shape[-1]), dtype=bool)], axis=-1)
            unique = np.sqrt(np.sum(u * u * null[..., None, :], axis=-1)) <= rank_tolerance(m, n)
    else:
        rank, unique = np.full(batch, m), np.ones((*batch, m), dtype=bool)
    if chol is None or np.all(rank == m):  # full row rank everywhere: the KKT system as it stands
        kkt = np.zeros((*batch, n + m, n + m))
        kkt[..., :n, :n] = mass
        kkt[..., :n, n:] = -np.swapaxes(jac, -1, -2)
        kkt[..., n:, :n] = jac
        sol = np.linalg.solve(kkt, np.concatenate([force, gamma], axis=-1)[..., None])[..., 0]
        qdd, lam = sol[..., :n], sol[..., n:]
    else:  # z = Lᵀq̈ = y + J_wᵀλ, y = L⁻¹F, J_w J_wᵀ λ = γ − J_w y, in U's basis on the kept directions
        y = np.linalg.solve(chol, force[..., None])[..., 0]
        k = s.shape[-1]
        rhs = np.einsum("...mj,...m->...j", u[..., :, :k], gamma - np.einsum("...mn,...n->...m", weighted, y))
        safe = np.where(keep, s, 1.0)
        lam = np.einsum("...mj,...j->...m", u[..., :, :k], np.where(keep, rhs / (safe * safe), 0.0))
        z = y + np.einsum("...mn,...m->...n", weighted, lam)
        qdd = np.linalg.solve(np.swapaxes(chol, -1, -2), z[..., None])[..., 0]
    generalized = np.einsum("...mn,...m->...n", jac, lam)
    return Constrained(qdd=qdd, lam=lam, generalized=generalized, unique=unique, rank=rank)


def kkt_tangent(mass: Array | Dual, force: Array | Dual, jac: Array | Dual | None, gamma: Array | Dual | None
                ) -> Constrained:
    """:func:`solve_kkt` of dual-number blocks: q̈ as a dual number whose tangent is the solve's exact derivative.

    Differentiating M q̈ = F + Jᵀλ and P(J q̈ − γ) = 0 (P the projector on the constraint directions, range J) gives
    the same system for the tangent q̈′, with the same M and J, right-hand sides F′ − M′q̈ + J′ᵀλ and
    γ′ − J′q̈ − (J⁺)ᵀJ′ᵀ r, r = J q̈ − γ: so q̈′ is :func:`solve_kkt` again, its truncation the same. Any λ with
    Jᵀλ the constraint force serves (another differs by ν with Jᵀν = 0, whose J′ᵀν lies in range Jᵀ, absorbed by
    the multiplier); the last term is the turning of range J, nonzero only where redundant rows disagree
    (r ≠ 0, outside range J). Exact wherever the rank of J is locally constant (not at a state where it
    changes: a singular configuration, where q̈ has no derivative). λ keeps no tangent."""
    (m, dm), (f, df) = _parts(mass), _parts(force)
    j, dj = _parts(jac) if jac is not None else (None, None)
    g, dg = _parts(gamma) if gamma is not None else (None, None)
    base = solve_kkt(m, f, j, g)
    qdd = base.qdd
    rhs_force = df - np.einsum("...ij,...j->...i", dm, qdd)
    rhs_gamma = None
    if j is not None:
        assert dj is not None and dg is not None and g is not None  # the constraints' parts, with j
        rhs_force = rhs_force + np.einsum("...mn,...m->...n", dj, base.lam)
        rhs_gamma = dg - np.einsum("...mn,...n->...m", dj, qdd)
        if not np.all(base.rank == j.shape[-2]):  # redundant rows: the turning of range J where they disagree
            residual = np.einsum("...mn,...n->...m", j, qdd) - g
            u, s, vt = np.linalg.svd(j, full_matrices=False)
            keep = np.arange(s.shape[-1]) < base.rank[..., None]
            v = np.einsum("...mn,...m->...n", dj, residual)  # J′ᵀ r, then (Jᵀ)⁺ of it on the kept directions
            coef = np.where(keep, np.einsum("...kn,...n->...k", vt, v) / np.where(keep, s, 1.0), 0.0)
            rhs_gamma = rhs_gamma - np.einsum("...mk,...k->...m", u, coef)
    moved = solve_kkt(m, rhs_force, j, rhs_gamma)
    # q̈ a dual number (it acts as an array: Constrained's type names arrays only)
    return Constrained(qdd=Dual(qdd, moved.qdd),  # type: ignore[arg-type]
                       lam=base.lam, generalized=base.generalized, unique=base.unique, rank=base.rank)


def _parts(x: Array | Dual) -> tuple[Array, Array]:
    """A block's value and tangent (zero for a plain array)."""
    if isinstance(x, Dual):
        return x.value, x.tangent
    return x, np.zeros_like(x)


def rank_tolerance(rows: int, n: int) -> float:
    """The relative singular value of the mass-weighted constraint Jacobian J_w below which a direction counts as
    no constraint: √(max(rows, n) ε). The multipliers solve J_w J_wᵀ λ = r, whose eigenvalues are σ²; its entries
    carry round-off of about max(rows, n) ε σ_max² (a sum of that many products), so an eigenvalue σ² below that
    is indistinguishable from zero, and dividing by it would give λ round-off / round-off. The same bound says
    whether a row's unit vector has a part in the left null space (its multiplier then is not unique)."""
    return float(np.sqrt(max(rows, n) * np.finfo(float).eps))


@dataclass(frozen=True)
class Constrained:
    """The KKT system's solution at states (..., n): ``qdd`` q̈ (unique: M is positive definite), ``lam`` the
    least-norm multipliers (..., rows), ``generalized`` Jᵀλ (..., n: unique, whatever the rank), ``unique`` which
    rows' multipliers are unique (..., rows: False for a redundant row, whose λ any split among its dependent rows
    satisfies, e.g. MuJoCo's regularized one), ``rank`` the number of independent constraint directions (...)."""

    qdd: Array
    lam: Array
    generalized: Array
    unique: Array
    rank: Array
