"""Diagnose one recording with a trained model: read, check, window, predict, weigh against physics.

A record is checked against the model before anything is predicted: its sampling rate
(resampled with ``scipy.signal.resample_poly`` to the model's when it differs, and said so),
its length (at least one window), its values (finite) and its shaft speed where the model's
features or the physics evidence need it. It is then cut into non-overlapping windows over its
whole length, every window is predicted (but those touching a dropout as long as a window, which read no
vibration, or samples with no value: :func:`diagnosed_windows`), and the record's verdict is the state most windows
voted for. :func:`diagnose_recording` returns the ``diagnosis.json`` contract:

``record``, ``model_uri``, ``model_version_uri`` (an alias replaced by the version it named), ``fs``, ``rpm``, ``verdict``, ``share``, ``mean_probability``,
``windows`` (``start_s``, ``state``, ``probabilities``; ``decided_by`` and ``feature_unseen`` where the model gives them), ``evidence``, ``evidence_state``, ``agree``,
``windows_left_out``, ``rate_check`` (the shaft line against the speed and rate: ``consistent``, ``ambiguous``,
``contradicted`` or ``not checked``), ``speed`` (how steadily the shaft turned, read from its harmonic series
segment by segment, and whether the record was resampled to a steady speed: :func:`steadied`; null where no speed
was known or the record is the twin's), ``unit_check`` (the record's unit against the model's: ``as stated``,
``converted``, ``assumed`` where the file states none, ``not checked`` where the model states none, ``not needed``
where no unit's scale matters to the model: :attr:`DiagnosisPipeline.scale_free`), ``level_unseen`` (the windows' level lies a decade or more from the
training windows'), ``features_unseen`` (the share of windows the classifier decided on a feature well beyond every
training window's; null for a model that kept no such range: :meth:`DiagnosisPipeline.features_unseen`), ``notes``, ``fault_size_in``, ``position`` and ``load_hp`` where the
file's name gives them and, when the truth is known, ``true_state``, ``correct`` and ``physics_correct`` (the evidence
alone). Beside them: ``source``, ``channel``, ``bearing`` (whose defect lines were read) and ``original_fs``
(what was read), and
``windows_correct`` with a truth (``calibration_record``, ``run_id`` and ``diagnosed_at`` are added by
:mod:`bearingtwin.diagnosis.run`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np
import scipy.signal

from bearingtwin.config import refuse_unknown_bearing
from bearingtwin.data.cwru import parse_cwru_name
from bearingtwin.data.formats import (RATE_NOT_CHECKED_SIMULATED, SIMULATED_RATE, RawRecord,
                                    file_bearing, named_rate_note, read_raw, recording_from_raw,
                                    refuse_a_label_the_file_contradicts, resolve_unit, tachometer_channel)
from bearingtwin.data.recording import CLIPPED_NOTE_END, HELD_NOTE_END, Recording, held_stretches
from bearingtwin.data.units import acceleration_unit, quantity_of, same_unit
from bearingtwin.diagnosis.evidence import PhysicsEvidence, physics_evidence
from bearingtwin.diagnosis.mlflow_model import DECIDED_BY_COLUMN, FEATURE_UNSEEN_COLUMN, STATE_COLUMN, model_params
from bearingtwin.diagnosis.pipeline import RANGE_MARGIN, DiagnosisPipeline, unit_for_model
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry, check_fault
from bearingtwin.signal.sampling_rate import (check_channels, decisive_channel, describe_mismatch, longest_run,
                                              rate_against_name_error, rate_witnesses, series_elsewhere_words,
                                              series_stands_at, shared_transforms, speeds_lines_alone_hide, true_runs)
from bearingtwin.signal.speed import (SPEED_OFF, UNSTEADY, order_track, series_prominences, sharpening,
                                      speed_off_words, speed_profile, steady_times, tachometer_profile)

CWRU_RATES_HZ = (12000.0, 48000.0)  # the rates the CWRU Bearing Data Center recorded at
MAX_RESAMPLE_DENOMINATOR = 1000
FEW_WINDOWS = 3
"""Fewer windows than this and a diagnosis says its verdict rests on them: below three, no majority outvotes one
misread window."""


@dataclass
class PreparedRecord:
    """A recording ready for a model: at the model's rate, with what was done to it."""

    recording: Recording
    true_state: str | None
    original_fs: float
    notes: list[str] = field(default_factory=list)
    bearing: dict = field(default_factory=dict)  # the bearing the physics evidence reads defect lines of
    rate_check: str = "not checked"  # the shaft line against speed and rate: consistent, ambiguous, contradicted
    unit_check: str = "not needed"  # the record's unit against the model's: one of UNIT_CHECKS
    speed: dict | None = None  # how steadily the shaft turned, and whether the record was order-tracked (steadied)
    gaps_s: list = field(default_factory=list)  # (start, end) s of samples the file holds none of (NaN), and their reach
    dropouts_s: list = field(default_factory=list)  # (start, end, words) of a window's length held at one value: dropouts
    bearing_given: bool = True  # whether bearing= or the file named the bearing, rather than the model's standing in
    clipped: bool = False  # the sensor or the converter saturated (Recording.quality_notes)
    declared_fs: float | None = None  # the rate the file, its name or its data set declared, where the check read another
    named_state: str | None = None  # the state the file's name gives, where a label given says another (scored by it)


CONDITION_KEYS = ("fault_size_in", "position", "load_hp", "severity")
"""What a data set's file name states of a record's condition (CWRU: defect size in inches, outer-race position in
o'clock, motor load in hp; HUST: the damage, ``medium`` or ``severe``, ``none`` for a healthy bearing), copied into
its diagnosis where known."""


HIGHEST_RECORDER_RATE_HZ = 204800.0
"""The highest rate common vibration recorders sample at: a rate a record's time stamps give above it is more likely
stamps in another unit than their column's name states."""

NOISE_FREE_SIMULATION = ("a record bearingtwin-simulate made without a noise effect: its floor is rounding error, so "
                         "every line stands out of it (a healthy bearing's ball-pass lines read as an outer-race "
                         "fault); simulate with effects=[noise] for a record like a measurement")
"""The note on a simulated record that states effects none of which is ``noise``."""

