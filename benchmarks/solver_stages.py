"""Fast solver: geometry shared between RK4 stages against every stage evaluated afresh.

    python benchmarks/solver_stages.py [--seconds 1] [--repeats 5]

The compiled stepper (:func:`bearingtwin.physics.solvers.fast._advance`) evaluates the
geometry (kinematic interpolation, defect depths, a cosine and a sine per ball) at most three
times per RK4 step instead of four (the midpoint stages share it, and a step's end is the next
step's start when the two times are the same number). The reference it replaced, re-created
here with the same force routine, evaluates it at every stage. Both integrate the same simulations (the identifiability benchmark's sampling rates,
the CWRU bearing, 1 s each after the start-up transient) in one process, alternating, and must
agree to the bit. Prints a markdown block for benchmarks/RESULTS.md ("Fast solver: stages").
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np
from hydra import compose, initialize_config_dir
from numba import njit
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.physics import simulator
from bearingtwin.physics.solvers import fast


@njit(nogil=True)  # not cached: nothing written beside the script
def _stage(t, state, fs, shaft, speed, cage, spin, offsets, roughness, defect, p, angles, depths, cosines, sines, out):
    """One stage as before: the geometry at ``t`` afresh, then the forces."""
    shaft_angle, shaft_speed = fast._geometry(t, fs, shaft, speed, cage, spin, offsets, roughness, defect, angles,
                                              depths, cosines, sines)
    fast.derivative(state, cosines, sines, depths, shaft_angle, shaft_speed, p, out)


@njit(nogil=True)
def _every_stage(state, first_sample, n_samples, substeps, fs, shaft, speed, cage, spin, offsets, roughness, defect, p,
                 accelerations):
    """The stepper before stage sharing: kinematics, depths and trigonometry at each of the four stages."""
    n_balls = offsets.shape[1]
    angles, depths, cosines, sines = np.empty(n_balls), np.empty(n_balls), np.empty(n_balls), np.empty(n_balls)
    k1, k2, k3, k4, trial = np.empty(8), np.empty(8), np.empty(8), np.empty(8), np.empty(8)
    dt = 1.0 / (fs * substeps)
    for i in range(n_samples):
        sample = first_sample + i
        for step in range(substeps):
            t = sample / fs + step * dt
            _stage(t, state, fs, shaft, speed, cage, spin, offsets, roughness, defect, p, angles, depths, cosines,
                   sines, k1)
            if step == 0:
                for dof in range(4):
                    accelerations[dof, i] = k1[4 + dof]
            for m in range(8):
                trial[m] = state[m] + 0.5 * dt * k1[m]
            _stage(t + 0.5 * dt, trial, fs, shaft, speed, cage, spin, offsets, roughness, defect, p, angles, depths,
                   cosines, sines, k2)
            for m in range(8):
                trial[m] = state[m] + 0.5 * dt * k2[m]
            _stage(t + 0.5 * dt, trial, fs, shaft, speed, cage, spin, offsets, roughness, defect, p, angles, depths,
                   cosines, sines, k3)
            for m in range(8):
                trial[m] = state[m] + dt * k3[m]
            _stage(t + dt, trial, fs, shaft, speed, cage, spin, offsets, roughness, defect, p, angles, depths, cosines,
                   sines, k4)
            for m in range(8):
                state[m] += dt / 6.0 * (k1[m] + 2.0 * k2[m] + 2.0 * k3[m] + k4[m])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=["bearing=cwru_6205", "measured.path=unused"])
    bearing = OmegaConf.to_container(cfg.bearing, resolve=True)
    shared = fast._advance
    # A step per sample at every rate: at 48 kHz a step would otherwise span two samples, _advance would
    # not run, and the two 'steppers' would agree to the bit trivially.
    fast.samples_per_step = lambda *resolution: 1
    rows = []
    for fault, fs in (("outer", 12000.0), ("inner", 25600.0), ("inner", 48000.0)):
        settings = OmegaConf.to_container(cfg.simulator, resolve=True)
        settings.update(rpm=1772.0, fs=fs, duration=args.seconds)
        times = {"every stage": [], "shared": []}
        outputs = {}
        for _ in range(args.repeats + 1):  # the first round compiles / loads the numba cache
            for name, stepper in (("every stage", _every_stage), ("shared", shared)):
                fast._advance = stepper
                start = time.perf_counter()
                _, channels = simulator.simulate(fault, bearing, settings)
                times[name].append(time.perf_counter() - start)
                outputs[name] = channels
        fast._advance = shared
        if not np.array_equal(outputs["every stage"], outputs["shared"]):
            raise SystemExit(f"{fault} at {fs:g} Hz: the two steppers differ")
        before, after = (statistics.median(times[name][1:]) for name in ("every stage", "shared"))
        rows.append(f"| {fault}, {fs / 1000:g} kHz, {args.seconds:g} s | {before:.3f} s | {after:.3f} s | "
                    f"**{before / after:.2f}x** | yes |")
    print(f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, shared with other jobs")
    print(f"- command: `python benchmarks/solver_stages.py --seconds {args.seconds:g} --repeats {args.repeats}`")
    print()
    print("| simulation | every stage (median) | shared geometry (median) | speed-up | same to the bit |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
