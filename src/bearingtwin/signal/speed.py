"""How steadily a shaft turned during a record, and the record resampled to a steady speed.

Every defect line is read at one shaft speed. A speed that drifts within a record (a fan or conveyor under a
changing load, a belt, a run-up) spreads each line over the speeds it passed through: a 4 % drift smears an
outer-race line at 107 Hz over 4 Hz, and its harmonics over more, until no line stands above its floor. A
machine tells its own speed through the shaft's harmonic series (1x, 2x, ... from residual unbalance and
misalignment), so the speed is read from that series segment by segment (:func:`speed_profile`).

Where it varies, :func:`order_track` resamples the record at equal steps of shaft angle instead of time
(computed order tracking, Fyfe & Munck, MSSP 1997): the record becomes one of a shaft turning steadily at its
mean speed, and every order-locked line (shaft, cage, defect rates) stands still again. No maintained Python
package provides tacholess order tracking, so it is written here, in ``scipy.signal``'s style.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.ndimage
import scipy.signal

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_record, check_positive

SEARCH = 0.12
"""How far from the stated speed (relative) each segment's shaft series is sought. Up to the 8th harmonic a harmonic's
search window holds none of its neighbours where the stated speed is the true one; a defect line may fall in one
(BPFO near 3.6x), and where the true speed lies outside the search the m-th and 2m-th windows may hold a k-th and
2k-th true harmonic: the agreement of the harmonics, the 1x or the 2x among them (:data:`AGREEMENT`), leaves both
out."""
HARMONICS = 8
MIN_PROMINENCE = 5.0
"""A harmonic stands where its spectral peak is this many times its local median (14 dB)."""
AGREEMENT = 0.005
"""The harmonics that place the shaft within this (relative) of their median speed agree; a segment's speed is read
where two or more agree, the 1x or the 2x among them."""
SUPPLY_HZ = (50.0, 60.0)
SUPPLY_AGREEMENT = 0.005
"""A speed whose shaft rate (or twice it) lies this close to a supply frequency may have been read from the supply's
lines, which every motor's vibration carries: not read (:func:`speed_profile`). An unloaded 4-pole motor's 2x lies
0.2 % below 60 Hz, so the speed of the CWRU rig at 0 hp (1796-1797 rpm) is not read at all."""
MIN_REVOLUTIONS = 20
"""The fewest shaft turns a segment holds, so that the 1x and 2x lines lie apart in its spectrum."""
UNSTEADY = 0.02
"""A spread of the speeds read (max - min, relative to their median) above which a record is called unsteady: twice
the relative width within which the physics evidence reads a line (``evidence.tolerance``, 1 %). The speeds read
on the steady CWRU records spread by 0.3 % at most."""


def near_supply(rpm: float) -> bool:
    """Whether ``rpm``'s shaft rate, or twice it, lies within :data:`SUPPLY_AGREEMENT` of a supply frequency: the
    supply's lines could pass for such a shaft series."""
    return any(abs(multiple * rpm / 60.0 / supply - 1) <= SUPPLY_AGREEMENT for supply in SUPPLY_HZ for multiple in (1, 2))


def supply_comb(hz: float) -> bool:
    """Whether a harmonic series at ``hz`` may be the supply's comb: its fundamental within :data:`SUPPLY_AGREEMENT` of a
    supply frequency or twice it (a motor's magnetic pull: 100 Hz on a 50 Hz supply, 4.05 times a 4-pole motor's
    shaft at 1480 rpm), which no speed moves."""
    return any(abs(hz / (multiple * supply) - 1) <= SUPPLY_AGREEMENT for supply in SUPPLY_HZ for multiple in (1, 2))