def read_record(path: str | Path, pipeline: DiagnosisPipeline, channel=None, fs=None, rpm=None,
                true_state: str | None = None, bearing: str | None = None, fs_key: str = "fs",
                rpm_key: str = "rpm", order_tracking: tuple[bool, float] = (True, UNSTEADY),
                unit: str | None = None, scale: float | None = None, unit_fills_in: bool = False,
                unit_key: str = "unit", scale_key: str = "scale") -> PreparedRecord:
    """Read one file, check it against the model and bring it to the model's sampling rate.

    ``channel`` (default: the format's, e.g. CWRU's drive end), ``fs``, ``rpm`` and ``unit`` fill in what the
    file does not state and must agree with what it does (``fs_key``, ``rpm_key``, ``unit_key`` and ``scale_key`` name
    where they came from in a message), ``unit`` naming the unit of the samples multiplied by ``scale`` where one is given
    (:func:`~bearingtwin.data.formats.scaled`); ``unit_fills_in`` (a folder's run, ``unit`` and ``scale`` given for
    every file): a file that states its own unit is read in it, said so, where one alone would be refused (a ``scale``
    still reads one in volts); ``bearing`` (a
    ``conf/bearing`` name) is the recorded bearing, the file's
    own (:func:`~bearingtwin.data.formats.file_bearing`: a CWRU or HUST file names it) or else the model's when
    not given. A measured record whose shaft speed varies is resampled to a steady one (:func:`steadied`;
    ``order_tracking``: whether to, and the spread of the speed above which), before its rate is checked against the
    shaft line (:func:`_checked_rate`).
    """
    raw = read_raw(path)
    channel, channel_note = _channel(raw, channel, pipeline)
    raw, gaps_by_channel = bridged(raw)
    own_unit = _own_unit(raw, channel) if unit_fills_in and unit is not None else ""
    # A folder's unit= is for the files that cannot say theirs, and its scale= for those too and those in volts (a
    # logger's counts, a sensor's V): one that states another unit keeps it (a file in g beside them is not
    # multiplied by the volts' scale).
    if own_unit and not (scale is not None and quantity_of(own_unit) == "a voltage"):
        if scale is not None or not same_unit(own_unit, str(unit)):
            given = f"unit={unit}" if scale is None else f"scale={scale} unit={unit}"
            channel_note.append(f"{given} given for the files that state none{'' if scale is None else ' or volts'}; "
                                f"this one states {own_unit}: read in it")
        unit, scale = None, None
    recording = recording_from_raw(raw, channel, fs=fs, rpm=rpm, fs_key=fs_key, rpm_key=rpm_key, unit=unit,
                                   unit_key=unit_key, scale=scale, scale_key=scale_key)
    recording.require_vibration()  # first: a flat record has no shaft line to check its rate by, nothing to diagnose
    gaps = file_gaps = gaps_by_channel.get(recording.channel, [])  # the file's positions, before tracking moves them
    quality = recording.quality_notes()
    notes = list(recording.meta["notes"]) + channel_note + quality
    named = file_bearing(recording.meta, recording.channel)
    if bearing is not None and named is not None and bearing != named:
        notes.append(f"bearing={bearing} given, where the file names {named}: read as {bearing}")
    if bearing is None and named is not None and named != (pipeline.bearing or {}).get("name"):  # the model carries its own
        refuse_unknown_bearing(named, recording.source)
    record_bearing, bearing_note = _record_bearing(bearing or named, pipeline)
    notes += bearing_note
    given_as = None if fs is None else fs_key  # the setting a rate was given as, None where the file's is read
    _refuse_a_rate_too_low(recording, record_bearing, pipeline, given_as)
    window_s = pipeline.window_length / pipeline.fs_hz
    # The file's held stretches, before order tracking or resampling smooths them: from a quarter of a window at the
    # rate read (the check may settle on one up to four times higher), those shorter than a window left below.
    as_read, held = recording, held_stretches(recording.signal, math.ceil(window_s * recording.fs / 4))
    recording, speed_notes, rate_check, speed, gaps, held_now = _speed_and_rate(
        recording, raw, record_bearing, gaps_by_channel, order_tracking, given_as, held)
    notes += speed_notes
    true_state, truth_notes, named_state = _true_state(path, raw, recording, true_state, pipeline)
    notes += truth_notes
    original_fs = recording.fs
    if file_gaps:  # in seconds at the rate the check settled on
        notes.append(gaps_note(recording, file_gaps))
    resampled = not math.isclose(recording.fs, pipeline.fs_hz, rel_tol=1e-9)
    # In seconds, now that the rate is settled; a resampling filter spreads a gap's edges over 10 input or output
    # samples, whichever are longer (resample_poly's filter: 10 x max(up, down) taps at the up-sampled rate).
    reach = 10.0 / min(recording.fs, pipeline.fs_hz) if resampled else 0.0
    gaps_s = [_in_seconds(start, length, recording.fs, reach) for start, length in gaps]
    dropouts_s = dropouts(as_read, window_s, reach, fs=recording.fs, held=held, held_now=held_now)
    if resampled:
        recording, note = resample_to(recording, pipeline.fs_hz)
        notes.append(note)
    recording, unit_notes, unit_check = in_model_unit(recording, pipeline)
    notes += unit_notes
    if recording.signal.size < pipeline.window_length:
        # Stamps in seconds under a header of milliseconds read a rate a thousand times too high, the record as
        # that much shorter: the rate is named where the stamps gave it, above any a vibration recorder samples at
        # (a record of a tenth of a second at 12 kHz is just short).
        stamped = (f"; read at {original_fs:.6g} Hz, the rate its time stamps give: if their values are in another unit "
                   "than the column's name states, give fs=<Hz>"
                   if recording.meta.get("fs_origin") == "time column" and original_fs > HIGHEST_RECORDER_RATE_HZ else "")
        raise BearingTwinError(
            f"{recording.source}: {recording.duration:.3f} s, shorter than one window of the model's "
            f"({pipeline.window_length} samples at {pipeline.fs_hz:g} Hz, {pipeline.window_length / pipeline.fs_hz:.3f} s)"
            f"{stamped}")
    if pipeline.needs_rpm and recording.rpm is None and recording.meta.get("no_speed"):
        raise BearingTwinError(f"{recording.source}: the file is {recording.meta['no_speed']}, and this model reads a "
                               "record at one shaft speed")
    if pipeline.needs_rpm and recording.rpm is None:
        unread = f" ({recording.meta['speed_unread']})" if recording.meta.get("speed_unread") else ""
        raise BearingTwinError(f"{recording.source}: the file does not state the shaft speed{unread} and this model "
                               "needs it; give rpm=<rev/min>, or the file's speed in the rpm column of a labels.csv "
                               "beside it")
    return PreparedRecord(recording, true_state, original_fs, notes, record_bearing, rate_check, unit_check, speed,
                          gaps_s, dropouts_s, bearing_given=(bearing or named) is not None,
                          clipped=any(note.endswith(CLIPPED_NOTE_END) for note in quality),
                          declared_fs=None if as_read.fs == original_fs else as_read.fs, named_state=named_state)


def _refuse_a_rate_too_low(recording: Recording, bearing: dict, pipeline: DiagnosisPipeline,
                           given_as: str | None) -> None:
    """Refuse a record whose rate cannot hold the recorded bearing's defect lines
    (:meth:`~bearingtwin.physics.geometry.BearingGeometry.rate_too_low`): resampled to the model's rate it would be
    diagnosed on nothing, and such a rate is most often one in kHz written as Hz (a logger's ``25.6``). At the record's
    speed, or at the slowest of the model's training windows' for a record without one (where a faster shaft puts
    the lines higher still); a record neither states nor the model knows a speed of is not checked."""
    rpm = recording.rpm or (pipeline.speeds_rpm[0] if pipeline.speeds_rpm else None)
    if not bearing or rpm is None:
        return
    geometry = BearingGeometry.from_config(bearing)
    why = geometry.rate_too_low(recording.fs, rpm)
    if why is None:
        return
    stated = f"{given_as}={recording.fs:g} Hz" if given_as else f"the rate the file states, {recording.fs:g} Hz,"
    speed = "" if recording.rpm else " (the slowest of the model's training windows': the record states no speed)"
    kilohertz = 1000 * recording.fs
    in_khz = (f"; if {recording.fs:g} kHz was meant, {'give' if given_as else 'the file must state'} {kilohertz:g} Hz"
              if geometry.rate_too_low(kilohertz, rpm) is None else "")
    raise BearingTwinError(f"{recording.source}: {stated} is too low to diagnose: {why}{speed}{in_khz}")


