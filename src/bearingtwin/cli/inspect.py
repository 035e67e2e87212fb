"""``bearingtwin-inspect path=<file>``: a JSON summary of any vibration file the project reads.

Reports what the file holds (format, channels, samples, NaN count, sampling rate, speed)
rather than judging it, so a file with NaNs is described, not refused; a file that cannot
be read at all (missing, empty, truncated, non-numeric) exits 2 naming the file and the
problem. With ``bearing=<name>`` the bearing's defect frequencies are added, in Hz when the
speed is known and always as orders (multiples of the shaft speed). Whenever the rate and
the speed are known, the sampling-rate check against the shaft line is reported too, with
every vibration channel of the file a witness of its one rate (the channel that decides, and each
channel's verdict), as the commands that read the file apply it, and ``shaft_speed``: how steadily the shaft turned,
per channel (:func:`shaft_speed`; a channel read null has its reason in ``shaft_speed_not_read``). Whenever the rate
is known,
``quality`` names per channel clipping and dropouts, with where they are (a diagnosis and the twin note them
for the channel they read, and refuse a dead one), or why a channel was not checked. ``levels`` gives each vibration
channel's mean, RMS, peak (largest magnitude), crest factor and kurtosis, in the file's unit (a first look at how
impulsive a record is: kurtosis 3 for Gaussian noise, far above for a defect's impacts).
Settings are Hydra overrides, as for every command (``bearingtwin-inspect --help``).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.checks import positive_number
from bearingtwin.config import (exit_on_user_error, hydra_command, load_bearing, refuse_unknown_keys,
                                unknown_bearing_note)
from bearingtwin.data.formats import (RATE_NOT_CHECKED_SIMULATED, SIMULATED_RATE, file_bearing, named_rate_note,
                                    read_raw, refuse_one_speed_for_a_varying_run, resolve_fact, resolve_fs, resolve_speed,
                                    speed_from_tachometer, speed_reader, tachometer_channel)
from bearingtwin.data.labels import labels_row
from bearingtwin.data.recording import Recording
from bearingtwin.data.units import same_unit
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.time_domain import FEATURE_NAMES, time_domain_features
from bearingtwin.tracking.lifecycle import stop_cleanly
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal.sampling_rate import (check_channels, decisive_channel, rate_witnesses, series_elsewhere_words,
                                              speeds_lines_alone_hide)
from bearingtwin.signal.speed import speed_profile, tachometer_profile


@hydra_command("inspect")
@exit_on_user_error
def inspect_command(cfg: DictConfig) -> None:
    refuse_unknown_keys(HydraConfig.get())
    if cfg.path is not None and not isinstance(cfg.path, (str, int, float)):
        raise BearingTwinError(f"path={cfg.path}: give one file (inspect reads one at a time)")
    bearing = cfg.get("bearing")
    summary = summarize(
        cfg.path,
        bearing=None if bearing is None else BearingGeometry.from_config(bearing),
        bearing_name=HydraConfig.get().runtime.choices.get("bearing"),
        fs=cfg.fs,
        rpm=cfg.rpm,
        channel=cfg.channel,
    )
    try:
        print(json.dumps(summary, indent=2), flush=True)
    except BrokenPipeError:  # the reader (`| head`) stopped reading; the Python docs' way out, without a traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)


def _vibration_read(raw, channel) -> str | None:
    """The channel a diagnosis or the twin would read (``channel``, else the file's default or only vibration
    channel); None where the file leaves the choice to the user."""
    try:
        return raw.channel(channel)[0]
    except BearingTwinError:
        return None


def summarize(path, bearing: BearingGeometry | None = None, bearing_name: str | None = None,
              fs: float | None = None, rpm: float | None = None, channel=None) -> dict:
    """The inspect report of one file as a JSON-ready dict."""
    raw = read_raw(path)
    rpm = None if rpm is None else positive_number(rpm, "rpm", "rev/min")
    # The bearing the file names (bearingtwin-simulate's, a CWRU record's), as diagnose and the twin read it
    named = file_bearing(raw.meta, raw.default_channel if channel is None else raw.channel(channel)[0])
    bearing_note = None
    if bearing is None and named:
        bearing_note = unknown_bearing_note(named, "its defect lines are not read")
        if bearing_note is None:
            bearing, bearing_name = load_bearing(str(named)), str(named)
    elif named and bearing_name and str(named) != bearing_name:  # as diagnose says it; the twin refuses it
        bearing_note = f"bearing={bearing_name} given, where the file names {named}: its defect lines are {bearing_name}'s"
    # A column that is no vibration (a HUST export's speed column, every sample 0) is listed, never read as one.
    vibration = raw.vibration_channels
    names = [raw.channel(channel)[0]] if channel is not None else list(vibration) or list(raw.channels)
    listed = names if channel is not None else list(raw.channels)
    # What the options leave unsaid, a labels.csv beside the file may say, read as the twin reads it: a rate there
    # replaces one the file merely declares; a speed there or given is the file's measured one where within 1 % of it,
    # read further off where the record's tachometer or shaft series bears it out, refused otherwise; a state there
    # must agree with the file's.
    units = {name: raw.channel_units.get(name, raw.unit) for name in listed}  # one, or each channel's where they differ
    unit = (next(iter(units.values()), "") or None) if len(set(units.values())) <= 1 else units
    row = labels_row(Path(str(path)), state_required=False) if fs is None or rpm is None or unit is None else None
    table, table_state, table_rpm, table_fs = (row.where, row.state, row.rpm, row.fs) if row else (None,) * 4
    unit_note = _row_unit_note(row, unit)
    if unit is None and row is not None and row.unit is not None and row.scale is None:
        unit = row.unit  # the samples' unit the file does not state, as a diagnosis reads it
    fs_origin = "option" if fs is not None else raw.fs_origin or None
    if fs is None and table_fs is not None:
        if raw.fs is None or raw.fs_origin == "declared":
            fs, fs_origin = table_fs, table
        else:  # a rate the file stores must agree with the row's, as training and diagnose require
            resolve_fs(raw, table_fs, f"{table}: fs")
    fs_hz = resolve_fs(raw, fs) if (fs is not None or raw.fs is not None) else None
    speed_notes = []  # a given speed read as the file's measured one, or one that may be in Hz
    rpm_origin, rpm_key = ("option", "rpm") if rpm is not None else (table, f"{table}: rpm")
    read = _vibration_read(raw, channel)
    reader = None if read is None or fs_hz is None else speed_reader(raw, read, raw.channels[read], fs_hz)
    refuse_one_speed_for_a_varying_run(raw, rpm if rpm is not None else table_rpm, rpm_key)
    rpm = resolve_speed(raw, rpm if rpm is not None else table_rpm, rpm_key, speed_notes, reader)
    if raw.rpm is not None and rpm == raw.rpm:
        rpm_origin = "file"
    elif rpm is None and raw.nominal_rpm is not None:
        rpm, rpm_origin = raw.nominal_rpm, "nominal"
    elif rpm is None:
        rpm_origin = None
        tachometer = None if read is None or fs_hz is None else tachometer_channel(raw, read)
        if tachometer is not None:  # as diagnose and the twin read a speed the file states no other way
            rpm, said = speed_from_tachometer(raw.channels[tachometer], tachometer, raw.channels[read], fs_hz)
            rpm_origin = None if rpm is None else "tachometer"
            speed_notes.append(said if rpm is not None else f"the file states no shaft speed, and {said}")
    fault = resolve_fact(raw, "fault", raw.fault, table_state, f"{table}: state")
    lengths = {name: int(raw.channels[name].size) for name in names}
    n_samples = next(iter(lengths.values())) if len(set(lengths.values())) == 1 else lengths
    summary = {
        "file": raw.path,
        "format": raw.format,
        "channels": list(raw.channels),
        "fs_hz": fs_hz,
        "fs_origin": fs_origin,
        "rpm": rpm,
        # option, file, nominal (the data set's speed for the file's condition), tachometer (its pulses, counted per
        # turn by the shaft series) or a labels.csv line beside the file
        "rpm_origin": rpm_origin,
        "fault": fault,
        "unit": unit,
        "n_samples": n_samples,
        "duration_s": None if fs_hz is None or isinstance(n_samples, dict) else n_samples / fs_hz,
        # Of every column read, a speed column's too (file facts, as the units above); the checks below read the
        # vibration alone.
        "nan_count": {name: int(np.count_nonzero(np.isnan(raw.channels[name]))) for name in listed},
        "inf_count": {name: int(np.count_nonzero(np.isinf(raw.channels[name]))) for name in listed},
        "levels": levels(raw, names),
        "meta": {key: value for key, value in raw.meta.items() if key != "header"},
    }
    if rpm_origin == "nominal":
        summary["meta"]["notes"] = [*raw.meta.get("notes", []), raw.nominal_rpm_note]
    given_rate = named_rate_note(raw.meta, fs, "fs" if fs_origin == "option" else f"{table}: fs")
    too_low = None if bearing is None or rpm is None or fs_hz is None else bearing.rate_too_low(fs_hz, rpm)
    too_low = too_low and f"a rate of {fs_hz:g} Hz is too low for a diagnosis: {too_low}"
    for note in filter(None, [bearing_note, given_rate, *speed_notes, too_low, unit_note]):
        summary["meta"]["notes"] = [*summary["meta"].get("notes", []), note]
    if fs_hz is not None:  # clipping, dropouts and dead channels, as a diagnosis or the twin names them
        quality = {name: Recording(raw.channels[name], fs_hz, source=raw.path).quality_notes()
                   if np.all(np.isfinite(raw.channels[name])) else
                   [f"not checked: {np.count_nonzero(~np.isfinite(raw.channels[name]))} NaN or infinite samples"]
                   for name in names if raw.channels[name].size}
        summary["quality"] = {name: notes for name, notes in quality.items() if notes}
    if rpm is not None and fs_hz is not None and fs_origin == SIMULATED_RATE:
        summary["shaft_line_check"] = {"verdict": "not checked", "reason": RATE_NOT_CHECKED_SIMULATED}
    elif rpm is not None and fs_hz is not None:
        # Every vibration channel of the file's length witnesses its one rate, as bearingtwin-diagnose and the twin read it.
        signal = raw.channels[names[0]]
        defect_hz = None if bearing is None else bearing.defect_frequencies(rpm)
        try:
            checks = check_channels(rate_witnesses(signal, vibration), fs_hz, rpm, defect_hz=defect_hz)
            decisive = decisive_channel(checks)
            summary["shaft_line_check"] = dict(checks[decisive].as_dict(), channel=decisive,
                                               channels={name: check.verdict for name, check in checks.items()})
            # A speed a whole factor too low that the cage's or a defect's lines alone bear out, read at their
            # harmonics: the twin refuses it and a diagnosis doubts it, so the summary says it too.
            higher = speeds_lines_alone_hide(checks[decisive], signal, defect_hz, vibration)
            if higher:
                summary["shaft_line_check"]["speed_doubt"] = (
                    f"{series_elsewhere_words(checks[decisive], higher)}; only the cage's or a defect's lines bear out "
                    f"{rpm:g} rpm, read at their harmonics: check the speed")
        except BearingTwinError as error:  # NaNs, or a record too short to resolve the shaft line
            summary["shaft_line_check"] = {"channel": names[0], "verdict": "not checked", "reason": str(error)}
        summary["shaft_speed"], not_read = shaft_speed(raw, names, fs_hz, rpm)
        if not_read:  # beside, so that each channel's entry keeps its shape (an object, or null)
            summary["shaft_speed_not_read"] = not_read
    elif rpm is None and fs_hz is not None:  # nothing to read a speed around: said, where a reader looks for it
        summary["shaft_speed"] = None
        summary["shaft_speed_not_read"] = (f"the file is {raw.meta['no_speed']}: no one speed describes it, and none is "
                                           "checked against" if raw.meta.get("no_speed") else
                                           "the file states no shaft speed: give rpm=<rev/min> (or the rpm column of a "
                                           "labels.csv beside it)")
    if bearing is not None:
        summary["bearing"] = bearing_name
        summary["defect_orders"] = {key: value for key, value in bearing.defect_frequencies(60.0).items() if key != "shaft"}
        if rpm is not None:
            summary["defect_frequencies_hz"] = bearing.defect_frequencies(rpm)
    return summary


def _row_unit_note(row, unit) -> str | None:
    """What the labels row beside the file says of its samples' unit that the summary's ``unit`` and levels (the
    file's own samples) do not: a scale a reading multiplies them by first, or a unit the file contradicts (which
    training, a diagnosis and the twin refuse)."""
    if row is None or row.unit is None:
        return None
    if row.scale is not None:
        return (f"{row.where} reads its samples x {row.scale:g} in {row.unit} (scale, unit): the levels here are the "
                "file's own samples, before it")
    if isinstance(unit, str) and unit and not same_unit(unit, row.unit):
        return (f"{row.where} gives unit {row.unit}, which the file's {unit} contradicts: training, a diagnosis and the "
                "twin refuse it")
    return None


def levels(raw, names: list[str]) -> dict:
    """Each of ``names``'s mean, RMS, peak (largest magnitude), crest factor and kurtosis (Pearson's) over its finite
    samples, as :func:`~bearingtwin.features.time_domain.time_domain_features` computes them; null for a channel with
    fewer than two finite samples, one value throughout, or levels beyond a float's range."""
    read = {}
    for name in names:
        values = raw.channels[name]
        values = values[np.isfinite(values)]
        read[name] = None
        if values.size < 2:
            continue
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                features = dict(zip(FEATURE_NAMES, time_domain_features(values).tolist()))
        except BearingTwinError:  # constant (to within the float's resolution): no kurtosis, no crest factor
            continue
        channel_levels = {"mean": features["mean"], "rms": features["rms"], "peak": float(np.max(np.abs(values))),
                          "crest_factor": features["crest_factor"], "kurtosis": features["kurtosis"]}
        if all(np.isfinite(value) for value in channel_levels.values()):  # JSON has no NaN
            read[name] = channel_levels
    return read


