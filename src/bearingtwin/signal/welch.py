"""Welch's power spectral density, set up once for many signals of one sampling rate and window.

``scipy.signal.welch`` builds a ``scipy.signal.ShortTimeFFT`` on every call and derives its PSD
scaling there, summing the window's squares element by element in Python: for a 0.1 s segment
at 48 kHz that set-up costs more than the transform itself. The twin's calibration profiles
hundreds of twin signals against one measurement, so :class:`WelchPSD` builds the transform
once and then does what ``scipy.signal.welch`` does with it (``scipy.signal.csd`` with the
defaults: half-overlapping segments, the mean removed from each, one-sided density, mean over
segments): to the bit where ``scipy.signal.welch`` itself runs on ``ShortTimeFFT`` (the locked
SciPy does; tests/test_welch.py checks it).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import ShortTimeFFT

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_signal, check_positive


class WelchPSD:
    """``scipy.signal.welch(x, fs, window=window, nperseg=len(window))`` with its transform built once.

    Args:
        fs_hz: sampling rate in Hz.
        window: the segment window, an array of ``nperseg`` samples (e.g. ``get_window("hann", n)``).

    Calling it with a signal (..., n), n at least ``nperseg``, returns ``(freqs_hz, psd)``: the
    bin frequencies (nperseg // 2 + 1,) in Hz and the one-sided PSD (..., nperseg // 2 + 1) in
    unit^2 / Hz, equal to ``scipy.signal.welch``'s.
    """

    def __init__(self, fs_hz: float, window):
        check_positive(fs_hz, "fs_hz")
        # A NaN in the window would turn every PSD into NaN, so it is checked as a signal is.
        window = as_signal(window, "window")
        if window.ndim != 1:
            raise BearingTwinError(f"window must be 1-D, one weight per sample of a segment (got shape {window.shape})")
        if not np.any(window):  # the PSD's scale divides by the window's power: every value would be NaN
            raise BearingTwinError("window is all zeros: it weighs no sample of a segment")
        self.nperseg = window.size
        self.noverlap = self.nperseg // 2
        self.transform = ShortTimeFFT(window, self.nperseg - self.noverlap, fs_hz, fft_mode="onesided",
                                      mfft=self.nperseg, scale_to="psd", phase_shift=None)
        self.freqs_hz = self.transform.f

    def __call__(self, x) -> tuple[np.ndarray, np.ndarray]:
        x = as_signal(x)
        n = x.shape[-1]
        if n < self.nperseg:
            raise BearingTwinError(f"a signal of {n} samples is shorter than one Welch segment ({self.nperseg})")
        # As scipy.signal.csd(x, x) computes it: the same segments, every one-sided bin but DC (and
        # Nyquist, for an even length) doubled.
        power = self.transform.spectrogram(x, x, detr="constant", p0=0, p1=(n - self.noverlap) // self.transform.hop,
                                           k_offset=self.nperseg // 2)
        power[..., 1:-1 if self.nperseg % 2 == 0 else None, :] *= 2
        return self.freqs_hz, power.mean(axis=-1).real
