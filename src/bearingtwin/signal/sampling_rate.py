"""Is a record's sampling rate the one declared? The shaft's harmonic series as a witness.

A shaft turning at ``rpm`` puts a series of lines at multiples of ``rpm / 60`` into the
spectrum; under a wrong rate every frequency appears scaled by ``declared / true``.
:func:`check_sampling_rate` (the one check every command applies: training, twin,
inspect, and any caller with a signal, a rate and a speed) looks for that series.

A rate that is a whole-number fraction of the true one (``true / k``: 6000 Hz declared
for a 12 kHz record) is the hard case: every k-th line of the true series lands on the
expected series, which therefore still "matches". What gives it away is the rest of the
true series, which then falls *between* the expected harmonics, at the multiples of
``rpm / 60 / k`` that are not multiples of ``rpm / 60``. Such in-between lines can also be real (subharmonics of a loose or
rubbing machine), so a second witness decides when the caller knows the bearing's defect
frequencies: their envelope lines appear at ``f / k`` under the wrong rate and at ``f``
under the right one. Without a decisive witness the verdict is ``ambiguous``. So it is where the
only strong series near the shaft's place is the supply's (a motor's 50/60 Hz line or its pull at
twice it): those lines say nothing of the shaft line. A machine whose only shaft line is 1x (no
series at all) is checked by its bearing instead: a defect's comb in the envelope and that line,
both standing the same factor from their places, name the true rate.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import functools
import hashlib
import math
from dataclasses import asdict, dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
import scipy.fft
import scipy.signal
from scipy.ndimage import median_filter

from bearingtwin.checks import is_finite_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_record, check_positive
from bearingtwin.signal.speed import SPEED_OFF, supply_comb

VERDICTS = ("consistent", "contradicted", "ambiguous")
VERDICTS_BY_FAVOUR = ("consistent", "ambiguous", "contradicted")


@dataclass(frozen=True)
class ShaftLineCheck:
    """Whether a record's spectrum shows its shaft speed where the declared rate puts it.

    Attributes:
        fs_hz: the declared sampling rate; rpm: the measured speed.
        expected_hz: rpm / 60.
        observed_hz: the strong shaft-harmonic series nearest to ``expected_hz`` (None if none).
        implied_fs_hz: the rate the evidence points to (``fs_hz`` when consistent; None if unknown), as fine
            as the spectrum's resolution and the rates tried: within about 0.5 %, so a true 12000 Hz may read
            12021-12064 Hz; name the nominal rate it lies near.
        score: median prominence (peak / local median spectrum) of the first harmonics at
            ``observed_hz`` (at ``expected_hz`` if nothing was observed).
        matches: ``observed_hz`` lies within the tolerance of ``expected_hz``.
        verdict: ``consistent``, ``contradicted`` or ``ambiguous`` (see the module docstring).
        fraction: k when a series also stands at n x g for n not a multiple of k, g within ``slip`` of
            observed / k (between its harmonics: the declared rate may be near true / k).
        reason: one sentence explaining the verdict.
        witness: what confirmed the rate where the shaft series did not: ``series`` (the strong series is
            a defect frequency's) or ``envelope`` (a defect line in the envelope); ``supply`` where the strong
            series is the supply's, and ``half comb`` where it stands at half a defect comb with no line of its own
            (:func:`_half_of_a_comb`), and ``weak shaft series`` where the shaft's own series stands at its place,
            below a strong series' prominence (:func:`_weak_shaft_series`), each of which leaves the rate ``ambiguous``;
            None otherwise.
        fraction_rate_hz: with a ``fraction``, the rate at which its in-between lines would be the shaft's series.
        implied_confirmed: a contradiction whose implied rate another channel of the record confirms (its shaft
            series stands at its place there; set by :func:`check_channels`).
        defect_reading: where the series taken for the shaft's reads as a defect's instead
            (:func:`_series_also_read_as_a_defects`): that defect's name and the 1x line it puts below the series
            (Hz, at the declared rate); None otherwise.
    """

    fs_hz: float
    rpm: float
    expected_hz: float
    observed_hz: float | None
    implied_fs_hz: float | None
    score: float
    matches: bool
    verdict: str = "consistent"
    fraction: int | None = None
    reason: str = ""
    witness: str | None = None
    fraction_rate_hz: float | None = None
    implied_confirmed: bool = False
    defect_reading: tuple[str, float] | None = None

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass
class _Shared:
    """What :func:`shared_transforms` keeps: transforms by kind and content, and each array's content digest
    (the array kept beside it, so that its id is not another's while the scope lasts), within :data:`SHARED_BYTES`."""

    results: dict = dataclasses.field(default_factory=dict)
    digests: dict = dataclasses.field(default_factory=dict)
    centres: dict = dataclasses.field(default_factory=dict)  # a long channel's centre (a view), by id and length
    nbytes: int = 0

    def keeps(self, array: np.ndarray) -> bool:
        """Whether ``array`` fits in what is left, counted against it if so."""
        if self.nbytes + array.nbytes > SHARED_BYTES:
            return False
        self.nbytes += array.nbytes
        return True


_SHARED: contextvars.ContextVar[_Shared | None] = contextvars.ContextVar("bearingtwin_shared_transforms", default=None)


SHARED_BYTES = 256 * 2**20
"""The most :func:`shared_transforms` keeps (a 10 s CWRU record's three channels: 6 MB)."""


@contextlib.contextmanager
def shared_transforms():
    """Within it, each channel's spectrum and envelope are computed once however many rates are tried on it
    (a record's check tries several on every channel of its file, and no rate changes them; a 10 s CWRU
    record's length is a slow FFT size); forgotten on leaving, and never more than :data:`SHARED_BYTES` of them
    (a file of many long channels computes the rest each time, as without it). Nested uses share the outermost's."""
    token = _SHARED.set(_SHARED.get() or _Shared())
    try:
        yield
    finally:
        _SHARED.reset(token)


def _once(kind: str, samples: np.ndarray, compute: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """``compute(samples)``, or the result for the same content within :func:`shared_transforms` (read-only)."""
    shared = _SHARED.get()
    if shared is None:
        return compute(samples)
    key = (kind, samples.shape, _digest(shared, samples))
    if key in shared.results:
        return shared.results[key]
    result = compute(samples)
    if shared.keeps(result):
        result.flags.writeable = False
        shared.results[key] = result
    return result


def _digest(shared: _Shared, samples: np.ndarray) -> bytes:
    """The content's digest, computed once per array within :func:`shared_transforms`: a check hands the same
    channels and envelopes to every rate it tries, and hashing a 10 s channel costs a millisecond."""
    seen = shared.digests.get(id(samples))
    if seen is not None and seen[0] is samples:
        return seen[1]
    digest = hashlib.blake2b(np.ascontiguousarray(samples).tobytes(), digest_size=16).digest()
    if shared.keeps(samples):
        shared.digests[id(samples)] = (samples, digest)
    return digest


@functools.lru_cache(maxsize=4)
def _hann(size: int) -> np.ndarray:
    """The Hann window of ``size`` samples, read-only (a record's channels and envelopes share their length)."""
    window = np.hanning(size)
    window.flags.writeable = False
    return window


SPECTRUM_RANGE_DB = 120.0
"""How far below its maximum a spectrum the check reads is floored: beyond any recorder's range (a 24-bit converter's
is about 110 dB), so a measured record is read as it is, while a noiseless one (the twin's own) no longer has bins at
the arithmetic's precision, over whose median every leakage skirt would stand as a prominent line."""


def _magnitude_spectrum(x: np.ndarray) -> np.ndarray:
    """|rfft| of the mean-removed, Hann-windowed samples, floored :data:`SPECTRUM_RANGE_DB` below its maximum.
    scipy's FFT plans a slow length (a 10 s CWRU record: 2 x 41 x 1493 samples) twice as fast as numpy's, to the
    same values."""
    magnitude = np.abs(scipy.fft.rfft((x - x.mean()) * _hann(x.size)))
    return np.maximum(magnitude, magnitude.max() * 10 ** (-SPECTRUM_RANGE_DB / 20))


def _prominence_spectrum(signal: np.ndarray, fs: float, top_hz: float, background_hz: float) -> tuple[np.ndarray, float]:
    """Spectrum / local median spectrum up to ``top_hz``, and the bin width in Hz."""
    resolution = fs / signal.size
    spectrum = _once("spectrum", np.asarray(signal, dtype=np.float64), _magnitude_spectrum)
    spectrum = spectrum[: min(spectrum.size, int(math.ceil(top_hz / resolution)) + 2)]
    # At most the spectrum's own length: at a rate of a few Hz the background's width spans millions of bins.
    half_width_bins = min(int(round(background_hz / resolution / 2)), spectrum.size // 2)
    background = median_filter(spectrum, size=2 * half_width_bins + 1, mode="nearest")
    return spectrum / np.maximum(background, np.finfo(float).tiny), resolution


def _search_bins(frequencies_hz: np.ndarray, resolution: float, relative_width: float,
                 n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """First and past-the-last bin of the window within ``relative_width`` (at least one bin) of each frequency."""
    half_width = np.maximum(frequencies_hz * relative_width, resolution)
    low = np.clip(np.floor((frequencies_hz - half_width) / resolution).astype(int), 0, n_bins - 1)
    high = np.clip(np.ceil((frequencies_hz + half_width) / resolution).astype(int) + 1, low + 1, n_bins)
    return low, high


def _peak(ratio: np.ndarray, resolution: float, frequencies_hz: np.ndarray, relative_width: float) -> np.ndarray:
    """The largest prominence within ``relative_width`` (at least one bin) of each frequency."""
    frequencies_hz = np.asarray(frequencies_hz, dtype=float)
    low, high = _search_bins(frequencies_hz, resolution, relative_width, ratio.size)
    # Each window's maximum in one pass (a trial grid holds tens of thousands of windows): reduceat over the
    # interleaved bounds takes ratio[low:high] at even places; a -inf past the end lets high reach ratio.size.
    bounds = np.column_stack([low.ravel(), high.ravel()]).ravel()
    return np.maximum.reduceat(np.append(ratio, -np.inf), bounds)[::2].reshape(frequencies_hz.shape)


def _lone_line_words(ratio: np.ndarray, resolution: float, expected_hz: float, rpm: float, fs: float,
                     prominence: float) -> str:
    """What stands near the shaft line's place (``expected_hz``) in a record with no harmonic series: the lone line
    nearest it within a tenth of the shaft rate, named where its peak stands (a search window on the place may hold
    only the skirt of a line beside it), and, where that lies more than a bin and 1 % from the place (a speed given
    3 % high), the speed that would put the shaft's line there; else nothing."""
    low, high = _search_bins(np.array([expected_hz]), resolution, 0.1, ratio.size)
    window = ratio[low[0]:high[0]]
    peaks = [index for index in range(1, window.size - 1)
             if window[index] >= prominence and window[index] >= window[index - 1] and window[index] >= window[index + 1]]
    if not peaks:
        return "nothing to check the rate against"
    top = low[0] + min(peaks, key=lambda index: abs((low[0] + index) * resolution - expected_hz))
    line_hz, lone = top * resolution, float(ratio[top])
    if abs(line_hz - expected_hz) <= max(resolution, 0.01 * expected_hz):  # on its place, to a bin or 1 %
        return (f"a lone line stands at {line_hz:.2f} Hz (prominence {lone:.0f}) without harmonics, which a 2x line "
                "read at half the rate would show as well")
    return (f"a lone line without harmonics stands at {line_hz:.2f} Hz (prominence {lone:.0f}), "
            f"{100 * abs(line_hz / expected_hz - 1):.1f} % {'below' if line_hz < expected_hz else 'above'} the shaft "
            f"line's place at {rpm:g} rpm: if it is the shaft's, the speed is about {rpm * line_hz / expected_hz:.0f} "
            f"rpm (or the rate {fs * expected_hz / line_hz:.0f} Hz)")


def _refined_fundamental(ratio: np.ndarray, resolution: float, multiples: np.ndarray, fundamental_hz: float,
                         relative_width: float) -> float:
    """The fundamental of a series from where its lines stand: the median over ``multiples`` n of (the
    frequency of the largest prominence within ``relative_width`` of n x ``fundamental_hz``) / n. Finer than
    the trial grid it was found on, which is as coarse as a line's search window."""
    low, high = _search_bins(multiples * fundamental_hz, resolution, relative_width, ratio.size)
    peaks_hz = np.array([(a + np.argmax(ratio[a:b])) * resolution for a, b in zip(low, high)])
    return float(np.median(peaks_hz / multiples))


@shared_transforms()  # the implied rates it tries, and its second looks, read the same channel
def check_sampling_rate(
    signal: np.ndarray,
    fs: float,
    rpm: float,
    *,
    defect_hz: Mapping[str, float] | None = None,
    tolerance: float = 0.02,
    prominence: float = 20.0,
    n_harmonics: int = 5,
    harmonic_tolerance: float = 0.005,
    search_factor: float = 5.0,
    background_hz: float = 5.0,
    max_fraction: int = 10,
    slip: float = 0.05,
    follow_implied: bool = True,
) -> ShaftLineCheck:
    """Check the declared sampling rate ``fs`` (Hz) of a record against its shaft speed ``rpm``.

    For every trial fundamental between ``expected / search_factor`` and ``expected *
    search_factor`` the first ``n_harmonics`` harmonics are scored by their prominence over
    the local median spectrum (``background_hz`` wide); a series' score is the median, so
    most harmonics must stand out. The strong series (score >= ``prominence``) nearest the
    expected frequency is taken as the shaft's: far from it, the rate is contradicted, unless the bearing's
    defect lines or the supply explain that series (:func:`_second_look`). Near
    it, the in-between lines of every whole-number fraction k (2 .. ``max_fraction``) are
    scored too, and ``defect_hz`` (the bearing's defect frequencies at ``rpm``, any subset)
    decides whether strong ones mean a rate near ``fs * k`` (they are sought within ``slip`` of
    observed / k: a rate near true / k puts the shaft's own series there, and the series nearest the
    shaft's place may be a motor's supply line, a slip above twice the shaft's). With no strong series within
    ``search_factor``, one up to ``search_factor**2`` away contradicts the rate; none at all
    leaves it ``ambiguous`` (nothing to check it against); in both cases the defect lines may
    still witness it. A contradiction's implied rate is checked in turn: where the shaft series would stand
    between its harmonics at it (the series nearest the shaft's place was a supply or 2x line under a rate
    near true / k), the rate at which those in-between lines are the shaft's series is named and replaces
    it (``follow_implied``).

    Args:
        signal: 1-D record (whole record: the resolution fs / n must resolve the harmonics).
        fs: declared sampling rate in Hz.
        rpm: measured shaft speed in rev/min.
        defect_hz: defect frequencies in Hz (e.g. ``BearingGeometry.defect_frequencies(rpm)``),
            the second witness; None: fractions stay ``ambiguous``.
        tolerance: relative distance between observed and expected that still matches.
        prominence: how many times above the local median spectrum a series or line must stand.
        harmonic_tolerance: relative width of the search window around each harmonic.
        slip: how far below twice the supply frequency a motor's shaft may turn (relative): the in-between
            series is sought within it of observed / k, since the series taken for the shaft's may be the
            supply's.
        follow_implied: check a contradiction's implied rate in turn (False: the rate the nearest series
            implies, as read).
    """
    signal = as_record(signal, "signal", "the sampling-rate check")  # real, finite, at least 2 samples, as all take it
    check_positive(fs, "fs")
    check_positive(rpm, "rpm", "shaft speed in rev/min")
    for name, value in (("tolerance", tolerance), ("prominence", prominence), ("harmonic_tolerance", harmonic_tolerance),
                        ("background_hz", background_hz)):
        check_positive(value, name, "number")
    if not (is_finite_number(slip) and slip >= 0):  # 0: the in-between series sought at observed / k exactly
        raise BearingTwinError(f"slip must be a non-negative number (got {slip!r})")
    n_harmonics = whole_number("n_harmonics", n_harmonics)
    max_fraction = whole_number("max_fraction", max_fraction, minimum=2)
    if not search_factor > 1.0:
        raise BearingTwinError(f"search_factor must exceed 1, got {search_factor}")
    expected = rpm / 60.0
    resolution = fs / signal.size
    if resolution > tolerance * expected:
        raise BearingTwinError(
            f"the record is too short to check its sampling rate: {signal.size} samples give {resolution:.3g} Hz "
            f"resolution, too coarse to place a {expected:.3g} Hz shaft line within {tolerance:.0%}"
        )
    options = dict(defect_hz=defect_hz, tolerance=tolerance, prominence=prominence, n_harmonics=n_harmonics,
                   harmonic_tolerance=harmonic_tolerance, search_factor=search_factor, background_hz=background_hz,
                   max_fraction=max_fraction, slip=slip)

    def concluded(check: ShaftLineCheck) -> ShaftLineCheck:
        if not follow_implied:
            return check
        if check.verdict == "contradicted" and defect_hz:  # a contradiction made stands, said with its other reading
            check = _series_also_read_as_a_defects(check, defect_hz, ratio, resolution, prominence, harmonic_tolerance)
        checked = _implied_rate_checked(check, signal, options)
        rescued = _by_a_defect_alone(checked)
        if not (checked.verdict == "ambiguous" or rescued) or not defect_hz:
            return checked

        def confirmed(rate: float) -> bool:
            try:
                return check_sampling_rate(signal, rate, rpm, **options, follow_implied=False).verdict == "consistent"
            except BearingTwinError:  # too short to check at that rate
                return False

        if rescued:
            # The defect lines read at the declared rate may be another defect's under another rate; that rate must be
            # confirmed by the shaft series there, not by the same lines read as a defect's again.
            return _comb_contradiction(checked, signal, defect_hz, ratio, resolution, prominence, search_factor,
                                       harmonic_tolerance, tolerance,
                                       lambda rate: _shaft_series_at(signal, rate, rpm, options)) or checked
        return _defect_comb_elsewhere(checked, signal, defect_hz, ratio, resolution, prominence, search_factor,
                                      harmonic_tolerance, tolerance, confirmed)

    def second_look(check: ShaftLineCheck) -> ShaftLineCheck:
        return _second_look(check, signal, defect_hz, prominence, max_fraction, n_harmonics, harmonic_tolerance,
                            ratio, resolution)

    # The search reaches search_factor^2 on either side only to tell "no series anywhere" from "a series
    # too far away"; the shaft's series is looked for within search_factor.
    wide = search_factor**2
    top_hz = min(n_harmonics * expected * wide * 1.1, fs / 2.0)
    ratio, resolution = _prominence_spectrum(signal, fs, top_hz, background_hz)
    n_grid = int(math.ceil(2 * math.log(search_factor) / harmonic_tolerance)) + 1
    grid = expected * np.geomspace(1 / search_factor, search_factor, n_grid)
    grid_step = grid[1] / grid[0]  # the same geometric steps on to search_factor^2 either side
    steps = grid_step ** np.arange(1, int(math.ceil(math.log(search_factor) / math.log(grid_step))) + 1)
    beyond = np.concatenate([grid[0] / steps[::-1], grid[-1] * steps])
    below_nyquist = n_harmonics * beyond * (1 + harmonic_tolerance) < top_hz
    # Only the Nyquist frequency's cut says something of the rate; a record too short to resolve the lowest
    # trial fundamentals (a few seconds at most) merely searches less far below the shaft's place.
    searched_all, beyond = bool(below_nyquist.all()), beyond[below_nyquist & (beyond > 2 * resolution)]
    harmonics = np.arange(1, n_harmonics + 1)

    def scores(fundamentals_hz: np.ndarray) -> np.ndarray:
        return np.median(_peak(ratio, resolution, np.outer(harmonics, fundamentals_hz), harmonic_tolerance), axis=0)

    score = scores(grid)
    at_expected = float(score[np.argmin(np.abs(np.log(grid / expected)))])
    near = np.flatnonzero(score >= prominence)

    if near.size == 0:
        beyond_score = scores(beyond) if beyond.size else np.zeros(0)
        strong = np.flatnonzero(beyond_score >= prominence)
        if strong.size == 0 and searched_all:
            # Nothing anywhere contradicts the declared rate, and nothing confirms it: a machine without
            # unbalance, a simulation, a channel far from the shaft. A lone line where the shaft's belongs does
            # not confirm it either: read at half its rate, a record's 2x line stands there too.
            seen = _lone_line_words(ratio, resolution, expected, rpm, fs, prominence)
            check = ShaftLineCheck(fs, rpm, expected, None, None, at_expected, False, "ambiguous", None,
                                   f"no shaft harmonic series stands out near {expected:.2f} Hz (prominence "
                                   f"{at_expected:.1f}) nor anywhere from {expected / wide:.2f} to {expected * wide:.0f} "
                                   f"Hz: {seen}")
            return concluded(second_look(check))
        if strong.size == 0:  # the declared rate cannot even hold the search (Nyquist below it): far too low
            check = ShaftLineCheck(fs, rpm, expected, None, None, at_expected, False, "contradicted", None,
                                   f"no shaft harmonic series stands out near {expected:.2f} Hz (prominence "
                                   f"{at_expected:.1f}), and at fs = {fs:g} Hz the spectrum ends at {fs / 2:g} Hz")
            return concluded(second_look(check))
        farther = strong[np.argmin(np.abs(np.log(beyond[strong] / expected)))]
        observed = float(beyond[farther])
        check = ShaftLineCheck(fs, rpm, expected, observed, fs * expected / observed, float(beyond_score[farther]),
                               False, "contradicted", None,
                               f"no shaft harmonic series stands out near {expected:.2f} Hz (prominence {at_expected:.1f}); "
                               f"the nearest strong one is at {observed:.2f} Hz, implying fs = {fs * expected / observed:.0f} Hz")
        return concluded(second_look(check))
    nearest = near[np.argmin(np.abs(np.log(grid[near] / expected)))]
    observed = float(grid[nearest])
    common = dict(fs_hz=fs, rpm=rpm, expected_hz=expected, observed_hz=observed, score=float(score[nearest]))
    if abs(observed / expected - 1.0) > tolerance:
        check = second_look(ShaftLineCheck(**common, implied_fs_hz=fs * expected / observed, matches=False,
                                           verdict="contradicted",
                                           reason=f"the nearest strong harmonic series is at {observed:.2f} Hz, "
                                                  f"implying fs = {fs * expected / observed:.0f} Hz"))
        if check.verdict == "contradicted" and check.witness is None:
            check = _weak_shaft_series(check, ratio, resolution, at_expected, scores, prominence, harmonic_tolerance,
                                       slip, max_fraction)
        return concluded(check)

    # The same series' in-between lines: n x g for n not a multiple of k, g within ``slip`` of observed / k. The
    # series taken for the shaft's may be another one that a rate near true / k puts near the shaft's place (a
    # motor's supply line, a slip above twice the shaft's), the shaft's own series then a slip from observed / k.
    in_between, fundamentals = {}, {}
    for k in range(2, max_fraction + 1):
        n = np.array([m for m in range(1, n_harmonics * k) if m % k][: 2 * n_harmonics])
        trial = observed / k * _within_slip(slip, harmonic_tolerance)
        trial_scores = np.median(_peak(ratio, resolution, np.outer(n, trial), harmonic_tolerance), axis=0)
        # A line's window is wider than the trial step: of the equal best, the fundamental nearest observed / k.
        tied = np.flatnonzero(trial_scores >= trial_scores.max())
        best = int(tied[np.argmin(np.abs(np.log(trial[tied] * k / observed)))])
        in_between[k] = float(trial_scores[best])
        fundamentals[k] = _refined_fundamental(ratio, resolution, n, float(trial[best]), harmonic_tolerance)
    fraction = max(in_between, key=in_between.get)
    if in_between[fraction] < prominence:
        return ShaftLineCheck(**common, implied_fs_hz=fs, matches=True, verdict="consistent",
                              reason=f"the shaft series stands at {observed:.2f} Hz and nowhere between its harmonics")
    below = fundamentals[fraction]
    suspicion = (f"the shaft series also stands between its harmonics, at multiples of {below:.2f} Hz "
                 f"(prominence {in_between[fraction]:.0f})")
    # Were those lines the shaft's own, the true rate would put them at rpm / 60: a whole multiple of the declared
    # one when they stand at expected / k (within a search window), else the rate their fundamental implies.
    whole = abs(math.log(below * fraction / expected)) <= harmonic_tolerance
    rate_if_shaft = fs * fraction if whole else fs * expected / below
    verdict, implied, why = "ambiguous", None, "no defect frequency was given to decide"
    if defect_hz:
        verdict, implied, why = _defect_witness(signal, fs, expected, defect_hz, fraction, below / expected,
                                                rate_if_shaft, prominence, max_fraction)
    if verdict == "ambiguous":
        times = f"{fraction}" if whole else f"{rate_if_shaft / fs:.3g}"
        # Half orders are also a machine's own mark (a loose foot, a rub), which no rate explains: the check cannot
        # tell the two apart without a defect line, so it names both.
        machine = (", or the machine makes lines between its shaft orders (looseness and rubs make half orders)"
                   if whole and fraction == 2 else "")
        why = f": fs may be {rate_if_shaft:.0f} Hz ({times} times {fs:.0f} Hz){machine}; {why}"
    check = ShaftLineCheck(**common, implied_fs_hz=implied, matches=True, verdict=verdict, fraction=fraction,
                           reason=suspicion + why, fraction_rate_hz=rate_if_shaft)
    # A rate the in-between lines and a defect line name is checked in turn, as any contradiction's (a record at 48 kHz
    # declared at 12: its lines at half their places name 24 kHz, where they stand at half their places again); where
    # the rates followed confirm none, the first stands as named (a speed ten times too high wanders off otherwise).
    followed = _implied_rate_checked(check, signal, options) if follow_implied else check
    return followed if followed.implied_fs_hz else check


def _series_also_read_as_a_defects(check: ShaftLineCheck, defect_hz: Mapping[str, float], ratio: np.ndarray,
                                   resolution: float, prominence: float, window: float) -> ShaftLineCheck:
    """A contradiction whose rate was read off a strong series taken for the shaft's, said with the series' other
    reading where the record bears it: a race's impacts (or a ball's) form a sharp series in the spectrum itself,
    and on a machine with a lone 1x line it is the strongest there. Read as a defect's, the series puts the rate
    where the shaft's line stands below it; where a line stands there (``ratio``, ``resolution``: the record's
    prominence spectrum at the declared rate), the reason names that reading too, its most prominent line first.
    The rate named stays the shaft reading's: the record read at either rate confirms it by the series itself, and
    a line below a shaft series (a belt's, a whirl's) can stand anywhere, so the spectrum alone does not decide."""
    if check.observed_hz is None or check.implied_fs_hz is None or check.fraction:
        return check
    readings = []
    for name, hz in named_defect_hz(defect_hz).items():
        if name not in _COMB_NAMES:
            continue
        rate = check.fs_hz * hz / check.observed_hz
        shaft_hz = check.expected_hz * check.fs_hz / rate  # where the shaft's line stands, read at the declared rate
        if abs(math.log(rate / check.implied_fs_hz)) <= window or _supply_multiple(shaft_hz) is not None:
            continue
        line = float(_peak(ratio, resolution, np.array([shaft_hz]), window)[0])
        if line >= prominence:
            readings.append((line, name, rate, shaft_hz))
    if not readings:
        return check
    _, name, rate, shaft_hz = max(readings)
    return dataclasses.replace(check, defect_reading=(name, shaft_hz), reason=(
        f"{check.reason} if it is the shaft's series; read as {name}'s, it puts fs at {rate:.0f} Hz, where the line "
        f"standing near {shaft_hz:.1f} Hz would be the shaft's 1x"))


def _implied_rate_checked(check: ShaftLineCheck, signal: np.ndarray, options: Mapping,
                          max_steps: int = 3) -> ShaftLineCheck:
    """A contradiction whose implied rate is checked in turn: where the shaft series would stand between its
    harmonics at that rate, the rate at which those in-between lines are the shaft's series replaces it, said so
    (a record's 1x line is far more common than lines at half orders, and the defect lines, where given,
    confirm it or leave it in doubt). Each rate named so is checked in turn, and where the record read at it is
    refused or its in-between lines name another, that one is followed (up to ``max_steps`` rates): the first the
    record does not refuse is named (a doubt there is no refusal), and where none is, no rate is (each series read
    as the shaft's placed it elsewhere)."""
    if check.verdict != "contradicted" or not check.implied_fs_hz:
        return check
    reason, rate, visited = check.reason, check.implied_fs_hz, [check.fs_hz]
    for step in range(max_steps):
        try:
            again = check_sampling_rate(signal, rate, check.rpm, **options, follow_implied=False)
        except BearingTwinError:  # the implied rate cannot be checked (too short a record at it): it stands as read
            break
        # The first rate named is followed where its in-between lines name another (as before it was read again); from
        # the second on, only a refusal is: a doubt there (a machine's own half orders) is the record's, whatever its rate.
        if again.verdict == "consistent" or (again.verdict == "ambiguous" and (step or not again.fraction)):
            break
        reason = f"{reason}; at {rate:.0f} Hz, {again.reason}"
        visited.append(rate)
        following = again.implied_fs_hz or again.fraction_rate_hz
        if following and abs(math.log(following / check.fs_hz)) <= options["tolerance"]:
            # Back at the declared rate: the strong series read as the shaft's stands between the shaft's harmonics
            # there, which is what the declared rate's own lines make. Nothing read contradicts it (nor confirms it).
            return dataclasses.replace(check, verdict="ambiguous", implied_fs_hz=None, reason=(
                f"{reason}: the readings lead back to the declared {check.fs_hz:g} Hz, which none contradicts"))
        if not following or any(abs(math.log(following / seen)) <= options["tolerance"] for seen in visited):
            rate = None  # nothing named, or a rate already read: the readings go round
            break
        rate = following
    else:
        rate = None  # the last rate named was not read: none of those read was confirmed
    if reason == check.reason:
        return check
    return dataclasses.replace(check, implied_fs_hz=rate,
                               reason=reason if rate else f"{reason}: none of the rates read is confirmed")


def check_channels(channels: Mapping[str, np.ndarray], fs: float, rpm: float, **options) -> dict[str, ShaftLineCheck]:
    """:func:`check_sampling_rate` on every channel of one record with finite samples, ``options`` passed
    on: the channels share the record's rate, so each is a witness (:func:`decisive_channel`). A channel with NaN or
    infinite samples (a logger's lost packets, or a gap a diagnosis bridged and marked so) is read on its longest
    stretch of finite samples (:func:`longest_finite_stretch`)."""
    length = _samples_to_read(fs, rpm, options.get("tolerance", 0.02))
    stretches = {name: longest_finite_stretch(values) for name, values in channels.items()}
    finite = {name: _centre(values, length) for name, values in stretches.items() if values.size}
    checks = {name: check_sampling_rate(values, fs, rpm, **options) for name, values in finite.items()}
    if not checks:
        raise BearingTwinError("the sampling-rate check needs a channel with finite samples")
    # Where a channel is confirmed by a defect line alone, another channel's refusal weighs as much as the rate it
    # names holds. Read at that rate, the refusing channel's own series stands at the shaft's place by construction,
    # so another channel must confirm it: its shaft series standing at its place there.
    if any(_by_a_defect_alone(check) for check in checks.values()):
        for name, check in checks.items():
            if check.verdict == "contradicted" and check.implied_fs_hz:
                confirmed = any(_shaft_series_at(values, check.implied_fs_hz, rpm, options)
                                for other, values in finite.items() if other != name)
                checks[name] = dataclasses.replace(check, implied_confirmed=confirmed)
    return checks


def true_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and length of every run of True in a 1-D boolean ``mask``, in order."""
    edges = np.diff(np.asarray(mask, dtype=np.int8), prepend=0, append=0)
    starts = np.flatnonzero(edges == 1)
    return starts, np.flatnonzero(edges == -1) - starts


def longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Start and length of the longest run of True in a 1-D boolean ``mask``; ``(0, 0)`` where it holds none."""
    starts, lengths = true_runs(mask)
    if not starts.size:
        return 0, 0
    longest = int(np.argmax(lengths))
    return int(starts[longest]), int(lengths[longest])


def longest_finite_stretch(values: np.ndarray) -> np.ndarray:
    """``values`` itself where every sample is finite, else its longest run of finite samples (:func:`longest_run`;
    empty where it has none). Any value put in a gap's place is a click whose flat spectrum fills the quiet band below a
    few hundred Hz where a shaft's lines stand: ten samples bridged by a straight line in the middle of a 10 s record
    (a ten thousandth of its energy) took a CWRU record's shaft series from a median prominence of 70 to 4."""
    values = np.asarray(values)
    finite = np.isfinite(values)
    if finite.all():
        return values
    start, length = longest_run(finite)
    return values[start:start + length]


def _shaft_series_at(signal: np.ndarray, fs: float, rpm: float, options: Mapping) -> bool:
    """Whether ``signal`` read at ``fs`` shows the shaft series at its place (a record too short to tell: no)."""
    try:
        again = check_sampling_rate(signal, fs, rpm, **options, follow_implied=False)
    except BearingTwinError:
        return False
    return again.verdict == "consistent" and again.matches


def _by_a_defect_alone(check: ShaftLineCheck) -> bool:
    """Whether ``check`` took its rate from a defect's lines alone, its shaft series not at its place."""
    return check.verdict == "consistent" and check.witness in ("series", "envelope")


RATE_CHECK_SAMPLES = 2**20
"""The fewest samples of a channel the rate check reads, its centre's (20 s at 51.2 kHz, 87 s at 12 kHz): a shaft
series is placed far finer than the check's 2 % within them, and a long multi-channel recording's spectra and
envelopes then stay within :data:`SHARED_BYTES`, computed once for every rate and speed tried. A slow shaft takes
more (:func:`_samples_to_read`)."""


def rate_witnesses(signal: np.ndarray, channels: Mapping[str, np.ndarray] | None) -> dict[str, np.ndarray]:
    """The channels of ``signal``'s file that witness its one rate (those of its length, a tachometer's pulses
    left out: their comb is no vibration's), or ``signal`` alone when the file gives no other."""
    same_length = {name: values for name, values in (channels or {}).items()
                   if np.shape(values) == np.shape(signal) and not is_pulse_train(values)}
    return same_length or {"signal": signal}


def _samples_to_read(fs: float, rpm: float, tolerance: float) -> int:
    """How many samples of a channel the check reads at ``rpm``: :data:`RATE_CHECK_SAMPLES`, or, where a slow shaft
    needs more to place its line within ``tolerance`` (fs / (tolerance x shaft rate) samples), twice those, rounded
    up to a power of two times it, so that the speeds a whole factor lower share few lengths (and transforms)."""
    if not all(is_finite_number(value) and value > 0 for value in (fs, rpm, tolerance)):
        return RATE_CHECK_SAMPLES  # check_sampling_rate refuses such a value, naming it
    needed = 2.0 * fs / (tolerance * rpm / 60.0)
    return RATE_CHECK_SAMPLES * 2 ** max(0, math.ceil(math.log2(needed / RATE_CHECK_SAMPLES)))


def _centre(values: np.ndarray, length: int) -> np.ndarray:
    """``values`` cut to their centre's ``length`` samples; within :func:`shared_transforms` one view per channel
    and length for every rate tried, so its content digest is computed once."""
    size = np.shape(values)[-1]
    if size <= length:
        return values
    shared = _SHARED.get()
    seen = None if shared is None else shared.centres.get((id(values), length))
    if seen is not None and seen[0] is values:
        return seen[1]
    start = (size - length) // 2
    centre = values[..., start:start + length]
    if shared is not None:
        shared.centres[(id(values), length)] = (values, centre)
    return centre


def is_pulse_train(values: np.ndarray, max_samples: int = 2**16) -> bool:
    """Whether a channel holds a pulse train (a tachometer's, a key phasor's) rather than a vibration: nine samples
    in ten within a tenth of its range from one of its two levels (its 1st and 99th percentiles), each level held
    by at least one sample in a hundred. A vibration spreads over its range (a sine keeps 41 % of its samples so
    near its peaks, noise a few %); up to ``max_samples``, evenly spaced, are read. A key phasor whose pulse lasts
    under a hundredth of a turn is not told apart: a vibration's rare impacts must not be taken for pulses."""
    x = np.ravel(values)
    x = x[:: max(1, x.size // max_samples)].astype(np.float64)
    x = x[np.isfinite(x)]
    if x.size < 100:
        return False
    low, high = np.percentile(x, [1.0, 99.0])
    near = 0.1 * (high - low)
    if not near > 0:
        return False
    at_low, at_high = np.abs(x - low) <= near, np.abs(x - high) <= near
    return bool(np.mean(at_low | at_high) >= 0.9 and min(at_low.mean(), at_high.mean()) >= 0.01)


def decisive_channel(checks: Mapping[str, ShaftLineCheck]) -> str:
    """The channel whose check stands for the record: the most favourable verdict (consistent, then
    ambiguous, then contradicted, then a channel showing no series at all or only the supply's; the first of
    equals),
    unless another channel holds evidence that the rate is too low by a whole factor. A channel's other lines can pass for a shaft series at a fraction
    of the true rate (a fan-end channel's 58 Hz series read at half of 12 kHz), so a defect line standing
    at 1/k of its frequency (a contradiction with a ``fraction``) overrules every other channel, and lines
    between the shaft harmonics (an ambiguous ``fraction``) leave the record ambiguous unless a channel's
    defect line showed them to be real subharmonics (a consistent ``fraction``). A channel confirmed only by a
    series at a defect frequency (``witness`` ``series``) does not count where another channel's shaft series
    stands a whole factor from its place: a wrong rate can put any series on a defect line by chance. Nor does a
    channel confirmed by a defect's lines alone (``series`` or ``envelope``) where another channel refuses the rate
    naming one that another channel confirms (``implied_confirmed``, :func:`check_channels`)."""
    names = list(checks)
    too_low = [name for name in names if checks[name].fraction and checks[name].verdict == "contradicted"]
    if too_low:
        return too_low[0]
    # Another channel's strong series may land on a defect frequency under a wrong rate (record 118's fan-end
    # 53.7 Hz series read at twice its 12 kHz stands on BPFO): a shaft series a whole factor from its place in
    # one channel outweighs that coincidence in another.
    if any(_off_by_a_whole_factor(checks[name]) for name in names):
        names = [name for name in names if checks[name].witness != "series"] or names
    # A defect line can stand where a wrong rate expects one by chance, or be another defect's under it (one race's
    # comb at the other's place): a channel whose refusal names a rate another channel confirms outweighs that.
    if any(checks[name].verdict == "contradicted" and checks[name].implied_confirmed for name in names):
        names = [name for name in names if not _by_a_defect_alone(checks[name])] or names

    def favour(name: str) -> int:  # a channel with no series at all (noise), or only the supply's or half a comb's,
        check = checks[name]          # says nothing after a contradiction
        no_evidence = check.verdict == "ambiguous" and ((check.observed_hz is None and check.fraction is None)
                                                         or check.witness in ("supply", "half comb"))
        return len(VERDICTS_BY_FAVOUR) if no_evidence else VERDICTS_BY_FAVOUR.index(check.verdict)

    best = min(names, key=favour)
    doubts = [name for name in names if checks[name].fraction and checks[name].verdict == "ambiguous"]
    settled = any(checks[name].fraction and checks[name].verdict == "consistent" for name in names)
    if checks[best].verdict == "consistent" and doubts and not settled:
        return doubts[0]
    return best


def _off_by_a_whole_factor(check: ShaftLineCheck, max_factor: int = 8) -> bool:
    """Whether ``check`` contradicts its rate with a series n or 1 / n times the shaft line (n = 2 .. ``max_factor``):
    the shaft's own series under a rate off by that factor."""
    return (check.verdict == "contradicted" and check.observed_hz is not None
            and _a_whole_factor_from(check.observed_hz, [check.expected_hz], max_factor, 2 * _WINDOW))


def _second_look(check: ShaftLineCheck, signal: np.ndarray, defect_hz: Mapping[str, float] | None,
                 prominence: float, max_fraction: int, n_harmonics: int, window: float, ratio: np.ndarray,
                 resolution: float) -> ShaftLineCheck:
    """A contradiction stands unless the bearing's own lines explain it at the declared rate, or the
    supply's leave it undecided.

    An accelerometer far from the shaft (a fan-end channel, a housing) may show the shaft series
    too weakly beside stronger lines of other machine elements, and a machine may have no
    unbalance to show. Two witnesses then speak for the declared rate:

    - the strong series taken for the shaft's is a defect frequency's at the declared rate (a
      spalled race's comb in the spectrum itself), and no whole multiple or fraction (n or 1 / n,
      n up to 4) of the shaft line or of another defect frequency, where a rate off by that factor
      would put the shaft's own series (the SKF 6203's BSF is 1.994 x shaft) or another defect's
      (BSF and 2 x BSF);
    - a defect line and its second harmonic in the envelope at their own frequencies, at none of
      their half, third or quarter (where a rate too low by that factor would put them), and away
      from the shaft's harmonics and their fractions (where a wrong rate puts the shaft's own
      lines).

    Either makes the rate ``consistent``, with ``matches`` still false (the shaft series does not
    stand where it belongs). Without either, a series at half a defect comb with no line at its own fundamental,
    the envelope's comb standing at the comb's frequency and not at half it (:func:`_half_of_a_comb`), makes it
    ``ambiguous`` (``witness`` ``half comb``). A series whose fundamental is a grid's supply frequency
    or twice it (a motor's magnetic pull, strong on many machines) and no whole multiple or fraction
    of the shaft line, or one whose lines stand nearer the supply's multiples than the shaft's
    (:func:`_nearer_the_supply`), makes it ``ambiguous`` (``witness`` ``supply``): those lines stand
    there whatever the shaft speed, so they do not place the shaft line. A truly wrong rate can put a shaft series
    there by chance (about 2 % of wrong pairs of common rates and speeds by a factor that is no whole
    number): it is then logged, not refused, and another channel's contradiction still decides
    (:func:`decisive_channel`)."""
    if defect_hz:
        explained = _defect_series_named(check.observed_hz, check.expected_hz, defect_hz)
        lower = explained and _series_below(signal, check, n_harmonics, window, prominence)
        if lower:
            (name, hz), m = explained, lower
            return dataclasses.replace(
                check, implied_fs_hz=check.fs_hz * m, verdict="contradicted", witness="series",
                reason=f"{check.reason}; that series stands where the bearing's {name} does at {check.rpm:g} rpm "
                       f"({hz:.2f} Hz), but lines stand between its harmonics, at multiples of "
                       f"{check.observed_hz / m:.2f} Hz: {name}'s own at a speed of {check.rpm / m:.0f} rpm, or a "
                       f"rate of {check.fs_hz * m:.0f} Hz")
        if explained is not None:
            name, hz = explained
            return dataclasses.replace(check, implied_fs_hz=check.fs_hz, verdict="consistent", witness="series",
                                       reason=f"{check.reason}; but that series is the bearing's {name} ({hz:.2f} Hz "
                                              f"at {check.rpm:g} rpm), where a rate off by a whole factor puts no shaft line")
        witness = _defect_series_at_its_frequency(signal, check.fs_hz, check.expected_hz, defect_hz, prominence,
                                                  max_speed_factor=max_fraction)
        if witness is not None:
            return dataclasses.replace(check, implied_fs_hz=check.fs_hz, verdict="consistent", witness="envelope",
                                       reason=f"{check.reason}; but the envelope lines of {witness} and its second "
                                              f"harmonic stand at their frequencies")
        half = _half_of_a_comb(check, signal, defect_hz, prominence, window)
        if half is not None:
            name, hz = half
            return dataclasses.replace(check, implied_fs_hz=None, verdict="ambiguous", witness="half comb",
                                       reason=f"{check.reason}; but that series lies at half the bearing's {name} "
                                              f"({hz:.2f} Hz at {check.rpm:g} rpm) with no line at its own fundamental, "
                                              f"and the envelope's {name} comb stands at its frequency, not at half it: "
                                              "the shaft's own series is not seen, the rate is not confirmed")
    supply = _supply_multiple(check.observed_hz)
    if check.verdict == "contradicted" and supply is not None:
        order, mains = supply
        if not _off_by_a_whole_factor(check):
            return dataclasses.replace(
                check, implied_fs_hz=None, verdict="ambiguous", witness="supply",
                reason=f"{check.reason}; but {check.observed_hz:.2f} Hz is {order} x the {mains:g} Hz supply, whose "
                       "lines stand there whatever the shaft speed, and no whole multiple or fraction of the shaft "
                       "line: the rate is not confirmed")
        lines_hz = _refined_fundamental(ratio, resolution, np.arange(1, n_harmonics + 1), check.observed_hz, window)
        if _nearer_the_supply(lines_hz, order * mains, check.expected_hz):
            return dataclasses.replace(
                check, implied_fs_hz=None, verdict="ambiguous", witness="supply",
                reason=f"{check.reason}; but its lines stand at multiples of {lines_hz:.2f} Hz, {order} x the {mains:g} "
                       "Hz supply, whose lines stand there whatever the shaft speed, nearer those than any whole "
                       "multiple or fraction of the shaft line: the rate is not confirmed")
    return check


def _nearer_the_supply(lines_hz: float, supply_hz: float, shaft_hz: float, max_factor: int = 8) -> bool:
    """Whether a series' fundamental ``lines_hz``, placed finer than the trial grid that found it, stands nearer
    ``supply_hz`` (a supply frequency or twice it) than any whole multiple or fraction (up to ``max_factor``) of the
    shaft line ``shaft_hz``, where a wrong rate would put the shaft's own series. A 4-pole motor on a 50 Hz supply
    turns at about 1480 rpm: its magnetic pull's comb (100, 200, 300 Hz) lies 1.35 % from four times its shaft line,
    within a trial window of both, and its lines stand at the supply's multiples. A record read at a quarter of its
    rate puts the shaft series of a 60 Hz motor at 1797 rpm at 119.8 Hz, 0.17 % from 120 Hz: its lines stand at four
    times the shaft line's, and the contradiction stays."""
    shaft_places_hz = shaft_hz * _whole_factors(max_factor)
    return abs(math.log(lines_hz / supply_hz)) < float(np.min(np.abs(np.log(lines_hz / shaft_places_hz))))


def _within_slip(slip: float, window: float) -> np.ndarray:
    """Factors from 1 - ``slip`` to 1 + ``slip`` in geometric steps of a search ``window`` (relative): the places a
    series a motor's slip from another may stand at, no line falling between two trials' windows."""
    return np.geomspace(1 - slip, 1 + slip, int(math.ceil(math.log((1 + slip) / (1 - slip)) / window)) + 1)


def _weak_shaft_series(check: ShaftLineCheck, ratio: np.ndarray, resolution: float, at_expected: float,
                       scores: Callable[[np.ndarray], np.ndarray], prominence: float, window: float, slip: float,
                       max_fraction: int) -> ShaftLineCheck:
    """``check``'s contradiction left in doubt (``witness`` ``weak shaft series``) where the shaft's own series stands
    where the declared rate puts it, below the strong series' prominence (a short record's coarse lines; a machine
    whose other lines outstand its shaft's): its median prominence (``at_expected``) half the threshold, its 1x line
    the whole, and no series standing as high within ``slip`` of 1 / k of its place (k = 2 .. ``max_fraction``). Under
    a rate too high the 1x line would be a fraction's of the true shaft's, which stands that high on no machine as a
    rule; under a rate too low by about k (or a speed typed k times too high) it is the true k-th harmonic, and the
    true shaft's series stands at 1 / k of its place. ``check`` as it was otherwise."""
    expected = check.expected_hz
    first = float(_peak(ratio, resolution, np.array([expected]), window)[0])
    if at_expected < prominence / 2 or first < prominence:
        return check
    fractions = np.outer(expected / np.arange(2, max_fraction + 1), _within_slip(slip, window))
    if np.any(scores(fractions[fractions > 2 * resolution]) >= min(at_expected, prominence)):
        return check
    return dataclasses.replace(check, implied_fs_hz=None, verdict="ambiguous", witness="weak shaft series",
                               reason=f"{check.reason}; but the shaft's own series stands where the declared rate puts "
                                      f"it, weaker (median prominence {at_expected:.0f}, its 1x line {first:.0f}): the "
                                      "rate is not contradicted, nor confirmed")


def _line_stands(signal: np.ndarray, fs: float, hz: float, prominence: float, window: float) -> bool:
    """Whether a line stands at ``hz`` in ``signal`` read at ``fs`` (its prominence at least ``prominence``)."""
    ratio, resolution = _prominence_spectrum(signal, fs, min(2.0 * hz, fs / 2), background_hz=5.0)
    return bool(_peak(ratio, resolution, np.array([hz]), window)[0] >= prominence)


def _half_of_a_comb(check: ShaftLineCheck, signal: np.ndarray, defect_hz: Mapping[str, float], prominence: float,
                    window: float) -> tuple[str, float] | None:
    """(name, frequency) of the defect comb at half of which ``check``'s contradicting series stands with no line at
    its own fundamental, while the envelope's comb stands at the comb's frequency and not at half it; None
    otherwise. A series scored on its harmonics' median takes its even harmonics from a strong comb (half the BPFO:
    the outer race's own lines), and a noise floor that buries the shaft's weak series leaves it nearest the
    shaft's place. Under a rate exactly twice too low the comb itself stands at half its frequency, its envelope
    comb too: that is read as the rate's contradiction, not as this."""
    if check.verdict != "contradicted" or check.observed_hz is None:
        return None
    hz = check.observed_hz
    halved = [(name, comb) for name, comb in named_defect_hz(defect_hz).items()
              if name in _COMB_NAMES and abs(math.log(2 * hz / comb)) <= 2 * window]
    if not halved or _line_stands(signal, check.fs_hz, hz, prominence, window):
        return None
    name, comb = halved[0]
    ratio, resolution = _envelope_prominence(signal, check.fs_hz, min(2.2 * comb, check.fs_hz / 2))
    at_comb, at_half = _comb_prominence(ratio, resolution, np.array([comb, comb / 2]), window)
    return (name, comb) if at_comb >= prominence > at_half else None


def _series_below(signal: np.ndarray, check: ShaftLineCheck, n_harmonics: int, window: float,
                  prominence: float) -> int | None:
    """The k (2 .. :data:`_MAX_FRACTION`) at which the strong series at ``check.observed_hz`` stands between its
    harmonics too, at multiples of observed / k that are no multiple of k (those below its ``n_harmonics``-th
    harmonic, at most 2 x ``n_harmonics`` of them, judged by their median as the series itself is): it is then the
    k-th harmonics of a comb at observed / k. Under a speed k times too high every defect frequency lands on its
    k-th harmonic, so a race's comb is read there as the declared speed's; a record without a shaft series of its
    own (the twin's) has only its in-between lines to tell the two readings apart. None where none stands, or where observed / k lies on a shaft harmonic, whose lines
    stand there whatever the speed."""
    hz = check.observed_hz
    ratio, resolution = _prominence_spectrum(signal, check.fs_hz, min(1.1 * n_harmonics * hz, check.fs_hz / 2),
                                             background_hz=5.0)
    for k in range(2, _MAX_FRACTION + 1):
        if not _apart_from_shaft(hz / k, check.expected_hz, 1, window):
            continue
        multiples = np.array([m for m in range(1, n_harmonics * k) if m % k][: 2 * n_harmonics])
        if np.median(_peak(ratio, resolution, multiples * hz / k, window)) >= prominence:
            return k
    return None


_MAX_FRACTION = 4
"""Rates off by a whole factor up to this are the ones a defect witness must tell apart (12 against 48 kHz)."""
_WINDOW = 0.005
"""Relative half-width of the search window around a line (the series search's grid step)."""

MAINS_HZ = (50.0, 60.0)
"""Supply frequencies of the world's grids."""


def _supply_multiple(hz: float | None, max_order: int = 2, tolerance: float = 2 * _WINDOW) -> tuple[int, float] | None:
    """(n, supply) when ``hz`` lies within ``tolerance`` (relative) of n x a grid's supply frequency, n = 1 ..
    ``max_order``: the fundamentals of the series a motor's supply leaves (its own line, and its magnetic pull at
    twice it); None otherwise. Higher multiples are no series' fundamental and would cover more of the spectrum
    where a shaft series under a wrong rate may stand."""
    if hz is None:
        return None
    distance, order, mains = min((abs(math.log(hz / (n * f))), n, f) for n in range(1, max_order + 1) for f in MAINS_HZ)
    return (order, mains) if distance <= tolerance else None


def _defect_series_named(observed_hz: float | None, shaft_hz: float, defect_hz: Mapping[str, float],
                         max_factor: int = _MAX_FRACTION, tolerance: float = 2 * _WINDOW) -> tuple[str, float] | None:
    """The defect frequency (a ball defect's comb at 2 x BSF included) within ``tolerance`` of ``observed_hz``,
    a series' fundamental, unless a rate off by a whole factor n (2 .. ``max_factor``) would put another line
    there: n or 1 / n times the shaft's (its own series) or another defect frequency (BSF and 2 x BSF are
    one such pair); None otherwise."""
    if observed_hz is None:
        return None
    candidates = named_defect_hz(defect_hz)
    distance, name, hz = min(((abs(math.log(observed_hz / hz)), name, hz) for name, hz in candidates.items()),
                             default=(math.inf, "", 0.0))
    if (distance > tolerance or _a_whole_factor_from(observed_hz, [shaft_hz, *candidates.values()], max_factor, tolerance)
            or _supply_multiple(observed_hz) is not None):  # the supply's series explains it as well
        return None
    return name, hz


def named_defect_hz(defect_hz: Mapping[str, float]) -> dict[str, float]:
    """``defect_hz``'s finite, positive defect frequencies by their names in messages (BPFI, BPFO, BSF, FTF), and a
    ball defect's comb at 2 x BSF (its spall strikes both races per spin)."""
    named = {name.upper(): float(hz) for name, hz in defect_hz.items()
             if name != "shaft" and is_finite_number(hz) and hz > 0}
    if "BSF" in named:
        named["2 x BSF"] = 2 * named["BSF"]
    return named


def _whole_factors(max_factor: int) -> np.ndarray:
    """n and 1 / n for n = 2 .. ``max_factor``: where a rate off by a whole factor moves a line."""
    factors = np.arange(2, max_factor + 1, dtype=float)
    return np.concatenate([factors, 1 / factors])


def _a_whole_factor_from(hz: float, lines_hz, max_factor: int, tolerance: float) -> bool:
    """Whether ``hz`` lies within ``tolerance`` (relative) of n or 1 / n times one of ``lines_hz``, n = 2 ..
    ``max_factor``: where a rate off by that whole factor puts those lines."""
    scaled = np.outer(lines_hz, _whole_factors(max_factor))
    return bool(np.min(np.abs(np.log(hz / scaled))) <= tolerance)


def _defect_series_at_its_frequency(signal, fs, shaft_hz: float, defect_hz: Mapping[str, float], prominence: float,
                                    max_fraction: int = _MAX_FRACTION, window: float = _WINDOW,
                                    max_speed_factor: int = _MAX_FRACTION) -> str | None:
    """The first defect frequency f whose envelope lines stand at f and 2 f (``prominence``), at none of
    f / k, k = 2 .. ``max_fraction``, and with no comb below them (:func:`_comb_below`, m up to
    ``max_speed_factor``: lines of a speed that many times lower than declared); frequencies within two search
    windows of a shaft harmonic's fraction m / k (k up to ``max_fraction``) are not witnesses, since under a wrong
    rate the shaft's lines land there (the SKF 6203's ball spin frequency is 1.994 x shaft), nor those on the
    supply or twice it, where the supply's lines beat. None if no frequency qualifies."""
    lines = {name: float(hz) for name, hz in defect_hz.items()
             if name != "shaft" and hz and 2.2 * hz < fs / 2 and _apart_from_shaft(float(hz), shaft_hz, max_fraction, window)
             and _supply_multiple(float(hz)) is None}  # the supply's lines beat at their spacing in the envelope
    if not lines:
        return None
    frequencies = np.array(list(lines.values()))
    ratio, resolution = _envelope_prominence(signal, fs, 2.2 * frequencies.max())
    at_f = _comb_prominence(ratio, resolution, frequencies, window)
    at_fractions = np.max([_peak(ratio, resolution, frequencies / k, window) for k in range(2, max_fraction + 1)], axis=0)
    standing = [name for name, a, b in zip(lines, at_f, at_fractions) if a >= prominence and b < prominence
                and _comb_below(ratio, resolution, lines[name], shaft_hz, defect_hz, max_speed_factor, prominence) is None]
    return standing[0] if standing else None


def _defect_comb_elsewhere(check: ShaftLineCheck, signal: np.ndarray, defect_hz: Mapping[str, float],
                           ratio: np.ndarray, resolution: float, prominence: float, search_factor: float,
                           window: float, tolerance: float, confirmed: Callable[[float], bool]) -> ShaftLineCheck:
    """An ``ambiguous`` check (no series settled the rate), and an envelope holding a defect's comb at ``s`` times
    its frequency: under a rate off by ``declared / true = s`` every line stands ``s`` times its place. Where the
    shaft's line stands ``s`` times its place too, and not at its place (``ratio``, ``resolution``: the record's
    prominence spectrum; under a rate too low by a whole factor its harmonic may), and the record checked at the
    rate they imply is ``confirmed`` there (``consistent``: its own shaft line or defect lines, this comb among
    them, hold there), the two agree and contradict the rate (``witness`` ``comb``). Otherwise a comb standing
    where it belongs (within ``tolerance``: a speed given a little off) leaves the check as it is, and a comb
    standing only elsewhere leaves it ``ambiguous``, naming the rate it implies. A contradiction made by a series
    is left to stand with the rate it implies: a healthy record's dense shaft lines can put a comb anywhere."""
    combs, belongs = _defect_combs(signal, check.fs_hz, check.expected_hz, defect_hz, prominence, search_factor,
                                   window, tolerance)
    contradiction = _comb_contradiction(check, signal, defect_hz, ratio, resolution, prominence, search_factor, window,
                                        tolerance, confirmed, combs)
    if contradiction is not None:
        return contradiction
    if belongs or not combs:
        return check
    name, scale = combs[0]
    return dataclasses.replace(check, reason=f"{check.reason}; {_comb_words(defect_hz, name, scale)}, and no defect's "
                                             f"comb stands where it belongs: fs may be {check.fs_hz / scale:.0f} Hz"
                                             f"{_shaft_comb_words(scale * named_defect_hz(defect_hz)[name], check)}")


def _shaft_comb_words(comb_hz: float, check: ShaftLineCheck) -> str:
    """Where a comb at ``comb_hz`` stands within :data:`~bearingtwin.signal.speed.SPEED_OFF` of a shaft order (1x to
    3x; ``check``'s expected shaft line), that it may be the shaft's own modulation of the envelope (an inner race's,
    an unbalance's) at a speed that far from the one stated ("" elsewhere): beside it 1 % from a shaft order, the
    comb is read as the shaft's, and a speed a little further off (a nameplate's, a drifting one) moves it out."""
    order = round(comb_hz / check.expected_hz)
    off = comb_hz / (order * check.expected_hz) - 1 if 1 <= order <= 3 else math.inf
    if not abs(off) <= SPEED_OFF[1]:
        return ""
    return f", or it is the shaft's {order}x modulation at a speed {100 * off:+.1f} % from the one stated"


def _comb_words(defect_hz: Mapping[str, float], name: str, scale: float) -> str:
    return (f"the envelope's {name} comb stands at {scale:.3g} times its frequency "
            f"({scale * named_defect_hz(defect_hz)[name]:.1f} Hz, its second harmonic too)")


def _comb_contradiction(check: ShaftLineCheck, signal: np.ndarray, defect_hz: Mapping[str, float], ratio: np.ndarray,
                        resolution: float, prominence: float, search_factor: float, window: float, tolerance: float,
                        confirmed: Callable[[float], bool], combs: list[tuple[str, float]] | None = None,
                        ) -> ShaftLineCheck | None:
    """``check`` contradicted at the rate a defect's comb standing at ``s`` times its frequency implies, where the
    shaft's line stands ``s`` times its place too and not at its place, and the record is ``confirmed`` at that rate
    (:func:`_defect_comb_elsewhere`); None where no comb does. ``check`` may be ``consistent`` by a defect witness
    alone (:func:`_second_look`): a comb read at the declared rate as one defect's may be another's under another
    rate (the SKF 6205's BPFI is 1.51 times its BPFO, so an inner race's comb declared at 2/3 of its rate stands at
    BPFO's place), and the shaft's line, standing where that other rate puts it, tells the two apart."""
    if combs is None:
        combs, _ = _defect_combs(signal, check.fs_hz, check.expected_hz, defect_hz, prominence, search_factor, window,
                                 tolerance)

    def line(hz: float) -> bool:
        return float(_peak(ratio, resolution, np.array([hz]), window)[0]) >= prominence

    at_its_place = line(check.expected_hz)
    for name, scale in combs:  # two combs may read the same lines (BPFO x 1.25, 2 x BSF x 0.94): the shaft decides
        # Under a rate too low by a whole factor k the shaft's k-th harmonic stands at its place.
        whole = any(abs(math.log(scale * k)) <= tolerance for k in range(2, _MAX_FRACTION + 1))
        shaft_hz = scale * check.expected_hz
        if ((whole or not at_its_place) and _supply_multiple(shaft_hz) is None and line(shaft_hz)
                and confirmed(check.fs_hz / scale)):
            return dataclasses.replace(
                check, implied_fs_hz=check.fs_hz / scale, verdict="contradicted", witness="comb",
                reason=f"{check.reason}; {'yet' if '; but ' in check.reason else 'but'} "
                       f"{_comb_words(defect_hz, name, scale)}, and a line stands at "
                       f"{shaft_hz:.2f} Hz, as many times the shaft's place: both fall where they belong at a rate of "
                       f"{check.fs_hz / scale:.0f} Hz")
    return None


_COMB_NAMES = ("BPFI", "BPFO", "2 x BSF")
"""The combs sought where a wrong rate would put them: a race's, and a ball's, whose spall strikes both races per
spin (its comb stands at twice BSF, so BSF itself, at half of it, would read as a rate off by two)."""


def _defect_combs(signal: np.ndarray, fs: float, shaft_hz: float, defect_hz: Mapping[str, float], prominence: float,
                  search_factor: float, window: float, tolerance: float) -> tuple[list[tuple[str, float]], bool]:
    """The defect combs (a line and its second harmonic in the envelope, each ``prominence`` over the floor)
    standing at ``s`` times their frequency, ``s`` within ``search_factor`` either way: (name, s), the most
    prominent first, every scale where one stands out; and whether a comb stands at its own frequency (within
    ``tolerance``) and at no whole fraction of it (1/2 .. 1/4: its lines there would then be that lower comb's
    harmonics, under a rate too low by that factor). Not counted elsewhere: a comb's own harmonics (``s`` near a
    whole number), and lines that the declared rate explains otherwise: within two search windows of a whole
    shaft order (``shaft_hz``: the shaft's modulation) or of the supply or twice it (a motor's pull)."""
    combs = {name: hz for name, hz in named_defect_hz(defect_hz).items() if name in _COMB_NAMES}
    if not combs:
        return [], False
    top = min(2.2 * max(combs.values()) * search_factor, 0.45 * fs)
    ratio, resolution = _envelope_prominence(signal, fs, top)
    scales = np.geomspace(1 / search_factor, search_factor, int(math.ceil(2 * math.log(search_factor) / window)) + 1)

    def near(scale: np.ndarray, factor: float) -> np.ndarray:
        return np.abs(np.log(scale * factor)) <= tolerance

    def explained(hz: np.ndarray) -> np.ndarray:
        orders = hz / shaft_hz
        on_shaft = np.abs(np.log(orders / np.maximum(np.round(orders), 1.0))) <= 2 * window
        return on_shaft | np.array([_supply_multiple(float(f)) is not None for f in hz])

    found, belongs = [], False
    for name, hz in combs.items():
        scored = scales[2.2 * scales * hz < top]
        score = _comb_prominence(ratio, resolution, scored * hz, window)
        standing = score >= prominence
        fractions = np.any([near(scored, k) for k in range(2, _MAX_FRACTION + 1)], axis=0)
        harmonics = np.any([near(scored, 1 / k) for k in range(2, int(math.ceil(search_factor)) + 1)], axis=0)
        belongs |= bool(np.any(standing & near(scored, 1.0)) and not np.any(standing & fractions))
        elsewhere = np.where(standing & ~near(scored, 1.0) & ~harmonics & ~explained(scored * hz), score, 0.0)
        peaks, _ = scipy.signal.find_peaks(np.concatenate([[0.0], elsewhere, [0.0]]))  # each comb once, at its best scale
        found += [(float(elsewhere[peak - 1]), name, float(scored[peak - 1])) for peak in peaks]
    return [(name, scale) for _, name, scale in sorted(found, reverse=True)], belongs


def _comb_prominence(ratio: np.ndarray, resolution: float, frequencies_hz: np.ndarray, window: float) -> np.ndarray:
    """How far a comb at each of ``frequencies_hz`` stands out of an envelope's prominence spectrum (``ratio``,
    ``resolution``): the lesser of its line's and its second harmonic's prominence."""
    return np.minimum(_peak(ratio, resolution, frequencies_hz, window), _peak(ratio, resolution, 2 * frequencies_hz, window))


def _apart_from_shaft(hz: float, shaft_hz: float, max_fraction: int, window: float) -> bool:
    """Whether ``hz`` lies more than two search windows from every shaft harmonic's fraction m / k
    (k up to ``max_fraction``), where the shaft's own lines stand, under the right rate or a wrong one."""
    top = max(12, int(hz / shaft_hz) + 2)  # every shaft order up to past ``hz``
    fractions = np.array([m / k for k in range(1, max_fraction + 1) for m in range(1, top * k)])
    return bool(np.min(np.abs(hz / shaft_hz - fractions) / (hz / shaft_hz)) > 2 * window)


def _on_half_orders(lines_hz: np.ndarray, shaft_hz: float, resolution: float) -> bool:
    """Whether every line of ``lines_hz`` lies within reach of a half order of the shaft: a loose machine's comb (its
    rattle's half orders fill its envelope too), which on a record of a few seconds also stands under a defect line's
    fraction whose lines fall a bin or two from it (the SKF 6205's BPFO / 7 is 0.512 x shaft), and says nothing of the
    speed. Within reach: a search window (at least a bin of ``resolution`` Hz) and a line's main lobe (two bins under
    the Hann window) apart."""
    half_order_hz = shaft_hz / 2
    nearest_hz = np.round(lines_hz / half_order_hz) * half_order_hz
    # At most a quarter of the half orders' spacing: where the bins are coarser, no comb tells itself from them.
    reach_hz = np.minimum(np.maximum(_WINDOW * lines_hz, resolution) + 2 * resolution, half_order_hz / 4)
    return bool(np.all(np.abs(lines_hz - nearest_hz) <= reach_hz))


def _envelope_prominence(signal: np.ndarray, fs: float, top_hz: float) -> tuple[np.ndarray, float]:
    from bearingtwin.signal.envelope import envelope

    return _prominence_spectrum(_once("envelope", np.asarray(signal, dtype=np.float64), envelope), fs, top_hz,
                                background_hz=5.0)


def _defect_witness(signal, fs, shaft_hz: float, defect_hz: Mapping[str, float], k: int, scale: float,
                    rate_if_shaft: float, prominence: float, max_fraction: int) -> tuple[str, float | None, str]:
    """Envelope lines of the defect frequencies at f (right rate) against f x ``scale`` (about 1 / k: where a
    rate too low by that factor, ``rate_if_shaft``, puts them); a frequency with f or f / k on a shaft harmonic
    is no witness, since the shaft's line stands there whatever the rate (the SKF 6203's BSF is 1.994 x shaft,
    its half 0.997 x).

    A line at f also stands where a speed m times lower than the declared one (a rate m times too low, m = 2 ..
    ``max_fraction``) puts the defect's m-th harmonic: a speed typed with a digit too many puts every defect
    frequency on a harmonic of its true one. Such a line witnesses nothing where the comb below it stands
    (:func:`_comb_below`), and that comb standing higher than f contradicts the rate, whatever the in-between shaft
    lines suggested for k."""
    lines = {name: float(hz) for name, hz in defect_hz.items() if name != "shaft" and hz and hz * 1.1 < fs / 2
             and _apart_from_shaft(float(hz), shaft_hz, 1, _WINDOW) and _apart_from_shaft(float(hz) * scale, shaft_hz, 1, _WINDOW)}
    if not lines:
        return "ambiguous", None, "no defect frequency away from the shaft's lines below the Nyquist frequency to decide"
    frequencies = np.array(list(lines.values()))
    ratio, resolution = _envelope_prominence(signal, fs, min(3.3 * frequencies.max(), fs / 2))
    at_f = _peak(ratio, resolution, frequencies, _WINDOW)
    at_fraction = _peak(ratio, resolution, frequencies * scale, _WINDOW)
    # A witness for the rate stands with its second and third harmonics where they are below the Nyquist frequency:
    # a line at f, or two at f and 2f, may be any of a fault's many envelope lines (an outer race's BPFO harmonics,
    # an inner race's BPFI harmonics and their shaft sidebands).
    with_second = np.where(2.2 * frequencies < fs / 2, _comb_prominence(ratio, resolution, frequencies, _WINDOW), at_f)
    with_third = np.minimum(with_second, _peak(ratio, resolution, 3 * frequencies, _WINDOW))
    as_witness = np.where(3.3 * frequencies < fs / 2, with_third, with_second)
    below = {name: _comb_below(ratio, resolution, hz, shaft_hz, defect_hz, max_fraction, prominence)
             for name, hz in lines.items()}
    wrong = [name for name, a, b in zip(lines, at_f, at_fraction) if b >= prominence and b > a]
    right = [name for name, a, b in zip(lines, as_witness, at_fraction) if a >= prominence and b < prominence
             and not below[name]]
    if wrong and not right:
        fraction = f"1/{k}" if math.isclose(scale * k, 1.0, rel_tol=_WINDOW) else f"{scale:.3g} times"
        return "contradicted", rate_if_shaft, (f", and the envelope line of {wrong[0]} stands at {fraction} its "
                                               f"frequency: it falls where it belongs at a rate of {rate_if_shaft:.0f} Hz")
    harmonic = [(name, *below[name]) for name in lines if below[name]]
    if harmonic and not right:
        name, m, _ = max(harmonic, key=lambda item: item[2])
        if m == k and math.isclose(scale * k, 1.0, rel_tol=_WINDOW):  # the shaft's in-between lines say the same
            return "contradicted", fs * m, (f", and the envelope lines of {name} stand at multiples of 1/{m} its "
                                            f"frequency: they fall where they belong at a rate of {fs * m:.0f} Hz, or a "
                                            f"speed of {60 * shaft_hz / m:.0f} rpm")
        # Under a speed M times too high the combs at M's divisors stand too, and a dense envelope may lend a comb
        # more: without the shaft's agreement the factor is not named.
        return "contradicted", None, (f", and the envelope lines of {name} stand at a whole fraction of its frequency, "
                                      "as the harmonics of a line a speed a whole factor lower puts there")
    if right and not wrong:
        return "consistent", fs, f", but the envelope line of {right[0]} stands at its frequency: real subharmonics"
    return "ambiguous", None, "the defect lines do not decide"


def _comb_below(ratio: np.ndarray, resolution: float, hz: float, shaft_hz: float, defect_hz: Mapping[str, float],
                max_fraction: int, prominence: float) -> tuple[int, float] | None:
    """``(m, prominence)`` of the comb below a line at ``hz`` that makes it the m-th harmonic of a line at ``hz`` / m
    (a speed m times lower than the one ``hz`` was computed at), for the largest m (2 .. ``max_fraction``) whose
    comb stands (its median ``prominence``; under a speed M times too high the combs at M's divisors stand too);
    None where none does. A comb is its first three lines j x ``hz`` / m with j no multiple of m (a multiple
    would be ``hz``'s own harmonics); one whose lines all lie on the shaft's half orders (:func:`_on_half_orders`),
    whose fundamental lies on a shaft harmonic, within two windows of
    another defect frequency (the outer race's BPFO is Z x FTF: a cage line is no speed m times lower) or below
    three bins of the spectrum (the envelope's slope towards 0 Hz) is passed over."""
    others = [float(value) for value in defect_hz.values() if value and not math.isclose(float(value), hz)]
    for m in range(max_fraction, 1, -1):
        fundamental = hz / m
        if fundamental < 3 * resolution or not _apart_from_shaft(fundamental, shaft_hz, 1, _WINDOW) or any(
                abs(fundamental / other - 1.0) <= 2 * _WINDOW for other in others):
            continue
        multiples = [j for j in range(1, 2 * m) if j % m][:3]
        if _on_half_orders(fundamental * np.array(multiples), shaft_hz, resolution):
            continue
        score = float(np.median(_peak(ratio, resolution, fundamental * np.array(multiples), _WINDOW)))
        if score >= prominence:
            return m, score
    return None


@shared_transforms()  # every speed tried reads the same channels' spectra and envelopes
def speeds_a_whole_factor_off(signal, fs: float, rpm: float, defect_hz: Mapping[str, float] | None = None,
                              channels: Mapping[str, np.ndarray] | None = None, max_factor: int = 10,
                              higher: bool = False) -> list[int]:
    """Every m (2 .. ``max_factor``) at which the record (every channel a witness) is ``consistent`` with a speed of
    ``rpm`` / m at ``fs`` (``higher``: ``rpm`` * m, and only where the shaft series stands at its place), those whose
    shaft series stands at its place first, then the least. A speed given a whole factor too high (twice the speed, a
    digit too many) puts every line the record holds on a harmonic of the lines expected, which a check at the given
    speed may leave unexplained. Under a speed M times too high the speeds M / m times too high may be confirmed too
    (their lines are the true ones' harmonics), so more than one m may be named. A speed a whole factor too low (half
    the speed) is the other way round: the record's shaft series stands at a multiple of its place, and the cage's or a
    defect's lines, read at their harmonics, may still witness it. Empty where none is confirmed (or the record is too
    short to check one). ``defect_hz``: the bearing's defect frequencies at ``rpm``, which scale with the speed."""
    consistent = []
    witnesses = rate_witnesses(signal, channels)  # the same channels for every speed tried
    for m in range(2, max_factor + 1):
        factor = m if higher else 1 / m
        scaled = {name: hz * factor for name, hz in defect_hz.items()} if defect_hz else None
        try:
            checks = check_channels(witnesses, fs, rpm * factor, defect_hz=scaled)
        except BearingTwinError:  # too short a record to place a shaft line this low: nor any lower one
            break
        check = checks[decisive_channel(checks)]
        if higher and check.matches and supply_comb(check.observed_hz):  # a 4-pole motor's 100 Hz comb, not its shaft
            continue
        if check.verdict == "consistent" and (check.matches or not higher):
            consistent.append((not check.matches, m))
    return [m for _, m in sorted(consistent)]


def speeds_lines_alone_hide(check: ShaftLineCheck, signal, defect_hz: Mapping[str, float] | None = None,
                            channels: Mapping[str, np.ndarray] | None = None) -> list[int]:
    """Where ``check`` took its speed from the cage's or a defect's lines alone (:func:`_by_a_defect_alone`), the m
    (2 .. 4) under whose ``rpm * m`` the shaft series stands at its place (:func:`speeds_a_whole_factor_off`): a speed
    typed a whole factor too low, its lines read at their harmonics. Empty otherwise."""
    if not _by_a_defect_alone(check):
        return []
    return speeds_a_whole_factor_off(signal, check.fs_hz, check.rpm, defect_hz, channels, max_factor=4, higher=True)


def series_elsewhere_words(check: ShaftLineCheck, multiples: Sequence[int], compared: str = "higher") -> str:
    """What ``check`` read at the speed given, then the speeds ``multiples`` times it where the shaft series and the
    lines stand, each "(m times ``compared``)": the reason of a speed :func:`speeds_lines_alone_hide` finds a whole
    factor too low."""
    speeds = "; ".join(f"{check.rpm * m:g} rpm ({m} times {compared})" for m in multiples)
    return (f"{check.reason.split('; but ')[0]}; the shaft series and the record's lines stand where they belong at "
            f"{speeds}")


def series_stands_at(signal, fs: float, rpm: float, defect_hz: Mapping[str, float] | None = None,
                     channels: Mapping[str, np.ndarray] | None = None) -> bool:
    """Whether the shaft series stands where it belongs at ``fs`` in a channel of the file (``channels`` witnesses,
    :func:`check_channels`); a record too short to tell at that rate (fewer seconds at a higher rate) does not."""
    try:
        checks = check_channels(rate_witnesses(signal, channels), fs, rpm, defect_hz=defect_hz)
    except BearingTwinError:
        return False
    return any(check.matches for check in checks.values())


def rate_against_name_error(source: str, against_name: str, named_hz: float, fs: float) -> BearingTwinError:
    """The refusal of a rate given against the one the file's name gives (``against_name``, the data layer's
    ``named_rate_note``), where the shaft line contradicts the rate given and stands where it belongs at the name's:
    two witnesses against one typed number."""
    return BearingTwinError(f"{source}: {against_name}, and the shaft line stands where it belongs at {named_hz:g} Hz, "
                            f"not at {fs:g} Hz: give this file no rate (its name's is read)")


def _three_digits(value: float) -> str:
    """``value`` to three significant digits, written out (1799.4 -> 1800, 8005 -> 8000): an implied rate or speed
    is as fine as the spectrum's resolution, about 0.5 %."""
    return f"{float(f'{value:.3g}'):g}"


def describe_mismatch(check: ShaftLineCheck) -> str:
    """One sentence on why a declared rate was rejected (or could not be confirmed)."""
    return (f"fs = {check.fs_hz:g} Hz {'contradicts' if check.verdict == 'contradicted' else 'is not confirmed by'} "
            f"the shaft speed: at {check.rpm:g} rpm the shaft line belongs at {check.expected_hz:.2f} Hz, but {check.reason}")


@shared_transforms()  # the check and the lower speeds a contradiction tries read the same channels
def require_plausible_rate(signal, fs: float, rpm: float, source: str, fs_key: str,
                           defect_hz: Mapping[str, float] | None = None, refuse: bool = True,
                           channels: Mapping[str, np.ndarray] | None = None,
                           check_key: str | None = None, rpm_key: str | None = None,
                           rate_from_file: bool = False, against_name: str | None = None,
                           named_hz: float | None = None) -> ShaftLineCheck | None:
    """The check as a command applies it: a contradicted rate raises naming ``source`` and the
    setting to correct (``fs_key``, and ``rpm_key`` where the speed was given, not read from the file: a
    speed off by a whole factor contradicts a rate as a rate off by it does); an ambiguous one is logged; a record too short to check is
    logged as unchecked (None). ``refuse=False`` only logs a contradiction: for a rate the file
    itself records (a header, a time column), which a record without a visible shaft line (a
    simulation, a machine without unbalance) cannot contradict. ``rate_from_file``: the file records the rate, and
    a setting typed the speed (``rpm_key``): a contradiction is refused all the same where the record is consistent
    with a speed a whole factor below it (:func:`speeds_a_whole_factor_off`), naming ``rpm_key`` alone (other
    contradictions of such a pair stay logged: a noise-free or short record's lines contradict a true pair too; and a
    machine's half orders can make a record consistent with half its speed: on CWRU's records cut to 5 s, one of 13
    at its true speed). A speed a setting gave that the cage's or a defect's lines witness where the shaft's series does
    not stand, while the series stands at its place under a speed a whole factor higher, is refused naming ``rpm_key``
    (half the speed typed: the defect lines, read at their second harmonics, witness it). ``against_name``: the note
    that the rate given differs from ``named_hz``, the one the file's name gives (``named_rate_note``): refused where the
    shaft line contradicts the rate given and stands at its place at the name's. ``channels``: the file's channels
    of ``signal``'s length, each a witness of the one rate (:func:`check_channels`). ``check_key``: the
    setting that turns the check off, named in the refusal."""
    import logging

    log = logging.getLogger(__name__)
    try:
        checks = check_channels(rate_witnesses(signal, channels), fs, rpm, defect_hz=defect_hz)
        check = checks[decisive_channel(checks)]
    except BearingTwinError as error:
        log.warning("%s: sampling rate not checked: %s", source, error)
        return None
    if against_name and check.verdict == "contradicted" and series_stands_at(signal, named_hz, rpm, defect_hz, channels):
        raise rate_against_name_error(source, against_name, named_hz, fs)
    higher = speeds_lines_alone_hide(check, signal, defect_hz, channels) if rpm_key else []
    if higher:
        off = f", or {check_key}=false if {rpm:g} rpm is true" if check_key else ""
        raise BearingTwinError(f"{source}: {rpm_key}={rpm:g} puts the shaft line at {check.expected_hz:.2f} Hz, but "
                               f"{series_elsewhere_words(check, higher)}: give the true speed with {rpm_key}=<rev/min>{off}")
    # Where a setting gave the speed, the speeds a whole factor lower the record is consistent with are named.
    lower = (speeds_a_whole_factor_off(signal, fs, rpm, defect_hz, channels)
             if rpm_key and check.verdict == "contradicted" and (refuse or rate_from_file) else [])
    speeds = "; ".join(f"{rpm / m:g} rpm ({m} times lower)" for m in lower)
    if check.verdict == "contradicted" and (refuse or lower):
        truth = f"both {fs:g} Hz and {rpm:g} rpm are true" if rpm_key else f"{fs:g} Hz is the true one"
        off = f", or {check_key}=false if {truth}" if check_key else ""
        if lower and rate_from_file:
            raise BearingTwinError(f"{source}: {describe_mismatch(check)}; the record's lines stand where they belong at "
                                   f"{speeds}, and the file records its rate: give the true speed with "
                                   f"{rpm_key}=<rev/min>{off}")
        if rpm_key and check.implied_fs_hz and (check.witness == "comb" or check.implied_confirmed) and not lower:
            # Both typed, and the rate the lines imply confirmed there (a defect's comb and the shaft's line agree on
            # it, or another channel does): no line tells a speed off from a rate off, so both readings come first, in
            # the settings' words, and the evidence after them. A rate implied by the nearest series alone is no
            # reading to lead with (CWRU 130 typed at 1500 rpm: its nearest series implies 721 rpm).
            factor = fs / check.implied_fs_hz
            raise BearingTwinError(
                f"{source}: {fs_key}={fs:g} and {rpm_key}={rpm:g} do not fit the record: its lines stand where about "
                f"{_three_digits(rpm * factor)} rpm puts them at {fs:g} Hz ({factor:.2g} times the speed given), or about "
                f"{_three_digits(check.implied_fs_hz)} Hz at {rpm:g} rpm; give the true speed with {rpm_key}=<rev/min> or "
                f"the true rate with {fs_key}=<Hz>{off} ({describe_mismatch(check)})")
        at_speeds = f": its lines stand where they belong at {speeds}" if lower else ""
        speed = f" (or the true speed with {rpm_key}=<rev/min>{at_speeds})" if rpm_key else ""
        raise BearingTwinError(f"{source}: {describe_mismatch(check)}; give the true rate with {fs_key}=<Hz>{speed}{off}")
    if check.verdict == "contradicted":
        log.warning("%s: %s (the rate the file records is kept)", source, describe_mismatch(check))
    if check.verdict == "ambiguous":
        # Where a setting gave the speed, the rate the in-between lines imply is as well a speed that many times lower.
        speed_doubt = (f"; or, at {fs:g} Hz, a speed of {rpm * fs / check.fraction_rate_hz:.0f} rpm ({rpm_key})"
                       if rpm_key and check.fraction_rate_hz and check.fraction_rate_hz > fs else "")
        log.warning("%s: %s%s", source, describe_mismatch(check), speed_doubt)
    return check
