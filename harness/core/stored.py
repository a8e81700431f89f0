"""Values as plain data (JSON), for the on-disk cache: nothing read back can run code.

A cache anyone else could write (a shared machine, a CI cache restored from elsewhere) must never be a
way into the user's process, so entries hold data only, read back through a closed vocabulary:

- JSON's own values (numbers, including NaN and ±Infinity; strings; booleans; null), lists, and tagged
  tuples and dicts;
- numpy arrays and scalars of a few numeric dtypes, as their raw bytes (base64);
- the dataclasses of :data:`CLASSES` only, rebuilt from their fields by their constructor;
- sympy expressions as a tree of nodes from a closed list (symbols with their assumptions, integers,
  rationals, floats, the named constants, and Add, Mul, Pow and the elementary functions of
  :data:`FUNCTIONS`); never sympy's ``sympify``/``parse_expr``, which evaluate text.

Anything else (an unknown tag, class, dtype or node) raises ``ValueError``: the caller treats the entry as
absent. Lambdify's source inside :class:`analytic.dynamics.Compiled` is a string here; it runs only after
``analytic.dynamics`` has checked it is arithmetic on numpy's functions (``_checked_source``).
"""

from __future__ import annotations

import base64
import dataclasses
import json
import math
from typing import Any

import numpy as np

__all__ = ["dumps", "loads"]

DTYPES = ("float64", "float32", "int64", "int32", "int8", "uint8", "bool")
# sympy functions an entry may name (applied to its arguments, as sympy builds them)
FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log", "Abs",
             "sign", "sqrt", "Min", "Max")
CONSTANTS = ("Zero", "One", "NegativeOne", "Half", "Pi", "Exp1", "Infinity", "NegativeInfinity", "NaN")
OPERATORS = ("Add", "Mul", "Pow")


def _classes() -> dict[str, type]:
    """The dataclasses an entry may hold, by name (a closed list: nothing else is ever constructed)."""
    from analytic import dop853, radau  # lazy: only where an entry holds a solution
    from analytic.dynamics import Compiled  # lazy: as above, for numeric dynamics

    return {"Compiled": Compiled, "dop853.Dense": dop853.Dense, "radau.Dense": radau.Dense}


def _class_name(value: object) -> str | None:
    for name, cls in _classes().items():
        if type(value) is cls:
            return name
    return None


def dumps(value: object) -> bytes:
    """``value`` as JSON bytes; ValueError for anything outside the vocabulary."""
    return json.dumps(_encode(value), separators=(",", ":"), sort_keys=True).encode()


def loads(data: bytes) -> object:
    """The value :func:`dumps` wrote; ValueError for anything else."""
    try:
        tree = json.loads(data)
    except (ValueError, RecursionError) as exc:
        raise ValueError(f"not a stored value: {exc}") from None
    try:
        return _decode(tree)
    except (TypeError, KeyError, IndexError, RecursionError, AttributeError) as exc:
        raise ValueError(f"not a stored value: {type(exc).__name__}: {exc}") from None


def _encode(value: object) -> Any:
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int) and type(value) is int:
        return value
    if type(value) is float:
        return value if math.isfinite(value) else {"$": "float", "v": repr(value)}
    if isinstance(value, np.ndarray):
        if value.dtype.name not in DTYPES:
            raise ValueError(f"an array of dtype {value.dtype} is not stored")
        data = np.array(value, order="C")  # (ascontiguousarray makes a 0-d array 1-d)
        return {"$": "array", "dtype": data.dtype.name, "shape": list(data.shape),
                "data": base64.b64encode(data.tobytes()).decode()}
    if isinstance(value, np.generic):
        return {"$": "scalar", "v": _encode(np.asarray(value))}
    if isinstance(value, tuple):
        return {"$": "tuple", "v": [_encode(v) for v in value]}
    if isinstance(value, list):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        return {"$": "dict", "v": [[_encode(k), _encode(v)] for k, v in value.items()]}
    name = _class_name(value)
    if name is not None:
        return {"$": "obj", "type": name,
                "v": {f.name: _encode(getattr(value, f.name)) for f in dataclasses.fields(value)}}  # type: ignore[arg-type]
    return {"$": "sympy", "v": _sympy_tree(value)}


