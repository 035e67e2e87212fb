"""Identifiability: hide effects in a measurement, see what ``bearingtwin-twin``'s ranking names.

Two sources of measurements:

* ``twin``: the twin itself at another operating point (load, clearance, defect depth, sensor
  direction), another random realization, a -40 dB sensor noise floor -- a self-test, which
  flatters because measurement and twin share every modelling choice;
* ``rig``: the independent test rig (:mod:`bearingtwin.testrig`: an impulse train through a
  2-DOF housing and sensor path, its own load zone and its own implementations of the effects),
  which shares no code with the twin.

Every case follows the workflow a user follows on a real rig. First a reference record of the
same rig at the same operating point, with nothing hidden, is held against the twin: the
effects found there are the rig's own (its transfer path, its noise floor) and the operating
point fitted there (sensor race and direction, load, clearance, defect size) is the rig's.
Then the case's record, with its hidden effects, is held against the twin with those effects
fixed and that operating point held (the gain is always fitted), as ``bearingtwin-twin
reference=<the reference's twin_report.json>`` holds them: what differs now is what was hidden. Case kinds: one hidden effect, a pair, none
(null), and one the library lacks (rig only). The conditions cycle through speeds, sampling rates
(12, 25.6, 48 kHz) and units (m/s^2, g). Each ranking is the CLI's defaults (every library
effect a candidate) on a 2 s record.

Scores: single -- the hidden effect is the first one added (also counted: first in the first
round's ranking, claimed or not, the goal's own wording); pair -- both are added; null -- none
is added; out of library -- no library effect is added; error halved -- the held-out
discrepancy at least halves when the hidden effect is found. An extra structural mode counts as
found whether it is added as ``resonance`` or, when the reference already needed a
``resonance`` for the rig's own path, as ``second_resonance``.

    python benchmarks/identifiability.py --split dev --jobs 2    # the development cases (seed 1)
    python benchmarks/identifiability.py --split test --jobs 2   # the benchmark: writes results/identifiability.{md,json}
    python benchmarks/identifiability.py --split dev --sources rig --fs 48000 --jobs 2   # the same cases at 48 kHz
    python benchmarks/identifiability.py --split dev --sources rig --faults normal --jobs 2   # on healthy bearings

Another rig's records go through the same protocol and scores: ``--records <cases.csv>`` lists each
record with its reference record (same rig and operating point, nothing hidden), its case kind and
what was hidden (:func:`cases_from_manifest`); ``--export <folder>`` writes a split's cases in that
form, as a template and to check that a record read from a file is judged as the one made in memory.

The development split exists to choose the ranking's free constants (``ranking.points_per_view``,
``ranking.view_floor_db``, ``ranking.min_signature_gain``) on rig measurements; its cases use other seeds, parameter values and
conditions than the test split, whose numbers are the result.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import math
import os
import platform
import re
import shlex
import sys
import tempfile
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir
from hydra.errors import HydraException
from omegaconf import OmegaConf
from omegaconf.errors import OmegaConfBaseException

from bearingtwin.config import CONF_DIR
from bearingtwin.data.formats import SPEED_TOLERANCE, same_speed
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.testrig import RigOperatingPoint, RigSetup, simulate_rig
from bearingtwin.testrig.rig import FAULTS as RIG_FAULTS
from bearingtwin.tracking.tables import markdown_table
from bearingtwin.twin.compare import Comparator, CompareSettings
from bearingtwin.twin.model import TwinModel
from bearingtwin.twin.rank import deviance, penalty_per_parameter, signature_gain, signature_views, view_floors
from bearingtwin.twin.reference import hold_reference
from bearingtwin.twin.report import MAX_SEED, build_ranker, load_measurement, ranker_settings, seed_value, twin_for

G = 9.80665
SECONDS = 2.0
# The rig's residual unbalance line is off: "nothing hidden" must mean nothing the twin lacks, and a 1x
# line is exactly what the library's `unbalance` adds.
RIG = RigSetup(residual_1x_db=None)
# Hidden parameters per split: effect -> (twin's parameters, rig's parameters). None of them is a default.
HIDDEN = {
    "dev": {
        "resonance": ({"natural_frequency_hz": 2200.0, "damping_ratio": 0.04}, {"natural_frequency_hz": 2200.0, "damping_ratio": 0.04}),
        "second_resonance": ({"natural_frequency_hz": 1500.0, "damping_ratio": 0.04}, {"frequencies_hz": [1500.0], "damping_ratio": 0.04}),
        "slip": ({"jitter": 0.03}, {"jitter": 0.03}),
        "speed_fluctuation": ({"depth": 0.02, "frequency_hz": 5.0}, {"depth": 0.02, "frequency_hz": 5.0}),
        "noise": ({"snr_db": 3.0, "spectral_slope": 1.0}, {"snr_db": 3.0, "spectral_slope": 1.0}),
        "tones": ({"frequencies_hz": [83.0, 217.0], "levels_db": [-3.0, -6.0]}, {"frequencies_hz": [83.0, 217.0], "levels_db": [-3.0, -6.0]}),
        "lubrication": ({"stiffness_ratio": 0.6, "damping_ns_per_m": 2000.0}, {"stiffness_ratio": 0.6, "damping_ratio": 0.1}),
        "unbalance": ({"level_db": 0.0}, {"level_db": 0.0}),
        "misalignment": ({"level_db": 0.0}, {"level_db": 0.0}),
        "looseness": ({"level_db": 0.0}, {"level_db": 0.0}),
        "line_frequency": ({"supply_hz": 60.0, "level_db": 0.0}, {"supply_hz": 60.0, "level_db": 0.0}),
        "clipping": ({"clip_level": 2.0}, {"level_rms": 2.0}),
    },
    "test": {
        "resonance": ({"natural_frequency_hz": 3200.0, "damping_ratio": 0.03}, {"natural_frequency_hz": 3200.0, "damping_ratio": 0.03}),
        "second_resonance": ({"natural_frequency_hz": 1800.0, "damping_ratio": 0.03}, {"frequencies_hz": [1800.0], "damping_ratio": 0.03}),
        "slip": ({"jitter": 0.04}, {"jitter": 0.04}),
        "speed_fluctuation": ({"depth": 0.03, "frequency_hz": 3.0}, {"depth": 0.03, "frequency_hz": 3.0}),
        "noise": ({"snr_db": 0.0, "spectral_slope": 0.5}, {"snr_db": 0.0, "spectral_slope": 0.5}),
        "tones": ({"frequencies_hz": [47.0, 173.0, 311.0], "levels_db": [0.0, -3.0, -6.0]}, {"frequencies_hz": [47.0, 173.0, 311.0], "levels_db": [0.0, -3.0, -6.0]}),
        "lubrication": ({"stiffness_ratio": 0.5, "damping_ns_per_m": 3000.0}, {"stiffness_ratio": 0.5, "damping_ratio": 0.12}),
        "unbalance": ({"level_db": 3.0}, {"level_db": 3.0}),
        "misalignment": ({"level_db": 3.0}, {"level_db": 3.0}),
        "looseness": ({"level_db": 3.0}, {"level_db": 3.0}),
        "line_frequency": ({"supply_hz": 50.0, "level_db": 3.0}, {"supply_hz": 50.0, "level_db": 3.0}),
        "clipping": ({"clip_level": 1.8}, {"level_rms": 1.8}),
    },
}
# A lone extra mode is `resonance`; `second_resonance` is hidden only beside it, as a pair.
PAIRS = {"dev": [("resonance", "unbalance"), ("slip", "noise"), ("resonance", "second_resonance")],
         "test": [("resonance", "tones"), ("misalignment", "noise"), ("slip", "line_frequency"),
                  ("unbalance", "clipping"), ("resonance", "second_resonance")]}
OUT_OF_LIBRARY_PARAMS = {
    "dev": {"gear_mesh": {"n_teeth": 23, "level_db": 0.0, "modulation_depth": 0.3},
            "am_interference": {"carrier_hz": 2900.0, "modulation_hz": 41.0, "depth": 0.8, "level_db": 0.0}},
    "test": {"gear_mesh": {"n_teeth": 29, "level_db": 0.0, "modulation_depth": 0.4},
             "rub": {"level_db": 0.0, "contact_fraction": 0.1},
             "am_interference": {"carrier_hz": 3300.0, "modulation_hz": 37.0, "depth": 0.8, "level_db": 0.0},
             "cable_crackle": {"rate_per_s": 4.0, "dropout_ms": 2.0, "spike_level_rms": 8.0}},
}
# Conditions: (rpm, fs Hz, unit), cycled through the cases; the operating point the ranking is not told.
CONDITIONS = {"dev": [(1797.0, 12000.0, "g")],
              "test": [(1772.0, 12000.0, "g"), (1750.0, 25600.0, "m/s^2"), (1730.0, 48000.0, "g")]}
OPERATING = {"dev": [{"radial_load_n": 700.0, "clearance_um": 6.0, "sensor_angle_deg": 90.0}],
             "test": [{"radial_load_n": 1200.0, "clearance_um": 4.0, "sensor_angle_deg": 90.0},
                      {"radial_load_n": 500.0, "clearance_um": 8.0, "sensor_angle_deg": 60.0}]}
FAULTS = ("outer", "inner")
SEED = {"dev": 1, "test": 2}


def cases(split: str, sources: list[str], fs_hz: float | None = None, other_faults: tuple[str, ...] = ()) -> list[dict]:
    """Every case of a split, each with its source, kind, hidden effects, fault and conditions; ``fs_hz``: every
    case at this sampling rate instead of its condition's (the same cases and seeds otherwise); ``other_faults``:
    the same kinds of case on bearings of other states too (``normal``: a healthy bearing, on which a machine's
    own effects are what a user most often meets), dealt after the split's own, whose seeds stay theirs."""
    listed = []
    for faults, source in itertools.product((FAULTS, other_faults), sources):
        kinds = [("single", (name,)) for name in HIDDEN[split] if name != "second_resonance"]
        kinds += [("pair", pair) for pair in PAIRS[split]]
        kinds += [("null", ())]
        if source == "rig":
            kinds += [("out_of_library", (name,)) for name in OUT_OF_LIBRARY_PARAMS[split]]
        for fault in faults:
            for kind, names in kinds:
                index = len(listed)
                rpm, fs, unit = CONDITIONS[split][index % len(CONDITIONS[split])]
                fs = fs if fs_hz is None else fs_hz
                operating = OPERATING[split][index % len(OPERATING[split])]
                listed.append({"split": split, "source": source, "kind": kind, "hidden": list(names), "fault": fault,
                               "rpm": rpm, "fs": fs, "unit": unit, "operating": operating,
                               "seed": SEED[split] * 1000 + index})
    return listed


