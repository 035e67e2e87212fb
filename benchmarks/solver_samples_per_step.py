"""Fast solver: one RK4 step over several samples against a step per sample.

    python benchmarks/solver_samples_per_step.py [--seconds 1] [--repeats 5] [--reference-seconds 0.25]

Sampled finer than the contact dynamics and the defect crossing ask (the CWRU bearing at
48 kHz, HUST's 51.2 kHz), :func:`bearingtwin.physics.solvers.fast.samples_per_step` lets a step
span several samples and reads the samples inside it off the step's Hermite interpolant. The
reference it replaces is the same stepper at one step per sample (``samples_per_step`` forced
to 1). Both run the same simulations in one process, alternating; their agreement with each
other and with the adaptive reference solver (scipy RK45, ``--reference-seconds`` of signal) is
printed beside the times. Prints a markdown block for benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.physics import simulator
from bearingtwin.physics.solvers import fast

CASES = (("outer", 48000.0), ("inner", 48000.0), ("ball", 51200.0), ("inner", 25600.0))
"""The identifiability benchmark's high rates, HUST's rate, and a rate with one sample per step (a control)."""


def lowest_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """The lowest correlation over the four race channels."""
    return min(float(np.corrcoef(x, y)[0, 1]) for x, y in zip(a, b))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--reference-seconds", type=float, default=0.25)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=["bearing=cwru_6205", "measured.path=unused"])
    bearing = OmegaConf.to_container(cfg.bearing, resolve=True)
    several = fast.samples_per_step
    steppers = {"a step per sample": lambda *resolution: 1, "several samples per step": several}
    rows = []
    for fault, fs in CASES:
        settings = OmegaConf.to_container(cfg.simulator, resolve=True)
        settings.update(rpm=1772.0, fs=fs)
        times = {name: [] for name in steppers}
        outputs, short, meta = {}, {}, {}
        for _ in range(args.repeats + 1):  # the first round compiles / loads the numba cache
            for name, rule in steppers.items():
                fast.samples_per_step = rule
                start = time.perf_counter()
                recording, outputs[name] = simulator.simulate(fault, bearing, {**settings, "duration": args.seconds})
                times[name].append(time.perf_counter() - start)
                meta[name] = recording.meta
        for name, rule in steppers.items():
            fast.samples_per_step = rule
            _, short[name] = simulator.simulate(fault, bearing, {**settings, "duration": args.reference_seconds})
        fast.samples_per_step = several  # restored for the next case (the reference solver does not use it)
        per_step = meta["several samples per step"]["samples_per_step"]
        _, reference = simulator.simulate(fault, bearing, {**settings, "duration": args.reference_seconds,
                                                           "solver": "reference"})
        one, many = outputs["a step per sample"], outputs["several samples per step"]
        difference = np.abs(many - one).max() / np.abs(one).max()
        before, after = (statistics.median(times[name][1:]) for name in steppers)
        rows.append(f"| {fault}, {fs / 1000:g} kHz | {per_step} | {before:.3f} s | {after:.3f} s | "
                    f"**{before / after:.2f}x** | {difference:.1e} | "
                    f"{lowest_correlation(short['a step per sample'], reference):.6f} | "
                    f"{lowest_correlation(short['several samples per step'], reference):.6f} |")
    print(f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, shared with other jobs")
    print(f"- command: `python benchmarks/solver_samples_per_step.py --seconds {args.seconds:g} "
          f"--repeats {args.repeats} --reference-seconds {args.reference_seconds:g}`")
    print()
    print("| simulation (CWRU 6205, 1772 rpm) | samples per step | a step per sample (median) | several (median) "
          "| speed-up | largest difference / peak | correlation with reference: a step per sample | : several |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
