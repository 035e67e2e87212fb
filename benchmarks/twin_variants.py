"""Twin variants simulated by several processes: the sim2real protocol's dataset build, one process against two.

    python benchmarks/twin_variants.py --data ../shared/data/cwru [--jobs 2] [--repeats 2]

``+experiment=sim2real`` (version 4: spin-slip and preload variants, randomized spall widths) with the
outer-race position left at the load zone, so 18 variants x 4 states x 8 speeds: each build in a fresh
cache, ``data.twin.n_jobs=1`` and ``=<jobs>`` alternating, the minimum over repeats. The windows of
both builds are compared to the bit. Prints a markdown block for benchmarks/RESULTS.md ("Twin
variants in parallel").
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import numpy as np
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.data.build import build_dataset

OVERRIDES = ["+experiment=sim2real", "~data.twin.randomize",
             "+data.twin.randomize={defect.width_mm: [0.178, 0.356, 0.533]}"]


def build(data_root: str, jobs: int):
    """The dataset built from an empty cache with ``data.twin.n_jobs=jobs``, and its wall time."""
    with tempfile.TemporaryDirectory() as cache, initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("train", overrides=[*OVERRIDES, f"data.root={data_root}", f"data.twin.n_jobs={jobs}",
                                          f"paths.cache_dir={cache}"])
        start = time.perf_counter()
        dataset = build_dataset(cfg)
        return dataset, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the folder of the CWRU records")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    times = {1: [], args.jobs: []}
    windows = {}
    for _ in range(args.repeats):
        for jobs in times:  # alternating: the shared machine's load falls on both alike
            dataset, seconds = build(args.data, jobs)
            times[jobs].append(seconds)
            windows[jobs] = dataset.windows
    same = np.array_equal(windows[1], windows[args.jobs])
    n_twin = len(dataset.fixed_split[0])
    one, many = min(times[1]), min(times[args.jobs])
    print(f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, shared with other jobs")
    print(f"- command: `python benchmarks/twin_variants.py --data {args.data} --jobs {args.jobs} "
          f"--repeats {args.repeats}`")
    print()
    print(f"| data.twin.n_jobs | dataset build, s (min of {args.repeats}) | relative to 1 |")
    print("|---|---|---|")
    print(f"| 1 | {one:.1f} | 1.00 |")
    print(f"| {args.jobs} | {many:.1f} | **{one / many:.2f}x** faster |")
    print()
    print(f"- {n_twin} twin training windows; windows of both builds identical to the bit: {same}")


if __name__ == "__main__":
    main()