def _speed_and_rate(recording: Recording, raw: RawRecord, record_bearing: dict,
                    gaps_by_channel: dict[str, list[tuple[int, int]]], order_tracking: tuple[bool, float],
                    given_as: str | None, held: list[tuple[int, int]] = ()
                    ) -> tuple[Recording, list[str], str, dict | None, list[tuple[int, int]], list[tuple[int, int]]]:
    """A measured record steadied where its shaft speed varies (:func:`steadied`), its rate checked against the shaft
    line (:func:`_checked_rate`; ``given_as``: the setting a rate was given as, None where none was, so that one the
    file merely declares may be corrected): the record, the notes, the rate check's verdict, the speed as read (None
    where none was known or the record is the twin's) and the record's gaps (``(start, length)`` samples; each
    channel's in ``gaps_by_channel``, as :func:`bridged` found them) and its ``held`` stretches (``(start, length)``)
    where steadying moved them. The check reads no bridged gap (:func:`gaps_unread`). A record without a speed, or a
    simulation, is said to be read without the check."""
    gaps = gaps_by_channel.get(recording.channel, [])
    notes, rate_check, speed = [], "not checked", None
    if recording.rpm is None and recording.meta.get("no_speed"):
        notes.append(f"the file is {recording.meta['no_speed']}: no physics evidence and no rate check")
    elif recording.rpm is None:  # a HUST export under a name of one's own: why, where it says its speed
        why = (f" ({recording.meta['unread_name']}, which would give it)" if recording.meta.get("unread_name") else
               f" ({recording.meta['speed_unread']})" if recording.meta.get("speed_unread") else "")
        notes.append(f"the file states no shaft speed{why}: no physics evidence and no rate check (give rpm=<rev/min>, "
                     "or the file's speed in the rpm column of a labels.csv beside it)")
    elif recording.meta.get("fs_origin") == SIMULATED_RATE:
        notes.append(RATE_NOT_CHECKED_SIMULATED)
        if "noise" not in str(recording.meta.get("effects", "noise")).split(", "):  # as bearingtwin-simulate lists them
            notes.append(NOISE_FREE_SIMULATION)
        if recording.meta.get("simulation_notes"):  # a defect no loaded ball met: its stated state is not heard
            notes.append(f"the simulation noted: {recording.meta['simulation_notes']}")
    else:
        recording, speed_notes, speed, moved = steadied(recording, *order_tracking, gaps=[*gaps, *held],
                                                        tachometer=_tachometer(raw, recording))
        gaps, held = moved[:len(gaps)], moved[len(gaps):]
        notes += speed_notes
        # The file's other channels witness the rate as recorded, not as steadied: the steadied channel alone then. The
        # rate is checked against the stated speed: a tracked record's mean speed was read from the series the check
        # reads, and would confirm any rate near the right one.
        read_at, steady_rpm = recording.fs, recording.rpm
        witnesses = ({recording.channel: gaps_unread(recording.signal, gaps)} if speed["tracked"] else
                     {name: gaps_unread(values, gaps_by_channel.get(name, []))
                      for name, values in raw.vibration_channels.items()})
        recording, rate_notes, rate_check = _checked_rate(dataclasses.replace(recording, rpm=speed["stated_rpm"]),
                                                          record_bearing, channels=witnesses, given_as=given_as)
        recording = dataclasses.replace(recording, rpm=steady_rpm)
        notes += rate_notes
        if recording.fs != read_at:  # the check found the file's rate (a CWRU record at 48 kHz): its times are shorter
            speed.update(segment_s=speed["segment_s"] * read_at / recording.fs,
                         times_s=[time * read_at / recording.fs for time in speed["times_s"]])
        # At the rate it was read at, and not where the rate check refused that rate: the series read off it is then
        # no speed (a 25.6 kHz record declared at 12: the rate note's 840 rpm, beside a "give rpm=1687" the series said).
        off = (speed_off_note(speed, recording.rpm)
               if recording.fs == read_at and rate_check != "contradicted" else None)
        if off:
            speed["off"] = True
            notes.append(off)
    return recording, notes, rate_check, speed, gaps, list(held)


def _true_state(path, raw: RawRecord, recording: Recording, true_state: str | None,
                pipeline: DiagnosisPipeline) -> tuple[str | None, list[str], str | None]:
    """The state a record is scored against, the notes on it, and the state its name gives where a label given
    says another (None otherwise): the label given (``true_state``), which a file that states another refuses (a CWRU
    name may speak of another bearing: noted, and scored by the label), else what the file's name (CWRU) or content
    states; None where nothing states one."""
    notes, against = [], None
    name = parse_cwru_name(path) if raw.format == "cwru-mat" or raw.meta.get("fault_from_name") else None
    if true_state is None:  # what the file's name (CWRU) or content states
        true_state = name.fault if name is not None else recording.fault
        if recording.meta.get("unlabelled_state"):
            notes.append(f"the file states {recording.meta['unlabelled_state']}, a state this model cannot answer "
                         f"(trained on {', '.join(pipeline.class_names)}): not scored")
    else:
        true_state = check_fault(true_state)
        refuse_a_label_the_file_contradicts(raw, true_state, "the label")
        if name is not None and name.fault != true_state:  # a CWRU name speaks of one bearing, a label maybe of another
            notes.append(f"labelled {true_state} where the file name says {name.fault}: scored as {true_state}")
            against = name.fault
        elif recording.fault not in (None, true_state):
            raise BearingTwinError(f"{recording.source}: labelled {true_state}, but the file states fault={recording.fault}")
    if true_state is not None and true_state not in pipeline.class_names:  # the verdict can only be wrong
        notes.append(f"true state {true_state}, which this model cannot answer: it was trained on "
                     f"{', '.join(pipeline.class_names)} only")
    return true_state, notes, against


def bridged(raw: RawRecord) -> tuple[RawRecord, dict[str, list[tuple[int, int]]]]:
    """``raw`` with each channel's NaN or infinite samples (a logger's lost packets, a CSV's empty cells) bridged by
    straight lines between their finite neighbours, and where they were, ``(start, length)`` per channel. The bridge
    serves the readings of the whole record (its rate, its speed, the physics evidence), which a short gap barely
    moves; no window touching a gap is diagnosed (:func:`diagnose_recording`): no value is made up for the model. A
    channel holding no finite sample is left as it is, and refused as such."""
    channels, gaps = {}, {}
    for name, values in raw.channels.items():
        values = np.asarray(values)
        bad = ~np.isfinite(values) if np.issubdtype(values.dtype, np.inexact) else np.zeros(values.shape, dtype=bool)
        if values.ndim != 1 or not bad.any() or np.count_nonzero(~bad) < 2:  # nothing to bridge from: refused
            channels[name] = values
            continue
        index = np.arange(values.size)
        filled = values.astype(np.float64, copy=True)
        filled[bad] = np.interp(index[bad], index[~bad], values[~bad])
        # At either end np.interp would hold the last value, a stretch read as a dropout: the record's own samples
        # beside the gap, mirrored, stand there instead.
        first, last = np.flatnonzero(~bad)[[0, -1]]
        if first:  # sample first - 1 - j takes sample first + 1 + j's value
            filled[:first] = np.resize(filled[first + 1:2 * first + 1], first)[::-1]
        tail = values.size - 1 - last
        if tail:  # sample last + 1 + j takes sample last - 1 - j's value
            filled[last + 1:] = np.resize(filled[max(last - tail, 0):last][::-1], tail)
        channels[name] = filled
        starts, lengths = true_runs(bad)
        gaps[name] = list(zip(starts.tolist(), lengths.tolist()))
    return dataclasses.replace(raw, channels=channels), gaps


def gaps_unread(values: np.ndarray, gaps: list[tuple[int, int]]) -> np.ndarray:
    """``values`` with its ``gaps`` (``(start, length)`` samples, :func:`bridged`'s) NaN again, for the sampling-rate
    check, which reads a channel's longest stretch of finite samples: a bridge's click buries a shaft's lines
    (:func:`~bearingtwin.signal.sampling_rate.longest_finite_stretch`); ``values`` itself where it has none."""
    if not gaps:
        return values
    marked = np.asarray(values, dtype=np.float64).copy()
    for start, length in gaps:
        marked[max(start, 0):start + length] = np.nan
    return marked


def _tachometer(raw: RawRecord, recording: Recording) -> tuple[str, np.ndarray] | None:
    """The file's first two-level channel as long as the record (a tachometer's pulses), its name and samples; None
    where the file holds none, or the record is that channel."""
    name = tachometer_channel(raw, recording.channel)
    return None if name is None else (name, np.asarray(raw.channels[name], dtype=np.float64))


