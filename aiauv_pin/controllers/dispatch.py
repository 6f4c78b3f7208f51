"""Which compiled controller the loop runs: a user's function, or a built-in one chosen by type.

numba's on-disk cache cannot key a compiled function on an argument that is itself a function
(:func:`aiauv_hydro.numerics.jit.user_or_builtin`), so the cached loop is given ``controller = None`` for the
built-in controllers and :func:`run_controller` chooses among them at compile time by the type of
their parameters. A new built-in controller is its module plus one branch here.
"""

from __future__ import annotations

from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE
from aiauv_pin.controllers.paper_compiled import PaperParameters, paper_path_following, passive
from aiauv_pin.controllers.turning_compiled import TurningParameters, thruster_turning

#: The built-in compiled controllers (given to the loop as ``None``).
BUILTIN_CONTROLLERS = (passive, paper_path_following, thruster_turning)


def run_controller(user, t, q, v, model, workspace, parameters, state, tau, info):
    """``user(...)``, or with ``user = None`` the built-in controller ``parameters`` select:
    :class:`PaperParameters` the paper's, :class:`TurningParameters` thruster turning, anything else
    passive. Compiled, the choice is made at compile time (an overload)."""
    if user is not None:
        return user(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, PaperParameters):
        return paper_path_following(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, TurningParameters):
        return thruster_turning(t, q, v, model, workspace, parameters, state, tau, info)
    return passive(t, q, v, model, workspace, parameters, state, tau, info)


if NUMBA_AVAILABLE:
    from numba import types
    from numba.extending import overload

    def _is(parameters, record) -> bool:
        return isinstance(parameters, types.BaseNamedTuple) and parameters.instance_class is record

    @overload(run_controller)
    def _run_controller(user, t, q, v, model, workspace, parameters, state, tau, info):
        if not isinstance(user, (types.NoneType, types.Omitted)):

            def call_user(user, t, q, v, model, workspace, parameters, state, tau, info):
                user(t, q, v, model, workspace, parameters, state, tau, info)

            return call_user
        if _is(parameters, PaperParameters):

            def call_paper(user, t, q, v, model, workspace, parameters, state, tau, info):
                paper_path_following(t, q, v, model, workspace, parameters, state, tau, info)

            return call_paper
        if _is(parameters, TurningParameters):

            def call_turning(user, t, q, v, model, workspace, parameters, state, tau, info):
                thruster_turning(t, q, v, model, workspace, parameters, state, tau, info)

            return call_turning

        def call_passive(user, t, q, v, model, workspace, parameters, state, tau, info):
            passive(t, q, v, model, workspace, parameters, state, tau, info)

        return call_passive
