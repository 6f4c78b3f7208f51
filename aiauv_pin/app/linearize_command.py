"""``aiauv linearize SCENARIO.toml``: eigenvalues and modes of the vehicle about straight-line motion.

The scenario file names the vehicle (``case`` or ``vehicle``), the current (uniform) and the
controller gains; the trim is straight-line motion at the gains' ``u_d`` along the vehicle's axis
with the inputs that hold it (:func:`aiauv_pin.dynamics.linear_model.straight_line_trim`). With the paper's
controller and ``continuous_joints`` the joint servo (eq. (24), gains ``k_qp``, ``k_qd``) closes the
loop around the joints; ``--open-loop`` leaves the joints free.
"""

from __future__ import annotations

from pathlib import Path

from aiauv_pin._internal.argument_types import finite_number


def add_linearize_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "linearize",
        help="eigenvalues and modes of the vehicle about straight-line motion",
        description="Linearise the vehicle about straight-line motion at the scenario's u_d (exact "
        "Jacobians) and print the eigenvalues with their time constants, frequencies, damping "
        "ratios and the states each mode moves most.",
    )
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument(
        "--speed", type=finite_number, default=None, help="surge speed [m/s] (the gains' u_d)"
    )
    parser.add_argument(
        "--open-loop", action="store_true", help="no joint servo (joints free, torques held)"
    )
    parser.set_defaults(handler=_run_linearize)


def _run_linearize(args) -> int:
    from aiauv_pin.dynamics.linear_model import format_modes, linearize, straight_line_trim
    from aiauv_pin.errors import AiauvError
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.toml_file import load_scenario

    scenario = load_scenario(args.scenario)
    path = scenario.vehicle if scenario.vehicle is not None else loading.bundled_urdf(scenario.case)
    vehicle = loading.load_vehicle(path)
    if vehicle.fast is None:
        raise AiauvError(f"linearize needs the compiled backend: {vehicle.fallback_reason}")
    gains = scenario.controller_gains
    speed = gains.u_d if args.speed is None else args.speed
    trim = straight_line_trim(vehicle, speed, current=scenario.current)
    servo = not args.open_loop and scenario.controller == "paper" and scenario.continuous_joints
    model = linearize(
        vehicle,
        trim,
        current=scenario.current,
        joint_gains=(gains.k_qp, gains.k_qd) if servo else None,
    )
    print(format_modes(model))
    return 0
