"""One vibration record and the labelled windows cut from many.

A :class:`Recording` is what every source yields, simulated or measured: one 1-D
signal with the facts needed to interpret it (sampling rate, shaft speed, bearing
state). A :class:`WindowedDataset` is what feature extractors and classifiers
consume: equal-length windows, their labels, and where each came from, so splits
can keep windows of one record apart.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bearingtwin.checks import is_finite_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS, check_fault

log = logging.getLogger(__name__)


CLIPPED_SHARE = 1e-3
"""A record with at least this share of its samples piled up at its largest or smallest value (:func:`piled_at`)
was clipped: a signal that is not reaches its extremes in a handful of samples, fewer than lie just below them."""
CLIP_EDGE = 0.0025
"""Share of a record's range at an extreme counted as at it: a limit in the sensor's amplifier reaches the
converter with its noise (a few codes) and any AC coupling's drift, not as one exact value."""
CLIP_BAND = 0.02
"""Share of a record's range below that edge that a clipped record leaves nearly empty."""
CLIPPED_SAMPLES = 10
"""... and at least this many samples (a short record's few equal peaks are no saturation)."""
DROPOUT_NOTE_S = 0.005
"""A stretch held at one value this long or longer is named (5 ms: 60 samples at 12 kHz, far longer than a
clipped peak's flat top)."""


SPIKE_LEVEL = 30.0
"""A sample this many times the record's typical deviation from its median (1.4826 x the median absolute deviation:
a Gaussian's standard deviation) or further is a spike. Bearing impacts stand up to 12 times it on the CWRU 0.007 in
records; a cable knock or an electrical transient stands 100 or more."""
SPIKES_PER_S = 1.0
"""Spikes as rare as this or rarer are isolated events, not a fault's impacts, which recur at a defect rate (tens to
hundreds a second)."""
SPIKE_OVER_PEAKS = 3.0
"""... and a spike stands this many times over the record's typical largest deviation in a second (the median over
its seconds): a fault's strongest impacts, a tail of the same train, stand within it."""
SPIKE_MERGE_S = 0.01
"""Crossings closer than this are one spike: a knock rings for a few milliseconds."""

LEVEL_RANGE = (1e-30, 1e30)
"""The largest magnitude a record may reach, in whatever unit: no vibration comes near either end (1 g is 1e9 ng and
1e-6 Mm/s^2), and squared levels beyond it leave a float's range in a spectrum or an RMS of a long record, which
would then read as infinite or NaN evidence rather than as a record scaled wrong."""


def piled_at(x: np.ndarray, top: float, bottom: float) -> np.ndarray:
    """Which samples of ``x`` (a boolean mask) lie within :data:`CLIP_EDGE` of the range (``top`` - ``bottom``) of
    ``top`` when more do than in the :data:`CLIP_BAND` just below that edge, else none. A hard limit piles samples up
    at one level over an empty band below it, even where the clipped ringing is too fast to leave flat tops (3 kHz
    at 12 kHz); a signal's own peaks, a sine's that repeat each period too, are outnumbered by the samples just below
    them. Soft saturation (a gradual compression) and a limit smoothed by a low-pass after it leave no such pile: they
    are not named. Falsely named: a noise-free tone quantized to a few codes, a half-wave rectified signal."""
    edge = top - CLIP_EDGE * (top - bottom)
    at = x >= edge
    below = int(np.count_nonzero((x < edge) & (x >= edge - CLIP_BAND * (top - bottom))))
    return at if np.count_nonzero(at) > below else np.zeros_like(at)


CLIPPED_NOTE_END = (": the sensor or the converter clipped (saturated), which flattens the impacts; what is read from "
                    "them may be off")
"""How :meth:`Recording.quality_notes` ends its note of a clipped record."""
HELD_NOTE_END = ": the windows over it read no vibration"
"""How :meth:`Recording.quality_notes` ends its note of the longest stretch held at one value."""


