"""The loop schedule, written once: what happens at step ``k`` of a fixed-step run.

Both loops call it, the compiled one (:mod:`aiauv_pin.simulation.compiled_loop`) and the
interpreted one of the
Pinocchio path (:func:`aiauv_pin.simulate` with a Python controller). The rules:

* the controller is sampled at ``t = k dt`` every ``steps_per_control`` steps, and its output is
  held over the steps up to the next sample (zero-order hold);
* with a method that samples inside the step (the midpoint method), the controller runs at every
  step's stage ``t + dt/2`` instead, and once more at the end of the run (for the last row's
  diagnostics); there is no sample at ``t = 0``: the first stage runs with no input (``tau = 0``),
  since a sample there would be held by a controller's integrators as if it applied over
  ``[0, dt/2]`` (a visible offset along the path on the paper's surge integral, issue 15);
* a row is logged every ``log_every`` steps and at the last step, after the sample of that step.
"""

from __future__ import annotations

from typing import NamedTuple

from aiauv_hydro.numerics.jit import compiled


class StepActions(NamedTuple):
    """What the loop does at step ``k``, in this order.

    Attributes:
        sample: Run the controller at ``t = k dt``.
        sample_at_stage: Run the controller at the step's stage ``t + dt/2`` (midpoint method).
        log: Log the row of ``t = k dt`` (after the sample).
        last: ``k`` is the last step: stop after logging (no integration).
    """

    sample: bool
    sample_at_stage: bool
    log: bool
    last: bool


@compiled
def step_actions(k, n_total, steps_per_control, log_every, inside):
    """The :class:`StepActions` of step ``k`` of a run of ``n_total`` steps.

    Args:
        k: Step index, ``0 <= k <= n_total``.
        n_total: Steps of the run.
        steps_per_control: Steps between two controller samples (1 with ``inside``).
        log_every: Steps between two logged rows.
        inside: The method samples the controller inside each step (the midpoint method).
    """
    last = k == n_total
    sample = k % steps_per_control == 0 and (not inside or last)
    return StepActions(sample, inside and not sample, k % log_every == 0 or last, last)


@compiled
def steps_to_next_event(k, n_total, steps_per_control, log_every):
    """Steps the loop may take from ``k`` without a sample, a row or the end in between: the
    interpreted loop integrates that many in one call."""
    to_sample = steps_per_control - k % steps_per_control
    to_log = log_every - k % log_every
    return min(to_sample, to_log, n_total - k)
