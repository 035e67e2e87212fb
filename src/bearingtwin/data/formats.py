"""Reading vibration records from files: one raw reader per format, one path to a Recording.

Reading happens in two steps because the two users want different things:
:func:`read_raw` returns every channel as stored, NaNs included, so ``bearingtwin-inspect``
can *report* a damaged file; :func:`load_recording` picks one channel, reconciles the
sampling rate and speed given by the user with those the file declares, and builds a
validated :class:`~bearingtwin.data.recording.Recording`, so a learning pipeline never
sees a NaN, a guessed sampling rate or a silently chosen channel.

Formats (chosen by extension): ``.npy`` (1-D, or 2-D: the longer axis is time), ``.npz``
(arrays are channels; scalars ``fs`` / ``rpm`` and a string ``fault`` are facts, as written
by ``bearingtwin-simulate``; an array named ``signal`` is the default channel), ``.csv`` / ``.txt`` / ``.tsv``
(a text table, as spreadsheets and data loggers export it: columns are channels,
separated by commas, semicolons, tabs or spaces, optional header row, which may state a column's unit, ``acc (g)``,
``acc_ms2`` (:func:`unit_in_name`), or have a row of units below it, and above which a logger's lines are notes,
one of which may state the rate, ``Sample rate: 12000 Hz``: :data:`_RATE_NOTE`; a ``time`` / ``time_s`` /
``Time (s)`` / ``Zeit [s]`` column, or ``time_ms`` / ``t [ms]`` in milliseconds, or a column of a logger's clock
times, ``2024-03-01 10:00:00.000083``, gives the sampling rate too: :data:`_TIME_COLUMN`), ``.mat`` (CWRU files by
their variable names, otherwise numeric variables, and a struct's numeric fields, are channels, a rising time vector
as long as them gives the rate as a time column does (in an ``.npz`` too), and scalars ``fs`` / ``SampleRate`` /
``rpm`` are facts: :data:`_FACTS`; MATLAB 7.3 files too, and HDF5 files without MATLAB's header), ``.wav`` (rate
from the header; integer samples scaled to the recorder's full scale, 1.0)
and ``.xls`` (HUST text exports). A file a reader cannot parse (corrupt, truncated, another
format under the extension) is refused naming the file, whatever the reading library raised.

Channel: when none is asked for, the file's only channel, or the one its format designates
(CWRU: the drive-end ``DE`` accelerometer; ``.npz``: ``signal``); otherwise the user must choose.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bearingtwin.checks import is_finite_number, positive_number
from bearingtwin.data.recording import Recording
from bearingtwin.data.units import (INTEGRATED_QUANTITIES, QUANTITY_WORDS, acceleration_unit, quantity_of, quantity_word,
                                    same_unit)
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.signal.sampling_rate import is_pulse_train
from bearingtwin.signal.speed import (HARMONICS, pulse_rate, pulse_times, pulses_per_turn, speed_profile,
                                     tachometer_profile, tachometer_speed)
from bearingtwin.storage import write_atomic

TEXT_TABLES = (".csv", ".txt", ".tsv")
"""Text tables of numbers: a spreadsheet's or data logger's export, whatever it separates its columns with."""
FORMATS = (".npy", ".npz", *TEXT_TABLES, ".mat", ".wav", ".xls")

FS_RELATIVE_TOLERANCE = 0.01
"""A user's sampling rate may differ this much from one measured in the file (a time column
printed with a few decimals) before it counts as a contradiction."""
FS_FLOAT_NOISE = 1e-9
"""A rate the file states exactly (an ``.npz`` / ``.mat`` ``fs``, a ``.wav`` header) must be repeated
exactly; this much relative difference is float rounding (12000 written as 12000.000000000002)."""

_TIME_UNIT = r"s|secs?|seconds?|ms|msecs?|milliseconds?|us|µs|μs|usecs?|microseconds?|ns|nanoseconds?"
_TIME_COLUMN = re.compile(
    rf"(?:t|time|timestamp|time stamp|zeit|tiempo)\s*(?:[_/]\s*(?P<suffix>{_TIME_UNIT})"
    rf"|[(\[]\s*(?P<bracketed>{_TIME_UNIT})\s*[)\]]|\s+in\s+(?P<worded>{_TIME_UNIT}))?", re.IGNORECASE)
"""Column (or variable) names read as time stamps: ``time``, ``t``, ``time_s``, ``time_ms``, ``Time (s)``,
``t [ms]``, ``Time [sec]``, ``time/s``, ``Timestamp``, ``Zeit [s]``, ``time in ms``, ``time_us``, ``t [µs]``, ..."""
_TIME_UNIT_SECONDS = (("micro", 1e-6), ("u", 1e-6), ("µ", 1e-6), ("μ", 1e-6), ("n", 1e-9), ("m", 1e-3), ("", 1.0))
"""A time unit's length in seconds by how it begins (``microseconds`` before ``ms``), the first that fits."""
_UNIT_IN_NAME = re.compile(r"(?P<name>.*?)\s*(?:[(\[]\s*(?P<unit>[^()\[\]]+?)\s*[)\]]|\s+in\s+(?P<worded>\S+))\s*")
"""A channel name that states its unit at its end, in brackets or after "in": ``acceleration (m/s^2)``, ``DE [g]``,
``a in m/s²``."""
LOWEST_FS_HZ = 200.0
"""A time column giving a slower rate than this is not a vibration record's (rather, stamps in milliseconds)."""


@dataclass
class RawRecord:
    """Every channel of a file as stored (NaN allowed), with what the file says about itself.

    Attributes:
        path: the file, used in every message.
        format: the reader used (``npy``, ``cwru-mat``, ``hust-xls``, ...).
        channels: channel name -> 1-D float64 samples.
        fs: sampling rate in Hz the file declares (None when it declares none).
        fs_origin: how ``fs`` was obtained (``header``, ``time column``, ``declared``, ...);
            a ``declared`` rate is a convention about the data set, not a measurement, so a
            user's value replaces it instead of contradicting it.
        fs_tolerance: how far (relative) a user's rate may lie from ``fs`` and still agree with it:
            float noise where the file states its rate exactly, FS_RELATIVE_TOLERANCE where the rate
            was measured from rounded time stamps (or checked against them, as a HUST header is).
        rpm: shaft speed the file declares (None when unknown).
        nominal_rpm: the speed the data set's tables give for the file's operating condition, used
            when neither the file nor the user states one; ``nominal_rpm_note`` says so, and where it is from.
        fault: bearing state the file or its name declares (None when unknown).
        unit: physical unit of the channels, when known.
        meta: anything else read from the file or its name.
        default_channel: the channel used when none is asked for, if the format designates one.
        channel_units: a channel's own unit where its name states one (a CSV header's ``acc (g)``), over ``unit``.
        fs_unread: why the file gives no rate where it seems to hold one (time stamps printed coarser than the
            sampling period), for the refusal that asks for it; "" otherwise.
    """

    path: str
    format: str
    channels: dict[str, np.ndarray]
    fs: float | None = None
    fs_origin: str = ""
    fs_tolerance: float = FS_FLOAT_NOISE
    rpm: float | None = None
    nominal_rpm: float | None = None
    nominal_rpm_note: str = ""
    fault: str | None = None
    unit: str = ""
    meta: dict = field(default_factory=dict)
    default_channel: str | None = None
    channel_units: dict[str, str] = field(default_factory=dict)
    fs_unread: str = ""

    @property
    def vibration_channels(self) -> dict[str, np.ndarray]:
        """The channels that may hold a vibration: every one but those the format says hold none (a HUST export's
        speed column, every sample 0), which neither witness a rate nor are read as a record."""
        not_vibration = self.meta.get("not_vibration", {})
        return {name: values for name, values in self.channels.items() if name not in not_vibration}

    def channel(self, name: str | int | None, key: str = "channel") -> tuple[str, np.ndarray]:
        """The channel called ``name`` (or at position ``name``, or so called without the unit its name states:
        ``FE`` for ``FE (g)``, where that names one channel alone); when ``name`` is None, the format's default
        channel or else the only vibration one (a tachometer's pulses beside it are none).

        ``key`` is the setting the caller reads ``name`` from, named in the error messages.
        """
        names = list(self.channels)
        not_vibration = self.meta.get("not_vibration", {})
        two_levels = self.meta.get("two_levels", [])  # a tachometer's pulses, or a sensor saturated most of the time
        vibration = [channel for channel in self.vibration_channels if channel not in two_levels]
        if name is None:
            if self.default_channel in self.channels:
                return self.default_channel, self.channels[self.default_channel]
            if not vibration:  # only pulses (or a saturated sensor): read, and said to be what they look like
                vibration = list(self.vibration_channels)
            if not vibration:
                raise BearingTwinError(f"{self.path}: holds no vibration channel "
                                       f"({'; '.join(f'{n} reads {why}' for n, why in not_vibration.items())})")
            if len(vibration) > 1 and self.format == "cwru-mat" and self.meta.get("bearing"):  # a fault's own sensor
                raise BearingTwinError(f"{self.path}: holds no {self.default_channel} channel, the accelerometer on the "
                                       f"faulty bearing (it holds {', '.join(vibration)}); choose one with {key}=<name>")
            if len(vibration) > 1:
                raise BearingTwinError(f"{self.path}: holds channels {', '.join(vibration)}; choose one with {key}=<name>"
                                       f"{_quoting_hint(key, vibration)}")
            return self.channel(vibration[0], key)  # said to be two levels where it is
        wanted = str(name)
        found = wanted if wanted in self.channels else None
        if found is None and (isinstance(name, int) or wanted.lstrip("-").isdigit()) and 0 <= int(wanted) < len(names):
            found = names[int(wanted)]
        if found is None:  # "FE" for the column headed "FE (g)", where no other column's name is FE without its unit
            bare = [channel for channel in names if split_unit(channel)[0] == wanted]
            found = bare[0] if len(bare) == 1 else None
        if found in not_vibration:
            raise BearingTwinError(f"{self.path}: {key}={wanted} reads {not_vibration[found]}; choose one of "
                                   f"{', '.join(vibration)}")
        if found is not None:
            said = (f"channel {found} holds two levels only: a tachometer's pulses, or a sensor saturated nine samples "
                    "in ten; read as asked, it is no vibration's record")
            if found in two_levels and said not in self.meta.get("notes", []):  # once, however often it is asked for
                self.meta.setdefault("notes", []).append(said)
            return found, self.channels[found]
        only = f", or {key}=null for its only one" if len(vibration) == 1 else ""
        raise BearingTwinError(f"{self.path}: no channel {name!r}; the file holds channel{'s' * (len(vibration) != 1)} "
                               f"{', '.join(vibration)} (choose with {key}=<name>{only}){_quoting_hint(key, vibration)}")


