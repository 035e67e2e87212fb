"""Case Western Reserve University bearing data: .mat records, names, and a checked sampling rate.

A CWRU file holds ``X<nnn>_DE_time`` / ``_FE_time`` / ``_BA_time`` accelerations (g) and
``X<nnn>RPM``, the measured speed, but not its sampling rate; the rate (12 kHz for the
drive-end records used here) is a convention of the data set, and the literature
disagrees about some records (97 may be 48 kHz). So the rate is *declared* per record
and then *checked*: a shaft turning at ``rpm`` puts a series of lines at multiples of
``rpm / 60`` into the spectrum, and under a wrong rate that series appears scaled by
``declared / true``. :func:`check_shaft_line` looks for it.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import median_filter

from bearingtwin.data.files import RawRecord, read_raw, recording_from_raw
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError

CHANNELS = ("DE", "FE", "BA")
DECLARED_FS_HZ = 12000.0
"""The rate the Data Center states for its 12k drive-end files; overridable per record in config."""

STATES = {"normal": "normal", "IR": "inner", "B": "ball", "OR": "outer"}

_VARIABLE = re.compile(r"^X(\d+)_(DE|FE|BA)_time$")
_NAME = re.compile(
    r"^(?:(?P<rate>\d+k)_(?P<end>Drive|Fan)_End_(?P<state>IR|B|OR)(?P<size>\d{3})(?:@(?P<position>\d+))?"
    r"|(?P<normal>normal))_(?P<load>\d)_(?P<record>\d+)$"
)


@dataclass(frozen=True)
class CwruName:
    """What a CWRU file name says (``12k_Drive_End_OR007@6_0_130.mat``, ``normal_0_97.mat``)."""

    fault: str
    load_hp: int
    record: int
    fault_size_in: float | None = None  # defect diameter in inches (0.007 for "007")
    position: str | None = None  # outer-race defect position in o'clock ("6"), None elsewhere
    rate_hz: float | None = None  # sampling rate the name states ("48k_..." -> 48000), None when it states none


def parse_cwru_name(path: str | Path) -> CwruName | None:
    """The state, motor load and record number in a CWRU file name (None for another form)."""
    match = _NAME.match(Path(path).stem)
    if match is None:
        return None
    if match["normal"]:
        return CwruName(fault="normal", load_hp=int(match["load"]), record=int(match["record"]))
    return CwruName(
        fault=STATES[match["state"]],
        load_hp=int(match["load"]),
        record=int(match["record"]),
        fault_size_in=int(match["size"]) / 1000.0,
        position=match["position"],
        rate_hz=1000.0 * int(match["rate"][:-1]),
    )


def is_cwru_mat(variables: dict) -> bool:
    """Whether a loaded .mat file has the CWRU layout (``X<nnn>_<channel>_time`` variables)."""
    return any(_VARIABLE.match(name) for name in variables)


def read_cwru_raw(path: str | Path, variables: dict) -> RawRecord:
    """The DE / FE / BA channels and measured speed of a loaded CWRU .mat file."""
    path = Path(path)
    channels, records = {}, set()
    for name, value in variables.items():
        match = _VARIABLE.match(name)
        if match:
            records.add(int(match[1]))
            channels[match[2]] = np.asarray(value, dtype=np.float64).reshape(-1)
    if len(records) != 1:
        raise BearingTwinError(f"{path}: holds variables of records {sorted(records)}; expected one record per file")
    record = records.pop()
    name = parse_cwru_name(path)
    if name is not None and name.record != record:
        raise BearingTwinError(f"{path}: the file name says record {name.record} but its variables are X{record:03d}_*")
    rpm_names = [n for n in variables if re.fullmatch(rf"X0*{record}RPM", n)]
    rpm = float(np.asarray(variables[rpm_names[0]]).reshape(-1)[0]) if rpm_names else None
    meta = {"record": record}
    if name is not None:
        meta.update(load_hp=name.load_hp, fault_size_in=name.fault_size_in, position=name.position)
    return RawRecord(
        str(path),
        "cwru-mat",
        {channel: channels[channel] for channel in CHANNELS if channel in channels},
        fs=DECLARED_FS_HZ if name is None or name.rate_hz is None else name.rate_hz,
        fs_origin="declared" if name is None or name.rate_hz is None else "file name",
        rpm=rpm,
        fault=None if name is None else name.fault,
        unit="g",
        meta=meta,
        default_channel="DE",  # the drive-end accelerometer: the channel the data set is known by
    )


def declared_fs_hz(record: int, default_hz: float, by_record: dict | None = None) -> float:
    """The sampling rate declared for ``record``: a per-record entry if any, else the default."""
    by_record = {int(key): float(value) for key, value in (by_record or {}).items()}
    return by_record.get(int(record), float(default_hz))


@dataclass(frozen=True)
class ShaftLineCheck:
    """Whether a record's spectrum shows its shaft speed where the declared rate puts it.

    Attributes:
        expected_hz: rpm / 60.
        observed_hz: the strong shaft-harmonic series nearest to ``expected_hz`` (None if none).
        implied_fs_hz: the rate under which ``observed_hz`` would be the shaft speed.
        score: median prominence (peak / local median spectrum) of the first harmonics at
            ``observed_hz`` (at ``expected_hz`` if nothing was observed).
        matches: ``observed_hz`` lies within the tolerance of ``expected_hz``.
    """

    fs_hz: float
    rpm: float
    expected_hz: float
    observed_hz: float | None
    implied_fs_hz: float | None
    score: float
    matches: bool

    def as_dict(self) -> dict:
        return asdict(self)


def check_shaft_line(
    signal: np.ndarray,
    fs: float,
    rpm: float,
    *,
    tolerance: float = 0.02,
    prominence: float = 20.0,
    n_harmonics: int = 5,
    harmonic_tolerance: float = 0.005,
    search_factor: float = 5.0,
    background_hz: float = 5.0,
) -> ShaftLineCheck:
    """Look for the shaft's harmonic series near rpm / 60 under the sampling rate ``fs`` (Hz).

    A single line is a weak witness (a record's shaft line can be weaker than a supply or
    defect line nearby), so the witness is the *series*: for every trial fundamental
    between ``expected / search_factor`` and ``expected * search_factor`` the first
    ``n_harmonics`` harmonics are scored by their prominence over the local median
    spectrum (``background_hz`` wide), and the series' score is the median, so most
    harmonics must stand out. The strong series (score >= ``prominence``) nearest the
    expected frequency is taken as the shaft's. A sampling rate that is an integer multiple
    *below* the true one maps a higher shaft harmonic onto the expected frequency and is
    not detectable this way.

    Args:
        signal: 1-D record (whole record: the resolution fs / n must resolve the harmonics).
        fs: declared sampling rate in Hz.
        rpm: measured shaft speed in rev/min.
        tolerance: relative distance between observed and expected that still matches.
        prominence: how many times above the local median spectrum the series must stand.
        harmonic_tolerance: relative width of the search window around each harmonic.
    """
    signal = np.asarray(signal, dtype=np.float64)
    if signal.ndim != 1 or not np.all(np.isfinite(signal)):
        raise BearingTwinError("check_shaft_line needs a 1-D, finite signal")
    if not (fs > 0 and rpm > 0):
        raise BearingTwinError(f"check_shaft_line needs positive fs and rpm (got fs={fs}, rpm={rpm})")
    expected = rpm / 60.0
    resolution = fs / signal.size
    if resolution > tolerance * expected:
        raise BearingTwinError(
            f"the record is too short to check its sampling rate: {signal.size} samples give {resolution:.3g} Hz "
            f"resolution, too coarse to place a {expected:.3g} Hz shaft line within {tolerance:.0%}"
        )
    spectrum = np.abs(np.fft.rfft((signal - signal.mean()) * np.hanning(signal.size)))
    top_bin = min(spectrum.size, int(math.ceil(n_harmonics * expected * search_factor * 1.1 / resolution)) + 2)
    spectrum = spectrum[:top_bin]
    background = median_filter(spectrum, size=2 * int(round(background_hz / resolution / 2)) + 1, mode="nearest")
    ratio = spectrum / np.maximum(background, np.finfo(float).tiny)
    n_grid = int(math.ceil(2 * math.log(search_factor) / harmonic_tolerance)) + 1
    grid = expected * np.geomspace(1 / search_factor, search_factor, n_grid)
    per_harmonic = np.empty((n_harmonics, grid.size))
    for k in range(1, n_harmonics + 1):
        half_width = np.maximum(k * grid * harmonic_tolerance, resolution)
        low = np.clip(np.floor((k * grid - half_width) / resolution).astype(int), 0, top_bin - 1)
        high = np.clip(np.ceil((k * grid + half_width) / resolution).astype(int) + 1, low + 1, top_bin)
        per_harmonic[k - 1] = [ratio[a:b].max() for a, b in zip(low, high)]
    score = np.median(per_harmonic, axis=0)
    strong = np.flatnonzero(score >= prominence)
    if strong.size == 0:
        at_expected = float(score[np.argmin(np.abs(np.log(grid / expected)))])
        return ShaftLineCheck(fs, rpm, expected, None, None, at_expected, False)
    nearest = strong[np.argmin(np.abs(np.log(grid[strong] / expected)))]
    observed = float(grid[nearest])
    return ShaftLineCheck(
        fs_hz=fs,
        rpm=rpm,
        expected_hz=expected,
        observed_hz=observed,
        implied_fs_hz=fs * expected / observed,
        score=float(score[nearest]),
        matches=abs(observed / expected - 1.0) <= tolerance,
    )


def load_cwru(
    path: str | Path,
    channel: str = "DE",
    fs: float | None = None,
    check_fs: bool = True,
    tolerance: float = 0.02,
    prominence: float = 20.0,
) -> Recording:
    """One channel of a CWRU record, its declared sampling rate checked against the shaft line.

    ``fs`` is the rate declared for this record (None: the data set's 12 kHz). All channels
    of a record share one rate, so every channel is a witness: the rate stands if the shaft
    series appears where expected in any of them (the fan-end channel of the fault records
    shows it only weakly). With ``check_fs`` a rate no channel supports raises, naming the
    rate the drive-end channel implies.
    """
    if channel not in CHANNELS:
        raise BearingTwinError(f"channel={channel!r} is not a CWRU channel; choose one of {', '.join(CHANNELS)}")
    raw = read_raw(path)
    if raw.format != "cwru-mat":
        raise BearingTwinError(f"{path}: not a CWRU record (no X<nnn>_DE_time / _FE_time / _BA_time variables)")
    recording = recording_from_raw(raw, channel=channel, fs=fs)
    if recording.rpm is None:
        raise BearingTwinError(f"{path}: no X<nnn>RPM variable, so the speed is unknown")
    checks = {
        name: check_shaft_line(values, recording.fs, recording.rpm, tolerance=tolerance, prominence=prominence)
        for name, values in raw.channels.items()
        if np.all(np.isfinite(values))
    }
    witness = next((name for name, check in checks.items() if check.matches), next(iter(checks)))
    recording.meta["shaft_line"] = dict(checks[witness].as_dict(), channel=witness)
    if check_fs and not checks[witness].matches:
        raise BearingTwinError(
            f"{path}: {describe_mismatch(checks[witness])} (channel {witness}); declare the record's rate "
            f"(+data.fs_by_record.{recording.meta['record']}=<Hz>) or set data.check_fs=false"
        )
    return recording


def describe_mismatch(check: ShaftLineCheck) -> str:
    """One sentence on why a declared rate was rejected."""
    where = (
        f"the nearest strong harmonic series is at {check.observed_hz:.2f} Hz, implying fs = {check.implied_fs_hz:.0f} Hz"
        if check.observed_hz is not None
        else f"no shaft harmonic series stands out nearby (prominence {check.score:.1f})"
    )
    return (
        f"fs = {check.fs_hz:g} Hz contradicts the shaft speed: at {check.rpm:g} rpm the shaft line belongs at "
        f"{check.expected_hz:.2f} Hz, but {where}"
    )
