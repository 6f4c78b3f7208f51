"""Dynamics-consistency checks of a vehicle model: the physics laws a correct model obeys.

Each check takes a :class:`~aiauv_pin.Vehicle` (loaded from any URDF), evaluates one law on
configurations and velocities drawn with a fixed seed (joints within their limits), and returns a
:class:`CheckResult`: the check's name, the measured figure, its tolerance, the verdict and a
one-line detail. Nothing here needs pytest; :mod:`aiauv_pin.testing` runs the same functions as a
pytest suite (``pytest --aiauv-vehicle my.urdf``), ``aiauv check --physics my.urdf`` prints them as a
table, and the project's own physics tests call them on the shipped vehicles.

The checks (:data:`CHECKS`, in the order :func:`run_checks` runs them):

1. ``mass_matrix_symmetric``, ``mass_matrix_positive_definite``, ``added_mass_positive_semidefinite``:
   ``M(q) = M_RB(q) + M_A(q)`` is symmetric positive definite and its added part positive
   semi-definite; ``kinetic_energy``: ``v^T M v / 2`` equals the sum over bodies of
   ``nu_i^T M_i nu_i / 2`` (Pinocchio's rigid-body energy plus each link's added-mass energy from
   its own twist), which checks how the added mass is assembled.
2. ``aba_without_fluid``: with every fluid effect off the acceleration is ``pinocchio.aba``.
3. ``energy_conserved``, ``impulse_conserved``: in an ideal fluid (added mass, if the vehicle has
   it on, but no damping, weight or buoyancy) the kinetic energy and the world-frame impulse of
   body plus fluid (Kirchhoff's, Lamb 1932, Sec. 119) are constants of the motion; integrated with
   the project's RK4 at ``dt`` and ``dt/2``, the drift must shrink as the integrator's error does.
4. ``damping_dissipates``: the power of the damping forces relative to the water,
   ``v_r . tau_D``, is negative (still water and a current); ``energy_decays``: with damping on and no
   input the total energy ``T + U`` never increases along a simulated run.
5. ``power_balance``: ``d/dt (T + U) = v . tau + v . tau_D`` and
   ``d/dt T = v . (tau - g(q)) + v . tau_D`` along the flow (central differences).
6. ``hydrostatics``: ``g(q)`` is the gradient of the potential of weight and buoyancy computed from
   the URDF's masses, volumes and centres of buoyancy; reports the trim (:func:`trim`) and warns if
   the vehicle is not neutrally buoyant.
7. ``invariance``: body-frame accelerations are unchanged by a rigid motion of the world (the
   current moved along; any motion without weight and buoyancy, a yaw and translation with them).
8. ``backends_agree``: the compiled and Pinocchio backends agree to 1e-9.
9. ``thrusters``: each column of ``B(q)`` is the generalised force of a unit force along the
   declared direction at the declared point, ``Q_k = f . dx/dxi_k`` by finite differences of the
   thruster point's world position (so moments come from the lever arm).
10. ``unsteady_flow``: in a tidal (uniformly accelerating) current, what the water's acceleration
    ``a`` adds to the dynamics, ``M(q) (dv - dv_quasi-steady)``, is Morison's inertia force of
    every link, ``sum_links J_l^T (rho V_l (a, c_B,l x a) + M_A,l[:, :3] a)`` in link axes
    (``C_M = 1 + C_a``; :mod:`aiauv_hydro.laws.unsteady_flow`), summed here link by link from the
    URDF with Pinocchio's frame Jacobians; and the compiled and Pinocchio backends agree with that
    current to 1e-9.

Errors are mixed absolute/relative where a check compares vectors of mixed units: the figure
``max_i |a_i - b_i| / (1 + |b_i|)`` passes a tolerance ``t`` exactly when
``numpy.allclose(a, b, rtol=t, atol=t)`` does.
"""

from __future__ import annotations

import math
import types
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from aiauv_pin._internal.text import signed
from aiauv_pin.checks.vehicle_check import BUOYANCY_TOLERANCE
from aiauv_pin.errors import SimulationDiverged
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.reference.integrators import rk4_step
from aiauv_pin.simulation.fixed_step import Trajectory, simulate

#: Seed of the random states (any fixed seed gives reproducible checks).
SEED = 20261121
#: Current used by the checks that need one, world frame [m/s].
CURRENT = (0.3, -0.2, 0.15)
#: Relative net buoyancy (fraction of the weight) beyond which :func:`trim` warns (as ``aiauv check``).
NEUTRAL_TOLERANCE = BUOYANCY_TOLERANCE

_LOCAL = pin.ReferenceFrame.LOCAL
_EMPTY: Mapping[str, float] = types.MappingProxyType({})


class CheckResult(NamedTuple):
    """Outcome of one consistency check.

    Attributes:
        name: Check name (``"energy_conserved"``, ...).
        figure: The measured figure (its meaning and unit are in ``detail``).
        tolerance: The bound the figure is compared with.
        passed: Whether ``figure relation tolerance`` holds (``True`` for a skipped check).
        detail: One line: what the figure is, how the tolerance is derived, why it failed.
        relation: ``"<="``, ``"<"`` or ``">="``: how ``figure`` must compare with ``tolerance``.
        warnings: One-line warnings that do not fail the check (e.g. not neutrally buoyant).
        skipped: The check does not apply (e.g. no thrusters); ``detail`` says why.
        measurements: Further named figures (e.g. the drift at the coarse step).
    """

    name: str
    figure: float
    tolerance: float
    passed: bool
    detail: str
    relation: str = "<="
    warnings: tuple[str, ...] = ()
    skipped: bool = False
    measurements: Mapping[str, float] = _EMPTY

    @property
    def verdict(self) -> str:
        """``"pass"``, ``"FAIL"`` or ``"skip"``."""
        return "skip" if self.skipped else ("pass" if self.passed else "FAIL")

    def message(self) -> str:
        """One line: name, verdict, figure against tolerance, detail."""
        if self.skipped:
            return f"{self.name}: skipped ({self.detail})"
        relation = self.relation if self.passed else _NEGATION[self.relation]
        return (
            f"{self.name}: {self.verdict}: {self.figure:.3g} {relation} tolerance "
            f"{self.tolerance:.3g} ({self.detail})"
        )


_NEGATION = {"<=": ">", "<": ">=", ">=": "<"}


