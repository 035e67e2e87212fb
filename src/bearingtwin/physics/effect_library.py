"""The effects a measured bearing shows and the bare twin does not.

Each effect is a small class with one or two physically meaningful parameters and
acts at the stage of the twin where the physics happens (see
:mod:`bearingtwin.physics.effects`): the sensor path (``resonance``,
``second_resonance``, ``structural_mode``, ``noise``, ``clipping`` and the line effects ``tones``,
``unbalance``, ``misalignment``, ``looseness``, ``line_frequency``), the kinematics the
solver reads (``slip``, ``spin_slip``, ``speed_fluctuation``, ``roughness``) or the dynamic parameters
(``lubrication``, ``load_zone``, ``preload``). The sensor-path physics is also exposed as
plain signal functions (arrays in, arrays out, batched along the leading axis) so it can
be used and tested without a simulator. Sensor-path effects cost the twin a filter, not
a simulation, so whatever physics allows is modelled there.

The line effects are the machine's usual suspects, each a set of narrow lines at
frequencies it knows from the shaft rate or the supply, rendered by one function
(:func:`add_lines`); each reads its starting parameters off the measured spectrum
(``initial_guess``), because a narrow line is found by looking, not by a short search.

Adding an effect is one class decorated with ``@register_effect`` and one
``conf/effects/<name>.yaml``; comparison, calibration and ranking pick it up by name.
Every class documents the signature it leaves in a measurement, which is what
:mod:`bearingtwin.twin.rank` reports as evidence.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.stats
from scipy import signal as sps
from scipy.ndimage import median_filter

from bearingtwin.checks import finite_number, is_finite_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.dynamics import DynamicParameters
from bearingtwin.physics.effects import Effect, register_effect
from bearingtwin.physics.kinematics import Kinematics
from bearingtwin.signal.envelope import peak_near
from bearingtwin.signal.sampling_rate import MAINS_HZ


MODE_REACH_OF_FS = 0.45
"""The highest natural frequency a mode effect is searched at, as a fraction of the sampling rate: 90 % of
Nyquist, where a recorder's anti-alias filter starts to roll its spectrum off, and as far as a mode's first guess
reads it. A stud-mounted accelerometer's own resonance and many housing modes lie far above a few kHz, and a
record sampled fast enough shows them."""

MAX_LEVEL_DB = 300.0
"""The largest level or ratio in dB an effect takes (10^15 in amplitude): far beyond any sensor's range, and well
inside what a float holds once raised to a power (1e6 dB overflowed, after the whole simulation)."""


def _decibels(field: str, value) -> float:
    """A level or ratio in dB: a finite number within +- :data:`MAX_LEVEL_DB`."""
    level = finite_number(field, value)
    if abs(level) > MAX_LEVEL_DB:
        raise BearingTwinError(f"{field} must lie within +-{MAX_LEVEL_DB:g} dB, got {value!r}")
    return level


def _positive(field: str, value: float) -> float:
    if not (is_finite_number(value) and value > 0):  # not a bool, a list or text: a number
        raise BearingTwinError(f"{field} must be a positive number, got {value}")
    return float(value)


def base_excitation_filter(x: np.ndarray, fs: float, natural_frequency_hz: float, damping_ratio: float,
                           effect: str = "resonance") -> np.ndarray:
    """Absolute acceleration of a sensor mount driven by the bearing housing's acceleration.

    The mount is a single-degree-of-freedom oscillator excited at its base, so its
    transmissibility is (2 zeta wn s + wn^2) / (s^2 + 2 zeta wn s + wn^2): unity far below
    ``natural_frequency_hz``, a peak of about 1 / (2 zeta) at it, -20 dB/decade above.
    Filters along the last axis; errors name the parameters as those of ``effect``.
    """
    return _second_order_filter(x, fs, natural_frequency_hz, damping_ratio, effect, base_excitation=True)


def mode_band_pass(x: np.ndarray, fs: float, natural_frequency_hz: float, damping_ratio: float,
                   effect: str = "structural_mode") -> np.ndarray:
    """The response of one structural mode to ``x``, normalised to unit gain at its natural frequency.

    The band-pass 2 zeta wn s / (s^2 + 2 zeta wn s + wn^2): unity at ``natural_frequency_hz``,
    half-power width 2 zeta f_n, falling at 20 dB/decade on both sides. Along the last axis.
    """
    return _second_order_filter(x, fs, natural_frequency_hz, damping_ratio, effect, base_excitation=False)


def _below_nyquist(natural_frequency_hz: float, fs: float, effect: str) -> None:
    """Refuse a mode at or above the Nyquist frequency of ``fs`` (Hz): no digital filter rings there."""
    if natural_frequency_hz >= fs / 2:
        raise BearingTwinError(
            f"{effect}.natural_frequency_hz={natural_frequency_hz} must lie below the Nyquist frequency {fs / 2} Hz"
        )


def _second_order_filter(x: np.ndarray, fs: float, natural_frequency_hz: float, damping_ratio: float, effect: str,
                         base_excitation: bool) -> np.ndarray:
    """(2 zeta wn s + [wn^2 if base_excitation]) / (s^2 + 2 zeta wn s + wn^2), digitised by the bilinear
    transform prewarped at the natural frequency, so the peak stays at the right place for any
    sampling rate ``fs`` (Hz)."""
    fs = _positive("fs", fs)
    natural_frequency_hz = _positive(f"{effect}.natural_frequency_hz", natural_frequency_hz)
    damping_ratio = _positive(f"{effect}.damping_ratio", damping_ratio)
    _below_nyquist(natural_frequency_hz, fs, effect)
    wn = 2 * math.pi * natural_frequency_hz
    k = wn / math.tan(wn / (2 * fs))
    b1, b0 = 2 * damping_ratio * wn, (wn**2 if base_excitation else 0.0)
    a1, a0 = 2 * damping_ratio * wn, wn**2
    num = np.array([b1 * k + b0, 2 * b0, b0 - b1 * k])
    den = np.array([k**2 + a1 * k + a0, 2 * a0 - 2 * k**2, k**2 - a1 * k + a0])
    return sps.lfilter(num / den[0], den / den[0], np.asarray(x, dtype=np.float64), axis=-1)


def coloured_noise(shape: tuple[int, ...], fs: float, spectral_slope: float, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean Gaussian noise of unit variance whose power density falls as f^-spectral_slope.

    ``spectral_slope`` 0 is white (electronic sensor noise), 1 is pink (background
    machinery, flow); the last axis is time sampled at ``fs`` Hz. The lowest bin takes the
    level of the first non-zero frequency so a steep slope cannot blow up at DC.
    """
    n = shape[-1]
    spectrum = np.fft.rfft(rng.standard_normal(shape), axis=-1)
    freqs_hz = np.fft.rfftfreq(n, d=1.0 / fs)
    freqs_hz[0] = freqs_hz[1] if n > 1 else 1.0
    noise = np.fft.irfft(spectrum * freqs_hz ** (-spectral_slope / 2.0), n=n, axis=-1)
    noise -= noise.mean(axis=-1, keepdims=True)
    return noise / np.maximum(noise.std(axis=-1, keepdims=True), np.finfo(float).tiny)


def add_noise(x: np.ndarray, fs: float, snr_db: float, spectral_slope: float, rng: np.random.Generator,
              reference_rms: float | None = None) -> np.ndarray:
    """``x`` plus coloured noise at a signal-to-noise power ratio of ``snr_db`` (per signal, last axis).

    The signal power the ratio refers to is each signal's own, or ``reference_rms`` squared
    when given (same units as ``x``): then every signal gets noise of the same absolute level,
    as a sensor's noise floor does whatever the bearing's state.
    """
    if not np.isfinite(snr_db):
        raise BearingTwinError(f"noise.snr_db must be finite, got {snr_db}")
    x = np.asarray(x, dtype=np.float64)
    if reference_rms is None:
        rms = np.sqrt(np.mean(x**2, axis=-1, keepdims=True))
    else:
        rms = _positive("noise.reference_rms", reference_rms)
    return x + rms * 10 ** (-snr_db / 20.0) * coloured_noise(x.shape, fs, spectral_slope, rng)


