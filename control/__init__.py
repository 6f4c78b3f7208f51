"""Path-following control laws for articulated intervention AUVs (plain numpy).

Modules, after Wrzos-Kaminska et al. (2019):

* :mod:`aiauv_control.reduced_attitude` - reduced-attitude tracking with two torques (Section 2),
  with the paper's feedforward (``"paper"``) or the corrected one (``"exact"``, default);
* :mod:`aiauv_control.guidance` - 3-D vector LOS guidance and exact derivatives of ``x_ref`` (eq. 21);
* :mod:`aiauv_control.joint_references` - base angles (eq. 23) and joint references (eq. 22);
* :mod:`aiauv_control.joint_control` - joint PD with hydrostatic compensation (eq. 24);
* :mod:`aiauv_control.surge` - surge PI on the longitudinal thrusters with anti-windup (eq. 25);
* :mod:`aiauv_control.path_following` - gains, measurement/command records and the composed controller.

For any vehicle: :mod:`aiauv_control.allocation` - thrust allocation within the actuators' limits.

Nothing here imports Pinocchio or the simulator.
"""

from aiauv_control.guidance import cross_track_gains, los_direction, los_reference
from aiauv_control.joint_control import joint_torques
from aiauv_control.joint_references import (
    JointLayoutWarning,
    base_angles,
    check_joint_axes,
    joint_references,
    pointing_law,
)
from aiauv_control.path_following import (
    CASES,
    PathFollowingCommand,
    PathFollowingController,
    PathFollowingGains,
    PathFollowingMeasurement,
)
from aiauv_control.reduced_attitude import (
    ANTIPODAL_TOLERANCE,
    FEEDFORWARD_OPTIONS,
    ReducedAttitudeLaw,
    ReducedAttitudeOutput,
    check_block_diagonal_inertia,
    error_angle,
    error_axis_angle,
    is_antipodal,
    lyapunov_function,
    minimal_rotation,
    minimal_rotation_rate_correction,
    reduced_attitude_errors,
    reduced_attitude_torque,
    reference_angular_acceleration,
    reference_angular_velocity,
)
from aiauv_control.surge import SurgePIController

__all__ = [
    "ANTIPODAL_TOLERANCE",
    "CASES",
    "FEEDFORWARD_OPTIONS",
    "JointLayoutWarning",
    "PathFollowingCommand",
    "PathFollowingController",
    "PathFollowingGains",
    "PathFollowingMeasurement",
    "ReducedAttitudeLaw",
    "ReducedAttitudeOutput",
    "SurgePIController",
    "base_angles",
    "check_block_diagonal_inertia",
    "check_joint_axes",
    "cross_track_gains",
    "error_angle",
    "error_axis_angle",
    "is_antipodal",
    "joint_references",
    "joint_torques",
    "los_direction",
    "los_reference",
    "lyapunov_function",
    "minimal_rotation",
    "minimal_rotation_rate_correction",
    "pointing_law",
    "reduced_attitude_errors",
    "reduced_attitude_torque",
    "reference_angular_acceleration",
    "reference_angular_velocity",
]