def _result(
    name: str,
    figure: float,
    tolerance: float,
    detail: str,
    relation: str = "<=",
    warnings: Sequence[str] = (),
    measurements: Mapping[str, float] | None = None,
) -> CheckResult:
    figure = float(figure)
    if relation == "<=":
        passed = figure <= tolerance
    elif relation == "<":
        passed = figure < tolerance
    else:
        passed = figure >= tolerance
    passed = passed and math.isfinite(figure)
    extra = _EMPTY if not measurements else types.MappingProxyType(dict(measurements))
    return CheckResult(
        name, figure, tolerance, passed, detail, relation, tuple(warnings), False, extra
    )


def _rng(seed: int, samples: int = 1) -> np.random.Generator:
    """The checks' random generator; ``samples`` must be a positive whole number."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples must be a positive whole number, got {samples!r}")
    return np.random.default_rng(seed)


def _skipped(name: str, reason: str) -> CheckResult:
    return CheckResult(name, math.nan, math.nan, True, reason, skipped=True)


def mixed_error(got: np.ndarray, expected: np.ndarray) -> float:
    """``max |got - expected| / (1 + |expected|)``: ``<= t`` iff ``allclose(rtol=t, atol=t)``."""
    got, expected = np.asarray(got, dtype=float), np.asarray(expected, dtype=float)
    if got.size == 0:
        return 0.0
    return float(np.max(np.abs(got - expected) / (1.0 + np.abs(expected))))


# ---------------------------------------------------------------- states and variants
def random_state(
    vehicle: Vehicle, rng: np.random.Generator, speed: float = 0.5
) -> tuple[np.ndarray, np.ndarray]:
    """A random configuration and velocity.

    Base position uniform in a 4 m cube [m], orientation uniform, each joint uniform within its
    URDF limits (clipped to ``[-pi, pi]`` rad or ``[-1, 1]`` m where a limit is missing or wider);
    velocity normal with standard deviation ``speed`` [m/s, rad/s].
    """
    model = vehicle.model
    q = pin.neutral(model)
    q[:3] = rng.uniform(-2.0, 2.0, 3)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    n = model.nq - 7
    if n:
        wide = np.full(n, math.pi)
        lower = np.nan_to_num(model.lowerPositionLimit[7:], nan=-math.inf)
        upper = np.nan_to_num(model.upperPositionLimit[7:], nan=math.inf)
        q[7:] = rng.uniform(np.maximum(lower, -wide), np.minimum(upper, wide))
    v = speed * rng.normal(size=model.nv)
    return q, v


def vehicle_variant(
    vehicle: Vehicle,
    *,
    added_mass: bool | None = None,
    damping: bool | None = None,
    restoring: bool | None = None,
    backend: str | None = None,
) -> Vehicle:
    """The same vehicle (same class, model copy, hydrodynamics) with other switches or backend.

    ``None`` keeps the vehicle's own setting. A subclass of :class:`Vehicle` must keep its
    constructor's signature to be checked.
    """
    variant = type(vehicle)(
        pin.Model(vehicle.model),
        vehicle.hydro,
        name=vehicle.name,
        added_mass=vehicle.added_mass if added_mass is None else added_mass,
        damping=vehicle.damping if damping is None else damping,
        restoring=vehicle.restoring if restoring is None else restoring,
        backend=vehicle.backend if backend is None else backend,
    )
    variant.urdf_path = vehicle.urdf_path
    return variant


# ---------------------------------------------------------------- energies from the URDF
def potential_energy(vehicle: Vehicle, q: np.ndarray) -> float:
    """Potential of weight and buoyancy [J]: ``sum m_j g z_G,j - sum rho V_i g z_B,i``.

    From the model's masses and centres of gravity (Pinocchio's ``computePotentialEnergy``) and the
    hydrodynamics block's volumes and centres of buoyancy (Fossen 2021, eq. (4.6)), independently
    of :meth:`Vehicle.restoring_forces`. Zero when the vehicle has restoring forces off.
    """
    if not vehicle.restoring:
        return 0.0
    model = vehicle.model
    weight = pin.computePotentialEnergy(model, model.createData(), q)
    hydro = vehicle.hydro
    if not hydro.links:
        return float(weight)
    rho, g = hydro.fluid_density, hydro.gravity
    buoyancy = 0.0
    for link, pose in zip(hydro.links, vehicle.link_placements(q), strict=True):
        buoyancy += rho * link.volume * g * pose.act(link.center_of_buoyancy)[2]
    return float(weight - buoyancy)


def kinetic_energy_by_body(vehicle: Vehicle, q: np.ndarray, v: np.ndarray) -> float:
    """Kinetic energy of body and fluid [J] as the sum over bodies (water at rest).

    Pinocchio's rigid-body ``computeKineticEnergy`` plus ``nu_l^T M_A,l nu_l / 2`` for every link,
    with ``nu_l`` the link's own twist (Pinocchio's frame velocity) and ``M_A,l`` as read from the
    URDF, about the link origin (Fossen 2021, eq. (6.43)).
    """
    model = vehicle.model
    data = model.createData()
    energy = pin.computeKineticEnergy(model, data, q, v)
    if not vehicle.added_mass:
        return float(energy)
    pin.forwardKinematics(model, data, q, v)
    for link in vehicle.hydro.links:
        frame = model.getFrameId(link.link, pin.FrameType.BODY)
        nu = pin.getFrameVelocity(model, data, frame, _LOCAL).vector
        energy += 0.5 * nu @ link.added_mass @ nu
    return float(energy)


def _relative_velocity(q: np.ndarray, v: np.ndarray, current: np.ndarray | None) -> np.ndarray:
    """``v`` relative to a uniform current: the base moves with ``-R^T V_c`` (all links do)."""
    if current is None:
        return v
    relative = v.copy()
    relative[:3] -= pin.Quaternion(q[3:7]).toRotationMatrix().T @ current
    return relative


def damping_force(
    vehicle: Vehicle, undamped: Vehicle, q: np.ndarray, v: np.ndarray, current=None
) -> np.ndarray:
    """Generalised damping force ``tau_D`` [N, N m] (right-hand side), from the two models' biases."""
    return undamped.fluid_forces(q, v, current).bias - vehicle.fluid_forces(q, v, current).bias