@dataclass(frozen=True)
class SpeedProfile:
    """The shaft speed read segment by segment from the shaft's harmonic series (:func:`speed_profile`) or a
    tachometer's pulses (:func:`tachometer_profile`).

    Attributes:
        times_s: (n_segments,) each segment's centre, s from the record's start.
        rpm: (n_segments,) the speed read there, rev/min (the median of it and the reads beside it); NaN where fewer
            than two harmonics stood and agreed.
        segment_s: the segments' length, s (half-overlapping).
        stated_rpm: the speed the record was said to turn at, around which the series was sought.
        source: what the speed was read from where it was not the shaft's series (``the tachometer channel tach``).
    """

    times_s: np.ndarray
    rpm: np.ndarray
    segment_s: float
    stated_rpm: float
    source: str = ""

    @property
    def read(self) -> np.ndarray:
        """Which segments' speed was read."""
        return np.isfinite(self.rpm)

    @property
    def readable(self) -> bool:
        """Whether enough of the record was read to say how steady it turned: three segments or more, and at least
        a third of them (a series that shows only now and then leaves the rest of the record unknown)."""
        return int(self.read.sum()) >= 3 and 3 * self.read.sum() >= self.read.size

    @property
    def spread(self) -> float:
        """(max - min) / median of the speeds read; NaN where the profile is not :attr:`readable`."""
        if not self.readable:
            return math.nan
        speeds = self.rpm[self.read]
        return float((speeds.max() - speeds.min()) / np.median(speeds))

    @property
    def read_rpm(self) -> float | None:
        """The median speed read, rev/min; None where the profile is not :attr:`readable`, or it was read from the
        shaft's series at a speed the supply's lines could pass for (:func:`near_supply`): a tachometer measures the
        shaft, the supply's lines are no measure of a speed."""
        if not self.readable:
            return None
        read = float(np.median(self.rpm[self.read]))
        return read if self.source or not near_supply(read) else None

    def unread_words(self) -> str:
        """Why the profile is not :attr:`readable`, in words ("" where it is)."""
        if self.readable:
            return ""
        if not self.source and self.rpm.size and near_supply(self.stated_rpm):
            return (f"at {self.stated_rpm:g} rpm the shaft rate or twice it lies near a supply frequency "
                    f"({', '.join(f'{hz:g}' for hz in SUPPLY_HZ)} Hz), whose lines could pass for its series: not read")
        if not self.rpm.size:
            return f"the record is shorter than one segment of {self.segment_s:g} s"
        return f"no {'pulse train' if self.source else 'shaft series'} stood out in enough segments to read a speed"

    def unsteady(self, tolerance: float = UNSTEADY) -> bool:
        """Whether the speed read varies by more than ``tolerance`` (relative spread)."""
        return bool(self.spread > tolerance)

    def rpm_at(self, n_samples: int, fs: float) -> np.ndarray:
        """The speed at every sample: linear between the segments read, held beyond the first and the last."""
        t = np.arange(n_samples) / fs
        return np.interp(t, self.times_s[self.read], self.rpm[self.read])

    def describe(self) -> str:
        """"from 1712 to 1784 rpm (4.1 % of its median, 1748 rpm), read in 17 of 17 1-s segments"."""
        speeds = self.rpm[self.read]
        return (f"from {speeds.min():.0f} to {speeds.max():.0f} rpm ({100 * self.spread:.2g} % of its median, "
                f"{np.median(speeds):.0f} rpm), read in {int(self.read.sum())} of {self.rpm.size} "
                f"{self.segment_s:.3g}-s segments" + (f" of {self.source}" if self.source else ""))


