"""From a composed ``twin`` config to a calibrated, ranked twin: the report, its figures, its MLflow run.

``run_twin`` is the whole of ``bearingtwin-twin``: read the measurement, set the
simulator to its operating point, rank the candidate effects, write
``twin_report.json`` and the PNGs, and log both to MLflow when tracking is enabled.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import logging
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Mapping

import numpy as np
from joblib import cpu_count
from omegaconf import DictConfig, OmegaConf, open_dict

from bearingtwin.checks import is_finite_number, non_negative_number, positive_number, true_or_false, whole_number
from bearingtwin.config import (bearing_config, bearing_overrides, given_on_command_line, output_folder, plain_config,
                                refuse_unknown_bearing, unknown_bearing_note)
from bearingtwin.data.formats import (RATE_NOT_CHECKED_SIMULATED, SIMULATED_RATE, file_bearing, named_rate_note,
                                    read_raw, recording_from_raw, same_speed, speed_setting)
from bearingtwin.data.labels import DEFAULT_LABELS, LabelsRow, labels_row, scale_and_unit_given
from bearingtwin.data.recording import Recording
from bearingtwin.data.units import INTEGRATED_QUANTITIES, acceleration_factor, acceleration_unit, quantity_of, same_unit
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.defects import build_defect
from bearingtwin.physics.effects import build_effects
from bearingtwin.physics.geometry import FAULTS, BearingGeometry
from bearingtwin.signal.sampling_rate import describe_mismatch, require_plausible_rate
from bearingtwin.signal.speed import speed_off_words, speed_profile
from bearingtwin.storage import file_digest
from bearingtwin.twin.compare import VIEWS, Comparator, CompareSettings, plot_comparison
from bearingtwin.twin.model import TwinModel, check_calibratable
from bearingtwin.twin.operating_point import BASE_PARAMETERS, DEFECT_PARAMETERS, OperatingPoint
from bearingtwin.twin.rank import EffectRanker, TwinFit, hardly_identified, view_floors, views_beyond_floor
from bearingtwin.twin.reference import (geometry_difference, hold_reference, read_reference, reference_bearing,
                                        refuse_reference_folder, rig_geometry)

if TYPE_CHECKING:
    from mlflow import MlflowClient

log = logging.getLogger(__name__)

REPORT_NAME = "twin_report.json"
STEPS_FIGURE = "error_steps.png"


def state_by_evidence(measured: Recording, cfg) -> tuple[Recording, str | None]:
    """``measured`` with the bearing state its envelope spectrum names (:func:`~bearingtwin.diagnosis.evidence.
    physics_evidence`: the defect series standing 6 dB or more over its floor, highest) where neither the settings,
    the file nor a labels row states one (a plant's record, its state what the user wants to know), and a line saying
    so; as it is, and None, where one was stated. Refused where the spectrum names none either: the twin simulates one
    state."""
    if measured.fault is not None:
        return measured, None
    from bearingtwin.diagnosis.evidence import physics_evidence

    evidence = physics_evidence(measured.signal, measured.fs, measured.rpm, plain_config(cfg.bearing, "bearing"))
    state = evidence.evidence_state
    if state is None:
        raise BearingTwinError(f"{cfg.measured.path}: the file does not state its bearing state, and its envelope "
                               f"spectrum cannot name one on this bearing ({'; '.join(evidence.unreadable.values())}); "
                               f"give measured.fault=<{'|'.join(FAULTS)}>")
    prominence = evidence.prominence_db.get(state)
    standing = (f"{state} lines {prominence:+.1f} dB over their floor" if prominence is not None else
                f"no defect series {evidence.threshold_db:g} dB over its floor")
    line = (f"{state}, as the record's envelope spectrum names it ({standing}; no state was given): give "
            "measured.fault= where it is known")
    log.warning("%s: held as %s", cfg.measured.path, line)
    return dataclasses.replace(measured, fault=state), line


def load_measurement(measured_cfg, bearing: BearingGeometry | None = None) -> Recording:
    """The measured record the config points at, with fs, rpm and bearing state all known, and
    its sampling rate checked against its shaft speed (``bearing``'s defect lines as a second witness)."""
    recording, channels = read_measurement(measured_cfg)
    return check_measurement(measured_cfg, recording, channels, bearing)


def read_measurement(measured_cfg, state_required: bool = True) -> tuple[Recording, dict]:
    """The first half of :func:`load_measurement`: the record read, with fs, rpm and bearing state all known (the state
    may stay unknown where not ``state_required``: :func:`state_by_evidence` then gives it), and every vibration
    channel of its file (the rate check's witnesses; a HUST export's speed column is none); its rate is not checked
    yet, so that the bearing it names (:func:`record_bearing`) can be settled first, whose defect lines are the check's
    second witness."""
    if OmegaConf.is_missing(measured_cfg, "path"):
        raise BearingTwinError("measured.path is missing: give measured.path=<file> (.npy, .npz, .csv, .txt, .tsv, .mat, .wav or .xls)")
    true_or_false(measured_cfg.check_fs, "measured.check_fs")  # before the file is read
    if not Path(str(measured_cfg.path)).expanduser().exists():  # named by its setting, as diagnose's path= is
        raise BearingTwinError(f"measured.path={measured_cfg.path}: no such file")
    raw = read_raw(measured_cfg.path)
    # What neither the settings nor the file say, a labels.csv beside it may (as training and diagnose read one).
    path = Path(str(measured_cfg.path))
    # A scale's unit is the product's, which no row's unit of the file's own samples replaces.
    scaled = measured_cfg.get("scale") is not None
    given = (measured_cfg.fault, measured_cfg.rpm, measured_cfg.fs, measured_cfg.get("unit") or None)
    row = labels_row(path, state_required=False) if None in given else _readable_row(path)
    from_row = (row.state, row.rpm, row.fs, None if scaled else row.unit) if row else (None,) * 4
    fault, rpm, fs = (value if value is not None else from_table for value, from_table in zip(given[:3], from_row))
    # The settings' scale and unit for the one file they name, else the row's pair, as a diagnosis of one file reads it.
    scale, unit, pair_from_row = scale_and_unit_given(measured_cfg.get("scale"), given[3], row, command_first=True)
    unit_key, scale_key = (f"{row.where}: unit", f"{row.where}: scale") if pair_from_row else ("measured.unit",
                                                                                               "measured.scale")
    if not pair_from_row and row is not None and row.scale is not None and not (
            scale is not None and math.isclose(float(scale), row.scale)):
        log.warning("%s: %s gives scale %g, not applied: the measured.unit and measured.scale given hold for the one "
                    "file they name", path, row.where, row.scale)
    _say_what_the_row_says_otherwise(path, given, from_row, row)
    if row is not None and (fault, rpm, fs, unit) != given:
        log.info("%s: %s read from %s", path, ", ".join(
            f"{name}={value:g}" if isinstance(value, float) else f"{name}={value}"
            for name, value, was in zip(("state", "rpm", "fs", "unit"), (fault, rpm, fs, unit), given)
            if was is None and value is not None), row.where)
    # A tachometer's pulses beside the record may give its speed once its rate is known (recording_from_raw).
    pulses = raw.meta.get("two_levels") and len(raw.channels) > 1
    unknown = [(fact, setting) for fact, setting, value, stated in (
        ("sampling rate", "measured.fs=<Hz>", fs, raw.fs),
        ("speed", "measured.rpm=<rev/min>", rpm, raw.rpm or raw.nominal_rpm or pulses or None),
        ("bearing state", f"measured.fault=<{'|'.join(FAULTS)}>", fault, raw.fault if state_required else "evidence"))
        if value is None and stated is None]
    for fact, words, twin in (("bearing state", raw.meta.get("unlabelled_state"), f"one of {', '.join(FAULTS)}"),
                              ("speed", raw.meta.get("no_speed"), "at one speed")):
        if words:  # what the file states instead: no value the twin can run, and none given or read stands for it
            raise BearingTwinError(f"{path}: the file states {words}; the twin simulates {twin}")
    if unknown:
        facts, settings = zip(*unknown)
        table = f"fill them in on {row.where}" if row else f"a row for it in a {DEFAULT_LABELS} beside it: record,state,rpm,fs"
        raise BearingTwinError(f"{path}: the file does not state its {', '.join(facts)}; give {' '.join(settings)} "
                               f"(or {table})")
    recording = recording_from_raw(raw, channel=measured_cfg.channel, fs=fs, rpm=rpm, fault=fault,
                                   channel_key="measured.channel", fs_key="measured.fs", rpm_key="measured.rpm",
                                   fault_key="measured.fault", unit=unit, unit_key=unit_key, scale=scale,
                                   scale_key=scale_key)
    if recording.rpm is None:  # its tachometer gave none
        why = f" ({recording.meta['speed_unread']})" if recording.meta.get("speed_unread") else ""
        raise BearingTwinError(f"{path}: the file does not state its speed{why}; give measured.rpm=<rev/min>"
                               + (f" (or fill it in on {row.where})" if row else
                                  f" (or a row for it in a {DEFAULT_LABELS} beside it)"))
    recording.require_vibration()  # before the rate check, which a flat record cannot answer
    quantity = quantity_of(recording.unit or "")
    if quantity in INTEGRATED_QUANTITIES:  # a gain would be fitted to it, and the tilt explained as physics
        raise BearingTwinError(f"{path}: the record is in {recording.unit} ({quantity}); the twin simulates an "
                               "accelerometer's record, whose spectrum integration tilts: hold it against the "
                               "accelerometer's own record, in an acceleration unit (or its voltage)")
    # e.g. a nominal speed the twin will run at; a clipping (which the library's `clipping` may then explain)
    for note in [*recording.meta.get("notes", []), *recording.quality_notes()]:
        log.warning("%s: %s", measured_cfg.path, note)
    return recording, raw.vibration_channels


def _readable_row(path: Path) -> LabelsRow | None:
    """The row of the labels.csv beside ``path`` where the settings give every value it could fill in: read only to
    say where it disagrees, so a row that does not read is passed over (as it was before it was read at all)."""
    try:
        return labels_row(path, state_required=False)
    except BearingTwinError:
        return None


def _say_what_the_row_says_otherwise(path: Path, given: tuple, from_row: tuple, row: LabelsRow | None) -> None:
    """Log where a state, speed (beyond :func:`same_speed`), rate or unit given (``given``: measured.fault, .rpm, .fs,
    .unit) differs from the labels row's (``from_row``, the same four of ``row``): the command's value holds for the
    one file it names, as diagnose's does, but not unsaid."""
    if row is None:
        return
    differ = [(key, value, from_table) for key, value, from_table in zip(("fault", "rpm", "fs", "unit"), given, from_row)
              if value is not None and from_table is not None
              and not (same_speed(float(value), float(from_table)) if key == "rpm" else
                       same_unit(str(value), str(from_table)) if key == "unit" else value == from_table)]
    if not differ:
        return
    def words(value) -> str:
        return f"{value:g}" if isinstance(value, float) else str(value)

    log.warning("%s: %s given where %s says %s: the given %s held", path,
                ", ".join(f"measured.{key}={words(value)}" for key, value, _ in differ), row.where,
                ", ".join(f"{'state' if key == 'fault' else key}={words(from_table)}" for key, _, from_table in differ),
                "value is" if len(differ) == 1 else "values are")


def check_measurement(measured_cfg, recording: Recording, channels: dict,
                      bearing: BearingGeometry | None = None) -> Recording:
    """The second half of :func:`load_measurement`: ``recording``'s sampling rate checked against its shaft speed
    (``bearing``'s defect lines as a second witness, every one of its file's vibration ``channels`` a witness) unless
    ``measured.check_fs=false`` (its levels, that the comparison's statistics stay within a float's range, were
    checked as it was loaded: :meth:`~bearingtwin.data.recording.Recording.require_vibration`)."""
    if recording.meta.get("fs_origin") == SIMULATED_RATE:
        log.info("%s: %s", measured_cfg.path, RATE_NOT_CHECKED_SIMULATED)
    elif true_or_false(measured_cfg.check_fs, "measured.check_fs"):
        # A rate given here or only declared by a data set's convention is refused when the record contradicts
        # it; one the file records itself is kept, the doubt logged (a speed typed a whole factor too high is refused).
        rate_given = recording.meta.get("fs_origin") in ("config", "declared")
        # A rate given against the one the file's name gives (a CWRU 12k_ file read at 48 kHz), as a diagnosis says.
        against_name = (named_rate_note(recording.meta, recording.fs, "measured.fs")
                        if recording.meta.get("fs_origin") == "config" else None)
        check = require_plausible_rate(
            recording.signal, recording.fs, recording.rpm, str(measured_cfg.path), "measured.fs",
            check_key="measured.check_fs", rpm_key=speed_setting(recording, "measured.rpm"),
            defect_hz=bearing.defect_frequencies(recording.rpm) if bearing is not None else None,
            refuse=rate_given, channels=channels,
            rate_from_file=not rate_given and recording.meta.get("rpm_origin") == "config",
            against_name=against_name, named_hz=(recording.meta.get("named_rate") or {}).get("hz"))
        if check is not None and check.verdict == "contradicted":  # kept (the file records its rate), in doubt
            recording.meta["rate_contradicted"] = describe_mismatch(check)
    return recording


def speed_read_off(measured: Recording) -> str | None:
    """What to say where the record's shaft series puts its speed 1-8 % from the stated one
    (:func:`~bearingtwin.signal.speed.speed_off_words`: a nameplate's speed given for a measured one, which the rate
    check lets through within its 2 %); None where it does not, cannot be read, or the speed is read from a tachometer
    or the record is the twin's own (its shaft lines stand at the nominal speed)."""
    if measured.meta.get("fs_origin") == SIMULATED_RATE or measured.meta.get("rpm_origin") == "tachometer":
        return None
    read = speed_profile(measured.signal, measured.fs, measured.rpm).read_rpm
    if read is None:
        return None
    return speed_off_words(read, measured.rpm, "the shaft's harmonic series", "measured.rpm")


DEFAULT_BEARING = "paper"
"""The bearing ``conf/twin.yaml`` composes when none is chosen: a record that names its own replaces it
(:func:`record_bearing`)."""


def bearing_chosen(cfg: DictConfig) -> bool:
    """Whether the twin's bearing was chosen rather than left at :data:`DEFAULT_BEARING`.

    It was left there when it is named ``paper`` and no command-line override names ``bearing`` or a
    ``bearing.<key>`` (so an explicit ``bearing=paper`` is a choice, and so is ``bearing.n_balls=8``). Outside a
    Hydra run (a config composed by a test or a script) no override can be read: the name alone decides, so
    ``paper`` counts as the default there.
    """
    return cfg.bearing.get("name") != DEFAULT_BEARING or bool(given_on_command_line("bearing"))


def record_bearing(cfg: DictConfig, measured: Recording, reference: str | None = None) -> tuple[DictConfig, str | None]:
    """The ``twin`` config with the bearing the record was made on, and the line the closing summary gives it
    (None when there is nothing to say: the record names the bearing chosen, or names none and one was chosen; a
    record that names none, held against the default bearing, is said to be).

    A record that names its bearing (:func:`~bearingtwin.data.formats.file_bearing`) is read with it: when no bearing
    was chosen (:func:`bearing_chosen`), that bearing's config replaces the default's (a line says so); a bearing chosen that
    is neither the record's by name nor of its geometry (the fields a reference's bearing is compared by,
    :func:`~bearingtwin.twin.reference.geometry_difference`) is refused, naming both, before a run opens or anything is
    written: the twin would be calibrated to another bearing's defect frequencies. A bearing the record names that
    no ``conf/bearing`` config describes cannot be read: the twin's stays, and the doubt is logged and returned.
    """
    path, ours = cfg.measured.path, cfg.bearing.get("name")
    named = file_bearing(measured.meta, measured.channel)
    chosen = bearing_chosen(cfg)
    if named is None and not chosen and reference is not None:  # a later record of the reference's rig
        return _with_bearing(cfg, bearing_config(reference, "the reference's bearing")), \
            f"{reference}, the reference's (no bearing= given)"
    if named is None and not chosen:  # a user's own record, held against the paper's bearing unless told otherwise
        line = (f"{ours}, the default: the record names no bearing; give bearing=<name> (a conf/bearing config, or "
                "one's own) for the defect frequencies of the bearing it was made on")
        return cfg, line  # said where the closing summary names the bearing
    if named is None or named == ours:
        return cfg, None
    if not chosen:
        refuse_unknown_bearing(named, path)
    unknown = unknown_bearing_note(named, f"the twin reads {ours}'s defect frequencies, unchecked against it")
    if unknown is not None:
        log.warning("%s: %s", path, unknown)
        return cfg, unknown
    own = bearing_config(named, f"{path}: its bearing")
    record, given = BearingGeometry.from_config(own), BearingGeometry.from_config(cfg.bearing)
    if chosen:
        if geometry_difference(rig_geometry(given), rig_geometry(record)) is None:  # your own under another name
            return cfg, None
        raise BearingTwinError(f"{path}: the record's bearing is {named} ({record.describe_orders()}), the one given is "
                               f"{ours} ({given.describe_orders()}): give bearing={named} for the record's defect "
                               "frequencies")
    log.info("%s: the record's bearing is %s and no bearing= was given: the twin reads it (%s), not %s's",
             path, named, record.describe_orders(), ours)
    return _with_bearing(cfg, own), f"{named}, the record's own (no bearing= given; {record.describe_orders()})"


def _with_bearing(cfg: DictConfig, bearing) -> DictConfig:
    """A copy of the ``twin`` config with ``bearing`` (a bearing config) in place of its own."""
    adopted = copy.deepcopy(cfg)
    OmegaConf.set_readonly(adopted, False)
    with open_dict(adopted):
        adopted.bearing = bearing
    return adopted


MAX_SEED = 2**31 - 1
"""Every Optuna sampler takes a seed derived from ``seed``, which numpy wants below 2**32: the operating point's
``seed`` itself, each re-fit's ``seed`` plus 1000 per round (half that range leaves room for any number of rounds),
each candidate's screen a 32-bit draw from ``seed``, its round and its name."""


def ranker_settings(cfg: DictConfig) -> dict:
    """The ``candidates``, ``effects``, trial budgets of ``calibration``, ``ranking`` and ``seed`` settings, each
    checked, as :class:`EffectRanker`'s keyword arguments (all but the operating point, which needs the record's
    bearing state): a bad one is named before the measurement is read, let alone a twin simulated."""
    calibration, ranking = cfg.calibration, cfg.ranking
    fixed_effects = _plain(cfg.effects) or {}
    build_effects(fixed_effects)  # their parameters, before the twin simulates with them
    later = ranking.later_points_per_view
    return {
        "candidates": candidate_names(_plain(cfg.candidates), fixed_effects),
        "fixed_effects": fixed_effects,
        **{key: whole_number(f"calibration.{key}", calibration[key])
           for key in ("n_trials_base", "n_trials_effect", "n_trials_refine")},
        **{key: whole_number(f"calibration.{key}", calibration[key], minimum=0)  # 0: no local polish
           for key in ("n_polish", "n_polish_effect")},
        "max_effects": whole_number("ranking.max_effects", ranking.max_effects, minimum=0),
        "points_per_view": values_per_view("ranking.points_per_view", ranking.points_per_view, "values per view"),
        "view_floor_db": positive_number(ranking.view_floor_db, "ranking.view_floor_db", "dB"),
        "min_signature_gain": non_negative_number("ranking.min_signature_gain", ranking.min_signature_gain),
        "pair_candidates": whole_number("ranking.pair_candidates", ranking.pair_candidates, minimum=0),
        "later_points_per_view": None if later is None else values_per_view(
            "ranking.later_points_per_view", later, "values per view, or null"),
        "n_jobs": thread_count(ranking.n_jobs),
        "seed": seed_value(cfg.seed),
    }


def values_per_view(key: str, value, unit: str) -> float:
    """How many values each view counts as: positive, and enough that the views count as more than one value in
    all, so that a parameter's price (ln of that count, :func:`~bearingtwin.twin.rank.penalty_per_parameter`) is
    a price."""
    points = positive_number(value, key, unit)
    if not points * len(VIEWS) > 1:
        count = points * len(VIEWS)
        raise BearingTwinError(f"{key}={value!r}: the {len(VIEWS)} views would count as {count:g} value"
                               f"{'s' * (count != 1)} in all, and a parameter would cost nothing; give more than "
                               f"{1 / len(VIEWS):g}")
    return points


def candidate_names(candidates, fixed_effects: Mapping) -> list[str]:
    """``candidates``: a list of distinct effect names the twin can calibrate (a fixed effect among them is tried as
    changed from its given values, see :class:`EffectRanker`)."""
    if isinstance(candidates, str):  # candidates=noise: Hydra reads a string, not a list of one
        raise BearingTwinError(f"candidates={candidates}: give a list of effect names, candidates=[{candidates}]")
    if not isinstance(candidates, list):
        raise BearingTwinError(f"candidates must be a list of effect names, got {candidates!r}")
    for index, name in enumerate(candidates):
        if not isinstance(name, str):
            raise BearingTwinError(f"candidates: {name!r} is not an effect name")
        if name in candidates[:index]:
            raise BearingTwinError(f"candidates: {name} is named twice")
        try:
            check_calibratable(name)
        except BearingTwinError as error:
            raise BearingTwinError(f"candidates: {error}") from None
    return candidates


def thread_count(n_jobs) -> int:
    """``ranking.n_jobs``: threads, or -1 for one per core (joblib's convention, as the project's other n_jobs)."""
    if is_finite_number(n_jobs) and n_jobs == -1:
        return cpu_count()
    try:
        return whole_number("ranking.n_jobs", n_jobs)
    except BearingTwinError as error:
        raise BearingTwinError(f"{error} (or -1: one thread per core)") from None


def seed_value(seed) -> int:
    """``seed`` as an int from 0 to :data:`MAX_SEED`."""
    seed = whole_number("seed", seed, minimum=0)
    if seed > MAX_SEED:
        raise BearingTwinError(f"seed must be at most {MAX_SEED}, got {seed}")
    return seed


def build_ranker(cfg: DictConfig, fault: str, progress: bool = False) -> EffectRanker:
    """The effect ranker the ``operating_point`` / ``calibration`` / ``ranking`` / ``candidates`` /
    ``effects`` config describes, for a measurement of bearing state ``fault``; with ``progress``, it shows
    its stages on stderr."""
    calibration = cfg.calibration
    operating = OperatingPoint.from_config(
        _plain(cfg.operating_point), _plain(calibration.ranges), _plain(calibration.base), fault,
        calibration.sensor_angle_step_deg, _plain(calibration.base_held))
    return EffectRanker(operating_point=operating, progress=progress, **ranker_settings(cfg))


def check_held_defect(cfg: DictConfig, operating: OperatingPoint, fault: str, geometry: BearingGeometry) -> None:
    """A defect size held in ``operating_point`` that the simulator cannot make (a spall wider than a ball) is
    refused before any run opens, naming the setting, rather than by every trial of the calibration."""
    held = {name: operating.known[name] for name in DEFECT_PARAMETERS if name in operating.known}
    if fault == "normal" or not held:
        return
    defect = dict(_plain(cfg.simulator.defect))
    defect.update({BASE_PARAMETERS[name].key.rsplit(".", 1)[-1]: value for name, value in held.items()})
    try:
        build_defect(fault, geometry, defect, 0.0)
    except BearingTwinError as error:
        given = ", ".join(f"operating_point.{name}={value:g}" for name, value in held.items())
        raise BearingTwinError(f"{given} cannot be simulated: {error}") from None


def _plain(node):
    """A config node as plain Python (a block the command line replaced by a value stays that value, to be named)."""
    return OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node


def twin_for(measured: Recording, cfg: DictConfig) -> TwinModel:
    """The simulator at the measurement's operating point (rpm, fs, fault), ``twin.duration`` long."""
    duration = cfg.twin.duration
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not (math.isfinite(duration) and duration > 0):
        raise BearingTwinError(f"twin.duration must be a positive, finite number of seconds, got {duration!r}")
    segments = CompareSettings.from_config(_plain(cfg.compare)).segments_s
    longest = max(segments, key=segments.get)
    if duration < segments[longest]:  # every trial would be refused, after the whole budget had run
        raise BearingTwinError(f"twin.duration={duration:g} s is shorter than one comparison segment "
                               f"(compare.{longest}={segments[longest]:g} s): give twin.duration of at least "
                               f"{segments[longest]:g} s")
    simulator_cfg = OmegaConf.to_container(cfg.simulator, resolve=True)
    simulator_cfg.update(rpm=float(measured.rpm), fs=float(measured.fs), duration=float(duration))
    return TwinModel(measured.fault, OmegaConf.to_container(cfg.bearing, resolve=True), simulator_cfg, int(cfg.seed))


def write_report(fit: TwinFit, out_dir: Path, figures: bool, measured: dict | None = None) -> list[Path]:
    """``twin_report.json`` (with ``measured``: what was measured, for a later run that takes this one as its
    reference) and, with ``figures``, the comparison views before and after and the error curve."""
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_earlier_figures(out_dir)
    report = {"measured": measured or {}, **fit.as_dict()}
    report["baseline_comparison"] = fit.steps[0].comparison.as_dict()
    report["final_comparison"] = fit.steps[-1].comparison.as_dict()
    path = out_dir / REPORT_NAME
    path.write_text(json.dumps(report, indent=2, default=float))
    written = [path]
    if figures:
        written += plot_comparison(fit.steps[0].comparison, out_dir, prefix="baseline")
        if len(fit.steps) > 1:
            written += plot_comparison(fit.steps[-1].comparison, out_dir, prefix="final")
        written += plot_steps(fit, out_dir)
    return written


def remove_earlier_figures(out_dir: Path) -> None:
    """Remove the figures an earlier run of this command left in ``out_dir``.

    Beside the new report they would pass for its own: another record's, or all of them after a run with
    figures=false. Only the names this command writes are removed (``<baseline|final>_<view>.png``, as
    :func:`plot_comparison` names them, and the error curve), never any other file in the folder.
    """
    names = [f"{prefix}_{view}.png" for prefix in ("baseline", "final") for view in VIEWS] + [STEPS_FIGURE]
    for name in names:
        (out_dir / name).unlink(missing_ok=True)


def plot_steps(fit: TwinFit, out_dir: Path) -> list[Path]:
    """Discrepancy against effects added, and the first-round ranking of every candidate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    labels = ["twin"] + [f"+{step}" for step in (fit.added[i].effect for i in range(len(fit.added)))]
    left.plot(range(len(fit.steps)), [s.error for s in fit.steps], "o-")
    left.set_xticks(range(len(fit.steps)), labels, rotation=30, fontsize=8)
    left.set(ylabel="discrepancy (dB)", title="error against effects added")
    names = [f.effect for f in fit.ranking]
    right.barh(range(len(names)), [100 * f.explained for f in fit.ranking])
    # The order is the evidence's, not the share's: a share closed in many views' points may not pay for more
    # parameters, so each bar carries the number it is ranked by.
    for row, candidate in enumerate(fit.ranking):
        right.annotate(f" evidence {candidate.evidence:+.3g}", (max(100 * candidate.explained, 0.0), row),
                       va="center", fontsize=7)
    right.set_yticks(range(len(names)), names, fontsize=8)
    right.invert_yaxis()
    right.axvline(0.0, color="k", lw=0.8)
    right.margins(x=0.25)
    # A candidate fitted on one half may leave the other half further off: a negative share, shown as such.
    right.set(xlabel="share of the held-out discrepancy closed (%; below 0: it grew)",
              title="each candidate alone, ranked by evidence (> 0: it pays)")
    fig.tight_layout()
    path = out_dir / STEPS_FIGURE
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def open_twin_run(cfg: DictConfig, measured: Recording) -> tuple[MlflowClient, str]:
    """The command's MLflow run, opened before the calibration with its config: an interrupt marks it
    KILLED and a failure FAILED (:func:`bearingtwin.tracking.lifecycle.stop_cleanly`), and a store
    that cannot serve is named before any work."""
    from mlflow.entities import Param

    from bearingtwin.tracking.lifecycle import open_owned_run, reap_dead_runs
    from bearingtwin.tracking.mlflow_logging import flatten, loggable_config, open_store

    client, experiment_id = open_store(cfg.tracking)
    reap_dead_runs(client)
    run_id = open_owned_run(client, experiment_id, f"twin {Path(str(measured.source)).name} {measured.fault}",
                            {"bt.kind": "twin", "measured": str(measured.source)}).info.run_id
    params = [Param(k[:250], str(v)[:6000]) for k, v in flatten(loggable_config(cfg)).items()]
    for first in range(0, len(params), 100):  # MLflow takes at most 100 params per batch
        client.log_batch(run_id, params=params[first:first + 100])
    return client, run_id


def log_to_mlflow(client: MlflowClient, run_id: str, fit: TwinFit, files: list[Path]) -> str:
    """The run's results: discrepancy per step and per view, the ranking, the report and figures; FINISHED."""
    from mlflow.entities import Metric, RunStatus

    now = int(time.time() * 1000)
    metrics = [Metric("discrepancy_db", s.error, now, i) for i, s in enumerate(fit.steps)]
    metrics += [Metric(f"view_{v}_db", r.error_db, now, i) for i, s in enumerate(fit.steps)
                for v, r in s.comparison.views.items()]
    metrics += [Metric(f"explained_{f.effect}", f.explained, now, 0) for f in fit.ranking]
    metrics += [Metric(f"evidence_{f.effect}", f.evidence, now, 0) for f in fit.ranking]
    metrics += [Metric(f"signature_gain_{f.effect}", f.signature_gain, now, 0) for f in fit.ranking]
    metrics += [Metric(f"op_{name}", entry["value"], now, 0) for name, entry in fit.operating_point.items()
                if isinstance(entry.get("value"), float)]
    metrics += [Metric("gain", fit.gain, now, 0), Metric("floor_error", fit.floor_error, now, 0)]
    metrics += [Metric("baseline_error", fit.baseline_error, now, 0), Metric("final_error", fit.final_error, now, 0)]
    client.log_batch(run_id, metrics=metrics)
    client.set_tag(run_id, "summary", fit.summary[:5000])
    client.set_tag(run_id, "verdict", fit.verdict)
    if fit.unclaimed is not None:
        client.set_tag(run_id, "unclaimed", fit.unclaimed.effect)
    for path in files:
        client.log_artifact(run_id, str(path))
    client.set_terminated(run_id, RunStatus.to_string(RunStatus.FINISHED))
    return run_id


def fault_check(measured: Recording, bearing_cfg) -> str | None:
    """A sentence when the measurement's envelope spectrum shows another bearing state's defect series standing
    out while the stated state's does not: a twin calibrated to a wrongly stated state explains the difference
    away with whatever else it can move. None when the envelope agrees, or says nothing either way."""
    from bearingtwin.diagnosis.evidence import physics_evidence

    try:
        evidence = physics_evidence(measured.signal, measured.fs, measured.rpm, _plain(bearing_cfg))
    except BearingTwinError:  # a record too short or too slow for the envelope's lines: no second opinion
        return None
    shown, stated = evidence.evidence_state, measured.fault
    if shown in (None, "normal", stated) or evidence.prominence_db.get(stated, -math.inf) >= evidence.threshold_db:
        return None
    given = ("" if stated == "normal" else
             f"; the {stated} defect's series {_over_its_floor(evidence.prominence_db[stated])}"
             if stated in evidence.prominence_db else f"; the {stated} defect's cannot be read here")
    return (f"measured.fault={stated}, but the envelope spectrum's defect series standing out is the {shown} defect's "
            f"({evidence.prominence_db[shown]:.1f} dB over its floor{given}): check the stated bearing state")


def _over_its_floor(prominence_db: float) -> str:
    """A series' prominence over its envelope floor in words: a negative one stands below it."""
    if abs(prominence_db) < 0.5:
        return "stands at its floor"
    return f"stands {abs(prominence_db):.1f} dB {'over' if prominence_db > 0 else 'below'} its floor"


def compare_with_reference(fit: TwinFit, comparator: Comparator, measured: Recording, reference: Mapping,
                           view_floor_db: float) -> None:
    """Set ``fit.since_reference``: the views in which ``measured`` (``comparator``'s measurement) differs from the
    reference's own record (read
    again from the path its report names), beyond the measurement's part-to-part scatter. No twin stands between
    the two, so whatever the twin cannot reproduce of the rig (its path, its floor) is the same in both and drops
    out; what is left is what changed. Where the record cannot be read, was taken at another rate or speed, or on
    another sensor of its file, ``fit.reference_note`` says why no comparison was made."""
    about = reference.get("measured") or {}
    stored = about.get("file") if isinstance(about.get("file"), Mapping) else {}
    path = stored.get("path") or about.get("path")  # the resolved path; a report without it names it as typed
    try:
        if not path or not Path(path).is_file():
            raise BearingTwinError(f"its record {path or '(not named in the report)'} is not there")
        if stored.get("sha256") and file_digest(Path(path)) != stored["sha256"]:
            raise BearingTwinError(f"its record {path} has changed since the reference was made")
        if Path(path).resolve() == Path(measured.source).resolve():
            raise BearingTwinError("it is this record itself")
        if not (is_finite_number(about.get("fs")) and math.isclose(float(about["fs"]), measured.fs, rel_tol=1e-9)):
            raise BearingTwinError(f"its record was taken at {_number_words(about.get('fs'))} Hz, this one at {measured.fs:g} Hz")
        if not (is_finite_number(about.get("rpm")) and same_speed(float(about["rpm"]), measured.rpm)):
            raise BearingTwinError(f"its record was taken at {_number_words(about.get('rpm'))} rpm, this one at "
                                   f"{measured.rpm:g} rpm")
        raw = read_raw(path)
        if "channel" not in about and len(raw.channels) > 1:
            raise BearingTwinError(f"its report does not say which of its record's channels ({', '.join(map(str, raw.channels))}) "
                                   "was read")
        # In the unit its run read it in: a WAV's or an .npy's was given (measured.unit, with measured.scale), and
        # read without it the record would state none, its level never compared with this one's. A report that
        # keeps no scale (made before reports kept one) may hold a scaled product's unit: its record is read as
        # it states itself, as then.
        kept = "scale" in about
        earlier = recording_from_raw(raw, channel=about.get("channel"), fs=float(about["fs"]),
                                     channel_key="the reference report's measured.channel",
                                     unit=(about.get("unit") or None) if kept else None,
                                     unit_key="the reference report's measured.unit",
                                     scale=about.get("scale") if kept else None,
                                     scale_key="the reference report's measured.scale")
        # Channel names differ between formats (a .mat's DE, an export's `signal`): only a file that holds this
        # record's channel too, and was read on another, says the reference is another sensor's.
        if str(earlier.channel) != str(measured.channel) and str(measured.channel) in map(str, raw.channels):
            raise BearingTwinError(f"its record was read on channel {earlier.channel}, this one on {measured.channel}, "
                                   "which its file holds too: another sensor")
        comparison = comparator(earlier.signal, other="the reference record")
    except BearingTwinError as error:
        fit.reference_note = str(error)
        return
    fit.since_reference = views_beyond_floor(comparison, view_floors(fit.repeatability_db, view_floor_db),
                                             comparator.settings.weights)
    # The views compare shapes after a gain fitted between the two records: their levels are compared apart, in one
    # unit (a record in g against one in m/s^2 differs by 9.81 in its numbers alone), as the overall RMS a vibration
    # analyst trends (the gain, a typical band's change, understates a defect's: 9.6 dB where the RMS rose 18 dB).
    units = acceleration_unit(measured.unit or ""), acceleration_unit(earlier.unit or "")
    rms = [float(np.std(signal)) for signal in (measured.signal, earlier.signal)]  # about the mean: a DC offset is no level
    if min(rms) > 0 and (units[0] is not None and units[1] is not None or measured.unit == earlier.unit):
        factor = acceleration_factor(units[1], units[0]) if units[0] and units[1] else 1.0
        fit.level_since_reference_db = 20.0 * math.log10(rms[0] / (rms[1] * factor))
    elif min(rms) > 0:  # a record of no stated unit beside one in m/s^2 (or the other way): numbers of two scales
        fit.level_not_compared = level_not_compared_words(measured.unit, earlier.unit)


def level_not_compared_words(unit: str | None, reference_unit: str | None) -> str:
    """Why a record's level is not compared with its reference record's: the units of the two (``unit``,
    ``reference_unit``), one of them not an acceleration unit known here, and how to say the one not stated."""
    words = f"this record's unit is {unit or 'not stated'}, the reference record's {reference_unit or 'not stated'}"
    if not unit:
        return words + " (give measured.unit=<unit>)"
    if not reference_unit:
        return words + " (its report's measured.unit, given when it was made, would state it)"
    return words


def mark_unidentified_by_reference(operating: dict, earlier: Mapping, taken: set[str]) -> None:
    """Mark the held values (``identified_by_reference: false``) that came from a reference whose own record did
    not identify them (any value, or nearly any, in its searched range fitted as well; for the sensor, any
    direction): numbers that mean little. ``taken``: the names this run's config left to fit, which the reference
    filled in (a value a user gives is not marked; the sensor's is its direction, ``sensor_angle_deg``)."""
    for name, entry in operating.items():
        before = earlier.get(name)
        left_to_fit = name in taken or name == "sensor" and "sensor_angle_deg" in taken
        if entry.get("held") and left_to_fit and isinstance(before, Mapping) and (
                hardly_identified(before) or before.get("identified_by_reference") is False):  # or held so there
            entry["identified_by_reference"] = False


def record_words(measured: Recording, channels: Mapping, inferred_state: bool = False) -> str:
    """What the twin was held against, as the closing summary says it: state, speed, rate, unit and, of a file of
    several vibration channels (``channels``), the channel, wherever each came from (the file, a labels table, a
    setting); a state the record's envelope spectrum named (``inferred_state``: none was stated) is said to be."""
    unit = f"in {measured.unit}" if measured.unit else "its unit not stated"
    channel = f", channel {measured.channel}" if measured.channel is not None and len(channels) > 1 else ""
    state = f"{measured.fault} (by its envelope spectrum: see state)" if inferred_state else measured.fault
    return f"{state}, {measured.rpm:g} rpm, {measured.fs:g} Hz, {unit}{channel}"


def _number_words(value) -> str:
    """A number a report holds as a reader would write it (1796, not 1796.0); anything else as it is."""
    return f"{value:g}" if is_finite_number(value) else str(value)


def run_twin(cfg: DictConfig, progress: bool = False) -> tuple[TwinFit, list[Path], str | None, dict[str, str]]:
    """Everything ``bearingtwin-twin`` does; returns the fit, the files written, the MLflow run id (None when
    tracking is disabled) and what the closing summary repeats of what was logged: ``bearing`` (the record's own,
    read because no bearing was given, or one it names that no config describes, :func:`record_bearing`) and
    ``check`` (the measurement's envelope against its stated state, :func:`fault_check`).
    ``progress``: show the calibration's stages on stderr."""
    out = output_folder(cfg.out)
    figures = true_or_false(cfg.figures, "figures")
    tracking = true_or_false(cfg.tracking.enabled, "tracking.enabled")
    ranker_settings(cfg)  # checked before the file is read; the ranker is built once the record's state is known
    settings = CompareSettings.from_config(OmegaConf.to_container(cfg.compare, resolve=True))
    if cfg.get("reference") is not None:
        refuse_reference_folder(cfg.reference, out)
    BearingGeometry.from_config(cfg.bearing)  # a bad bearing.* value is named before the file is read
    measured, channels = read_measurement(cfg.measured, state_required=False)
    # The record's own bearing replaces the default one, and another chosen is refused, before its defect lines
    # witness the rate, the MLflow run opens (with the config: the bearing used) or anything is written.
    reference = read_reference(cfg.reference) if cfg.get("reference") is not None else None
    cfg, bearing_line = record_bearing(cfg, measured, reference_bearing(reference))
    geometry = BearingGeometry.from_config(cfg.bearing)
    measured = check_measurement(cfg.measured, measured, channels, geometry)
    measured, state_line = state_by_evidence(measured, cfg)
    # What the closing summary repeats, as logged: the bearing whose defect lines the twin reads, always.
    # A geometry of its own (a simulation's bearing.n_balls=12) is said with the name it changes.
    notes = {"record": record_words(measured, channels, inferred_state=state_line is not None),
             "bearing": bearing_line or " ".join([str(cfg.bearing.get("name")), *bearing_overrides()])}
    if state_line:
        notes["state"] = state_line
    off = speed_read_off(measured)
    if off:  # said now, and again in the closing summary: every defect line is sought beside where it stands
        log.warning("%s: %s", cfg.measured.path, off)
        notes["speed"] = off
    elif measured.meta.get("rate_contradicted"):  # logged by the check; the summary is what a user reads last
        notes["speed"] = (f"IN DOUBT: the shaft line contradicts the speed or rate ({measured.meta['rate_contradicted']}): "
                          "every defect line is sought where the stated values put it: check the speed and the rate "
                          "the record was read at")
    to_fit = {name for name, value in cfg.operating_point.items() if value is None} | set(cfg.calibration.base)
    if reference is not None:  # an earlier record of this rig: what it found is held
        cfg = hold_reference(cfg, reference, measured.fault, source=f"reference={cfg.reference}")
    twin = twin_for(measured, cfg)
    ranker = build_ranker(cfg, measured.fault, progress)
    check_held_defect(cfg, ranker.operating_point, measured.fault, geometry)
    for note in ranker.operating_point.notes:  # said now, and again in the closing summary
        log.warning(note)
    if ranker.operating_point.notes:
        notes["held"] = "; ".join(ranker.operating_point.notes)
    comparator = Comparator(measured, geometry, settings)  # a record too short for one comparison segment, before a run opens
    tracked = open_twin_run(cfg, measured) if tracking else None
    ranker.fit(twin, measured, geometry, settings)
    if reference is not None:
        compare_with_reference(ranker.fit_, comparator, measured, reference, ranker.view_floor_db)
        mark_unidentified_by_reference(ranker.fit_.operating_point, reference["operating_point"], to_fit)
    check = fault_check(measured, cfg.bearing)
    record = Path(str(cfg.measured.path)).expanduser().resolve()  # a later run may start in another folder
    about = {"path": str(cfg.measured.path), "file": {"path": str(record), "sha256": file_digest(record)},
             "fault": measured.fault, "fs": measured.fs, "rpm": measured.rpm, "unit": measured.unit,
             "scale": measured.meta.get("scale"),
             "channel": measured.channel, "bearing": cfg.bearing.get("name"), "geometry": rig_geometry(geometry),
             "reference": cfg.get("reference"), "fault_check": check}
    files = write_report(ranker.fit_, out, figures, about)
    run_id = log_to_mlflow(*tracked, ranker.fit_, files) if tracked else None
    if check:
        notes["check"] = check
    return ranker.fit_, files, run_id, notes