def _run(vehicle: Vehicle, q0, v0, duration: float, dt: float, **options) -> tuple[Trajectory, str]:
    """``simulate``, keeping the part computed before a divergence; ``(trajectory, why it stopped)``."""
    try:
        return simulate(vehicle, q0, v0, duration, dt, **options), ""
    except SimulationDiverged as exc:
        return exc.trajectory, f"the run diverged ({exc})"


# ---------------------------------------------------------------- 1. mass matrix
def _mass_matrices(vehicle: Vehicle, samples: int, seed: int):
    rng = _rng(seed, samples)
    data = vehicle.model.createData()
    for _ in range(samples):
        q, _ = random_state(vehicle, rng)
        mass = vehicle.mass_matrix(q)
        rigid = pin.crba(vehicle.model, data, q)
        yield mass, np.triu(rigid) + np.triu(rigid, 1).T


def check_mass_matrix_symmetric(
    vehicle: Vehicle, *, samples: int = 5, seed: int = SEED, tolerance: float = 1e-12
) -> CheckResult:
    """``M(q)`` is symmetric: ``max |M_ij - M_ji| / (1 + |M_ji|)`` at round-off (tolerance 1e-12)."""
    figure = max(mixed_error(m, m.T) for m, _ in _mass_matrices(vehicle, samples, seed))
    return _result(
        "mass_matrix_symmetric",
        figure,
        tolerance,
        f"max |M - M^T| / (1 + |M|) over {samples} configurations; round-off is below 1e-14",
    )


def check_mass_matrix_positive_definite(
    vehicle: Vehicle, *, samples: int = 5, seed: int = SEED, tolerance: float = 1e-12
) -> CheckResult:
    """Smallest eigenvalue of ``M(q)`` relative to its largest, at least 1e-12 (else singular)."""
    ratios = []
    for mass, _ in _mass_matrices(vehicle, samples, seed):
        eigenvalues = np.linalg.eigvalsh(0.5 * (mass + mass.T))
        ratios.append(eigenvalues[0] / max(abs(eigenvalues[-1]), 1e-300))
    return _result(
        "mass_matrix_positive_definite",
        min(ratios),
        tolerance,
        f"min over {samples} configurations of lambda_min(M) / lambda_max(M); below 1e-12 M(q) is "
        "singular to working precision",
        relation=">=",
    )


def check_added_mass_positive_semidefinite(
    vehicle: Vehicle, *, samples: int = 5, seed: int = SEED, tolerance: float = -1e-12
) -> CheckResult:
    """``M(q) - M_RB(q) = sum_i J_i^T M_A,i J_i`` is positive semi-definite (to round-off)."""
    ratios = []
    for mass, rigid in _mass_matrices(vehicle, samples, seed):
        added = mass - rigid
        scale = max(float(np.max(np.abs(np.linalg.eigvalsh(0.5 * (mass + mass.T))))), 1e-300)
        ratios.append(np.linalg.eigvalsh(0.5 * (added + added.T))[0] / scale)
    return _result(
        "added_mass_positive_semidefinite",
        min(ratios),
        tolerance,
        f"min over {samples} configurations of lambda_min(M - M_RB) / lambda_max(M); an indefinite "
        "added mass lets the fluid carry negative energy",
        relation=">=",
    )


def check_kinetic_energy(
    vehicle: Vehicle, *, samples: int = 5, seed: int = SEED, tolerance: float = 1e-12
) -> CheckResult:
    """``v^T M(q) v / 2`` equals the bodies' rigid plus added-mass energies.

    The reference is :func:`kinetic_energy_by_body`; the tolerance, 1e-12 relative, is far above the
    round-off of a sum of a few dozen terms (about 1e-15).
    """
    rng = _rng(seed, samples)
    errors = []
    for _ in range(samples):
        q, v = random_state(vehicle, rng)
        reference = kinetic_energy_by_body(vehicle, q, v)
        errors.append(abs(vehicle.kinetic_energy(q, v) - reference) / abs(reference))
    return _result(
        "kinetic_energy",
        max(errors),
        tolerance,
        f"max relative difference of v^T M v / 2 from sum_i nu_i^T M_i nu_i / 2 over {samples} "
        "states; round-off is about 1e-15",
    )


# ---------------------------------------------------------------- 2. rigid part is Pinocchio's
def check_aba_without_fluid(
    vehicle: Vehicle, *, samples: int = 5, seed: int = SEED, tolerance: float = 1e-9
) -> CheckResult:
    """With added mass, damping, weight and buoyancy off, ``acceleration == pinocchio.aba``."""
    dry = vehicle_variant(vehicle, added_mass=False, damping=False, restoring=False)
    rng = _rng(seed, samples)
    data = dry.model.createData()
    errors = []
    for _ in range(samples):
        q, v = random_state(dry, rng)
        tau = rng.normal(size=dry.nv)
        expected = pin.aba(dry.model, data, q, v, tau)
        errors.append(mixed_error(dry.acceleration(q, v, tau), expected))
    return _result(
        "aba_without_fluid",
        max(errors),
        tolerance,
        f"max |dv - aba| / (1 + |aba|) over {samples} states, tau ~ N(0, 1) [N, N m]",
    )


# ---------------------------------------------------------------- 3. ideal fluid
class IdealFluidRun(NamedTuple):
    """Drifts of an ideal-fluid run (added mass only) at two steps.

    Attributes:
        dt: The coarse step [s] (the fine one is ``dt / 2``).
        duration: Simulated time [s].
        energy_drift: ``max_t |T(t) - T(0)| / T(0)`` at ``dt`` and at ``dt / 2``.
        impulse_drift: ``max_t |P(t) - P(0)|_inf / |P(0)|`` at ``dt`` and ``dt / 2`` (world impulse of
            body plus fluid, :meth:`Vehicle.momentum_in_world`).
        joint_motion: Largest range of any joint angle during the run [rad or m] (the run exercises
            the articulated added-mass coupling when this is not small).
        diverged: Why a run stopped early (empty if both completed).
    """

    dt: float
    duration: float
    energy_drift: tuple[float, float]
    impulse_drift: tuple[float, float]
    joint_motion: float
    diverged: str = ""