KINDS = {"single": (1, 1), "pair": (2, 2), "null": (0, 0), "out_of_library": (1, None)}
"""Each case kind and how many hidden names it takes (least, most; None: any number)."""
MANIFEST_COLUMNS = ("record", "reference", "kind", "hidden")
MEASURED_COLUMNS = ("fs", "rpm", "fault", "channel")
"""Optional manifest columns: what a record's file does not state (``measured.*`` of ``bearingtwin-twin``)."""
SEED_COLUMNS = ("seed", "reference_seed")
"""Optional manifest columns: ``bearingtwin-twin``'s ``seed=`` for the record's run and its reference's (default 0)."""


def library_effects() -> set[str]:
    """The names of the twin's library effects (conf/effects/*.yaml)."""
    return {path.stem for path in (Path(CONF_DIR) / "effects").glob("*.yaml")}


def read_manifest(manifest: Path) -> list[tuple[int, dict]]:
    """A manifest's rows, each with the line it ends on, its column names stripped (a spreadsheet's
    "CSV UTF-8" byte-order mark and spaces after the commas are read as nothing)."""
    try:
        with manifest.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.DictReader(handle, skipinitialspace=True)
            header = [name.strip().lower() for name in reader.fieldnames or []]  # Record, RPM: any case
            reader.fieldnames = header
            rows = [(reader.line_num, row) for row in reader]
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise BearingTwinError(f"{manifest}: not a readable CSV manifest ({error})") from None
    known = (*MANIFEST_COLUMNS, *MEASURED_COLUMNS, *SEED_COLUMNS)
    unknown = [column for column in header if column and column not in known]
    if unknown and ";" not in ",".join(header):  # a column no case reads would pass unseen (a speed beside rpm)
        named = {"state": "fault", "speed": "rpm", "rate": "fs", "sampling_rate": "fs"}.get(unknown[0])
        raise BearingTwinError(f"{manifest}: no case reads a column {unknown[0]}"
                               + (f" (the manifest names it {named})" if named else "")
                               + f"; columns: {', '.join(known)}")
    missing = [column for column in MANIFEST_COLUMNS if column not in header]
    if missing:
        separator = " (columns are separated by commas)" if ";" in ",".join(header) else ""
        raise BearingTwinError(f"{manifest}: has no column {', '.join(missing)}; its header reads "
                               f"{','.join(header) or 'nothing'}{separator}; columns: {', '.join(MANIFEST_COLUMNS)}")
    if not rows:
        raise BearingTwinError(f"{manifest}: lists no case")
    return rows


