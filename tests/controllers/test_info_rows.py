"""The info rows of the built-in compiled controllers: one declaration, offsets derived from it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.info_rows import field_spans, info_offsets
from aiauv_pin.controllers.paper_compiled import PaperInfo, paper_info_shapes
from aiauv_pin.errors import ArgumentError, RecordSizeError
from aiauv_pin.scenario.definition import Scenario, plan_run


def test_offsets_follow_the_declaration():
    shapes = paper_info_shapes(n_joints=4, n_thrusters=7)
    offsets = info_offsets(shapes, PaperInfo)
    # p (3), u, phi_tilde, omega_tilde (2), base_angles (2), joint_references (4), x_ref (3), ...
    assert offsets.p == 0 and offsets.u == 3 and offsets.omega_tilde == 5
    assert offsets.joint_references == 9 and offsets.x_ref == 13 and offsets.thrust == 19
    assert offsets.thruster_power == 26 and offsets.joint_torque == 33 and offsets.path_s == 39
    spans = list(field_spans(shapes))
    assert [name for name, _, _ in spans] == list(PaperInfo._fields)
    assert sum(size for _, _, size in spans) == 40


def test_a_record_that_names_other_fields_is_refused():
    shapes = paper_info_shapes(4, 7)
    swapped = dict(reversed(list(shapes.items())))
    with pytest.raises(ArgumentError, match="PaperInfo names the fields"):
        info_offsets(swapped, PaperInfo)


@pytest.mark.parametrize("controller", ["paper", "thruster_turning", "gait", "constant"])
def test_each_builtin_writes_every_declared_float(paper_vehicle, controller):
    """A sample writes every float of the declared row (none is left at NaN), so no field was
    skipped or written over another."""
    thrusts = (1.0,) * len(paper_vehicle.thruster_names) if controller == "constant" else None
    scenario = Scenario(duration=0.2, controller=controller, thrusts=thrusts)
    plan = plan_run(paper_vehicle, scenario)
    law = plan.arguments[-1]
    assert isinstance(law, CompiledController)
    trajectory = aiauv_pin.simulate(*plan.arguments, **plan.options)
    for key, shape in law.info_shapes.items():
        values = np.asarray(trajectory.info[key])
        assert values.shape[1:] == shape, key
        assert np.all(np.isfinite(values[1:])), key


def test_offsets_for_another_vehicle_are_refused(paper_vehicle):
    plan = plan_run(paper_vehicle, Scenario(duration=0.1))
    law = plan.arguments[-1]
    wrong = law.parameters._replace(info=law.parameters.info._replace(path_s=10**6))
    bad = dataclasses.replace(law, parameters=wrong)
    with pytest.raises(RecordSizeError, match=r"parameters\.info must be the offsets"):
        aiauv_pin.simulate(*plan.arguments[:-1], bad, **plan.options)
