"""The fluid terms of the equations of motion, written once for every backend.

Each function here is the only implementation of its law in the project. They are compiled by
:func:`aiauv_hydro.numerics.jit.compiled` (numba) and called

* from compiled code, by the articulated-body kernels and the simulation loop
  (:mod:`aiauv_pin.kernels.articulated_body`);
* from Python, by the Pinocchio reference path (:meth:`aiauv_pin.Vehicle.fluid_forces`) and by
  the batched helpers of :mod:`aiauv_hydro.laws.crossflow`, :mod:`aiauv_hydro.laws.damping` and
  :mod:`aiauv_hydro.laws.kirchhoff`;
* interpreted, when numba is missing (the same source runs as plain Python).

Conventions: spatial vectors are ``(linear, angular)``, twists ``nu = (v, omega)`` [m/s, rad/s]
and wrenches ``(f, n)`` [N, N m] in a body or link frame (Featherstone 2008, Ch. 2; Fossen 2021,
Ch. 6). "Bias" is the left-hand side of ``M dv + bias = tau``, so a damping force enters it with a
minus sign.

Single-vector laws return tuples of floats (kept in registers by the compiler); the per-body
composition :func:`add_body_fluid_bias` writes into preallocated arrays.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3

#: Gauss-Legendre nodes on each of the two sub-intervals of the crossflow integral (see
#: :func:`crossflow_wrench`; :func:`aiauv_hydro.laws.crossflow.gauss_legendre_unit` gives the rule).
CROSSFLOW_NODES = 16


class FluidModel(NamedTuple):
    """Per-body and per-link fluid parameters of a vehicle, packed for the laws below.

    Built by :meth:`aiauv_pin.Vehicle.fluid_model` from the URDF's ``<hydrodynamics>`` block;
    ``nb`` is the number of Pinocchio bodies (joints below the universe), ``nl`` the number of
    links with damping.

    Attributes:
        added_mass: ``M_A`` of each body about its origin, body axes (nb, 6, 6) [kg, kg m, kg m^2].
        hydrostatics: ``(F, m_x, m_y, m_z)`` per body (nb, 4): the hydrostatic wrench on the body is
            ``(F e, m x e)`` with ``e`` the world up axis in body axes (Fossen 2021, eq. (4.6));
            ``F = B - W`` [N] and ``m = B c_B - W c_W`` [N m] when the weight is included, or the
            buoyancy alone (``F = B``, ``m = B c_B``) when the rigid-body code adds the weight.
        current_probe: Point of each body where the water velocity is sampled, body frame (nb, 3)
            [m] (its links' centre of buoyancy, or its origin).
        displaced: ``(rho Vol, rho Vol c_B)`` of each body (nb, 4) [kg, kg m]: the mass of the
            water its links displace and its first moment about the body origin, body axes (the
            Froude-Krylov force of :mod:`aiauv_hydro.laws.unsteady_flow`).
        link_body: Body of each damped link (nl,).
        link_from_body: Motion transform ``X`` with ``nu_link = X nu_body`` (nl, 6, 6).
        link_is_body: 1 where that transform is the identity (skips the products) (nl,).
        linear_damping: ``D_L`` in the link frame (nl, 6, 6) [N s/m, N s, N m s].
        quadratic_damping: ``D_Q`` in the link frame (nl, 6, 6) [N s^2/m^2, ...].
        quadratic_is_diagonal: 1 where ``D_Q`` is diagonal (nl,).
        forward_speed_damping: ``D_F`` in the link frame (nl, 6, 6) [N s^2/m^2, N s^2/m, N m s^2/m]:
            the surge-proportional linear damping ``-u_r D_F nu_r``
            (:func:`forward_speed_damping_wrench`).
        has_forward_speed_damping: 1 where ``D_F`` is not zero (nl,).
        has_crossflow: 1 for a slender link with strip-theory crossflow drag (nl,).
        cylinder_from_link: Motion transform from the link to its cylinder frame (nl, 6, 6).
        cylinder_is_link: 1 where the cylinder frame is the link frame (nl,).
        cylinder_length: Cylinder length ``L`` (nl,) [m].
        strip_coefficient: ``rho r C_dC`` (nl,) [kg/m^2].
        axial_coefficient: ``1/2 rho pi r^2 C_d1`` of the cylinder-frame axial drag (nl,) [kg/m]
            (0 where it is in ``D_Q``).
        roll_coefficient: ``1/2 rho pi L r^4 C_d4`` of the cylinder-frame roll drag (nl,)
            [kg m^2] (0 where it is in ``D_Q``).
        gauss_nodes: Gauss-Legendre nodes on ``[0, 1]`` (n,).
        gauss_weights: Their weights (n,).
    """

    added_mass: np.ndarray
    hydrostatics: np.ndarray
    current_probe: np.ndarray
    displaced: np.ndarray
    link_body: np.ndarray
    link_from_body: np.ndarray
    link_is_body: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    quadratic_is_diagonal: np.ndarray
    forward_speed_damping: np.ndarray
    has_forward_speed_damping: np.ndarray
    has_crossflow: np.ndarray
    cylinder_from_link: np.ndarray
    cylinder_is_link: np.ndarray
    cylinder_length: np.ndarray
    strip_coefficient: np.ndarray
    axial_coefficient: np.ndarray
    roll_coefficient: np.ndarray
    gauss_nodes: np.ndarray
    gauss_weights: np.ndarray


# ---------------------------------------------------------------------- single-vector laws
@compiled(fastmath=True)
def _row_dot(matrix, i, vector):
    """``matrix[i] . vector`` for a 6-vector (a scalar, so no temporary array)."""
    return (
        matrix[i, 0] * vector[0]
        + matrix[i, 1] * vector[1]
        + matrix[i, 2] * vector[2]
        + matrix[i, 3] * vector[3]
        + matrix[i, 4] * vector[4]
        + matrix[i, 5] * vector[5]
    )


@compiled(fastmath=True)
def coriolis_wrench(inertia, twist):
    """Coriolis-centripetal wrench ``nu x* (M nu)`` of a body or of its added mass.

    Kirchhoff's equations ``M nu_dot + nu x* (M nu) = f`` (Fossen 2021, eq. (6.43); ``C_A(nu) nu`` of
    eq. (6.46) for the added mass; Featherstone 2008, eq. (2.67)), with
    ``(v, w) x* (f, n) = (w x f, v x f + w x n)``; holds for any symmetric 6x6 ``M``.

    Args:
        inertia: Generalised inertia ``M`` about the frame origin (6, 6).
        twist: Twist ``nu`` in the same frame (6,) [m/s, rad/s].

    Returns:
        The wrench as it appears on the left-hand side, 6 floats [N, N m].
    """
    f0, f1, f2 = (
        _row_dot(inertia, 0, twist),
        _row_dot(inertia, 1, twist),
        _row_dot(inertia, 2, twist),
    )
    n0, n1, n2 = (
        _row_dot(inertia, 3, twist),
        _row_dot(inertia, 4, twist),
        _row_dot(inertia, 5, twist),
    )
    return coriolis_of_momentum(
        twist[0], twist[1], twist[2], twist[3], twist[4], twist[5], f0, f1, f2, n0, n1, n2
    )


@compiled(fastmath=True)
def coriolis_of_momentum(v0, v1, v2, w0, w1, w2, f0, f1, f2, n0, n1, n2):
    """``nu x* h``: the Coriolis-centripetal wrench of :func:`coriolis_wrench` from the momentum
    ``h = M nu`` (for callers that hold ``nu`` and ``h`` in scalars).

    ``(v, w) x* (f, n) = (w x f, v x f + w x n)`` (Featherstone 2008, eq. (2.67)).

    Args:
        v0, v1, v2, w0, w1, w2: Twist ``nu = (v, w)`` [m/s, rad/s].
        f0, f1, f2, n0, n1, n2: Momentum ``h = M nu`` [kg m/s, kg m^2/s].

    Returns:
        The wrench as it appears on the left-hand side, 6 floats [N, N m].
    """
    a0, a1, a2 = cross3(w0, w1, w2, f0, f1, f2)
    b0, b1, b2 = cross3(v0, v1, v2, f0, f1, f2)
    c0, c1, c2 = cross3(w0, w1, w2, n0, n1, n2)
    return a0, a1, a2, b0 + c0, b1 + c1, b2 + c2


@compiled(fastmath=True)
def stacked_row_dot(matrices, b, i, x0, x1, x2, x3, x4, x5):
    """``matrices[b, i] . x`` for a stack of 6x6 matrices and a 6-vector in scalars (no views)."""
    return (
        matrices[b, i, 0] * x0
        + matrices[b, i, 1] * x1
        + matrices[b, i, 2] * x2
        + matrices[b, i, 3] * x3
        + matrices[b, i, 4] * x4
        + matrices[b, i, 5] * x5
    )


@compiled(fastmath=True)
def current_acceleration_wrench(added_mass, omega0, omega1, omega2, vc0, vc1, vc2):
    """``M_A (omega x v_c, 0)``: the added-mass reaction to the current seen from a rotating body.

    With ``nu_r = nu - (v_c, 0)`` and ``v_c = R^T V_c`` for a uniform, steady current ``V_c``,
    ``d/dt nu_r = nu_dot + (omega x v_c, 0)`` (Fossen 2021, eq. (10.5)); the added-mass force
    ``M_A d/dt nu_r`` therefore carries this velocity-dependent term.

    Args:
        added_mass: ``M_A`` (6, 6).
        omega0, omega1, omega2: Body angular velocity [rad/s].
        vc0, vc1, vc2: Current in body axes [m/s].

    Returns:
        6 floats [N, N m] (left-hand side).
    """
    a0, a1, a2 = cross3(omega0, omega1, omega2, vc0, vc1, vc2)
    return (
        added_mass[0, 0] * a0 + added_mass[0, 1] * a1 + added_mass[0, 2] * a2,
        added_mass[1, 0] * a0 + added_mass[1, 1] * a1 + added_mass[1, 2] * a2,
        added_mass[2, 0] * a0 + added_mass[2, 1] * a1 + added_mass[2, 2] * a2,
        added_mass[3, 0] * a0 + added_mass[3, 1] * a1 + added_mass[3, 2] * a2,
        added_mass[4, 0] * a0 + added_mass[4, 1] * a1 + added_mass[4, 2] * a2,
        added_mass[5, 0] * a0 + added_mass[5, 1] * a1 + added_mass[5, 2] * a2,
    )


@compiled(fastmath=True, inline=True)
def damping_wrench(linear, quadratic, quadratic_is_diagonal, twist):
    """Linear and quadratic damping ``-D_L nu_r - D_Q (|nu_r| * nu_r)`` (Fossen 2021, eq. (6.60)-(6.62)).

    ``|nu_r| * nu_r`` is element-wise. ``quadratic_is_diagonal`` only skips multiplications by 0.

    Args:
        linear: ``D_L`` (6, 6).
        quadratic: ``D_Q`` (6, 6).
        quadratic_is_diagonal: Whether ``D_Q`` is diagonal.
        twist: ``nu_r``, the link's twist relative to the water (6,) [m/s, rad/s].

    Returns:
        The damping wrench acting on the link, 6 floats [N, N m].
    """
    d0 = -_row_dot(linear, 0, twist)
    d1 = -_row_dot(linear, 1, twist)
    d2 = -_row_dot(linear, 2, twist)
    d3 = -_row_dot(linear, 3, twist)
    d4 = -_row_dot(linear, 4, twist)
    d5 = -_row_dot(linear, 5, twist)
    s0, s1, s2 = abs(twist[0]) * twist[0], abs(twist[1]) * twist[1], abs(twist[2]) * twist[2]
    s3, s4, s5 = abs(twist[3]) * twist[3], abs(twist[4]) * twist[4], abs(twist[5]) * twist[5]
    if quadratic_is_diagonal:
        return (
            d0 - quadratic[0, 0] * s0,
            d1 - quadratic[1, 1] * s1,
            d2 - quadratic[2, 2] * s2,
            d3 - quadratic[3, 3] * s3,
            d4 - quadratic[4, 4] * s4,
            d5 - quadratic[5, 5] * s5,
        )
    square = (s0, s1, s2, s3, s4, s5)
    return (
        d0 - _row_dot(quadratic, 0, square),
        d1 - _row_dot(quadratic, 1, square),
        d2 - _row_dot(quadratic, 2, square),
        d3 - _row_dot(quadratic, 3, square),
        d4 - _row_dot(quadratic, 4, square),
        d5 - _row_dot(quadratic, 5, square),
    )


@compiled(fastmath=True, inline=True)
def forward_speed_damping_wrench(forward, twist):
    """Linear damping proportional to the surge speed, ``-u_r D_F nu_r``.

    Newman (1977, *Marine Hydrodynamics*, Sec. 4.17) shows a damping that grows linearly with
    forward speed, notably on slender bodies; UUV Simulator models it as
    ``D(nu) = -DLin - u DLinForwardSpeed - ...`` (``HMFossen::ComputeDampingMatrix`` in
    uuv_gazebo_plugins, after Antonelli 2014), with the signed relative surge speed ``u_r``. Like
    that plugin, the term is dissipative only while ``u_r > 0`` (for a positive semi-definite
    ``D_F``); running backwards it adds energy.

    Args:
        forward: ``D_F`` (6, 6), link frame [N s^2/m^2, N s^2/m, N m s^2/m].
        twist: ``nu_r``, the link's twist relative to the water (6,) [m/s, rad/s].

    Returns:
        The wrench acting on the link, 6 floats [N, N m].
    """
    u = twist[0]
    return (
        -u * _row_dot(forward, 0, twist),
        -u * _row_dot(forward, 1, twist),
        -u * _row_dot(forward, 2, twist),
        -u * _row_dot(forward, 3, twist),
        -u * _row_dot(forward, 4, twist),
        -u * _row_dot(forward, 5, twist),
    )


@compiled(fastmath=True, inline=True)
def crossflow_wrench(velocity, length, coefficient, axial, roll, nodes, weights):
    """Strip-theory crossflow drag of a slender cylinder, about its rear end, cylinder axes.

    A section at ``x`` in ``[0, L]`` moves through the water with the normal velocity
    ``v_n(x) = (v + r x, w - q x)`` and feels ``f(x) = -k |v_n| v_n`` per unit length with
    ``k = rho r C_dC`` (crossflow principle; Fossen 2021, Sec. 6.4.3; PAPER_DATA.md). The wrench is
    ``(0, int f_y, int f_z, 0, -int x f_z, int x f_y)`` with the lever arm ``x`` in metres.

    ``|v_n| v_n`` loses smoothness only where ``|v_n|`` is smallest (``v_n`` is affine in ``x``), so
    ``[0, L]`` is split there and each part integrated with an ``n``-node Gauss-Legendre rule
    (16 nodes per part agree with a 200 000-point rule to better than 1e-7 relative;
    tests/hydro/test_slender_cylinder.py).

    Axial and roll drag (a cylinder off its link's axis, where they have no link-frame ``D_Q``
    form): every station of a rigid cylinder has the same axial speed ``u`` (``(omega x x e1) . e1
    = 0``) and roll rate ``p``, so the strip sums are exact in closed form, the axial force
    ``-c_1 |u| u`` along the axis (no moment about the rear end, which lies on it) and the roll
    moment ``-c_4 |p| p``, with ``c_1 = 1/2 rho pi r^2 C_d1`` and ``c_4 = 1/2 rho pi L r^4 C_d4``,
    the coefficients of the on-axis ``D_Q`` (Schmidt-Didlaukies et al. 2018; Fossen 2021,
    Sec. 6.4; :func:`aiauv_hydro.estimate.slender_cylinder.quadratic_damping_matrix`).

    Args:
        velocity: Twist of the cylinder frame relative to the water, cylinder axes (6,).
        length: ``L`` [m].
        coefficient: ``k = rho r C_dC`` [kg/m^2].
        axial: ``c_1 = 1/2 rho pi r^2 C_d1`` [kg/m] (0 for a cylinder on its link's axis).
        roll: ``c_4 = 1/2 rho pi L r^4 C_d4`` [kg m^2] (0 for a cylinder on its link's axis).
        nodes: Gauss-Legendre nodes on ``[0, 1]`` (n,).
        weights: Their weights (n,).

    Returns:
        6 floats [N, N m].
    """
    a_y, a_z = velocity[1], velocity[2]
    b_y, b_z = velocity[5], -velocity[4]
    slope2 = b_y * b_y + b_z * b_z
    split = 0.0
    if slope2 > 0.0:
        split = -(a_y * b_y + a_z * b_z) / slope2  # minimiser of |A + B x|^2
    if split < 0.0:
        split = 0.0
    elif split > length:
        split = length
    fy = 0.0
    fz = 0.0
    my = 0.0
    mz = 0.0
    for part in range(2):
        start = 0.0 if part == 0 else split
        width = split if part == 0 else length - split
        for k in range(nodes.shape[0]):
            x = start + width * nodes[k]
            w = width * weights[k]
            ny = a_y + b_y * x
            nz = a_z + b_z * x
            speed = math.sqrt(ny * ny + nz * nz)
            fy -= w * speed * ny
            fz -= w * speed * nz
            my += w * x * speed * nz
            mz -= w * x * speed * ny
    fx = 0.0
    mx = 0.0
    if axial != 0.0:
        fx = -axial * abs(velocity[0]) * velocity[0]
    if roll != 0.0:
        mx = -roll * abs(velocity[3]) * velocity[3]
    return fx, coefficient * fy, coefficient * fz, mx, coefficient * my, coefficient * mz


@compiled(fastmath=True)
def hydrostatic_wrench(force, moment0, moment1, moment2, up0, up1, up2):
    """Hydrostatic wrench ``(F e, m x e)`` acting on a body (Fossen 2021, eq. (4.6)).

    Args:
        force: ``F`` = buoyancy minus weight, or buoyancy alone [N].
        moment0, moment1, moment2: ``m = B c_B - W c_W`` (or ``B c_B``) in body axes [N m].
        up0, up1, up2: The world's up axis in body axes, ``e = R^T z``.

    Returns:
        The wrench acting on the body, 6 floats [N, N m] (minus it on the left-hand side).
    """
    m0, m1, m2 = cross3(moment0, moment1, moment2, up0, up1, up2)
    return force * up0, force * up1, force * up2, m0, m1, m2


# ---------------------------------------------------------------------- composition per body
@compiled(fastmath=True)
def current_in_body(rotation, current, b):
    """``v_c = R_b^T V_c``: the water velocity at body ``b``'s probe in its axes [m/s], 3 floats.

    Args:
        rotation: Body-to-world rotations (nb, 3, 3).
        current: Water velocity at each body's probe point, world axes (nb, 3) [m/s].
        b: The body.
    """
    c0, c1, c2 = current[b, 0], current[b, 1], current[b, 2]
    return (
        rotation[b, 0, 0] * c0 + rotation[b, 1, 0] * c1 + rotation[b, 2, 0] * c2,
        rotation[b, 0, 1] * c0 + rotation[b, 1, 1] * c1 + rotation[b, 2, 1] * c2,
        rotation[b, 0, 2] * c0 + rotation[b, 1, 2] * c1 + rotation[b, 2, 2] * c2,
    )


@compiled(fastmath=True, borrows_only=True)
def add_body_fluid_bias(fluid, rotation, twist, current, bias, relative, scratch):
    """Add every fluid term of every body to ``bias`` (left-hand side, body axes, about the origin).

    For body ``b`` with world rotation ``R``, twist ``nu``, current ``V_c`` (world) and
    ``v_c = R^T V_c``, ``nu_r = nu - (v_c, 0)`` (Fossen 2021, eq. (10.4)):

    ``bias_b += nu_r x* (M_A nu_r) + M_A (omega x v_c, 0) - (F e, m x e)
    - sum_links X^T tau_D(X nu_r)``

    with the damping ``tau_D`` of each link (linear, quadratic, forward-speed and crossflow) in
    its link frame (:func:`add_link_damping`, the walk over the links that the derivative
    :func:`body_fluid_bias_jacobians` shares).
    The added-mass inertia term ``M_A dv`` is not here: it belongs to the mass matrix; nor are the
    water's own acceleration terms (Froude-Krylov and the added mass's reaction to it):
    :func:`aiauv_hydro.laws.unsteady_flow.add_flow_acceleration_bias`.

    Args:
        fluid: The vehicle's :class:`FluidModel`.
        rotation: Body-to-world rotations (nb, 3, 3).
        twist: Body twists in body axes (nb, 6) [m/s, rad/s].
        current: Water velocity at each body's probe point, world axes (nb, 3) [m/s].
        bias: Accumulator (nb, 6) [N, N m]; the fluid terms are added.
        relative: Output: each body's twist relative to the water (nb, 6).
        scratch: Work array (3, 6).
    """
    nb = twist.shape[0]
    # every record field read once, outside the loops (each read of a field is a counted reference)
    added, hydrostatics = fluid.added_mass, fluid.hydrostatics
    for b in range(nb):
        # body by body in scalars, indexing the stacked arrays directly (no views)
        vc0, vc1, vc2 = current_in_body(rotation, current, b)
        r0, r1, r2 = twist[b, 0] - vc0, twist[b, 1] - vc1, twist[b, 2] - vc2
        r3, r4, r5 = twist[b, 3], twist[b, 4], twist[b, 5]
        relative[b, 0], relative[b, 1], relative[b, 2] = r0, r1, r2
        relative[b, 3], relative[b, 4], relative[b, 5] = r3, r4, r5
        w = coriolis_of_momentum(
            r0,
            r1,
            r2,
            r3,
            r4,
            r5,
            stacked_row_dot(added, b, 0, r0, r1, r2, r3, r4, r5),
            stacked_row_dot(added, b, 1, r0, r1, r2, r3, r4, r5),
            stacked_row_dot(added, b, 2, r0, r1, r2, r3, r4, r5),
            stacked_row_dot(added, b, 3, r0, r1, r2, r3, r4, r5),
            stacked_row_dot(added, b, 4, r0, r1, r2, r3, r4, r5),
            stacked_row_dot(added, b, 5, r0, r1, r2, r3, r4, r5),
        )
        h = hydrostatic_wrench(
            hydrostatics[b, 0],
            hydrostatics[b, 1],
            hydrostatics[b, 2],
            hydrostatics[b, 3],
            rotation[b, 2, 0],
            rotation[b, 2, 1],
            rotation[b, 2, 2],
        )
        for i in range(6):
            bias[b, i] += w[i] - h[i]
        if vc0 != 0.0 or vc1 != 0.0 or vc2 != 0.0:
            w = current_acceleration_wrench(added[b], r3, r4, r5, vc0, vc1, vc2)
            for i in range(6):
                bias[b, i] += w[i]
    add_link_damping(fluid, rotation, twist, current, bias, None, None, scratch, None)


# ---------------------------------------------------------------------- lagged added mass
#: Filter coefficient of UUV Simulator's lagged added mass: ``HydrodynamicModel::ComputeAcc`` is
#: called with ``_alpha = 0.3`` by ``HMFossen::ApplyHydrodynamicForces``
#: (uuvsimulator/uuv_simulator, uuv_gazebo_plugins/src/HydrodynamicModel.cc, last changed 2018).
UUV_SIMULATOR_FILTER = 0.3
#: gz-sim's Hydrodynamics system differences the velocity without a filter, i.e. ``alpha = 1``
#: (gazebosim/gz-sim, src/systems/hydrodynamics/Hydrodynamics.cc, ``stateDot = (state -
#: prevState) / dt``, since its first version in 2021 and still in 2026).
GZ_SIM_FILTER = 1.0


@compiled(fastmath=True)
def add_lagged_added_mass_bias(added_mass, relative, previous_relative, filtered, dt, alpha, bias):
    """The added-mass wrench of UUV Simulator and gz-sim: from a lagged, filtered acceleration.

    Those simulators give the rigid-body solver the rigid inertia only and apply the added mass as
    an external wrench computed at the start of each step from the state of the previous steps
    (UUV Simulator ``HydrodynamicModel::ComputeAcc`` and ``HMFossen::ApplyHydrodynamicForces``;
    gz-sim ``Hydrodynamics::PreUpdate``). Per body, with ``nu_r,n`` its twist relative to the water
    at step ``n`` (body axes):

    ``a_n = (nu_r,n - nu_r,n-1) / dt``, ``f_n = (1 - alpha) f_n-1 + alpha a_n``,
    left-hand side ``+= M_A f_n + C_A(nu_r,n) nu_r,n``

    (the Coriolis part as :func:`coriolis_wrench`, from the current velocity, as both plugins do;
    the current's ``omega x v_c`` term is inside the difference of relative twists). With
    ``alpha = 1`` (gz-sim) ``f_n`` is the mean acceleration of the previous step. The exact
    equations put ``M_A`` in the mass matrix instead (:func:`add_body_fluid_bias`).

    Args:
        added_mass: ``M_A`` of each body about its origin, body axes (nb, 6, 6).
        relative: Twists relative to the water at this step, body axes (nb, 6) [m/s, rad/s].
        previous_relative: The same at the previous step (nb, 6); overwritten with ``relative``.
        filtered: The filtered acceleration ``f`` (nb, 6) [m/s^2, rad/s^2]; updated in place.
        dt: Step [s] (> 0).
        alpha: Filter coefficient in ``(0, 1]`` (:data:`UUV_SIMULATOR_FILTER`,
            :data:`GZ_SIM_FILTER`).
        bias: Accumulator (nb, 6) [N, N m]; the wrenches are added (left-hand side).
    """
    for b in range(relative.shape[0]):
        for i in range(6):
            rate = (relative[b, i] - previous_relative[b, i]) / dt
            filtered[b, i] = (1.0 - alpha) * filtered[b, i] + alpha * rate
            previous_relative[b, i] = relative[b, i]
        added = added_mass[b]
        w = coriolis_wrench(added, relative[b])
        for i in range(6):
            bias[b, i] += _row_dot(added, i, filtered[b]) + w[i]


# ---------------------------------------------------------------------- derivatives of the laws
# One law, one place: the derivative of each law above sits here, in the same module, and is
# called by every backend's derivative code (aiauv_pin.kernels.tangent_rnea and the Pinocchio path
# of aiauv_pin.model.derivatives). Each is the exact derivative of what its law computes
# (tests/hydro/test_laws.py checks each against central differences of the law).
@compiled(fastmath=True, borrows_only=True)
def coriolis_wrench_jacobian(inertia, twist, out):
    """``d/dnu [nu x* (M nu)]`` (6, 6) into ``out``: the derivative of :func:`coriolis_wrench`.

    With ``h = M nu = (f, n)``: ``d(nu x* h) = dnu x* h + nu x* (M dnu)``, and
    ``(dv, dw) x* (f, n) = (-[f] dw, -[f] dv - [n] dw)``, so
    ``J = crf(nu) M + [[0, -[f]], [-[f], -[n]]]`` (Featherstone 2008, eq. (2.67);
    Carpentier and Mansard 2018, the ``nu x*`` derivative of their RNEA derivatives).

    Args:
        inertia: Generalised inertia ``M`` (6, 6).
        twist: Twist ``nu`` (6,) [m/s, rad/s].
        out: Output (6, 6) [N s/m, N s, N m s].
    """
    v0, v1, v2, w0, w1, w2 = twist[0], twist[1], twist[2], twist[3], twist[4], twist[5]
    for j in range(6):  # column j of crf(nu) M: nu x* (column j of M)
        out[0, j], out[1, j], out[2, j], out[3, j], out[4, j], out[5, j] = coriolis_of_momentum(
            v0,
            v1,
            v2,
            w0,
            w1,
            w2,
            inertia[0, j],
            inertia[1, j],
            inertia[2, j],
            inertia[3, j],
            inertia[4, j],
            inertia[5, j],
        )
    f0 = _row_dot(inertia, 0, twist)
    f1 = _row_dot(inertia, 1, twist)
    f2 = _row_dot(inertia, 2, twist)
    n0 = _row_dot(inertia, 3, twist)
    n1 = _row_dot(inertia, 4, twist)
    n2 = _row_dot(inertia, 5, twist)
    # -[f] in the (0:3, 3:6) and (3:6, 0:3) blocks, -[n] in (3:6, 3:6); [a] b = a x b
    for r in range(2):
        o = 3 * r
        c = 3 - o
        out[o + 0, c + 1] += f2
        out[o + 0, c + 2] -= f1
        out[o + 1, c + 0] -= f2
        out[o + 1, c + 2] += f0
        out[o + 2, c + 0] += f1
        out[o + 2, c + 1] -= f0
    out[3, 4] += n2
    out[3, 5] -= n1
    out[4, 3] -= n2
    out[4, 5] += n0
    out[5, 3] += n1
    out[5, 4] -= n0


@compiled(fastmath=True, borrows_only=True)
def current_acceleration_wrench_jacobian(
    added_mass, omega0, omega1, omega2, vc0, vc1, vc2, by_omega, by_current
):
    """Derivatives of :func:`current_acceleration_wrench` ``M_A (omega x v_c, 0)``.

    ``d/domega = -M_A[:, :3] [v_c]`` and ``d/dv_c = M_A[:, :3] [omega]`` (``[a] b = a x b``).

    Args:
        added_mass: ``M_A`` (6, 6).
        omega0, omega1, omega2: Body angular velocity [rad/s].
        vc0, vc1, vc2: Current in body axes [m/s].
        by_omega: Output (6, 3): ``d/domega`` [N s, N m s].
        by_current: Output (6, 3): ``d/dv_c`` [N s/m, N s].
    """
    for i in range(6):
        m0, m1, m2 = added_mass[i, 0], added_mass[i, 1], added_mass[i, 2]
        # row i of M_A[:, :3] [a] is (m_i x a)^T, [a] = [[0, -a2, a1], [a2, 0, -a0], [-a1, a0, 0]]
        c0, c1, c2 = cross3(m0, m1, m2, vc0, vc1, vc2)
        by_omega[i, 0], by_omega[i, 1], by_omega[i, 2] = -c0, -c1, -c2
        by_current[i, 0], by_current[i, 1], by_current[i, 2] = cross3(
            m0, m1, m2, omega0, omega1, omega2
        )


@compiled(fastmath=True, borrows_only=True)
def damping_wrench_jacobian(linear, quadratic, twist, out):
    """``d/dnu_r`` of :func:`damping_wrench`: ``-D_L - D_Q diag(2 |nu_r|)`` (6, 6) into ``out``.

    ``d(|x| x)/dx = 2 |x|`` (continuous, so the derivative exists everywhere).

    Args:
        linear: ``D_L`` (6, 6).
        quadratic: ``D_Q`` (6, 6).
        twist: ``nu_r`` (6,) [m/s, rad/s].
        out: Output (6, 6) [N s/m, N s, N m s].
    """
    for j in range(6):
        s = 2.0 * abs(twist[j])
        for i in range(6):
            out[i, j] = -linear[i, j] - quadratic[i, j] * s


@compiled(fastmath=True, borrows_only=True)
def forward_speed_damping_wrench_jacobian(forward, twist, out):
    """``d/dnu_r`` of :func:`forward_speed_damping_wrench`: ``-u_r D_F - (D_F nu_r) e_1^T`` (6, 6)
    into ``out`` (``e_1`` picks the surge component).

    Args:
        forward: ``D_F`` (6, 6).
        twist: ``nu_r`` (6,) [m/s, rad/s].
        out: Output (6, 6) [N s/m, N s, N m s].
    """
    u = twist[0]
    for i in range(6):
        row = _row_dot(forward, i, twist)
        for j in range(6):
            out[i, j] = -u * forward[i, j]
        out[i, 0] -= row


@compiled(fastmath=True, borrows_only=True)
def crossflow_wrench_jacobian(velocity, length, coefficient, axial, roll, nodes, weights, out):
    """``d/dnu`` of :func:`crossflow_wrench` (6, 6) into ``out``: exact for its quadrature.

    With ``n(x) = a + b x`` (``a = (v, w)``, ``b = (r, -q)``) and ``g = |n| n``,
    ``dg/dn = |n| I + n n^T / |n|`` (continuous). The rule's nodes move with the split point
    ``s = -(a . b) / |b|^2`` (when it lies inside ``(0, L)``): on the first part ``x_k = s t_k``,
    ``w_k = s omega_k``, on the second ``x_k = s + (L - s) t_k``, ``w_k = (L - s) omega_k``; the
    derivative of the sum through ``s`` is added, so this is the derivative of the computed
    quadrature, not of the exact integral (they differ by the quadrature error).

    Args:
        velocity: Twist of the cylinder frame relative to the water (6,).
        length: ``L`` [m].
        coefficient: ``k = rho r C_dC`` [kg/m^2].
        axial: ``c_1`` [kg/m]: ``d(-c_1 |u| u)/du = -2 c_1 |u|`` (the only entry of row 0).
        roll: ``c_4`` [kg m^2]: ``d(-c_4 |p| p)/dp = -2 c_4 |p|`` (the only entry of row 3).
        nodes: Gauss-Legendre nodes on ``[0, 1]`` (n,).
        weights: Their weights (n,).
        out: Output (6, 6) [N s/m, N s, N m s]; rows 0 and 3 and columns 0 and 3 are 0 except the
            diagonal entries of the axial and roll drag.
    """
    a_y, a_z = velocity[1], velocity[2]
    b_y, b_z = velocity[5], -velocity[4]
    slope2 = b_y * b_y + b_z * b_z
    split = 0.0
    if slope2 > 0.0:
        split = -(a_y * b_y + a_z * b_z) / slope2
    interior = 0.0 < split < length
    if split < 0.0:
        split = 0.0
    elif split > length:
        split = length
    # j_oi: outputs o = (fy, fz, my, mz) / coefficient by inputs i = (a_y, a_z, b_y, b_z); s_o: by split
    j00 = j01 = j02 = j03 = 0.0
    j10 = j11 = j12 = j13 = 0.0
    j20 = j21 = j22 = j23 = 0.0
    j30 = j31 = j32 = j33 = 0.0
    s0 = s1 = s2 = s3 = 0.0
    for part in range(2):
        start = 0.0 if part == 0 else split
        width = split if part == 0 else length - split
        for k in range(nodes.shape[0]):
            x = start + width * nodes[k]
            w = width * weights[k]
            ny = a_y + b_y * x
            nz = a_z + b_z * x
            speed = math.sqrt(ny * ny + nz * nz)
            if speed > 0.0:
                hyy = speed + ny * ny / speed
                hzz = speed + nz * nz / speed
                hyz = ny * nz / speed
            else:
                hyy = 0.0
                hzz = 0.0
                hyz = 0.0
            # d g / d(a_y, a_z, b_y, b_z) = (H, H x), g = |n| n
            wx = w * x
            wxx = wx * x
            j00 -= w * hyy
            j01 -= w * hyz
            j02 -= wx * hyy
            j03 -= wx * hyz
            j10 -= w * hyz
            j11 -= w * hzz
            j12 -= wx * hyz
            j13 -= wx * hzz
            j20 += wx * hyz
            j21 += wx * hzz
            j22 += wxx * hyz
            j23 += wxx * hzz
            j30 -= wx * hyy
            j31 -= wx * hyz
            j32 -= wxx * hyy
            j33 -= wxx * hyz
            if interior:
                dx_ds = nodes[k] if part == 0 else 1.0 - nodes[k]
                dw_ds = weights[k] if part == 0 else -weights[k]
                gy = speed * ny
                gz = speed * nz
                dgy_dx = hyy * b_y + hyz * b_z  # dn/dx = b
                dgz_dx = hyz * b_y + hzz * b_z
                s0 -= dw_ds * gy + w * dgy_dx * dx_ds
                s1 -= dw_ds * gz + w * dgz_dx * dx_ds
                s2 += dw_ds * x * gz + w * (gz + x * dgz_dx) * dx_ds
                s3 -= dw_ds * x * gy + w * (gy + x * dgy_dx) * dx_ds
    if interior:
        dot = a_y * b_y + a_z * b_z
        e0 = -b_y / slope2
        e1 = -b_z / slope2
        e2 = -a_y / slope2 + 2.0 * dot * b_y / (slope2 * slope2)
        e3 = -a_z / slope2 + 2.0 * dot * b_z / (slope2 * slope2)
        j00 += s0 * e0
        j01 += s0 * e1
        j02 += s0 * e2
        j03 += s0 * e3
        j10 += s1 * e0
        j11 += s1 * e1
        j12 += s1 * e2
        j13 += s1 * e3
        j20 += s2 * e0
        j21 += s2 * e1
        j22 += s2 * e2
        j23 += s2 * e3
        j30 += s3 * e0
        j31 += s3 * e1
        j32 += s3 * e2
        j33 += s3 * e3
    for i in range(6):
        for j in range(6):
            out[i, j] = 0.0
    k = coefficient
    # columns: a_y = nu[1], a_z = nu[2], b_y = nu[5], b_z = -nu[4]
    out[1, 1], out[1, 2], out[1, 5], out[1, 4] = k * j00, k * j01, k * j02, -k * j03
    out[2, 1], out[2, 2], out[2, 5], out[2, 4] = k * j10, k * j11, k * j12, -k * j13
    out[4, 1], out[4, 2], out[4, 5], out[4, 4] = k * j20, k * j21, k * j22, -k * j23
    out[5, 1], out[5, 2], out[5, 5], out[5, 4] = k * j30, k * j31, k * j32, -k * j33
    if axial != 0.0:
        out[0, 0] = -2.0 * axial * abs(velocity[0])
    if roll != 0.0:
        out[3, 3] = -2.0 * roll * abs(velocity[3])


@compiled(fastmath=True, borrows_only=True)
def hydrostatic_wrench_jacobian(force, moment0, moment1, moment2, out):
    """``d/de`` of :func:`hydrostatic_wrench` ``(F e, m x e)``: ``[[F I], [[m]]]`` (6, 3) into ``out``.

    Args:
        force: ``F`` [N].
        moment0, moment1, moment2: ``m`` in body axes [N m].
        out: Output (6, 3) [N, N m].
    """
    for i in range(6):
        for j in range(3):
            out[i, j] = 0.0
    out[0, 0] = force
    out[1, 1] = force
    out[2, 2] = force
    out[3, 1] = -moment2
    out[3, 2] = moment1
    out[4, 0] = moment2
    out[4, 2] = -moment0
    out[5, 0] = -moment1
    out[5, 1] = moment0


@compiled(fastmath=True, borrows_only=True)
def add_link_damping(fluid, rotation, twist, current, bias, d_twist, d_current, vectors, matrices):
    """The walk over the damped links: each link's damping on its body, its value or its derivative.

    Link ``k`` of body ``b`` moves with ``nu_link = X nu_r`` (``X`` its ``link_from_body``, ``nu_r``
    the body's twist relative to the water) and feels, in link axes, the sum of its terms

    ``tau_D = damping_wrench + forward_speed_damping_wrench + X_cyl^T crossflow_wrench(X_cyl nu_link)``

    which acts on the body as ``X^T tau_D``. With ``J_D = d tau_D / d nu_link`` (the sum of the
    terms' ``*_jacobian``, the crossflow one moved by ``X_cyl^T J X_cyl``), this adds

    * ``bias_b -= X^T tau_D`` when ``bias`` is given (the left-hand side,
      :func:`add_body_fluid_bias`);
    * ``d_twist_b -= X^T J_D X`` and ``d_current_b += (X^T J_D X)[:, :3]`` when ``d_twist`` is given
      (``nu_r = nu - (v_c, 0)``; :func:`body_fluid_bias_jacobians`).

    Every per-link term is written here once, its value next to its derivative, for both callers.
    Compiled, the outputs that are ``None`` are pruned at compile time (two specialisations).

    Args:
        fluid: The vehicle's :class:`FluidModel`.
        rotation: Body-to-world rotations (nb, 3, 3).
        twist: Body twists in body axes (nb, 6) [m/s, rad/s].
        current: Water velocity at each body's probe point, world axes (nb, 3) [m/s].
        bias: Accumulator (nb, 6) [N, N m], or ``None``.
        d_twist: Accumulator (nb, 6, 6) [N s/m, N s, N m s], or ``None`` (then ``d_current`` and
            ``matrices`` are ``None`` too).
        d_current: Accumulator (nb, 6, 3) [N s/m, N s], or ``None``.
        vectors: Work array (3, 6).
        matrices: Work array (3, 6, 6), or ``None``.
    """
    link_body, link_from_body, link_is_body = (
        fluid.link_body,
        fluid.link_from_body,
        fluid.link_is_body,
    )
    linear, quadratic, quadratic_is_diagonal = (
        fluid.linear_damping,
        fluid.quadratic_damping,
        fluid.quadratic_is_diagonal,
    )
    forward, has_forward = fluid.forward_speed_damping, fluid.has_forward_speed_damping
    has_crossflow, cylinder_from_link, cylinder_is_link = (
        fluid.has_crossflow,
        fluid.cylinder_from_link,
        fluid.cylinder_is_link,
    )
    cylinder_length, strip_coefficient = fluid.cylinder_length, fluid.strip_coefficient
    axial_coefficient, roll_coefficient = fluid.axial_coefficient, fluid.roll_coefficient
    nodes, weights = fluid.gauss_nodes, fluid.gauss_weights
    relative = vectors[0]
    link_twist = vectors[1]
    cylinder_twist = vectors[2]
    link_wrench = vectors[0]  # the body's relative twist is spent once the link's is formed
    for k in range(link_body.shape[0]):
        b = link_body[k]
        vc0, vc1, vc2 = current_in_body(rotation, current, b)
        relative[0], relative[1], relative[2] = (
            twist[b, 0] - vc0,
            twist[b, 1] - vc1,
            twist[b, 2] - vc2,
        )
        relative[3], relative[4], relative[5] = twist[b, 3], twist[b, 4], twist[b, 5]
        is_body = link_is_body[k]
        _move_twist(link_from_body, k, is_body, relative, link_twist)
        # linear and quadratic damping
        if bias is not None:
            w = damping_wrench(linear[k], quadratic[k], quadratic_is_diagonal[k], link_twist)
            for i in range(6):
                link_wrench[i] = w[i]
        if d_twist is not None:
            damping_wrench_jacobian(linear[k], quadratic[k], link_twist, matrices[1])
        # forward-speed damping
        if has_forward[k]:
            if bias is not None:
                w = forward_speed_damping_wrench(forward[k], link_twist)
                for i in range(6):
                    link_wrench[i] += w[i]
            if d_twist is not None:
                forward_speed_damping_wrench_jacobian(forward[k], link_twist, matrices[0])
                _add_matrix(matrices[0], matrices[1])
        # crossflow drag, in the cylinder frame
        if has_crossflow[k]:
            length = cylinder_length[k]
            coefficient = strip_coefficient[k]
            axial, roll = axial_coefficient[k], roll_coefficient[k]
            on_link = cylinder_is_link[k]
            _move_twist(cylinder_from_link, k, on_link, link_twist, cylinder_twist)
            if bias is not None:
                w = crossflow_wrench(
                    cylinder_twist, length, coefficient, axial, roll, nodes, weights
                )
                if on_link:
                    for i in range(6):
                        link_wrench[i] += w[i]
                else:
                    for i in range(6):  # back to the link frame: X_cyl^T w
                        s = 0.0
                        for j in range(6):
                            s += cylinder_from_link[k, j, i] * w[j]
                        link_wrench[i] += s
            if d_twist is not None:
                crossflow_wrench_jacobian(
                    cylinder_twist, length, coefficient, axial, roll, nodes, weights, matrices[0]
                )
                if on_link:
                    _add_matrix(matrices[0], matrices[1])
                else:
                    _add_congruent(cylinder_from_link[k], matrices[0], matrices[2], matrices[1])
        # on the body: X^T tau_D (left-hand side: minus); d/dnu_r X^T J_D X, and v_c enters as -v
        if bias is not None:
            if is_body:
                for i in range(6):
                    bias[b, i] -= link_wrench[i]
            else:
                for i in range(6):
                    s = 0.0
                    for j in range(6):
                        s += link_from_body[k, j, i] * link_wrench[j]
                    bias[b, i] -= s
        if d_twist is not None:
            link_jac = matrices[1]
            if not is_body:
                for i in range(6):
                    for j in range(6):
                        matrices[0, i, j] = 0.0
                _add_congruent(link_from_body[k], link_jac, matrices[2], matrices[0])
                link_jac = matrices[0]
            for i in range(6):
                for j in range(6):
                    d_twist[b, i, j] -= link_jac[i, j]
                for j in range(3):
                    d_current[b, i, j] += link_jac[i, j]


@compiled(fastmath=True, borrows_only=True, inline=True)
def _move_twist(transforms, k, is_identity, twist, out):
    """``out = X_k twist`` with ``X_k = transforms[k]`` (a copy where ``is_identity``) (6,)."""
    if is_identity:
        for i in range(6):
            out[i] = twist[i]
        return
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += transforms[k, i, j] * twist[j]
        out[i] = s


@compiled(fastmath=True, borrows_only=True)
def _add_matrix(a, out):
    """``out += a`` (6, 6)."""
    for i in range(6):
        for j in range(6):
            out[i, j] += a[i, j]


@compiled(fastmath=True, borrows_only=True)
def _add_congruent(x, a, tmp, out):
    """``out += X^T a X`` for 6x6 matrices (a Jacobian moved by the motion transform ``X``)."""
    for i in range(6):
        for j in range(6):
            s = 0.0
            for m in range(6):
                s += a[i, m] * x[m, j]
            tmp[i, j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for m in range(6):
                s += x[m, i] * tmp[m, j]
            out[i, j] += s


@compiled(fastmath=True, borrows_only=True)
def body_fluid_bias_jacobians(fluid, rotation, twist, current, d_twist, d_current, d_up, scratch):
    """Derivatives of :func:`add_body_fluid_bias` for every body, added to the outputs.

    With ``bias_b(nu, v_c, e)`` the fluid part of body ``b``'s left-hand side (see
    :func:`add_body_fluid_bias`; ``v_c = R^T V_c`` the current and ``e = R^T z`` the up axis in body
    axes), by the chain rule through ``nu_r = nu - (v_c, 0)`` and ``nu_link = X nu_r``:

    * ``d/dnu = C'(nu_r) + [0, d/domega of M_A (omega x v_c, 0)] - sum_links X^T J_D X``;
    * ``d/dv_c = -(C'(nu_r) - sum_links X^T J_D X)[:, :3] + M_A[:, :3] [omega]``;
    * ``d/de = -d(F e, m x e)/de``,

    with ``C'`` from :func:`coriolis_wrench_jacobian` and ``J_D`` the sum of
    :func:`damping_wrench_jacobian`, :func:`forward_speed_damping_wrench_jacobian` and
    :func:`crossflow_wrench_jacobian` (moved to the link frame by ``X_cyl^T J X_cyl``), summed by
    :func:`add_link_damping`, the walk over the links that :func:`add_body_fluid_bias` shares.

    Args:
        fluid: The vehicle's :class:`FluidModel`.
        rotation: Body-to-world rotations (nb, 3, 3).
        twist: Body twists in body axes (nb, 6) [m/s, rad/s].
        current: Water velocity at each body's probe point, world axes (nb, 3) [m/s].
        d_twist: Accumulator (nb, 6, 6): ``d bias / d nu``.
        d_current: Accumulator (nb, 6, 3): ``d bias / d v_c`` (current in body axes).
        d_up: Accumulator (nb, 6, 3): ``d bias / d e``.
        scratch: Work array (5, 6, 6).
    """
    nb = twist.shape[0]
    jac = scratch[0]
    tmp = scratch[2]
    cur = scratch[3]
    rel = scratch[4, 0]
    for b in range(nb):
        vc0, vc1, vc2 = current_in_body(rotation, current, b)
        for i in range(6):
            rel[i] = twist[b, i]
        rel[0] -= vc0
        rel[1] -= vc1
        rel[2] -= vc2
        added = fluid.added_mass[b]
        coriolis_wrench_jacobian(added, rel, jac)
        for i in range(6):
            for j in range(6):
                d_twist[b, i, j] += jac[i, j]
            for j in range(3):
                d_current[b, i, j] -= jac[i, j]
        current_acceleration_wrench_jacobian(
            added, twist[b, 3], twist[b, 4], twist[b, 5], vc0, vc1, vc2, cur[:, :3], cur[:, 3:]
        )
        for i in range(6):
            for j in range(3):
                d_twist[b, i, 3 + j] += cur[i, j]
                d_current[b, i, j] += cur[i, 3 + j]
        h = fluid.hydrostatics[b]
        hydrostatic_wrench_jacobian(h[0], h[1], h[2], h[3], tmp[:, :3])
        for i in range(6):
            for j in range(3):
                d_up[b, i, j] -= tmp[i, j]
    add_link_damping(
        fluid, rotation, twist, current, None, d_twist, d_current, scratch[4, :3], scratch[:3]
    )