def hidden_names(row: dict, kind: str, library: set[str], where: str) -> list[str]:
    """The effects a row hides, checked against its kind: library effects for single (one) and pair (two
    different ones), none for null, effects the library lacks for out of library."""
    hidden = [name.strip() for name in (row["hidden"] or "").split("+") if name.strip()]
    least, most = KINDS[kind]
    if len(hidden) < least or (most is not None and len(hidden) > most) or len(set(hidden)) < len(hidden):
        count = {"single": "one effect", "pair": "two different effects", "null": "no effect",
                 "out_of_library": "at least one effect"}[kind]
        raise BearingTwinError(f"{where}: a case of kind {kind} hides {count}, joined by '+'; hidden is {row['hidden']!r}")
    if kind == "out_of_library":
        claimed = [name for name in hidden if name in library]
        if claimed:
            raise BearingTwinError(f"{where}: hidden {', '.join(claimed)} is a library effect: a case hiding it is "
                                   "single or pair, not out_of_library")
    else:
        unknown = [name for name in hidden if name not in library]
        if unknown:
            raise BearingTwinError(f"{where}: hidden {', '.join(unknown)} is not a library effect "
                                   f"({', '.join(sorted(library))}); a case the library lacks is out_of_library")
    return hidden


def row_seed(row: dict, column: str, where: str) -> int:
    """A seed column's value, 0 when empty (:func:`seed_value`'s range)."""
    text = (row.get(column) or "").strip() or "0"
    try:
        return seed_value(int(text))
    except (ValueError, BearingTwinError):
        raise BearingTwinError(f"{where}: {column} {text!r} is not a seed (a whole number from 0 to {MAX_SEED})") from None


def row_settings(row: dict, cfg, where: str) -> dict:
    """``measured.*`` for a row's files: the command line's, with what the row's optional columns state."""
    settings = OmegaConf.to_container(cfg.measured, resolve=True)
    for column in MEASURED_COLUMNS:
        text = (row.get(column) or "").strip()
        if text and column in ("fs", "rpm"):
            try:
                settings[column] = float(text)
            except ValueError:
                raise BearingTwinError(f"{where}: {column} {text!r} is not a number") from None
        elif text:
            settings[column] = text
    return settings


def read_listed(manifest: Path, row: dict, role: str, settings: dict, bearing: BearingGeometry,
                compare: CompareSettings, where: str) -> tuple[dict, Recording]:
    """The ``measured.*`` settings that read a row's ``role`` file (record or reference) and the recording they read,
    checked as ``bearingtwin-twin`` checks ``measured.path`` (its rate against ``bearing``'s lines, its length against
    ``compare``'s segments)."""
    name = (row[role] or "").strip()
    if not name:
        raise BearingTwinError(f"{where}: the {role} column is empty")
    path = manifest.parent / name
    if not path.is_file():
        raise BearingTwinError(f"{where}: {role} {path} {'is not a file' if path.exists() else 'does not exist'}")
    settings = {**settings, "path": str(path)}
    try:
        recording = load_measurement(OmegaConf.create(settings), bearing)
        # Built only to refuse, before any run starts, a record too short or sampled too slowly to compare.
        Comparator(recording, bearing, compare)
    except BearingTwinError as error:
        said = in_manifest_words(str(error))
        raise BearingTwinError(f"{where}: {said}" if str(path) in said else f"{where}: {path}: {said}") from None
    return settings, recording


def in_manifest_words(said: str) -> str:
    """A reader's message about a ``measured.*`` setting said of the manifest's column that gives it per row (a
    ``measured.fs=`` on the command line would set every row's)."""
    if "does not state its" in said:
        columns = re.findall(r"measured\.(\w+)=", said)
        many = len(columns) > 1
        return (f"{said.split('; give ')[0]}; give {'them' if many else 'it'} in the manifest's {', '.join(columns)} "
                f"column{'s' if many else ''}")
    said = re.sub(r"measured\.(fs|rpm|fault|channel)=(?!<)(\S+) contradicts", r"the manifest's \1 \2 contradicts", said)
    return re.sub(r"with measured\.(fs|rpm|fault|channel)=<[^>]*>", r"in the manifest's \1 column", said)


def listed_case(manifest: Path, row: dict, cfg, library: set[str], bearing: BearingGeometry, compare: CompareSettings,
                where: str) -> dict:
    """The case one manifest row lists, its record and reference read and checked (:func:`cases_from_manifest`)."""
    kind = (row["kind"] or "").strip()
    if kind not in KINDS:
        raise BearingTwinError(f"{where}: kind {kind!r} is not one of {', '.join(KINDS)}")
    hidden = hidden_names(row, kind, library, where)
    seeds = {column: row_seed(row, column, where) for column in SEED_COLUMNS}
    settings = row_settings(row, cfg, where)
    record_settings, record = read_listed(manifest, row, "record", settings, bearing, compare, where)
    reference_settings, reference = read_listed(manifest, row, "reference", settings, bearing, compare, where)
    # The reference holds what it fitted for the record (sensor, load, path), as bearingtwin-twin reference= does,
    # which takes one of another state (a rig's healthy baseline) or speed; but a row pairing other states, rates or
    # speeds may as well be a slip of the pen, which would score the record against another operating point unsaid.
    elsewhere = ""
    if (reference.fault != record.fault or not math.isclose(reference.fs, record.fs, rel_tol=1e-3)
            or not same_speed(reference.rpm, record.rpm)):
        elsewhere = (f"the reference is {reference.fault} at {reference.fs:g} Hz and {reference.rpm:g} rpm, the record "
                     f"{record.fault} at {record.fs:g} Hz and {record.rpm:g} rpm")
        print(f"warning: {where}: {elsewhere}: held as bearingtwin-twin reference= holds it (the benchmark's references "
              f"are the same operating point: state, rate, speed within {SPEED_TOLERANCE:.0%})", file=sys.stderr)
    return {"split": "records", "source": "records", "kind": kind, "hidden": hidden, "fault": record.fault,
            "rpm": record.rpm, "fs": record.fs, "unit": record.unit or "unit not stated",
            "operating": {}, "seed": seeds["seed"], "measured": record_settings,
            "reference": {"seed": seeds["reference_seed"], "measured": reference_settings,
                          "fault": reference.fault, "rpm": reference.rpm, "fs": reference.fs},
            "reference_elsewhere": elsewhere}