def _runs(signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start index and length (samples) of every run of equal consecutive samples of a 1-D signal, in order."""
    # Run boundaries: where a sample differs from the one before it.
    starts = np.concatenate([[0], np.flatnonzero(np.diff(signal) != 0) + 1])
    return starts, np.diff(np.concatenate([starts, [signal.size]]))


def longest_held_stretch(signal: np.ndarray) -> tuple[int, int]:
    """Start index and length (samples) of the longest run of equal consecutive samples of a 1-D signal."""
    signal = np.asarray(signal)
    if signal.size < 2:
        return 0, signal.size
    starts, lengths = _runs(signal)
    longest = int(np.argmax(lengths))
    return int(starts[longest]), int(lengths[longest])


def held_stretches(signal: np.ndarray, shortest: int) -> list[tuple[int, int]]:
    """Start index and length (samples) of every run of equal consecutive samples of a 1-D signal that is
    ``shortest`` samples long or longer (two at least: one sample is no stretch), in order."""
    starts, lengths = _runs(np.asarray(signal))
    held = lengths >= max(shortest, 2)
    return list(zip(starts[held].tolist(), lengths[held].tolist()))


@dataclass
class Recording:
    """A single-channel vibration record.

    Attributes:
        signal: 1-D float64 array (units in ``unit``).
        fs: sampling rate in Hz.
        rpm: shaft speed in rev/min (None when unknown).
        fault: bearing state, one of :data:`~bearingtwin.physics.geometry.FAULTS` (None when unknown).
        source: where it came from (a file path or a simulator description), used in messages.
        channel: channel name within the source (e.g. ``DE``, ``X``, ``inner_x``).
        unit: physical unit of ``signal`` (``m/s^2``, ``g``, ``V``, ...).
    """

    signal: np.ndarray
    fs: float
    rpm: float | None = None
    fault: str | None = None
    source: str = "<memory>"
    channel: str = ""
    unit: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        signal = np.asarray(self.signal)
        if signal.ndim != 1:
            raise BearingTwinError(f"{self.source}: a recording holds one channel, got shape {signal.shape}")
        if signal.size == 0:
            raise BearingTwinError(f"{self.source}: the recording is empty")
        if not np.issubdtype(signal.dtype, np.number):
            raise BearingTwinError(f"{self.source}: the signal is not numeric (dtype {signal.dtype})")
        self.signal = signal.astype(np.float64, copy=False)
        bad = ~np.isfinite(self.signal)
        n_bad = int(np.count_nonzero(bad))
        if n_bad == self.signal.size:
            raise BearingTwinError(f"{self.source}: channel {self.channel or '?'} holds no value: every one of its "
                                   f"{n_bad} samples is NaN or infinite")
        if n_bad:  # where, so a user can cut them out (an acquisition's dropout, a logger's missing rows)
            first, last = int(np.argmax(bad)), self.signal.size - 1 - int(np.argmax(bad[::-1]))
            seconds = is_finite_number(self.fs) and self.fs > 0
            where = (f"at sample {first}" + (f" ({first / self.fs:.6g} s)" if seconds else "") if n_bad == 1 else
                     f"the first at sample {first}, the last at {last}"
                     + (f" ({first / self.fs:.6g} s to {last / self.fs:.6g} s)" if seconds else ""))
            raise BearingTwinError(f"{self.source}: {n_bad} NaN or infinite values in channel {self.channel or '?'}, "
                                   f"{where}; no value is made up for them: cut them out, or give the stretches "
                                   "between them as files of their own")
        if not self.fs > 0:
            raise BearingTwinError(f"{self.source}: sampling rate must be positive, got {self.fs}")
        if self.rpm is not None and not self.rpm > 0:
            raise BearingTwinError(f"{self.source}: rpm must be positive, got {self.rpm}")
        if self.fault is not None:
            check_fault(self.fault)

    def require_vibration(self) -> None:
        """Refuse a record whose every sample is the same (a dead sensor, a disconnected channel), or that only
        rises or only falls (a column of time stamps or sample numbers read as the channel): it has no
        vibration to compare or diagnose, and any verdict on it would be made up."""
        flat = self._flat()
        if flat:
            raise BearingTwinError(f"{self.source}: {flat}")
        peak = float(np.nanmax(np.abs(self.signal)))  # NaN gaps are bridged or named elsewhere
        if not LEVEL_RANGE[0] <= peak <= LEVEL_RANGE[1]:
            raise BearingTwinError(f"{self.source}: channel {self.channel or '?'}'s largest magnitude, {peak:.3g}, lies "
                                   f"outside {LEVEL_RANGE[0]:g} to {LEVEL_RANGE[1]:g}, where a vibration lies in any "
                                   "unit: the numbers are scaled wrong or are no vibration")
        steps = np.diff(self.signal)
        if steps.size >= 2 and (np.all(steps >= 0) or np.all(steps <= 0)):  # not flat: ptp > 0 above
            raise BearingTwinError(
                f"{self.source}: channel {self.channel or '?'} {'rises' if steps.sum() > 0 else 'falls'} throughout, "
                f"from {self.signal[0]:g} to {self.signal[-1]:g}: time stamps or sample numbers, not a vibration; "
                "choose the vibration's channel (channel=<name or index>)")

    def quality_notes(self, shortest_dropout_s: float = DROPOUT_NOTE_S) -> list[str]:
        """What in the record may spoil a reading of it without making it unreadable: samples piled up at its
        extremes (the sensor or the converter clipped, flattening the impacts; :data:`CLIPPED_SHARE`) and a
        stretch held at one value for ``shortest_dropout_s`` or longer (a dropout), each named with where it is."""
        x = self.signal
        flat = self._flat()
        if flat:
            return [flat]
        notes = []
        # Fewer levels than the band below an extreme can tell apart (a two-level tacho pulse): no reading of clipping.
        piles = ([] if np.unique(x).size < 1 / CLIP_BAND else
                 [(name, level, piled_at(sign * x, sign * level, sign * other)) for name, level, other, sign in
                  (("maximum", x.max(), x.min(), 1.0), ("minimum", x.min(), x.max(), -1.0))])
        piles = [(name, level, piled) for name, level, piled in piles  # a side clipped on its own (one-sided too)
                 if np.count_nonzero(piled) >= max(CLIPPED_SAMPLES, CLIPPED_SHARE * x.size)]
        if piles:
            clipped = np.logical_or.reduce([piled for _, _, piled in piles])
            what = " and ".join(f"its {name}, {level:g}" for name, level, _ in piles)
            notes.append(f"{100 * np.count_nonzero(clipped) / x.size:.3g} % of the samples pile up at {what}, "
                         f"{self._stretches(clipped)}{CLIPPED_NOTE_END}")
        spikes = self._spikes()
        if spikes:
            notes.append(spikes)
        held = self._held_stretch(shortest_dropout_s)
        if held:  # the longest, and how many there are: twenty short dropouts are not one
            count = len(held_stretches(self.signal, max(2, math.ceil(shortest_dropout_s * self.fs))))
            notes.append(f"{held}{f', the longest of {count} such stretches' if count > 1 else ''}{HELD_NOTE_END}")
        return notes

    def _spikes(self) -> str | None:
        """What a few isolated spikes are (:data:`SPIKE_LEVEL`, at most :data:`SPIKES_PER_S` a second): "4 isolated
        spikes, up to 190 times the record's typical level, at 1.2, 3.4, ... s: ..."; None where there are none, or
        so many that they are the vibration's own."""
        deviation = np.abs(self.signal - np.median(self.signal))
        typical = 1.4826 * float(np.median(deviation))
        if typical == 0:
            return None
        threshold = SPIKE_LEVEL * typical
        second, seconds = max(1, int(self.fs)), deviation.size // max(1, int(self.fs))
        if seconds >= 3:  # over the strongest deviation a typical second holds: no tail of the vibration's own
            peaks = deviation[:seconds * second].reshape(seconds, second).max(axis=1)
            threshold = max(threshold, SPIKE_OVER_PEAKS * float(np.median(peaks)))
        beyond = np.flatnonzero(deviation >= threshold)
        if beyond.size == 0:
            return None
        starts = beyond[np.concatenate([[True], np.diff(beyond) > SPIKE_MERGE_S * self.fs])]  # a knock's ringing is one
        if starts.size > SPIKES_PER_S * self.signal.size / self.fs:
            return None
        at = ", ".join(f"{start / self.fs:.4g}" for start in starts[:5]) + (", ..." if starts.size > 5 else "")
        return (f"{starts.size} isolated spike{'s' * (starts.size > 1)}, up to {deviation.max() / typical:.0f} times "
                f"the record's typical level, at {at} s: a cable knock or an electrical transient, not a bearing's "
                "impacts, which recur; each lifts the envelope spectrum's floor, which may hide the defect lines")

    def _stretches(self, mask: np.ndarray) -> str:
        """Where the samples ``mask`` marks lie: "in 212 stretches from 1.2 s to 2.05 s" (the first one's start, the
        last one's end), "in one stretch from ..."."""
        starts = np.flatnonzero(np.diff(mask.astype(np.int8), prepend=0) == 1)
        last_end = np.flatnonzero(mask)[-1] + 1
        count = f"{starts.size} stretches" if starts.size > 1 else "one stretch"
        return f"in {count} from {starts[0] / self.fs:.3g} s to {last_end / self.fs:.3g} s"

    def _flat(self) -> str | None:
        """What a record of one value is ("every sample is 0: no vibration recorded"), None for any other."""
        return f"every sample is {self.signal[0]:g}: no vibration recorded" if np.ptp(self.signal) == 0 else None

    def _held_stretch(self, seconds: float) -> str | None:
        """Where the record holds one value for ``seconds`` or longer ("samples from 1 s to 1.3 s are all 0 (a
        dropout, ...)"), None where it holds none so long."""
        start, length = longest_held_stretch(self.signal)
        if length > 1 and length >= seconds * self.fs:
            return self.held_at(start, length)
        return None

    def held_at(self, start: int, length: int) -> str:
        """A stretch held at one value, from sample ``start`` for ``length`` samples, in seconds ("samples from 1 s
        to 1.3 s are all 0 (a dropout, or a stretch held at one value)")."""
        return (f"samples from {start / self.fs:.3g} s to {(start + length) / self.fs:.3g} s are all "
                f"{self.signal[start]:g} (a dropout, or a stretch held at one value)")

    def require_no_held_stretch(self, seconds: float, why: str) -> None:
        """Refuse a record holding one value for ``seconds`` or longer (a dropout, a sensor saturated or
        disconnected for a while): ``why`` says what such a stretch would spoil. Shorter runs (a quiet signal
        on a coarse converter, a clipped peak) are left alone."""
        held = self._held_stretch(seconds)
        if held:
            raise BearingTwinError(f"{self.source}: {held}, which would spoil {why}; cut it out of the record or "
                                   "choose another stretch")

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return self.signal.size / self.fs

    @property
    def label(self) -> int:
        """Class index of the bearing state in :data:`FAULTS` order."""
        if self.fault is None:
            raise BearingTwinError(f"{self.source}: the bearing state is unknown, so it has no label")
        return FAULTS.index(self.fault)


@dataclass
class WindowedDataset:
    """Equal-length windows cut from one or more recordings.

    Attributes:
        windows: (n_windows, window_length) float64.
        labels: (n_windows,) int class indices into ``class_names``.
        record_ids: (n_windows,) int index into ``records`` of the record each window came from.
        starts: (n_windows,) int first sample of each window within its record.
        records: the source of every record (file path or simulator key), for reports.
        fs: common sampling rate in Hz.
        class_names: names of the classes, index = label.
        key: a stable identifier of the dataset's content (used as a cache key and logged).
        fixed_split: (train_index, test_index) when the source decides the split itself (twin
            windows train, real windows test); None lets ``data.split`` decide.
        record_rpms: shaft speed of each record in rev/min, for features on the shaft-order
            axis; None when the source does not give it.
        validation: indices of windows in neither part of ``fixed_split``, scored on their own
            (``calibration_*`` metrics) and never trained on; empty when the source has none.
        window_normalization: what was done to every window after cutting (``none`` or ``zscore``,
            :func:`bearingtwin.data.windows.normalize_windows`); a diagnosis repeats it.
        unit: physical unit of the windows (``m/s^2``, ``g``); "" when the records do not state one. A
            diagnosis brings a record stated in another acceleration unit to it.
        bearing: the ``conf/bearing`` name of the bearing the records name themselves, where no setting gave one
            (``data=files``: a folder of HUST exports names the ER-16K); None: the config's (``data.bearing``).
    """

    windows: np.ndarray
    labels: np.ndarray
    record_ids: np.ndarray
    starts: np.ndarray
    records: list[str]
    fs: float
    class_names: tuple[str, ...] = FAULTS
    key: str = ""
    record_lengths: list[int] = field(default_factory=list)
    fixed_split: tuple[np.ndarray, np.ndarray] | None = None
    record_rpms: list[float] | None = None
    validation: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    window_normalization: str = "none"
    unit: str = ""
    bearing: str | None = None

    def __post_init__(self) -> None:
        n = len(self.windows)
        for name in ("labels", "record_ids", "starts"):
            if len(getattr(self, name)) != n:
                raise BearingTwinError(f"WindowedDataset.{name} has {len(getattr(self, name))} entries for {n} windows")

    def __len__(self) -> int:
        return len(self.windows)

    @property
    def window_rpms(self) -> np.ndarray | None:
        """(n_windows,) shaft speed in rev/min of each window's record, or None when unknown."""
        return None if self.record_rpms is None else np.asarray(self.record_rpms, dtype=np.float64)[self.record_ids]


def warn_of_quality(recordings: Iterable[Recording]) -> None:
    """Log each recording's :meth:`Recording.quality_notes` as a warning naming its file: a training run reads its
    real records as a diagnosis does, and a clipped record or a dropout in one must not pass unnoticed there either."""
    for recording in recordings:
        for note in recording.quality_notes():
            log.warning("%s: %s", Path(str(recording.source)).name, note)
