"""Anti-aliasing benchmark: what ``simulator.oversample`` removes and what it costs.

    python benchmarks/anti_alias.py [--seconds 2] [--repeats 3]
    python benchmarks/anti_alias.py --sim2real-features ../shared/data/cwru

For each bearing at the rate its data is recorded at (the paper's at 10 kHz, the CWRU 6205 at
12 kHz; 1797 rpm, the housing's vertical channel ``outer_y``), every fault state simulated with
``oversample`` 1 (samples of the solution at fs, the paper's way), 2 and 4, against the truth: the
solution 8 times finer through an ideal low-pass (FFT truncation) to fs. Prints a markdown block
for benchmarks/RESULTS.md ("Anti-aliasing"): each record's power in the top two kHz bands below
fs/2 relative to the truth's, and each setting's wall time relative to ``oversample`` 1's within
this one run (the minimum over repeats; the machine is shared).

With ``--sim2real-features <CWRU folder>``: what oversampling would change in the sim2real
protocol's features instead. Version 4's twin records (``+experiment=sim2real``, seed 0, as
calibrated: no variants, no randomized sizes) at oversample 1 and 4, each window's features as the
protocol reads them; per state, the largest shift of a feature's median and that shift over the
feature's interquartile range among the state's windows. No real record is scored.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import numpy as np
import scipy.signal
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR, bearing_config
from bearingtwin.physics.simulator import simulate

SETTINGS = (("paper", 10000.0), ("cwru_6205", 12000.0))  # each bearing at the rate its data is recorded at
FACTORS = (1, 2, 4)
TRUTH_FACTOR = 8


def band_powers(signal: np.ndarray, fs: float, edges_hz: list[float]) -> np.ndarray:
    freqs, psd = scipy.signal.welch(signal, fs=fs, nperseg=1024)
    return np.array([psd[(freqs >= low) & (freqs < high)].sum() for low, high in zip(edges_hz[:-1], edges_hz[1:])])


def ideal_low_pass(signal: np.ndarray, factor: int) -> np.ndarray:
    """``signal`` cut to 1/``factor`` of its rate by truncating its spectrum (no aliasing, no roll-off)."""
    n = signal.size // factor
    return np.fft.irfft(np.fft.rfft(signal)[: n // 2 + 1], n) / factor


def sim2real_features(data_root: str, oversample: int, cache_dir: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The sim2real protocol's twin training windows' features (seed 0, as calibrated), their states, the state names."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.data.twin_to_real import build_twin_to_real_dataset
    from bearingtwin.features.extractor import build_feature_extractor

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("train", overrides=["+experiment=sim2real", f"data.root={data_root}", "data.twin.variants=null",
                                          "data.twin.randomize=null", f"simulator.oversample={oversample}"])
    dataset = build_twin_to_real_dataset(cfg.data, cfg.bearing, cfg.simulator, cfg.get("effects"), cache_dir)
    train = dataset.fixed_split[0]
    rpm = np.asarray(dataset.record_rpms)[dataset.record_ids[train]]
    extractor = build_feature_extractor(cfg.features).fit(dataset.windows[train], fs_hz=dataset.fs, rpm=rpm)
    return (extractor.transform(dataset.windows[train], fs_hz=dataset.fs, rpm=rpm), dataset.labels[train],
            list(dataset.class_names))


def feature_shift(data_root: str) -> None:
    with tempfile.TemporaryDirectory() as cache_dir:
        (plain, states, names), (filtered, _, _) = (sim2real_features(data_root, q, cache_dir) for q in (1, 4))
    print(f"- command: `python benchmarks/anti_alias.py --sim2real-features {data_root}`; "
          f"{plain.shape[0]} twin windows, {plain.shape[1]} features")
    print()
    print("| state | largest shift of a feature's median, oversample 1 -> 4 | over its interquartile range |")
    print("|---|---|---|")
    for index, name in enumerate(names):
        before, after = plain[states == index], filtered[states == index]
        shift = np.abs(np.median(after, axis=0) - np.median(before, axis=0))
        spread = np.subtract(*np.percentile(before, [75, 25], axis=0))
        print(f"| {name} | {shift.max():.3f} | {(shift / spread).max():.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sim2real-features", metavar="CWRU_FOLDER",
                        help="instead: the sim2real protocol's feature shift (needs the CWRU records)")
    args = parser.parse_args()
    if args.sim2real_features:
        feature_shift(args.sim2real_features)
        return
    base = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml"))
    base.update(rpm=1797.0, duration=args.seconds, sensor="outer_y")
    rows, times = [], {factor: 0.0 for factor in FACTORS}
    for bearing_name, fs in SETTINGS:
        bearing = bearing_config(bearing_name)
        edges = [fs / 2 - 2000.0, fs / 2 - 1000.0, fs / 2]
        for fault in ("outer", "inner", "ball"):
            simulate(fault, bearing, {**base, "fs": fs, "duration": 0.1})  # compile / load the numba cache
            fine, _ = simulate(fault, bearing, {**base, "fs": TRUTH_FACTOR * fs})
            truth = band_powers(ideal_low_pass(fine.signal, TRUTH_FACTOR), fs, edges)
            ratios = []
            for factor in FACTORS:
                best = np.inf
                for _ in range(args.repeats):
                    start = time.perf_counter()
                    record, _ = simulate(fault, bearing, {**base, "fs": fs, "oversample": factor})
                    best = min(best, time.perf_counter() - start)
                times[factor] += best
                ratios.append(band_powers(record.signal, fs, edges) / truth)
            rows.append((bearing_name, fs, fault, ratios))

    print(f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, shared with other jobs")
    print(f"- command: `python benchmarks/anti_alias.py --seconds {args.seconds:g} --repeats {args.repeats}`")
    print()
    header = " | ".join(f"oversample {f}: {lo} / {hi}" for f in FACTORS for lo, hi in [("lower kHz", "top kHz")])
    print(f"| bearing | fs | fault | {header} |")
    print("|---|---|---|" + "---|" * len(FACTORS))
    for bearing_name, fs, fault, ratios in rows:
        cells = " | ".join(f"{r[0]:.2f} / {r[1]:.2f}" for r in ratios)
        print(f"| {bearing_name} | {fs / 1000:g} kHz | {fault} | {cells} |")
    print()
    print("Power in the two kHz bands just below fs/2, relative to the truth's (1.00: as an ideal "
          "anti-aliasing filter leaves it).")
    print()
    print("- wall time of all six records relative to oversample 1 (minimum of "
          f"{args.repeats} runs each): " + ", ".join(f"oversample {f}: **{times[f] / times[1]:.2f}x**" for f in FACTORS)
          + f" ({times[1]:.2f} s at oversample 1)")


if __name__ == "__main__":
    main()