def cases_from_manifest(manifest: Path, cfg) -> list[dict]:
    """The cases a manifest (CSV) lists, each record and its reference read and checked as ``bearingtwin-twin``
    reads ``measured.path`` with the twin config ``cfg`` (its ``measured.*`` settings, bearing and comparison
    settings), before any runs.

    Columns: ``record`` and ``reference`` (files, relative to the manifest's folder; the reference is what
    ``bearingtwin-twin reference=`` takes, here a record of the same rig at the same operating point with nothing
    hidden), ``kind`` (single, pair, null, out_of_library) and ``hidden`` (the hidden effects' names joined by
    ``+``: library names for single and pair, names the library lacks for out_of_library, empty for null);
    optional ``fs``, ``rpm``, ``fault``, ``channel`` for what the files do not state (as ``measured.*``, for the
    record and its reference), and ``seed``, ``reference_seed`` (``bearingtwin-twin``'s ``seed=`` of each run; 0
    when not given). A record's unit does not matter: the twin's gain is fitted. Every row is checked before any
    run, and every bad row named; a reference of another state, rate or speed than its record's is said so.
    """
    library = library_effects()
    bearing = BearingGeometry.from_config(cfg.bearing)
    compare = CompareSettings.from_config(OmegaConf.to_container(cfg.compare, resolve=True))
    listed, refused = [], []
    for line, row in read_manifest(manifest):
        where = f"{manifest}, line {line}"
        try:
            listed.append({**listed_case(manifest, row, cfg, library, bearing, compare, where), "line": line})
        except BearingTwinError as error:  # every bad row is named at once: a large manifest is mended in one go
            refused.append(str(error))
    if refused:
        more = f" ({len(refused)} rows refused)" if len(refused) > 1 else ""
        raise BearingTwinError("; ".join(refused) + more)
    return listed


def export_cases(todo: list[dict], folder: Path, cfg) -> Path:
    """Write ``todo``'s records and their references as .npz files (signal, fs, rpm, fault, unit) and a
    ``cases.csv`` manifest that :func:`cases_from_manifest` reads: the form another rig's records take.
    ``cfg``: the twin config the runs compose (the self-test's measurements are simulated with it)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise BearingTwinError(f"--export {folder}: cannot make that folder ({error.strerror})") from None
    reference_files, reference_seeds, rows = {}, {}, []
    for index, case in enumerate(todo):
        key = _reference_key(case)
        if key not in reference_files:  # a split's cases of one key share the first one's reference, as in a run
            reference_files[key] = f"reference_{len(reference_files):02d}.npz"
            reference_seeds[key] = twin_seed(reference_of(case))
            _save(measurement(reference_of(case), cfg), folder / reference_files[key])
        name = f"{index:03d}_{case['source']}_{case['kind']}_{case['fault']}_{'+'.join(case['hidden']) or 'none'}.npz"
        _save(measurement(case, cfg), folder / name)
        rows.append({"record": name, "reference": reference_files[key], "kind": case["kind"],
                     "hidden": "+".join(case["hidden"]), "seed": twin_seed(case), "reference_seed": reference_seeds[key]})
    manifest = folder / "cases.csv"
    with manifest.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=MANIFEST_COLUMNS + SEED_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return manifest


def _save(recording: Recording, path: Path) -> None:
    np.savez(path, signal=recording.signal, fs=recording.fs, rpm=recording.rpm, fault=recording.fault,
             unit=recording.unit)


def _effect_params(case: dict) -> dict:
    split, column = case["split"], 0 if case["source"] == "twin" else 1
    effects = {name: (OUT_OF_LIBRARY_PARAMS[split][name] if case["kind"] == "out_of_library"
                      else HIDDEN[split][name][column]) for name in case["hidden"]}
    if case["source"] == "rig" and "second_resonance" in effects:
        # The rig's second_resonance adds two modes: the first one's and its own.
        first = effects.pop("resonance")
        effects["second_resonance"] = {**effects["second_resonance"], "frequencies_hz": [
            first["natural_frequency_hz"], *effects["second_resonance"]["frequencies_hz"]]}
    return effects


def measurement(case: dict, cfg) -> Recording:
    """The hidden-effect record of ``case``, ``SECONDS`` long, in its unit (a listed record: read from its file)."""
    if "measured" in case:
        return load_measurement(OmegaConf.create(case["measured"]), BearingGeometry.from_config(cfg.bearing))
    op = case["operating"]
    effects = _effect_params(case)
    if case["source"] == "rig":
        point = RigOperatingPoint(rpm=case["rpm"], fs=case["fs"], duration_s=SECONDS, radial_load_n=op["radial_load_n"],
                                  clearance_um=op["clearance_um"], sensor_angle_deg=op["sensor_angle_deg"],
                                  unit=case["unit"])
        signal = simulate_rig(case["fault"], point, effects, seed=case["seed"], setup=RIG)
    else:
        simulator = OmegaConf.to_container(cfg.simulator, resolve=True)
        simulator.update(rpm=case["rpm"], fs=case["fs"], duration=SECONDS)
        truth = TwinModel(case["fault"], cfg.bearing, simulator, seed=case["seed"])
        base = {"simulator.load_y_n": -op["radial_load_n"], "bearing.clearance_mm": op["clearance_um"] / 1000,
                "simulator.defect.depth_mm": 0.004, "simulator.sensor": "outer_x",
                "simulator.sensor_angle_deg": op["sensor_angle_deg"]}
        clean = truth.signal(base, effects)
        bare = truth.signal(base) if effects else clean
        floor = np.random.default_rng(case["seed"]).standard_normal(clean.size)  # a sensor's -40 dB floor
        signal = clean + 0.01 * np.sqrt(np.mean(bare**2)) * floor
        signal = signal / G if case["unit"] == "g" else signal
    return Recording(signal, case["fs"], case["rpm"], case["fault"], source=f"{case['source']} {case['kind']}",
                     unit=case["unit"])


SPLIT_BEARING = "bearing=cwru_6205"
"""The bearing of a split's cases: the test rig's and the twin's self-test measurements are an SKF 6205's."""


def run_overrides(records: bool, overrides: list[str]) -> list[str]:
    """The overrides every run composes: a split's cases are a 6205's (``SPLIT_BEARING``, before the command line's);
    a manifest's records are run as ``bearingtwin-twin`` runs them, its defaults and the command line's overrides
    (another bearing: ``bearing=<name>`` among them)."""
    return list(overrides) if records else [SPLIT_BEARING, *overrides]


def twin_config(*overrides: str):
    """``bearingtwin-twin``'s config as every case's run composes it: no tracking, then ``overrides`` (the measured
    record is read by the benchmark, not by ``measured.path``)."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("twin", overrides=["measured.path=unused", "tracking.enabled=false", *overrides])


def rank(case: dict, overrides: list[str], reference: dict | None = None):
    """``bearingtwin-twin``'s ranking of the case's record; with ``reference`` (a reference's twin report),
    what that found held, as ``bearingtwin-twin reference=<its twin_report.json>`` holds it."""
    cfg = twin_config(f"seed={twin_seed(case)}", *overrides)
    if reference:
        cfg = hold_reference(cfg, reference, case["fault"])
    measured = measurement(case, cfg)
    geometry = BearingGeometry.from_config(cfg.bearing)
    settings = CompareSettings.from_config(OmegaConf.to_container(cfg.compare, resolve=True))
    ranker = build_ranker(cfg, case["fault"])
    start = time.perf_counter()
    fit = ranker.fit(twin_for(measured, cfg), measured, geometry, settings).fit_
    return fit, time.perf_counter() - start


def twin_seed(case: dict) -> int:
    """``bearingtwin-twin``'s ``seed=`` for the case's run (a split's case seeds its measurement with the rest)."""
    return case["seed"] if "measured" in case else case["seed"] % 1000


def _reference_key(case: dict) -> tuple:
    if "measured" in case:
        return case["source"], tuple(sorted(case["reference"]["measured"].items())), case["reference"]["seed"]
    return (case["source"], case["fault"], case["rpm"], case["fs"], case["unit"],
            tuple(sorted(case["operating"].items())))


def reference_of(case: dict) -> dict:
    """The case's reference: same rig, operating point and conditions, nothing hidden, another realization
    (a listed record's: the reference record the manifest names)."""
    if "measured" in case:  # the listed reference file, with its own facts
        return {**case, **case["reference"], "kind": "reference", "hidden": []}
    return {**case, "kind": "reference", "hidden": [], "seed": case["seed"] + 500}


def run_reference(case: dict, overrides: list[str]) -> dict:
    """The reference record's twin report (what ``bearingtwin-twin`` writes of it) and its time; ``{"error": ...}``
    where its run fails (:func:`failed`)."""
    try:
        fit, seconds = rank(reference_of(case), overrides)
    except Exception as error:  # one record's failure is that case's, and the others go on
        return failed(error)
    return {"measured": {"fault": case["fault"]}, **fit.as_dict(), "seconds": seconds}


def failed(error: Exception) -> dict:
    """A run that failed, in one line: the user's error as it is said, another with its type and place (printed with
    its traceback where it happens, for a bug to be found)."""
    if isinstance(error, BearingTwinError):
        return {"error": str(error)}
    traceback.print_exc()
    return {"error": f"{type(error).__name__}: {error}"}


def run_listed_case(case: dict, overrides: list[str], reference: dict) -> dict:
    """:func:`run_case`, or the case with the ``error`` that stopped it or its reference."""
    if "error" in reference:
        return {**case, "error": f"its reference failed: {reference['error']}"}
    try:
        return run_case(case, overrides, reference)
    except Exception as error:
        return {**case, **failed(error)}


def run_case(case: dict, overrides: list[str], reference: dict) -> dict:
    fit, seconds = rank(case, overrides, reference)
    added = [f.effect for f in fit.added]
    sensor = fit.operating_point["sensor"]
    held = reference["operating_point"]
    return {
        **case, "reference_effects": list(reference["steps"][-1]["params"]),
        "reference_sensor": [held["sensor"]["race"], held["sensor"]["angle_deg"]],
        "added": added, "verdict": fit.verdict, "seconds": seconds, "reference_seconds": reference["seconds"],
        "reference_base": {name: entry["value"] for name, entry in held.items() if name != "sensor"},
        "ranking": [(f.effect, f.drop_per_point, f.n_parameters, f.evidence) for f in fit.ranking],
        "rounds": fit.rounds, "pairs": fit.pairs, "repeatability_db": fit.repeatability_db,
        "margin": fit.margin, "baseline_error": fit.baseline_error, "final_error": fit.final_error,
        "floor_error": fit.floor_error, "unexplained": [u["view"] for u in fit.unexplained],
        "steps": [s.error for s in fit.steps],
        "step_views": [s.as_dict()["views"] for s in fit.steps],
        "fitted_load_n": fit.operating_point.get("radial_load_n", {}).get("value"),
        "fitted_sensor": [sensor["race"], sensor["angle_deg"], sensor["interval"]],
    }


MODE = {"second_resonance": "resonance", "structural_mode": "resonance"}
"""An extra structural mode is one finding, under either name."""


def score(result: dict) -> dict:
    kind = result["kind"]
    hidden = [MODE.get(name, name) for name in result["hidden"]]
    added = [MODE.get(name, name) for name in result["added"]]
    if kind == "pair" and hidden == ["resonance", "resonance"]:
        return {"right": added.count("resonance") >= 2, "halved": None, "ranked_first": None}
    ranked_first = None
    if kind == "single":
        right = bool(added) and added[0] == hidden[0]
        ranked_first = bool(result["ranking"]) and MODE.get(result["ranking"][0][0], result["ranking"][0][0]) == hidden[0]
    elif kind == "pair":
        right = set(hidden) <= set(added)
    else:
        right = not added
    found = [h for h in hidden if h in added]
    halved = None
    if kind in ("single", "pair") and found:
        halved = result["final_error"] <= 0.5 * result["baseline_error"]
    return {"right": right, "halved": halved, "ranked_first": ranked_first}


POINTS_GRID = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)
VIEW_FLOOR_GRID = (0.3, 0.5, 1.0, 2.0)
SIGNATURE_GAIN_GRID = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0)


