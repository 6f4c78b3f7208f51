"""Exactly rounded sums of long arrays, in compiled code.

:func:`exact_partials` reduces an array to Shewchuk's non-overlapping partial sums: a few floats
whose exact sum is the exact sum of the array (Shewchuk 1997, "Adaptive precision floating-point
arithmetic and fast robust geometric predicates", Discrete Comput. Geom. 18, Sec. 2.3: Grow-Expansion
with error-free Two-Sum). It is the first stage of Python's ``math.fsum``, which cites the same
paper; ``math.fsum`` of the partials then rounds their exact sum correctly, so
``math.fsum(partials) == math.fsum(array)`` bit for bit (:func:`aiauv_pin.simulation.energy.exact_sum`). The
loop runs in compiled code; ``math.fsum`` over a 75 000-step log goes through a Python list.

No fast-math: reassociation would undo the error-free transformations.
"""

from __future__ import annotations

import math

import numpy as np

from aiauv_hydro.numerics.jit import compiled

#: Room for the partials: a double's exponent range holds at most about 2098 / 53 + 1 = 41
#: non-overlapping components (Shewchuk 1997, Sec. 2.2); more means "give up, use math.fsum".
PARTIALS = 64


@compiled(borrows_only=True)
def exact_partials(values, partials) -> int:
    """Non-overlapping partials of the sum of ``values`` (1-D float64) into ``partials``.

    Returns:
        How many partials were written (their exact sum is the exact sum of ``values``), or -1 if
        a value or an intermediate sum is not finite or the buffer is too small (then
        ``math.fsum`` of the values decides: infinity, NaN, or its overflow error).
    """
    n = 0
    for index in range(values.shape[0]):
        x = values[index]
        if not math.isfinite(x):
            return -1
        i = 0
        for j in range(n):
            y = partials[j]
            if abs(x) < abs(y):
                x, y = y, x
            high = x + y  # Two-Sum: high + low == x + y exactly (|x| >= |y|)
            if not math.isfinite(high):
                return -1
            low = y - (high - x)
            if low != 0.0:
                partials[i] = low
                i += 1
            x = high
        if i >= partials.shape[0]:
            return -1
        partials[i] = x
        n = i + 1
    return n


def exact_sum_compiled(values: np.ndarray) -> float:
    """``math.fsum(values)`` for a 1-D float64 array, through :func:`exact_partials`."""
    partials = np.empty(PARTIALS)
    n = exact_partials(values, partials)
    if n < 0:
        return math.fsum(values.tolist())
    return math.fsum(partials[:n].tolist())