def _quoting_hint(key: str, names: list[str]) -> str:
    """How to type the first of ``names`` that a command line cannot take bare (spaces, brackets, commas: Hydra
    reads ``channel=DE (g)`` as a syntax error), "" when each can be typed as it is."""
    awkward = next((name for name in names if not re.fullmatch(r"[\w.\-/]+", name)), None)
    return "" if awkward is None else f"; quote a name like {awkward!r} in single quotes inside double: {key}=\"'{awkward}'\""


def read_raw(path: str | Path) -> RawRecord:
    """Read every channel of a supported file, without judging its values."""
    path = Path(path)
    suffix = path.suffix.lower()
    if path.is_dir():
        raise BearingTwinError(f"{path}: is a folder; give one file ({', '.join(FORMATS)})")
    if suffix not in FORMATS:
        raise BearingTwinError(f"{path}: unknown file type {path.suffix or '(no extension)'}; supported: {', '.join(FORMATS)}")
    if not path.is_file():
        raise BearingTwinError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise BearingTwinError(f"{path}: the file is empty")
    try:
        if suffix == ".xls":
            from bearingtwin.data.hust import read_hust_raw

            raw = read_hust_raw(path)
        elif suffix == ".mat":
            from bearingtwin.data.cwru import is_cwru_mat, read_cwru_raw

            variables = _load_mat(path)
            raw = read_cwru_raw(path, variables) if is_cwru_mat(variables) else _read_generic_mat(path, variables)
        elif suffix in TEXT_TABLES:
            raw = _read_csv(path)
        else:
            raw = {".npy": _read_npy, ".npz": _read_npz, ".wav": _read_wav}[suffix](path)
        if raw.format not in ("cwru-mat", "hust-xls"):  # a CWRU record saved in another format, by its name
            from bearingtwin.data.cwru import facts_from_long_name

            raw = facts_from_long_name(raw)
    except BearingTwinError:
        raise
    except Exception as error:  # a corrupt file makes scipy, numpy and zipfile raise any type (BadZipFile, MatReadError, ...)
        said = " ".join(str(error).split())
        raise BearingTwinError(f"{path}: not a readable {suffix} file ({type(error).__name__}: {said})") from None
    return _pulse_trains_marked(raw)


def _pulse_trains_marked(raw: RawRecord) -> RawRecord:
    """``raw`` with each channel of two levels only (a tachometer's pulses recorded beside the accelerometers)
    named in ``meta["two_levels"]``: no channel choice falls on it by default (one named is read, and said to be
    what it looks like)."""
    pulses = [name for name, values in raw.channels.items() if is_pulse_train(values)]
    if pulses:
        raw.meta["two_levels"] = pulses
    return raw


def load_recording(
    path: str | Path,
    channel: str | int | None = None,
    fs: float | None = None,
    rpm: float | None = None,
    fault: str | None = None,
    channel_key: str = "channel",
    fs_key: str = "fs",
    rpm_key: str = "rpm",
    fault_key: str = "fault",
    unit: str | None = None,
    unit_key: str = "unit",
    scale: float | None = None,
    scale_key: str = "scale",
) -> Recording:
    """One validated channel of a file.

    ``fs``, ``rpm`` and ``unit`` fill in what the file does not declare (``scale`` multiplies the samples first,
    ``unit`` then naming the product's: :func:`scaled`); where it does, a different
    value is an error rather than a silent override (a speed the record's own tachometer or shaft series bears out
    against the file's is read, said: :func:`resolve_speed`; a ``declared`` data-set convention is
    the exception: the user's value wins). Non-finite samples raise: nothing is dropped.
    ``channel_key``, ``fs_key``, ``rpm_key``, ``fault_key``, ``unit_key`` and ``scale_key`` are the settings
    ``channel``, ``fs``, ``rpm``, ``fault``, ``unit`` and ``scale`` come from, as messages name them.
    """
    return recording_from_raw(read_raw(path), channel, fs, rpm, fault, channel_key, fs_key, rpm_key, fault_key, unit,
                              unit_key, scale, scale_key)


def recording_from_raw(
    raw: RawRecord,
    channel: str | int | None = None,
    fs: float | None = None,
    rpm: float | None = None,
    fault: str | None = None,
    channel_key: str = "channel",
    fs_key: str = "fs",
    rpm_key: str = "rpm",
    fault_key: str = "fault",
    unit: str | None = None,
    unit_key: str = "unit",
    scale: float | None = None,
    scale_key: str = "scale",
) -> Recording:
    """The validated Recording of one channel of an already read file (see :func:`load_recording`); ``unit`` (setting
    ``unit_key``) is the samples' unit where the file states none (:func:`resolve_unit`), or, with ``scale`` (setting
    ``scale_key``), the unit the samples are in once multiplied by it (:func:`scaled`)."""
    # A rate the file records stays the file's when the user repeats it (resolve_fs refuses any other);
    # a given rate replaces a merely declared one, or fills in a missing one.
    factor = restamped(raw, fs)
    fs_origin = (raw.fs_origin if fs is None or (raw.fs is not None and raw.fs_origin != "declared" and factor is None)
                 else "config")
    name, signal = raw.channel(channel, channel_key)
    if fault is not None and fault not in FAULTS:
        raise BearingTwinError(f"{fault_key}={fault!r} is not a bearing state; choose one of {', '.join(FAULTS)}")
    refuse_a_label_the_file_contradicts(raw, fault, fault_key)
    notes = list(raw.meta.get("notes", []))  # what reading did that the user should know
    notes += filter(None, [named_rate_note(raw.meta, fs, fs_key)])
    if factor is not None:
        notes.append(f"{fs_key}={fs:g} Hz given, {factor:g} times the {raw.fs:.6g} Hz the file's time stamps give: "
                     "read as stamps in another unit than their column's name states")
    fs = resolve_fs(raw, fs, fs_key)
    refuse_one_speed_for_a_varying_run(raw, rpm, rpm_key)
    rpm = resolve_speed(raw, None if rpm is None else positive_number(rpm, rpm_key, "rev/min"), rpm_key, notes,
                        speed_reader(raw, name, signal, fs))
    # Where the speed comes from: a refusal of the rate names the speed's setting too where one gave it.
    rpm_origin = "file" if raw.rpm is not None and rpm == raw.rpm else "config" if rpm is not None else None
    if rpm is None and raw.nominal_rpm is not None:
        rpm, rpm_origin = raw.nominal_rpm, "nominal"
        notes.append(raw.nominal_rpm_note)
    reading = {}  # what reading the file found beside its notes: a speed it could not read, the scale applied
    tachometer = tachometer_channel(raw, name)
    if rpm is None and tachometer is not None:  # a tachometer's pulses beside the record may give it
        rpm, said = speed_from_tachometer(raw.channels[tachometer], tachometer, signal, fs)
        if rpm is not None:
            rpm_origin = "tachometer"
            notes.append(said)
        else:
            reading["speed_unread"] = said
    elif tachometer is not None:
        notes += filter(None, [pulses_off_note(tachometer, raw.channels[tachometer], fs, rpm)])
    if scale is None:
        unit = resolve_unit(raw, name, unit, unit_key)
    else:
        signal, unit = scaled(raw, name, signal, scale, unit, scale_key, unit_key, notes)
        reading["scale"] = float(scale)  # what the samples were multiplied by: a later reading repeats it
    return Recording(
        signal=signal,
        fs=fs,
        rpm=rpm,
        fault=resolve_fact(raw, "fault", raw.fault, fault, fault_key),
        source=raw.path,
        channel=name,
        unit=unit,
        meta=dict(raw.meta, format=raw.format, fs_origin=fs_origin, rpm_origin=rpm_origin, notes=notes, **reading),
    )