class _SeriesSpectrum:
    """The spectra a shaft series is read from: the record at a rate four times the series' top (a long record's
    transforms then cost a hundredth of theirs at 51.2 kHz), each stretch's Hann-windowed magnitude up to that top
    over its local median (the median over one shaft rate: wide against a line's few bins, narrow against the
    spectrum's shape), and each harmonic's search window in bins."""

    def __init__(self, x: np.ndarray, fs: float, shaft_hz: float, length_s: float, harmonics: int, search: float,
                 zero_pad: int):
        factor = int(fs // (4 * harmonics * shaft_hz * (1 + search)))
        self.x, self.fs = (scipy.signal.resample_poly(x, 1, factor), fs / factor) if factor >= 2 else (x, fs)
        self.length = min(int(round(length_s * self.fs)), self.x.size)
        self.n_fft = scipy.fft.next_fast_len(zero_pad * self.length)
        self.resolution = self.fs / self.n_fft
        self.top_bin = min(self.n_fft // 2, int(math.ceil(harmonics * shaft_hz * (1 + search) / self.resolution)) + 2)
        self.background_bins = 2 * max(1, int(round(0.5 * shaft_hz / self.resolution))) + 1
        self.orders = np.arange(1, harmonics + 1)
        self.low = np.floor(self.orders * shaft_hz * (1 - search) / self.resolution).astype(int)
        self.high = np.minimum(np.ceil(self.orders * shaft_hz * (1 + search) / self.resolution).astype(int) + 1,
                               self.top_bin - 1)
        self.window = scipy.signal.get_window("hann", self.length)

    def of(self, start: int) -> tuple[np.ndarray, np.ndarray]:
        """The magnitude spectrum of the stretch from sample ``start`` and its prominence over the local median."""
        stretch = self.x[start:start + self.length]
        spectrum = np.abs(scipy.fft.rfft((stretch - stretch.mean()) * self.window, self.n_fft))[:self.top_bin]
        background = scipy.ndimage.median_filter(spectrum, size=self.background_bins, mode="nearest")
        return spectrum, spectrum / np.maximum(background, np.finfo(float).tiny)


def _check(signal, fs, rpm, search, harmonics, agreement=AGREEMENT, name="signal") -> np.ndarray:
    x = as_record(signal, name)
    check_positive(fs, "fs")
    check_positive(rpm, "rpm", "shaft speed in rev/min")
    if not 0 < search < 0.5 or not 0 < agreement < search or int(harmonics) != harmonics or harmonics < 2:
        raise BearingTwinError(f"search (got {search}) must lie in (0, 0.5), agreement (got {agreement}) in (0, "
                               f"search), harmonics (got {harmonics}) be a whole number of 2 or more")
    return x


def speed_profile(signal, fs: float, rpm: float, *, segment_s: float = 1.0, search: float = SEARCH,
                  harmonics: int = HARMONICS, min_prominence: float = MIN_PROMINENCE,
                  agreement: float = AGREEMENT) -> SpeedProfile:
    """The shaft speed of each half-overlapping segment of a 1-D ``signal``, read from its shaft harmonics.

    In each segment (``segment_s``, at least :data:`MIN_REVOLUTIONS` turns at ``rpm``), the k-th harmonic is the
    largest peak within ``search`` (relative) of ``k x rpm / 60`` that stands ``min_prominence`` times over its local
    median (a Hann-windowed spectrum, eight times zero-padded, the peak placed by a parabola); it places the shaft at
    its frequency / k. The segment's speed is the median of the largest group of places that lie within
    ``agreement`` of one of them and hold the 1x or the 2x, where two or more do: a lone line may be anything, and a
    defect's comb can pass for a shaft series from its 4th or 5th harmonic up (BPFO = 3.585 x shaft is the 4th
    harmonic of a shaft 10 % slower), never from its 1st or 2nd. A speed that may be the supply's
    (:func:`near_supply`) is not read: the supply's lines are steady, and a segment reading them beside
    segments reading the shaft would pass for a speed that varies.

    Args:
        signal: (n,) samples, any unit; fs: its sampling rate, Hz; rpm: the speed stated for it, rev/min.

    Returns:
        :class:`SpeedProfile`; a record shorter than three segments gives one with no segment read.
    """
    x = _check(signal, fs, rpm, search, harmonics, agreement)
    shaft_hz = rpm / 60.0
    segment_s = max(float(segment_s), MIN_REVOLUTIONS / shaft_hz)
    spectra = _SeriesSpectrum(x, fs, shaft_hz, segment_s, harmonics, search, zero_pad=8)
    length, resolution = spectra.length, spectra.resolution
    starts = (np.arange(0, spectra.x.size - length + 1, max(1, length // 2))
              if spectra.x.size >= int(round(segment_s * spectra.fs)) else np.zeros(0, dtype=int))
    speeds = np.full(starts.size, np.nan)
    for index, start in enumerate(starts):
        spectrum, prominence = spectra.of(start)
        places, lowest = [], []
        for order, a, b in zip(spectra.orders, spectra.low, spectra.high):
            if b <= a + 1:  # a harmonic beyond the spectrum (a rate too low for it)
                continue
            peak = a + int(np.argmax(prominence[a:b]))
            if prominence[peak] < min_prominence or not 0 < peak < spectra.top_bin - 1:
                continue
            left, centre, right = spectrum[peak - 1:peak + 2]
            curvature = left - 2 * centre + right
            offset = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
            places.append((peak + offset) * resolution / order)
            lowest.append(order <= 2)
        if len(places) < 2:
            continue
        places, lowest = np.array(places), np.array(lowest)
        # The largest group of places that agree with one of them, the 1x or the 2x among it: where a stated speed a
        # little off lets a defect's comb take half the windows, the median of all the places falls between the two
        # and agrees with neither (CWRU 131 stated at 1740 rpm had been read in 4 of its 19 segments).
        # A larger group without them (another shaft's upper harmonics, a defect's comb) leaves the segment unread.
        groups = np.abs(places[:, None] / places[None, :] - 1) <= agreement
        agree = groups[max(range(places.size), key=lambda i: (lowest[groups[i]].any(), int(groups[i].sum())))]
        if agree.sum() < 2 or not lowest[agree].any() or agree.sum() < groups.sum(axis=1).max():
            continue
        speed = 60.0 * float(np.median(places[agree]))
        if not near_supply(speed):
            speeds[index] = speed
    read = np.isfinite(speeds)
    speeds[read] = smoothed(speeds[read])
    return SpeedProfile((starts + length / 2) / spectra.fs, speeds, segment_s, float(rpm))


def tachometer_profile(pulses, fs: float, rpm: float, *, segment_s: float = 1.0, search: float = SEARCH,
                       source: str = "a tachometer channel") -> SpeedProfile:
    """The shaft speed of each half-overlapping segment of a record, read from a tachometer's pulses recorded beside
    it (``pulses``: its two-level channel, as long as the record): the revolutions each segment holds over its length.

    A pulse is a rise through the middle of the channel's two levels, placed between samples by a straight line. The
    pulses per revolution are the whole number nearest to the pulse rate over the stated ``rpm``; where that puts the
    speed more than ``search`` from the stated one (a tachometer on another shaft, a speed stated far off), nothing is
    read. A segment the pulses do not span is not read.
    """
    x = _check(pulses, fs, rpm, search, HARMONICS, name="pulses")
    shaft_hz = rpm / 60.0
    segment_s = max(float(segment_s), MIN_REVOLUTIONS / shaft_hz)
    length = int(round(segment_s * fs))
    starts = np.arange(0, x.size - length + 1, max(1, length // 2)) if x.size >= length else np.zeros(0, dtype=int)
    nothing = SpeedProfile((starts + length / 2) / fs, np.full(starts.size, np.nan), segment_s, float(rpm), source)
    times = pulse_times(x, fs)
    if times.size < 3:
        return nothing
    per_turn = pulses_per_turn(pulse_rate(times), rpm, search)
    if per_turn is None:
        return nothing
    begin, end = starts / fs, (starts + length) / fs
    spanned = (begin >= times[0]) & (end <= times[-1])
    turns = np.arange(times.size) / per_turn
    speeds = np.where(spanned, 60.0 * (np.interp(end, times, turns) - np.interp(begin, times, turns)) / segment_s,
                      np.nan)
    return SpeedProfile(nothing.times_s, speeds, segment_s, float(rpm), source)


SPEED_OFF = (0.01, 0.08)
"""How far (relative) the speed a record's shaft series reads may lie from the stated one before a note says so: the
physics evidence reads each line within 1 % of where the stated speed puts it (``evidence.tolerance``); and how far it
may lie for the note to name it: a nameplate's speed or a motor's slip is off by a few %, while a series read 10 % off
may be a defect's comb taken for the shaft's under a speed stated twice the true one (the rate check names those)."""


def speed_off_words(read_rpm: float, rpm: float, source: str, key: str = "rpm") -> str | None:
    """What to say where ``source`` (the shaft's harmonic series, a tachometer) reads ``read_rpm`` more than 1 % and at
    most 8 % from the stated ``rpm`` (:data:`SPEED_OFF`), the speed's setting ``key`` (which a file stating the wrong
    speed yields to where the record reads the given one); None where it does not."""
    if not SPEED_OFF[0] < abs(read_rpm / rpm - 1) <= SPEED_OFF[1]:
        return None
    return (f"{source} reads {read_rpm:.0f} rpm, {100 * (read_rpm / rpm - 1):+.1f} % from the stated "
            f"{rpm:g} rpm: every defect line is read where the stated speed puts it; if the sampling rate is right, "
            f"give {key}={read_rpm:.0f}")


def pulse_times(pulses, fs: float) -> np.ndarray:
    """When each pulse of a two-level channel (a tachometer's) begins, s from its first sample: each rise through the
    middle of its two levels, placed between samples by a straight line."""
    x = as_record(pulses, "pulses")
    check_positive(fs, "fs")
    middle = (x.min() + x.max()) / 2.0
    rises = np.flatnonzero((x[:-1] < middle) & (x[1:] >= middle))
    return (rises + (middle - x[rises]) / (x[rises + 1] - x[rises])) / fs


def pulse_rate(times_s: np.ndarray) -> float:
    """Pulses a second over the span of their times ``times_s`` (:func:`pulse_times`, at least two)."""
    return (times_s.size - 1) / (times_s[-1] - times_s[0])


def pulses_per_turn(pulse_hz: float, rpm: float, search: float = SEARCH) -> int | None:
    """The whole number of pulses a revolution nearest ``pulse_hz`` over the shaft rate ``rpm`` / 60 gives, where the
    speed it puts the shaft at lies within ``search`` (relative) of ``rpm``; None where none does (a speed stated far
    off, a tachometer on another shaft)."""
    per_turn = max(1, int(round(pulse_hz / (rpm / 60.0))))
    return per_turn if abs(60.0 * pulse_hz / per_turn / rpm - 1.0) <= search else None


MAX_PULSES_PER_TURN = 64
"""The most pulses a revolution is tried at where a record states no speed (:func:`tachometer_speed`): a key phasor
or a reflective mark gives one, a toothed wheel or a simple encoder a few dozen; a fine encoder's thousands are a
speed no shaft series can settle."""
STANDING_HARMONICS = 3
"""How many of the shaft series' first :data:`HARMONICS` harmonics must stand (:data:`MIN_PROMINENCE`) at a speed the
pulses give for the record to confirm it: a lone line may be anything."""
SERIES_MARGIN = 2.0
"""How many times higher the median prominence of one speed's harmonics must stand than any other's the pulses give
for the record to tell that speed apart (:func:`tachometer_speed`)."""
PULSE_SPEED_SEARCH = 0.01
"""How far (relative) from where a tachometer's speed puts each harmonic of the shaft series it is sought: the
pulses give the mean speed exactly; a drift within the record smears the lines by about as much."""


@dataclass(frozen=True)
class TachometerSpeed:
    """A shaft speed read from a tachometer's pulses where a record states none (:func:`tachometer_speed`).

    Attributes:
        pulse_hz: the pulses a second over the record (NaN where fewer than three pulses were found).
        per_turn: the pulses per revolution the record's shaft series confirmed; None where it confirmed none.
        standing: how many of the shaft series' first :data:`HARMONICS` harmonics stand at that speed.
        alternatives: where the series stands about as high at several speeds and tells none apart, their pulses
            per revolution, fewest first (empty otherwise).
    """

    pulse_hz: float
    per_turn: int | None
    standing: int = 0
    alternatives: tuple[int, ...] = ()

    @property
    def rpm(self) -> float | None:
        """The shaft speed, rev/min; None where the pulses per revolution were not confirmed."""
        return None if self.per_turn is None else 60.0 * self.pulse_hz / self.per_turn

    def describe_unconfirmed(self) -> str:
        """Why no speed was read, in words: "... pulses 29.9 times a second: 1796 rpm at 1 pulse per revolution or 898
        at 2, which the record's shaft series does not tell apart"."""
        if math.isnan(self.pulse_hz):
            return "holds fewer than three pulses"
        if not self.alternatives:
            return (f"pulses {self.pulse_hz:.4g} times a second, a speed the record's shaft series does not confirm at "
                    f"any whole number of pulses per revolution up to {MAX_PULSES_PER_TURN}")
        speeds = [f"{60.0 * self.pulse_hz / count:.0f} rpm at {count} pulse{'s' * (count > 1)} per revolution"
                  for count in self.alternatives]
        return (f"pulses {self.pulse_hz:.4g} times a second: {', '.join(speeds[:-1])} or {speeds[-1]}, which the "
                "record's shaft series does not tell apart")


def tachometer_speed(pulses, signal, fs: float, *, max_per_turn: int = MAX_PULSES_PER_TURN,
                     min_standing: int = STANDING_HARMONICS) -> TachometerSpeed:
    """The shaft speed a tachometer's ``pulses`` give, recorded beside a vibration ``signal`` (both at ``fs`` Hz) that
    states none: the pulse rate over a whole number of pulses per revolution, from 1 to ``max_per_turn``, confirmed by
    the signal's shaft series (:func:`series_prominences`, each harmonic sought within :data:`PULSE_SPEED_SEARCH`).

    Of the speeds whose 1x line stands with at least ``min_standing`` harmonics standing, the one whose harmonics
    stand highest (their median prominence) is read where it stands :data:`SERIES_MARGIN` times higher than every
    other's: a speed a whole number of times too slow stands only every other line, or fewer (its half orders, as a
    rule, do not), which halves its median or worse. A speed a whole number of times too fast stands every line where
    the true one's harmonics all stand (a tachometer of several pulses a turn on a machine rich in harmonics), as a
    slow one does on a machine that makes half orders: where several speeds stand within that margin, none is read
    (their counts of pulses are the ``alternatives``). Neither the strongest 1x nor the fewest pulses decide between
    them: a shaft's 2x outstands its 1x on many machines (misalignment; the CWRU inner-race records), and a tachometer
    may give several pulses a turn, so either rule would read a speed a whole number of times off, unawares."""
    times = pulse_times(pulses, fs)
    if times.size < 3:
        return TachometerSpeed(math.nan, None)
    rate = pulse_rate(times)
    standing, height = {}, {}
    for per_turn in range(1, int(max_per_turn) + 1):
        # A speed too slow for the record to resolve its harmonics stands none (NaN).
        prominence = np.nan_to_num(series_prominences(signal, fs, 60.0 * rate / per_turn, search=PULSE_SPEED_SEARCH))
        if prominence[0] >= MIN_PROMINENCE and np.sum(prominence >= MIN_PROMINENCE) >= min_standing:
            standing[per_turn], height[per_turn] = int(np.sum(prominence >= MIN_PROMINENCE)), float(np.median(prominence))
    if not height:
        return TachometerSpeed(rate, None)
    best = max(height, key=height.get)
    near = tuple(count for count in height if height[count] * SERIES_MARGIN > height[best])
    return TachometerSpeed(rate, best, standing[best]) if len(near) == 1 else TachometerSpeed(rate, None, 0, near)


def smoothed(reads: np.ndarray) -> np.ndarray:
    """Speeds read in consecutive segments (those read, in order), each the median of it and the reads beside it,
    each end's against the smoothed reads inside and their trend: a shaft's speed moves smoothly from segment to
    segment, a segment whose weak lines happened to agree on a wrong place (1.6 % off in a healthy CWRU record) does
    not, at the ends either. Segments not read between two reads are passed over, as if the reads were neighbours."""
    reads = np.asarray(reads, dtype=np.float64)
    if reads.size < 3:
        return reads.copy()
    if reads.size == 3:  # one read beside each end: the middle one's median, the ends held to it
        return np.full(3, np.median(reads))
    out = reads.copy()
    out[1:-1] = np.median(np.lib.stride_tricks.sliding_window_view(reads, 3), axis=1)
    out[0] = np.median([reads[0], out[1], 2 * out[1] - out[2]])
    out[-1] = np.median([reads[-1], out[-2], 2 * out[-2] - out[-3]])
    return out


def series_prominences(signal, fs: float, rpm: float, *, search: float = SEARCH,
                       harmonics: int = HARMONICS) -> np.ndarray:
    """How high each harmonic of a record's shaft series stands over the whole record: per harmonic k, the highest
    prominence (over the local median) within ``search`` of ``k x rpm / 60`` in one spectrum of the whole record
    (NaN for a harmonic beyond it). A speed that varies smears each line over the speeds passed, and lowers it; a
    record steadied to the speed its shaft turned at shows it sharp again (:func:`sharpening`)."""
    x = _check(signal, fs, rpm, search, harmonics)
    spectra = _SeriesSpectrum(x, fs, rpm / 60.0, x.size / fs, harmonics, search, zero_pad=2)
    _, prominence = spectra.of(0)
    return np.array([prominence[a:b].max() if b > a + 1 else np.nan for a, b in zip(spectra.low, spectra.high)])


def sharpening(before: np.ndarray, after: np.ndarray, min_prominence: float = MIN_PROMINENCE) -> float:
    """How many times higher a shaft series stands ``after`` steadying than ``before`` (:func:`series_prominences`):
    the median over the harmonics that stand (``min_prominence``) in either, for a machine may show three harmonics
    of eight and the empty windows' noise says nothing. Steadied to a wrong profile (two shafts' series, a supply's
    lines, a swing faster than the segments resolve) a series stands no higher, or lower; NaN where none stands."""
    keep = (before >= min_prominence) | (after >= min_prominence)
    if not keep.any():
        return math.nan
    return float(np.median(after[keep]) / np.median(before[keep]))


def steady_times(profile: SpeedProfile, n_samples: int, fs: float) -> tuple[np.ndarray, float]:
    """When each of a record's ``n_samples`` samples falls on the steady time axis :func:`order_track` resamples it
    to (s, the shaft's turns so far over its mean speed; the last sample at ``(n_samples - 1) / fs``), and that mean
    speed (rev/min): where an instant of the record (a gap, an event) lies once it is tracked."""
    check_positive(fs, "fs")
    if not profile.read.any():
        raise BearingTwinError(f"the speed profile reads no segment's speed ({profile.unread_words()}): nothing to track")
    speed = profile.rpm_at(n_samples, fs)
    between = (speed[1:] + speed[:-1]) / 2  # over each sample interval, as the turns are summed (trapezoids)
    mean_rpm = float(between.mean()) if between.size else float(speed[0])
    return np.concatenate([[0.0], np.cumsum(between / (mean_rpm * fs))]), mean_rpm


def order_track(signal, fs: float, profile: SpeedProfile) -> tuple[np.ndarray, float]:
    """``signal`` resampled at equal steps of shaft angle: as recorded by a shaft turning steadily at its mean
    speed over the record, sampled at ``fs``; and that mean speed (rev/min).

    The speed at each sample is the ``profile``'s (:meth:`SpeedProfile.rpm_at`); its integral, scaled by the mean
    speed, is the steady time each sample belongs at, and the record is read at every ``1 / fs`` of that time by
    cubic-spline interpolation after doubling its rate (``scipy.signal.resample_poly``), which carries content up to
    0.8 of the Nyquist frequency within 0.02 dB (1.2 dB down at 0.9, where the doubling filter's transition band lies).
    The record keeps its length to a sample.
    """
    x = as_record(signal)
    if not isinstance(profile, SpeedProfile):
        raise BearingTwinError(f"profile must be a SpeedProfile (speed_profile's or tachometer_profile's), got "
                               f"{type(profile).__name__}")
    steady_time, mean_rpm = steady_times(profile, x.size, fs)
    n_out = int(round(steady_time[-1] * fs)) + 1
    # Where each steady sample lies in the recorded time, in samples of the doubled rate.
    positions = 2.0 * np.interp(np.arange(n_out) / fs, steady_time, np.arange(x.size) / fs) * fs
    doubled = scipy.signal.resample_poly(x, 2, 1)
    return scipy.ndimage.map_coordinates(doubled, positions[None, :], order=3, mode="nearest"), mean_rpm
