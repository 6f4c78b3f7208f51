"""Second implementations kept on purpose: interpreted mirrors of compiled code, each pinned to it.

The compiled kernels of :mod:`aiauv_pin.kernels` are the implementation a simulation runs; what
lives here computes the same thing another way, for the models the kernels do not take and as the
reference the kernels are tested against:

* :mod:`aiauv_pin.reference.integrators`: the integrators (RK4 Munthe-Kaas, semi-implicit Euler,
  midpoint) on Pinocchio's Lie group, any joint Pinocchio knows. They step the Pinocchio backend;
  ``tests/kernels/test_fast.py`` pins each method to its compiled twin in
  :mod:`aiauv_pin.kernels.articulated_body` (``rk4_into``, ``euler_into``,
  ``midpoint_stage_into``/``midpoint_final_into``) to 1e-9.

May import Pinocchio, NumPy and the floors below :mod:`aiauv_pin.dynamics`.
"""
