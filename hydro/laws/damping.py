"""Hydrodynamic damping wrenches on links, batched over links.

Linear and quadratic damping follow Fossen 2021, eq. (6.60)-(6.62) in the form
``tau_D = -D_L nu_r - D_Q (|nu_r| * nu_r)`` (element-wise absolute value and product), with ``nu_r`` the
link's twist relative to the water (Fossen 2021, eq. (10.4)). Slender links add strip-theory crossflow
drag (:mod:`aiauv_hydro.laws.crossflow`).
"""

from __future__ import annotations

import numpy as np

from aiauv_hydro.laws import fluid_terms as laws


def linear_quadratic_wrench(
    linear: np.ndarray, quadratic: np.ndarray, relative_twist: np.ndarray
) -> np.ndarray:
    """Damping wrench ``-D_L nu_r - D_Q (|nu_r| * nu_r)`` acting on each link.

    Args:
        linear: ``D_L`` per link, shape (n, 6, 6).
        quadratic: ``D_Q`` per link, shape (n, 6, 6).
        relative_twist: ``nu_r`` per link in its frame, shape (n, 6) [m/s, rad/s].

    Returns:
        Wrenches on the links in their frames, shape (n, 6) [N, N m].
    """
    wrench = np.empty(relative_twist.shape)
    for k in range(relative_twist.shape[0]):
        quadratic_k = np.ascontiguousarray(quadratic[k], dtype=float)
        diagonal = not np.any(quadratic_k - np.diag(np.diag(quadratic_k)))
        wrench[k] = laws.damping_wrench(  # the one implementation of the law
            np.ascontiguousarray(linear[k], dtype=float),
            quadratic_k,
            diagonal,
            np.ascontiguousarray(relative_twist[k], dtype=float),
        )
    return wrench