def ideal_fluid_run(
    vehicle: Vehicle,
    *,
    duration: float = 5.0,
    dt: float = 0.005,
    speed: float = 0.3,
    seed: int = SEED,
) -> IdealFluidRun:
    """Integrate the vehicle in an ideal fluid with the project's RK4 (:func:`aiauv_pin.simulate`)."""
    ideal = vehicle_variant(vehicle, damping=False, restoring=False)
    q0, v0 = random_state(ideal, np.random.default_rng(seed), speed)
    energy, impulse, motion, stopped = [], [], 0.0, ""
    for step in (dt, dt / 2):
        trajectory, why = _run(ideal, q0, v0, duration, step, log_every=max(1, round(0.05 / step)))
        stopped = stopped or why
        e = np.array(
            [ideal.kinetic_energy(q, v) for q, v in zip(trajectory.q, trajectory.v, strict=True)]
        )
        p = np.array(
            [ideal.momentum_in_world(q, v) for q, v in zip(trajectory.q, trajectory.v, strict=True)]
        )
        energy.append(float(np.max(np.abs(e - e[0])) / e[0]))
        impulse.append(float(np.max(np.abs(p - p[0])) / max(np.linalg.norm(p[0]), 1e-300)))
        if trajectory.q.shape[1] > 7:
            motion = float(np.ptp(trajectory.q[:, 7:], axis=0).max())
    return IdealFluidRun(
        dt, duration, (energy[0], energy[1]), (impulse[0], impulse[1]), motion, stopped
    )


#: Smallest factor by which a conserved quantity's drift must shrink when the step is halved (RK4
#: gives 16; 8 allows for the drift not yet being in its asymptotic regime).
HALVING_FACTOR = 8.0
#: Relative drift treated as round-off (a few thousand steps of relative error ~1e-14 each).
ROUND_OFF_DRIFT = 1e-10


def _conservation(name: str, quantity: str, drifts: tuple[float, float], run: IdealFluidRun):
    coarse, fine = drifts
    tolerance = max(coarse / HALVING_FACTOR, ROUND_OFF_DRIFT)
    detail = (
        f"relative drift of the {quantity} over {run.duration:g} s at dt = {run.dt / 2:g} s "
        f"({coarse:.3g} at {run.dt:g} s); an exactly conserving model drifts only by RK4's O(dt^4) "
        f"error, so halving dt divides the drift by ~16: tolerance = drift at {run.dt:g} s / "
        f"{HALVING_FACTOR:g}, or round-off {ROUND_OFF_DRIFT:g}"
    )
    warnings = []
    if run.joint_motion < 1e-3 and run.joint_motion > 0:
        warnings.append("the joints hardly moved: the articulated coupling was barely exercised")
    result = _result(
        name,
        fine,
        tolerance,
        detail,
        warnings=warnings,
        measurements={"drift_coarse": coarse, "drift_fine": fine, "joint_motion": run.joint_motion},
    )
    if run.diverged:
        return result._replace(passed=False, detail=f"{run.diverged}; {detail}")
    return result


def check_energy_conserved(
    vehicle: Vehicle, *, run: IdealFluidRun | None = None, seed: int = SEED
) -> CheckResult:
    """Ideal fluid: the kinetic energy of body plus fluid is conserved (see :func:`ideal_fluid_run`)."""
    run = ideal_fluid_run(vehicle, seed=seed) if run is None else run
    return _conservation("energy_conserved", "kinetic energy", run.energy_drift, run)


def check_impulse_conserved(
    vehicle: Vehicle, *, run: IdealFluidRun | None = None, seed: int = SEED
) -> CheckResult:
    """Ideal fluid: the world-frame impulse of body plus fluid is conserved."""
    run = ideal_fluid_run(vehicle, seed=seed) if run is None else run
    return _conservation("impulse_conserved", "impulse", run.impulse_drift, run)


# ---------------------------------------------------------------- 4. damping dissipates
def check_damping_dissipates(
    vehicle: Vehicle,
    *,
    samples: int = 20,
    speed: float = 1.0,
    current: Sequence[float] = CURRENT,
    seed: int = SEED,
) -> CheckResult:
    """The damping power relative to the water, ``v_r . tau_D``, is negative at every sampled state.

    ``v_r`` is ``v`` with the current subtracted from the base's linear velocity (a uniform
    current moves every link alike). Each state is evaluated in still water and in ``current``.
    The speeds span two decades, ``speed * 10^U(-2, 0)``: linear damping dominates at low speed,
    quadratic and crossflow drag at high speed, and each must dissipate on its own.
    """
    if not vehicle.damping:
        return _skipped("damping_dissipates", "damping is off")
    damped = vehicle_variant(vehicle, backend="pinocchio")
    undamped = vehicle_variant(vehicle, damping=False, backend="pinocchio")
    water = np.asarray(current, dtype=float)
    rng = _rng(seed, samples)
    powers = []
    for _ in range(samples):
        q, v = random_state(vehicle, rng, speed * 10.0 ** rng.uniform(-2.0, 0.0))
        for c in (None, water):
            relative = _relative_velocity(q, v, c)
            powers.append(float(relative @ damping_force(damped, undamped, q, v, c)))
    powers = np.array(powers)
    if np.all(powers == 0.0):
        return _result(
            "damping_dissipates",
            0.0,
            0.0,
            "the vehicle has no damping",
            warnings=("no damping: every damping power is zero",),
        )
    return _result(
        "damping_dissipates",
        powers.max(),
        0.0,
        f"largest damping power v_r . tau_D [W] over {samples} states (speeds {speed / 100:g} to "
        f"{speed:g}), still water "
        f"and a current of {np.linalg.norm(water):.3g} m/s; it must be negative",
        relation="<",
    )


