"""The water's acceleration on a body: Froude-Krylov and the added mass's reaction, written once.

Each function here is the only implementation of its law; the compiled kernels
(:func:`aiauv_pin.kernels.articulated_body.body_bias`, the derivatives of
:mod:`aiauv_pin.kernels.tangent_rnea`) and the Pinocchio reference
(:meth:`aiauv_pin.Vehicle.fluid_forces`, :mod:`aiauv_pin.model.derivatives`) call them.

Derivation (docs/source/unsteady_flow.md has it in full). A body ``b`` with twist ``nu`` in body
axes moves in water of velocity ``V(t, x)`` and material acceleration ``a = DV/Dt`` (world axes,
:mod:`aiauv_hydro.currents`), both sampled at its probe point
(:attr:`aiauv_hydro.laws.fluid_terms.FluidModel.current_probe`). With ``v_c = R^T V`` and
``nu_r = nu - (v_c, 0)`` (Fossen 2021, eq. (10.4)), the added-mass wrench on the left-hand side is
``M_A d/dt nu_r + C_A(nu_r) nu_r`` (Fossen 2021, eq. (10.5); ``C_A(nu_r) nu_r`` is
:func:`aiauv_hydro.laws.fluid_terms.coriolis_wrench`). In body axes,

    ``d/dt v_c = R^T a - omega x v_c``,

so ``M_A d/dt nu_r = M_A nu_dot + M_A (omega x v_c, 0) - M_A (R^T a, 0)``: the first term is in the
mass matrix, the second is :func:`aiauv_hydro.laws.fluid_terms.current_acceleration_wrench` (there
since the constant current, exact for it), the third is the added mass's reaction to the water's
acceleration, new here. For a uniform current ``a = dV/dt`` is exact; in a non-uniform flow the
derivative of the water's velocity along the body's path differs from ``DV/Dt`` by
``((v - V) . grad) V``; for a body in a weakly non-uniform inviscid flow, the force of Auton,
Hunt and Prud'homme (1988, *J. Fluid Mech.* 197, 241-257), ``C_a rho Vol (DV/Dt - dv/dt)``, takes
the material derivative: so does this law.

The pressure gradient that accelerates the water, ``-grad p = rho (DV/Dt - g)`` (Euler's
equation), also pushes the displaced volume: ``rho Vol (DV/Dt - g)`` at its centroid, the centre of
buoyancy ``c_B``. The ``-g`` part is the buoyancy (:func:`aiauv_hydro.laws.fluid_terms.hydrostatic_wrench`);
the rest is the Froude-Krylov force ``rho Vol R^T a`` with the moment ``c_B x rho Vol R^T a``
(DNV-RP-C205, 2021, Sec. 6.2, Morison's load formula: the ``1`` of ``C_M = 1 + C_A``). Together,
the wrench of the water's acceleration on body ``b`` is

    ``w_b = (M_F + M_A)[:, :3] R^T a``,   ``M_F[:, :3] = (rho Vol I, rho Vol [c_B])``

(``M_F`` the rigid-body inertia of the displaced water, Fossen 2021, eq. (3.44) form): for a
cylinder in crossflow (``C_a = 1``) it is Morison's inertia force ``rho A C_M dU/dt`` per metre with
``C_M = 1 + C_a = 2`` (Morison et al. 1950; DNV-RP-C205, Sec. 6.2); for a neutrally buoyant
body with ``M_RB = M_F`` it makes the body move with a uniformly accelerating flow.

A uniform steady current gives ``a = 0`` and nothing is added (the constant-current results stay
bit-identical); the quasi-steady model (``Current(..., unsteady=False)``) samples ``a = 0``.
"""

from __future__ import annotations

from aiauv_hydro.laws.fluid_terms import current_in_body
from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3


