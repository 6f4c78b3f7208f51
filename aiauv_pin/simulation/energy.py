"""Electrical energy of a run: thrusters and joint motors, from the logged thrusts and torques.

Pure post-processing of a trajectory; every power formula of the project lives here.

Thruster (momentum theory, ideal actuator disk at zero advance speed; e.g. Fossen 2021, Sec. 6.7, or
any propeller text such as Carlton, *Marine Propellers and Propulsion*, 4th ed., 2019, Ch. 5)::

    P_ideal = |T|^{3/2} / sqrt(2 rho A)   [W],     P_el = P_ideal / eta

with thrust ``T`` [N], water density ``rho`` [kg/m^3], disk area ``A = pi D^2 / 4`` [m^2] and an
overall efficiency ``eta`` (propeller figure of merit, motor and driver). The zero-advance-speed
(bollard) form is exact for the tunnel thrusters, which work across the flow, and an upper bound for
the longitudinal ones at speed; the same formula is used for every controller, so the comparison of
two controllers on the same vehicle does not depend on this choice for the tunnel thrusters.

Joint motor (DC motor with gear ratio ``N`` and torque constant ``k_t``; the motor current is
``i = tau / (k_t N)``)::

    P_joint = max(tau q_dot, 0) + R (tau / (k_t N))^2   [W]

mechanical power counted when the motor drives the joint (no regeneration when the water drives it)
plus the copper losses in the winding resistance ``R``. The thrust and the sampled joint torque are
held over each logged step (zero-order hold), so the energy is the left Riemann sum over the log.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np

from aiauv_pin.errors import ArgumentError


@dataclass(frozen=True)
class EnergyParameters:
    """Parameters of the energy model (defaults: a small AUV thruster and a geared joint motor).

    Attributes:
        fluid_density: ``rho`` [kg/m^3]; the paper's water, 1000.
        propeller_diameter: ``D`` [m]. Default 0.0762 m (3 in), the propeller of the Blue Robotics
            T200, a common small-AUV thruster whose maximum thrust (about 5 kgf, 50 N) matches the
            paper's 50 N thrusters (Blue Robotics, "T200 Thruster" technical details).
        thruster_efficiency: ``eta`` [-], electrical to ideal actuator-disk power. Default 0.3: the
            T200 draws about 390 W at 16 V for about 50 N, against 117 W ideal from the formula
            above with ``D = 0.0762 m`` (same source).
        joint_torque_constant: ``k_t`` [N m/A] of the joint motor. Default 0.0335, a 24 V brushless
            flat motor of about 70 W (order of the maxon EC 45 flat series' catalogue values).
        joint_gear_ratio: ``N`` [-]. Default 100, a harmonic drive as used in robot joints
            (Harmonic Drive CSF/HFUC series ratios 50-160).
        joint_winding_resistance: ``R`` [ohm], terminal resistance. Default 0.6 (same motor class).
    """

    fluid_density: float = 1000.0
    propeller_diameter: float = 0.0762
    thruster_efficiency: float = 0.3
    joint_torque_constant: float = 0.0335
    joint_gear_ratio: float = 100.0
    joint_winding_resistance: float = 0.6

    def __post_init__(self) -> None:
        for name in (
            "fluid_density",
            "propeller_diameter",
            "thruster_efficiency",
            "joint_torque_constant",
            "joint_gear_ratio",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ArgumentError(f"energy.{name}: must be > 0, got {value!r}")
        if not self.thruster_efficiency <= 1.0:
            raise ArgumentError(
                f"energy.thruster_efficiency: must be <= 1, got {self.thruster_efficiency!r}"
            )
        r = self.joint_winding_resistance
        if not (math.isfinite(r) and r >= 0):
            raise ArgumentError(f"energy.joint_winding_resistance: must be >= 0, got {r!r}")

    @property
    def disk_area(self) -> float:
        """Propeller disk area ``A = pi D^2 / 4`` [m^2]."""
        return math.pi * self.propeller_diameter**2 / 4.0


def thruster_power(thrust, parameters: EnergyParameters = EnergyParameters()) -> np.ndarray:
    """Electrical power of thrusters ``|T|^{3/2} / (eta sqrt(2 rho A))`` [W] at thrust ``T`` [N]."""
    thrust = np.asarray(thrust, dtype=float)
    ideal = np.abs(thrust) ** 1.5 / math.sqrt(2.0 * parameters.fluid_density * parameters.disk_area)
    return ideal / parameters.thruster_efficiency


def joint_power(torque, rate, parameters: EnergyParameters = EnergyParameters()) -> np.ndarray:
    """Electrical power of joint motors ``max(tau q_dot, 0) + R (tau / (k_t N))^2`` [W].

    Args:
        torque: Joint torque ``tau`` [N m]; rate: joint rate ``q_dot`` [rad/s] (same shape).
    """
    torque = np.asarray(torque, dtype=float)
    rate = np.asarray(rate, dtype=float)
    current = torque / (parameters.joint_torque_constant * parameters.joint_gear_ratio)  # [A]
    return np.maximum(torque * rate, 0.0) + parameters.joint_winding_resistance * current**2


def exact_sum(values) -> float:
    """The correctly rounded sum of an array's elements (``math.fsum``).

    NumPy's vectorised reductions may round differently with the alignment of the data in memory,
    so the same run could report integrals differing in the last digit from one process to another;
    an exactly rounded sum is the same everywhere (a sweep compares its records bit for bit).
    Compiled, the partial sums are formed without a Python list
    (:func:`aiauv_pin.kernels.summation.exact_sum_compiled`, 10x faster on a 75 000-step log).
    """
    flat = np.ascontiguousarray(values, dtype=float).ravel()
    if flat.size > 64:
        from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE

        if NUMBA_AVAILABLE:
            from aiauv_pin.kernels.summation import exact_sum_compiled

            return exact_sum_compiled(flat)
    return math.fsum(flat.tolist())


def exact_column_sums(values) -> tuple[list[float], float]:
    """The correctly rounded sum of each column of a 2-D array and of all its elements, as
    :func:`exact_sum` gives them, in one pass over the array.

    The total is ``math.fsum`` of the columns' partial sums
    (:func:`aiauv_pin.kernels.summation.exact_partials`), whose exact sum is the exact sum of the
    array: correctly rounded, it is the same float as :func:`exact_sum` of the whole array.
    """
    table = np.asarray(values, dtype=float)
    if table.ndim != 2:
        raise ArgumentError(f"exact_column_sums: a 2-D array, got shape {table.shape}")
    from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE

    if not NUMBA_AVAILABLE or table.shape[0] <= 64:
        return [exact_sum(table[:, k]) for k in range(table.shape[1])], exact_sum(table)
    from aiauv_pin.kernels.summation import PARTIALS, exact_partials

    columns, partials = [], []
    buffer = np.empty(PARTIALS)
    for k in range(table.shape[1]):
        n = exact_partials(np.ascontiguousarray(table[:, k]), buffer)
        if n < 0:  # a value not finite, or too many partials: math.fsum decides, as exact_sum
            return [exact_sum(table[:, j]) for j in range(table.shape[1])], exact_sum(table)
        columns.append(math.fsum(buffer[:n].tolist()))
        partials.extend(buffer[:n].tolist())
    return columns, math.fsum(partials)


class Energy(NamedTuple):
    """Electrical energy of a run."""

    thrusters: float  # [J]
    joints: float  # [J]
    total: float  # [J]
    distance: float  # path length travelled, s(end) - s(start) [m]
    per_metre: float | None  # total / distance [J/m]; None when no progress along the path


def run_energy(
    t,
    thrust,
    joint_torque,
    joint_rate,
    path_s,
    parameters: EnergyParameters = EnergyParameters(),
) -> Energy:
    """Energy of a logged run, each sample held until the next (left Riemann sum).

    Args:
        t: Log times (k,) [s].
        thrust: Thrusts (k, m) [N].
        joint_torque: Joint torques (k, n) [N m].
        joint_rate: Joint rates (k, n) [rad/s].
        path_s: Path parameter of the end-effector (k,) [m].
        parameters: The energy model.
    """
    _, energy = _run_energy(t, thrust, joint_torque, joint_rate, path_s, parameters)
    return energy


def _run_energy(
    t, thrust, joint_torque, joint_rate, path_s, parameters: EnergyParameters
) -> tuple[list[float], Energy]:
    """:func:`run_energy`, and the energy of each thruster [J] (the columns of the same sum)."""
    t = np.asarray(t, dtype=float)
    step = np.diff(t)
    thrust = np.asarray(thrust, dtype=float).reshape(len(t), -1)[:-1]
    torque = np.asarray(joint_torque, dtype=float).reshape(len(t), -1)[:-1]
    rate = np.asarray(joint_rate, dtype=float).reshape(len(t), -1)[:-1]
    each, thrusters = exact_column_sums(thruster_power(thrust, parameters) * step[:, None])
    joints = exact_sum(joint_power(torque, rate, parameters) * step[:, None])
    total = thrusters + joints
    path_s = np.asarray(path_s, dtype=float)
    distance = float(path_s[-1] - path_s[0])
    per_metre = total / distance if distance > 0 else None
    return each, Energy(thrusters, joints, total, distance, per_metre)


def energy_summary(result, parameters: EnergyParameters = EnergyParameters()) -> dict | None:
    """The ``energy`` block of ``summary.json`` for a :class:`aiauv_pin.scenario.definition.ScenarioResult`.

    ``None`` when the controller logged no thrusts (a passive run).
    """
    tr = result.trajectory
    info = tr.info
    if "thrust" not in info or "joint_torque" not in info or "path_s" not in info:
        return None
    each, energy = _run_energy(
        tr.t, info["thrust"], info["joint_torque"], tr.v[:, 6:], info["path_s"], parameters
    )
    return {
        "thrusters": energy.thrusters,
        "thruster_each": dict(zip(result.thruster_names, each, strict=True)),
        "joints": energy.joints,
        "total": energy.total,
        "distance_along_path": energy.distance,
        "per_metre": energy.per_metre,
        "model": "thruster |T|^1.5/(eta sqrt(2 rho A)); joint max(tau qdot, 0) + R (tau/(k_t N))^2",
        "parameters": asdict(parameters),
    }