def check_energy_decays(
    vehicle: Vehicle,
    *,
    duration: float = 5.0,
    dt: float = 0.01,
    speed: float = 0.5,
    seed: int = SEED,
    tolerance: float = 1e-9,
) -> CheckResult:
    """With damping on and no input, ``T + U`` never increases between samples of a simulated run.

    The figure is the largest increase between samples 0.05 s apart relative to the energy's range
    over the run. RK4's energy error over one sample interval is ``O(dt^5)`` per step, many orders
    below the damping's decrease for steps that resolve the motion; 1e-9 allows for round-off.
    """
    if not vehicle.damping:
        return _skipped("energy_decays", "damping is off")
    q0, v0 = random_state(vehicle, np.random.default_rng(seed), speed)
    trajectory, stopped = _run(vehicle, q0, v0, duration, dt, log_every=max(1, round(0.05 / dt)))
    energy = np.array(
        [
            vehicle.kinetic_energy(q, v) + potential_energy(vehicle, q)
            for q, v in zip(trajectory.q, trajectory.v, strict=True)
        ]
    )
    spread = float(np.ptp(energy))
    figure = float(np.diff(energy).max()) / spread if spread > 0 else 0.0
    result = _result(
        "energy_decays",
        figure,
        tolerance,
        f"largest increase of T + U between samples 0.05 s apart / its range over a {duration:g} s "
        f"run at dt = {dt:g} s, no input",
        measurements={"initial_energy": energy[0], "final_energy": energy[-1]},
    )
    if stopped:
        return result._replace(passed=False, detail=f"{stopped}; {result.detail}")
    if result.passed and not energy[-1] < energy[0]:
        return result._replace(passed=False, detail=result.detail + "; the energy did not decrease")
    return result


# ---------------------------------------------------------------- 5. power balance
def _flow(vehicle: Vehicle, q, v, tau, duration: float, substep: float):
    """State a time ``duration`` (may be negative) later along the flow (RK4, steps <= ``substep``)."""
    n = max(1, math.ceil(abs(duration) / substep - 1e-9))
    for _ in range(n):
        q, v = rk4_step(
            vehicle.model, lambda qq, vv: vehicle.acceleration(qq, vv, tau), q, v, duration / n
        )
    return q, v


def derivative(function: Callable[[float], float], h: float) -> float:
    """``f'(0)`` by the five-point central difference ``(8 (f(h) - f(-h)) - (f(2h) - f(-2h))) / 12h``.

    Truncation error ``h^4 f^(5) / 30``, round-off about ``1e-16 |f| / h`` (Abramowitz and Stegun
    1964, eq. 25.3.6).
    """
    return (8.0 * (function(h) - function(-h)) - (function(2 * h) - function(-2 * h))) / (12 * h)


def check_power_balance(
    vehicle: Vehicle,
    *,
    samples: int = 3,
    speed: float = 0.8,
    seed: int = SEED,
    h: float = 2e-4,
    tolerance: float = 1e-6,
) -> CheckResult:
    """``d/dt (T + U) = v . tau + v . tau_D`` and ``d/dt T = v . (tau - g(q)) + v . tau_D``.

    The rates are five-point central differences (:func:`derivative`) over ``+-h, +-2h`` along the
    flow (RK4 with steps of ``h / 4``) with a random input ``tau ~ N(0, 3^2)`` [N, N m]; ``U`` is
    :func:`potential_energy`, ``g`` :meth:`Vehicle.restoring_forces`, ``tau_D``
    :func:`damping_force`. The difference's truncation error is about ``(h omega)^4 / 30`` relative
    for motions of rate ``omega`` (measured: it falls 40-fold from ``h = 1e-3`` to ``4e-4`` s on the
    paper's vehicle, whose light joints reach ``omega ~ 35`` rad/s under this input: 8e-11 at
    ``h = 2e-4`` s), RK4's ``(h omega / 4)^5`` is smaller still, round-off is ``1e-16 E / h``
    (5e-10 measured). The tolerance, 1e-6 relative, leaves room for vehicles up to ~10x faster.
    """
    undamped = vehicle_variant(vehicle, damping=False) if vehicle.damping else None
    rng = _rng(seed, samples)
    errors = []
    for _ in range(samples):
        q, v = random_state(vehicle, rng, speed)
        tau = 3.0 * rng.normal(size=vehicle.nv)
        states = {}

        def state(t, q=q, v=v, tau=tau, states=states):
            if t not in states:
                states[t] = _flow(vehicle, q, v, tau, t, h / 4)
            return states[t]

        kinetic = derivative(lambda t: vehicle.kinetic_energy(*state(t)), h)
        potential = derivative(lambda t: potential_energy(vehicle, state(t)[0]), h)
        damping_power = 0.0 if undamped is None else v @ damping_force(vehicle, undamped, q, v)
        expected_total = v @ tau + damping_power
        expected_kinetic = v @ (tau - vehicle.restoring_forces(q)) + damping_power
        errors.append(abs(kinetic + potential - expected_total) / abs(expected_total))
        errors.append(abs(kinetic - expected_kinetic) / abs(expected_kinetic))
    return _result(
        "power_balance",
        max(errors),
        tolerance,
        f"max relative error of d(T + U)/dt against v.tau + v.tau_D and of dT/dt against "
        f"v.(tau - g) + v.tau_D over {samples} states (five-point differences, h = {h:g} s)",
    )


# ---------------------------------------------------------------- 6. hydrostatics and trim
class Trim(NamedTuple):
    """Hydrostatic trim of the straight vehicle (joints at zero).

    Attributes:
        roll, pitch: Equilibrium attitude [rad] (ZYX Euler angles, yaw free) at which the centre of
            buoyancy is straight above the centre of gravity; NaN when they coincide (any attitude
            is an equilibrium) or there is no buoyancy.
        net_buoyancy: ``(rho V - m) g`` [N], positive upward.
        weight: ``m g`` [N].
        center_of_gravity, center_of_buoyancy: In the root-link frame [m] (buoyancy NaN if ``V = 0``).
        warnings: ``"not neutrally buoyant ..."`` beyond :data:`NEUTRAL_TOLERANCE` of the weight.
    """

    roll: float
    pitch: float
    net_buoyancy: float
    weight: float
    center_of_gravity: np.ndarray
    center_of_buoyancy: np.ndarray
    warnings: tuple[str, ...]

    def describe(self) -> str:
        """One line: attitude and net buoyancy."""
        if math.isnan(self.roll):
            attitude = "any attitude (centre of buoyancy at the centre of gravity)"
            if np.any(np.isnan(self.center_of_buoyancy)):
                attitude = "no buoyancy"
        else:
            roll, pitch = signed(math.degrees(self.roll)), signed(math.degrees(self.pitch))
            attitude = f"roll {roll} deg, pitch {pitch} deg"
        share = 100.0 * self.net_buoyancy / self.weight if self.weight > 0 else math.nan
        return f"trim {attitude}; net buoyancy {self.net_buoyancy:+.4g} N ({signed(share)} % of the weight)"