def known_unit(unit, key: str, on_command_line: bool = True) -> str:
    """``unit`` (setting ``key``) as given, where it is a unit known here (:func:`~bearingtwin.data.units.quantity_of`);
    ``on_command_line``: the refusal says how a caret is quoted for the shell (not for a table's cell)."""
    unit = str(unit).strip()
    if quantity_of(unit) is None:
        accelerations = "g, mg, m/s2, mm/s2 (an acceleration; a caret, m/s^2, only in quotes)" if on_command_line else \
            "g, mg, m/s^2, mm/s^2 (an acceleration)"
        raise BearingTwinError(f"{key}={unit!r} is no unit known here; give one such as {accelerations}, V, mm/s or um")
    return unit


def resolve_unit(raw: RawRecord, channel: str, unit: str | None, key: str = "unit") -> str:
    """The unit of ``channel``'s samples: the file's (its own, or the file's for every channel), else the one given
    (setting ``key``), which must be a unit known here (:func:`~bearingtwin.data.units.quantity_of`); a given unit the
    file contradicts is refused ("" where neither states one)."""
    stated = raw.channel_units.get(channel, raw.unit)
    word = stated if stated.lower() in QUANTITY_WORDS else ""  # "vel": a quantity named, no unit
    if word and raw.unit and quantity_of(raw.unit) == quantity_of(word):
        stated = raw.unit  # the file's note gives the unit the channel's word names the quantity of
    if unit is None or not str(unit).strip():
        return stated
    unit = known_unit(unit, key)
    if word and stated == word and quantity_of(unit) == quantity_of(word):
        return unit  # the unit of the quantity the channel's name says (Velocity, unit=mm/s)
    if stated and not same_unit(stated, unit):
        raise BearingTwinError(f"{raw.path}: {key}={unit} contradicts the file's unit, {stated}")
    return stated or unit


def scale_and_unit(scale, unit, scale_key: str = "scale", unit_key: str = "unit") -> tuple[float, str]:
    """A scale given (setting ``scale_key``) as a positive number, and the unit the samples are in once multiplied by
    it (``unit_key``), which it needs, as a unit known here (:func:`known_unit`)."""
    scale = positive_number(scale, scale_key, "the unit given per unit of the file's samples")
    if unit is None or not str(unit).strip():
        raise BearingTwinError(f"{scale_key}={scale:g} needs {unit_key}=<unit>: the unit the samples are in once "
                               f"multiplied by {scale:g} (g for a sensitivity in V per g)")
    return scale, known_unit(unit, unit_key)


FULL_SCALE_HINT = (", which states no physical unit: a scale and a unit given read it in one (scale=50 unit=g where "
                   "full scale is 50 g)")
"""What a WAV's note on its full-scale fractions advises, left out once a scale and a unit are given."""


def scaled(raw: RawRecord, channel: str, signal: np.ndarray, scale, unit: str | None, scale_key: str, unit_key: str,
           notes: list[str]) -> tuple[np.ndarray, str]:
    """``channel``'s samples multiplied by ``scale`` (setting ``scale_key``), and ``unit`` (setting ``unit_key``), the
    unit they are in then: a logger's WAV of full-scale fractions (``scale=50 unit=g`` where its +-5 V hold +-50 g of a
    100 mV/g accelerometer), or volts read through the sensor's sensitivity (``scale=10 unit=g`` for 100 mV/g). The file's
    own unit, if it states one, is what the scale converts from, so it is no contradiction: said in ``notes``; but
    samples the file states in one acceleration unit are converted to another by the units themselves, so a scale
    naming another (``scale=1 unit=g`` on a file in m/s^2: read 9.81 times too strong) is refused, while one in the
    file's own unit (a gain corrected) is read."""
    scale, unit = scale_and_unit(scale, unit, scale_key, unit_key)
    stated = resolve_unit(raw, channel, None)
    if acceleration_unit(stated) and acceleration_unit(unit) and not same_unit(stated, unit):
        raise BearingTwinError(f"{raw.path}: {unit_key}={unit} with {scale_key}={scale:g}, but the file states its samples "
                               f"in {stated}, which is converted to {unit} by itself: give no scale, or one in {stated} "
                               "(a gain to correct)")
    prefix = scale_key.removesuffix("scale")  # one source of both (a labels row's, not a config node's): named once
    given = (f"{prefix}scale={scale:g} unit={unit}" if prefix and not prefix.endswith(".") and unit_key == prefix + "unit" else
             f"{scale_key}={scale:g} {unit_key}={unit}")
    notes[:] = [note.removesuffix(FULL_SCALE_HINT) for note in notes]  # the advice taken: not given again beside it
    notes.append(f"samples x {scale:g} read in {unit} ({given}{f'; the file states {stated}' if stated else ''})")
    return np.asarray(signal, dtype=np.float64) * scale, unit


def tachometer_channel(raw: RawRecord, channel: str) -> str | None:
    """The file's first two-level channel beside ``channel`` and as long as it (a tachometer's pulses); None where the
    file holds none."""
    length = np.shape(raw.channels[channel])
    return next((other for other in raw.meta.get("two_levels", [])
                 if other != channel and np.shape(raw.channels[other]) == length), None)


def speed_from_tachometer(pulses: np.ndarray, name: str, signal: np.ndarray, fs: float) -> tuple[float | None, str]:
    """The shaft speed (rev/min) a tachometer channel (``name``, its ``pulses``) gives a record that states none
    (:func:`~bearingtwin.signal.speed.tachometer_speed`: its pulses per revolution confirmed by the record's shaft
    series), and a note saying so; or None and why it gives none."""
    if not (np.isfinite(signal).all() and np.isfinite(pulses).all()):
        return None, f"its tachometer channel {name} is not read: the record holds samples with no value"
    reading = tachometer_speed(pulses, signal, fs)
    if reading.rpm is None:
        return None, f"its tachometer channel {name} {reading.describe_unconfirmed()}"
    count = f"{reading.per_turn} pulse{'s' * (reading.per_turn > 1)}"
    return reading.rpm, (f"shaft speed {reading.rpm:.0f} rpm from the tachometer channel {name}: {count} per "
                         "revolution, the one count at which the record's shaft series stands clearly highest "
                         f"({reading.standing} of its first {HARMONICS} harmonics standing)")


def pulses_off_note(name: str, pulses: np.ndarray, fs: float, rpm: float) -> str | None:
    """A note where a tachometer channel's pulses give no speed within :data:`~bearingtwin.signal.speed.SEARCH` of
    the stated ``rpm`` at any whole number of pulses per revolution (where
    :func:`~bearingtwin.signal.speed.tachometer_profile` reads none): a speed stated far off, or a tachometer on
    another shaft; None where they give one, or the channel holds too few pulses to say."""
    times = pulse_times(pulses, fs)
    if times.size < 3:
        return None
    rate = pulse_rate(times)
    if pulses_per_turn(rate, rpm) is not None:
        return None
    per_turn = max(1, round(rate / (rpm / 60.0)))  # the nearest count, to say what speed the pulses give
    return (f"the tachometer channel {name} pulses {rate:.4g} times a second, {60.0 * rate / per_turn:.0f} rpm at "
            f"{per_turn} pulse{'s' * (per_turn > 1)} per revolution, not near the stated {rpm:g} rpm at any whole "
            "number of pulses per revolution: check the stated speed, or whether the tachometer watches another shaft")


def refuse_a_label_the_file_contradicts(raw: RawRecord, state: str | None, key: str) -> None:
    """Refuse a bearing state given (as ``key``) to a file that states one no label fits (a HUST export's combined
    inner and outer race damage): the file would pass as that state's."""
    stated = raw.meta.get("unlabelled_state")
    if state is not None and stated:
        raise BearingTwinError(f"{raw.path}: {key}={state} given, but the file states {stated}, none of "
                               f"{', '.join(FAULTS)}")


def named_rate_note(meta: Mapping, fs: float | None, key: str = "fs") -> str | None:
    """A note where a rate given as ``key`` differs from the one a data set's naming convention gives the file
    (``meta["named_rate"]``: a CWRU file's ``12k_`` / ``48k_``, its catalogue's for a numbered file): a convention,
    not the file's own statement, so not refused on reading; a rate that contradicts it is more likely a typo than a
    mislabelled file, and a diagnosis and the twin refuse it where the shaft line bears the name's rate out
    (:func:`bearingtwin.signal.sampling_rate.rate_against_name_error`)."""
    named = meta.get("named_rate")
    if fs is None or not named or abs(float(fs) / named["hz"] - 1.0) <= FS_FLOAT_NOISE:
        return None
    return f"{key}={float(fs):g} Hz given, where {named['by']} {named['hz']:g} Hz"


def file_bearing(meta: Mapping, channel: str | None) -> str | None:
    """The ``conf/bearing`` name of the bearing a file was recorded on, as it names it: its own (a CWRU fault
    record's by its name's end, a HUST export's ER-16K, ``bearingtwin-simulate``'s), else, for a file of several
    bearings' accelerometers (a healthy CWRU record: DE on the SKF 6205, FE on the 6203), the one under ``channel``;
    None where it names none (a CWRU label such as ``IR007_0`` gives no end, unless the variables it holds are a
    catalogued record's: the user's to say)."""
    named = meta.get("bearing") or meta.get("bearing_by_channel", {}).get(channel)
    return None if named is None else str(named)


