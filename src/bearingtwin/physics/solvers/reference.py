"""The reference solver: scipy's adaptive RK45 (Dormand-Prince, MATLAB's ode45) as in the paper.

The paper ran ode45 at rtol 1e-3, atol 1e-6. Two things make that setting unsafe on
its own: the step-size control can stride over a 0.3 ms defect crossing in one step
while the ball is out of the pit, and an absolute tolerance of 1e-6 (m, m/s) is
larger than the micrometre displacements being computed. ``max_step`` is therefore
bounded by a fraction of the defect-crossing time, and the tolerances are parameters
so that a tightened reference can be used to judge both (see tests/test_solvers.py).
"""

from __future__ import annotations

import numpy as np
import scipy.integrate

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.defects import defect_depths
from bearingtwin.physics.dynamics import DynamicParameters, state_derivative
from bearingtwin.physics.kinematics import Kinematics, add_roughness, sample_kinematics


def integrate(params: DynamicParameters, kinematics: Kinematics, defect: np.ndarray, initial_state: np.ndarray,
              first_sample: int, n_samples: int, rtol: float, atol: float, max_step_s: float) -> np.ndarray:
    """Accelerations (4, n_samples) in m/s^2 at grid samples ``first_sample`` .. + n_samples - 1,
    integrating from t = 0 and ``initial_state``."""
    if first_sample + n_samples >= kinematics.n_samples:
        raise ValueError("the kinematic grid must extend one sample beyond the last output sample")
    fs = kinematics.fs_hz
    *angle_series, roughness = kinematics.solver_arrays()
    angles = np.empty(kinematics.n_balls)
    depths = np.empty(kinematics.n_balls)

    def rhs(t, state):
        shaft_angle, shaft_speed, spin_angle = sample_kinematics(t, fs, *angle_series, angles)
        defect_depths(defect, angles, shaft_angle, spin_angle, depths)
        add_roughness(t, fs, roughness, depths)
        return state_derivative(state, angles, depths, shaft_angle, shaft_speed, params)

    times = (first_sample + np.arange(n_samples)) / fs
    solution = scipy.integrate.solve_ivp(rhs, (0.0, times[-1]), np.asarray(initial_state, dtype=np.float64),
                                         method="RK45", t_eval=times, rtol=rtol, atol=atol, max_step=max_step_s)
    if not solution.success:
        raise BearingTwinError(f"the reference solver failed: {solution.message}")
    return np.stack([rhs(t, y)[4:] for t, y in zip(solution.t, solution.y.T)], axis=1)