def trim(vehicle: Vehicle) -> Trim:
    """Equilibrium roll and pitch and net buoyancy of the straight vehicle, from the URDF.

    Weight ``m g`` acts at the centre of gravity, buoyancy ``rho V g`` at the centre of buoyancy; the
    restoring moment about the centre of gravity vanishes when ``r_B - r_G`` points up (Fossen 2021,
    Sec. 4.2): with ``d = (r_B - r_G) / |r_B - r_G|`` in the root frame and ``R = Rz Ry(pitch)
    Rx(roll)``, ``R^T e_z = d`` gives ``pitch = -asin(d_x)``, ``roll = atan2(d_y, d_z)``.
    """
    model = vehicle.model
    hydro = vehicle.hydro
    g = hydro.gravity
    q0 = vehicle.neutral_configuration()
    data = model.createData()
    mass = float(sum(inertia.mass for inertia in model.inertias))
    cg = pin.centerOfMass(model, data, q0).copy() if mass > 0 else np.zeros(3)
    volume = sum(link.volume for link in hydro.links)
    cb = np.full(3, np.nan)
    if volume > 0:
        placements = vehicle.link_placements(q0)
        cb = (
            sum(
                link.volume * pose.act(link.center_of_buoyancy)
                for link, pose in zip(hydro.links, placements, strict=True)
            )
            / volume
        )
    net = (hydro.fluid_density * volume - mass) * g
    weight = mass * g
    roll = pitch = math.nan
    if volume > 0 and np.linalg.norm(cb - cg) > 1e-9:
        d = (cb - cg) / np.linalg.norm(cb - cg)
        pitch, roll = -math.asin(float(np.clip(d[0], -1.0, 1.0))), math.atan2(d[1], d[2])
    warnings = []
    if weight > 0 and abs(net) > NEUTRAL_TOLERANCE * weight:
        state = "positively" if net > 0 else "negatively"
        warnings.append(
            f"not neutrally buoyant: {state} buoyant by {net:+.4g} N "
            f"({100 * net / weight:+.2f} % of the weight)"
        )
    return Trim(roll, pitch, net, weight, cg, cb, tuple(warnings))


def check_hydrostatics(
    vehicle: Vehicle,
    *,
    samples: int = 3,
    seed: int = SEED,
    h: float = 1e-3,
    tolerance: float = 1e-6,
) -> CheckResult:
    """``v . g(q) = dU/dt`` with ``U`` from the URDF's weight and buoyancy (:func:`potential_energy`).

    Five-point central difference (:func:`derivative`) of ``U`` along the geodesic
    ``integrate(q, t v)``; the figure is the error relative to ``max(|v . g|, 0.01 W)``. With
    ``h = 1e-3`` the truncation error is about ``h^4 |U^(5)| / 30`` (1e-12 of ``m g L`` for speeds
    of order 1) and the round-off ``1e-16 |U| / h`` (4e-10 W for ``|U|`` of 2 kJ). The trim
    (:func:`trim`) is reported in the detail; not being neutrally buoyant is a warning.
    """
    if not vehicle.restoring:
        return _skipped("hydrostatics", "weight and buoyancy are off")
    rng = _rng(seed, samples)
    model = vehicle.model
    errors = []
    for _ in range(samples):
        q, v = random_state(vehicle, rng)
        rate = derivative(
            lambda t, q=q, v=v: potential_energy(vehicle, pin.integrate(model, q, t * v)), h
        )
        power = float(v @ vehicle.restoring_forces(q))
        errors.append(abs(rate - power) / max(abs(power), 1e-2))
    balance = trim(vehicle)
    return _result(
        "hydrostatics",
        max(errors),
        tolerance,
        f"max error of v.g(q) against dU/dt (weight and buoyancy from the URDF) / max(|v.g|, 0.01 W) "
        f"over {samples} states; {balance.describe()}",
        warnings=balance.warnings,
        measurements={
            "roll": balance.roll,
            "pitch": balance.pitch,
            "net_buoyancy": balance.net_buoyancy,
        },
    )


# ---------------------------------------------------------------- 7. invariance
def _random_displacement(rng: np.random.Generator, vertical_axis_only: bool) -> pin.SE3:
    if vertical_axis_only:
        rotation = pin.exp3(np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)]))
    else:
        rotation = pin.exp3(rng.normal(size=3))
    return pin.SE3(rotation, rng.uniform(-5.0, 5.0, 3))


def check_invariance(
    vehicle: Vehicle,
    *,
    samples: int = 3,
    current: Sequence[float] = CURRENT,
    seed: int = SEED,
    tolerance: float = 1e-10,
) -> CheckResult:
    """Body-frame accelerations are unchanged when the world is moved rigidly, current included.

    Without weight and buoyancy any rigid motion; with them, one that keeps gravity (a rotation about
    the vertical and a translation). The figure is the mixed error of the accelerations.
    """
    water = np.asarray(current, dtype=float)
    free = vehicle_variant(vehicle, restoring=False) if vehicle.restoring else vehicle
    cases = [(free, False)] + ([(vehicle, True)] if vehicle.restoring else [])
    rng = _rng(seed, samples)
    errors = []
    for _ in range(samples):
        for model_vehicle, vertical_only in cases:
            q, v = random_state(model_vehicle, rng)
            tau = rng.normal(size=model_vehicle.nv)
            displacement = _random_displacement(rng, vertical_only)
            moved = q.copy()
            moved[:7] = pin.SE3ToXYZQUAT(displacement * pin.XYZQUATToSE3(q[:7]))
            for c in (None, water):
                c_moved = None if c is None else displacement.rotation @ c
                errors.append(
                    mixed_error(
                        model_vehicle.acceleration(moved, v, tau, c_moved),
                        model_vehicle.acceleration(q, v, tau, c),
                    )
                )
    return _result(
        "invariance",
        max(errors),
        tolerance,
        f"max |dv(moved) - dv| / (1 + |dv|) over {samples} states and rigid motions of the world, "
        "still water and a current moved along",
    )