@compiled(fastmath=True)
def flow_acceleration_wrench(added_mass, displaced, b, a0, a1, a2):
    """``(M_F + M_A)[:, :3] a``: the wrench of the water's acceleration on body ``b``.

    Froude-Krylov ``(m_F a, m_F c_B x a)`` plus the added mass's reaction ``M_A[:, :3] a``
    (see the module docstring; DNV-RP-C205, Sec. 6.2: ``C_M = 1 + C_A``).

    Args:
        added_mass: ``M_A`` of each body about its origin, body axes (nb, 6, 6).
        displaced: ``(m_F, m_F c_B)`` of each body (nb, 4) [kg, kg m]: the displaced water's mass
            ``rho Vol`` and first moment about the body origin, body axes.
        b: Body index.
        a0, a1, a2: The water's acceleration at the body's probe point, body axes [m/s^2].

    Returns:
        The wrench acting on the body, 6 floats [N, N m] (minus it on the left-hand side).
    """
    m = displaced[b, 0]
    c0, c1, c2 = cross3(displaced[b, 1], displaced[b, 2], displaced[b, 3], a0, a1, a2)
    return (
        m * a0 + added_mass[b, 0, 0] * a0 + added_mass[b, 0, 1] * a1 + added_mass[b, 0, 2] * a2,
        m * a1 + added_mass[b, 1, 0] * a0 + added_mass[b, 1, 1] * a1 + added_mass[b, 1, 2] * a2,
        m * a2 + added_mass[b, 2, 0] * a0 + added_mass[b, 2, 1] * a1 + added_mass[b, 2, 2] * a2,
        c0 + added_mass[b, 3, 0] * a0 + added_mass[b, 3, 1] * a1 + added_mass[b, 3, 2] * a2,
        c1 + added_mass[b, 4, 0] * a0 + added_mass[b, 4, 1] * a1 + added_mass[b, 4, 2] * a2,
        c2 + added_mass[b, 5, 0] * a0 + added_mass[b, 5, 1] * a1 + added_mass[b, 5, 2] * a2,
    )


@compiled(fastmath=True, borrows_only=True)
def add_flow_acceleration_bias(fluid, rotation, acceleration, bias):
    """``bias_b -= (M_F + M_A)[:, :3] R_b^T a_b`` for every body whose water accelerates.

    Bodies with ``a_b = 0`` (a constant current, still water, the quasi-steady model) are skipped,
    so their bias is bit for bit what it was without this law.

    Args:
        fluid: The vehicle's :class:`aiauv_hydro.laws.fluid_terms.FluidModel`.
        rotation: Body-to-world rotations (nb, 3, 3).
        acceleration: The water's acceleration ``DV/Dt`` at each body's probe point, world axes
            (nb, 3) [m/s^2].
        bias: Accumulator (nb, 6) [N, N m] (left-hand side).
    """
    added, displaced = fluid.added_mass, fluid.displaced
    for b in range(acceleration.shape[0]):
        if acceleration[b, 0] == 0.0 and acceleration[b, 1] == 0.0 and acceleration[b, 2] == 0.0:
            continue
        a0, a1, a2 = current_in_body(rotation, acceleration, b)
        w = flow_acceleration_wrench(added, displaced, b, a0, a1, a2)
        for i in range(6):
            bias[b, i] -= w[i]


@compiled(fastmath=True, borrows_only=True)
def add_flow_acceleration_rotation_jacobian(fluid, rotation, acceleration, d_rotation):
    """``d_rotation_b += d/dtheta_b`` of :func:`add_flow_acceleration_bias`: ``-G_b [R_b^T a_b]``.

    With ``G_b = (M_F + M_A)[:, :3]`` and a rotation ``R_b exp([d theta])`` of the body (its own
    axes), ``R^T a`` changes by ``-d theta x R^T a = [R^T a] d theta`` (``[x] y = x x y``), as
    the current and the up axis do (:mod:`aiauv_pin.kernels.tangent_rnea`). For a current uniform
    in space the water's acceleration depends on neither the body's position nor its velocity,
    so this is the law's whole derivative.

    Args:
        fluid: The vehicle's :class:`aiauv_hydro.laws.fluid_terms.FluidModel`.
        rotation: Body-to-world rotations (nb, 3, 3).
        acceleration: The water's acceleration at each probe, world axes (nb, 3) [m/s^2].
        d_rotation: Accumulator (nb, 6, 3) [N, N m]: ``d bias_b / d theta_b``.
    """
    added, displaced = fluid.added_mass, fluid.displaced
    for b in range(acceleration.shape[0]):
        if acceleration[b, 0] == 0.0 and acceleration[b, 1] == 0.0 and acceleration[b, 2] == 0.0:
            continue
        a0, a1, a2 = current_in_body(rotation, acceleration, b)
        # column j of G [a] is G (a x e_j); the wrench is linear in its acceleration argument
        for j in range(3):
            e0, e1, e2 = cross3(a0, a1, a2, 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0,
                                1.0 if j == 2 else 0.0)  # fmt: skip
            w = flow_acceleration_wrench(added, displaced, b, e0, e1, e2)
            for i in range(6):
                d_rotation[b, i, j] -= w[i]