def speed_setting(recording: Recording, key: str) -> str | None:
    """``key``, the setting that gave ``recording`` its speed, where a setting did (or the speed is a data set's
    nominal one, which a setting replaces); None where the file measured it: a refused rate names it too."""
    return key if recording.meta.get("rpm_origin") in ("config", "nominal") else None


STAMP_UNIT_FACTORS = (1e-6, 1e-3, 1e3, 1e6)
"""Ratios of a given rate to the one a file's time stamps give that say the stamps are in another unit than their
column's name states (seconds under a header of ms or µs, milliseconds under one of s): such a rate is read, and said
to be, where any other ratio is a contradiction."""


def restamped(raw: RawRecord, fs: float | None) -> float | None:
    """The factor (:data:`STAMP_UNIT_FACTORS`) by which a given rate ``fs`` stands from the rate ``raw``'s time stamps
    give, within their tolerance; None where the rate is not the stamps' or stands by no such factor."""
    if fs is None or raw.fs is None or raw.fs_origin != "time column":
        return None
    return next((factor for factor in STAMP_UNIT_FACTORS if abs(fs / (raw.fs * factor) - 1.0) <= raw.fs_tolerance), None)


def resolve_fs(raw: RawRecord, fs: float | None, key: str = "fs") -> float:
    """The sampling rate to use: the user's (given as setting ``key``), checked against the file's within
    ``raw.fs_tolerance`` unless the file's is only declared, or is its time stamps' and the user's stands a factor of
    a thousand or a million from it (:func:`restamped`)."""
    if fs is None:
        if raw.fs is None:
            why = f": {raw.fs_unread}" if raw.fs_unread else ""
            raise BearingTwinError(f"{raw.path}: the file does not state its sampling rate{why}; give {key}=<Hz>")
        return float(raw.fs)
    fs = positive_number(fs, key, "Hz")
    if (raw.fs is not None and raw.fs_origin != "declared" and abs(fs / raw.fs - 1.0) > raw.fs_tolerance
            and restamped(raw, fs) is None):
        origin = {"file": "stored in it", "header": "in its header"}.get(raw.fs_origin, f"from its {raw.fs_origin}")
        raise BearingTwinError(f"{raw.path}: {key}={fs:g} Hz contradicts the file's {raw.fs:g} Hz ({origin})")
    return fs


def resolve_fact(raw: RawRecord, name: str, from_file, from_user, key: str | None = None):
    """The user's value of a fact the file may state too (``key``: the setting it came from, as the message names
    it; ``name`` by default); one that contradicts the file's is refused."""
    if from_user is None:
        return from_file
    if from_file is not None and from_user != from_file:
        raise BearingTwinError(f"{raw.path}: {key or name}={from_user!r} contradicts the file's {name}={from_file!r}")
    return from_user


SPEED_TOLERANCE = 0.01
"""How far (relative) two speeds of one machine may lie apart and still be the same: a motor's speed drifts by a
few rpm within a record and between its readings, while a load step moves it by more than 1 % (the CWRU motor's
nominal speeds lie 1.0-1.4 % apart), and 1 % moves a defect's tenth harmonic by a tenth of its spacing."""


def same_speed(a_rpm: float, b_rpm: float) -> bool:
    """Whether two shaft speeds are the same within :data:`SPEED_TOLERANCE` (relative to the second)."""
    return abs(a_rpm / b_rpm - 1.0) <= SPEED_TOLERANCE


SLOW_RPM = 120.0
"""A given speed below this is noted as possibly the shaft's frequency in Hz (a motor's 29.2 Hz typed for 1750 rpm):
slow bearings exist (a wind turbine's main shaft turns at 10-20 rpm), so it is said, not refused."""


def refuse_one_speed_for_a_varying_run(raw: RawRecord, rpm, rpm_key: str = "rpm") -> None:
    """Refuse a speed given for a file that states its speed varies (HUST's VS_ runs): a run-up read at one speed puts
    every line in the wrong place."""
    if rpm is not None and raw.meta.get("no_speed"):
        raise BearingTwinError(f"{raw.path}: {rpm_key}={rpm} given, but the file is {raw.meta['no_speed']}: no one "
                               "speed describes it")


def resolve_speed(raw: RawRecord, rpm: float | None, key: str, notes: list[str],
                  read_speed: Callable[[float], tuple[float | None, str]] | None = None) -> float | None:
    """The shaft speed: the file's measured one where it has one and a given ``rpm`` (setting ``key``) agrees with it
    within :data:`SPEED_TOLERANCE` (said in ``notes`` when they differ), else the given one. A given speed the file's
    contradicts is read where the record itself bears it out against the file's (``read_speed``: what the record
    reads around a stated speed, :func:`speed_reader`; a logger may stamp a nameplate's speed), refused otherwise."""
    if rpm is not None and rpm < SLOW_RPM and raw.rpm is None:
        notes.append(f"{key}={rpm:g} is a shaft at {rpm / 60:.3g} Hz; if {rpm:g} is the shaft's frequency in Hz, give "
                     f"{key}={rpm * 60:g}")
    if rpm is None or raw.rpm is None or rpm == raw.rpm:
        return raw.rpm if rpm is None else rpm
    if same_speed(rpm, raw.rpm):
        notes.append(f"{key}={rpm:g} given; the file's measured {raw.rpm:g} rpm read")
        return float(raw.rpm)
    read, source = read_speed(rpm) if read_speed is not None else (None, "")
    # Sought around the file's speed too, which must read the given speed or none: a shaft at twice, half or a third
    # of the given speed puts some of its harmonics where the given one's would stand, and the series sought around
    # the given speed reads it there.
    at_file, file_source = read_speed(raw.rpm) if read_speed is not None else (None, "")
    if read is not None and same_speed(read, rpm) and (at_file is None or same_speed(at_file, rpm)):
        notes.append(f"{key}={rpm:g} given against the file's {raw.rpm:g} rpm: {source} reads {read:.0f} rpm, so the "
                     "given speed is read")
        return rpm
    if at_file is not None:  # what the record reads near the speed its file states, for the message
        read, source = at_file, file_source
    reading = (f"; {source} reads {read:.0f} rpm" if read is not None else
               "; no speed could be read off the record itself to decide between them (a tachometer channel's, or "
               "the shaft's harmonic series' away from the supply's lines)" if read_speed is not None else "")
    raise BearingTwinError(f"{raw.path}: {key}={rpm!r} contradicts the file's rpm={raw.rpm!r} "
                           f"(more than {SPEED_TOLERANCE:.0%} apart){reading}")


def speed_reader(raw: RawRecord, channel: str, signal: np.ndarray,
                 fs: float) -> Callable[[float], tuple[float | None, str]]:
    """What the record itself reads as its speed around a stated one (rev/min), and what it was read from: a
    tachometer's pulses recorded beside ``channel`` (:func:`tachometer_channel`) where they read one, else the shaft's
    harmonic series of ``signal`` (:func:`~bearingtwin.signal.speed.speed_profile`); None where neither does."""
    tachometer = tachometer_channel(raw, channel)

    def read(rpm: float) -> tuple[float | None, str]:
        if not np.isfinite(signal).all():  # a record with gaps is read whole only once they are bridged
            return None, ""
        if tachometer is not None:  # the shaft itself, where its pulses read a speed; none where they do not
            source = f"the tachometer channel {tachometer}"
            if not np.isfinite(raw.channels[tachometer]).all():
                return None, source
            return tachometer_profile(raw.channels[tachometer], fs, rpm, source=source).read_rpm, source
        return speed_profile(signal, fs, rpm).read_rpm, "the shaft's harmonic series"

    return read


def time_column_seconds(name: str) -> float | None:
    """The unit in seconds of a column of time stamps called ``name`` (1e-3 for ``time_ms``, 1e-6 for ``t [µs]``),
    None for another column."""
    match = _TIME_COLUMN.fullmatch(name.strip().rsplit(".", 1)[-1])  # a struct's field: info.time
    if match is None:
        return None
    unit = (match["suffix"] or match["bracketed"] or match["worded"] or "s").lower()
    return next(seconds for start, seconds in _TIME_UNIT_SECONDS if unit.startswith(start))


def unit_in_name(name: str) -> str:
    """The unit a channel's name states at its end, in brackets (``acc (m/s2)`` -> ``m/s^2``, ``U [V]`` -> ``V``),
    after "in" (an acceleration unit: ``a in m/s²``) or after an underscore (an acceleration unit: ``acc_g``,
    ``a_m/s2``, ``accel_ms2``, ``acc_m_s2``; a velocity's or displacement's: ``vel_mm_s``, ``vel_ips``, ``gap_um``),
    acceleration units in their canonical spelling; where it states none, the word calling it a velocity or a
    displacement (``Velocity``: :func:`~bearingtwin.data.units.quantity_word`), else "". A name's own letters are no
    unit (``signal``, ``gear``): only a separate word is read as one."""
    return split_unit(name)[1]


