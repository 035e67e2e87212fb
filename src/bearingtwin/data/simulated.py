"""The paper's simulated dataset: one digital-twin record per bearing state, cut into windows.

Section 4.1 of the paper: 1797 rpm, 10 kHz, 30 s per state, 150 windows of 2048
points per state, labels in :data:`~bearingtwin.physics.geometry.FAULTS` order. The
records are the expensive part, so they are cached under ``cache_dir/simulated/``
keyed by a hash of everything that shapes them (bearing, simulator with the data
config's rpm/fs/duration, effects): a sweep over classifier or window settings
simulates once. Files are written to a temporary name and renamed into place, so
parallel sweep jobs either find a complete file or none; an unreadable one is removed and
simulated again.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Mapping

import numpy as np

from bearingtwin.checks import positive_number, whole_number
from bearingtwin.config import plain_config
from bearingtwin.data.recording import WindowedDataset
from bearingtwin.data.windows import check_split, check_stratified, cut_windows
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import order_identity
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.physics.simulator import records_identity, simulate_many
from bearingtwin.storage import SIMULATION_CODE, code_fingerprint, content_key, load_npz_or_heal, save_npz_atomic


DATA_SET_OPERATING_POINT = ("rpm", "fs", "duration")
"""The simulator settings the data set's own (``data.rpm`` ...) replace."""


def simulation_config(data_cfg: Mapping, simulator_cfg: Mapping) -> dict:
    """The simulator config with the dataset's operating point (rpm, fs, duration) applied."""
    simulator = plain_config(simulator_cfg)
    for name in DATA_SET_OPERATING_POINT:
        simulator[name] = data_cfg[name]
    return simulator


def records_key(data_cfg: Mapping, bearing_cfg: Mapping, simulator_cfg: Mapping, effects_cfg: Mapping | None) -> str:
    """Hash of everything that determines the simulated records."""
    effects = plain_config(effects_cfg)
    return content_key({"bearing": plain_config(bearing_cfg),
                        "simulator": records_identity(simulation_config(data_cfg, simulator_cfg)),
                        "effects": effects, **order_identity(effects), "faults": FAULTS})


def _simulated_records(data_cfg, bearing_cfg, simulator_cfg, effects_cfg, cache_dir) -> tuple[np.ndarray, str]:
    """Sensor signals (4, n) in FAULTS order, from the cache or freshly simulated (then cached)."""
    key = records_key(data_cfg, bearing_cfg, simulator_cfg, effects_cfg)
    path = Path(cache_dir) / "simulated" / f"records-{key}-{code_fingerprint(*SIMULATION_CODE)}.npz"
    cached = load_npz_or_heal(path, "signals")
    if cached is not None:
        return cached["signals"], key
    results = simulate_many(FAULTS, bearing_cfg, simulation_config(data_cfg, simulator_cfg), effects_cfg,
                            n_jobs=int(data_cfg.get("n_jobs", 1)))
    signals = np.stack([recording.signal for recording, _ in results])
    save_npz_atomic(path, signals=signals)
    return signals, key


def check_simulated_settings(data_cfg: Mapping) -> dict:
    """The simulated data config as a plain dict, its counts whole numbers, its operating point positive: refused,
    naming the key, before a record is simulated or a run opened."""
    data_cfg = plain_config(data_cfg)
    if data_cfg.get("source", "simulated") != "simulated":
        raise BearingTwinError(f"data.source={data_cfg['source']!r}: build_simulated_dataset needs 'simulated'")
    for name in ("samples_per_class", "window_length"):  # a YAML true is no count
        data_cfg[name] = whole_number(f"data.{name}", data_cfg[name])
    for name, unit in (("rpm", "rev/min"), ("fs", "Hz"), ("duration", "seconds")):  # named as the user set them
        positive_number(data_cfg[name], f"data.{name}", unit)
    samples = round(data_cfg["duration"] * data_cfg["fs"])  # as the simulator keeps them
    if samples < data_cfg["window_length"]:  # no window to cut: said in the settings' words
        shortest_s = math.ceil(1e4 * data_cfg["window_length"] / data_cfg["fs"]) / 1e4  # 0.1 ms steps, rounded up
        raise BearingTwinError(f"data.duration={data_cfg['duration']:g} s at data.fs={data_cfg['fs']:g} Hz gives "
                               f"{samples} samples a state, shorter than one window of data.window_length="
                               f"{data_cfg['window_length']}: give data.duration={shortest_s:g} or more")
    train_fraction = check_split(data_cfg.get("split"), data_cfg.get("train_fraction"))
    if data_cfg["split"] == "random":  # one record a state: its windows are the state's
        check_stratified([data_cfg["samples_per_class"]] * len(FAULTS), train_fraction)
    if data_cfg["split"] == "record":  # refused before the twin simulates a record
        raise BearingTwinError("data.split=record needs two records or more of each state; the simulated data set has "
                               "one a state: use data.split=random or block")
    return data_cfg


def build_simulated_dataset(data_cfg: Mapping, bearing_cfg: Mapping, simulator_cfg: Mapping,
                            effects_cfg: Mapping | None, cache_dir: str | os.PathLike) -> WindowedDataset:
    """``data.samples_per_class`` windows of ``data.window_length`` samples from each simulated state.

    ``data.rpm``, ``data.fs`` and ``data.duration`` replace the simulator's values; the
    windows are spread evenly over each record by :func:`~bearingtwin.data.windows.cut_windows`.
    """
    data_cfg = check_simulated_settings(data_cfg)
    signals, records = _simulated_records(data_cfg, bearing_cfg, simulator_cfg, effects_cfg, cache_dir)
    windows, starts, labels, record_ids = [], [], [], []
    for label, signal in enumerate(signals):
        cut, first = cut_windows(signal, data_cfg["window_length"], data_cfg["samples_per_class"])
        windows.append(cut)
        starts.append(first)
        labels.append(np.full(len(cut), label))
        record_ids.append(np.full(len(cut), label))
    return WindowedDataset(
        windows=np.concatenate(windows),
        labels=np.concatenate(labels),
        record_ids=np.concatenate(record_ids),
        starts=np.concatenate(starts),
        records=[f"simulated:{fault}:{records}" for fault in FAULTS],
        fs=float(data_cfg["fs"]),
        class_names=FAULTS,
        key=content_key({"records": records, "samples_per_class": data_cfg["samples_per_class"],
                     "window_length": data_cfg["window_length"]}),
        record_lengths=[signal.size for signal in signals],
        record_rpms=[float(data_cfg["rpm"])] * len(FAULTS),  # every state simulated at the data set's speed
        unit="m/s^2",  # the simulator's sensor reads acceleration in m/s^2
    )