def _decode(tree: Any) -> object:
    if tree is None or isinstance(tree, (bool, str, int, float)):
        return tree
    if isinstance(tree, list):
        return [_decode(v) for v in tree]
    if not isinstance(tree, dict):
        raise ValueError(f"not a stored value: {type(tree).__name__}")
    tag = tree["$"]
    if tag == "float":
        if tree["v"] not in ("nan", "inf", "-inf"):
            raise ValueError(f"not a float: {tree['v']!r}")
        return float(tree["v"])
    if tag == "array":
        if tree["dtype"] not in DTYPES:
            raise ValueError(f"an array of dtype {tree['dtype']!r} is not read")
        shape = tuple(int(n) for n in tree["shape"])
        return np.frombuffer(base64.b64decode(tree["data"], validate=True), dtype=tree["dtype"]).reshape(shape).copy()
    if tag == "scalar":
        array = _decode(tree["v"])
        if not isinstance(array, np.ndarray) or array.shape != ():
            raise ValueError("not a numpy scalar")
        return array[()]
    if tag == "tuple":
        return tuple(_decode(v) for v in tree["v"])
    if tag == "dict":
        return {_decode(k): _decode(v) for k, v in tree["v"]}
    if tag == "obj":
        cls = _classes().get(tree["type"])
        if cls is None:
            raise ValueError(f"an object of type {tree['type']!r} is not read")
        names = {f.name for f in dataclasses.fields(cls)}
        fields = tree["v"]
        if not isinstance(fields, dict) or not set(fields) <= names:
            raise ValueError(f"not the fields of {tree['type']}")
        return cls(**{k: _decode(v) for k, v in fields.items()})
    if tag == "sympy":
        return _sympy_value(tree["v"])
    raise ValueError(f"not a stored value: tag {tag!r}")


def _sympy_tree(value: object) -> Any:
    """A sympy expression or matrix as nested lists [kind, ...]; ValueError for anything outside the
    vocabulary."""
    import sympy as sp  # lazy: only a symbolic value gets here, and sympy is then loaded already
    from sympy.core.function import AppliedUndef  # lazy: as above

    if isinstance(value, sp.MatrixBase):
        return ["matrix", value.rows, value.cols, [_sympy_tree(e) for e in value]]
    if not isinstance(value, sp.Basic):
        raise ValueError(f"a {type(value).__name__} is not stored")
    if isinstance(value, sp.Symbol) and type(value) is sp.Symbol:
        return ["symbol", value.name, {k: v for k, v in sorted(value._assumptions_orig.items())}]
    for name in CONSTANTS:
        if value is getattr(sp.S, name):
            return ["constant", name]
    if isinstance(value, sp.Integer):
        return ["integer", str(int(value))]
    if isinstance(value, sp.Rational):
        return ["rational", str(value.p), str(value.q)]
    if isinstance(value, sp.Float):
        sign, mantissa, exponent, bits = value._mpf_
        return ["float", sign, str(mantissa), exponent, bits, value._prec]
    name = type(value).__name__
    if name in OPERATORS or name in FUNCTIONS:
        return ["apply", name, [_sympy_tree(a) for a in value.args]]
    if isinstance(value, AppliedUndef):
        return ["undefined", name, [_sympy_tree(a) for a in value.args]]
    if isinstance(value, sp.Derivative):
        return ["derivative", _sympy_tree(value.expr), [[_sympy_tree(v), int(n)] for v, n in value.variable_count]]
    raise ValueError(f"a sympy {name} is not stored")


def _sympy_value(tree: Any) -> object:
    """The expression :func:`_sympy_tree` wrote, built node by node (no text is parsed)."""
    import sympy as sp  # lazy: only a symbolic entry needs sympy

    kind = tree[0]
    if kind == "matrix":
        rows, cols = int(tree[1]), int(tree[2])
        return sp.Matrix(rows, cols, [_sympy_value(e) for e in tree[3]])
    if kind == "symbol":
        assumptions = tree[2]
        if not isinstance(tree[1], str) or not all(isinstance(v, bool) for v in assumptions.values()):
            raise ValueError("not a symbol")
        return sp.Symbol(tree[1], **assumptions)
    if kind == "constant":
        if tree[1] not in CONSTANTS:
            raise ValueError(f"not a constant: {tree[1]!r}")
        return getattr(sp.S, tree[1])
    if kind == "integer":
        return sp.Integer(_digits(tree[1]))
    if kind == "rational":
        return sp.Rational(_digits(tree[1]), _digits(tree[2]))
    if kind == "float":
        sign, mantissa, exponent, bits, prec = tree[1:]
        if not all(type(v) is int for v in (sign, exponent, bits, prec)) or abs(exponent) > 10**6 or prec > 10**4:
            raise ValueError("not a float")
        return sp.Float._new((sign, _digits(mantissa), exponent, bits), prec)
    if kind == "apply":
        name = tree[1]
        if name not in OPERATORS and name not in FUNCTIONS:
            raise ValueError(f"not a function of the vocabulary: {name!r}")
        args = [_sympy_value(a) for a in tree[2]]
        return getattr(sp, name)(*args, evaluate=False)
    if kind == "undefined":
        if not isinstance(tree[1], str) or not tree[1].isidentifier():
            raise ValueError("not a function name")
        return sp.Function(tree[1])(*[_sympy_value(a) for a in tree[2]])
    if kind == "derivative":
        return sp.Derivative(_sympy_value(tree[1]), *[(_sympy_value(v), int(n)) for v, n in tree[2]])
    raise ValueError(f"not a sympy node: {kind!r}")


def _digits(text: object) -> int:
    """An integer written in decimal, of a bounded length (no number-parsing surprises)."""
    if not isinstance(text, str) or len(text) > 4000 or not text.lstrip("-").isdigit():
        raise ValueError("not an integer")
    return int(text)
