"""Fixed-step fourth-order Runge-Kutta in numba: the everyday solver.

Why fixed-step RK4: the model is smooth (the defect profile has a continuous slope,
the Hertz force a continuous slope at first contact) and mildly stiff at most, so an
explicit method with a step that resolves the fastest contact mode and the defect
crossing is accurate, and a fixed step makes the cost predictable and the loop free
of error-control overhead. The step is 1 / (fs x substeps), substeps chosen by
:func:`substeps_per_sample` from the contact dynamics, so every output sample falls
on a step. Sampled finer than the dynamics ask (48 kHz and above for the usual
bearings), a step spans several samples (:func:`samples_per_step`) and the samples
inside it are read off the step's cubic Hermite interpolant, whose error is of the
step's own order. Accuracy is checked against the adaptive reference solver in the tests.

:func:`derivative` re-implements :func:`bearingtwin.physics.dynamics.state_derivative`
in scalar loops (tested equal at random states), from the balls' direction cosines and sines
that :func:`_geometry` computes with the kinematics and defect depths, through the same
compiled functions as the reference solver.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bearingtwin.physics.defects import defect_depths
from bearingtwin.physics.dynamics import DynamicParameters
from bearingtwin.physics.kinematics import Kinematics, add_roughness, sample_kinematics


def _longest_step_s(highest_mode_hz: float, crossing_time_s: float, steps_per_period: int,
                    steps_per_defect: int) -> float:
    """The longest RK4 step (s) that is at most 1/``steps_per_period`` of the fastest contact mode's
    period and 1/``steps_per_defect`` of a defect crossing."""
    return min(1.0 / (highest_mode_hz * steps_per_period), crossing_time_s / steps_per_defect)


def substeps_per_sample(fs_hz: float, highest_mode_hz: float, crossing_time_s: float, steps_per_period: int,
                        steps_per_defect: int) -> int:
    """RK4 steps per output sample so that no step is longer than :func:`_longest_step_s`."""
    step_s = _longest_step_s(highest_mode_hz, crossing_time_s, steps_per_period, steps_per_defect)
    return max(1, math.ceil(1.0 / (fs_hz * step_s) - 1e-9))  # 2.0000000000000004 is 2 steps


def samples_per_step(fs_hz: float, highest_mode_hz: float, crossing_time_s: float, steps_per_period: int,
                     steps_per_defect: int) -> int:
    """Output samples per RK4 step when the sampling is finer than :func:`_longest_step_s` asks; 1 otherwise."""
    step_s = _longest_step_s(highest_mode_hz, crossing_time_s, steps_per_period, steps_per_defect)
    return max(1, math.floor(fs_hz * step_s + 1e-9))


@njit(cache=True, nogil=True)  # nogil: the ranking screens candidates in threads
def derivative(state, cosines, sines, depths, shaft_angle, shaft_speed, p, out):
    """d(state)/dt into ``out``, given each ball's direction cosine and sine (:func:`_geometry`);
    ``p`` is ``DynamicParameters.as_array()``."""
    inner_mass, outer_mass = p[0], p[1]
    inner_damping, outer_damping = p[2], p[3]
    inner_stiffness, outer_stiffness = p[4], p[5]
    contact_stiffness, clearance = p[6], p[7]
    eccentricity, load_x, load_y, gravity = p[9], p[10], p[11], p[12]
    contact_damping = p[13]
    relative_x = state[0] - state[2]
    relative_y = state[1] - state[3]
    relative_vx = state[4] - state[6]
    relative_vy = state[5] - state[7]
    force_x = 0.0
    force_y = 0.0
    for j in range(cosines.size):
        c = cosines[j]
        s = sines[j]
        deflection = relative_x * c + relative_y * s - clearance - depths[j]
        if deflection > 0.0:
            load = contact_stiffness * deflection * math.sqrt(deflection)
            load = max(load + contact_damping * (relative_vx * c + relative_vy * s), 0.0)
            force_x += load * c
            force_y += load * s
    unbalance = inner_mass * eccentricity * shaft_speed * shaft_speed
    out[0] = state[4]
    out[1] = state[5]
    out[2] = state[6]
    out[3] = state[7]
    out[4] = (-force_x + unbalance * math.cos(shaft_angle) + load_x
              - inner_damping * state[4] - inner_stiffness * state[0]) / inner_mass
    out[5] = (-force_y + unbalance * math.sin(shaft_angle) + load_y - inner_mass * gravity
              - inner_damping * state[5] - inner_stiffness * state[1]) / inner_mass
    out[6] = (force_x - outer_damping * state[6] - outer_stiffness * state[2]) / outer_mass
    out[7] = (force_y - outer_mass * gravity - outer_damping * state[7] - outer_stiffness * state[3]) / outer_mass


@njit(cache=True, nogil=True)
def _geometry(t, fs, shaft, speed, cage, spin, offsets, roughness, defect, angles, depths, cosines, sines):
    """Everything at time ``t`` that does not depend on the state: the balls' angles, their cosines
    and sines, the defect depths and roughness under them; returns (shaft angle, shaft speed)."""
    shaft_angle, shaft_speed, spin_angle = sample_kinematics(t, fs, shaft, speed, cage, spin, offsets, angles)
    defect_depths(defect, angles, shaft_angle, spin_angle, depths)
    add_roughness(t, fs, roughness, depths)
    for j in range(angles.size):
        cosines[j] = math.cos(angles[j])
        sines[j] = math.sin(angles[j])
    return shaft_angle, shaft_speed


@njit(cache=True, nogil=True)
def _ball_arrays(n_balls):
    """Scratch arrays of the per-ball geometry: angles, defect depths, cosines, sines."""
    return np.empty(n_balls), np.empty(n_balls), np.empty(n_balls), np.empty(n_balls)


@njit(cache=True, nogil=True)
def _rk4_step(state, t, dt, k1, k2, k3, k4, trial, fs, shaft, speed, cage, spin, offsets, roughness, defect, p,
              mid_angles, mid_depths, mid_cosines, mid_sines, end_angles, end_depths, end_cosines, end_sines):
    """One classical RK4 step from ``t`` over ``dt``, in place on ``state``, given its first stage ``k1``.

    The midpoint's geometry goes to the ``mid_*`` arrays and the end's to the ``end_*`` arrays
    (the same arrays when the midpoint's is not needed afterwards); returns the shaft angle and
    speed at the midpoint and at the end.
    """
    for m in range(8):
        trial[m] = state[m] + 0.5 * dt * k1[m]
    mid_angle, mid_speed = _geometry(t + 0.5 * dt, fs, shaft, speed, cage, spin, offsets, roughness, defect, mid_angles,
                                     mid_depths, mid_cosines, mid_sines)
    derivative(trial, mid_cosines, mid_sines, mid_depths, mid_angle, mid_speed, p, k2)
    for m in range(8):
        trial[m] = state[m] + 0.5 * dt * k2[m]
    derivative(trial, mid_cosines, mid_sines, mid_depths, mid_angle, mid_speed, p, k3)
    for m in range(8):
        trial[m] = state[m] + dt * k3[m]
    end_angle, end_speed = _geometry(t + dt, fs, shaft, speed, cage, spin, offsets, roughness, defect, end_angles,
                                     end_depths, end_cosines, end_sines)
    derivative(trial, end_cosines, end_sines, end_depths, end_angle, end_speed, p, k4)
    for m in range(8):
        state[m] += dt / 6.0 * (k1[m] + 2.0 * k2[m] + 2.0 * k3[m] + k4[m])
    return mid_angle, mid_speed, end_angle, end_speed


@njit(cache=True, nogil=True)  # nogil: the ranking screens candidates in threads
def _advance(state, first_sample, n_samples, substeps, fs, shaft, speed, cage, spin, offsets, roughness, defect, p,
             accelerations):
    """Integrate from sample ``first_sample`` over ``n_samples`` samples, in place on ``state``;
    the acceleration at each sample's start goes to ``accelerations[:, i]``.

    The geometry (:func:`_geometry`: interpolation, defect profile, a cosine and a sine per ball)
    costs more than the contact forces, and an RK4 step asks for it at three times, not four:
    the two midpoint stages share one, and the end of a step is the next step's start whenever
    the two times are the same number (a time computed both ways may differ in its last bit, and
    then it is computed again, so the result is the same to the bit as evaluating every stage).
    """
    n_balls = offsets.shape[1]
    angles, depths, cosines, sines = _ball_arrays(n_balls)
    k1 = np.empty(8)
    k2 = np.empty(8)
    k3 = np.empty(8)
    k4 = np.empty(8)
    trial = np.empty(8)
    dt = 1.0 / (fs * substeps)
    ready_at = -1.0  # the time the geometry arrays hold: none yet
    shaft_angle = 0.0
    shaft_speed = 0.0
    for i in range(n_samples):
        sample = first_sample + i
        for step in range(substeps):
            t = sample / fs + step * dt
            if t != ready_at:
                shaft_angle, shaft_speed = _geometry(t, fs, shaft, speed, cage, spin, offsets, roughness, defect,
                                                     angles, depths, cosines, sines)
            derivative(state, cosines, sines, depths, shaft_angle, shaft_speed, p, k1)
            if step == 0:
                for dof in range(4):
                    accelerations[dof, i] = k1[4 + dof]
            ready_at = t + dt
            _, _, shaft_angle, shaft_speed = _rk4_step(state, t, dt, k1, k2, k3, k4, trial, fs, shaft, speed, cage, spin,
                                                       offsets, roughness, defect, p, angles, depths, cosines,
                                                       sines, angles, depths, cosines, sines)


@njit(cache=True, nogil=True)
def _advance_over_samples(state, first_sample, n_samples, per_step, fs, shaft, speed, cage, spin, offsets, roughness,
                          defect, p, accelerations):
    """:func:`_advance` with one RK4 step over ``per_step`` samples (fewer at the end of the stretch).

    A step's first sample takes the derivative at its start (the step's first stage, as in
    :func:`_advance`); each sample inside the step takes the derivative at the state of the
    step's cubic Hermite interpolant (from the states and derivatives at both ends, an error of
    the order of the step's own). The derivative at a step's end is the next step's first stage,
    and a sample at the step's middle shares the midpoint stages' geometry, so two samples per
    step cost two geometry evaluations and five derivatives instead of four and eight.
    """
    n_balls = offsets.shape[1]
    angles, depths, cosines, sines = _ball_arrays(n_balls)
    mid_angles, mid_depths, mid_cosines, mid_sines = _ball_arrays(n_balls)  # the midpoint's, kept for inside samples
    k1 = np.empty(8)
    k2 = np.empty(8)
    k3 = np.empty(8)
    k4 = np.empty(8)
    k_end = np.empty(8)
    k_inside = np.empty(8)
    trial = np.empty(8)
    start = np.empty(8)
    shaft_angle, shaft_speed = _geometry(first_sample / fs, fs, shaft, speed, cage, spin, offsets, roughness, defect,
                                         angles, depths, cosines, sines)
    derivative(state, cosines, sines, depths, shaft_angle, shaft_speed, p, k1)
    i = 0
    while i < n_samples:
        count = min(per_step, n_samples - i)
        t = (first_sample + i) / fs
        dt = count / fs
        for dof in range(4):
            accelerations[dof, i] = k1[4 + dof]
        for m in range(8):
            start[m] = state[m]
        mid_angle, mid_speed, shaft_angle, shaft_speed = _rk4_step(
            state, t, dt, k1, k2, k3, k4, trial, fs, shaft, speed, cage, spin, offsets, roughness, defect, p,
            mid_angles, mid_depths, mid_cosines, mid_sines, angles, depths, cosines, sines)
        derivative(state, cosines, sines, depths, shaft_angle, shaft_speed, p, k_end)
        for inside in range(1, count):
            theta = inside / count
            h00 = (2.0 * theta - 3.0) * theta * theta + 1.0
            h10 = ((theta - 2.0) * theta + 1.0) * theta
            h01 = (3.0 - 2.0 * theta) * theta * theta
            h11 = (theta - 1.0) * theta * theta
            for m in range(8):
                trial[m] = h00 * start[m] + h10 * dt * k1[m] + h01 * state[m] + h11 * dt * k_end[m]
            if 2 * inside == count:
                derivative(trial, mid_cosines, mid_sines, mid_depths, mid_angle, mid_speed, p, k_inside)
            else:
                inside_angle, inside_speed = _geometry(t + theta * dt, fs, shaft, speed, cage, spin, offsets, roughness,
                                                       defect, angles, depths, cosines, sines)
                derivative(trial, cosines, sines, depths, inside_angle, inside_speed, p, k_inside)
            for dof in range(4):
                accelerations[dof, i + inside] = k_inside[4 + dof]
        for m in range(8):
            k1[m] = k_end[m]
        i += count


def integrate(params: DynamicParameters, kinematics: Kinematics, defect: np.ndarray, initial_state: np.ndarray,
              first_sample: int, n_samples: int, substeps: int, progress=None, per_step: int = 1) -> np.ndarray:
    """Accelerations (4, n_samples) in m/s^2 at grid samples ``first_sample`` .. + n_samples - 1.

    Integration starts at t = 0 from ``initial_state``; the samples before ``first_sample``
    (the start-up transient) are computed and dropped. ``substeps`` RK4 steps per sample or,
    with ``substeps`` = 1, one step per ``per_step`` samples (:func:`samples_per_step`).
    ``progress``: a tqdm-like bar advanced by the number of samples done, updated about once
    per simulated second.
    """
    if first_sample + n_samples >= kinematics.n_samples:
        raise ValueError("the kinematic grid must extend one sample beyond the last output sample")
    if substeps > 1 and per_step > 1:
        raise ValueError("a step spans several samples or a sample several steps, not both")
    state = np.array(initial_state, dtype=np.float64)
    arrays = kinematics.solver_arrays()
    p = params.as_array()
    total = first_sample + n_samples
    accelerations = np.empty((4, total))
    chunk = max(per_step, int(kinematics.fs_hz) // per_step * per_step)  # whole steps in every chunk
    for start in range(0, total, chunk):
        count = min(chunk, total - start)
        if per_step > 1:
            _advance_over_samples(state, start, count, per_step, kinematics.fs_hz, *arrays, defect, p,
                                  accelerations[:, start:start + count])
        else:
            _advance(state, start, count, substeps, kinematics.fs_hz, *arrays, defect, p,
                     accelerations[:, start:start + count])
        if progress is not None:
            progress.update(count)
    return accelerations[:, first_sample:]