def gaps_note(recording: Recording, gaps: list[tuple[int, int]]) -> str:
    """"120 samples hold no value (NaN or infinite) in 3 stretches from 1 s to 4.01 s: bridged for the readings of the
    whole record (the sampling rate checked on the longest stretch without one), no window touching one diagnosed"."""
    missing = sum(length for _, length in gaps)
    if len(gaps) > 1:
        where = (f"in {len(gaps)} stretches from {gaps[0][0] / recording.fs:.4g} s to "
                 f"{(gaps[-1][0] + gaps[-1][1]) / recording.fs:.4g} s")
    else:
        where = f"in one stretch at {gaps[0][0] / recording.fs:.4g} s"
    return (f"{missing} sample{'s' * (missing > 1)} hold{'s' * (missing == 1)} no value (NaN or infinite) {where}: "
            "bridged for the readings of the whole record (the sampling rate checked on the longest stretch without "
            "one), no window touching one diagnosed")


def speed_off_note(speed: dict, rpm: float) -> str | None:
    """A note where the shaft's harmonic series or a tachometer, read segment by segment (:func:`steadied`), puts the
    speed more than 1 % and at most 8 % from the stated ``rpm`` (:func:`~bearingtwin.signal.speed.speed_off_words`: a
    nameplate's speed given for a measured one); None where it does not or cannot be read."""
    read = speed.get("read_rpm")  # not where the reading is in doubt (a misread profile), nor tracked (read at it)
    if read is None or speed.get("tracked") or speed.get("in_doubt"):
        return None
    return speed_off_words(read, rpm, speed["source"])


TRACKING_REACH = 12
"""How many samples either side of a gap order tracking spreads it over (its doubling filter's ten, its spline's)."""
SHARPER = 1.25
"""How much higher (:func:`~bearingtwin.signal.speed.sharpening`) a record's shaft series must stand once tracked for
the tracked record to be read."""
TRACKING_PASSES = 2
"""How often a record is tracked at most: a strong drift smears the first profile's lines, which read the speed less
finely than a second look at the record tracked once does."""


def steadied(recording: Recording, track: bool, unsteady: float, gaps: list[tuple[int, int]] = (),
             tachometer: tuple[str, np.ndarray] | None = None) -> tuple[Recording, list[str], dict, list[tuple[int, int]]]:
    """The recording, resampled at equal steps of shaft angle where its speed varies by more than ``unsteady``
    (:func:`~bearingtwin.signal.speed.speed_profile`, :func:`~bearingtwin.signal.speed.order_track`; up to
    :data:`TRACKING_PASSES` times) and ``track``; a note where it varies; and ``diagnosis.json``'s ``speed``: the
    spread read (null where the shaft series did not show in enough of the record to read it), whether the record
    was tracked (its ``steady_rpm`` and the ``spread_after`` it), whether the speed leaves the verdict in doubt (left
    unsteady), and the speed read segment by segment (null where not read); and ``gaps`` (``(start, length)``,
    samples) where they lie in the record returned. A ``tachometer`` channel (its name and pulses) recorded beside the
    record gives the speed where its pulses read one (:func:`~bearingtwin.signal.speed.tachometer_profile`), the shaft's
    series otherwise."""
    profile = None
    if tachometer is not None:
        name, pulses = tachometer
        profile = tachometer_profile(pulses, recording.fs, recording.rpm, source=f"the tachometer channel {name}")
    if profile is None or not profile.readable:
        profile = speed_profile(recording.signal, recording.fs, recording.rpm)
    speed = {"spread": None if math.isnan(profile.spread) else profile.spread, "tracked": False, "in_doubt": False,
             "segment_s": profile.segment_s, "times_s": profile.times_s.tolist(),
             "rpm": [None if math.isnan(value) else value for value in profile.rpm.tolist()],
             "read_rpm": profile.read_rpm, "source": profile.source or "the shaft's harmonic series",
             "stated_rpm": recording.rpm}
    gaps = list(gaps)
    if not profile.unsteady(unsteady):
        return recording, [], speed, gaps
    varies = f"the shaft speed varies {profile.describe()}"
    if not track:
        speed["in_doubt"] = True
        return recording, [f"{varies}: read as recorded (order_tracking.enabled=false), every defect line smeared "
                           "over the speeds it passed through; the verdict is in doubt"], speed, gaps
    signal, again, moved = recording.signal, profile, gaps
    for _ in range(TRACKING_PASSES):
        steady, _ = steady_times(again, signal.size, recording.fs)  # where each gap lies once tracked, in samples
        # Widened by the reach of order_track's own resampling filter and spline (about 10 samples each side).
        first_last = [(math.floor(steady[start] * recording.fs) - TRACKING_REACH,
                       math.ceil(steady[start + length - 1] * recording.fs) + TRACKING_REACH) for start, length in moved]
        last_sample = int(round(steady[-1] * recording.fs))  # the tracked record's last sample
        moved = [(max(first, 0), min(last, last_sample) - max(first, 0) + 1) for first, last in first_last]
        signal, steady_rpm = order_track(signal, recording.fs, again)
        again = speed_profile(signal, recording.fs, recording.rpm)
        if not again.unsteady(unsteady):
            break
    # Tracked to the speed the shaft turned at, its own series stands sharper than as recorded; tracked to a profile
    # misread (two shafts' series, segments reading the supply, a swing faster than the segments resolve), it does
    # not, and the record is read as recorded: a steady record warped would smear every line.
    gain = sharpening(series_prominences(recording.signal, recording.fs, speed["read_rpm"] or recording.rpm),
                      series_prominences(signal, recording.fs, steady_rpm))
    speed["sharpening"] = None if math.isnan(gain) else gain
    # A tachometer measures the speed itself: its profile is refused only where it smears a shaft series that stood
    # (another shaft's tachometer), while a profile read from the series must make it stand sharper.
    if not (gain >= SHARPER or (profile.source and not gain * SHARPER < 1)):
        speed.update(in_doubt=True, steadying_refused=True)
        why = ("the tachometer's shaft is another than the one whose series the record shows" if profile.source else
               "two shafts' series, a supply's lines or a swing faster than the segments resolve, not one speed")
        return recording, [f"{varies}, but the record steadied to it shows the shaft's series no sharper ("
                           f"{gain:.2g} times its prominence as recorded): {why}; read as recorded, the "
                           "verdict is in doubt"], speed, gaps
    speed.update(tracked=True, spread_after=None if math.isnan(again.spread) else again.spread, steady_rpm=steady_rpm,
                 in_doubt=again.unsteady(unsteady))
    stated = (f" (the stated {recording.rpm:g} rpm lies {100 * (recording.rpm / steady_rpm - 1):+.1f} % from it)"
              if abs(recording.rpm / steady_rpm - 1) > SPEED_OFF[0] else "")
    note = (f"{varies}: resampled at equal steps of shaft angle to a steady {steady_rpm:.0f} rpm, its mean (computed "
            f"order tracking), and read at that speed{stated}, so its defect lines stand still where they are sought")
    if again.unsteady(unsteady):
        note += f"; tracked, it still varies {again.describe()}: the verdict is in doubt"
    return dataclasses.replace(recording, signal=signal, rpm=steady_rpm), [note], speed, moved


def _own_unit(raw: RawRecord, channel) -> str:
    """The unit the file states for the channel read (``channel``, else its own choice); "" where it states none, or
    the channel cannot be read (said by the reading itself)."""
    try:
        name, _ = raw.channel(channel)
    except BearingTwinError:
        return ""
    return resolve_unit(raw, name, None)


def _channel(raw, channel, pipeline: DiagnosisPipeline) -> tuple[str | int | None, list[str]]:
    """The channel to read: the one asked for, else the file's own default, else, in a file of several, the channel
    the model was trained on when the file has one of that name (a HUST export's X axis), said in a note. A CWRU
    fault record's default is the accelerometer on its faulty bearing: where it lacks that one, no other stands in."""
    trained = (pipeline.config.get("data") or {}).get("channel")
    if channel is not None or raw.default_channel in raw.channels or len(raw.channels) == 1 \
            or (raw.format == "cwru-mat" and raw.meta.get("bearing")) \
            or not isinstance(trained, str) or trained not in raw.channels:
        return channel, []
    return trained, [f"channel {trained}, the one the model was trained on (channel=<name> reads another)"]