def add_lines(x: np.ndarray, fs: float, frequencies_hz, levels_db, rng: np.random.Generator) -> np.ndarray:
    """``x`` plus one sinusoid per frequency in ``frequencies_hz`` (Hz), at ``levels_db`` (dB).

    A line's level is its RMS relative to the RMS of ``x`` (a sinusoid of amplitude A has
    RMS A / sqrt(2)), per signal along the last axis, so the lines keep their share of
    whatever scale the bearing signal has. Phases are uniform random from ``rng``, one per
    signal and line, because a power spectrum does not observe them. Lines at or above the
    Nyquist frequency ``fs / 2`` are left out (their phases are still drawn, so the random
    stream does not depend on ``fs``).
    """
    frequencies_hz = np.atleast_1d(np.asarray(frequencies_hz, dtype=np.float64))
    levels_db = np.atleast_1d(np.asarray(levels_db, dtype=np.float64))
    if frequencies_hz.ndim != 1 or frequencies_hz.shape != levels_db.shape:
        raise BearingTwinError(f"frequencies_hz and levels_db must be two lists of one length, got "
                               f"{frequencies_hz.tolist()} and {levels_db.tolist()}")
    if not np.all(np.isfinite(frequencies_hz) & (frequencies_hz > 0)):
        raise BearingTwinError(f"frequencies_hz must be positive numbers, got {frequencies_hz.tolist()}")
    if not np.all(np.isfinite(levels_db)):
        raise BearingTwinError(f"levels_db must be finite, got {levels_db.tolist()}")
    fs = _positive("fs", fs)
    x = np.asarray(x, dtype=np.float64)
    t = np.arange(x.shape[-1]) / fs
    amplitudes = np.sqrt(np.mean(x**2, axis=-1, keepdims=True)) * math.sqrt(2.0) * 10 ** (levels_db / 20.0)
    phases = rng.uniform(0.0, 2 * math.pi, size=x.shape[:-1] + frequencies_hz.shape)
    out = x.copy()
    for k in np.flatnonzero(frequencies_hz < fs / 2):  # one line at a time: memory stays at one signal
        out += amplitudes[..., k, None] * np.cos(2 * math.pi * frequencies_hz[k] * t + phases[..., k, None])
    return out


def clip_at_rms(x: np.ndarray, clip_level: float) -> np.ndarray:
    """``x`` limited to +- ``clip_level`` times its RMS (per signal, last axis): a saturated sensor."""
    clip_level = _positive("clipping.clip_level", clip_level)
    x = np.asarray(x, dtype=np.float64)
    limit = clip_level * np.sqrt(np.mean(x**2, axis=-1, keepdims=True))
    return np.clip(x, -limit, limit)


LINE_RESOLUTION_HZ = 0.5
"""Finest frequency resolution (Hz) of the spectra the line effects read their guesses from:
lines 1 Hz apart stay apart, and a record longer than 2 s averages segments instead of
resolving speed wander into separate bins."""

LINE_PROMINENCE_DB = 13.0
"""A measured peak is a narrow line when it stands this far above the measurement's local
median. A bin of noise does so rarely (e^(-20 ln 2), about 1e-6, in a one-segment
periodogram, more with the median's own scatter): in 40 records of 2 s of white noise at
12 kHz, two false lines turned up, each 30 dB below the RMS."""

LINE_ABSENT_DB = 10.0
"""A measured line is one the twin lacks when it stands this far above the twin's PSD
within the line's tolerance (:func:`_tolerance_hz` with 1 %: a twin's defect lines may sit
that far from the measured ones and are still the twin's)."""

_LOBE_BINS = 2  # a Hann window's main lobe spans +-2 bins: a line's power lies within them, between bins or not
_BACKGROUND_HZ = 5.0  # half-width of the median that gives a spectrum's floor under a line


LOOSENESS_HARMONICS = 10
"""Default number of shaft harmonics of ``looseness`` (with as many half orders below them)."""

LOOSENESS_DECAY_DB_PER_ORDER = 1.0
"""Default fall of ``looseness``'s comb per shaft order, in dB."""

LOOSENESS_MAX_DECAY_DB_PER_ORDER = 10.0
"""Steepest fall of ``looseness``'s comb its initial guess reads off a measurement, in dB per order."""

LOOSENESS_READ_RANGE_DB = 30.0
"""``looseness``'s initial guess reads the comb's fall from the lines added within this many dB of the
strongest: further down, a line's level is the measurement's floor fluctuating against the twin's."""

LOOSENESS_SERIES_LINES = 2
"""A line at a shaft half order above 3x (or at 0.5x, 1.5x, 2.5x) is left to ``looseness`` only when at least
this many other such orders carry lines the twin lacks: a rattle raises a series, while a lone order is a
source of its own (a fan's blade pass, a pump's vane pass, a coupling's jaws) that ``tones`` may take."""

SUPPLY_HARMONICS = 3
"""Default number of lines of ``line_frequency`` at even multiples of the supply frequency."""

FUNDAMENTAL_FLOOR_DB = -40.0
"""Weakest f_s line ``line_frequency`` guesses, relative to its 2 f_s line, in dB."""


