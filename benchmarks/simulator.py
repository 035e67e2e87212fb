"""Simulator benchmark: the paper's dataset (30 s of all four states at 10 kHz), fast vs reference.

    python benchmarks/simulator.py [--reference-seconds 2]

Prints a markdown block for benchmarks/RESULTS.md ("Simulator"). The reference solver is
timed on a shorter signal of every state and compared with the fast solver on exactly
the same signal (same states, same duration, one process each), so the ratio is like for like.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.physics.simulator import simulate, simulate_many


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    function(*args, **kwargs)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference-seconds", type=float, default=2.0)
    args = parser.parse_args()
    bearing = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
    simulator = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")
    paper = OmegaConf.merge(simulator, {"duration": 30.0})
    simulate("outer", bearing, OmegaConf.merge(simulator, {"duration": 0.1}))  # compile / load the numba cache

    dataset_parallel = timed(simulate_many, FAULTS, bearing, paper, n_jobs=2)
    dataset_serial = timed(simulate_many, FAULTS, bearing, paper, n_jobs=1)
    short = OmegaConf.merge(simulator, {"duration": args.reference_seconds})
    fast_short = sum(timed(simulate, fault, bearing, short) for fault in FAULTS)
    reference = OmegaConf.merge(short, {"solver": "reference"})
    reference_short = sum(timed(simulate, fault, bearing, reference) for fault in FAULTS)

    print(f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, shared with other jobs")
    print("- command: `python benchmarks/simulator.py"
          f" --reference-seconds {args.reference_seconds:g}`")
    print(f"- 30 s x 4 states at 10 kHz, fast solver, 2 processes: **{dataset_parallel:.2f} s** "
          f"(1 process: {dataset_serial:.2f} s)")
    print(f"- {args.reference_seconds:g} s x 4 states, one process: fast {fast_short:.2f} s, "
          f"reference (RK45, rtol 1e-3, atol 1e-6, max_step = crossing / 6) {reference_short:.2f} s: "
          f"**ratio {reference_short / fast_short:.0f}x**")


if __name__ == "__main__":
    main()
