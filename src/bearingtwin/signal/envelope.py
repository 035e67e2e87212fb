"""Hilbert envelopes and envelope spectra: where bearing defect frequencies show up.

A localized bearing defect produces a train of impacts that excite a structural
resonance; the fault repetition rate (BPFO, BPFI, 2 x BSF, ...) is the frequency of
the *amplitude modulation* of that resonance, not a spectral line of the raw signal.
Demodulating with the analytic signal and taking the spectrum of the envelope moves
the repetition rate down to where it can be read off directly. All functions work
along the last axis and accept any leading batch axes.
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from bearingtwin.checks import finite_number, non_negative_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_signal, check_positive


def cepstral_prewhiten(x) -> np.ndarray:
    """The signal with every frequency's magnitude set to one and its phase kept, along the last axis.

    Cepstral pre-whitening (Sawalhi & Randall; Borghesani, Pennacchi, Randall et al., MSSP 2013):
    zeroing the real cepstrum except at zero quefrency divides the spectrum by its own magnitude.
    What the transfer path does to the spectrum's shape (resonances, the sensor's response) and
    discrete lines' dominance go; the timing of repeated impacts, which lives in the phases, stays,
    so the envelope of the whitened signal shows the defect's repetition rate whatever the path.
    The output has unit power per frequency bin, whatever the input's unit.
    """
    x = as_signal(x)
    spectrum = np.fft.rfft(x - x.mean(axis=-1, keepdims=True), axis=-1)
    magnitude = np.abs(spectrum)
    whitened = np.where(magnitude > 0, spectrum / np.where(magnitude > 0, magnitude, 1.0), 0.0)
    whitened[..., 0] = 0.0  # the mean was removed: what is left at DC is rounding, its sign arbitrary
    return np.fft.irfft(whitened, n=x.shape[-1], axis=-1)


def envelope(x) -> np.ndarray:
    """Magnitude of the analytic signal along the last axis (same shape as ``x``).

    The FFT-based Hilbert transform assumes a periodic signal, so the first and last
    few samples carry edge effects when the window does not hold whole periods.

    ``x`` should have zero mean, as a band-passed signal has (every caller here band-passes or
    high-passes first): ``|c + a(t) cos(wt)|`` is not ``a(t)``, so a DC offset ``c`` (a converter's
    or a sensor's bias) hands the envelope the carrier instead of the modulation. As
    ``scipy.signal.hilbert``, this function does not remove the mean itself.
    """
    return np.abs(scipy.signal.hilbert(as_signal(x), axis=-1))


def envelope_spectrum(x, fs: float, *, remove_mean: bool = True, window=None) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of the Hilbert envelope.

    Args:
        x: signal(s), shape (..., n), any unit, zero mean (band-passed: see :func:`envelope`); the
            amplitude comes out in the same unit.
        fs: sampling rate in Hz.
        remove_mean: subtract the envelope's mean first, so the (large) DC term does not
            leak into the low-frequency bins where the fault rates live.
        window: ``None`` for rectangular, or anything ``scipy.signal.get_window`` accepts
            (e.g. ``"hann"``), or an array of length n.

    Returns:
        freqs_hz: (n // 2 + 1,) bin frequencies in Hz.
        amplitude: (..., n // 2 + 1) amplitude, scaled by 2 / sum(window) (DC and Nyquist
            by 1 / sum(window)) so that an envelope ``c + m cos(2 pi f t)`` with f on a bin
            shows a line of height m at f: the modulation amplitude is read off directly.
    """
    check_positive(fs)
    env = envelope(x)
    n = env.shape[-1]
    if remove_mean:
        env = env - env.mean(axis=-1, keepdims=True)
    if window is None:
        taper = np.ones(n)
    elif isinstance(window, (str, tuple)):
        try:
            taper = scipy.signal.get_window(window, n, fftbins=True)
        except ValueError as error:
            raise BearingTwinError(f"window {window!r} is not a window scipy.signal.get_window knows: {error}") from None
    else:
        taper = np.asarray(window, dtype=np.float64)
        if taper.shape != (n,):
            raise BearingTwinError(f"window must have shape ({n},) to match the signal (got {taper.shape})")
    if not (np.all(np.isfinite(taper)) and taper.sum() > 0):  # the amplitude's scale divides by the sum
        raise BearingTwinError("window must hold finite weights with a positive sum: it scales the amplitude")
    amplitude = np.abs(np.fft.rfft(env * taper, axis=-1)) / taper.sum()
    last = None if n % 2 else -1  # an even length has a Nyquist bin, which is not doubled
    amplitude[..., 1:last] *= 2.0
    return np.fft.rfftfreq(n, d=1.0 / fs), amplitude


def peak_near(freqs_hz, amplitude, target_hz: float, tolerance_hz: float, *, interpolate: bool = True):
    """Largest spectral line within ``target_hz +- tolerance_hz``.

    Used to check that a defect frequency is present in an envelope spectrum. With
    ``interpolate`` the peak is refined by a parabola through the top bin and its two
    neighbours, which recovers a line that falls between bins to a fraction of a bin
    (the frequency resolution fs / n is often coarser than the defect-frequency shifts
    one wants to see). The parabola suits a Hann window's spectrum: there a 0.5 line a quarter of a
    bin off reads 0.489, 0.05 bins out, and midway between bins 0.467. A rectangular window's leaves
    the same lines 0.2 bins out at 0.452 and 0.345: compare lines read through the same window.

    Args:
        freqs_hz: (m,) evenly spaced bin frequencies in Hz.
        amplitude: (..., m) spectrum amplitudes.
        target_hz, tolerance_hz: search band in Hz.

    Returns:
        peak_freq_hz, peak_amp: arrays of shape ``amplitude.shape[:-1]`` (0-d for one spectrum).
    """
    freqs_hz = np.asarray(freqs_hz, dtype=np.float64)
    amplitude = np.asarray(amplitude, dtype=np.float64)
    if freqs_hz.ndim != 1 or freqs_hz.size < 3 or amplitude.shape[-1:] != freqs_hz.shape:
        raise BearingTwinError(
            f"amplitude's last axis must match freqs_hz (got amplitude {amplitude.shape}, freqs_hz {freqs_hz.shape})"
        )
    finite_number("target_hz", target_hz, "a frequency in Hz")
    non_negative_number("tolerance_hz", tolerance_hz)
    in_band = np.flatnonzero(np.abs(freqs_hz - target_hz) <= tolerance_hz)
    if in_band.size == 0:
        raise BearingTwinError(
            f"no frequency bin within {tolerance_hz} Hz of target_hz={target_hz} "
            f"(bins span {freqs_hz[0]}..{freqs_hz[-1]} Hz, spacing {freqs_hz[1] - freqs_hz[0]})"
        )
    top = in_band[np.argmax(amplitude[..., in_band], axis=-1)]
    peak_amp = np.take_along_axis(amplitude, top[..., None], axis=-1)[..., 0]
    peak_freq = freqs_hz[top]
    if not interpolate:
        return peak_freq, peak_amp
    inner = (top > 0) & (top < freqs_hz.size - 1)
    left = np.take_along_axis(amplitude, np.clip(top - 1, 0, None)[..., None], axis=-1)[..., 0]
    right = np.take_along_axis(amplitude, np.clip(top + 1, None, freqs_hz.size - 1)[..., None], axis=-1)[..., 0]
    curvature = left - 2.0 * peak_amp + right
    # Only a local maximum has its parabola's vertex within half a bin; a band-edge bin
    # beside a larger line outside the band would send the vertex anywhere.
    usable = inner & (curvature < 0) & (peak_amp >= left) & (peak_amp >= right)
    safe_curvature = np.where(usable, curvature, -1.0)
    offset = np.where(usable, 0.5 * (left - right) / safe_curvature, 0.0)
    spacing = freqs_hz[1] - freqs_hz[0]
    return peak_freq + offset * spacing, peak_amp - 0.25 * (left - right) * offset
