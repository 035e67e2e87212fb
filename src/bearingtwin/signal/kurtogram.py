"""Spectral kurtosis and the kurtogram: in which frequency band a signal is most impulsive.

A localized bearing defect sends a train of impacts through the structure; each impact rings a
resonance, so in that band the signal is far more impulsive (heavier-tailed) than elsewhere.
Spectral kurtosis (Antoni, MSSP 2006) measures this per frequency from the short-time Fourier
transform X(t, f):

    SK(f) = <|X(t, f)|^4> / <|X(t, f)|^2>^2 - 2

(the ``- 2`` makes a stationary Gaussian signal's SK zero; a stationary tone's is -1; impacts give
large positive values). Which band stands out depends on the frequency resolution, so the
kurtogram computes SK for several window lengths (Antoni & Randall, MSSP 2006): short windows
resolve short transients over wide bands, long windows narrow bands. The band with the largest SK
is where to demodulate. This is the STFT-based kurtogram; Antoni's fast kurtogram (MSSP 2007)
computes a comparable map with a 1/3-binary filter bank. No maintained Python package provides
either, so it is written here, in ``scipy.signal``'s style.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_record, as_signal, check_positive


def spectral_kurtosis(x, fs_hz: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """SK per frequency along the last axis: (freqs_hz (m,), sk (..., m)), from a Hann STFT with 75 % overlap.

    Bins where the signal has no power get SK = 0. ``fs_hz`` is the sampling rate in Hz; ``nperseg`` the
    STFT window length in samples.
    """
    # A NaN anywhere in a row would leave that row's SK silently zero, so refuse it as envelope() does.
    x = as_signal(x)
    check_positive(fs_hz, "fs_hz")
    if not (isinstance(nperseg, (int, np.integer)) and 4 <= nperseg <= x.shape[-1]):
        raise BearingTwinError(f"nperseg must be an integer between 4 and the signal's length {x.shape[-1]}, got {nperseg!r}")
    freqs_hz, _, coefficients = scipy.signal.stft(x, fs=fs_hz, window="hann", nperseg=nperseg,
                                                  noverlap=3 * nperseg // 4, boundary=None, padded=False, axis=-1)
    power = np.abs(coefficients) ** 2
    second = power.mean(axis=-1)
    fourth = (power ** 2).mean(axis=-1)
    sk = np.where(second > 0, fourth / np.where(second > 0, second, 1.0) ** 2 - 2.0, 0.0)
    return freqs_hz, sk


@dataclass
class Kurtogram:
    """SK for each window length, and the band where it is largest.

    Attributes:
        nperseg: the window lengths (samples), one per level.
        freqs_hz: per level, the STFT's bin frequencies.
        sk: per level, SK per bin (edge bins excluded from the search: DC and Nyquist).
        band_hz: (low, high) of the best bin: centre +- half its bandwidth fs / nperseg, within (0, fs/2).
        best_sk: the largest SK; best_nperseg: the window length it was found with.
    """

    nperseg: list[int]
    freqs_hz: list[np.ndarray]
    sk: list[np.ndarray]
    band_hz: tuple[float, float]
    best_sk: float
    best_nperseg: int


def kurtogram(x, fs_hz: float, nperseg=(16, 32, 64, 128, 256), min_hz: float = 0.0) -> Kurtogram:
    """The STFT kurtogram of a 1-D signal and its most impulsive band (above ``min_hz``).

    ``min_hz`` excludes low bands (shaft harmonics, electrical lines) from the choice, as a
    demodulation band for bearing diagnosis lies above them.

    The best band of a signal with no transient is chance: a Gaussian signal's SK scatters by about
    ``2 / sqrt(K)`` over the ``K`` segments a window length gives (Antoni 2006), most at the longest
    windows. In a 2048-sample window the longest level's chance maximum reaches an SK of about 1; a
    whole record's thousands of segments keep it near 0, so an SK well above that scatter marks
    impacts.
    """
    x = as_record(x, "x", "the kurtogram")
    check_positive(fs_hz, "fs_hz")
    if np.ptp(x) == 0:  # every band's kurtosis 0 / 0: a band would be named by chance (a dead channel)
        raise BearingTwinError(f"x is constant (every sample {x[0]:g}): it has no spectral kurtosis to choose a band by")
    if isinstance(nperseg, (int, np.integer)):  # one window length, as spectral_kurtosis takes it
        nperseg = (nperseg,)
    try:
        lengths = list(nperseg)
    except TypeError:
        raise BearingTwinError(f"nperseg must be a window length or a sequence of them (samples), got {nperseg!r}") from None
    whole = [n for n in lengths if isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 4]
    if not lengths or len(whole) < len(lengths):
        raise BearingTwinError(f"nperseg must hold integer window lengths of 4 samples or more, got {nperseg!r}")
    levels = [int(n) for n in whole if n <= x.size]  # a window longer than the signal reads nothing: not a level
    if not levels:
        raise BearingTwinError(f"the signal ({x.size} samples) is shorter than every window length {list(nperseg)}")
    freqs, sks, best = [], [], (-np.inf, 0.0, levels[0])
    for n in levels:
        f, sk = spectral_kurtosis(x, fs_hz, n)
        freqs.append(f)
        sks.append(sk)
        usable = (f > max(min_hz, 0.0)) & (f < fs_hz / 2)
        if usable.any():
            index = np.flatnonzero(usable)[np.argmax(sk[usable])]
            if sk[index] > best[0]:
                best = (float(sk[index]), float(f[index]), n)
    if not np.isfinite(best[0]):
        raise BearingTwinError(f"no frequency bin above min_hz={min_hz} Hz below Nyquist ({fs_hz / 2:g} Hz)")
    best_sk, centre, n = best
    half = fs_hz / n / 2.0
    band = (max(centre - half, fs_hz / n / 4.0), min(centre + half, 0.49 * fs_hz))
    if band[0] >= band[1]:  # a bin centred above the band's upper limit: the bin's width below that limit
        band = (0.49 * fs_hz - 2.0 * half, 0.49 * fs_hz)
    return Kurtogram(levels, freqs, sks, band, best_sk, n)
