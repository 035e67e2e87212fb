"""Spectral kurtosis and the kurtogram against the values Antoni (MSSP 2006) derives: 0 for stationary
Gaussian noise, -1 for a stationary tone, large at the resonance an impact train rings."""

import numpy as np
import pytest
import scipy.signal

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal import envelope_spectrum
from bearingtwin.signal.kurtogram import kurtogram, spectral_kurtosis

FS = 12000.0


def test_gaussian_noise_has_zero_and_a_tone_minus_one_spectral_kurtosis():
    rng = np.random.default_rng(0)
    noise = rng.standard_normal(int(20 * FS))
    freqs, sk = spectral_kurtosis(noise, FS, 64)
    inner = (freqs > 200) & (freqs < 5800)
    assert abs(np.mean(sk[inner])) < 0.02 and np.max(np.abs(sk[inner])) < 0.1
    t = np.arange(int(20 * FS)) / FS
    tone = np.sin(2 * np.pi * 1500.0 * t) + 1e-3 * noise
    freqs, sk = spectral_kurtosis(tone, FS, 64)
    assert sk[np.argmin(np.abs(freqs - 1500.0))] == pytest.approx(-1.0, abs=0.02)


def test_the_kurtogram_finds_the_band_an_impact_train_rings():
    rng = np.random.default_rng(1)
    t = np.arange(int(5 * FS)) / FS
    ring = np.exp(-900 * t[:300]) * np.sin(2 * np.pi * 3500.0 * t[:300])
    impacts = np.zeros(t.size)
    impacts[(np.arange(0, 5, 1 / 107.0) * FS).astype(int)] = 1.0
    tone = 2.0 * np.sin(2 * np.pi * 600.0 * t)  # a strong stationary line elsewhere: not impulsive
    signal = np.convolve(impacts, ring)[: t.size] + tone + 0.1 * rng.standard_normal(t.size)
    result = kurtogram(signal, FS, min_hz=200.0)
    low, high = result.band_hz
    # SK is largest where the impacts dominate most, on the resonance or its skirt, never at the tone;
    # demodulating that band shows the impact rate.
    assert 2500.0 < (low + high) / 2 < 5000.0 and high - low <= 1500.0 and low > 600.0
    assert result.best_sk > 1.0
    sos = scipy.signal.butter(4, result.band_hz, btype="bandpass", fs=FS, output="sos")
    freqs, amplitude = envelope_spectrum(scipy.signal.sosfiltfilt(sos, signal), FS)
    low_band = (freqs > 50) & (freqs < 300)
    assert freqs[low_band][np.argmax(amplitude[low_band])] == pytest.approx(107.0, abs=0.5)
    at_tone = [sk[np.argmin(np.abs(f - 600.0))] for f, sk in zip(result.freqs_hz, result.sk)]
    assert max(at_tone) < 0.0  # a stationary line is less impulsive than Gaussian noise
    with pytest.raises(BearingTwinError, match="shorter than every window length"):
        kurtogram(signal[:10], FS)


@pytest.mark.parametrize("level", [0.0, 3.5])
def test_a_constant_signal_names_no_band(level):
    """Every band's kurtosis is 0 / 0 on a dead channel: a band had been named by chance."""
    with pytest.raises(BearingTwinError, match=r"^x is constant \(every sample 3.5\)" if level else r"^x is constant"):
        kurtogram(np.full(1000, level), 12000.0)