# ---------------------------------------------------------------- 8. backends
def check_backends_agree(
    vehicle: Vehicle,
    *,
    samples: int = 4,
    current: Sequence[float] = CURRENT,
    seed: int = SEED,
    tolerance: float = 1e-9,
) -> CheckResult:
    """The compiled (numba) and Pinocchio backends give the same dynamics to 1e-9 (mixed error).

    Compared: accelerations (still water and a current), restoring forces, thrust matrix, the pose
    and twist of the last link with hydrodynamics (or the last frame), and a 0.2 s simulated run
    (RK4, ``dt = 0.01`` s, constant input, current).
    """
    try:
        compiled = vehicle_variant(vehicle, backend="numba")
    except ValueError as exc:
        return _skipped("backends_agree", f"no compiled backend: {exc}")
    reference = vehicle_variant(vehicle, backend="pinocchio")
    water = np.asarray(current, dtype=float)
    links = [link.link for link in vehicle.hydro.links]
    frame = reference.frame_id(links[-1]) if links else len(reference.model.frames) - 1
    rng = _rng(seed, samples)
    errors = []
    for _ in range(samples):
        q, v = random_state(reference, rng)
        tau = 10.0 * rng.normal(size=reference.nv)
        for c in (None, water):
            errors.append(
                mixed_error(
                    compiled.acceleration(q, v, tau, c), reference.acceleration(q, v, tau, c)
                )
            )
        errors.append(mixed_error(compiled.restoring_forces(q), reference.restoring_forces(q)))
        errors.append(mixed_error(compiled.thrust_matrix(q), reference.thrust_matrix(q)))
        for got, expected in zip(
            compiled.frame_motion(q, v, frame), reference.frame_motion(q, v, frame), strict=True
        ):
            errors.append(mixed_error(got, expected))
    q0, v0 = random_state(reference, rng, speed=0.2)
    tau = rng.normal(size=reference.nv)
    runs = [
        _run(model_vehicle, q0, v0, 0.2, 0.01, controller=lambda t, q, v: tau, current=water)[0]
        for model_vehicle in (compiled, reference)
    ]
    if runs[0].q.shape == runs[1].q.shape:
        errors.append(mixed_error(runs[0].q, runs[1].q))
        errors.append(mixed_error(runs[0].v, runs[1].v))
    else:  # one backend diverged, the other did not
        errors.append(math.inf)
    return _result(
        "backends_agree",
        max(errors),
        tolerance,
        f"max |compiled - Pinocchio| / (1 + |Pinocchio|) over accelerations, g(q), B(q) and frame "
        f"motion at {samples} states and a 0.2 s run",
    )


# ---------------------------------------------------------------- 9. thrusters
def thrust_matrix_by_virtual_work(vehicle: Vehicle, q: np.ndarray, eps: float = 1e-5) -> np.ndarray:
    """``B(q)`` from the declared thrusters by virtual work, independent of any Jacobian.

    Column ``j``, row ``k``: ``f_j . dx_j / dxi_k`` with ``f_j`` the unit force along the thruster's
    direction in the world and ``x_j`` its point in the world; the derivative along the tangent
    direction ``xi_k`` of ``q`` (``integrate(q, +-eps e_k)``) is a central difference (error
    ``O(eps^2)`` plus round-off ``1e-16 |x| / eps``).
    """
    thrusters = vehicle.hydro.thrusters
    links = [t.link for t in thrusters]
    model = vehicle.model

    def points(config):
        poses = vehicle.link_placements(config, links)
        return np.array([pose.act(t.position) for pose, t in zip(poses, thrusters, strict=True)])

    forces = np.array(
        [
            pose.rotation @ t.direction
            for pose, t in zip(vehicle.link_placements(q, links), thrusters, strict=True)
        ]
    )
    matrix = np.zeros((vehicle.nv, len(thrusters)))
    for k in range(vehicle.nv):
        step = np.zeros(vehicle.nv)
        step[k] = eps
        velocity = (
            points(pin.integrate(model, q, step)) - points(pin.integrate(model, q, -step))
        ) / (2 * eps)
        matrix[k] = np.einsum("ji,ji->j", forces, velocity)
    return matrix


def check_thrusters(
    vehicle: Vehicle, *, samples: int = 3, seed: int = SEED, tolerance: float = 1e-8
) -> CheckResult:
    """Each column of ``B(q)`` is a unit force at the declared point along the declared direction.

    Compared with :func:`thrust_matrix_by_virtual_work` (mixed error; finite-difference error below
    1e-9 for vehicles of a few metres).
    """
    if not vehicle.hydro.thrusters:
        return _skipped("thrusters", "the vehicle has no thrusters")
    rng = _rng(seed, samples)
    errors = []
    for _ in range(samples):
        q, _ = random_state(vehicle, rng)
        errors.append(
            mixed_error(vehicle.thrust_matrix(q), thrust_matrix_by_virtual_work(vehicle, q))
        )
    return _result(
        "thrusters",
        max(errors),
        tolerance,
        f"max |B - B_virtual_work| / (1 + |B|) over {samples} configurations and "
        f"{len(vehicle.hydro.thrusters)} thrusters",
    )


# ---------------------------------------------------------------- 10. unsteady flow
#: Tidal current of :func:`check_unsteady_flow`: mean [m/s], amplitude [m/s], period [s], phase.
TIDAL_CURRENT = ((0.2, -0.1, 0.05), (0.5, 0.3, -0.2), 6.0, 0.2)