def split_unit(name: str) -> tuple[str, str]:
    """A channel's name without the unit it states at its end (``DE (g)`` -> ``DE``, ``acc_g`` -> ``acc``), and
    that unit (:func:`unit_in_name`); the name as it is and "" when it states none."""
    name, repeated = re.fullmatch(r"(.*?)(\.\d+)?", name).groups(default="")  # a repeated header's "acc (g).1" too
    match = _UNIT_IN_NAME.fullmatch(name)
    if match is None:
        # "acc_g", "acc_m_s2" (the unit's own "/" written "_"); "vel_mm_s", "vel_ips" too, a velocity or a
        # displacement being what must not pass for an acceleration; "ch_1" or "acc_x" states none.
        words = name.split("_")
        for length in (2, 1):
            written = "/".join(words[-length:]) if len(words) > length else ""
            unit = acceleration_unit(written) or (written if quantity_of(written) in INTEGRATED_QUANTITIES else None)
            if unit:
                return "_".join(words[:-length]) + repeated, unit
        return name + repeated, quantity_word(name)
    if match["worded"]:  # "a in m/s²"; "speed in rig 2" states no unit
        unit = acceleration_unit(match["worded"]) or ""
    else:  # "ch1 (left)" states none
        unit = acceleration_unit(match["unit"]) or (match["unit"] if quantity_of(match["unit"]) else "")
    # A velocity's channel that names no unit ("Velocity", "vel (pump 2)") is named so by its word: not read as an
    # acceleration in the model's unit.
    return (match["name"] + repeated, unit) if unit else (name + repeated, quantity_word(name))


def _time_stamps(path: Path, columns: dict[str, np.ndarray], notes: list[str], fs: float | None = None,
                 variables: bool = False, clock: str | None = None) -> tuple[dict[str, np.ndarray], float | None, str]:
    """The channels without a column of time stamps, the rate those stamps give (said in ``notes``): ``fs``
    when the file states one already (the stamps must agree with it), None when they are printed too coarsely to
    give one, and then why (:attr:`RawRecord.fs_unread`; "" otherwise). ``variables``: the columns are a .mat's or
    .npz's variables, where a name alone (``T``, a temperature) does not make time stamps: only a vector as long as
    the other channels that rises does. ``clock``: a column of a logger's clock times (seconds of their day), the
    stamps whatever its name."""
    def stamps(name: str) -> bool:
        if time_column_seconds(name) is None or np.squeeze(columns[name]).ndim != 1:
            return False
        if not variables:
            return True
        vector = np.squeeze(columns[name])
        others = {np.size(values) for key, values in columns.items() if key != name}
        return vector.size > 1 and (not others or vector.size in others) and bool(np.all(np.diff(vector) > 0))

    time_name = clock or next((name for name in columns if stamps(name)), None)
    if time_name is None:
        return columns, fs, ""
    columns = dict(columns)
    time_s = np.squeeze(np.asarray(columns.pop(time_name), dtype=np.float64))
    # A clock's seconds of the day start again at midnight; a column of time stamps counts in its unit.
    time_s = np.unwrap(time_s, period=86400.0) if clock else time_column_seconds(time_name) * time_s
    if coarse_stamps(time_s):
        unread = (f"the {time_name} stamps repeat, printed coarser than the sampling period (to "
                  f"{_printed_unit_s(time_s):g} s): the rate is not read from them; they span about "
                  f"{(time_s.size - 1) / np.ptp(time_s):.0f} rows a second")
        notes.append(unread + ("" if fs is not None else " (give it: fs)"))
        return columns, fs, unread
    measured = fs_from_time_column(time_s, str(path), time_name)
    if fs is not None:
        if abs(measured / fs - 1.0) > FS_RELATIVE_TOLERANCE:
            raise BearingTwinError(f"{path}: its sampling rate, {fs:g} Hz, contradicts its time stamps {time_name}, "
                                   f"{measured:.6g} Hz")
        return columns, fs, ""
    notes.append(f"sampling rate {measured:.6g} Hz from the time stamps {time_name}")
    return columns, measured, ""


def _unnamed_time_stamps(channels: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], float | None]:
    """A headerless table's columns without its first where that one is time stamps in seconds (``0.0000000,
    -0.0721`` rows: two columns, the first rising in steps within 1 % of one another to a rate of
    :data:`LOWEST_FS_HZ` or more), and the rate they give; the columns as they are and None otherwise. A vibration
    channel never rises throughout."""
    if len(channels) < 2:
        return channels, None
    first, *rest = channels
    steps = np.diff(channels[first])
    if steps.size < 2 or not np.all(np.isfinite(steps)) or np.any(steps <= 0):
        return channels, None
    typical = float(np.median(steps))
    if np.max(np.abs(steps / typical - 1)) > 0.01:
        return channels, None
    try:
        rate = fs_from_time_column(channels[first], "", "0")
    except BearingTwinError:  # too slow for stamps in seconds (another unit, or no stamps): not guessed
        return channels, None
    return {name: channels[name] for name in rest}, rate


def fs_from_time_column(time_s: np.ndarray, source: str, column: str = "time") -> float:
    """Sampling rate in Hz from a time column: samples per second over the whole span.

    The span rather than one step is used because exported time stamps are rounded to a
    few decimals, which makes single steps jitter by percent while the span stays exact up to
    the rounding of its two ends. A whole number of Hz within that rounding is the rate: a
    12 kHz record stamped to five decimals spans 11999.98 samples per second, and it is read
    at 12000 Hz, as a file's stated rate would be (another rate would need resampling).
    """
    time_s = np.asarray(time_s, dtype=np.float64)
    if time_s.size < 2:
        raise BearingTwinError(f"{source}: the {column} column holds {time_s.size} "
                               f"value{'' if time_s.size == 1 else 's'}: a sampling rate needs at least two")
    if not np.all(np.isfinite(time_s)):
        row = int(np.argmax(~np.isfinite(time_s)))
        raise BearingTwinError(f"{source}: the {column} column holds {time_s[row]:g} at data row {row + 1}: a sampling "
                               "rate needs every stamp finite")
    steps = np.diff(time_s)
    if np.any(steps <= 0):  # a stamp that goes back before one that repeats (stamps printed coarsely repeat)
        row = int(np.argmax(steps < 0) if np.any(steps < 0) else np.argmax(steps == 0)) + 1
        raise BearingTwinError(f"{source}: the {column} column does not increase at data row {row + 1}")
    typical = float(np.median(steps))
    # Stamps printed to a few decimals make the steps take two or three values a printed unit apart (2e-5 and
    # 3e-5 s at 48 kHz and five decimals): that unit is allowed beside a step, a missing row is not.
    near = np.unique(steps[(steps > 0.5 * typical) & (steps < 2.0 * typical)])
    spacing = np.diff(near)
    unit = float(spacing[spacing > 1e-3 * typical].min()) if np.any(spacing > 1e-3 * typical) else 0.0
    uneven = (steps > 1.5 * typical + unit) | (steps < 0.5 * typical - unit)
    if np.any(uneven):
        row = int(np.argmax(uneven)) + 1
        raise BearingTwinError(f"{source}: the {column} column steps {steps[row - 1]:.6g} s at data row {row + 1}, not "
                               f"its usual {typical:.6g} s: rows missing or merged, so no single sampling rate")
    span_s = float(time_s[-1] - time_s[0])
    fs = (time_s.size - 1) / span_s
    # Either end rounded by half the printed unit; float arithmetic's own error where the stamps carry full precision.
    # Only a whole number alone within that is the rate: a short record's rounding may allow several.
    allowed = fs * (_printed_unit_s(time_s) / span_s + 1e-9)
    whole = range(math.ceil(fs - allowed), math.floor(fs + allowed) + 1)
    if len(whole) == 1:
        fs = float(whole[0])
    if fs < LOWEST_FS_HZ:
        hint = ": if it counts milliseconds, head it time_ms" if time_column_seconds(column) == 1.0 else ""
        raise BearingTwinError(f"{source}: the {column} column gives {fs:g} samples per second, too slow for a "
                               f"vibration record{hint}")
    return fs


def coarse_stamps(time_s: np.ndarray) -> bool:
    """Whether time stamps were printed in a unit longer than the sampling period (a 12 kHz record stamped to
    four decimals), so that they repeat every few rows, never going back: they state no rate (a lost or a doubled
    row would not show), and exact stamps never repeat."""
    time_s = np.asarray(time_s, dtype=np.float64)
    if time_s.size < 2 or not np.all(np.isfinite(time_s)):
        return False
    steps, span_s = np.diff(time_s), float(time_s[-1] - time_s[0])
    return bool(span_s > 0 and np.any(steps == 0) and np.all(steps >= 0)
                and _printed_unit_s(time_s) > span_s / steps.size * (1 + 1e-6))


def _printed_unit_s(time_s: np.ndarray) -> float:
    """The unit the stamps were printed in (1e-5 s for five decimals), 0 when they carry full precision."""
    ends = np.concatenate([time_s[:1000], time_s[-1000:]])
    for decimals in range(10):
        scaled = ends * 10.0**decimals
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-3 + 8 * np.finfo(float).eps * np.abs(scaled)):
            return 10.0**-decimals
    return 0.0