def first_round_evidence(result: dict, points_per_view: float, view_floor_db: float) -> list[tuple[float, float, str]]:
    """Each first-round candidate's evidence and signature gain as the judge would give them with these
    constants (the judge's own deviance and penalty, the views weighted as configured by default): the
    deviance's drop from the twin before the round minus the candidate's parameters times the penalty,
    and the drop within the views its signature shows in."""
    floors = view_floors(result["repeatability_db"], view_floor_db)
    weights = CompareSettings().weights
    before = deviance(result["step_views"][0], floors, weights, points_per_view)
    penalty = penalty_per_parameter(points_per_view, weights)
    return [(before - deviance(c["views"], floors, weights, points_per_view) - c["n_parameters"] * penalty,
             signature_gain(result["step_views"][0], c["views"], floors, weights, points_per_view,
                            signature_views(c["effect"])),
             c["effect"]) for c in (result["rounds"][0] if result["rounds"] else [])]


def first_round_right(result: dict, points_per_view: float, view_floor_db: float, min_signature_gain: float) -> bool:
    """Whether the first round's decision would be right with these constants: the candidate with the
    most evidence, if it pays and gains ``min_signature_gain`` in its signature's views, else none. A pair the
    ranking may claim where that candidate falls short (``ranking.pair_candidates``) is fitted anew, so it is not
    replayed here: the replay reads the ranking as it was before pairs (the pairs tried are in each case's
    ``pairs``)."""
    evidence = first_round_evidence(result, points_per_view, view_floor_db)
    best, gain, name = max(evidence) if evidence else (-1.0, 0.0, None)
    first = MODE.get(name, name) if best > 0 and gain >= min_signature_gain else None
    hidden = [MODE.get(h, h) for h in result["hidden"]]
    if result["kind"] in ("single", "pair"):
        return first in hidden
    return first is None


def first_round_rates(results: list[dict], kinds: list[str], points_per_view: float, view_floor_db: float,
                      min_signature_gain: float) -> list[float]:
    """Per case kind, the share of cases whose first-round decision would be right with these constants."""
    return [float(np.mean([first_round_right(r, points_per_view, view_floor_db, min_signature_gain)
                           for r in results if r["kind"] == kind])) for kind in kinds]