def morison_inertia_force(vehicle: Vehicle, q: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
    """Generalised force [N, N m] of a uniform water acceleration ``acceleration`` (3,) [m/s^2],
    world axes, summed link by link from the URDF's hydrodynamics block: each link feels
    ``(rho V a + M_A[:3, :3] a, rho V c_B x a + M_A[3:, :3] a)`` in its own axes (Froude-Krylov
    plus the added mass's reaction; DNV-RP-C205, Sec. 6.2, ``C_M = 1 + C_a``), mapped by its
    frame Jacobian (Pinocchio, ``LOCAL``)."""
    model = vehicle.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    rho = vehicle.hydro.fluid_density
    force = np.zeros(vehicle.nv)
    for link in vehicle.hydro.links:
        frame = vehicle.frame_id(link.link)
        a = data.oMf[frame].rotation.T @ acceleration
        mass = rho * link.volume
        wrench = np.concatenate(
            (mass * a, mass * np.cross(np.asarray(link.center_of_buoyancy, dtype=float), a))
        )
        if vehicle.added_mass:
            wrench += np.asarray(link.added_mass, dtype=float)[:, :3] @ a
        jacobian = pin.getFrameJacobian(model, data, frame, _LOCAL)
        force += jacobian.T @ wrench
    return force


def check_unsteady_flow(
    vehicle: Vehicle, *, samples: int = 4, seed: int = SEED, tolerance: float = 1e-9
) -> CheckResult:
    """The water's acceleration acts as Morison's inertia force on every link, on both backends.

    At random states in a tidal current (:data:`TIDAL_CURRENT`, uniform, ``a = dV/dt``), the
    figure is the larger of ``mixed_error(M(q) (dv - dv_qs), morison_inertia_force)`` (``dv_qs``
    with the quasi-steady current: the difference is exactly what the water's acceleration adds)
    and the compiled-against-Pinocchio mixed error of ``dv``, both to 1e-9.
    """
    from aiauv_hydro.currents import Current

    reference = vehicle_variant(vehicle, backend="pinocchio")
    try:
        compiled = vehicle_variant(vehicle, backend="numba")
    except ValueError:
        compiled = None
    mean, amplitude, period, phase = TIDAL_CURRENT
    water = Current.tidal(mean, amplitude, period, phase)
    rng = _rng(seed, samples)
    errors, backend_errors = [], []
    for _ in range(samples):
        q, v = random_state(reference, rng)
        tau = 10.0 * rng.normal(size=reference.nv)
        t = float(rng.uniform(0.0, period))
        dv = reference.acceleration(q, v, tau, water, t=t)
        dv_quasi = reference.acceleration(q, v, tau, water.quasi_steady(), t=t)
        added = reference.mass_matrix(q) @ (dv - dv_quasi)
        expected = morison_inertia_force(reference, q, water.water_acceleration(t, np.zeros(3)))
        errors.append(mixed_error(added, expected))
        if compiled is not None:
            backend_errors.append(mixed_error(compiled.acceleration(q, v, tau, water, t=t), dv))
    figure = max(errors + backend_errors)
    both = "" if compiled is None else " and compiled against Pinocchio"
    return _result(
        "unsteady_flow",
        figure,
        tolerance,
        f"max mixed error of M (dv - dv_quasi-steady) against the links' Morison inertia force "
        f"(C_M = 1 + C_a){both}, {samples} states in a tidal current",
        measurements={
            "morison": max(errors),
            "backends": max(backend_errors) if backend_errors else math.nan,
        },
    )


# ---------------------------------------------------------------- all of them
#: The checks by name, in the order :func:`run_checks` runs them.
CHECKS: Mapping[str, Callable[..., CheckResult]] = types.MappingProxyType(
    {
        "mass_matrix_symmetric": check_mass_matrix_symmetric,
        "mass_matrix_positive_definite": check_mass_matrix_positive_definite,
        "added_mass_positive_semidefinite": check_added_mass_positive_semidefinite,
        "kinetic_energy": check_kinetic_energy,
        "aba_without_fluid": check_aba_without_fluid,
        "energy_conserved": check_energy_conserved,
        "impulse_conserved": check_impulse_conserved,
        "damping_dissipates": check_damping_dissipates,
        "energy_decays": check_energy_decays,
        "power_balance": check_power_balance,
        "hydrostatics": check_hydrostatics,
        "invariance": check_invariance,
        "backends_agree": check_backends_agree,
        "thrusters": check_thrusters,
        "unsteady_flow": check_unsteady_flow,
    }
)


def run_checks(vehicle: Vehicle, *, seed: int = SEED) -> list[CheckResult]:
    """Every check of :data:`CHECKS` on one vehicle (the ideal-fluid run is shared)."""
    run = ideal_fluid_run(vehicle, seed=seed)
    results = []
    for name, check in CHECKS.items():
        if name in ("energy_conserved", "impulse_conserved"):
            results.append(check(vehicle, run=run, seed=seed))
        else:
            results.append(check(vehicle, seed=seed))
    return results


def format_results(
    results: Sequence[CheckResult], title: str = "", notes: Sequence[str] = ()
) -> str:
    """A plain-text table: check, figure, relation, tolerance, verdict; then ``notes``, warnings,
    failures and a count."""
    lines = [title] if title else []
    lines.append(f"{'check':<34} {'figure':>11}    {'tolerance':>11}  verdict")
    for r in results:
        if r.skipped:
            lines.append(f"{r.name:<34} {'-':>11}    {'-':>11}  skip ({r.detail})")
        else:
            lines.append(
                f"{r.name:<34} {r.figure:>11.3g} {r.relation:>2} {r.tolerance:>11.3g}  {r.verdict}"
            )
    lines += list(notes)
    for r in results:
        lines += [f"warning: {r.name}: {w}" for w in r.warnings]
    for r in results:
        if not r.passed:
            lines.append(f"failed: {r.message()}")
    failed = sum(1 for r in results if not r.passed)
    skipped = sum(1 for r in results if r.skipped)
    lines.append(
        f"{len(results) - failed - skipped} of {len(results)} checks passed"
        + (f", {skipped} skipped" if skipped else "")
        + (f", {failed} FAILED" if failed else "")
    )
    return "\n".join(lines)


def run_physics_check(path, **load_options) -> int:
    """``aiauv check --physics PATH``: print the table; 0 if every check passed, else raise.

    ``load_options`` go to :func:`aiauv_pin.load_vehicle` (``lenient``, ``fixed_base``, xacro
    options). The checks are those of a free-floating vehicle (impulse, trim): a fixed base is
    refused.

    Raises:
        AiauvError: One line naming the failed checks (the table is printed first), or the
            vehicle's load error.
    """
    from aiauv_pin.checks.vehicle_check import check_vehicle
    from aiauv_pin.errors import AiauvError
    from aiauv_pin.model.loading import load_vehicle

    # a usable vehicle, else its one-line reason (e.g. a singular M(q))
    check_vehicle(path, **load_options)
    with warnings.catch_warnings():  # the repairs were shown by check_vehicle
        warnings.simplefilter("ignore")
        vehicle = load_vehicle(path, **load_options)
    if vehicle.fixed_base:
        raise AiauvError(
            f"{path}: --physics checks a free-floating vehicle (impulse, trim); this one has a "
            "fixed base"
        )
    results = run_checks(vehicle)
    title = f"vehicle '{vehicle.name}' from {path}"
    print(format_results(results, title, notes=[trim(vehicle).describe()]), flush=True)
    failed = [r.name for r in results if not r.passed]
    if failed:
        raise AiauvError(f"{len(failed)} physics check(s) failed: {', '.join(failed)}")
    return 0
