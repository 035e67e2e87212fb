"""Benchmark: one SABO-VMD search (N = 15, T = 20: 315 decompositions + fitness) on 2048 points.

Target: under 5 s per search. The reference is the straightforward stack the paper's
pipeline would be written with - vmdpy 0.2 for the decomposition, antropy for the
permutation entropy, a plain loop over trials - timed on ``--reference-trials`` trials
spread evenly over the same study and scaled to 315 (running all of it takes minutes).

With ``--table2`` it instead reproduces the paper's Table 2 (per-class SABO-VMD parameters)
on the twin's simulated dataset (``conf/data/simulated.yaml``, shortened by ``--duration``).

Usage:
    python benchmarks/sabo.py [--repeats 3] [--reference-trials 15]
    python benchmarks/sabo.py --table2 [--duration 5] [--fitness pe_mie]
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from bearingtwin.features.fitness import FITNESS, optimal_mode
from bearingtwin.optim.search import OPTIMIZERS, search_vmd_params
from bearingtwin.signal import mean_mode_mutual_information

FS = 12000.0
N = 2048
PAPER_TABLE_2 = ((8, 2313, 1), (3, 454, 1), (3, 275, 1), (10, 2291, 2))  # (k, alpha, optimal IMF) per label


def bearing_signal(seed: int = 0) -> np.ndarray:
    """Outer-race-like impacts (107 Hz) ringing at 3 kHz, a shaft tone and noise, 2048 points at 12 kHz."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(N) / FS
    since = np.mod(time_s, 1 / 107.0)
    impacts = np.exp(-since * 900) * np.sin(2 * np.pi * 3000 * since)
    return impacts + 0.3 * np.sin(2 * np.pi * 29.95 * time_s) + 0.1 * rng.normal(size=N)


def timed(function, repeats: int) -> tuple[float, object]:
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def reference_seconds_per_trial(signal: np.ndarray, params: list[dict]) -> float:
    """vmdpy + antropy PE + this package's envelope entropy / MIE, one trial at a time."""
    import antropy
    from vmdpy import VMD

    start = time.perf_counter()
    for p in params:
        modes, _, _ = VMD(signal, p["alpha"], 0.0, p["k"], 0, 1, 1e-7)
        used = modes[optimal_mode(modes)]
        float(antropy.perm_entropy(used, order=5, delay=1, normalize=True) + mean_mode_mutual_information(modes))
    return (time.perf_counter() - start) / len(params)


def table2(duration_s: float, fitness: str, seed: int) -> None:
    """Per-class search on the simulated dataset, printed as the paper's Table 2."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR
    from bearingtwin.data.simulated import build_simulated_dataset
    from bearingtwin.features.extractor import parameter_table

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        group = lambda name: compose(config_name=name)  # noqa: E731
        data = group("data/simulated").data
        data.duration = duration_s
        bearing, simulator, paths = group("bearing/paper").bearing, group("simulator/default").simulator, group("paths/default").paths
    dataset = build_simulated_dataset(data, bearing, simulator, {}, paths.cache_dir)
    start = time.perf_counter()
    rows = parameter_table(dataset.windows, dataset.labels, dataset.class_names, fitness=fitness, seed=seed)
    print(f"simulated dataset {dataset.key}: {len(dataset)} windows of {dataset.windows.shape[1]} points, "
          f"{duration_s} s per state; fitness {fitness}; {time.perf_counter() - start:.0f} s")
    print("| label | class | k | alpha | optimal IMF | fitness | paper k | paper alpha | paper IMF |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row, (k, alpha, imf) in zip(rows, PAPER_TABLE_2):
        print(f"| {row['label']} | {row['class']} | {row['k']} | {row['alpha']:.0f} | {row['optimal_imf']} "
              f"| {row['fitness']:.4f} | {k} | {alpha} | {imf} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--reference-trials", type=int, default=15)
    parser.add_argument("--table2", action="store_true")
    parser.add_argument("--duration", type=float, default=5.0, help="seconds simulated per state (--table2)")
    parser.add_argument("--fitness", default="pe_mie", choices=sorted(FITNESS))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.table2:
        table2(args.duration, args.fitness, args.seed)
        return
    signal = bearing_signal()
    search = lambda fitness, optimizer: search_vmd_params(signal, fitness, optimizer=optimizer, seed=0)  # noqa: E731
    search("pe_mie", "sabo")  # compile numba kernels outside the timing
    print(f"machine: {platform.processor() or platform.machine()}, {platform.system()}, python {platform.python_version()}")
    print("| fitness | optimizer | trials | distinct (k, alpha) | best s / search | ms / trial | best k | best alpha | best value |")
    print("|---|---|---|---|---|---|---|---|---|")
    results = {}
    for fitness in FITNESS:
        for optimizer in OPTIMIZERS:
            seconds, result = timed(lambda: search(fitness, optimizer), args.repeats)
            results[fitness, optimizer] = (seconds, result)
            n_trials = len(result.study.trials)
            distinct = len({(t.params["k"], t.params["alpha"]) for t in result.study.trials})
            print(
                f"| {fitness} | {optimizer} | {n_trials} | {distinct} | {seconds:.2f} | {1000 * seconds / n_trials:.1f} "
                f"| {result.k} | {result.alpha:.0f} | {result.value:.4f} |"
            )
    seconds, result = results["pe_mie", "sabo"]
    trials = result.study.trials
    params = [t.params for t in trials[:: max(1, len(trials) // args.reference_trials)]]
    reference = reference_seconds_per_trial(signal, params) * len(trials)
    print(
        f"\nreference (vmdpy + antropy, {len(params)} trials scaled to {len(trials)}): "
        f"{reference:.1f} s per search; speed-up {reference / seconds:.1f}x"
    )


if __name__ == "__main__":
    main()
