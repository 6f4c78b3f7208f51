"""Compiled kinematics of linear (Airy) waves: elevation, water velocity and acceleration.

A sea is a sum of regular components (one for a regular wave), each read from one flat float64
parameter array (:data:`HEADER` numbers, then :data:`STRIDE` per component):

``(V_x, V_y, V_z, surface_z, depth, N, [a_i, omega_i, k_i, cos beta_i, sin beta_i, eps_i, e_i] * N)``

with ``V`` [m/s] a uniform current added to the wave velocity (world axes), ``surface_z`` [m] the
world ``z`` of the still-water level (world z up, docs/source/conventions.md), ``depth`` ``h``
[m] the water depth (sea floor at ``surface_z - h``; a negative number: deep water), ``N`` the
number of components, and per component the amplitude ``a`` [m], angular frequency ``omega``
[rad/s], wavenumber ``k`` [rad/m] (from :func:`aiauv_hydro.waves.dispersion.wavenumber`), the
direction ``beta`` the waves travel to (from the world x-axis about z), the phase ``eps``
[rad] and the elevation amplitude ``e`` [m] (``e = a`` for a linear component; the harmonics of a
nonlinear stream-function wave have kinematics and elevation of the same form with different
amplitudes, :mod:`aiauv_hydro.waves.sea_state`).

Per component, with ``theta = k (x cos beta + y sin beta) - omega t + eps`` and
``zeta = z - surface_z`` (DNV-RP-C205 (2010) Table 3-1; Faltinsen 1990, ch. 2, Table 2.1):

* elevation ``eta = e cos(theta)`` (``e = a``);
* horizontal velocity ``u = a omega F_c(zeta) cos(theta)`` along ``(cos beta, sin beta)``,
  vertical ``w = a omega F_s(zeta) sin(theta)``;
* local acceleration ``du/dt = a omega^2 F_c(zeta) sin(theta)`` (horizontal), ``dw/dt =
  -a omega^2 F_s(zeta) cos(theta)``;

with ``F_c = cosh(k (zeta + h)) / sinh(k h)`` and ``F_s = sinh(k (zeta + h)) / sinh(k h)``,
written ``(e^{k zeta} +- e^{-k (zeta + 2 h)}) / (1 - e^{-2 k h})`` so that no ``cosh`` overflows at
great depth, and ``F_c = F_s = e^{k zeta}`` in deep water.

The acceleration is the local one, ``dU/dt`` at a fixed point: the convective term ``(U . grad) U``
is of second order in the wave steepness ``k a`` and linear theory leaves it out (DNV-RP-C205
sec. 3.2; Faltinsen 1990, ch. 2); the uniform current ``V`` adds no acceleration (the waves and
the current are superposed without wave-current interaction, i.e. without the Doppler shift of
the frequency).

Above the still-water level (``zeta > 0``, between it and a crest) the kinematics are those at
``zeta = 0`` (constant extrapolation; linear theory is defined below the mean level only, and
``e^{k zeta}`` would grow there without bound for short components); below the sea floor, those at
the floor. A point out of the water is not refused here: the vehicle's hydrostatics assume it is
submerged (:class:`aiauv_hydro.waves.sea_state.Waves` refuses a floor above the start).
"""

from __future__ import annotations

import math

from aiauv_hydro.numerics.jit import compiled

#: Numbers before the first component, and per component, in the parameter array.
HEADER, STRIDE = 6, 7
#: Indices of the header.
CURRENT_X, CURRENT_Y, CURRENT_Z, SURFACE_Z, DEPTH, COUNT = range(HEADER)


@compiled
def depth_factors(k, zeta, depth):
    """``(F_c, F_s)`` of a component of wavenumber ``k`` [rad/m] at ``zeta`` [m] below the
    still-water level (clamped to ``[-depth, 0]``; ``depth < 0``: deep water)."""
    if zeta > 0.0:
        zeta = 0.0
    if depth < 0.0:
        e = math.exp(k * zeta)
        return e, e
    if zeta < -depth:
        zeta = -depth
    upper = math.exp(k * zeta)
    lower = math.exp(-k * (zeta + 2.0 * depth))
    scale = -math.expm1(-2.0 * k * depth)
    return (upper + lower) / scale, (upper - lower) / scale


@compiled
def wave_elevation(t, x, y, parameters):
    """Surface elevation ``eta`` [m] above the still-water level at ``(x, y)`` [m], time ``t`` [s]."""
    eta = 0.0
    for i in range(int(parameters[COUNT])):
        j = HEADER + STRIDE * i
        omega, k = parameters[j + 1], parameters[j + 2]
        theta = k * (x * parameters[j + 3] + y * parameters[j + 4]) - omega * t + parameters[j + 5]
        eta += parameters[j + 6] * math.cos(theta)
    return eta


@compiled(inline=True)
def component_at(t, x, y, zeta, parameters, i):
    """What the velocity and the acceleration of component ``i`` share at ``(t, x, y)`` and
    ``zeta = z - z_surface`` [m]: ``a omega`` [m/s], ``omega`` [rad/s], the direction's cosine and
    sine, the phase ``theta = k (x cos b + y sin b) - omega t + phi`` [rad] and the depth factors
    of :func:`depth_factors`."""
    j = HEADER + STRIDE * i
    a, omega, k = parameters[j], parameters[j + 1], parameters[j + 2]
    cb, sb = parameters[j + 3], parameters[j + 4]
    theta = k * (x * cb + y * sb) - omega * t + parameters[j + 5]
    fc, fs = depth_factors(k, zeta, parameters[DEPTH])
    return a * omega, omega, cb, sb, theta, fc, fs


@compiled
def wave_velocity(t, x, y, z, parameters):
    """Water velocity ``(V_x, V_y, V_z)`` [m/s], world axes: the waves' plus the uniform current."""
    vx, vy, vz = parameters[CURRENT_X], parameters[CURRENT_Y], parameters[CURRENT_Z]
    zeta = z - parameters[SURFACE_Z]
    for i in range(int(parameters[COUNT])):
        a_omega, _, cb, sb, theta, fc, fs = component_at(t, x, y, zeta, parameters, i)
        horizontal = a_omega * fc * math.cos(theta)
        vx += horizontal * cb
        vy += horizontal * sb
        vz += a_omega * fs * math.sin(theta)
    return vx, vy, vz


@compiled
def wave_acceleration(t, x, y, z, parameters):
    """Local acceleration of the water ``dV/dt`` [m/s^2], world axes (the current adds none)."""
    ax, ay, az = 0.0, 0.0, 0.0
    zeta = z - parameters[SURFACE_Z]
    for i in range(int(parameters[COUNT])):
        a_omega, omega, cb, sb, theta, fc, fs = component_at(t, x, y, zeta, parameters, i)
        horizontal = a_omega * omega * fc * math.sin(theta)
        ax += horizontal * cb
        ay += horizontal * sb
        az -= a_omega * omega * fs * math.cos(theta)
    return ax, ay, az


@compiled
def elevation_grid(t, xs, ys, parameters, out):
    """``out[i, j]``: the elevation [m] at ``(xs[i], ys[j])`` [m] at time ``t`` [s] (playback)."""
    for i in range(xs.shape[0]):
        for j in range(ys.shape[0]):
            out[i, j] = wave_elevation(t, xs[i], ys[j], parameters)


@compiled
def elevation_series(times, x, y, parameters, out):
    """``out[i]``: the elevation [m] at ``(x, y)`` [m] at ``times[i]`` [s] (records, tests)."""
    for i in range(times.shape[0]):
        out[i] = wave_elevation(times[i], x, y, parameters)
