"""Train on the twin, test on real bearings: a dataset whose training windows are all simulated.

The twin is set to the operating points of the real CWRU records (each file's measured
rpm, its 12 kHz rate, the cwru_6205 geometry, a housing channel) and simulates every
bearing state there, with the base parameters and effects of one step of a
``bearingtwin-twin`` calibration report. The test windows are the real records at
motor loads never used for calibration. Nothing measured enters training: the twin
was calibrated on records of ``calibration.classes`` at ``calibration.load`` only,
and those may not be test records, which the builder enforces on every run.

Any other rig's records are read the same way from a labels table (``data.labels``: the
``record,state[,rpm,fs]`` table ``data=files`` reads): the calibration records are named
in ``calibration.records``, and every other labelled record is a test record.

The twin speaks m/s^2, the CWRU channel g, and the twin's severity for the inner-race
and ball faults is not calibrated at all: with ``normalize_windows`` every window is
scaled to zero mean and unit standard deviation, so amplitude-dependent features
describe waveform shape, not a unit or a guessed defect depth.

The split is fixed by construction (:attr:`WindowedDataset.fixed_split`): twin
windows train, real windows test; ``data.split`` plays no part. Windows of the
calibration records (0 hp) are scored apart as a validation set
(:attr:`WindowedDataset.validation`): the test set holds no healthy bearing, so only
there does a twin show whether it calls a healthy bearing faulty.

Effect parameters the calibration records cannot determine (how erratically a ball
with a spall spins, say: there is no ball record to fit it to) can be spanned instead of
guessed: ``twin.variants`` simulates every state at every combination of the listed
values, each a twin record of its own (domain randomization on a grid).
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

import joblib
import numpy as np
import scipy.signal
from omegaconf import OmegaConf
from tqdm.auto import tqdm

from bearingtwin.checks import is_finite_number, positive_number, whole_number
from bearingtwin.config import REPO_ROOT, plain_config
from bearingtwin.data.cwru import declared_fs_hz, load_cwru, parse_cwru_name
from bearingtwin.data.formats import read_raw, recording_from_raw
from bearingtwin.data.labels import LabelledFile, rows_from_labels
from bearingtwin.data.recording import Recording, WindowedDataset, warn_of_quality
from bearingtwin.data.windows import check_windows_fit, cut_windows, normalize_windows
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import acting_before, build_effects, order_identity
from bearingtwin.physics.geometry import FAULTS, BearingGeometry, check_fault
from bearingtwin.physics.simulator import records_identity, simulate, simulate_at_speeds
from bearingtwin.signal.sampling_rate import check_channels, decisive_channel, describe_mismatch, rate_witnesses
from bearingtwin.storage import (SIMULATION_CODE, code_fingerprint, content_key, file_digest, load_npz_or_heal,
                                 mark_used_if_present, save_npz_atomic, takes_entries)
from bearingtwin.twin.reference import require_same_bearing

log = logging.getLogger(__name__)

TWIN_PREFIX = "twin:"
"""Records whose source starts with this are simulated; every other record is a measurement file."""


def cwru_file(root: Path, stem: str) -> Path:
    """``<root>/<stem>.mat``, which must exist and carry a CWRU name (state, load, record)."""
    path = root / f"{stem}.mat"
    if parse_cwru_name(path) is None:
        raise BearingTwinError(f"{path.name}: not a CWRU record name (12k_Drive_End_<state><size>_<load>_<record>, "
                               "normal_<load>_<record>, the Data Center's record number or its label <state><size>_<load>)")
    if not path.is_file():
        raise BearingTwinError(f"{path}: no such CWRU record; point data.root at the folder of .mat files")
    return path


def test_files(data_cfg: Mapping) -> list[Path]:
    """The test records: one per class in ``test.classes`` and load in ``test.loads``, found by file stem."""
    root, stems = Path(data_cfg["root"]), data_cfg["files"]
    found = []
    for load in data_cfg["test"]["loads"]:
        for fault in data_cfg["test"]["classes"]:
            check_fault(fault)
            matches = sorted(p for p in root.glob(f"{stems[fault]}_{load}_*.mat") if parse_cwru_name(p) is not None)
            if len(matches) != 1:
                raise BearingTwinError(
                    f"data.test: need exactly one {fault} record at {load} hp in {root}, found "
                    f"{', '.join(p.name for p in matches) or 'none'}"
                )
            found.append(matches[0])
    return found


@dataclass(frozen=True)
class LabelsTable:
    """The rows of a labels table (``data.labels``): each record's file in ``root``, its state, and the rpm,
    fs, unit and scale the row gives (None: the file's own)."""

    root: Path
    rows: list[LabelledFile]

    def written(self, path: Path) -> str:
        """The record as the table writes it (``sub/run.npy``)."""
        return path.relative_to(self.root).as_posix() if path.is_relative_to(self.root) else str(path)

    def named(self, name, key: str) -> LabelledFile:
        """The row of the record ``name``: its file as the table writes it (``sub/run.npy``) or its file name
        (``run.npy``), either without the extension (``sub/run``, ``run``); ``key`` names the setting."""
        def names(path: Path) -> set[str]:
            written = self.written(path)
            return {written, written.removesuffix(path.suffix), path.name, path.stem}

        matches = [row for row in self.rows if str(name) in names(row.path)]
        if len(matches) != 1:
            listed = ", ".join(self.written(row.path) for row in (matches or self.rows))
            raise BearingTwinError(f"{key}: {name} is {'no' if not matches else 'more than one'} record of the labels "
                                   f"table ({listed}){'; name it by its path in the table' if matches else ''}")
        return matches[0]


def labels_table_of(data_cfg: Mapping, warn_unlisted: bool = True) -> LabelsTable | None:
    """With ``data.labels``, that table's rows (files in ``data.root``, any rig's records, read as ``data=files``
    reads them; ``warn_unlisted``: say which files it leaves out); None for the CWRU records, found by their names."""
    if not data_cfg.get("labels"):
        return None
    root = Path(str(data_cfg["root"])).expanduser()
    if not root.is_dir():
        raise BearingTwinError(f"data.root={root} is not a folder; point it at the folder of the labelled records")
    return LabelsTable(root, rows_from_labels(root, data_cfg, alternative="", warn_unlisted=warn_unlisted))


def check_protocol(data_cfg: Mapping) -> tuple[list[Path], list[Path]]:
    """The calibration and test records, after checking that no record is both (:func:`protocol_records`).
    A check before the run: the files a labels table leaves out are said where the data is built."""
    return protocol_records(data_cfg, labels_table_of(data_cfg, warn_unlisted=False))


def protocol_records(data_cfg: Mapping, table: LabelsTable | None) -> tuple[list[Path], list[Path]]:
    """The calibration and test records, after checking that no record is both.

    A calibration record must be of a state in ``calibration.classes`` at ``calibration.load``
    (the twin may have seen only those); the test loads must exclude the calibration load.
    With a labels ``table`` (``data.labels``), the calibration records are the ones named (of
    those states), and every other labelled record is a test record.
    """
    calibration = data_cfg["calibration"]
    records = calibration.get("records")
    if not (isinstance(records, Sequence) and not isinstance(records, str) and records
            and all(isinstance(name, (str, int, float)) for name in records)):
        raise BearingTwinError(f"data.calibration.records={records!r}: give a list of record names "
                               "(data.calibration.records=[<healthy>,<outer>])")
    if len(set(map(str, records))) != len(records):
        raise BearingTwinError(f"data.calibration.records={list(records)}: a record named twice")
    if table is not None:
        return _labelled_protocol(data_cfg, table)
    allowed, load = list(calibration["classes"]), calibration["load"]
    if load in list(data_cfg["test"]["loads"]):
        raise BearingTwinError(f"data.test.loads: {load} hp is the calibration load (data.calibration.load); "
                               "test only at loads the twin was never fitted to")
    root = Path(data_cfg["root"])
    calibration_paths = []
    for stem in calibration["records"]:
        name = parse_cwru_name(f"{stem}.mat")
        if name is None:
            raise BearingTwinError(f"data.calibration.records: {stem} is no CWRU record name; records of another rig are "
                                   "named in a labels table (data.labels=<table of record,state[,rpm,fs]>)")
        if name.fault not in allowed or name.load_hp != load:
            raise BearingTwinError(
                f"data.calibration.records: {stem} is not a calibration record; the twin may be fitted only "
                f"to {' or '.join(allowed)} records at {load} hp"
            )
        calibration_paths.append(cwru_file(root, stem))
    _check_calibration_record(calibration, calibration_paths, calibration_path(data_cfg, None, calibration["record"]))
    simulated = [check_fault(fault) for fault in data_cfg["twin"]["classes"]]
    unsimulated = [state for state in map(check_fault, data_cfg["test"]["classes"]) if state not in simulated]
    if unsimulated:  # a classifier cannot name a state it never saw
        raise BearingTwinError(f"data.test.classes: {unsimulated[0]} is a state the twin does not simulate "
                               f"(data.twin.classes: {', '.join(simulated)})")
    tests = test_files(data_cfg)
    shared = {p.name for p in tests} & {p.name for p in calibration_paths}
    if shared:
        raise BearingTwinError(f"data.test: {sorted(shared)[0]} is a calibration record")
    return calibration_paths, tests


def calibration_path(data_cfg: Mapping, table: LabelsTable | None, name: str,
                     key: str = "data.calibration.records") -> Path:
    """The file of the record ``name``: its labels row's (``table``), else the CWRU record of that stem in ``data.root``."""
    return table.named(name, key).path if table is not None else Path(data_cfg["root"]) / f"{name}.mat"


def _check_calibration_record(calibration: Mapping, calibration_paths: list[Path], path: Path) -> None:
    """``calibration.record`` (the report's record, at ``path``) must be one of the calibration records."""
    if path not in calibration_paths:
        raise BearingTwinError(f"data.calibration.record={calibration['record']}: not among data.calibration.records "
                               f"({', '.join(map(str, calibration['records']))})")


def _labelled_protocol(data_cfg: Mapping, table: LabelsTable) -> tuple[list[Path], list[Path]]:
    """:func:`check_protocol` for labelled records: the named calibration records, then every other row."""
    calibration = data_cfg["calibration"]
    allowed = list(calibration["classes"])
    calibration_paths = []
    for name in calibration["records"]:
        path, state, *_ = table.named(name, "data.calibration.records")
        if state not in allowed:
            raise BearingTwinError(f"data.calibration.records: {name} is labelled {state}; the twin may be fitted only "
                                   f"to {' or '.join(allowed)} records")
        calibration_paths.append(path)
    _check_calibration_record(calibration, calibration_paths,
                              calibration_path(data_cfg, table, calibration["record"], "data.calibration.record"))
    simulated = [check_fault(fault) for fault in data_cfg["twin"]["classes"]]
    tests = [(row.path, row.state) for row in table.rows if row.path not in calibration_paths]
    if not tests:
        raise BearingTwinError("data.labels: every labelled record is a calibration record; label the records to test on too")
    for path, state in tests:
        if state not in simulated:
            raise BearingTwinError(f"{table.written(path)}: labelled {state}, a state the twin does not simulate "
                                   f"(data.twin.classes: {', '.join(simulated)})")
    return calibration_paths, [path for path, _ in tests]


def report_file(report_path: str | Path) -> Path:
    """The report a ``report`` setting names: the file, or the ``twin_report.json`` in bearingtwin-twin's ``out=``
    folder given instead."""
    path = Path(str(report_path)).expanduser()
    return path / "twin_report.json" if path.is_dir() and (path / "twin_report.json").is_file() else path


def _read_report(report_path: str | Path, key: str) -> dict:
    """The ``twin_report.json`` that ``<key>.report`` names."""
    if report_path is None:
        raise BearingTwinError(f"{key}.report is not set; give the twin_report.json bearingtwin-twin wrote for {key}.record")
    path = report_file(report_path)
    if path.is_dir():
        raise BearingTwinError(f"{key}.report={path}: a folder without a twin_report.json; give the report "
                               f"bearingtwin-twin wrote for {key}.record (or the out= folder it wrote it in)")
    if not path.is_file():
        raise BearingTwinError(f"{key}.report={path}: no such file; run bearingtwin-twin on {key}.record first "
                               "(the CWRU study: scripts/cwru_twin_study.py)")
    try:
        report = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        report = None
    if not (isinstance(report, dict) and isinstance(report.get("steps"), list)):
        raise BearingTwinError(f"{path}: not a twin_report.json (no 'steps' list)")
    return report


def resolved_step(report_path: str | Path, step: int | str, key: str = "data.calibration") -> int:
    """``<key>.step`` as the number of a step of ``<key>.report``: ``all`` is its last, every effect it added."""
    return _step_number(_read_report(report_path, key)["steps"], report_path, step, key)


def _step_number(steps: list, report_path: str | Path, step: int | str, key: str) -> int:
    if step == "all":
        return len(steps) - 1
    if not (isinstance(step, int) and not isinstance(step, bool) and 0 <= step < len(steps)):
        raise BearingTwinError(f"{key}.step={step!r}: {Path(str(report_path)).expanduser()} has steps 0..{len(steps) - 1} "
                               "(or all)")
    return step


def calibration_step(report_path: str | Path, step: int | str, key: str = "data.calibration") -> tuple[dict, dict]:
    """Base parameters (dotted config keys) and effects of step ``step`` of a ``twin_report.json``
    (``<key>.report``, ``<key>.step``).

    Step 0 is the bare twin (base parameters fitted, no effect); step k adds the first k
    effects the forward selection chose, with the parameters fitted at that step; ``all`` every one.
    """
    steps = _read_report(report_path, key)["steps"]
    chosen = steps[_step_number(steps, report_path, step, key)]
    return dict(chosen.get("base_params") or {}), dict(chosen.get("params") or {})


def check_report_of(report_path: str | Path, key: str, state: str, bearing_cfg: Mapping, fs: float,
                    record: Path | None = None) -> None:
    """A calibration report must be of ``<key>.record`` (the file ``record``): ``bearingtwin-twin`` writes what it
    held the twin against into its report, and a report of another file (by its contents' digest), state, bearing or
    rate is refused (two reports swapped, or one of another rig, would calibrate the twin silently wrong). A report
    that states none of it (written before reports did) is taken as it is, except the project's own CWRU study's
    (the defaults') for a record that is no CWRU record: a rig's own records with the report settings left out."""
    measured = _read_report(report_path, key).get("measured")
    where = f"{key}.report={report_path}"
    if not isinstance(measured, Mapping):
        study = (REPO_ROOT / "results" / "cwru_twin_study").resolve()
        if record is not None and parse_cwru_name(record) is None and report_file(report_path).resolve().is_relative_to(study):
            raise BearingTwinError(f"{where}: the project's CWRU study's report (the default), not one of {record.name}; "
                                   f"run bearingtwin-twin on {record.name} and give its report as {key}.report")
        return
    written_for = measured["file"].get("sha256") if isinstance(measured.get("file"), Mapping) else None
    if record is not None and written_for and written_for != file_digest(record):
        raise BearingTwinError(f"{where}: a report of {Path(str(measured['file'].get('path', '?'))).name}, not of "
                               f"{record.name} ({key}.record; their contents differ); give the report bearingtwin-twin "
                               "wrote for that record")
    if measured.get("fault") not in (None, state):
        article = "an" if str(measured["fault"])[:1] in "aeiou" else "a"
        raise BearingTwinError(f"{where}: a report of {article} {measured['fault']} record, where {key}.record is {state}; "
                               "give the report bearingtwin-twin wrote for that record")
    if is_finite_number(measured.get("fs")) and not math.isclose(float(measured["fs"]), fs):
        raise BearingTwinError(f"{where}: a report of a record at {float(measured['fs']):g} Hz, where the twin "
                               f"simulates at data.fs={fs:g} Hz")
    require_same_bearing(OmegaConf.create(dict(bearing_cfg)), measured, where, "a calibration report")


def merged_calibration(calibration: Mapping, table: LabelsTable | None = None) -> tuple[dict, dict]:
    """Base parameters and effects of the twin that ``data.calibration`` describes.

    The base parameters and the ranked effects up to ``step`` come from ``report`` (the
    fault record); the first ``healthy.step`` effects found on the healthy record
    (``healthy.report``) are added to every bearing state, after the fault record's ones:
    they describe what the sensor sees besides the bearing (noise found on record 97) and
    apply last, on the sensor path. ``healthy: null`` or ``healthy.step: 0`` adds nothing.
    An effect both reports give is refused, unless ``step`` is ``all``: then it is the healthy record's
    (noise found on both is the sensor's floor, which the healthy record shows without a fault's signal).
    The healthy record's state is its labels row's (``table``), else its CWRU name's.
    """
    base_params, effects = calibration_step(calibration["report"], calibration["step"])
    healthy = calibration.get("healthy")
    if not healthy or not healthy.get("step"):
        return base_params, effects
    key = "data.calibration.healthy.record"
    if table is not None:
        path, state, *_ = table.named(healthy["record"], key)
        among = path in {table.named(name, "data.calibration.records").path for name in calibration["records"]}
    else:
        state = getattr(parse_cwru_name(f"{healthy['record']}.mat"), "fault", None)
        among = healthy["record"] in calibration["records"]
    if not among:
        raise BearingTwinError(f"{key}={healthy['record']}: not among data.calibration.records "
                               f"({', '.join(map(str, calibration['records']))})")
    if state != "normal":
        stated = f"labelled {state} in data.labels" if table is not None else f"its name says {state}"
        raise BearingTwinError(f"data.calibration.healthy.record={healthy['record']}: {stated}, not healthy (normal)")
    _, healthy_effects = calibration_step(healthy["report"], healthy["step"], "data.calibration.healthy")
    if calibration["step"] == "all":  # every effect of the fault record's but the sensor path's, the healthy record's
        effects = {name: params for name, params in effects.items() if name not in healthy_effects}
    shared = sorted(set(effects) & set(healthy_effects))
    if shared:
        raise BearingTwinError(f"data.calibration.healthy: effect {shared[0]} was found on both calibration records; "
                               "choose one (lower data.calibration.healthy.step or data.calibration.step)")
    return base_params, {**effects, **healthy_effects}


def with_base_params(bearing_cfg: Mapping, simulator_cfg: Mapping, base_params: Mapping,
                     report: str | Path) -> tuple[dict, dict]:
    """Copies of the bearing and simulator configs with a report's fitted base parameters set."""
    twin_cfg = OmegaConf.create({"bearing": dict(bearing_cfg), "simulator": dict(simulator_cfg)})
    absent = object()  # a key set to null (simulator.sensor_angle_deg) is a key all the same
    for key, value in base_params.items():
        if OmegaConf.select(twin_cfg, key, default=absent) is absent:
            raise BearingTwinError(f"{report}: base parameter {key} is no bearing.* / simulator.* key")
        OmegaConf.update(twin_cfg, key, value, merge=False)
    return OmegaConf.to_container(twin_cfg.bearing), OmegaConf.to_container(twin_cfg.simulator)


def healthy_twin_rms(report_path: str | Path, step: int | str, healthy: Recording, bearing_cfg: Mapping,
                     simulator_cfg: Mapping) -> float:
    """RMS (m/s^2) of the healthy twin of the healthy record's calibration as its ``noise`` met it, at its speed.

    The healthy record's ``noise`` was fitted as a ratio to the power of the twin it acted on: every
    effect acting before the sensor path (slip, a load zone), and the sensor-path effects found before
    it, not those found after (a resonance found after the noise filters the floor, and would count
    its gain twice); with this as the noise's ``reference_rms`` every bearing state gets the same
    absolute noise floor.
    """
    base_params, effects = calibration_step(report_path, step, "data.calibration.healthy")
    effects = acting_before("noise", effects) if "noise" in effects else effects
    bearing, simulator = with_base_params(bearing_cfg, simulator_cfg, base_params, report_path)
    recording, _ = simulate("normal", bearing, {**simulator, "rpm": float(healthy.rpm)}, effects)
    return float(recording.signal.std())


def operating_points_rpm(recordings: list[Recording]) -> list[float]:
    """The distinct measured speeds (rev/min, to 0.1) of the records, ascending."""
    return sorted({round(float(r.rpm), 1) for r in recordings})


def twin_signals(faults, rpms, bearing_cfg: Mapping, simulator_cfg: Mapping, effects: Mapping,
                 cache_dir: str | os.PathLike, variant: int | None = None) -> tuple[np.ndarray, str]:
    """:func:`~bearingtwin.physics.simulator.simulate_at_speeds`' records (each with its own seed), cached by their
    config; and their key."""
    path, key = _records_path(faults, rpms, bearing_cfg, simulator_cfg, effects, cache_dir, variant)
    cached = load_npz_or_heal(path, "signals")
    if cached is not None:
        return cached["signals"], key
    signals = simulate_at_speeds(faults, rpms, bearing_cfg, simulator_cfg, effects, variant)
    save_npz_atomic(path, signals=signals)
    return signals, key


def _records_path(faults, rpms, bearing_cfg: Mapping, simulator_cfg: Mapping, effects: Mapping,
                  cache_dir: str | os.PathLike, variant: int | None) -> tuple[Path, str]:
    """Where :func:`twin_signals` caches these records, and their key (what they are simulated from)."""
    key = content_key({"bearing": bearing_cfg, "simulator": records_identity(simulator_cfg), "effects": effects,
                       **order_identity(effects), "faults": list(faults), "rpms": list(rpms), "variant": variant})
    return Path(cache_dir) / "twin_to_real" / f"records-{key}-{code_fingerprint(*SIMULATION_CODE)}.npz", key


def simulation_jobs(value) -> int:
    """``data.twin.n_jobs``: processes simulating the variants; ``auto`` is every core, or one in a Hydra multirun
    whose launcher runs its jobs side by side (joblib, Ray, submitit: each job has a core of its own; Hydra's basic
    launcher runs them one after another, so each takes every core); -1 is every core."""
    if value == "auto":
        from hydra.core.hydra_config import HydraConfig
        from hydra.types import RunMode

        if not HydraConfig.initialized() or HydraConfig.get().mode != RunMode.MULTIRUN:
            return -1
        launcher = str(HydraConfig.get().launcher.get("_target_", ""))
        return -1 if launcher.endswith(".BasicLauncher") else 1
    if value == -1:
        return -1
    try:
        return whole_number("data.twin.n_jobs", value)
    except BearingTwinError as error:
        raise BearingTwinError(f"{error} (or auto: every core, one per job of a sweep run side by side; -1: every "
                               "core)") from None


def simulate_variants(faults, rpms, bearing_cfg: Mapping, variants: Sequence[tuple[Mapping, Mapping]],
                      cache_dir: str | os.PathLike, n_jobs: int) -> None:
    """Simulate and cache every variant's records (``(simulator settings, effects)`` each, numbered as
    :func:`twin_signals` numbers them) not in the cache yet, ``n_jobs`` processes at a time. Each record's seed
    is its own (the seed, the variant, the state, the speed), so the numbers do not depend on ``n_jobs``; the
    workers return nothing but write the cache the caller then reads, one variant at a time."""
    numbered = [(variant_number(index, len(variants)), setting, effects)
                for index, (setting, effects) in enumerate(variants)]
    missing = [(variant, setting, effects) for variant, setting, effects in numbered
               if not mark_used_if_present(_records_path(faults, rpms, bearing_cfg, setting, effects, cache_dir, variant)[0])]
    if joblib.effective_n_jobs(n_jobs) < 2 or len(missing) < 2:
        return  # simulated one by one where they are read
    if not takes_entries(Path(cache_dir) / "twin_to_real"):  # the workers hand their records back through it
        log.warning("%s takes no new entries: the twin's %d variants are simulated one by one, as they are read",
                    Path(cache_dir) / "twin_to_real", len(missing))
        return
    results = joblib.Parallel(n_jobs=n_jobs, return_as="generator_unordered")(
        joblib.delayed(_simulated_key)(faults, rpms, bearing_cfg, setting, effects, cache_dir, variant)
        for variant, setting, effects in missing)
    for _ in tqdm(results, total=len(missing), desc="simulating twin variants", unit="variant", disable=None):
        pass


def variant_number(index: int, n_variants: int) -> int | None:
    """The number a variant's records are seeded and cached by: its index, none when it is the only one (so a
    twin without variants keeps the records it had before variants existed)."""
    return index if n_variants > 1 else None


def _simulated_key(faults, rpms, bearing_cfg, simulator_cfg, effects, cache_dir, variant) -> str:
    """A worker's part of :func:`simulate_variants`: the records simulated and cached, their key returned."""
    return twin_signals(faults, rpms, bearing_cfg, simulator_cfg, effects, cache_dir, variant)[1]


def background_levels(twin_cfg: Mapping) -> list[float]:
    """``data.twin.background_snr_db``: the levels (dB, the twin record's RMS over the background's) at which each
    twin record is heard again with a background of other sources added; [] for null (none)."""
    levels = twin_cfg.get("background_snr_db")
    if levels is None:
        return []
    if isinstance(levels, (str, bytes)) or not isinstance(levels, Sequence) or not levels \
            or not all(is_finite_number(level) for level in levels):
        raise BearingTwinError(f"data.twin.background_snr_db must be null or a non-empty list of finite numbers (dB), "
                               f"got {levels!r}")
    return [float(level) for level in levels]


def with_background(signal: np.ndarray, snr_db: float, seed: Sequence[int]) -> np.ndarray:
    """``signal`` with white Gaussian background added ``snr_db`` below its RMS (seeded by ``seed``).

    What the twin does not model at a sensor away from the bearing, or on another machine: the other
    sources its path mixes in (a motor, a fan, another bearing), which raise the floor under the
    defect's lines and weaken their harmonics most. Heard at several levels, the twin's states teach
    a classifier that a weaker series is still the same fault.
    """
    rng = np.random.default_rng(np.random.SeedSequence(list(seed)))
    rms = float(np.sqrt(np.mean(np.square(signal))))
    return signal + rng.standard_normal(signal.size) * rms * 10.0 ** (-snr_db / 20.0)


HEARING_KEYS = ("background_snr_db", "other_paths")
"""``data.twin`` options that hear every twin record again; null (their default) leaves the dataset's key as before."""
OTHER_PATH_KEYS = ("hearings", "modes", "natural_frequency_hz", "damping_ratio")


def other_path_settings(twin_cfg: Mapping, fs_hz: float) -> dict | None:
    """``data.twin.other_paths``, checked: ``hearings`` (paths per twin record), ``modes`` (per path) and the
    [low, high] ranges of the modes' ``natural_frequency_hz`` (low below the Nyquist frequency of ``fs_hz``)
    and ``damping_ratio``; None for null (none)."""
    settings = twin_cfg.get("other_paths")
    if settings is None:
        return None
    if not isinstance(settings, Mapping) or set(settings) != set(OTHER_PATH_KEYS):
        raise BearingTwinError(f"data.twin.other_paths must be null or give exactly {', '.join(OTHER_PATH_KEYS)}, "
                               f"got {settings!r}")
    checked = {name: whole_number(f"data.twin.other_paths.{name}", settings[name], minimum=1)
               for name in ("hearings", "modes")}
    for name, (least, most) in (("natural_frequency_hz", (0.0, math.inf)), ("damping_ratio", (0.0, 1.0))):
        bounds = settings[name]
        if isinstance(bounds, (str, bytes)) or not isinstance(bounds, Sequence) or len(bounds) != 2 \
                or not all(is_finite_number(v) for v in bounds) or not least < bounds[0] <= bounds[1] < most:
            raise BearingTwinError(f"data.twin.other_paths.{name} must be [low, high] with {least:g} < low <= high "
                                   f"< {most:g}, got {bounds!r}")
        checked[name] = (float(bounds[0]), float(bounds[1]))
    if checked["natural_frequency_hz"][0] >= fs_hz / 2.0:
        raise BearingTwinError(f"data.twin.other_paths.natural_frequency_hz: low {checked['natural_frequency_hz'][0]:g} "
                               f"Hz is at or above the twin's Nyquist frequency ({fs_hz / 2.0:g} Hz): no mode could ring")
    return checked


def through_other_path(signal: np.ndarray, fs_hz: float, modes: int, natural_frequency_hz: tuple[float, float],
                       damping_ratio: tuple[float, float], seed: Sequence[int]) -> np.ndarray:
    """``signal`` as a sensor elsewhere on the structure hears it: through ``modes`` lightly damped modes in
    parallel, its RMS kept.

    Each mode's natural frequency (Hz) and damping ratio are drawn log-uniform from their [low, high] ranges
    and its modal weight standard normal (seeded by ``seed``); a mode is the impulse-invariant resonator
    ``h[n] = r^n sin(n theta)`` (scipy.signal.lfilter), skipped at or above the Nyquist frequency (its draws
    made all the same, so the others do not move). What the twin's one
    calibrated path does not show: another path's modes ring with phases of their own, which spreads each
    impact in time even after pre-whitening has flattened the path's spectrum, so the envelope's harmonics
    stand lower and the band holds another share of the power.
    """
    rng = np.random.default_rng(np.random.SeedSequence(list(seed)))
    signal = np.asarray(signal, dtype=np.float64)
    log_f, log_zeta = np.log(natural_frequency_hz), np.log(damping_ratio)
    heard = np.zeros_like(signal)
    for _ in range(modes):
        frequency_hz, zeta = np.exp(rng.uniform(*log_f)), np.exp(rng.uniform(*log_zeta))
        weight = rng.standard_normal()
        if frequency_hz >= fs_hz / 2.0:
            continue
        omega = 2.0 * np.pi * frequency_hz / fs_hz
        radius, theta = np.exp(-zeta * omega), omega * np.sqrt(1.0 - zeta ** 2)
        heard += weight * scipy.signal.lfilter([0.0, radius * np.sin(theta)],
                                               [1.0, -2.0 * radius * np.cos(theta), radius ** 2], signal)
    rms = float(np.sqrt(np.mean(np.square(heard))))
    if rms == 0.0:
        raise BearingTwinError(f"no mode of this path rings below the Nyquist frequency ({fs_hz / 2.0:g} Hz), or the "
                               "signal is silent: nothing is heard through it")
    return heard * float(np.sqrt(np.mean(np.square(signal)))) / rms


def simulator_settings(simulator_cfg: Mapping, randomize: Mapping | None) -> list[tuple[str, dict]]:
    """(label, simulator config) for every combination of ``twin.randomize`` values; [("", config)] without any.

    ``randomize`` maps a dotted simulator key to a list of values (``{defect.width_mm: [0.178, 0.533],
    defect.outer_angle_deg: [null, 0.0]}``): what no calibration record determines, such as the
    size and position of a defect, is spanned rather than guessed. Every key must exist.
    """
    axes = []
    for key, values in (randomize or {}).items():
        if OmegaConf.select(OmegaConf.create(dict(simulator_cfg)), key, default="<absent>") == "<absent>":
            raise BearingTwinError(f"data.twin.randomize: simulator.{key} is no simulator setting")
        if not isinstance(values, (list, tuple)) or not values:
            raise BearingTwinError(f"data.twin.randomize.{key}: need a non-empty list of values, got {values!r}")
        axes.append((key, list(values)))
    settings = []
    for values in itertools.product(*(values for _, values in axes)):
        setting = OmegaConf.create(dict(simulator_cfg))
        for (key, _), value in zip(axes, values):
            OmegaConf.update(setting, key, value, merge=False)
        label = ",".join(f"simulator.{key}={value}" for (key, _), value in zip(axes, values))
        settings.append((label, OmegaConf.to_container(setting)))
    return settings


def effect_variants(effects: Mapping, variants: Mapping | None) -> list[tuple[str, dict]]:
    """(label, effects) for every combination of ``twin.variants`` values; [("", effects)] without any.

    ``variants`` maps effect -> parameter -> list of values, like the effects config it
    overrides (``{spin_slip: {jitter: [0.05, 0.2]}}``); an effect the twin lacks is added
    with its other parameters at their defaults. A null value leaves the effect out of the
    combinations that take it (``{preload: {interference_um: [null, 20.0]}}``: the twin as
    calibrated, and preloaded), so whether an effect is present at all can be spanned too; it
    is refused for an effect with more than one varied parameter (the effect absent would be
    simulated once per value of the other), and a parameter that takes null as a value (noise's
    ``reference_rms``) is set in the effect's own config, not varied.
    """
    axes = []
    for effect, parameters in (variants or {}).items():
        if not isinstance(parameters, Mapping) or not parameters:
            raise BearingTwinError(f"data.twin.variants.{effect}: give parameter: [values, ...], got {parameters!r}")
        for parameter, values in parameters.items():
            if not isinstance(values, (list, tuple)) or not values:
                raise BearingTwinError(f"data.twin.variants.{effect}.{parameter}: need a non-empty list of values, got {values!r}")
            axes.append((effect, parameter, list(values)))
        if len(parameters) > 1 and any(None in values for values in parameters.values()):
            raise BearingTwinError(f"data.twin.variants.{effect}: a null leaves the effect out, so it can be the "
                                   f"only varied parameter of {effect} (got {', '.join(parameters)})")
    if not axes:
        return [("", dict(effects))]
    combinations = []
    for values in itertools.product(*(axis[2] for axis in axes)):
        varied = {name: dict(params) for name, params in effects.items()}
        for (effect, parameter, _), value in zip(axes, values):
            varied.setdefault(effect, {})[parameter] = value
        for effect, parameter, _ in axes:
            if effect in varied and varied[effect].get(parameter, "") is None:
                del varied[effect]
        label = ",".join(f"{e}.{p}={v:g}" if isinstance(v, float) else f"{e}=absent" if v is None else f"{e}.{p}={v}"
                         for (e, p, _), v in zip(axes, values))
        try:  # every combination is checked before the first simulation starts
            build_effects(varied)
        except BearingTwinError as error:
            raise BearingTwinError(f"data.twin.variants ({label}): {error}") from None
        combinations.append((label, varied))
    return combinations


def read_labelled_record(row: LabelledFile, channel, default_fs: float, geometry: BearingGeometry, tolerance: float,
                         check_fs: bool = True) -> Recording:
    """A labelled record (its labels ``row``: the file, its state, rpm, fs and unit) at the rate the row or the file states
    (:func:`_check_rates` judges it against ``data.fs``), else at ``default_fs`` (``data.fs``): a rate the file does
    not record is checked against the shaft line as a CWRU record's declared one is, and refused where the shaft
    series contradicts it (``check_fs=False``: not checked)."""
    path, fs = row.path, row.fs
    raw = read_raw(path)
    stated = raw.fs is not None and raw.fs_origin != "declared"  # a rate a data set's convention gives is no statement
    recording = recording_from_raw(raw, channel, fs=fs if fs is not None or stated else default_fs, rpm=row.rpm,
                                   fault=row.state, channel_key="data.channel", fault_key="the labels row's state",
                                   fs_key="data.fs" if fs is None else "the labels row's fs", rpm_key="the labels row's rpm",
                                   **row.unit_settings())
    if recording.rpm is None:
        raise BearingTwinError(f"{path}: states no shaft speed; give it in the labels table's rpm column "
                               "(the twin runs at each record's speed)")
    recording.require_vibration()
    if check_fs and not stated:  # a rate the labels row or data.fs gives, not the file: the shaft line is its witness
        try:
            checks = check_channels(rate_witnesses(recording.signal, raw.vibration_channels), recording.fs, recording.rpm,
                                    defect_hz=geometry.defect_frequencies(recording.rpm), tolerance=tolerance)
        except BearingTwinError:  # too short to resolve the shaft line: nothing to check the rate by
            return recording
        check = checks[decisive_channel(checks)]
        if check.verdict == "contradicted":
            read_at = (f"read at data.fs={default_fs:g} Hz, a rate neither the file nor its labels row states" if fs is None
                       else f"read at its labels row's fs={fs:g} Hz")
            raise BearingTwinError(f"{path}: {read_at}, but {describe_mismatch(check)}; give its rate in the labels "
                                   f"table's fs column, or data.check_fs=false if {recording.fs:g} Hz is the true one")
    return recording


def _check_rates(recordings: list[Recording], twin_fs: float, labelled: bool) -> None:
    """Every record must be at the rate the twin simulates at (``data.fs``): one that is not is named, with the
    rate to set when all records share one; ``labelled``: the records come from a labels table."""
    off = [r for r in recordings if not math.isclose(r.fs, twin_fs)]
    if not off:
        return
    rates = {}
    for recording in recordings:
        rates.setdefault(round(recording.fs, 6), Path(str(recording.source)).name)
    if len(rates) == 1:
        raise BearingTwinError(f"{off[0].source}: recorded at {off[0].fs:g} Hz, where the twin simulates at "
                               f"data.fs={twin_fs:g} Hz; set data.fs={off[0].fs:g}")
    at = ", ".join(f"{rate:g} Hz ({name}, ...)" for rate, name in rates.items())
    if labelled:
        raise BearingTwinError(f"data.labels: the records are at {at}; the twin simulates at one rate (data.fs): label "
                               "only the records of one rate, or resample them to it")
    raise BearingTwinError(f"the records are at {at}; the twin simulates at one rate (data.fs): choose records of one "
                           "rate (data.files, data.calibration.records: all 12k_... or all 48k_...)")


def check_twin_to_real_settings(data_cfg: Mapping, bearing_cfg: Mapping) -> dict:
    """The data config as a plain dict, its counts whole numbers, after checking the values a twin-to-real run
    needs before a record is read or a run opened: the bearing group matching the records', the twin's rate."""
    cfg, bearing = plain_config(data_cfg), plain_config(bearing_cfg)
    if cfg.get("source") != "twin_to_real":
        raise BearingTwinError(f"data.source={cfg.get('source')!r}: build_twin_to_real_dataset needs 'twin_to_real'")
    if bearing.get("name") != cfg["bearing"]:
        raise BearingTwinError(f"data=twin_to_real simulates the {cfg['bearing']} bearing of the records: add "
                               f"bearing={cfg['bearing']} (got bearing.name={bearing.get('name')!r})")
    cfg["window_length"] = whole_number("data.window_length", cfg["window_length"])  # a YAML true is no count
    simulation_jobs(cfg["twin"].get("n_jobs", 1))
    for section in ("twin", "test"):
        cfg[section]["windows_per_record"] = whole_number(f"data.{section}.windows_per_record",
                                                          cfg[section]["windows_per_record"])
    positive_number(cfg["fs"], "data.fs", "Hz")
    n_validation = cfg["calibration"].get("validation_windows_per_record", 0)
    if not (isinstance(n_validation, int) and not isinstance(n_validation, bool) and n_validation >= 0):
        raise BearingTwinError(f"data.calibration.validation_windows_per_record must be an integer >= 0, got {n_validation!r}")
    noise_level = (cfg["calibration"].get("healthy") or {}).get("noise_level", "absolute")
    if noise_level not in ("absolute", "relative"):
        raise BearingTwinError(f"data.calibration.healthy.noise_level={noise_level!r}: choose absolute or relative")
    return cfg


def build_twin_to_real_dataset(data_cfg, bearing_cfg, simulator_cfg, effects_cfg, cache_dir) -> WindowedDataset:
    """Twin windows (training) at the real records' operating points, real windows (test).

    Args:
        data_cfg: ``conf/data/twin_to_real.yaml``.
        bearing_cfg: must be the bearing named by ``data.bearing`` (``bearing=cwru_6205``).
        simulator_cfg: the simulator group; rpm, fs, duration and sensor are set from ``data``.
        effects_cfg: effects set by hand on top of the calibrated ones (``effects=[preload]``), for
            diagnosis: they were not fitted to a calibration record, so a twin with them is outside
            the protocol, and ``bearingtwin-report sim2real`` labels its rows "hand-set".
        cache_dir: twin records are cached under ``<cache_dir>/twin_to_real/``.

    Returns windows in the order twin (training), test records, calibration records
    (``validation``, ``calibration.validation_windows_per_record`` each; none when 0).
    """
    cfg = check_twin_to_real_settings(data_cfg, bearing_cfg)
    bearing, simulator = plain_config(bearing_cfg), plain_config(simulator_cfg)
    n_jobs = simulation_jobs(cfg["twin"].get("n_jobs", 1))
    twin_fs = float(cfg["fs"])
    n_validation = cfg["calibration"].get("validation_windows_per_record", 0)
    noise_level = (cfg["calibration"].get("healthy") or {}).get("noise_level", "absolute")
    table = labels_table_of(cfg)  # read once: it is the records' truth for the protocol and the reading alike
    calibration_paths, test_paths = protocol_records(cfg, table)
    try:
        digests = {path: file_digest(path) for path in calibration_paths + test_paths}  # each file read once
    except OSError as error:
        raise BearingTwinError(f"{error.filename}: cannot read it ({error.strerror})") from None
    fitted_to = {digests[path]: path for path in calibration_paths}
    for path in test_paths:
        if digests[path] in fitted_to:  # by its contents: scored as a test, the twin's own fit would count as one
            raise BearingTwinError(f"{path}: the same contents as the calibration record {fitted_to[digests[path]].name}, "
                                   "which the twin was fitted to; leave the copy out of the records to test on")
    base_params, effects = merged_calibration(cfg["calibration"], table)
    hand_set = plain_config(effects_cfg) or {}
    if set(hand_set) & set(effects):
        raise BearingTwinError(f"effects: {sorted(set(hand_set) & set(effects))[0]} is already in the calibrated twin "
                               "(data.calibration); set only effects the calibration did not find")
    effects = {**effects, **hand_set}  # after the calibrated ones of the same stage: preload replaces load_zone's clearance

    labelled = {row.path: row for row in (table.rows if table else [])}

    def measured(path: Path) -> Recording:
        if table is None:
            return load_cwru(path, channel=cfg["channel"], fs=declared_fs_hz(path, cfg["fs"]),
                             remedy="give its rate in a labels table (data.labels=<csv> with an fs column) or set "
                                    "data.check_fs=false",
                             check_fs=bool(cfg["check_fs"]), tolerance=float(cfg["fs_check_tolerance"]),
                             bearing=BearingGeometry.from_config(bearing))
        return read_labelled_record(labelled[path], channel=cfg["channel"], default_fs=twin_fs,
                                    geometry=BearingGeometry.from_config(bearing),
                                    tolerance=float(cfg["fs_check_tolerance"]), check_fs=bool(cfg["check_fs"]))

    tests = [measured(path) for path in test_paths]
    calibration_records = {path: measured(path) for path in calibration_paths}
    _check_rates(tests + list(calibration_records.values()), twin_fs, labelled=table is not None)
    warn_of_quality(tests + list(calibration_records.values()))
    reports = [("data.calibration", cfg["calibration"]["record"], cfg["calibration"]["report"])]
    healthy = cfg["calibration"].get("healthy") or {}
    if healthy.get("step"):
        reports.append(("data.calibration.healthy", healthy["record"], healthy["report"]))
    for key, name, report in reports:
        path = calibration_path(cfg, table, name, f"{key}.record")
        check_report_of(report, key, calibration_records[path].fault, bearing, twin_fs, path)
    # Operating points: speeds only (what a tachometer gives in service), never a test signal.
    rpms = operating_points_rpm(tests + list(calibration_records.values()))
    simulator.update(fs=twin_fs, duration=float(cfg["twin"]["duration"]), sensor=cfg["twin"]["sensor"])
    # Only noise found on the healthy record has a healthy twin to refer to; noise found on the
    # fault record keeps the ratio it was fitted as. A report made with reference= gives its noise at an absolute
    # level already (the reference's), which its snr_db refers to: kept, and no ratio to hold it as.
    held_level = (effects.get("noise") or {}).get("reference_rms")
    if held_level is not None and noise_level == "relative":
        raise BearingTwinError(f"data.calibration.healthy.noise_level=relative: the calibration's noise is held at an "
                               f"absolute level (reference_rms={held_level:g} m/s^2, as a bearingtwin-twin run with "
                               "reference= holds it), not as a ratio; give noise_level=absolute")
    if noise_level == "absolute" and held_level is None and healthy.get("step") and "noise" in calibration_step(
            healthy["report"], healthy["step"], "data.calibration.healthy")[1]:
        effects["noise"] = {**effects["noise"], "reference_rms": healthy_twin_rms(
            healthy["report"], healthy["step"], calibration_records[calibration_path(cfg, table, healthy["record"])],
            bearing, simulator)}
    bearing, simulator = with_base_params(bearing, simulator, base_params, cfg["calibration"]["report"])
    faults = [check_fault(f) for f in cfg["twin"]["classes"]]
    variants = [(",".join(filter(None, (effect_label, setting_label))), varied, setting)
                for effect_label, varied in effect_variants(effects, cfg["twin"].get("variants"))
                for setting_label, setting in simulator_settings(simulator, cfg["twin"].get("randomize"))]
    length = cfg["window_length"]
    # Each twin record as simulated, then with each background, then through each other path: (the name's
    # suffix, what is done to the signal given a seed). A hearing's seed carries its place in this list.
    hearings: list[tuple[str, Callable | None]] = [("", None)]
    hearings += [(f"[background {level:g} dB]", functools.partial(with_background, snr_db=level))
                 for level in background_levels(cfg["twin"])]
    paths = other_path_settings(cfg["twin"], twin_fs)
    if paths:
        through = functools.partial(through_other_path, fs_hz=twin_fs, modes=paths["modes"],
                                    natural_frequency_hz=paths["natural_frequency_hz"],
                                    damping_ratio=paths["damping_ratio"])
        hearings += [(f"[path {number}]", through) for number in range(1, paths["hearings"] + 1)]
    validation_records = list(calibration_records.values()) if n_validation else []
    # Before minutes of simulation: every twin record is a state at a distinct measured speed in a variant.
    check_windows_fit(len(variants) * len(faults) * len(rpms) * len(hearings), length, cfg["twin"]["windows_per_record"],
                      "data.twin.windows_per_record",
                      records=f"twin records ({len(faults)} states x {len(rpms)} distinct speeds of the records, to "
                              f"0.1 rpm, x {len(variants)} variant{'s' * (len(variants) != 1)}"
                              + (f" x {len(hearings)} hearings of each (data.twin: background_snr_db, other_paths)"
                                 if len(hearings) > 1 else "") + ")",
                      remedy=", or give records of one nominal speed that speed (a labels table's rpm column)")

    def windows_of(signal: np.ndarray, n_windows: int, source: str):
        try:
            return cut_windows(signal, length, n_windows)
        except BearingTwinError as error:  # which record is too short
            raise BearingTwinError(f"{source}: {error} (data.window_length)") from None

    cuts, record_lengths, twin_keys, sources, twin_labels, twin_rpms = [], [], [], [], [], []
    seed = whole_number("simulator.seed", simulator["seed"], minimum=0)
    # Simulating every variant takes minutes (seconds each); cached ones are read in a blink. Shown in a
    # terminal only (disable=None), not in CI or a log. A variant's records are cut at once: only their
    # windows are kept (every variant's whole records at once outgrew a 23 GB machine at 25.6 kHz).
    # Where no bar shows (output to a file, a sweep's log), a line says what the minutes go to.
    log.info("twin: %d variant%s x %d state%s x %d speed%s (cached ones are read, not simulated)", len(variants),
             "s" * (len(variants) != 1), len(faults), "s" * (len(faults) != 1), len(rpms), "s" * (len(rpms) != 1))
    started = time.perf_counter()
    simulate_variants(faults, rpms, bearing, [(setting, varied) for _, varied, setting in variants], cache_dir, n_jobs)
    for index, (label, varied, setting) in enumerate(tqdm(variants, desc="twin variants", unit="variant",
                                                          disable=True if len(variants) < 2 else None)):
        variant_signals, key = twin_signals(faults, rpms, bearing, setting, varied, cache_dir,
                                            variant=variant_number(index, len(variants)))
        twin_keys.append(key)
        names = [f"{TWIN_PREFIX}{fault}@{rpm:g}rpm" + (f"[{label}]" if label else "") for fault in faults for rpm in rpms]
        for hearing_index, (suffix, hear) in enumerate(hearings):
            for record_index, (signal, name) in enumerate(zip(variant_signals, names)):
                if hear is not None:
                    signal = hear(signal, seed=(seed, index, hearing_index, record_index))
                    name += suffix
                cuts.append(windows_of(signal, cfg["twin"]["windows_per_record"], name))
                record_lengths.append(signal.size)
                sources.append(name)
            twin_labels += [FAULTS.index(fault) for fault in faults for _ in rpms]
            twin_rpms += [float(rpm) for _ in faults for rpm in rpms]
    twin_key = twin_keys[0] if len(twin_keys) == 1 else content_key(twin_keys)
    n_twin_records = len(cuts)
    log.info("twin: %d records ready in %.0f s", n_twin_records, time.perf_counter() - started)

    labels = list(twin_labels)
    cuts += [windows_of(r.signal, cfg["test"]["windows_per_record"], r.source) for r in tests]
    cuts += [windows_of(r.signal, n_validation, r.source) for r in validation_records]
    labels += [r.label for r in tests + validation_records]
    sources += [str(r.source) for r in tests + validation_records]
    windows = np.concatenate([w for w, _ in cuts])
    normalization = "zscore" if cfg["normalize_windows"] else "none"
    try:
        windows = normalize_windows(windows, normalization)
    except BearingTwinError as error:
        raise BearingTwinError(f"data.normalize_windows: {error}") from None
    record_ids = np.concatenate([np.full(len(w), i) for i, (w, _) in enumerate(cuts)])
    n_twin = sum(len(w) for w, _ in cuts[:n_twin_records])
    n_test = sum(len(w) for w, _ in cuts[n_twin_records:n_twin_records + len(tests)])
    index = np.arange(len(windows))
    return WindowedDataset(
        windows=windows,
        labels=np.concatenate([np.full(len(w), label) for (w, _), label in zip(cuts, labels)]),
        record_ids=record_ids,
        starts=np.concatenate([s for _, s in cuts]),
        records=sources,
        fs=twin_fs,
        class_names=FAULTS,
        # What the test and calibration records hold (names and contents), wherever they lie: a record written over
        # with another of the same size is other data.
        key=content_key({"twin": twin_key, "tests": [(p.name, digests[p]) for p in test_paths],
                         "calibration": [(p.name, digests[p]) for p in calibration_paths],
                         # the folder and the table are no part of the data (their places differ between machines);
                         # what a labelled record holds and is labelled is
                         "config": {k: v for k, v in cfg.items() if k not in ("root", "labels")} | (
                             # a null hearing option is what its absence was: the key stays that of earlier runs
                             {"twin": {k: v for k, v in cfg["twin"].items()
                                       if not (k in HEARING_KEYS and v is None) and k != "n_jobs"}}),
                         **({"labels": [(p.name, digests[p], *labelled[p].key_facts())
                                        for p in calibration_paths + test_paths]}
                            if table else {})}),
        record_lengths=record_lengths + [r.signal.size for r in tests + validation_records],
        fixed_split=(index[:n_twin], index[n_twin:n_twin + n_test]),
        window_normalization=normalization,
        validation=index[n_twin + n_test:],
        record_rpms=twin_rpms + [float(r.rpm) for r in tests + validation_records],
    )
