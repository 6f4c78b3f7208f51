"""The paper's simulation scenario (Sec. 4): straight-path following from an offset start.

Choices the paper leaves open, documented here and in the README:

* the path is the world x-axis; the vehicle starts straight, at rest, parallel to the path, with its
  end-effector at ``(0, 2, 2)`` m (a few metres off in y and z, PAPER_DATA "Start");
* 300 s of simulated time (the lineage code's duration), step ``dt = 0.01`` s (RK4); the guidance,
  base-angle and surge loops are sampled every step (zero-order hold; ``control_period`` samples them
  more slowly, with states logged at the controller's rate) and the joint PD (eq. 24) runs as a
  continuous servo evaluated at every integrator stage (see
  :class:`aiauv_pin.path_following.VehiclePathFollowing`);
* ``timeseries.csv`` holds one row every ``csv_period = 0.05`` s (every fifth step); the summary's
  integrals and settling times use every step;
* the base-angle saturation ``q_max`` is :class:`control.path_following.PathFollowingGains`' default.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from control.path_following import PathFollowingGains

from .path_following import END_EFFECTOR, VehiclePathFollowing, compiled_path_following_reason
from .simulation import Trajectory, simulate
from .vehicle import Vehicle

CASES = ("uniform", "stabilised")


@dataclass(frozen=True)
class PaperScenario:
    """Parameters of one path-following run.

    Attributes:
        case: ``"uniform"`` or ``"stabilised"`` (selects the paper's ``k_D``).
        duration: Simulated time [s].
        dt: Integration step [s].
        initial_offset: End-effector start ``(p_y, p_z)`` [m]; ``p_x = 0``.
        initial_surge: Initial forward speed of the straight vehicle [m/s].
        method: Integrator, ``"rk4"`` or ``"euler"``.
        current: Constant water velocity in the world frame [m/s].
        gains: Controller gains; ``None`` means the paper's for the case.
        continuous_joints: Joint PD as a continuous servo (True) or sampled with the controller.
        control_period: Sampling period of the guidance, base-angle and surge loops [s], a whole
            multiple of ``dt``; ``None`` samples them every step.
        csv_period: Time between rows of ``timeseries.csv`` [s], rounded to a whole number of
            logged samples (at least one); ``None`` writes every logged sample. The run is still
            logged at every sample and ``summary.json`` uses them all.
    """

    case: str = "uniform"
    duration: float = 300.0
    dt: float = 0.01
    initial_offset: tuple[float, float] = (2.0, 2.0)
    initial_surge: float = 0.0
    method: str = "rk4"
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gains: PathFollowingGains | None = None
    continuous_joints: bool = True
    control_period: float | None = None
    csv_period: float | None = 0.05

    def __post_init__(self) -> None:
        if self.case not in CASES:
            raise ValueError(f"unknown case '{self.case}' (expected uniform or stabilised)")
        for name in ("duration", "dt"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if self.control_period is not None:
            period = self.control_period
            ratio = period / self.dt if isinstance(period, (int, float)) else math.nan
            if not (
                math.isfinite(ratio) and period > 0 and abs(ratio - round(ratio)) < 1e-9 * ratio
            ):
                raise ValueError(
                    f"control_period must be a positive whole multiple of dt = {self.dt:g} s, "
                    f"got {period!r}"
                )
        if self.csv_period is not None and not (
            isinstance(self.csv_period, (int, float))
            and math.isfinite(self.csv_period)
            and self.csv_period > 0
        ):
            raise ValueError(
                f"csv_period must be a positive number of seconds or None, got {self.csv_period!r}"
            )
        if self.dt > self.duration:
            raise ValueError(
                f"dt ({self.dt:g} s) must not exceed the duration ({self.duration:g} s)"
            )
        if len(self.initial_offset) != 2 or not all(map(math.isfinite, self.initial_offset)):
            raise ValueError("initial_offset must be two finite numbers (p_y, p_z) [m]")
        if not math.isfinite(self.initial_surge):
            raise ValueError("initial_surge must be finite")
        if len(self.current) != 3 or not all(map(math.isfinite, self.current)):
            raise ValueError("current must be three finite numbers [m/s]")

    @property
    def steps_per_control(self) -> int:
        """Integration steps per controller call."""
        if self.control_period is None:
            return 1
        return max(1, round(self.control_period / self.dt))

    @property
    def controller_gains(self) -> PathFollowingGains:
        """The gains in force: the given ones or the paper's for the case."""
        return self.gains if self.gains is not None else PathFollowingGains.for_case(self.case)


def initial_state(vehicle: Vehicle, scenario: PaperScenario) -> tuple[np.ndarray, np.ndarray]:
    """Straight vehicle parallel to the x-axis with its end-effector at ``(0, p_y, p_z)``."""
    q = vehicle.neutral_configuration()
    tip = vehicle.frame_placement(q, END_EFFECTOR).translation
    q[:3] = np.array([0.0, *scenario.initial_offset]) - tip
    v = np.zeros(vehicle.nv)
    v[0] = scenario.initial_surge
    return q, v


@dataclass
class ScenarioResult:
    """A finished (or diverged) path-following run.

    Attributes:
        scenario: What was run.
        trajectory: Logged states and controller diagnostics.
        wall_time: Wall-clock time of the simulation loop [s].
        joint_names: Names of the actuated joints.
        thruster_names: Names of the thrusters.
    """

    scenario: PaperScenario
    trajectory: Trajectory
    wall_time: float
    joint_names: list[str]
    thruster_names: list[str]
    extra: dict = field(default_factory=dict)


def run_paper_scenario(
    vehicle: Vehicle,
    scenario: PaperScenario,
    *,
    progress: bool = False,
    on_log=None,
    controller: VehiclePathFollowing | None = None,
    compiled: bool | None = None,
    after_first_chunk: Callable[[], None] | None = None,
) -> ScenarioResult:
    """Simulate the path-following scenario on a vehicle.

    ``on_log(t, q, info)`` is called at every logged sample (see :func:`aiauv_pin.simulate`).

    With the numba backend and the paper's controller the whole run (dynamics, controller every
    step, logging) executes in compiled code (:func:`aiauv_pin.fast.path_following.
    run_path_following`), in chunks of one simulated second between which the progress bar and
    ``on_log`` run; otherwise (Pinocchio backend, a subclass of :class:`VehiclePathFollowing` or
    of its controller) the Python controller is called every step. Both give the same trajectory
    and the same logged keys.

    Args:
        vehicle: The vehicle.
        scenario: What to run.
        progress: Show a progress bar.
        on_log: Callback at every logged sample.
        after_first_chunk: Called once the compiled loop's first chunk has run, for work that can
            overlap the rest in a background thread (the loop releases the GIL), e.g.
            :func:`aiauv_pin.outputs.preload_plotting`.
        controller: The controller callback; ``None`` builds the paper's for ``scenario``.
        compiled: ``True`` requires the compiled path, ``False`` forbids it, ``None`` (default)
            uses it when :func:`compiled_path_following_reason` allows.

    Raises:
        SimulationDiverged: With the partial trajectory, if the state became non-finite.
        ValueError: ``compiled=True`` but the compiled path cannot run this controller.
    """
    if controller is None:
        controller = VehiclePathFollowing(
            vehicle, scenario.controller_gains, continuous_joints=scenario.continuous_joints
        )
    reason = compiled_path_following_reason(controller)
    if compiled and reason is not None:
        raise ValueError(f"compiled path following unavailable: {reason}")
    use_compiled = reason is None and compiled is not False
    q0, v0 = initial_state(vehicle, scenario)
    current = np.asarray(scenario.current, dtype=float)
    options = dict(
        method=scenario.method,
        current=current if np.any(current) else None,
        progress=progress,
        control_period=scenario.control_period,
        log_every=scenario.steps_per_control,
        on_log=on_log,
    )
    start = time.perf_counter()
    trajectory = simulate(
        vehicle,
        q0,
        v0,
        scenario.duration,
        scenario.dt,
        controller.compiled() if use_compiled else controller,
        servo=controller.joint_servo if controller.continuous_joints else None,
        after_first_chunk=after_first_chunk if use_compiled else None,
        **options,
    )
    return ScenarioResult(
        scenario=scenario,
        trajectory=trajectory,
        wall_time=time.perf_counter() - start,
        joint_names=vehicle.joint_names,
        thruster_names=vehicle.thruster_names,
        extra={"backend": vehicle.active_backend, "compiled_controller": use_compiled},
    )


def settling_time(t: np.ndarray, error: np.ndarray, band: float) -> float | None:
    """First time after which ``|error|`` stays within ``band`` (``None`` if it never does)."""
    outside = np.flatnonzero(np.abs(error) > band)
    if outside.size == 0:
        return float(t[0])
    if outside[-1] == len(t) - 1:
        return None
    return float(t[outside[-1] + 1])


def summary(result: ScenarioResult) -> dict:
    """Figures of merit of a run (all SI units)."""
    scenario = result.scenario
    tr = result.trajectory
    t, info = tr.t, tr.info
    gains = scenario.controller_gains
    p, u = info["p"], info["u"]
    last30 = t >= t[-1] - 30.0
    dt_log = np.diff(t)
    thruster_power = np.abs(info["thruster_power"][:-1])
    joint_power = np.abs(info["joint_torque"][:-1] * tr.v[:-1, 6:])
    steps = len(t) - 1
    gains_dict = asdict(gains)
    return {
        "case": scenario.case,
        "status": tr.status,
        "message": tr.message,
        "parameters": {
            **{k: v for k, v in asdict(scenario).items() if k != "gains"},
            "gains": gains_dict,
        },
        "dt": scenario.dt,
        "method": scenario.method,
        "steps": steps,
        "simulated_time": float(t[-1]),
        "wall_time": result.wall_time,
        "real_time_factor": float(t[-1] / result.wall_time) if result.wall_time > 0 else None,
        "backend": result.extra.get("backend"),
        "compiled_controller": result.extra.get("compiled_controller"),
        "final": {
            "p_y": float(p[-1, 1]),
            "p_z": float(p[-1, 2]),
            "u": float(u[-1]),
            "phi_tilde": float(info["phi_tilde"][-1]),
            "omega_tilde": [float(x) for x in info["omega_tilde"][-1]],
            "max_abs_u_error_last_30s": float(np.abs(u[last30] - gains.u_d).max()),
            "max_phi_tilde_last_30s": float(np.abs(info["phi_tilde"][last30]).max()),
        },
        "settling_time": {
            "p_y_5cm": settling_time(t, p[:, 1], 0.05),
            "p_z_5cm": settling_time(t, p[:, 2], 0.05),
            "u_1cm_s": settling_time(t, u - gains.u_d, 0.01),
            "phi_tilde_0.02rad": settling_time(t, info["phi_tilde"], 0.02),
        },
        "thruster_work": {
            name: float(np.sum(thruster_power[:, k] * dt_log))
            for k, name in enumerate(result.thruster_names)
        },
        "joint_work": {
            name: float(np.sum(joint_power[:, k] * dt_log))
            for k, name in enumerate(result.joint_names)
        },
        "total_thruster_work": float(np.sum(thruster_power.sum(axis=1) * dt_log)),
        "total_joint_work": float(np.sum(joint_power.sum(axis=1) * dt_log)),
    }
