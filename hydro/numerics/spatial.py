"""Spatial (6-D) vector algebra used by the hydrodynamic models and the compiled kernels.

Twists are ``(v, omega)`` and wrenches ``(f, n)``: linear part first, the order of Pinocchio's
``Motion.vector`` and ``Force.vector`` and of Fossen's ``nu`` and ``tau`` (Featherstone 2008, Ch. 2).

The products are written once, on scalars, and compiled
(:func:`aiauv_hydro.numerics.jit.compiled`): the compiled
kernels call them from compiled code, where LLVM inlines them (so they cost what the unrolled
formulas cost), and the batched NumPy helpers below call their interpreted form on arrays.

The rule a base-orientation quaternion must pass, :func:`unit_quaternion_check`, is here too, written
once for the argument checks made in Python and those made in compiled code.
"""

from __future__ import annotations

import math

import numpy as np

from aiauv_hydro.numerics.jit import compiled, interpreted


# ---------------------------------------------------------------------- on scalars (compiled)
@compiled
def cross3(a0, a1, a2, b0, b1, b2):
    """Cross product ``a x b = S(a) b`` of two 3-vectors given by their components, 3 values
    (Fossen 2021, eq. (2.10)); the components may be floats or NumPy arrays (element-wise)."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@compiled
def motion_cross(v0, v1, v2, w0, w1, w2, m0, m1, m2, m3, m4, m5):
    """Spatial cross product of motions ``(v, w) x (m_v, m_w) = (w x m_v + v x m_w, w x m_w)``
    (Featherstone 2008, eq. (2.31)), 6 floats."""
    a0, a1, a2 = cross3(w0, w1, w2, m0, m1, m2)
    b0, b1, b2 = cross3(v0, v1, v2, m3, m4, m5)
    c0, c1, c2 = cross3(w0, w1, w2, m3, m4, m5)
    return a0 + b0, a1 + b1, a2 + b2, c0, c1, c2


@compiled
def motion_to_child(placement, v0, v1, v2, w0, w1, w2):
    """A motion ``(v, w)`` of a parent frame in a child frame placed at ``(R, p)`` in it:
    ``X (v, w) = (R^T (v - p x w), R^T w)`` (Featherstone 2008, eq. (2.24)), 6 floats.

    Args:
        placement: The child's placement (4, 3): rows 0-2 the rotation ``R`` (child to parent),
            row 3 the origin ``p`` [m].
        v0, v1, v2, w0, w1, w2: The motion in parent axes at the parent origin [m/s, rad/s] (or
            [m/s^2, rad/s^2]).
    """
    p0, p1, p2 = placement[3, 0], placement[3, 1], placement[3, 2]
    c0, c1, c2 = cross3(p0, p1, p2, w0, w1, w2)
    e0, e1, e2 = v0 - c0, v1 - c1, v2 - c2
    r = placement
    return (
        r[0, 0] * e0 + r[1, 0] * e1 + r[2, 0] * e2,
        r[0, 1] * e0 + r[1, 1] * e1 + r[2, 1] * e2,
        r[0, 2] * e0 + r[1, 2] * e1 + r[2, 2] * e2,
        r[0, 0] * w0 + r[1, 0] * w1 + r[2, 0] * w2,
        r[0, 1] * w0 + r[1, 1] * w1 + r[2, 1] * w2,
        r[0, 2] * w0 + r[1, 2] * w1 + r[2, 2] * w2,
    )


@compiled(borrows_only=True)
def motion_transform_into(rotation, p0, p1, p2, out):
    """``X = [[R^T, -R^T [p]], [0, R^T]]`` into ``out`` (6, 6): the matrix of
    :func:`motion_to_child` (Featherstone 2008, eq. (2.24)).

    Args:
        rotation: ``R`` (child to parent), indexable as ``rotation[i][j]`` (a 3x3 array or a tuple
            of three rows).
        p0, p1, p2: The child's origin ``p`` in the parent frame [m].
        out: Output (6, 6).
    """
    for i in range(3):
        r0, r1, r2 = rotation[0][i], rotation[1][i], rotation[2][i]  # row i of R^T
        out[i, 0] = r0
        out[i, 1] = r1
        out[i, 2] = r2
        out[i + 3, 3] = r0
        out[i + 3, 4] = r1
        out[i + 3, 5] = r2
        out[i + 3, 0] = 0.0
        out[i + 3, 1] = 0.0
        out[i + 3, 2] = 0.0
        c0, c1, c2 = cross3(r0, r1, r2, p0, p1, p2)  # row i of R^T [p] is (R^T row i) x p
        out[i, 3] = -c0
        out[i, 4] = -c1
        out[i, 5] = -c2


#: Verdicts of :func:`unit_quaternion_check`: unit norm (use as is), near unit (divide by the
#: norm), or too far from unit (refuse).
QUATERNION_UNIT, QUATERNION_NORMALISE, QUATERNION_NOT_UNIT = 0, 1, 2


@compiled
def unit_quaternion_check(x, y, z, w, tolerance, exact_below):
    """The rule for a quaternion ``(x, y, z, w)`` that should have unit norm.

    The deviation ``| |q| - 1 |`` (the norm summed in the order ``x, y, z, w``, not fast-math, so
    that compiled and interpreted callers divide by the same bits): above ``tolerance`` the
    quaternion is refused, up to ``exact_below`` it is used as it is, in between it is divided by
    its norm. A non-finite quaternion has a non-finite deviation and is refused.

    Returns:
        ``(verdict, norm)``: one of :data:`QUATERNION_UNIT`, :data:`QUATERNION_NORMALISE`,
        :data:`QUATERNION_NOT_UNIT`, and the norm to divide by.
    """
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    deviation = abs(norm - 1.0)
    if not deviation <= tolerance:
        return QUATERNION_NOT_UNIT, norm
    if deviation <= exact_below:
        return QUATERNION_UNIT, norm
    return QUATERNION_NORMALISE, norm


# ---------------------------------------------------------------------- batched (NumPy)
def skew(vector: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``S(a)`` with ``S(a) b = a x b`` (Fossen 2021, eq. (2.10))."""
    x, y, z = np.asarray(vector, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (:func:`cross3` on arrays: ``np.cross`` costs ~10x more on
    small arrays)."""
    return np.stack(
        interpreted(cross3)(a[..., 0], a[..., 1], a[..., 2], b[..., 0], b[..., 1], b[..., 2]),
        axis=-1,
    )


def spatial_cross_wrench(twist: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """Spatial cross product ``twist x* wrench`` (Featherstone 2008, eq. (2.32)), batched.

    Args:
        twist: Twists ``(v, omega)``, shape (..., 6) [m/s, rad/s].
        wrench: Wrenches ``(f, n)``, shape (..., 6) [N, N m].

    Returns:
        ``(omega x f, v x f + omega x n)``, shape (..., 6).
    """
    v, omega = twist[..., :3], twist[..., 3:]
    f, n = wrench[..., :3], wrench[..., 3:]
    return np.concatenate((cross(omega, f), cross(v, f) + cross(omega, n)), axis=-1)


def motion_transform(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Matrix mapping twists of a frame A to a frame B placed at ``(R, p)`` in A.

    A point with B coordinates ``x_B`` has A coordinates ``R x_B + p``; a twist ``(v, w)`` of A at
    A's origin has B coordinates ``(R^T (v + w x p), R^T w)`` at B's origin (Featherstone 2008,
    eq. (2.24)). Wrenches go back with the transpose: ``f_A = X^T f_B``, and a generalised inertia
    moves as ``M_A = X^T M_B X``.

    Args:
        rotation: Orientation ``R`` of frame B in frame A (3x3).
        translation: Origin ``p`` of frame B in frame A [m].

    Returns:
        ``X`` (6x6) with ``nu_B = X nu_A`` (:func:`motion_transform_into`).
    """
    p0, p1, p2 = (float(x) for x in np.asarray(translation, dtype=float))
    transform = np.empty((6, 6))
    interpreted(motion_transform_into)(np.asarray(rotation, dtype=float), p0, p1, p2, transform)
    return transform