def _float_channels(path: Path, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Numeric arrays as float64 channels: 1-D as is, 2-D as (channels, samples)."""
    channels: dict[str, np.ndarray] = {}
    for name, array in arrays.items():
        array = np.asarray(array)
        which = f"array {name!r}" if name else "its array"  # a .npy's one array has no name
        if not (np.issubdtype(array.dtype, np.number) or array.dtype == bool) or np.iscomplexobj(array):
            raise BearingTwinError(f"{path}: {which} is not real numeric (dtype {array.dtype})")
        array = np.squeeze(array)
        if array.ndim == 1:
            channels[name or "0"] = np.ascontiguousarray(array, dtype=np.float64)  # a copy only of another type
        elif array.ndim == 2:
            if array.shape[0] == array.shape[1]:
                raise BearingTwinError(f"{path}: {which} has shape {array.shape}, so which axis is time is not "
                                       "clear; store it as channels x samples or samples x channels")
            # A record holds more samples than channels: samples x channels (a MATLAB or spreadsheet column per
            # channel) as well as channels x samples.
            for row, values in enumerate(array if array.shape[0] < array.shape[1] else array.T):
                channels[f"{name}[{row}]" if name else str(row)] = values.astype(np.float64)
        else:
            raise BearingTwinError(f"{path}: {which} has shape {array.shape}; expected 1-D or 2-D (channels and samples)")
    if not channels:
        raise BearingTwinError(f"{path}: holds no signal array")
    return channels


def _scalar(path: Path, name: str, value) -> float | bool:
    try:
        if np.asarray(value).dtype == bool:  # a logical is no number: kept so that a rate given as true is refused
            return bool(np.asarray(value).reshape(()))
        return float(np.asarray(value).reshape(()))
    except (TypeError, ValueError):
        shown = " ".join(repr(value).split())  # a MATLAB struct's repr runs over many lines
        raise BearingTwinError(f"{path}: {name} must be a single number, got {shown[:120]}") from None


def _read_npy(path: Path) -> RawRecord:
    with open(path, "rb") as handle:
        if handle.read(6) != b"\x93NUMPY":  # numpy would take any other file for a pickle
            raise BearingTwinError(f"{path}: not a NumPy .npy file (it does not start with the .npy header)")
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise BearingTwinError(f"{path}: not a readable .npy file ({error})") from None
    notes = _counts_notes({"": array})
    return RawRecord(str(path), "npy", _float_channels(path, {"": array} if array.ndim == 2 else {"0": array}),
                     meta={"notes": notes} if notes else {})


def _counts_notes(arrays: dict[str, np.ndarray]) -> list[str]:
    """A note on the signal arrays held as integers: a converter's counts, read as they are (no scale is applied,
    whatever unit the file states), so their level is no physical one."""
    counts = {name: array.dtype.name for name, array in arrays.items() if np.issubdtype(np.asarray(array).dtype, np.integer)}
    if not counts:
        return []
    which = ", ".join(f"{name} ({dtype})" if name else dtype for name, dtype in counts.items())
    return [f"integer samples ({which}): converter counts, read as they are, which state no physical unit until "
            "scaled by the sensor's sensitivity"]


def _split_facts(path: Path, items: dict[str, np.ndarray]) -> tuple[dict, dict]:
    """Separate size-1 entries and strings (facts about the record) from the signal arrays.

    A MATLAB struct's fields count as entries of their own, named ``<struct>.<field>``; a cell
    array's contents are facts, as text.
    """
    facts, arrays = {}, {}
    for name, value in items.items():
        value = np.asarray(value)
        if value.size == 0:  # MATLAB's [] or {}: nothing to read (a struct's unset field, a placeholder)
            facts[name] = "empty"
        elif value.dtype.names and value.size == 1:  # a struct (scipy: a record array of one element)
            fields = {f"{name}.{field}": value[field].reshape(-1)[0] for field in value.dtype.names}
            more_facts, more_arrays = _split_facts(path, fields)
            facts.update(more_facts)
            arrays.update(more_arrays)
        elif value.dtype.names:
            facts[name] = f"a MATLAB struct array of shape {value.shape}, not read"
        elif value.dtype.kind == "O":  # a cell array
            texts = [" ".join(str(np.squeeze(item)).split()) for item in value.reshape(-1)]
            facts[name] = texts[0] if len(texts) == 1 else texts
        elif value.dtype.kind in "US":
            facts[name] = str(value.reshape(-1)[0]) if value.size == 1 else value.reshape(-1).tolist()
        elif value.size == 1:
            facts[name] = _scalar(path, name, value)
        else:
            arrays[name] = value
    return facts, arrays


_FACTS = {"fs": ("fs", "fshz", "samplerate", "sampleratehz", "samplingrate", "samplingratehz", "samplingfrequency",
                  "samplefrequency", "sr"),
          "rpm": ("rpm", "speedrpm", "shaftrpm"), "fault": ("fault",), "unit": ("unit", "units")}
"""Each fact a file may state, and the names it may go by (in any case, with or without ``_``, ``-`` or spaces:
``SampleRate``, ``sampling_rate``; also as a struct's field)."""


def _fact_name(name: str) -> str:
    """A variable's name as :data:`_FACTS` lists it: lower case, without separators."""
    return re.sub(r"[\s_\-]", "", name).lower()


SIMULATOR_MARK = "bearingtwin-simulate"
"""The ``made_by`` fact of a record ``bearingtwin-simulate`` wrote."""


def save_simulated_record(path: Path, recording: Recording, channels: np.ndarray, channel_names, facts: dict) -> None:
    """Write a record ``bearingtwin-simulate`` made, as :func:`read_raw` reads it back: the sensor's channel
    (``signal``), every sensor's (``channels``, a row per one of ``channel_names``), the facts a reader needs beside
    the samples (rate, speed, state, sensor, unit) and ``facts`` (the bearing, whose defect lines witness the rate; the
    settings no sample shows), marked :data:`SIMULATOR_MARK`. Written whole or not at all
    (:func:`~bearingtwin.storage.write_atomic`: a full disk raises ``OSError`` and leaves an earlier file there as it
    was)."""
    # By a stream: numpy adds ".npz" to a name that ends ".NPZ"; through a link, to the file it names.
    write_atomic(Path(path).resolve(), lambda stream: np.savez(
        stream, signal=recording.signal, channels=channels, channel_names=np.array(channel_names), fs=recording.fs,
        rpm=recording.rpm, fault=recording.fault, sensor=recording.channel, unit=recording.unit,
        made_by=SIMULATOR_MARK, **facts))


SIMULATED_RATE = "simulation"
"""``fs_origin`` of such a record's rate: exact by construction, and the twin has no shaft line (no residual
unbalance) to check it by, so no rate check reads it (one had taken its balls' passing series for the shaft's)."""
RATE_NOT_CHECKED_SIMULATED = ("sampling rate not checked: bearingtwin-simulate made this record at exactly its stated "
                              "rate (the twin has no shaft line to check a rate by)")


def _facts_to_record(path: Path, fmt: str, facts: dict, arrays: dict) -> RawRecord:
    found = {fact: _named_fact(facts, names, fact) for fact, names in _FACTS.items()}
    fs = None if found["fs"] is None else positive_number(found["fs"][1], found["fs"][0], "Hz", f"{path}: ")
    notes = []
    arrays, fs_from_stamps, _ = _time_stamps(path, arrays, notes, fs, variables=True)  # rising: never coarse
    notes += _counts_notes(arrays)
    if fs is None and fs_from_stamps is not None:
        fs, fs_origin = fs_from_stamps, "time column"
    else:
        fs_origin = "file" if fs is not None else ""
    if fs_origin == "file" and facts.get("made_by") == SIMULATOR_MARK:
        fs_origin = SIMULATED_RATE
    rpm = None if found["rpm"] is None else positive_number(found["rpm"][1], found["rpm"][0], "rev/min", f"{path}: ")
    fault = None if found["fault"] is None else found["fault"][1]
    if fault is not None and fault not in FAULTS:
        raise BearingTwinError(f"{path}: fault {fault!r} is not a bearing state ({', '.join(FAULTS)})")
    used = {entry[0] for entry in found.values() if entry is not None} | {"made_by"} & set(facts)
    # Numbers under names not read as a fact (a .mat's fsamp, n_rpm): where a rate or speed is missing, named with it.
    numbers = ", ".join(f"{key}={value:g}" for key, value in facts.items()
                        if key not in used and is_finite_number(value) and value > 0)
    unread = f"it holds {numbers}, under names not read as one" if numbers else ""
    names, table = facts.get("channel_names"), arrays.get("channels")  # bearingtwin-simulate's: a row per sensor
    if isinstance(names, list) and np.ndim(table) == 2 and len(names) in np.shape(table):
        rows = table if len(table) == len(names) else np.transpose(table)
        arrays = {**{name: values for name, values in arrays.items() if name != "channels"}, **dict(zip(names, rows))}
        used.add("channel_names")
    return RawRecord(
        str(path),
        fmt,
        _float_channels(path, arrays),
        fs=fs,
        fs_origin=fs_origin,
        fs_tolerance=FS_RELATIVE_TOLERANCE if fs_origin == "time column" else FS_FLOAT_NOISE,
        rpm=rpm,
        fault=fault,
        unit="" if found["unit"] is None else str(found["unit"][1]),
        meta={**{k: v for k, v in facts.items() if k not in used}, **({"notes": notes} if notes else {}),
              **({"speed_unread": unread} if rpm is None and unread else {})},
        default_channel="signal" if fmt == "npz" else None,
        fs_unread="" if fs is not None else unread,
    )


def _named_fact(facts: dict, names: tuple[str, ...], fact: str) -> tuple[str, object] | None:
    """The entry (its name, its value) stating a fact: by one of ``names`` in any case, else as the one struct
    field of that name (``info.fs``) whose value can state it (a field ``info.fault`` may hold free text)."""
    for key, value in facts.items():
        if _fact_name(key) in names:
            return key, value
    fields = [(key, value) for key, value in facts.items()
              if _fact_name(key.rsplit(".", 1)[-1]) in names and _can_state(fact, value)]
    return fields[0] if len(fields) == 1 else None


def _can_state(fact: str, value) -> bool:
    if fact in ("fs", "rpm"):
        return is_finite_number(value) and value > 0
    return value in FAULTS if fact == "fault" else isinstance(value, str)


def _read_npz(path: Path) -> RawRecord:
    with open(path, "rb") as handle:
        if handle.read(2) != b"PK":  # numpy would take any file that is no zip archive for a pickle, and say so
            raise BearingTwinError(f"{path}: not a NumPy .npz archive (it is no zip archive, as numpy.savez writes)")
    try:
        with np.load(path, allow_pickle=False) as archive:
            items = {name: archive[name] for name in archive.files}
    except (ValueError, OSError, EOFError) as error:
        raise BearingTwinError(f"{path}: not a readable .npz archive ({error})") from None
    facts, arrays = _split_facts(path, items)
    return _facts_to_record(path, "npz", facts, arrays)


def _load_mat(path: Path) -> dict:
    import h5py
    import scipy.io

    try:
        # MATLAB 7.3 (save -v7.3, and any file over 2 GB) is HDF5 after a header of MATLAB's; h5py writes HDF5 alone.
        if h5py.is_hdf5(path):
            return _load_mat_hdf5(path)
        variables = scipy.io.loadmat(path)
    except (ValueError, OSError, TypeError, NotImplementedError) as error:
        raise BearingTwinError(f"{path}: not a readable MATLAB file ({error})") from None
    return {name: value for name, value in variables.items() if not name.startswith("__")}


def _load_mat_hdf5(path: Path) -> dict:
    """The variables of a MATLAB 7.3 file, as :func:`scipy.io.loadmat` gives those of older ones (scipy reads
    no 7.3 file; h5py reads their HDF5, and MATLAB's own conventions are undone here): arrays in MATLAB's
    shape (HDF5 stores them transposed), text decoded from its UTF-16 codes, a struct's fields as
    ``<struct>.<field>``, a cell array's contents as text. An HDF5 file without MATLAB's header (``h5py.File``'s)
    is read alike: its arrays' orientation is told as any file's is (the longer axis is time)."""
    import h5py

    def value(item):
        kind = item.attrs.get("MATLAB_class", b"").decode()
        data = item[()]
        if kind == "char":
            return np.array("".join(map(chr, data.T.reshape(-1))))
        if kind == "cell":
            return np.array([" ".join(str(np.squeeze(value(item.file[ref]))).split()) for ref in data.T.reshape(-1)],
                            dtype=object)
        if item.attrs.get("MATLAB_empty", 0):
            return np.zeros((0,))
        if data.dtype.names == ("real", "imag"):  # MATLAB's complex numbers, which no channel may be
            data = data["real"] + 1j * data["imag"]
        return np.asarray(data).T.astype(bool) if kind == "logical" else np.asarray(data).T

    variables = {}

    def collect(prefix: str, group) -> None:
        for name, item in group.items():
            if name.startswith("#"):  # MATLAB's store of the objects cells refer to
                continue
            if isinstance(item, h5py.Group):
                collect(f"{prefix}{name}.", item)
            else:
                variables[prefix + name] = value(item)

    with h5py.File(path, "r") as file:
        collect("", file)
    return variables


def _read_generic_mat(path: Path, variables: dict) -> RawRecord:
    facts, arrays = _split_facts(path, variables)
    return _facts_to_record(path, "mat", facts, arrays)


def _wav_shortfall_bytes(path: Path) -> int:
    """How many bytes a RIFF file lacks of the size its header states (0 for another container, e.g. RF64)."""
    with open(path, "rb") as file:
        head = file.read(8)
    if len(head) < 8 or head[:4] != b"RIFF":
        return 0
    return int.from_bytes(head[4:8], "little") + 8 - path.stat().st_size


def _read_wav(path: Path) -> RawRecord:
    import scipy.io.wavfile

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fs, data = scipy.io.wavfile.read(path)
        except (ValueError, OSError, EOFError) as error:
            raise BearingTwinError(f"{path}: not a readable .wav file ({error})") from None
    # scipy reads a truncated file in part and only warns: the samples before the cut would pass for the record. It
    # warns as well where a writer overstates the RIFF size by its 8-byte header or a pad byte, the data all there.
    truncated = next((warning.message for warning in caught if str(warning.message).startswith("Reached EOF")), None)
    if truncated is not None and _wav_shortfall_bytes(path) > 16:
        raise BearingTwinError(f"{path}: not a readable .wav file, truncated ({truncated})")
    notes = [f"reading it: {warning.message}" for warning in caught if warning.message is not truncated]
    columns = data if data.ndim == 2 else data[:, None]
    offset, full_scale = 0.0, 1.0
    if np.issubdtype(data.dtype, np.integer):  # PCM counts; the unsigned 8-bit format is offset by half its range
        stored, bits = data.dtype.name, 8 * data.dtype.itemsize
        offset = 2.0 ** (bits - 1) if np.issubdtype(data.dtype, np.unsignedinteger) else 0.0
        full_scale = 2.0 ** (bits - 1)
        notes.append(f"integer samples ({stored}, as scipy reads them) scaled to the recorder's full scale "
                     f"(1.0){FULL_SCALE_HINT}")
    # One channel at a time, in place: a long recording of many channels is held once as float64 beside its counts,
    # not as several whole copies (a 400 MB file of 16-bit counts took 3.2 GB).
    channels = {}
    for index in range(columns.shape[1]):
        values = columns[:, index].astype(np.float64)
        values -= offset
        values /= full_scale
        channels[str(index)] = values
    del data, columns
    return RawRecord(str(path), "wav", _float_channels(path, channels), fs=float(fs), fs_origin="header",
                     meta={"notes": notes})


def _read_csv(path: Path) -> RawRecord:
    """Columns of numbers (:func:`~bearingtwin.data.csv_file.read_csv_table`), optionally under a header row of
    names, which may state each column's unit in brackets (``acc (g)``) or in a row of units below it. A column of a
    logger's clock times gives the time stamps (beside it, a column of its dates is passed over). Without a header
    the longer axis is time, as in the other formats (one row of numbers is one channel)."""
    from bearingtwin.data.csv_file import read_csv_table

    table = read_csv_table(path)
    line, noted = rate_in_notes(path, table.preamble, table.decimal) or (None, None)
    above = "the header" if table.names is not None else "the numbers"
    read_in_notes = [] if noted is None else [f"sampling rate {noted:g} Hz from the note {line!r} above {above}"]
    note_unread = "" if line is None or noted is not None else (
        f"its note {line!r} writes the rate so that it reads as more than one number (a thousands separator, or a "
        f"decimal mark other than its numbers' '{table.decimal}')")
    noted_rpm, noted_unit, said = speed_and_unit_in_notes(table.preamble, table.decimal)
    read_in_notes += said
    if table.names is None:
        channels, stamped = _unnamed_time_stamps(_float_channels(path, {"": table.values}))
        if stamped is not None and noted is not None and abs(stamped / noted - 1.0) > FS_RELATIVE_TOLERANCE:
            raise BearingTwinError(f"{path}: its sampling rate, {noted:g} Hz, contradicts its time stamps (column 0), "
                                   f"{stamped:.6g} Hz")
        origin = "header" if noted is not None else "time column" if stamped is not None else ""
        if origin == "time column":
            read_in_notes.append(f"column 0 rises in even steps, with no header to name it: read as time stamps in "
                                 f"seconds, sampling rate {stamped:.6g} Hz")
        return RawRecord(str(path), "csv", channels, fs=noted if noted is not None else stamped, fs_origin=origin,
                         fs_tolerance=FS_RELATIVE_TOLERANCE if origin == "time column" else FS_FLOAT_NOISE,
                         meta={"notes": read_in_notes} if read_in_notes else {},
                         fs_unread=note_unread, rpm=noted_rpm, unit=noted_unit)
    # A noted rate is exact where time stamps are printed to a few decimals: they must agree with it.
    notes = list(table.notes) + read_in_notes
    passed_over = table.clock[1:] + table.dates  # a logger's dates beside its clock times; a second clock
    if passed_over:
        notes.append(f"column{'s' * (len(passed_over) > 1)} {', '.join(passed_over)} passed over: the clock times "
                     f"of {table.clock[0]} are the time stamps")
    columns = {name: values for name, values in zip(table.names, table.values.T) if name not in passed_over}
    columns, fs, fs_unread = _time_stamps(path, columns, notes, fs=noted, clock=next(iter(table.clock), None))
    units = {name: unit for name in columns if (unit := unit_in_name(name))}
    origin = "header" if noted is not None else "time column" if fs else ""
    # A spreadsheet's row numbers ("Nr", "Index") beside the vibration are no channel to choose among.
    counters = {name: f"sample numbers ({values[0]:g}, {values[1]:g}, ...), not a vibration"
                for name, values in columns.items() if len(columns) > 1 and values.size > 2
                and values[0] == np.round(values[0]) and np.all(np.diff(values) == 1)}
    meta = {"notes": notes} if notes else {}
    return RawRecord(str(path), "csv", _float_channels(path, columns), fs=fs, fs_origin=origin,
                     fs_tolerance=FS_FLOAT_NOISE if noted is not None else FS_RELATIVE_TOLERANCE,
                     meta=dict(meta, not_vibration=counters) if counters else meta, channel_units=units,
                     rpm=noted_rpm, unit=noted_unit,
                     fs_unread=fs_unread or ("" if fs else note_unread))


_RATE_NOTE = re.compile(
    r"(?:sampl(?:e|ing)[ _-]*(?:rate|frequency|freq)\s*(?:\([^)]*\)|\[[^\]]*\])?\s*[:=;\t]\s*"
    r"(?P<value>\d+(?:[.,]\d+)*(?:[eE][+-]?\d+)?)\s*(?P<unit>k?hz|k?s/s|k?sps|k?samples/s)?"
    r"|fs\s*[:=]\s*(?P<fs_value>\d+(?:[.,]\d+)*(?:[eE][+-]?\d+)?)\s*(?P<fs_unit>k?hz|k?s/s|k?sps|k?samples/s))"
    r"\s*(?:$|[;(]|,(?!\d))", re.IGNORECASE)
"""A logger's note stating its rate: ``Sample rate: 12000 Hz``, ``Sampling frequency [Hz] = 25.6 kHz``, ``fs: 48000
Hz``, ``Sample rate: 51.2 kS/s``, ``Sample rate;25600`` (two cells of a spreadsheet's export); the number (Hz unless
a k is before its unit) ends the note or a part of it. A bare ``fs`` needs its unit (``FS: 10``, a sensor's full
scale, states no rate)."""
_INTERVAL_NOTE = re.compile(
    r"(?:sampl(?:e|ing)[ _-]*(?:interval|period)|delta[ _-]*t|dt)\s*(?:\((?P<bracketed>[^)]*)\)|\[(?P<squared>[^\]]*)\])?"
    r"\s*[:=;\t]\s*(?P<value>\d+(?:[.,]\d+)*(?:[eE][+-]?\d+)?)\s*(?P<unit>s|ms|µs|μs|us)?\s*(?:$|[;(]|,(?!\d))",
    re.IGNORECASE)
"""A logger's note stating the time between samples instead: ``Sampling interval: 1.953125e-05 s``, ``dt [ms] =
0.02``; its unit stated (s, ms or µs), beside the number or in brackets after the label."""
_SECONDS = {"s": 1.0, "ms": 1e-3, "µs": 1e-6, "μs": 1e-6, "us": 1e-6}


def _noted_number(value: str, decimal: str) -> float | None:
    """A note's number read with the file's ``decimal`` mark; None where it reads more than one way (a thousands
    separator, or the other mark: ``12,800`` among decimal points, ``25.600`` among decimal commas)."""
    marks = re.findall(r"[.,]", value)
    if marks and marks != [decimal]:
        return None
    return float(value.replace(",", "."))


_SPEED_NOTE = re.compile(
    r"(?:(?:shaft|motor|rotor|rotational|rotating)[ _-]*)?(?P<key>speed|rpm|drehzahl)\s*"
    r"(?:\((?P<bracketed>[^)]*)\)|\[(?P<squared>[^\]]*)\])?\s*[:=;\t]\s*(?P<value>\d+(?:[.,]\d+)*)\s*"
    r"(?P<unit>rpm|r/min|rev/min|1/min|min-1|min⁻¹|u/min|hz)?\s*(?:$|[;(]|,(?!\d))", re.IGNORECASE)
"""A logger's note stating the shaft speed: ``Speed: 1796 rpm``, ``Shaft speed [Hz] = 29.9``, ``RPM: 1796``; the
speed needs its unit (rev/min or Hz) unless the label is ``rpm``."""
_PER_MINUTE = ("rpm", "r/min", "rev/min", "1/min", "min-1", "min⁻¹", "u/min")
_UNIT_NOTE = re.compile(r"(?:units?|einheit|engineering units?|eu)\s*[:=;\t]\s*(?P<unit>[^;,]+?)\s*$", re.IGNORECASE)
"""A logger's note stating the samples' unit: ``Unit: g``, ``Units = m/s^2``, ``Einheit: m/s²``."""


def speed_and_unit_in_notes(lines: list[str], decimal: str = ".") -> tuple[float | None, str, list[str]]:
    """The shaft speed (rev/min) and the samples' unit a logger's notes above the header state (None and "" where they
    state none), and notes on what was read or why a note was not: a speed with no unit (rev/min or Hz?), a unit no
    quantity of which is known here."""
    rpm, unit, said = None, "", []
    for line in lines:
        speed = _SPEED_NOTE.match(line.strip())
        if speed is not None and rpm is None:
            number = _noted_number(speed["value"], decimal)
            stated = (speed["unit"] or speed["bracketed"] or speed["squared"] or "").strip().lower()
            stated = stated or ("rpm" if speed["key"].lower() == "rpm" else "")
            if number is None or not number > 0 or stated not in (*_PER_MINUTE, "hz"):
                said.append(f"the note {line!r} is not read as the shaft speed (a positive number in rev/min or Hz, "
                            "its unit stated): give rpm=")
                continue
            rpm = number * (60.0 if stated == "hz" else 1.0)
            said.append(f"shaft speed {rpm:g} rpm from the note {line!r}")
        named = _UNIT_NOTE.match(line.strip())
        if named is not None and not unit:
            if quantity_of(named["unit"]) is None:
                said.append(f"the note {line!r} names no unit known here: not read")
                continue
            unit = acceleration_unit(named["unit"]) or named["unit"]
            said.append(f"unit {unit} from the note {line!r}, for every column that states none")
    return rpm, unit, said


def rate_in_notes(path: Path, lines: list[str], decimal: str = ".") -> tuple[str, float | None] | None:
    """The first of a logger's notes (its lines above the header) that states the sampling rate, and the rate in Hz
    (no unit: Hz); None when none does. The number is read with the file's ``decimal`` mark (``25,6 kHz`` among
    numbers written with decimal commas); one that reads more than one way (``12,800 Hz``, ``12.000,0 Hz``, or
    ``25.600 Hz`` among decimal commas: a thousands separator?) is a rate not read, None, rather than a misread one:
    the user gives it (``fs=``). A stated rate that is no positive number is refused, naming the line."""
    for line in lines:
        match = _RATE_NOTE.match(line.strip())
        interval = None if match is not None else _INTERVAL_NOTE.match(line.strip())
        per = (interval["unit"] or interval["bracketed"] or interval["squared"] or "").strip().lower() if interval else ""
        if match is None and per not in _SECONDS:  # an interval's unit stated, or it is no note of the rate
            continue
        if match is None:
            number = _noted_number(interval["value"], decimal)
            if number is None:
                return line, None
            rate = 1.0 / (number * _SECONDS[per]) if number > 0 else 0.0
            # The rate to the digits the interval was printed with, where that rate's interval prints as the note
            # does: 8.333e-05 s is 12000 Hz, not 12000.48; 0.04 ms stays 25000 Hz.
            digits = max(1, len(re.sub(r"\D", "", re.split(r"[eE]", interval["value"])[0]).lstrip("0")))
            rounded = float(f"{rate:.{digits}g}") if math.isfinite(rate) and rate > 0 else rate
            if rounded > 0 and math.isclose(float(f"{1.0 / rounded / _SECONDS[per]:.{digits}g}"), number, rel_tol=1e-9):
                rate = rounded
            elif math.isfinite(rate):
                rate = float(f"{rate:.12g}")  # a division's float noise off: 0.04 ms is 25000 Hz, not 24999.999999999996
            if not (math.isfinite(rate) and rate > 0):
                raise BearingTwinError(f"{path}: the note {line!r} above the header states no positive sampling interval")
            return line, rate
        value, unit = (match["value"], match["unit"]) if match["value"] else (match["fs_value"], match["fs_unit"])
        number = _noted_number(value, decimal)
        if number is None:
            return line, None
        rate = number * (1000.0 if (unit or "").lower().startswith("k") else 1.0)
        if not (math.isfinite(rate) and rate > 0):
            raise BearingTwinError(f"{path}: the note {line!r} above the header states no positive sampling rate")
        return line, rate
    return None
