"""Integrators of the bearing model: ``fast`` (numba fixed-step RK4) and ``reference`` (scipy RK45).

Both take the same inputs (dynamic parameters, sampled kinematics, defect, initial
state) and return the accelerations of the four degrees of freedom, (4, n) in m/s^2,
at the kinematic grid's sample times from ``first_sample`` on.
"""

SOLVERS = ("fast", "reference")