def shaft_speed(raw, names: list[str], fs_hz: float, rpm: float) -> tuple[dict, dict]:
    """How steadily the shaft turned, per channel, as a diagnosis reads it before it steadies a record (a tachometer's
    pulses counted, a vibration channel's shaft series read, in 1 s segments): the spread of the speeds read, their
    median and range, in how many segments, and whether a diagnosis would call the record unsteady; null where
    nothing was read, and then, in the second dict, why (NaN samples, a record too short, a speed a supply's lines
    could pass for, no series standing out)."""
    speeds, not_read = {}, {}
    for name in names:
        values = raw.channels[name]
        speeds[name] = None
        if not values.size or not np.all(np.isfinite(values)):
            not_read[name] = "no samples" if not values.size else "NaN or infinite samples"
            continue
        pulses = name in raw.meta.get("two_levels", [])
        try:
            profile = tachometer_profile(values, fs_hz, rpm) if pulses else speed_profile(values, fs_hz, rpm)
        except BearingTwinError as error:
            not_read[name] = str(error)
            continue
        if not profile.readable:
            not_read[name] = profile.unread_words()
            continue
        read = profile.rpm[profile.read]
        speeds[name] = {
            "spread": profile.spread, "median_rpm": float(np.median(read)), "range_rpm": [float(read.min()),
                                                                                         float(read.max())],
            "segments_read": f"{int(profile.read.sum())} of {profile.rpm.size}", "unsteady": profile.unsteady()}
    return speeds, not_read


main = stop_cleanly(inspect_command)  # Ctrl-C: one line and exit 130, not a traceback from inside the work

if __name__ == "__main__":
    main()