def _record_bearing(named: str | None, pipeline: DiagnosisPipeline) -> tuple[dict, list[str]]:
    """The recorded bearing's config (``named``, else the model's) and a note when it is not the model's.

    The physics evidence reads that bearing's defect lines, and so do the model's features where they
    are read at defect orders (:meth:`DiagnosisPipeline.features`, :func:`diagnose_recording`): an
    outer-race line means the same on any bearing, only its order differs.
    """
    model_bearing = pipeline.bearing or {}
    if named is None or model_bearing.get("name") == named:
        return model_bearing, []
    from bearingtwin.config import bearing_config

    bearing = bearing_config(named)
    if not model_bearing:
        return bearing, []
    words = ", ".join(f"{name} {BearingGeometry.from_config(config).describe_orders()}"
                      for name, config in ((named, bearing), (model_bearing.get("name", "the model's"), model_bearing)))
    return bearing, [f"the record's bearing is {named}, the model was trained on {model_bearing.get('name', 'another')} "
                     f"({words}): the physics evidence reads {named}'s defect lines"]


@shared_transforms()  # every rate tried reads the same channels
def _checked_rate(recording: Recording, bearing: dict, channels: dict[str, np.ndarray],
                  given_as: str | None = None) -> tuple[Recording, list[str], str]:
    """The recording after the sampling-rate check (shaft series, and the bearing's defect lines as a
    second witness), what the check said, and its verdict (:attr:`PreparedRecord.rate_check`). Every vibration
    channel of the file is a witness (:func:`check_channels`): a fan-end accelerometer may show the shaft series too
    weakly, the drive end's beside it does not.

    A rate the file states is kept (a doubt is reported). A rate only declared by the data set's
    convention (a CWRU file's) is tried against the data set's rates, and the highest rate under which
    the shaft's harmonic series stands where it belongs is the record's: read at a whole-number fraction of its
    true rate, a record puts a higher shaft harmonic onto the expected line, so a lower rate can seem
    to fit, a higher one cannot (the CWRU healthy baselines exist at 48 kHz); a lower one is the record's only where
    the declared rate is contradicted. A rate and speed the shaft line contradicts, with no other rate of the data set
    consistent, are kept, and the note says that one
    of the two is wrong (the line cannot tell which): a speed variable a tachometer got wrong must not cost
    the record its diagnosis, only its certainty. A rate given (as the setting ``given_as``) that the shaft line
    contradicts where it confirms the rate the data set's naming gives the file (a CWRU ``12k_`` name, its
    catalogue's number) is refused: two witnesses against one typed number.
    """
    defect_hz = BearingGeometry.from_config(bearing).defect_frequencies(recording.rpm) if bearing else None

    witnesses = rate_witnesses(recording.signal, channels)

    def check(rate: float):
        at_rate = check_channels(witnesses, rate, recording.rpm, defect_hz=defect_hz)
        return at_rate[decisive_channel(at_rate)]

    try:
        declared = check(recording.fs)
    except BearingTwinError as error:  # too short to resolve the shaft line: say so, do not refuse
        return recording, [f"sampling rate not checked ({error})"], "not checked"
    higher = speeds_lines_alone_hide(declared, recording.signal, defect_hz, channels)
    if higher:  # the speed's own place holds no shaft series; the cage's or a defect's lines, read at harmonics, do
        doubt = [f"the speed contradicts the record: at {recording.rpm:g} rpm the shaft line belongs at "
                 f"{declared.expected_hz:.2f} Hz, but {series_elsewhere_words(declared, higher, 'the stated')}: "
                 "check the speed given. Every defect line is read where the stated values put it: the verdict is in doubt"]
        return recording, doubt, "contradicted"
    if declared.verdict == "contradicted":
        doubt = [_speed_or_rate_wrong(declared, recording.meta.get("fs_origin"))]
    elif declared.verdict == "ambiguous":
        doubt = [f"sampling rate unconfirmed: {describe_mismatch(declared)}"]
    else:
        doubt = []
    against_name = named_rate_note(recording.meta, recording.fs, given_as) if given_as else None
    named_hz = (recording.meta.get("named_rate") or {}).get("hz")
    if against_name and declared.verdict == "contradicted" and series_stands_at(recording.signal, named_hz,
                                                                                recording.rpm, defect_hz, channels):
        raise rate_against_name_error(recording.source, against_name, named_hz, recording.fs)
    if given_as or recording.meta.get("fs_origin") != "declared":  # a rate given, or one the file itself states
        return recording, doubt, declared.verdict
    # The series standing where it belongs is what a lower rate can fake and a higher one cannot; in-between
    # lines (a machine's half orders) may leave the higher rate's verdict ambiguous, never contradicted. A lower
    # rate is tried only where the declared one is contradicted (a 48 kHz name on 12 kHz samples): nothing
    # higher then stands where it belongs for it to fake.
    contradicted = declared.verdict == "contradicted"
    others = [rate for rate in CWRU_RATES_HZ
              if (rate > recording.fs or contradicted and rate < recording.fs)
              and series_stands_at(recording.signal, rate, recording.rpm, defect_hz, channels)]
    if not others:
        return recording, doubt, declared.verdict
    rate = max(others)
    at_declared = "not at" if contradicted else "not only at"
    note = (f"the shaft line stands where it belongs at {rate:g} Hz, {at_declared} the declared {recording.fs:g} Hz: "
            f"read at {rate:g} Hz")
    return dataclasses.replace(recording, fs=rate), [note], check(rate).verdict


RATE_THE_FILE_STATES = {"header": "the file states", "time column": "the file's time stamps give",
                        "file": "the file states"}
"""Where a file's own rate comes from (``fs_origin``), in words: a rate so stated is no suspect when a speed contradicts it."""


def _speed_or_rate_wrong(check, fs_origin: str | None = None) -> str:
    """The note on a stated speed and rate the shaft line contradicts: the line fixes only their ratio, so it names
    what either would be if the other is right; where the file states its rate itself (``fs_origin``), the speed
    is the first suspect, and the series the check found near the speed's line is no reading of the true speed;
    a rate the file states but did not measure (a header's, a stored number, not time stamps) is named too."""
    if fs_origin in RATE_THE_FILE_STATES and check.matches:  # the series stands where the speed puts it
        return (f"the speed contradicts the record: at {check.rpm:g} rpm the shaft series stands where it belongs "
                f"({check.expected_hz:.2f} Hz) at the rate {RATE_THE_FILE_STATES[fs_origin]} ({check.fs_hz:g} Hz), but "
                f"{check.reason}: check the speed given. Every defect line is read where the stated values put it: "
                "the verdict is in doubt")
    if fs_origin in RATE_THE_FILE_STATES:
        nearest = (f"; the nearest strong harmonic series, at {check.observed_hz:.2f} Hz, would put it at "
                   f"{60 * check.observed_hz:.0f} rpm if it is the shaft's" if check.observed_hz else "")
        # Time stamps are measured; a rate written in a header or beside the samples was typed, and may be wrong.
        typed = (f"; or the rate {RATE_THE_FILE_STATES[fs_origin]} is wrong: at {check.rpm:g} rpm that series puts "
                 f"it at {check.implied_fs_hz:.0f} Hz" if fs_origin != "time column" and check.implied_fs_hz else "")
        return (f"the speed contradicts the record: at {check.rpm:g} rpm the shaft line belongs at "
                f"{check.expected_hz:.2f} Hz, and the shaft's series does not stand where that puts it at the rate "
                f"{RATE_THE_FILE_STATES[fs_origin]} ({check.fs_hz:g} Hz): check the speed given{nearest}{typed}. "
                "Every defect line is read where the stated values put it: the verdict is in doubt")
    words = f"speed and rate disagree: {describe_mismatch(check)}"
    if check.defect_reading and check.implied_fs_hz:  # the series may be a defect's: its 1x line's speed comes first
        name, shaft_hz = check.defect_reading
        words += (f"; at fs = {check.fs_hz:g} Hz the line near {shaft_hz:.1f} Hz says {60 * shaft_hz:.0f} rpm if the "
                  f"series is {name}'s, {check.rpm * check.fs_hz / check.implied_fs_hz:.0f} rpm if it is the shaft's")
    elif check.implied_fs_hz:  # the rate it implies at the stated speed is in describe_mismatch's words already
        implied_rpm = check.rpm * check.fs_hz / check.implied_fs_hz
        words += f"; at fs = {check.fs_hz:g} Hz the shaft line says {implied_rpm:.0f} rpm"
    return words + ". Every defect line is read where the stated values put it: the verdict is in doubt"


