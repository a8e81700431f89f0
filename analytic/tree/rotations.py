"""Rotations for the tree reference, written so that every function also takes complex arguments.

The tree reference differentiates its Lagrangian by complex step (f'(x) = Im f(x + ih)/h, exact to
round-off), which breaks silently through ``abs``, ``norm`` and ``conj``. So nothing here uses them:
angles enter through sin/cos of the coordinate itself, and the exponential map's coefficients are
power series in θ² = θ·θ (an analytic function of θ), never in |θ|.

Conventions (MuJoCo's): quaternions are (w, x, y, z); a rotation matrix R maps body-frame vectors to
the parent (world) frame; ``Exp(θ)`` is the rotation by |θ| about θ/|θ|; the body-frame angular
velocity of R(t) = R₀ Exp(θ(t)) is ω = J_r(θ) θ̇ (the right Jacobian of SO(3)).
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross", "exp_and_jacobian", "exp_map", "mat_t_vec", "mat_to_quat", "mat_vec", "quat_to_mat",
           "right_jacobian", "skew", "vee"]

Array = np.ndarray

_EYE = np.eye(3)


def _array(x: Array) -> Array:
    """x as an array: itself where it takes part in numpy's functions already (an array, or a
    :class:`~analytic.dual.Dual`, which ``np.asarray`` would turn into an object array)."""
    return x if hasattr(x, "__array_function__") else np.asarray(x)


def quat_to_mat(quat: Array) -> Array:
    """(..., 4) unit quaternions (w, x, y, z) -> (..., 3, 3) rotation matrices."""
    w, x, y, z = np.moveaxis(np.asarray(quat), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def mat_to_quat(mat: Array) -> Array:
    """(3, 3) rotation matrix -> unit quaternion (w, x, y, z) with w >= 0 (real input only)."""
    m = np.asarray(mat, dtype=float)
    trace = np.trace(m)
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = np.array([0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s])
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = np.empty(4)
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q = q / np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def skew(v: Array) -> Array:
    """(..., 3) -> (..., 3, 3) with skew(a) b = a × b (filled in place: this runs on tiny arrays, where numpy's
    stacking costs more than the arithmetic)."""
    v = _array(v)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    out = np.zeros((*v.shape[:-1], 3, 3), dtype=v.dtype, like=v)
    out[..., 0, 1], out[..., 0, 2] = -z, y
    out[..., 1, 0], out[..., 1, 2] = z, -x
    out[..., 2, 0], out[..., 2, 1] = -y, x
    return out


def cross(a: Array, b: Array) -> Array:
    """a × b over the last axis (3), broadcasting; by components into one array, which numpy's cross does with
    more copying (the same products and differences: the same bits)."""
    a, b = _array(a), _array(b)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a.dtype, b.dtype),
                   like=b if isinstance(a, np.ndarray) else a)
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def mat_vec(m: Array, v: Array) -> Array:
    """m v for (..., 3, 3) matrices and (..., 3) vectors, broadcasting: three products summed in order, without
    einsum's or matmul's per-call cost on tiny arrays."""
    return m[..., :, 0] * v[..., 0, None] + m[..., :, 1] * v[..., 1, None] + m[..., :, 2] * v[..., 2, None]


def mat_t_vec(m: Array, v: Array) -> Array:
    """mᵀ v for (..., 3, 3) matrices and (..., 3) vectors, as :func:`mat_vec`."""
    return m[..., 0, :] * v[..., 0, None] + m[..., 1, :] * v[..., 1, None] + m[..., 2, :] * v[..., 2, None]


def vee(m: Array) -> Array:
    """The vector of the skew-symmetric part of (..., 3, 3): vee(skew(a)) = a."""
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
                          axis=-1)


def axis_angle(axis: Array, angle: Array) -> Array:
    """Rotation matrices by ``angle`` (...) about the unit ``axis`` (3,) or (..., 3) (Rodrigues)."""
    angle = _array(angle)
    k = skew(np.broadcast_to(axis, (*angle.shape, 3)))
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


# Series of the exponential map's coefficients in t = θ·θ: a = sin θ/θ, b = (1 − cos θ)/θ², c = (θ − sin θ)/θ³.
# Below SERIES_T the truncated series is exact to round-off (next term < 1e-17 relative); above it the closed
# forms are used, with θ = sqrt(t) (analytic away from t = 0, so the complex step stays exact there).
SERIES_T = 1e-4


def _coefficients(t: Array) -> tuple[Array, Array, Array]:
    t = _array(t)
    small = np.abs(t.real) < SERIES_T
    if small.all():  # the branch every entry takes (a batch of complex steps shares its real part): that one alone
        return _series(t)
    safe = np.where(small, 1.0, t)
    if not small.any():
        return _closed(safe)
    series, closed = _series(t), _closed(safe)
    (s0, s1, s2), (c0, c1, c2) = series, closed
    return np.where(small, s0, c0), np.where(small, s1, c1), np.where(small, s2, c2)


def _series(t: Array) -> tuple[Array, Array, Array]:
    return (1 - t / 6 + t * t / 120 - t ** 3 / 5040, 0.5 - t / 24 + t * t / 720 - t ** 3 / 40320,
            1 / 6 - t / 120 + t * t / 5040 - t ** 3 / 362880)


def _closed(t: Array) -> tuple[Array, Array, Array]:
    theta = np.sqrt(t)
    sin = np.sin(theta)
    return sin / theta, (1 - np.cos(theta)) / t, (theta - sin) / (t * theta)


def exp_map(theta: Array) -> Array:
    """Exp(θ): (..., 3) rotation vectors -> (..., 3, 3) rotation matrices."""
    return exp_and_jacobian(theta)[0]


def right_jacobian(theta: Array) -> Array:
    """J_r(θ), (..., 3, 3): the body-frame angular velocity of R₀ Exp(θ(t)) is J_r(θ) θ̇."""
    theta = _array(theta)
    _, b, c = _coefficients(np.sum(theta * theta, axis=-1))
    k = skew(theta)
    return _EYE - b[..., None, None] * k + c[..., None, None] * (k @ k)


def exp_and_jacobian(theta: Array) -> tuple[Array, Array]:
    """Exp(θ) and J_r(θ) together, (..., 3, 3) each: one skew, one square and one set of coefficients for both."""
    theta = _array(theta)
    a, b, c = _coefficients(np.sum(theta * theta, axis=-1))
    k = skew(theta)
    kk = k @ k
    a, b, c = a[..., None, None], b[..., None, None], c[..., None, None]
    return _EYE + a * k + b * kk, _EYE - b * k + c * kk