def whole_percent(share: float) -> str:
    """A share as a whole percentage with a half rounded up, as a reader rounds (5/8 -> "63%"; Python's own
    format rounds a half to the even neighbour, "62%")."""
    return f"{math.floor(100 * float(share) + 0.5)}%"


def choose_decision_constants(results: list[dict], min_signature_gain: float) -> tuple[tuple[float, float], list[list[str]]]:
    """The (points_per_view, view_floor_db) whose first-round decisions are right most often, each case
    kind weighing the same; ties go to fewer points, then to the lower floor."""
    kinds = sorted({r["kind"] for r in results})
    rows, best = [], (-1.0, 0.0, 0.0)
    for floor in VIEW_FLOOR_GRID:
        for points in POINTS_GRID:
            rates = first_round_rates(results, kinds, points, floor, min_signature_gain)
            rows.append([f"{points:g}", f"{floor:g}", *map(whole_percent, rates), whole_percent(np.mean(rates))])
            best = max(best, (float(np.mean(rates)), -points, -floor))
    return (-best[1], -best[2]), [["points_per_view", "view_floor_db", *kinds, "mean"], *rows]


def choose_signature_gain(results: list[dict], points_per_view: float, view_floor_db: float):
    """The ``ranking.min_signature_gain`` of :data:`SIGNATURE_GAIN_GRID` whose first-round decisions are
    right most often at the configured constants, each case kind weighing the same; ties go to the lower."""
    kinds = sorted({r["kind"] for r in results})
    rows, best = [], (-1.0, 0.0)
    for gain in SIGNATURE_GAIN_GRID:
        rates = first_round_rates(results, kinds, points_per_view, view_floor_db, gain)
        rows.append([f"{gain:g}", *map(whole_percent, rates), whole_percent(np.mean(rates))])
        best = max(best, (float(np.mean(rates)), -gain))
    return -best[1], [["min_signature_gain", *kinds, "mean"], *rows]


def summarize(results: list[dict]) -> dict:
    """Per source and kind: cases right out of all, and cases with the error halved."""
    table = {}
    for r in results:
        s = score(r)
        entry = table.setdefault(r["source"], {}).setdefault(r["kind"], {"right": 0, "n": 0, "halved": 0, "found": 0,
                                                                        "ranked_first": 0})
        entry["n"] += 1
        entry["right"] += s["right"]
        entry["ranked_first"] += bool(s["ranked_first"])
        if s["halved"] is not None:
            entry["found"] += 1
            entry["halved"] += s["halved"]
    return table


def print_counts(table: dict, label: str = "") -> None:
    """One line per source of a :func:`summarize` table: each kind's cases right and errors halved."""
    for source, kinds in table.items():
        print(source + label, {k: f"{e['right']}/{e['n']}, halved {e['halved']}/{e['found']}" for k, e in kinds.items()})


def confusion(results: list[dict], source: str) -> str:
    """Single-effect cases: hidden effect (rows) against the first effect added (columns)."""
    singles = [r for r in results if r["source"] == source and r["kind"] == "single"]
    names = list(dict.fromkeys(r["hidden"][0] for r in singles))
    columns = names + sorted({(r["added"] or ["none"])[0] for r in singles} - set(names))
    counts = Counter((r["hidden"][0], (r["added"] or ["none"])[0]) for r in singles)
    rows = [[name] + [str(counts[(name, c)] or "") for c in columns] for name in names]
    return markdown_table(["hidden \\ added first", *columns], rows)


SOURCES = {"twin": "twin -> twin (self-test)", "rig": "twin -> independent rig", "records": "twin -> listed records"}
"""Each source of measurements and its column's heading."""