def in_model_unit(recording: Recording, pipeline: DiagnosisPipeline) -> tuple[Recording, list[str], str]:
    """The recording in the unit the model was trained in, what was done (notes) and how the units were held
    against each other (:data:`UNIT_CHECKS`; :func:`unit_for_model`)."""
    factor, notes, check = unit_for_model(recording.unit, pipeline, recording.source)
    if factor is None:
        return recording, notes, check
    signal = np.asarray(recording.signal, dtype=np.float64) * factor  # the factor between the two units' names
    converted = dataclasses.replace(recording, signal=signal, unit=acceleration_unit(pipeline.unit))
    return converted, notes, check


def resample_to(recording: Recording, target_fs: float) -> tuple[Recording, str]:
    """The recording at ``target_fs`` by polyphase resampling (``scipy.signal.resample_poly``), and a note."""
    ratio = Fraction(target_fs / recording.fs).limit_denominator(MAX_RESAMPLE_DENOMINATOR)
    if ratio == 0 or abs(float(ratio) * recording.fs - target_fs) > 1e-6 * target_fs:
        stamped = (f"; {recording.fs:g} Hz is the rate its time stamps give: if their values are in another unit than "
                   "the column's name states, give fs=<Hz>" if recording.meta.get("fs_origin") == "time column" else "")
        raise BearingTwinError(f"{recording.source}: cannot resample {recording.fs:g} Hz to the model's "
                               f"{target_fs:g} Hz by a ratio of small integers{stamped}")
    signal = scipy.signal.resample_poly(recording.signal, ratio.numerator, ratio.denominator)
    note = f"resampled {recording.fs:g} Hz -> {target_fs:g} Hz (resample_poly, up {ratio.numerator}, down {ratio.denominator})"
    if target_fs > recording.fs:  # the model's features span a band the record never held
        note += (f"; the record holds nothing between its Nyquist frequency, {recording.fs / 2:g} Hz, and the "
                 f"model's, {target_fs / 2:g} Hz")
    return dataclasses.replace(recording, signal=signal, fs=target_fs), note


def _windows_at(signal: np.ndarray, starts: np.ndarray, window_length: int) -> tuple[np.ndarray, np.ndarray]:
    """The windows of ``window_length`` samples beginning at ``starts``, and ``starts``."""
    return signal[starts[:, None] + np.arange(window_length)], starts


def dropouts(recording: Recording, window_s: float, reach_s: float = 0.0, fs: float | None = None,
             held: list[tuple[int, int]] | None = None,
             held_now: list[tuple[int, int]] | None = None) -> list[tuple[float, float, str]]:
    """The stretches of ``recording`` (as the file holds it) held at one value for ``window_s`` (a model's window) or
    longer at ``fs`` (the rate the record is read at; its own by default), each as its start and end in seconds of the
    record diagnosed, widened by ``reach_s`` either side (a resampling filter's spread of their edges), and in words
    (:meth:`~bearingtwin.data.recording.Recording.held_at`, in the file's samples). ``held``: its held stretches
    (:func:`~bearingtwin.data.recording.held_stretches`; found here where None), ``held_now``: where each lies in the
    record diagnosed once order tracking has moved them (:func:`steadied`; where they were by default). Found as
    the file holds them: steadied or resampled to a model's rate, a held stretch holds one value no longer. A window
    inside one reads no vibration (it has no features: a constant window cannot even be normalized), one reaching
    into it a step into none: such windows are left out (:func:`diagnosed_windows`), and a shorter stretch only
    noted (:meth:`~bearingtwin.data.recording.Recording.quality_notes`)."""
    fs = recording.fs if fs is None else fs
    shortest = math.ceil(window_s * fs - 1e-9)
    held = held_stretches(recording.signal, shortest) if held is None else held
    in_file = recording if fs == recording.fs else dataclasses.replace(recording, fs=fs)
    return [(*_in_seconds(*now, fs, reach_s), in_file.held_at(*stretch))
            for stretch, now in zip(held, held if held_now is None else held_now) if stretch[1] >= shortest]


def _in_seconds(start: int, length: int, fs: float, reach_s: float = 0.0) -> tuple[float, float]:
    """A stretch of ``length`` samples from ``start`` as its start and end in seconds at ``fs``, widened by ``reach_s``
    either side (:func:`_in_samples` turns it back)."""
    return start / fs - reach_s, (start + length) / fs + reach_s


def _in_samples(start_s: float, end_s: float, fs: float) -> tuple[int, int]:
    """A stretch from ``start_s`` to ``end_s`` as ``(first sample, length)`` at ``fs``, every sample it reaches; a
    stretch given in samples and turned into seconds comes back as it was (3072 / 10000 * 10000 is 3071.9999...)."""
    first = math.floor(start_s * fs + 1e-6)
    return first, math.ceil(end_s * fs - 1e-6) - first


def _longest_stretch_between(n_samples: int, stretches: list[tuple[int, int]]) -> tuple[int, int]:
    """The longest run of samples of a record of ``n_samples`` outside every one of ``stretches`` (``(start,
    length)``), as ``(start, length)``."""
    free = np.ones(n_samples, dtype=bool)
    for start, length in stretches:
        free[max(start, 0):max(start + length, 0)] = False
    return longest_run(free)


def _touching(starts: np.ndarray, window_length: int, start: int, length: int) -> np.ndarray:
    """Which windows (by their first samples) share a sample with the stretch from ``start`` for ``length``."""
    return (starts < start + length) & (starts + window_length > start)


def _spans(starts: np.ndarray, window_length: int, fs: float) -> str:
    """Windows beginning at ``starts`` (samples, in order), those in a row joined: "from 0.4096 s to 0.6144 s and from
    2.458 s to 2.867 s"."""
    runs = np.split(starts, np.flatnonzero(np.diff(starts) > window_length) + 1)
    return " and ".join(f"from {run[0] / fs:.4g} s to {(run[-1] + window_length) / fs:.4g} s" for run in runs)


