"""Dual numbers over complex arrays, a + b ε with ε² = 0 and ε commuting with i: forward-mode derivatives of code
that already differentiates by complex step inside.

The tree reference's equations of motion take their q-derivatives by complex step (:mod:`analytic.tree.dynamics`),
so q̈'s own derivative in q cannot be one more complex step: the two imaginary parts would mix. A dual number's
ε is a second, independent infinitesimal: run the same code on y + ε e_j and the ε part of every result is its
exact derivative along e_j, while the complex steps inside stay in i (Im(a + b ε) = Im a + Im b ε, so the code's
``.imag / h`` reads the inner derivative of the value and of the tangent alike). No difference quotient is taken:
the tangent is exact to round-off.

:class:`Dual` holds the two parts as numpy arrays of one shape and takes part in numpy's protocols
(``__array_ufunc__``, ``__array_function__``, ``like=``) for exactly the operations the tree's code uses; any other
raises TypeError, never a silently wrong tangent (and numpy cannot turn one into a plain array: ``__array__``
raises). Code that allocates an array and fills it passes ``like=`` its input, so that it allocates a Dual when
given one; on ordinary arrays nothing changes, to the bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.lib.mixins import NDArrayOperatorsMixin

__all__ = ["Dual", "seeded", "tangent"]

Array = np.ndarray


class Dual(NDArrayOperatorsMixin):
    """value + tangent · ε, arrays of one shape (real or complex)."""

    __slots__ = ("tangent", "value")

    def __init__(self, value: Array, tangent: Array) -> None:
        value, tangent = np.asarray(value), np.asarray(tangent)
        if value.shape != tangent.shape:
            raise ValueError(f"a dual number's value {value.shape} and tangent {tangent.shape} differ in shape")
        self.value, self.tangent = value, tangent

    def __repr__(self) -> str:
        return f"Dual({self.value!r}, {self.tangent!r})"

    def __array__(self, *args, **kwargs):
        raise TypeError("a dual number cannot become a plain array: its tangent would be lost")

    # ---- the ndarray attributes the code reads -----------------------------------------------------
    @property
    def shape(self) -> tuple[int, ...]:
        return self.value.shape

    @property
    def ndim(self) -> int:
        return self.value.ndim

    @property
    def size(self) -> int:
        return self.value.size

    @property
    def dtype(self) -> np.dtype:
        return np.result_type(self.value.dtype, self.tangent.dtype)

    @property
    def real(self) -> Dual:
        return Dual(self.value.real, self.tangent.real)

    @property
    def imag(self) -> Dual:
        return Dual(self.value.imag, self.tangent.imag)

    def __len__(self) -> int:
        return len(self.value)

    def __getitem__(self, key) -> Dual:
        return Dual(self.value[key], self.tangent[key])

    def __setitem__(self, key, item) -> None:
        value, tangent = _parts(item)
        if (np.iscomplexobj(value) and not np.iscomplexobj(self.value)) or \
                (tangent is not None and np.iscomplexobj(tangent) and not np.iscomplexobj(self.tangent)):
            raise TypeError("complex parts set into a real dual number would lose their imaginary part")
        self.value[key] = value
        self.tangent[key] = 0.0 if tangent is None else tangent

    def copy(self) -> Dual:
        return Dual(self.value.copy(), self.tangent.copy())

    def astype(self, dtype) -> Dual:
        return Dual(self.value.astype(dtype), self.tangent.astype(dtype))

    def reshape(self, *shape) -> Dual:
        return Dual(self.value.reshape(*shape), self.tangent.reshape(*shape))

    # ---- numpy's protocols ----------------------------------------------------------------------------
    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs, **kwargs):
        rule = _UFUNCS.get(ufunc)
        if method != "__call__" or kwargs or rule is None:
            raise TypeError(f"no dual-number rule for {ufunc.__name__}.{method}"
                            + (f" with {sorted(kwargs)}" if kwargs else ""))
        return rule(*inputs)

    def __array_function__(self, func, types, args, kwargs):
        rule = _FUNCTIONS.get(func)
        if rule is None:
            raise TypeError(f"no dual-number rule for numpy.{func.__name__}")
        return rule(*args, **kwargs)


def _parts(x) -> tuple[Array, Array | None]:
    """(value, tangent) of a dual number, (x, None) of anything else (a constant: tangent zero)."""
    if isinstance(x, Dual):
        return x.value, x.tangent
    return x, None


def _sum(*terms: Array | None) -> Array | None:
    present = [t for t in terms if t is not None]
    if not present:
        return None
    out = present[0]
    for t in present[1:]:
        out = out + t
    return out


def _dual(value: Array, tangent: Array | None) -> Dual:
    value = np.asarray(value)
    if tangent is None:
        return Dual(value, np.zeros_like(value))
    tangent = np.asarray(tangent)
    if tangent.shape != value.shape:
        value, tangent = np.broadcast_arrays(value, tangent)
        value, tangent = value.copy(), tangent.copy()
    return Dual(value, tangent)


# ---- ufuncs: the value by numpy, the tangent by the derivative's rule ------------------------------------
def _add(a, b):
    (av, at), (bv, bt) = _parts(a), _parts(b)
    return _dual(av + bv, _sum(at, bt))


def _subtract(a, b):
    (av, at), (bv, bt) = _parts(a), _parts(b)
    return _dual(av - bv, _sum(at, None if bt is None else -bt))


def _multiply(a, b):
    (av, at), (bv, bt) = _parts(a), _parts(b)
    return _dual(av * bv, _sum(None if at is None else at * bv, None if bt is None else av * bt))


def _divide(a, b):
    (av, at), (bv, bt) = _parts(a), _parts(b)
    value = av / bv
    return _dual(value, _sum(None if at is None else at / bv, None if bt is None else -(value * bt) / bv))


def _matmul(a, b):
    (av, at), (bv, bt) = _parts(a), _parts(b)
    return _dual(av @ bv, _sum(None if at is None else at @ bv, None if bt is None else av @ bt))


def _power(a, k):
    if isinstance(k, Dual):
        raise TypeError("no dual-number rule for a dual exponent")
    av, at = _parts(a)
    if np.ndim(k) or at is None:
        raise TypeError("dual powers take a dual base and a scalar exponent")
    if k == 0:
        return _dual(av ** k, None)
    return _dual(av ** k, k * av ** (k - 1) * at)


def _unary(value: Callable[[Array], Array], slope: Callable[[Array, Array], Array]):
    """A rule for f(a): f(value), f′(value) · tangent, ``slope(value, f(value))`` giving f′."""
    def rule(a):
        av, at = _parts(a)
        out = value(av)
        return _dual(out, slope(av, out) * at)
    return rule


def _absolute(a):
    av, at = _parts(a)
    if np.iscomplexobj(av):
        raise TypeError("no dual-number rule for |z| of a complex z (not analytic)")
    return _dual(np.abs(av), np.sign(av) * at)


def _compare(ufunc: np.ufunc):
    """Comparisons see the values alone (a branch taken by the value keeps its slope)."""
    def rule(a, b):
        return ufunc(_parts(a)[0], _parts(b)[0])
    return rule


def _isfinite(a):
    av, at = _parts(a)
    return np.isfinite(av) & np.isfinite(at)


_UFUNCS: dict[np.ufunc, Callable] = {
    np.add: _add, np.subtract: _subtract, np.multiply: _multiply, np.true_divide: _divide, np.matmul: _matmul,
    np.power: _power, np.negative: lambda a: Dual(-a.value, -a.tangent), np.positive: lambda a: a.copy(),
    np.sin: _unary(np.sin, lambda v, _: np.cos(v)), np.cos: _unary(np.cos, lambda v, _: -np.sin(v)),
    np.sqrt: _unary(np.sqrt, lambda _, s: 0.5 / s), np.absolute: _absolute, np.isfinite: _isfinite,
    **{f: _compare(f) for f in (np.less, np.less_equal, np.greater, np.greater_equal, np.equal, np.not_equal)},
}


# ---- numpy functions: linear ones act on both parts alike -------------------------------------------------
def _linear(func: Callable) -> Callable:
    def rule(a, *args, **kwargs):
        av, at = _parts(a)
        return _dual(func(av, *args, **kwargs), None if at is None else func(at, *args, **kwargs))
    return rule


def _joined(func: Callable) -> Callable:
    """concatenate/stack: constants among the arrays get zero tangents."""
    def rule(arrays, *args, dtype=None, **kwargs):
        parts = [_parts(x) for x in arrays]
        values = [v for v, _ in parts]
        tangents = [np.zeros(np.shape(v)) if t is None else t for v, t in parts]
        return Dual(func(values, *args, dtype=dtype, **kwargs), func(tangents, *args, dtype=dtype, **kwargs))
    return rule


def _allocate(func: Callable) -> Callable:
    """zeros/empty with ``like=`` a dual number: a dual number of zeros (its tangent zero, whatever is set later)."""
    def rule(shape, dtype=float, **kwargs):
        return Dual(func(shape, dtype=dtype, **kwargs), np.zeros(shape, dtype=dtype))
    return rule


def _like_array(a, dtype=None, *, copy=True, **kwargs):
    av, at = _parts(a)
    value = np.array(av, dtype=dtype, copy=True, **kwargs)
    return Dual(value, np.zeros_like(value) if at is None else np.array(at, dtype=dtype, copy=True, **kwargs))


def _zeros_like(a, dtype=None, **kwargs):
    value = np.zeros_like(_parts(a)[0], dtype=dtype, **kwargs)
    return Dual(value, np.zeros_like(value))


def _broadcast_to(a, shape, **kwargs):
    av, at = _parts(a)
    return Dual(np.broadcast_to(av, shape, **kwargs),
                np.broadcast_to(np.zeros((), dtype=av.dtype) if at is None else at, shape, **kwargs))


def _broadcast_arrays(*arrays, **kwargs):
    shape = np.broadcast_shapes(*(np.shape(x) for x in arrays))
    return tuple(_broadcast_to(x, shape, **kwargs) if isinstance(x, Dual) else np.broadcast_to(x, shape, **kwargs)
                 for x in arrays)


def _where(condition, x, y):
    if isinstance(condition, Dual):
        raise TypeError("a dual number cannot be a condition")
    (xv, xt), (yv, yt) = _parts(x), _parts(y)
    value = np.where(condition, xv, yv)
    if xt is None and yt is None:
        return _dual(value, None)
    return _dual(value, np.where(condition, 0.0 if xt is None else xt, 0.0 if yt is None else yt))


def _einsum(subscripts, *operands, **kwargs):
    """The product rule over every dual operand (einsum is linear in each)."""
    parts = [_parts(x) for x in operands]
    values = [v for v, _ in parts]
    terms = [np.einsum(subscripts, *values[:i], t, *values[i + 1:], **kwargs)
             for i, (_, t) in enumerate(parts) if t is not None]
    return _dual(np.einsum(subscripts, *values, **kwargs), _sum(*terms))


_FUNCTIONS: dict[Callable, Callable] = {
    np.zeros: _allocate(np.zeros), np.empty: _allocate(np.empty), np.array: _like_array, np.copy: _like_array,
    np.zeros_like: _zeros_like, np.concatenate: _joined(np.concatenate), np.stack: _joined(np.stack),
    np.shape: lambda a: a.shape, np.ndim: lambda a: a.ndim, np.broadcast_to: _broadcast_to,
    np.broadcast_arrays: _broadcast_arrays, np.where: _where, np.einsum: _einsum,
    **{f: _linear(f) for f in (np.swapaxes, np.moveaxis, np.reshape, np.transpose, np.sum, np.trace)},
}


def seeded(y: Array, directions: Array) -> Dual:
    """The batch of dual numbers y + ε d, one per row d of ``directions`` (k, size): evaluated at once, the tangent
    of the k-th result is the derivative along the k-th direction."""
    directions = np.asarray(directions, dtype=float)
    return Dual(np.broadcast_to(np.asarray(y, dtype=float), directions.shape).copy(), directions.copy())


def tangent(x: object) -> Array:
    """The tangent of a result; TypeError where it is no dual number (code that dropped its seeds' tangents would
    otherwise read as a zero derivative)."""
    if not isinstance(x, Dual):
        raise TypeError(f"a {type(x).__name__} where a dual number was expected: its derivative would read as zero")
    return x.tangent