def plot_rates(table: dict, goals: dict, path: Path, sources: list[str]) -> None:
    """Share of cases right per kind, one bar per source (twin -> twin beside twin -> rig), with the goals marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = list(goals)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.8 / len(sources)
    for number, source in enumerate(sources):
        rates = [table.get(source, {}).get(k, {}) for k in kinds]
        heights = [100 * e["right"] / e["n"] if e else np.nan for e in rates]
        ax.bar(np.arange(len(kinds)) + (number - (len(sources) - 1) / 2) * width, heights, width=width,
               label=SOURCES[source])
    for index, kind in enumerate(kinds):
        ax.hlines(100 * goals[kind], index - 0.4, index + 0.4, colors="k", linestyles="--", lw=1)
    ax.set_xticks(range(len(kinds)), [k.replace("_", " ") for k in kinds])
    ax.set(ylabel="cases right (%)", ylim=(0, 105), title="dashed: goal")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


DISCUSSION = "\n## Discussion\n"
"""The heading from which results/identifiability.md is written by hand (kept when the tables are regenerated)."""


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


PATH_OPTIONS = ("--records", "--out", "--export")


def regenerating_command(argv: list[str]) -> str:
    """The command as the page gives it, runnable from any folder: the paths it names absolute, every word quoted
    for a shell where it must be (``candidates=[a,b]`` would be a glob)."""
    words = []
    for index, word in enumerate(argv):
        option, equals, value = word.partition("=")
        if option in PATH_OPTIONS and equals:
            word = f"{option}={Path(value).resolve()}"
        elif index and argv[index - 1] in PATH_OPTIONS:
            word = str(Path(word).resolve())
        words.append(shlex.quote(word))
    return " ".join(["python benchmarks/identifiability.py", *words])


def write_failures_only(out: Path, failures: list[dict]) -> None:
    """identifiability.md in ``out`` when every case failed: the failures alone (a page left from an earlier run would
    read as this one's), and no earlier run's JSON or figure beside it."""
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("identifiability.json", "identifiability.png"):
        (out / stale).unlink(missing_ok=True)
    (out / "identifiability.md").write_text("\n".join([
        "# Identifiability: does the ranking name the missing physics?", "", "Every case failed: nothing is scored.", "",
        *failed_section(failures)]))


def failed_section(failures: list[dict]) -> list[str]:
    return ["## Failed cases", "", "Not scored: their runs failed.", "",
            markdown_table(["case", "kind", "hidden", "error"],
                           [[case_name(f), f["kind"], ", ".join(f["hidden"]) or "none", f["error"]] for f in failures]),
            ""]


def case_name(case: dict) -> str:
    """A case as a reader finds it: a listed record by its file, a split's by its source, kind, fault and rate."""
    if "measured" in case:
        return f"{Path(case['measured']['path']).name} (line {case['line']})" if "line" in case else \
            Path(case["measured"]["path"]).name
    return f"{case['source']} {case['kind']} {case['fault']} {'+'.join(case['hidden']) or 'none'} {case['fs']:g} Hz"


def write_results(results: list[dict], out: Path, command: str, wall_s: float, manifest: Path | None = None,
                  failures: list[dict] | None = None) -> None:
    """identifiability.{md,json,png} in ``out``: the goals' table per source, the confusion of single effects, how the
    cases were made (``manifest``: the listed records'), the misses, the cases whose runs failed (``failures``, not
    scored); a discussion already below the tables is kept."""
    failures = failures or []
    table = summarize(results)
    sources = [source for source in SOURCES if source in table]
    rate = {"single": "hidden single effect added first", "pair": "both effects of a pair added",
            "null": "nothing added on a null case", "out_of_library": "no library effect claimed (out of library)"}
    goals = {"single": 0.9, "pair": 0.8, "null": 0.9, "out_of_library": 0.8}
    # The goal's own wording for single effects: first in the ranking, whether claimed or not.
    counted = [(rate["single"], "single", "right"),
               ("hidden single effect ranked first (claimed or not)", "single", "ranked_first"),
               *((rate[kind], kind, "right") for kind in ("pair", "null", "out_of_library"))]
    rows = []
    for label, kind, key in counted:
        row = [label, whole_percent(goals[kind])]
        for source in sources:
            entry = table.get(source, {}).get(kind)
            row.append(f"{entry[key]}/{entry['n']} ({whole_percent(entry[key] / entry['n'])})" if entry else "—")
        rows.append(row)
    halved = []
    for source in sources:
        found = sum(e["found"] for k, e in table.get(source, {}).items())
        ok = sum(e["halved"] for k, e in table.get(source, {}).items())
        halved.append(f"{ok}/{found}" if found else "—")
    rows.append(["error at least halved when a hidden effect is found", "all", *halved])
    times = [r["seconds"] for r in results]
    by_fs = {fs: np.median([r["seconds"] for r in results if r["fs"] == fs]) for fs in sorted({r["fs"] for r in results})}
    # A listed record's miss names its file: the reader goes back to it.
    misses = [[*([Path(r["measured"]["path"]).name] if manifest is not None else []),
               r["source"], r["kind"], r["fault"], ", ".join(r["hidden"]) or "none", f"{r['fs']:g}", r["unit"],
               ", ".join(r["added"]) or "none",
               ", ".join(f"{c['effect']} {c['evidence']:.1f} ({c['signature_gain']:.1f})" for c in r["rounds"][0][:3])
               if r["rounds"] else "—",
               ", ".join(r["unexplained"]) or "—"]
              for r in results if not score(r)["right"]]
    machine = f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    described = {"twin": "`twin` measurements come from the twin itself (a self-test)",
                 "rig": "`rig` measurements come from the independent test rig, which shares no code with the twin",
                 "records": f"`records` are the files `{manifest}` lists, each with its reference record"}
    if manifest is None:
        made = [
            f"Each case is a {SECONDS:g} s record at one of the conditions (rpm, fs, unit) "
            f"{', '.join(f'({r:g}, {f:g} Hz, {u})' for r, f, u in CONDITIONS['test'])}, an outer- or inner-race "
            "defect, and an operating point the ranking is not told "
            f"({'; '.join(', '.join(f'{k} {v:g}' for k, v in o.items()) for o in OPERATING['test'])}; the clearance "
            "as each source states it: the twin's gap per ball, the rig's total play, twice that gap). "
            "Hidden parameters differ from every configured default and from the development split's, on which "
            "`ranking.points_per_view`, `ranking.view_floor_db` and `ranking.min_signature_gain` were chosen "
            "(`--split dev`)."]
    else:
        made = [f"Each case is a record `{manifest}` lists, held against the twin after its reference record (the "
                "same rig and operating point, nothing hidden), as `bearingtwin-twin reference=` holds one; the "
                "operating point fitted there is held, the gain fitted again. "
                f"Conditions: {'; '.join(sorted({'{:g} Hz, {}'.format(r['fs'], r['unit']) for r in results}))}.",
                *(f"\nHeld against a reference of another operating point: {case_name(r)}, {r['reference_elsewhere']}."
                  for r in results if r.get("reference_elsewhere"))]
    text = [
        "# Identifiability: does the ranking name the missing physics?", "",
        "Effects hidden in a measurement, named (or not) by `bearingtwin-twin`'s compare-calibrate-rank with its "
        "defaults: the operating point fitted (sensor race and direction, load, clearance, defect size, gain), "
        "then every library effect a candidate, added only when it pays for its parameters on the held-out half "
        "and brings the twin closer in the views its own signature shows in (or, where two hide each other's "
        "mark, beside the other of a pair). "
        + "; ".join(described[source] for source in sources) + ".", "",
        markdown_table(["case kind", "goal", *(SOURCES[source] for source in sources)], rows), "",
        "![cases right per kind against the goals](identifiability.png)", "",
        f"Regenerate ({f'{wall_s / 60:.1f} min' if wall_s >= 90 else f'{wall_s:.0f} s'} on {machine}):", "",
        "```bash", command, "```", "",
        "## Hidden single effects: what was added first", "",
        *(line for source in sorted(sources, key=["rig", "records", "twin"].index)
          for line in (f"### {SOURCES[source][0].upper()}{SOURCES[source][1:]}", "", confusion(results, source), "")),
        "## How the cases were made", "", *made, "",
        f"Speed: median compare-calibrate-rank {np.median(times):.0f} s per case "
        f"({', '.join(f'{fs / 1000:g} kHz {t:.0f} s' for fs, t in by_fs.items())}), {len((results[0]['rounds'] or [[]])[0])} "
        "candidates offered in the first round, one process per case.", "",
        "## Misses", "",
        markdown_table([*(["record"] if manifest is not None else []), "source", "kind", "fault", "hidden", "fs", "unit", "added", "first-round evidence (signature gain)",
                        "unexplained views"], misses) if misses else "None.", "",
        *(failed_section(failures) if failures else []),
    ]
    out.mkdir(parents=True, exist_ok=True)
    plot_rates(table, goals, out / "identifiability.png", sources)
    path = out / "identifiability.md"
    # The discussion is written by hand below the generated sections; a new run keeps it.
    kept = path.read_text() if path.is_file() else ""
    kept = kept[kept.index(DISCUSSION):] if DISCUSSION in kept else ""
    path.write_text("\n".join(text).rstrip("\n") + "\n" + kept)
    (out / "identifiability.json").write_text(json.dumps(results, indent=1, default=float))
    print(out / "identifiability.md")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", choices=("dev", "test"), default="test")
    parser.add_argument("--sources", default="twin,rig",
                        help="measurement sources: twin (self-test), rig (the independent rig); conditions, operating "
                             "points and seeds are dealt in the listed order, so one source alone draws its own "
                             "(--split test --sources rig is not the rig half of the committed results; --export the "
                             "split and run its rig rows with --records for that)")
    parser.add_argument("--records", type=Path, default=None,
                        help="a CSV manifest of another rig's records (record, reference, kind, hidden): its cases "
                             "instead of a split's")
    parser.add_argument("--export", type=Path, default=None,
                        help="write the selected cases and their references as .npz files and a cases.csv manifest "
                             "in this folder, and stop")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default=None,
                        help="folder for identifiability.{md,json,png} (default: results for the whole test split, "
                             "else a folder under the system's temporary directory, one per split or manifest)")
    parser.add_argument("--faults", default=None,
                        help="bearing states of the cases (default: outer,inner of a split, every listed record); "
                             "normal or ball: the split's kinds of case on such bearings too, after its own")
    parser.add_argument("--limit", type=int, default=None, help="run only the first N cases (a quick look)")
    parser.add_argument("--fs", type=float, default=None,
                        help="every case of the split at this sampling rate, Hz (the same cases and seeds otherwise: "
                             "how the rate alone moves the decisions)")
    parser.add_argument("overrides", nargs="*", help="bearingtwin-twin overrides, e.g. ranking.points_per_view=3")
    args = parser.parse_args()
    # The committed results are the whole test split's at the defaults: a part of it, another split or other
    # settings are written elsewhere, and never over them.
    whole = (args.records is None and args.split == "test" and args.sources == "twin,rig"
             and args.faults in (None, "outer,inner") and args.limit is None and args.fs is None
             and all(o.startswith("ranking.n_jobs=") for o in args.overrides))
    if args.fs is not None and (args.records is not None or not args.fs > 0):
        parser.error(f"--fs {args.fs:g}: a positive rate for a split's cases (a manifest's records have their own)")
    # A manifest's results go to a folder of its own: another manifest's run does not replace them.
    name = (f"records-{args.records.stem}-{hashlib.sha256(str(args.records.resolve()).encode()).hexdigest()[:8]}"
            if args.records is not None else args.split)
    if args.out is None:
        args.out = "results" if whole else str(Path(tempfile.gettempdir()) / f"bearingtwin-identifiability-{name}")
    elif not whole and Path(args.out).resolve() == (Path(__file__).resolve().parents[1] / "results"):
        parser.error(f"--out {args.out}: the committed results are the whole test split's at the defaults; "
                     "write a part, another split, another rig's records or other settings elsewhere")
    import joblib
    from tqdm.auto import tqdm

    try:
        overrides = run_overrides(args.records is not None, args.overrides)
        try:  # the overrides every run composes, checked once before any
            cfg = twin_config(*overrides)
        except (HydraException, OmegaConfBaseException) as error:
            raise BearingTwinError(f"overrides {' '.join(args.overrides)}: {str(error).splitlines()[0]}") from None
        ranker_settings(cfg)  # a budget or rule bearingtwin-twin would refuse (calibration.n_trials_base=0)
        if args.records is not None:
            todo = cases_from_manifest(args.records, cfg)
        faults = args.faults.split(",") if args.faults else FAULTS if args.records is None else None
        if args.records is None:
            unknown = sorted(set(faults) - set(RIG_FAULTS))
            if unknown:
                raise BearingTwinError(f"--faults {args.faults}: {unknown[0]} is no bearing state; choose from "
                                       f"{', '.join(RIG_FAULTS)}")
            todo = cases(args.split, args.sources.split(","), args.fs, tuple(f for f in faults if f not in FAULTS))
        todo = [case for case in todo if faults is None or case["fault"] in faults][: args.limit]
        if not todo:
            selection = f"--faults {args.faults or ('outer,inner' if args.records is None else 'all')}"
            if args.limit is not None:
                selection += f" --limit {args.limit}"
            raise BearingTwinError(f"no case of {args.records or f'the {args.split} split'} is left by {selection}")
        if args.export is not None:
            manifest = export_cases(todo, args.export, cfg)
            print(f"{len(todo)} cases and their references written; manifest: {manifest} (an SKF 6205's records: "
                  f"run them back with --records {manifest} {SPLIT_BEARING})")
            return 0
    except BearingTwinError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"{plural(len(todo), 'case')}; results will be written to {args.out}", file=sys.stderr)
    start = time.perf_counter()
    keys = list(dict.fromkeys(_reference_key(case) for case in todo))
    first_of = {key: next(case for case in todo if _reference_key(case) == key) for key in keys}
    references = dict(zip(keys, tqdm(joblib.Parallel(n_jobs=args.jobs, return_as="generator")(
        joblib.delayed(run_reference)(first_of[key], overrides) for key in keys), total=len(keys),
        desc="references")))
    ran = list(tqdm(joblib.Parallel(n_jobs=args.jobs, return_as="generator")(
        joblib.delayed(run_listed_case)(case, overrides, references[_reference_key(case)]) for case in todo),
        total=len(todo), desc="cases"))
    wall = time.perf_counter() - start
    results, failures = [r for r in ran if "error" not in r], [r for r in ran if "error" in r]
    for failure in failures:
        print(f"FAILED: {case_name(failure)}: {failure['error']}", file=sys.stderr)
    if not results:
        write_failures_only(Path(args.out), failures)
        print(f"error: {'the case' if len(failures) == 1 else f'all {len(failures)} cases'} failed; nothing to score "
              f"({Path(args.out) / 'identifiability.md'} lists {'it' if len(failures) == 1 else 'them'})", file=sys.stderr)
        return 1
    table = summarize(results)
    print_counts(table)
    states = list(dict.fromkeys(r["fault"] for r in results))
    for state in states if len(states) > 1 else []:  # each bearing state's own counts beside the whole
        print_counts(summarize([r for r in results if r["fault"] == state]), f" {state}")
    if args.split == "dev" and args.records is None:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        Path(args.out, "identifiability_dev.json").write_text(json.dumps(results, indent=1, default=float))
        print(f"written: {Path(args.out, 'identifiability_dev.json')}")
        ranking = OmegaConf.to_container(cfg.ranking, resolve=True)
        gain, rows = choose_signature_gain(results, ranking["points_per_view"], ranking["view_floor_db"])
        print(markdown_table(rows[0], rows[1:]))
        print(f"ranking.min_signature_gain={gain:g} decides the first round right most often at "
              f"ranking.points_per_view={ranking['points_per_view']:g} ranking.view_floor_db={ranking['view_floor_db']:g}"
              " (ties: the lower gain)")
        (points, floor), rows = choose_decision_constants(results, ranking["min_signature_gain"])
        print(markdown_table(rows[0], rows[1:]))
        print(f"ranking.points_per_view={points:g} ranking.view_floor_db={floor:g} decide the first round right "
              f"most often at ranking.min_signature_gain={ranking['min_signature_gain']:g} (ties: fewer points, "
              "then the lower floor)")
        return 1 if failures else 0
    write_results(results, Path(args.out), regenerating_command(sys.argv[1:]), wall, args.records, failures)
    if failures:
        print(f"{len(failures)} of {plural(len(ran), 'case')} FAILED (listed above and in the page's 'Failed cases'); the "
              "others are scored", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