def diagnosed_windows(prepared: PreparedRecord, window_length: int) -> tuple[np.ndarray, np.ndarray, list[str], int]:
    """The windows of ``window_length`` samples a diagnosis reads of ``prepared``'s record, their first samples, the
    record's notes with which windows were left out, and how many: non-overlapping windows over the whole record (a
    remainder shorter than a window left out), but for those touching a dropout (``prepared.dropouts_s``,
    :func:`dropouts`) or samples with no value (bridged by :func:`read_record`, so never read by the model), each named
    with the span of its windows. A record every window of which touches one is refused."""
    recording = prepared.recording
    notes = list(prepared.notes)
    starts = np.arange(0, recording.signal.size - window_length + 1, window_length)
    held = [(_in_samples(start_s, end_s, recording.fs), words) for start_s, end_s, words in prepared.dropouts_s]
    gaps = [_in_samples(start_s, end_s, recording.fs) for start_s, end_s in prepared.gaps_s]
    by_dropout = [_touching(starts, window_length, *stretch) for stretch, _ in held]
    touched, gapped = np.zeros(starts.size, dtype=bool), np.zeros(starts.size, dtype=bool)
    for over in by_dropout:
        touched |= over
    for gap in gaps:
        gapped |= _touching(starts, window_length, *gap)
    if held and touched.all():
        raise BearingTwinError(f"{recording.source}: {'; '.join(words for _, words in held)}, and every window of the "
                               f"model's ({window_length} samples) touches one, so none reads a vibration; cut them "
                               "out of the record or choose another stretch")
    if (touched | gapped).all():
        start, length = _longest_stretch_between(recording.signal.size, [stretch for stretch, _ in held] + gaps)
        where = (f"the longest stretch between them, {length} samples from {start / recording.fs:.4g} s, holds one: "
                 "give each such stretch as a file of its own" if length >= window_length else
                 f"no stretch between them holds one (the longest: {length} samples)")
        raise BearingTwinError(f"{recording.source}: every window of the model's ({window_length} samples) "
                               f"touches a stretch with no value (NaN) or a dropout, so none can be read; {where}")
    kept = f"the verdict is the other {int((~(touched | gapped)).sum())} of {starts.size} windows'"
    if held:  # the stretches are among those the record's notes name, with what was done about them: not said twice
        parts = [f"{words}: the {int(over.sum())} window{'s' * int(over.sum() > 1)} touching it, "
                 f"{_spans(starts[over], window_length, recording.fs)}, left out" for (_, words), over in zip(held, by_dropout)]
        said = "; ".join(parts) + ("" if gapped.any() else f"; {kept}")  # the count once, after the gaps' where they are
        notes = [note for note in notes if not note.endswith(HELD_NOTE_END)] + [said]
    if gapped.any():
        over = starts[gapped]
        notes.append(f"the {over.size} window{'s' * (over.size > 1)} touching samples with no value, "
                     f"{_spans(over, window_length, recording.fs)}, left out; {kept}")
    touched = touched | gapped
    windows, starts = _windows_at(recording.signal, starts[~touched], window_length)
    return windows, starts, notes, int(touched.sum())


def diagnose_recording(prepared: PreparedRecord, model, pipeline: DiagnosisPipeline, model_uri: str,
                       evidence_settings: dict, model_version_uri: str | None = None) -> tuple[dict, PhysicsEvidence | None]:
    """The ``diagnosis.json`` content of one record, and the physics evidence behind it; ``model_version_uri``: the
    model's URI with a registry alias replaced by the version it named (``model_uri`` where there was none)."""
    recording = prepared.recording
    windows, starts, notes, left_out = diagnosed_windows(prepared, pipeline.window_length)
    params = {"rpm": float(recording.rpm or 0.0)}
    level = pipeline.level_note(windows)
    if level:
        notes.append(level)
    speed_unseen = pipeline.speed_note(recording.rpm)
    if speed_unseen:
        notes.append(speed_unseen)
    if len(windows) < FEW_WINDOWS:  # a majority of one or two windows: one misread window decides it
        notes.append(f"the verdict rests on {len(windows)} window{'s' * (len(windows) > 1)} of the model's "
                     f"{pipeline.window_length} samples ({pipeline.window_length / recording.fs:.3g} s): a longer "
                     "record gives a surer one")
    if prepared.bearing and prepared.bearing != pipeline.bearing:
        if not pipeline.needs_rpm:
            notes.append("the model's features do not depend on the bearing")
        elif "bearing" in model_params(model):
            params["bearing"] = prepared.bearing["name"]
            reader = "the model's features" if pipeline.reads_defect_orders else "the physics that may decide a window"
            notes.append(f"{reader} read {prepared.bearing['name']}'s defect lines too")
            on_shaft = pipeline.bands_on_shaft_harmonics(prepared.bearing)
            if on_shaft:
                notes.append(f"on {prepared.bearing['name']} the bands of {', '.join(on_shaft)} hold whole shaft orders, "
                             "where on the model's own bearing they do not: the model may take the shaft's lines for "
                             "those defects' (hold its verdict against the physics evidence, which reads them apart "
                             "at 1 Hz where it can)")
        else:
            notes.append("the model's features read its own bearing's defect lines: it was logged before models took "
                         "the recorded bearing; train it again to read the record's")
    frame = model.predict(windows, params=params)
    names = pipeline.class_names
    states = frame[STATE_COLUMN].to_numpy()
    probabilities = frame[names].to_numpy()
    deciders = frame[DECIDED_BY_COLUMN].to_numpy() if DECIDED_BY_COLUMN in frame else None
    verdict, counts = majority(states, probabilities, names, deciders)
    # What the classifier said of the windows left to it, where the envelope spectrum decided some (physics_first):
    # the verdict above may be the physics' more than the model's. None where the physics decided every window.
    left = np.ones(len(states), dtype=bool) if deciders is None else deciders != "physics"
    classifier_verdict = majority(states[left], probabilities[left], names)[0] if left.any() else None
    if deciders is not None:
        notes.append(physics_first_note(pipeline, deciders))
    unseen = frame[FEATURE_UNSEEN_COLUMN].to_numpy() if FEATURE_UNSEEN_COLUMN in frame else None
    extrapolated = None if unseen is None else left & (unseen != "")
    if extrapolated is not None and extrapolated.any():
        notes.append(extrapolation_note(unseen[extrapolated], int(left.sum())))
    evidence = None
    if recording.rpm is not None and prepared.bearing:
        evidence = physics_evidence(recording.signal, recording.fs, recording.rpm, prepared.bearing, **evidence_settings)
        notes += [f"the physics cannot read {state} on {prepared.bearing.get('name', 'this bearing')}: {why}"
                  for state, why in evidence.unreadable.items()]
    result = {
        "record": Path(str(recording.source)).stem,
        "model_uri": model_uri,
        "model_version_uri": model_version_uri or model_uri,
        "fs": recording.fs,
        "rpm": recording.rpm,
        "verdict": verdict,
        "share": counts[verdict] / len(states),
        "window_states": counts,  # how many windows each state won: a record that changed state shows two
        "classifier_verdict": classifier_verdict,
        "physics_decided": float(np.mean(~left)),
        "mean_probability": float(probabilities[:, names.index(verdict)].mean()),
        "windows": [
            {"start_s": float(start / recording.fs), "state": str(state),
             "probabilities": {name: float(p) for name, p in zip(names, row)},
             **({} if deciders is None else {"decided_by": str(deciders[index])}),
             **({} if unseen is None or not unseen[index] else {"feature_unseen": str(unseen[index])})}
            for index, (start, state, row) in enumerate(zip(starts, states, probabilities))
        ],
        "evidence": None if evidence is None else evidence.as_dict(),
        "evidence_state": None if evidence is None else evidence.evidence_state,
        "agree": None if evidence is None or evidence.evidence_state is None else bool(evidence.evidence_state == verdict),
        "source": str(recording.source),
        "channel": recording.channel,
        "bearing": prepared.bearing.get("name"),  # whose defect lines the physics (and defect-order features) read
        "bearing_given": prepared.bearing_given,  # named by bearing= or the file, not the model's standing in
        "original_fs": prepared.original_fs,
        "declared_fs": prepared.declared_fs,  # where the rate check read the record at another rate than declared
        "named_state": prepared.named_state,  # the file name's state, where the label scored by says another
        "rate_check": prepared.rate_check,
        "speed": prepared.speed,
        "unit": recording.unit or None,  # of the samples read (the model's, where they were converted to it)
        "scale": recording.meta.get("scale"),  # what the file's samples were multiplied by (scale=, a labels row's)
        "unit_check": prepared.unit_check,
        "level_unseen": level is not None,
        "clipped": prepared.clipped,
        "speed_unseen": speed_unseen is not None,
        "speed_varies": bool(recording.meta.get("no_speed")),  # a file stating a variable-speed run (HUST's VS_...)
        "features_unseen": None if extrapolated is None else float(np.mean(extrapolated)),
        "windows_left_out": left_out,  # touching a dropout as long as a window or a gap with no value
        "notes": notes,
    }
    for key in CONDITION_KEYS:  # what the file's name says of the record's condition, to score by it
        if recording.meta.get(key) is not None:
            result[key] = recording.meta[key]
    if prepared.true_state is not None:
        result["true_state"] = prepared.true_state
        result["correct"] = bool(verdict == prepared.true_state)
        result["windows_correct"] = int(np.sum(states == prepared.true_state))
        # The classifier's own answer on every window, where the envelope spectrum decided some (physics_first) too.
        result["classifier_windows_correct"] = int(np.sum(np.asarray(names)[probabilities.argmax(axis=1)]
                                                          == prepared.true_state))
        if evidence is not None and evidence.evidence_state is not None:  # an answer the physics gave
            result["physics_correct"] = bool(evidence.evidence_state == prepared.true_state)
    return result, evidence