def _line_spectra(measured: np.ndarray, twin: np.ndarray, fs: float,
                  shaft_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies (Hz), Hann-windowed Welch PSDs (2, m) of measured and twin, and their floors (2, m).

    The floor is a running median, narrower than half the shaft rate so that a comb of
    half-order lines cannot lift it.
    """
    fs, shaft_hz = _positive("fs", fs), _positive("shaft_hz", shaft_hz)
    signals = [np.asarray(x, dtype=np.float64).ravel() for x in (measured, twin)]
    nperseg = int(min(signals[0].size, signals[1].size, round(fs / LINE_RESOLUTION_HZ)))
    if nperseg < 64:
        raise BearingTwinError(f"initial_guess: {nperseg} samples are too few to read lines from")
    (freqs_hz, measured_psd), (_, twin_psd) = (sps.welch(x, fs, window="hann", nperseg=nperseg) for x in signals)
    psd = np.stack([measured_psd, twin_psd])
    half_width = int(round(min(_BACKGROUND_HZ, shaft_hz / 4) / freqs_hz[1]))
    # At least 3 lobes wide, so a line's own lobe is less than half the median's window.
    return freqs_hz, psd, median_filter(psd, size=(1, 2 * max(half_width, 3 * _LOBE_BINS) + 1), mode="nearest")


def _tolerance_hz(centres_hz: np.ndarray, df: float, relative: float = 0.005) -> np.ndarray:
    """How far from a nominal line its peak may lie: a bin, plus 0.5 % for an inexact speed."""
    return df + relative * np.abs(centres_hz)


def _window_argmax(freqs_hz: np.ndarray, values: np.ndarray, centres_hz, half_widths_hz) -> np.ndarray:
    """Per centre, the bin of the largest of ``values`` within ``half_widths_hz`` (at least the nearest bin)."""
    centres_hz = np.clip(np.atleast_1d(np.asarray(centres_hz, dtype=np.float64)), 0.0, freqs_hz[-1])
    bins = []
    for centre, half_width in zip(centres_hz, np.broadcast_to(half_widths_hz, centres_hz.shape)):
        near = np.flatnonzero(np.abs(freqs_hz - centre) <= max(half_width, freqs_hz[1] / 2))
        bins.append(near[np.argmax(values[near])])
    return np.array(bins, dtype=int)


def _added_power(psd: np.ndarray, floor: np.ndarray, bins: np.ndarray, df: float) -> np.ndarray:
    """Mean-square of the line the measurement has beyond the twin's at each bin (units^2; may be < 0).

    A line's power is its main lobe's minus the floor under it, in each spectrum; with
    random phases, powers add, so the difference is what an effect must add to the twin.
    """
    lobe = np.clip(bins[:, None] + np.arange(-_LOBE_BINS, _LOBE_BINS + 1), 0, psd.shape[-1] - 1)
    line = (psd[:, lobe].sum(axis=-1) - (2 * _LOBE_BINS + 1) * floor[:, bins]) * df
    return line[0] - line[1]


def _relative_db(power: np.ndarray, reference_power: float, floor_db: float) -> np.ndarray:
    """``power`` in dB re ``reference_power``, no lower than ``floor_db`` (a line that is not there)."""
    ratio = np.maximum(power, 0.0) / max(reference_power, np.finfo(float).tiny)
    return np.maximum(10 * np.log10(np.maximum(ratio, np.finfo(float).tiny)), floor_db)


def _added_line_levels_db(measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float, centres_hz,
                         floor_db: float, tolerances_hz=None) -> tuple[np.ndarray, np.ndarray]:
    """Levels (dB re the twin's RMS) and frequencies (Hz) of the lines a measurement adds to its twin.

    For each nominal line in ``centres_hz`` the peak is sought within ``tolerances_hz`` (default:
    a bin plus 0.5 % of the frequency), where the measured PSD exceeds the twin's most; its
    level is the measured line's power above the local floor minus the twin's there, over the
    twin's mean square, and no lower than ``floor_db``. ``twin`` is the gain-matched twin, so
    a level is the one an effect appended to the twin must give its line.
    """
    freqs_hz, psd, floor = _line_spectra(measured, twin, fs, shaft_hz)
    centres_hz = np.atleast_1d(np.asarray(centres_hz, dtype=np.float64))
    if tolerances_hz is None:
        tolerances_hz = _tolerance_hz(centres_hz, freqs_hz[1])
    bins = _window_argmax(freqs_hz, psd[0] - psd[1], centres_hz, tolerances_hz)  # where the measurement adds most
    power = _added_power(psd, floor, bins, freqs_hz[1])
    reference = float(np.mean(np.asarray(twin, dtype=np.float64) ** 2))
    refined = [float(peak_near(freqs_hz, psd[0], freqs_hz[b], freqs_hz[1] / 2)[0]) for b in bins]
    return _relative_db(power, reference, floor_db), np.array(refined)


def _near(freqs_hz: np.ndarray, centres_hz: np.ndarray, df: float) -> np.ndarray:
    """(lines, centres): whether each frequency lies within a centre's tolerance (:func:`_tolerance_hz`)."""
    return np.abs(freqs_hz[:, None] - centres_hz) <= _tolerance_hz(centres_hz, df)


def _explained_elsewhere(freqs_hz: np.ndarray, shaft_hz: float, df: float) -> np.ndarray:
    """Which of the lines at ``freqs_hz`` (every line the measurement adds to the twin) the machine effects
    explain: multiples of the supply (``line_frequency``), shaft orders 1x-3x (``unbalance``,
    ``misalignment``), and the other half orders up to ``LOOSENESS_HARMONICS`` when they form a series
    (``looseness``, :data:`LOOSENESS_SERIES_LINES`)."""
    supply = np.outer(np.arange(1, 2 * SUPPLY_HARMONICS + 1), MAINS_HZ).ravel()
    orders = np.arange(1, 2 * LOOSENESS_HARMONICS + 1) / 2
    machine = np.isin(orders, (1.0, 2.0, 3.0))
    on_order = _near(freqs_hz, orders * shaft_hz, df)
    rattle = on_order[:, ~machine].any(axis=1)
    in_series = np.count_nonzero(on_order[:, ~machine].any(axis=0)) > LOOSENESS_SERIES_LINES  # itself and others
    return _near(freqs_hz, supply, df).any(axis=1) | on_order[:, machine].any(axis=1) | (rattle & in_series)


def _fluctuated_angle(angle_rad: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """An unwrapped angle series whose rate is multiplied by ``factor`` (per interval), same start."""
    steps = np.diff(angle_rad) * 0.5 * (factor[1:] + factor[:-1])
    return angle_rad[0] + np.concatenate([[0.0], np.cumsum(steps)])


def _mode_search_space(search_space: dict, fs: float) -> dict:
    """``search_space`` with the natural frequency searched up to :data:`MODE_REACH_OF_FS` of ``fs`` (Hz)."""
    low, _, log = search_space["natural_frequency_hz"]
    return {**search_space, "natural_frequency_hz": (low, MODE_REACH_OF_FS * fs, log)}


def _psd_ratio_peak(measured: np.ndarray, twin: np.ndarray, fs: float,
                    search_space: dict) -> tuple[float, float, float] | None:
    """Where the measurement's PSD stands highest over the twin's: frequency (Hz), damping ratio
    from the half-power width (2 zeta f_n), and the ratio's peak over its median.

    The ratio is smoothed over 5 bins (50 Hz each) so one noisy bin does not win; frequency and
    damping are kept within ``search_space``. None when no band stands 3 dB above the median.
    """
    low, high, _ = search_space["natural_frequency_hz"]
    nperseg = int(fs // 50)
    freqs_hz, measured_psd = sps.welch(np.asarray(measured, dtype=np.float64), fs=fs, nperseg=nperseg)
    _, twin_psd = sps.welch(np.asarray(twin, dtype=np.float64), fs=fs, nperseg=nperseg)
    ratio = measured_psd / np.maximum(twin_psd, np.finfo(float).tiny)
    ratio = np.convolve(ratio, np.ones(5) / 5, mode="same")
    band = (freqs_hz >= low) & (freqs_hz <= high)
    if not band.any():
        return None
    excess = ratio[band] / np.median(ratio[band])
    peak = int(np.argmax(excess))
    if excess[peak] < 2.0:
        return None
    above = np.flatnonzero(excess >= 1.0 + (excess[peak] - 1.0) / 2)  # half the excess power
    width_hz = max(float(np.ptp(freqs_hz[band][above])), fs / nperseg)
    natural_hz = float(freqs_hz[band][peak])
    zeta_low, zeta_high, _ = search_space["damping_ratio"]
    return natural_hz, float(np.clip(width_hz / (2 * natural_hz), zeta_low, zeta_high)), float(excess[peak])


@register_effect
class Resonance(Effect):
    """Transmission path from the bearing to the sensor: a mount or housing mode.

    Args:
        natural_frequency_hz: the path's natural frequency (housings and magnet mounts: 1-6 kHz; a
            stud-mounted accelerometer: 10-30 kHz), searched from 300 Hz up to
            :data:`MODE_REACH_OF_FS` of the record's sampling rate.
        damping_ratio: its damping ratio zeta (0.02-0.1 for bolted steel).

    Signature: a band of raised energy around the natural frequency (peak gain ~1/(2 zeta))
    and a roll-off above it in the PSD; impacts ring at the natural frequency.
    """

    name = "resonance"
    signature = "band energy around the natural frequency"
    signature_views = ("psd",)
    search_space = {"natural_frequency_hz": (300.0, math.inf, True), "damping_ratio": (0.01, 0.3, True)}  # see search_space_at

    def __init__(self, natural_frequency_hz: float, damping_ratio: float):
        self.natural_frequency_hz = _positive(f"{self.name}.natural_frequency_hz", natural_frequency_hz)
        self.damping_ratio = _positive(f"{self.name}.damping_ratio", damping_ratio)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return base_excitation_filter(signal, fs, self.natural_frequency_hz, self.damping_ratio, self.name)

    def check_rate(self, fs: float) -> None:
        _below_nyquist(self.natural_frequency_hz, fs, self.name)

    @classmethod
    def search_space_at(cls, fs: float) -> dict[str, tuple[float, float, bool]]:
        return _mode_search_space(cls.search_space, fs)

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict | None:
        """The mode where the measurement's PSD stands highest over the twin's, and its width.

        A mode in the path multiplies the twin's spectrum by its transmissibility, so the ratio
        of the two PSDs peaks at the natural frequency; its half-power width is 2 zeta f_n.
        """
        peak = _psd_ratio_peak(measured, twin, fs, cls.search_space_at(fs))
        return None if peak is None else {"natural_frequency_hz": peak[0], "damping_ratio": peak[1]}


@register_effect
class SecondResonance(Resonance):
    """A second mode of the transmission path, in series with ``resonance``'s (same filter).

    Housing and mount each have a mode, and a bolted sensor sees both: the path's
    transmissibility is the product of two base-excitation filters. Offered alone, the
    ranking could not tell this mode from the first (``resonance`` explains a lone mode
    equally well), so it ``requires`` ``resonance`` to be in the twin already.

    Args:
        natural_frequency_hz: the second mode's natural frequency (below or above the first; searched
            as the first's).
        damping_ratio: its damping ratio zeta (0.01-0.1).

    Signature: a second band of raised energy (peak gain ~1/(2 zeta)) where the twin with one
    resonance is short of energy; impacts ring at two frequencies.
    """

    name = "second_resonance"
    requires = ("resonance",)
    signature = "a second band of raised energy around its natural frequency"
    signature_views = ("psd",)


@register_effect
class StructuralMode(Effect):
    """A mode of the housing or frame that the bearing's forces excite beside the direct path.

    A sensor reads the sum of the structure's modal responses, so a mode the twin lacks adds
    its own response to the signal: ``y = x + g B(x)``, with ``B`` a second-order band-pass of
    unit gain at the natural frequency and half-power width ``2 zeta f_n``. Unlike
    ``resonance`` (a mount in series, which also rolls the spectrum off above it), the rest of
    the spectrum stays as it is.

    Args:
        natural_frequency_hz: the mode's natural frequency (housings, frames and covers: 0.3 kHz to
            tens of kHz), searched from 300 Hz up to :data:`MODE_REACH_OF_FS` of the record's sampling rate.
        damping_ratio: its damping ratio zeta.
        level_db: ``g`` in dB, the mode's peak response relative to the direct path's at the
            natural frequency.

    Signature: a band of raised energy around the natural frequency, the rest of the spectrum
    unchanged; impacts ring at it.
    """

    name = "structural_mode"
    signature = "a raised band around the natural frequency, the rest of the spectrum unchanged"
    signature_views = ("psd",)
    search_space = {"natural_frequency_hz": (300.0, math.inf, True), "damping_ratio": (0.01, 0.3, True),
                    "level_db": (-10.0, 40.0, False)}  # see search_space_at

    def __init__(self, natural_frequency_hz: float, damping_ratio: float, level_db: float):
        self.natural_frequency_hz = _positive(f"{self.name}.natural_frequency_hz", natural_frequency_hz)
        self.damping_ratio = _positive(f"{self.name}.damping_ratio", damping_ratio)
        self.level_db = _decibels(f"{self.name}.level_db", level_db)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        mode = mode_band_pass(signal, fs, self.natural_frequency_hz, self.damping_ratio, self.name)
        return signal + 10 ** (self.level_db / 20.0) * mode

    def check_rate(self, fs: float) -> None:
        _below_nyquist(self.natural_frequency_hz, fs, self.name)

    @classmethod
    def search_space_at(cls, fs: float) -> dict[str, tuple[float, float, bool]]:
        return _mode_search_space(cls.search_space, fs)

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict | None:
        """The band where the measurement's PSD stands highest over the twin's, its width and height.

        With the mode added, the power ratio at the natural frequency is (1 + g)^2.
        """
        peak = _psd_ratio_peak(measured, twin, fs, cls.search_space_at(fs))
        if peak is None:
            return None
        natural_hz, zeta, excess = peak
        low, high, _ = cls.search_space["level_db"]
        level_db = 20 * math.log10(max(math.sqrt(excess) - 1.0, 10 ** (low / 20)))
        return {"natural_frequency_hz": natural_hz, "damping_ratio": zeta, "level_db": float(min(level_db, high))}


@register_effect
class Slip(Effect):
    """Random rolling-element slip: each ball wanders in its cage pocket instead of rolling ideally.

    Every ball gets a random angular offset, redrawn once per ball pass (the time the cage
    takes to advance one ball spacing, 2 pi / Nb) and interpolated linearly in between, with
    standard deviation ``jitter`` x 2 pi / Nb at the draws. Since consecutive impacts are one
    ball spacing apart, ``jitter`` is the standard deviation of the impact times as a fraction
    of the nominal impact spacing at the draws (Randall & Antoni: typically 0.01-0.02); between
    them the interpolation lowers it, to sqrt(2/3) = 0.82 of that on average. Race defects only: a ball
    defect's impacts follow the ball's spin, which this slip leaves unchanged.

    Signature: the impacts lose strict periodicity, so envelope-spectrum harmonics weaken with
    order and a random floor rises between them; band energies hardly change.
    """

    name = "slip"
    signature = "envelope harmonics sink into a raised random floor"
    signature_views = ("envelope", "harmonics")
    search_space = {"jitter": (0.002, 0.08, True)}

    def __init__(self, jitter: float):
        self.jitter = _positive("slip.jitter", jitter)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        n, n_balls = kinematics.n_samples, kinematics.n_balls
        spacing_rad = 2 * math.pi / n_balls
        cage_step_rad = abs(kinematics.cage_angle_rad[-1] - kinematics.cage_angle_rad[0]) / max(n - 1, 1)
        samples_per_pass = spacing_rad / cage_step_rad
        n_knots = int(math.ceil((n - 1) / samples_per_pass)) + 2
        knots = rng.normal(0.0, self.jitter * spacing_rad, size=(n_knots, n_balls))
        position = np.arange(n) / samples_per_pass
        lower = np.floor(position).astype(int)
        fraction = (position - lower)[:, None]
        offsets = knots[lower] * (1 - fraction) + knots[lower + 1] * fraction
        return replace(kinematics, ball_offset_rad=kinematics.ball_offset_rad + offsets)


@register_effect
class SpinSlip(Effect):
    """Erratic ball spin: a ball defect strikes the races at irregular times.

    A ball's spin axis is not fixed: the ball skids and its axis precesses, so a spall on
    it leaves and re-enters the rolling track and its strikes lose the strict 2 x BSF
    rhythm (Randall & Antoni 2011, section 2.2: ball faults "may not strike the races every
    revolution"). Modelled as a random walk of the spin angle: once per spin revolution the
    phase takes a Gaussian step of standard deviation ``jitter`` x 2 pi, linearly interpolated
    in between. Race defects are unaffected (their impacts follow the cage and the shaft).

    Signature: the 2 x BSF envelope lines smear into a raised floor, while the cage-rate (FTF)
    modulation of a ball defect passing through the load zone survives.
    """

    name = "spin_slip"
    signature = "2 x BSF envelope lines smear, cage-rate modulation stays"
    signature_views = ("envelope", "harmonics")
    search_space = {"jitter": (0.005, 0.5, True)}

    def __init__(self, jitter: float):
        self.jitter = _positive("spin_slip.jitter", jitter)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        spin = kinematics.ball_spin_angle_rad
        revolutions = abs(spin[-1] - spin[0]) / (2 * math.pi)
        position = np.abs(spin - spin[0]) / (2 * math.pi)  # spin revolutions so far, per sample
        knots = np.concatenate([[0.0], np.cumsum(rng.normal(0.0, self.jitter * 2 * math.pi,
                                                            size=int(math.ceil(revolutions)) + 1))])
        walk = np.interp(position, np.arange(len(knots)), knots)
        return replace(kinematics, ball_spin_angle_rad=spin + walk)


@register_effect
class SpeedFluctuation(Effect):
    """Periodic variation of the shaft speed (load torque ripple, a coupling, a belt).

    omega(t) = omega_0 (1 + depth sin(2 pi frequency_hz t + phi)), phi random; cage and ball
    spin follow the shaft in proportion (rolling without slip), and so does the unbalance force.

    Args:
        depth: peak relative speed deviation (0.005-0.05).
        frequency_hz: modulation frequency (0.5-20 Hz: once per revolution or slower).

    Signature: every defect harmonic k f_d is frequency-modulated, giving sidebands at
    +- frequency_hz whose spread grows with k (k f_d depth / frequency_hz).
    """

    name = "speed_fluctuation"
    signature = "sidebands and smearing growing with harmonic order"
    signature_views = ("envelope", "harmonics", "lines")
    search_space = {"depth": (0.002, 0.08, True), "frequency_hz": (0.5, 30.0, True)}

    def __init__(self, depth: float, frequency_hz: float):
        self.depth = _positive("speed_fluctuation.depth", depth)
        if self.depth >= 1:
            raise BearingTwinError(f"speed_fluctuation.depth must be below 1 (the shaft would stop), got {depth}")
        self.frequency_hz = _positive("speed_fluctuation.frequency_hz", frequency_hz)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        t = np.arange(kinematics.n_samples) / kinematics.fs_hz
        factor = 1.0 + self.depth * np.sin(2 * math.pi * self.frequency_hz * t + rng.uniform(0, 2 * math.pi))
        return replace(
            kinematics,
            shaft_angle_rad=_fluctuated_angle(kinematics.shaft_angle_rad, factor),
            shaft_speed_rad_s=kinematics.shaft_speed_rad_s * factor,
            cage_angle_rad=_fluctuated_angle(kinematics.cage_angle_rad, factor),
            ball_spin_angle_rad=_fluctuated_angle(kinematics.ball_spin_angle_rad, factor),
        )


@register_effect
class Roughness(Effect):
    """Rough, wavy surfaces: every ball's contacts roll over a random height, and the bearing vibrates with it.

    The bare twin's races and balls are ideally smooth, so a healthy bearing vibrates only with the varying
    compliance of its turning ball set (lines at the ball-pass rate). A real bearing also rolls over the
    roughness and waviness of its surfaces and the varying thickness of its lubricant film. Each ball's
    compression loses a random height, independent from ball to ball (a ball's contact track wanders over
    its own surface as its spin axis moves), white up to ``bandwidth_hz`` (the contact ellipse averages
    shorter wavelengths away). The height acts on the races through the Hertz contacts, so the vibration
    it makes is shaped by the bearing's own dynamics: a floor that rises with frequency up to the contact
    modes (acceleration from a force grows as f^2 below the support's resonance), where a sensor's white
    floor lies flat, and only loaded balls pass it on, which modulates it at the ball-pass rate.

    Args:
        rms_um: RMS of each contact's height over 0 - ``bandwidth_hz`` at its flat spectral level
            (``rms_um``^2 / ``bandwidth_hz`` per Hz; the low-pass's roll-off at the band's edge leaves the
            whole height's RMS about 5 % lower); a ground race's roughness is 0.05-0.2 um, waviness and film
            variation add to it.
        bandwidth_hz: highest frequency of the height seen in time (Hz). A grid too coarse to carry it
            keeps the same spectral level over the band it can (the level is held, not the total).

    Signature: a broadband floor shaped by the bearing's contact modes, lower kurtosis, a raised
    envelope floor; no lines.

    Not among ``bearingtwin-twin``'s default candidates (``candidates=[..., roughness]`` adds it), and offered
    on a healthy bearing's record only (``bearing_states``). A defect's impacts ring the same contact modes
    far louder, and what a floor under them brings the twin closer in is chiefly the lines view, where any
    floor buries the bare twin's own lines, so there it is not told from a sensor's floor (on the test rig's
    development split a hidden white floor on an inner-race record was taken for roughness). On a healthy
    record it stands in for the bare twin's model-form gap too: its ball-pass lines far above a real
    bearing's, which on one rig took a height at the search's edge (10 um) to bury, and a twin calibrated so
    carries it to every state (``data=twin_to_real``), burying small defects (results/identifiability.md says
    how much).
    """

    name = "roughness"
    bearing_states = ("normal",)
    signature = "broadband floor rising towards the contact modes, lower kurtosis"
    signature_views = ("psd", "statistics")
    search_space = {"rms_um": (0.001, 10.0, True)}

    def __init__(self, rms_um: float, bandwidth_hz: float = 10000.0):
        self.rms_um = _positive("roughness.rms_um", rms_um)
        self.bandwidth_hz = _positive("roughness.bandwidth_hz", bandwidth_hz)

    def modify_kinematics(self, kinematics: Kinematics, rng: np.random.Generator) -> Kinematics:
        fs = kinematics.fs_hz
        band_hz = min(self.bandwidth_hz, 0.45 * fs)
        # White at the grid's rate with the band's spectral level (rms^2 / bandwidth), then low-passed to the band.
        level = math.sqrt(0.5 * fs / self.bandwidth_hz) * self.rms_um * 1e-6
        white = level * rng.standard_normal((kinematics.n_samples, kinematics.n_balls))
        height = sps.sosfiltfilt(sps.butter(4, band_hz, fs=fs, output="sos"), white, axis=0)
        earlier = kinematics.contact_roughness_m
        return replace(kinematics, contact_roughness_m=height if earlier is None else earlier + height)


@register_effect
class Noise(Effect):
    """Sensor and background noise: electronics (white) and machinery or flow (falling with frequency).

    Args:
        snr_db: ratio of the bearing signal's power to the noise power, in dB (searched in [-10, 50]: from a
            floor above the bearing's signal to a good accelerometer's, 40-50 dB below a faulty bearing's).
        spectral_slope: exponent of the noise PSD ~ f^-slope (0 white, 1 pink, 2 brown).
        reference_rms: the signal RMS (m/s^2) that ``snr_db`` refers to; null = each simulated
            signal's own. Fitted on one record, the noise is a property of the sensor and the
            machine, not of the bearing's state: ``data=twin_to_real`` sets this to the healthy
            twin's RMS so that a faulty twin gets the healthy record's noise floor, not one
            scaled up with its own fault.

    Signature: a raised floor in the bands where the bearing is quiet, lower kurtosis and
    crest factor, a raised envelope-spectrum floor.
    """

    name = "noise"
    signature = "raised floor in quiet bands, lower kurtosis"
    signature_views = ("psd", "statistics")
    search_space = {"snr_db": (-10.0, 50.0, False), "spectral_slope": (0.0, 2.0, False)}

    def __init__(self, snr_db: float, spectral_slope: float, reference_rms: float | None = None):
        if not is_finite_number(snr_db):
            raise BearingTwinError(f"noise.snr_db must be finite, got {snr_db}")
        _decibels("noise.snr_db", snr_db)
        if not (is_finite_number(spectral_slope) and 0.0 <= spectral_slope <= 3.0):
            raise BearingTwinError(f"noise.spectral_slope must lie in [0, 3], got {spectral_slope}")
        self.snr_db, self.spectral_slope = float(snr_db), float(spectral_slope)
        self.reference_rms = None if reference_rms is None else _positive("noise.reference_rms", reference_rms)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return add_noise(signal, fs, self.snr_db, self.spectral_slope, rng, self.reference_rms)


def _at_most_zero(field: str, value: float, why: str) -> float:
    if not finite_number(field, value) <= 0:
        raise BearingTwinError(f"{field} must be at most 0 dB ({why}), got {value}")
    return float(value)


class LineEffect(Effect):
    """An effect that adds narrow lines to the sensor signal; subclasses say where and how strong.

    Sensor-only: a machine force at a low frequency (shaft orders, supply multiples) reaches
    the sensor through the housing beside the bearing's response, far below the path's
    resonances, so it adds to the signal as it is and the twin never re-simulates for it.
    The lines sit at the nominal shaft rate: a speed fluctuation (``modify_kinematics``)
    modulates the bearing's lines, not these.
    """

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies (Hz) and levels (dB re the signal's RMS) of the lines at shaft rate ``shaft_hz``."""
        raise NotImplementedError

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return add_lines(signal, fs, *self.lines(_positive("shaft_hz", shaft_hz)), rng)


@register_effect
class Tones(LineEffect):
    """Narrow lines from elsewhere: neighbouring machines, rotor-bar pass, a drive's carrier, a fan's blade pass.

    A set of independent lines, each with its own frequency and level: the lines a
    measurement shows that none of the machine effects (``unbalance``, ``misalignment``: 1x-3x;
    ``looseness``: a series of shaft orders and half orders; ``line_frequency``: supply multiples)
    accounts for, a lone shaft order or half order other than 1x-3x (a blade or vane pass) among
    them. A gear on
    the shaft is not such a set: its mesh lines stand at whole shaft orders with shaft-rate
    sidebands, a modulation these independent lines do not make; the library has no gear mesh
    (the guide's "Adding an effect" writes one).
    ``initial_guess`` reads them off the measured spectrum; the calibration then refines one
    common ``level_offset_db``, so the parameters stay a plain dict and the search one-dimensional.

    Args:
        frequencies_hz: the lines' frequencies in Hz (any number, possibly none).
        levels_db: each line's RMS relative to the bearing signal's RMS, in dB (-40 to +20).
        level_offset_db: added to every level, in dB (what the ranking calibrates; 0 as read).

    Signature: narrow lines in the PSD that no machine effect accounts for: off the supply's
    multiples, the shaft's 1x-3x, a looseness series and the defect frequencies (a lone higher
    shaft order, a blade pass, among them).
    """

    name = "tones"
    signature = "narrow lines no machine effect accounts for (a lone higher shaft order among them)"
    signature_views = ("lines",)
    search_space = {"level_offset_db": (-10.0, 10.0, False)}
    max_lines = 5
    """At most this many lines are read off a measurement, the strongest."""
    max_frequency_hz = 2000.0
    """Lines are read off a measurement below this frequency only. Machines' lines (supply,
    shaft, gear mesh, rotor-bar pass, neighbours) lie below it; above, in the structural
    resonance band, a bearing record's narrow lines are the defect's own impact comb (the
    harmonics of BPFO under the resonance: seen on CWRU records 105 and 130 at 2.4-3.6 kHz),
    which the bearing model, not a set of tones, has to explain."""

    def __init__(self, frequencies_hz: list[float], levels_db: list[float], level_offset_db: float = 0.0):
        frequencies_hz, levels_db = list(frequencies_hz), list(levels_db)
        if len(frequencies_hz) != len(levels_db):
            raise BearingTwinError(f"tones.levels_db must give one level per line of tones.frequencies_hz, "
                                   f"got {len(levels_db)} levels for {len(frequencies_hz)} lines")
        self.frequencies_hz = [_positive("tones.frequencies_hz", f) for f in frequencies_hz]
        self.levels_db = [_decibels("tones.levels_db", level) for level in levels_db]
        self.level_offset_db = _decibels("tones.level_offset_db", level_offset_db)

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.frequencies_hz), np.array(self.levels_db) + self.level_offset_db

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict:
        """The strongest narrow lines the measurement has and the twin lacks, off the other effects' lines.

        A line is a local maximum of the measured PSD standing :data:`LINE_PROMINENCE_DB` above
        the measurement's local floor and :data:`LINE_ABSENT_DB` above the twin's PSD near
        it, below :attr:`max_frequency_hz`, and none the machine effects explain: within the
        tolerance of a multiple of 50 or 60 Hz (up to twice :data:`SUPPLY_HARMONICS`), of the shaft's
        1x-3x, or of another half order up to :data:`LOOSENESS_HARMONICS` when such orders form a
        series (:func:`_explained_elsewhere`). Frequencies are refined between bins; levels are the
        power the measurement adds there, relative to the twin's. No line: empty lists.
        """
        freqs_hz, psd, floor = _line_spectra(measured, twin, fs, shaft_hz)
        df = freqs_hz[1]
        peaks, _ = sps.find_peaks(psd[0], distance=2 * _LOBE_BINS + 2)  # a strong line's side lobes are no lines
        peaks = peaks[(psd[0, peaks] > 10 ** (LINE_PROMINENCE_DB / 10) * floor[0, peaks])
                      & (freqs_hz[peaks] < cls.max_frequency_hz)]
        twin_bins = _window_argmax(freqs_hz, psd[1], freqs_hz[peaks], _tolerance_hz(freqs_hz[peaks], df, 0.01))
        peaks = peaks[psd[0, peaks] > 10 ** (LINE_ABSENT_DB / 10) * psd[1, twin_bins]]
        peaks = peaks[~_explained_elsewhere(freqs_hz[peaks], shaft_hz, df)]
        added = _added_power(psd, floor, peaks, df)
        strongest = np.argsort(-added)[: cls.max_lines]
        strongest = np.sort(strongest[added[strongest] > 0])
        reference = float(np.mean(np.asarray(twin, dtype=np.float64) ** 2))
        levels = _relative_db(added[strongest], reference, -np.inf)
        return {"frequencies_hz": [float(peak_near(freqs_hz, psd[0], freqs_hz[b], df / 2)[0]) for b in peaks[strongest]],
                "levels_db": [float(level) for level in levels], "level_offset_db": 0.0}


@register_effect
class Unbalance(LineEffect):
    """Rotor unbalance: a rotating force m e omega^2 at the shaft rate.

    A mass m at eccentricity e on a shaft turning at omega pulls on the bearings with a force
    of constant magnitude rotating with the shaft; a radial accelerometer sees its projection,
    a sinusoid at the shaft rate. (The bearing model's own ``eccentricity_m`` puts it through
    the dynamics; as a line in the sensor path it costs the twin no simulation.)

    Args:
        level_db: the 1x line's RMS relative to the bearing signal's RMS, in dB (-60 to +20; an
            acceleration sensor weighs the low shaft rate down, so a few dB below the bearing's
            broadband level is typical of a well-balanced motor).

    Signature: one line at exactly the shaft rate, nothing at its harmonics.
    """

    name = "unbalance"
    signature = "a line at the shaft rate (1x) only"
    signature_views = ("lines",)
    search_space = {"level_db": (-60.0, 20.0, False)}

    def __init__(self, level_db: float):
        self.level_db = _decibels("unbalance.level_db", level_db)

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array([shaft_hz]), np.array([self.level_db])

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict:
        """The level of the line the measurement adds at the shaft rate."""
        (level,), _ = _added_line_levels_db(measured, twin, fs, shaft_hz, [shaft_hz], cls.search_space["level_db"][0])
        return {"level_db": float(level)}


@register_effect
class Misalignment(LineEffect):
    """Shaft misalignment at a coupling: a force at twice the shaft rate, with 1x and 3x beside it.

    An angular or parallel offset between two coupled shafts bends the coupling twice per
    revolution, so the bearings feel a reaction force whose strongest component is at 2x the
    shaft rate; the coupling's asymmetry adds 1x (parallel offset) and 3x.

    Args:
        level_db: the 2x line's RMS relative to the bearing signal's RMS, in dB (-60 to +20).
        one_x_db: the 1x line relative to the 2x line, in dB (-30 to 0: 2x dominates, or it
            would be unbalance).
        three_x_db: the 3x line relative to the 2x line, in dB (fixed, not fitted; -30 to 0).

    Signature: a 2x shaft line stronger than the 1x, with a weaker 3x.
    """

    name = "misalignment"
    signature = "a 2x shaft line above the 1x, a weaker 3x"
    signature_views = ("lines",)
    search_space = {"level_db": (-60.0, 20.0, False), "one_x_db": (-30.0, 0.0, False)}

    def __init__(self, level_db: float, one_x_db: float = -6.0, three_x_db: float = -10.0):
        self.level_db = _decibels("misalignment.level_db", level_db)
        self.one_x_db = _at_most_zero("misalignment.one_x_db", one_x_db, "the 2x line dominates")
        self.three_x_db = _at_most_zero("misalignment.three_x_db", three_x_db, "the 2x line dominates")

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        return shaft_hz * np.arange(1.0, 4.0), self.level_db + np.array([self.one_x_db, 0.0, self.three_x_db])

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict:
        """The 2x level, and the 1x and 3x relative to it, that the measurement adds at those orders."""
        floor_db, relative_floor_db = cls.search_space["level_db"][0], cls.search_space["one_x_db"][0]
        (one, two, three), _ = _added_line_levels_db(measured, twin, fs, shaft_hz, shaft_hz * np.arange(1.0, 4.0),
                                                     floor_db)
        return {"level_db": float(two), "one_x_db": float(np.clip(one - two, relative_floor_db, 0.0)),
                "three_x_db": float(np.clip(three - two, relative_floor_db, 0.0))}


@register_effect
class Looseness(LineEffect):
    """Mechanical looseness: a part that rattles at the shaft rate (loose foot, bearing loose in its seat).

    The loose part follows the shaft's excitation only while in contact and lifts off for
    the rest of the revolution, so its response is a truncated, impacting waveform: rich in
    shaft harmonics, and, because the rattle repeats only every other revolution at the
    threshold of lift-off, in half orders (0.5x, 1.5x, 2.5x ...). Rendered directly as that
    spectrum's lines, so the comb's level and its half-order content are separate parameters.

    Args:
        level_db: the 1x line's RMS relative to the bearing signal's RMS, in dB (-60 to +20).
        half_order_db: half-order lines relative to the integer-order comb at their order, in
            dB (-30 to 0).
        n_harmonics: lines at 1x ... n_harmonics x and the half orders below them (fixed, not
            fitted; 10 is typical of a loose machine's spectrum).
        decay_db_per_order: the comb falls this much per shaft order, in dB (not fitted: the
            initial guess reads it off the measurement, 0-10; short impacts keep the harmonics
            strong, longer ones lose them within a few orders).

    Signature: a long comb of shaft harmonics with half-order lines between them.
    """

    name = "looseness"
    signature = "a comb of shaft harmonics with half orders (0.5x, 1.5x ...)"
    signature_views = ("lines",)
    search_space = {"level_db": (-60.0, 20.0, False), "half_order_db": (-30.0, 0.0, False)}

    def __init__(self, level_db: float, half_order_db: float = -10.0, n_harmonics: int = LOOSENESS_HARMONICS,
                 decay_db_per_order: float = LOOSENESS_DECAY_DB_PER_ORDER):
        self.level_db = _decibels("looseness.level_db", level_db)
        self.half_order_db = _decibels("looseness.half_order_db", half_order_db)
        self.n_harmonics = whole_number("looseness.n_harmonics", n_harmonics)
        if not finite_number("looseness.decay_db_per_order", decay_db_per_order) >= 0:
            raise BearingTwinError(f"looseness.decay_db_per_order must be non-negative, got {decay_db_per_order}")
        self.decay_db_per_order = float(decay_db_per_order)

    @staticmethod
    def _comb(n_harmonics: int, decay_db_per_order: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Shaft orders 0.5, 1, ..., n, whether each is a half order, and the comb's dB re its 1x there."""
        orders = np.arange(1, 2 * n_harmonics + 1) / 2
        return orders, orders % 1 != 0, -decay_db_per_order * np.maximum(orders - 1, 0.0)

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        orders, half, comb_db = self._comb(self.n_harmonics, self.decay_db_per_order)
        return shaft_hz * orders, self.level_db + comb_db + np.where(half, self.half_order_db, 0.0)

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict:
        """The comb's fall per order, its 1x level and the half orders' level relative to it.

        How fast a rattle's comb falls depends on how short its impacts are, which differs from one
        loose part to the next. Where half-order lines stand (looseness's own mark, which no
        unbalance or misalignment leaves; standing: added within :data:`LOOSENESS_READ_RANGE_DB` of
        the strongest line), the fall is the robust (Theil-Sen) slope of every standing line's level
        against its order, between 0 and :data:`LOOSENESS_MAX_DECAY_DB_PER_ORDER`; else it stays the
        default. Each line's level is then referred back to the 1x through that comb and the median
        taken, so that one strong line of another effect (unbalance's 1x, misalignment's 2x) does
        not set the comb.
        """
        floor_db, relative_floor_db = cls.search_space["level_db"][0], cls.search_space["half_order_db"][0]
        orders, half, _ = cls._comb(LOOSENESS_HARMONICS, LOOSENESS_DECAY_DB_PER_ORDER)
        levels, _ = _added_line_levels_db(measured, twin, fs, shaft_hz, shaft_hz * orders, floor_db)
        standing = levels > max(float(levels.max()) - LOOSENESS_READ_RANGE_DB, floor_db)
        decay = LOOSENESS_DECAY_DB_PER_ORDER
        if np.count_nonzero(standing & half) >= 2 and np.count_nonzero(standing) >= 3:
            slope = scipy.stats.theilslopes(levels[standing], orders[standing]).slope
            decay = float(np.clip(-slope, 0.0, LOOSENESS_MAX_DECAY_DB_PER_ORDER))
        _, _, comb_db = cls._comb(LOOSENESS_HARMONICS, decay)
        at_one_x = levels - comb_db
        level = float(np.median(at_one_x[~half]))
        return {"level_db": level, "decay_db_per_order": decay,
                "half_order_db": float(np.clip(np.median(at_one_x[half]) - level, relative_floor_db, 0.0))}


@register_effect
class LineFrequency(LineEffect):
    """Electrical lines of an induction motor: magnetic pull at twice the supply frequency.

    The stator field pulls on the rotor twice per supply cycle, strongest where the air gap
    is smallest (an eccentric rotor, a soft foot), so the frame vibrates at 2 f_s and, as
    the pull is not sinusoidal, at 4 f_s, 6 f_s ...; an unbalanced supply or pickup in the
    sensor cable adds f_s itself.

    Args:
        supply_hz: supply frequency f_s in Hz: 50 or 60 from the grid, anything from a drive.
            Fitted continuously in [45, 65]: a variable-frequency drive is not tied to the
            grid's values, and the guess read off the spectrum is already within a bin.
        level_db: the 2 f_s line's RMS relative to the bearing signal's RMS, in dB (-60 to +20).
        fundamental_db: the f_s line relative to the 2 f_s line, in dB (fixed, not fitted;
            -40 to 0).
        n_harmonics: lines at 2 k f_s for k = 1..n_harmonics, amplitude 1/k (fixed, not fitted).

    Signature: a line at twice the supply frequency, the largest of a family at its
    multiples, with a weaker one at the supply frequency.
    """

    name = "line_frequency"
    signature = "a line at twice the supply frequency, its harmonics, a weaker 1x supply"
    signature_views = ("lines",)
    search_space = {"supply_hz": (45.0, 65.0, False), "level_db": (-60.0, 20.0, False)}

    def __init__(self, supply_hz: float, level_db: float, fundamental_db: float = -10.0,
                 n_harmonics: int = SUPPLY_HARMONICS):
        self.supply_hz = _positive("line_frequency.supply_hz", supply_hz)
        self.level_db = _decibels("line_frequency.level_db", level_db)
        self.fundamental_db = _at_most_zero("line_frequency.fundamental_db", fundamental_db,
                                            "the line at twice the supply frequency dominates")
        self.n_harmonics = whole_number("line_frequency.n_harmonics", n_harmonics)

    def lines(self, shaft_hz: float) -> tuple[np.ndarray, np.ndarray]:
        k = np.arange(1, self.n_harmonics + 1)
        return (self.supply_hz * np.concatenate([[1.0], 2.0 * k]),
                self.level_db + np.concatenate([[self.fundamental_db], -20 * np.log10(k)]))

    @classmethod
    def initial_guess(cls, measured: np.ndarray, twin: np.ndarray, fs: float, shaft_hz: float) -> dict:
        """The supply from the strongest added line in twice the search range, its level and the f_s line's."""
        low, high, _ = cls.search_space["supply_hz"]
        floor_db = cls.search_space["level_db"][0]
        # The 2 f_s line is sought over twice the supply range: centre low + high, half-width high - low.
        (level,), (twice_supply_hz,) = _added_line_levels_db(measured, twin, fs, shaft_hz, [low + high],
                                                             floor_db, tolerances_hz=[high - low])
        supply_hz = twice_supply_hz / 2
        (fundamental,), _ = _added_line_levels_db(measured, twin, fs, shaft_hz, [supply_hz], floor_db)
        # No f_s line read (its level at the floor): as weak as the ratio goes, not floor minus floor = 0 dB.
        ratio = fundamental - level if fundamental > floor_db else FUNDAMENTAL_FLOOR_DB
        return {"supply_hz": float(supply_hz), "level_db": float(level),
                "fundamental_db": float(np.clip(ratio, FUNDAMENTAL_FLOOR_DB, 0.0))}


@register_effect
class Clipping(Effect):
    """Sensor saturation: the recorded signal is the true one limited to the sensor's range.

    An accelerometer's amplifier or the acquisition's converter stops at its full-scale
    range. Modelled as a hard limit, not a soft one (tanh): a converter's full scale is
    exact and an IEPE amplifier stays linear almost to its rail, which is what saturated
    records show, flat tops. The range is given relative to the RMS of the signal reaching
    the sensor, because the twin's absolute scale is the fitted sensor gain.

    Args:
        clip_level: the range as a multiple of the signal's RMS (1-10; impacts of a defect
            reach 4-10 times the RMS, so a clip level of a few RMS cuts them).

    Signature: flat-topped peaks; lower kurtosis and crest factor; the clipped impacts'
    energy spreads to odd harmonics and a broadband floor.

    It clips what reaches the recorder, so it runs after every other effect wherever it is
    listed (``records_last``): a shaft line added after it would stand unclipped.
    """

    name = "clipping"
    records_last = True
    signature = "flat-topped peaks, lower kurtosis and crest factor"
    signature_views = ("statistics",)
    search_space = {"clip_level": (1.0, 10.0, True)}

    def __init__(self, clip_level: float):
        self.clip_level = _positive("clipping.clip_level", clip_level)

    def modify_signal(self, signal: np.ndarray, fs: float, rng: np.random.Generator, shaft_hz: float) -> np.ndarray:
        return clip_at_rms(signal, self.clip_level)


@register_effect
class LoadZone(Effect):
    """Radial load on the shaft and the radial clearance, which together set the load zone.

    Args:
        radial_load_n: downward radial load on the inner race in N (belt pull, rotor weight
            beyond the model's); replaces ``simulator.load_y_n``.
        clearance_um: radial clearance in micrometres, the gap per ball (half the catalogue's
            radial internal clearance, see ``BearingGeometry.clearance_mm``): the larger it is for
            a given load, the fewer balls carry it and the narrower the load zone.

    Signature: impacts are strong only inside the load zone, so a rotating defect (inner race:
    shaft rate, ball: cage rate) is amplitude-modulated: sidebands around the defect
    harmonics; the contact stiffness, hence the race modes, shifts with load.
    """

    name = "load_zone"
    signature = "modulation sidebands and shifted race modes"
    signature_views = ("envelope", "harmonics", "psd")
    search_space = {"radial_load_n": (10.0, 5000.0, True), "clearance_um": (0.5, 40.0, True)}

    def __init__(self, radial_load_n: float, clearance_um: float):
        if not is_finite_number(radial_load_n) or radial_load_n < 0:
            raise BearingTwinError(f"load_zone.radial_load_n must be a non-negative number, got {radial_load_n}")
        if not is_finite_number(clearance_um) or clearance_um < 0:
            raise BearingTwinError(f"load_zone.clearance_um must be a non-negative number, got {clearance_um}")
        self.radial_load_n, self.clearance_um = float(radial_load_n), float(clearance_um)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, load_y_n=-self.radial_load_n, clearance_m=self.clearance_um * 1e-6)


@register_effect
class Preload(Effect):
    """A preloaded bearing: every ball is compressed, so the load zone spans the whole circle.

    Motor bearings are usually held by an axial wave spring (or fitted with interference),
    which presses every ball against both races. In this radial model that is a negative
    internal clearance: each ball starts ``interference_um`` compressed, so the radial load
    only varies the ball loads around the circle instead of unloading half of them.

    Args:
        interference_um: radial compression of every ball at rest, in micrometres; replaces
            the clearance (a ball carrying ~1 kN of a 6205's load sinks ~20 um, so a few tens
            of micrometres keep every ball loaded).

    Signature: a rotating defect (inner race, ball) strikes at every position, so its
    shaft- or cage-rate modulation and the sidebands around its harmonics shrink, and the
    defect lines carry a larger share of the envelope.
    """

    name = "preload"
    signature = "modulation sidebands shrink, defect lines dominate the envelope"
    signature_views = ("envelope", "harmonics")
    search_space = {"interference_um": (1.0, 60.0, True)}

    def __init__(self, interference_um: float):
        self.interference_um = _positive("preload.interference_um", interference_um)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, clearance_m=-self.interference_um * 1e-6)


@register_effect
class Lubrication(Effect):
    """Elastohydrodynamic oil film in the ball-race contacts.

    The pressurised film is a compliant, viscous layer in series with the dry Hertz
    contact: it lowers the contact stiffness and damps each loaded contact.

    Args:
        stiffness_ratio: contact stiffness with the film / dry Hertz stiffness (0.5-1).
        damping_ns_per_m: viscous damping of each loaded ball contact in N s/m, acting on the
            races' approach speed along the contact's line (tens to thousands of N s/m for grease
            to oil bath); a ball's drop into a pit is not damped, so its impact passes whole.

    Signature: the race-contact modes (a few hundred Hz in the paper's bearing) move down
    with the softer film and lose energy to its damping, while the sharp deflection rate at
    a pit still passes as force: the mode bands weaken and the impacts stand out more.
    """

    name = "lubrication"
    signature = "weaker, lower contact-mode bands; impacts stand out more"
    signature_views = ("psd", "statistics")
    search_space = {"stiffness_ratio": (0.3, 1.0, False), "damping_ns_per_m": (1.0, 5000.0, True)}

    def __init__(self, stiffness_ratio: float, damping_ns_per_m: float):
        if not 0.0 < stiffness_ratio <= 1.0:
            raise BearingTwinError(f"lubrication.stiffness_ratio must lie in (0, 1], got {stiffness_ratio}")
        if not np.isfinite(damping_ns_per_m) or damping_ns_per_m < 0:
            raise BearingTwinError(
                f"lubrication.damping_ns_per_m must be a non-negative number, got {damping_ns_per_m}")
        self.stiffness_ratio, self.damping_ns_per_m = float(stiffness_ratio), float(damping_ns_per_m)

    def modify_parameters(self, params: DynamicParameters) -> DynamicParameters:
        return replace(params, contact_stiffness_n_per_m1_5=params.contact_stiffness_n_per_m1_5 * self.stiffness_ratio,
                       contact_damping_ns_per_m=params.contact_damping_ns_per_m + self.damping_ns_per_m)