def majority(states: np.ndarray, probabilities: np.ndarray, names: list[str],
             deciders: np.ndarray | None = None) -> tuple[str, dict[str, int]]:
    """The state most windows were given, and how many each state won. A tie goes to the state the envelope spectrum
    decided more windows of (``deciders``: a defect series standing 20 dB over its floor and 10 dB above the others
    is stronger evidence than a classifier's call), then to the higher mean probability."""
    counts = {name: int(np.sum(states == name)) for name in names}
    by_physics = {name: 0 if deciders is None else int(np.sum((states == name) & (deciders == "physics")))
                  for name in names}
    return max(names, key=lambda name: (counts[name], by_physics[name], probabilities[:, names.index(name)].mean())), counts


def physics_first_note(pipeline: DiagnosisPipeline, deciders: np.ndarray) -> str:
    """How many windows the envelope spectrum decided (the model's ``physics_first``), and why it may."""
    decided = int(np.sum(deciders == "physics"))
    gate = pipeline.physics_first
    rest = ("the classifier decided none (" if decided == len(deciders) else "the classifier decided the rest (their ")
    return (f"{decided} of {len(deciders)} windows decided by the envelope spectrum, where one defect series stood "
            f"{gate.threshold_db:g} dB or more over its floor and {gate.margin_db:g} dB above the others; {rest}"
            "probabilities are the classifier's throughout)")


def extrapolation_note(unseen: np.ndarray, decided: int) -> str:
    """What to say of the ``decided`` windows the classifier decided, of which those named in ``unseen`` (each window's
    feature farthest beyond the training windows' range) hold a feature well beyond it."""
    names, counts = np.unique(unseen, return_counts=True)
    named = ", ".join(f"{name} in {count} window{'s' * int(count != 1)}"
                      for count, name in sorted(zip(counts, names), reverse=True)[:3])
    counted = ("the one window" if decided == 1 else f"all {decided} windows" if len(unseen) == decided else
               f"{len(unseen)} of the {decided} windows")
    return (f"{counted} the classifier decided hold{'s' * (len(unseen) == 1)} a feature beyond its range over the "
            f"training windows by more than {RANGE_MARGIN:.0%} of that range ({named}): the classifier "
            "extrapolates there, and its probabilities do not say so; hold its verdict against the physics evidence")


def one_line(result: dict) -> str:
    """What a reliability engineer reads first: verdict, confidence, physics, truth."""
    n_windows = len(result["windows"])
    by_physics = sum(window.get("decided_by") == "physics" for window in result["windows"])
    # The probability is the classifier's: beside windows the physics decided, said to be.
    probability = (f"{by_physics} decided by the envelope spectrum; classifier p {result['mean_probability']:.2f}"
                   if by_physics else f"p {result['mean_probability']:.2f}")
    # A verdict its windows split on (a state that changed along a long record) says what the rest said.
    split = [f"{state} {count / n_windows:.0%}" for state, count in result.get("window_states", {}).items()
             if state != result["verdict"] and count >= 0.1 * n_windows]
    asides = [f"the others: {', '.join(split)}"] if split else []
    if (result.get("features_unseen") or 0.0) >= 0.5:  # a probability of a model extrapolating is no confidence
        asides.append(f"{result['features_unseen']:.0%} of windows beyond the model's training features")
    alone = result.get("classifier_verdict")  # where the physics decided windows, the model's own answer may differ
    if by_physics and alone not in (None, result["verdict"]):
        asides.append(f"the windows left to the classifier: {alone}")
    line = (f"{result['record']}: {result['verdict']} ({result['share']:.0%} of {n_windows} window{'s' * (n_windows != 1)}, "
            f"{probability}{''.join(f'; {aside}' for aside in asides)})")
    if result["evidence_state"] is not None:
        prominence = result["evidence"]["prominence_db"]
        top = max(prominence, key=prominence.get, default=None)
        line += f"; physics: {result['evidence_state']}" + (f" ({top} lines {prominence[top]:+.1f} dB)" if top else "")
        if not result["agree"]:
            line += " - DISAGREES with the model"
    # What leaves the verdict in doubt, where it is read first (the notes say why at length): a confident verdict on a
    # record read at a wrong rate, or a dead sensor's bias called healthy, had said so only in the closing summary.
    doubts = [words for flagged, words in (
        (result.get("rate_check") == "contradicted", "the shaft line contradicts the speed or rate"),
        (result.get("level_unseen"), "its level lies a decade from the model's training windows: check unit and gain"),
        (result.get("unit_check") == "assumed", "its unit is assumed to be the model's, which reads levels: give unit="),
        (result.get("clipped"), "it clipped, which flattens the impacts"),
        ((result.get("speed") or {}).get("off"), "its shaft turns 1-8 % from the speed stated"),
        ((result.get("speed") or {}).get("in_doubt"), "its speed varies, or its reading was refused"),
        (result.get("speed_varies"), "the file is a variable-speed run, read as if at one speed"),
    ) if flagged]
    if doubts:
        line += f" - IN DOUBT: {'; '.join(doubts)}"
    if "true_state" in result:
        line += f"; true {result['true_state']}: {'right' if result['correct'] else 'WRONG'}"
    return line


def plot_diagnosis(result: dict, evidence: PhysicsEvidence | None, class_names: list[str], path: Path) -> Path:
    """Per-window class probabilities along time, and the envelope spectrum with defect harmonics marked."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(10, 6.5))
    top, bottom = figure.subplots(2, 1)
    times = [w["start_s"] for w in result["windows"]]
    for name in class_names:
        top.plot(times, [w["probabilities"][name] for w in result["windows"]], marker=".", lw=1, label=name)
    top.set(xlabel="window start (s)", ylabel="class probability", ylim=(-0.02, 1.02),
            title=f"{result['record']}: {result['verdict']} ({result['share']:.0%} of windows)")
    top.legend(loc="center left", bbox_to_anchor=(1.01, 0.5))  # beside the traces, which reach every corner
    if evidence is None or not evidence.lines_hz:
        bottom.text(0.5, 0.5, "no shaft speed: physics evidence not computed" if evidence is None else
                    "no defect series can be read apart from the shaft's lines", ha="center", va="center")
        bottom.set_axis_off()
    else:
        top_line = max(max(lines) for lines in evidence.lines_hz.values())
        shown = evidence.freqs_hz <= 1.25 * top_line  # past the last line read, so a line just beyond stands whole
        bottom.semilogy(evidence.freqs_hz[shown], evidence.spectrum[shown], color="k", lw=0.7)
        colors = {"inner": "tab:blue", "ball": "tab:green", "outer": "tab:red"}
        for state, lines in evidence.lines_hz.items():
            for index, line in enumerate(lines):
                bottom.axvline(line, color=colors[state], ls="--", lw=0.9,
                               label=f"{state} {evidence.prominence_db[state]:+.1f} dB" if index == 0 else None)
        low, high = evidence.band_hz
        unit = result.get("unit") or "unit"
        bottom.set(xlabel="frequency (Hz)",
                   ylabel=f"squared-envelope PSD ({f'({unit})' if '/' in unit else unit}$^4$/Hz)",
                   title=f"envelope of {low:.0f}-{high:.0f} Hz: physics says {evidence.evidence_state}")
        bottom.legend(loc="center left", bbox_to_anchor=(1.01, 0.5))
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    return path
