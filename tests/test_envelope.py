"""Envelope spectra recover amplitude modulation: the mechanism that reveals bearing defect rates."""

import numpy as np
import pytest

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal import envelope, envelope_spectrum, peak_near

FS = 12_000.0
N = 12_000  # 1 s: bins are 1 Hz apart


def am_tone(mod_hz, depth, carrier_hz=3_000.0, n=N, fs=FS, offset=1.0):
    t = np.arange(n) / fs
    return (offset + depth * np.cos(2 * np.pi * mod_hz * t)) * np.cos(2 * np.pi * carrier_hz * t)


def test_envelope_of_am_tone_is_its_modulation():
    x = am_tone(107.0, 0.4)
    t = np.arange(N) / FS
    np.testing.assert_allclose(envelope(x), 1.0 + 0.4 * np.cos(2 * np.pi * 107.0 * t), atol=1e-9)


@pytest.mark.parametrize("window", [None, "hann"])
def test_envelope_spectrum_peaks_at_modulation_frequency_with_its_amplitude(window):
    freqs, amp = envelope_spectrum(am_tone(107.0, 0.4), FS, window=window)
    assert freqs.shape == amp.shape == (N // 2 + 1,)
    assert freqs[np.argmax(amp)] == pytest.approx(107.0)
    assert amp.max() == pytest.approx(0.4, rel=1e-6)
    assert amp[0] < 1e-9  # mean removed


def test_envelope_spectrum_is_batched_over_leading_axes():
    depths = np.array([[0.1, 0.2, 0.3], [0.5, 0.6, 0.7]])
    mods = np.array([[50.0, 80.0, 107.0], [160.0, 233.0, 300.0]])
    x = np.stack([np.stack([am_tone(f, d) for f, d in zip(fr, dr)]) for fr, dr in zip(mods, depths)])
    freqs, amp = envelope_spectrum(x, FS)
    assert amp.shape == (2, 3, N // 2 + 1)
    np.testing.assert_allclose(freqs[np.argmax(amp, axis=-1)], mods)
    np.testing.assert_allclose(amp.max(axis=-1), depths, rtol=1e-6)
    _, single = envelope_spectrum(x[1, 2], FS)
    np.testing.assert_allclose(amp[1, 2], single)


def test_odd_length_keeps_every_bin_doubled():
    n = 1001
    t = np.arange(n) / 1001.0
    x = (1 + 0.3 * np.cos(2 * np.pi * 50 * t)) * np.cos(2 * np.pi * 300 * t)
    freqs, amp = envelope_spectrum(x, 1001.0)
    assert freqs.size == n // 2 + 1
    assert amp[50] == pytest.approx(0.3, rel=1e-6)


def test_peak_near_finds_the_line_inside_the_band_only():
    t = np.arange(N) / FS
    two_rates = (2.0 + 0.4 * np.cos(2 * np.pi * 107.0 * t) + 0.9 * np.cos(2 * np.pi * 160.0 * t)) * np.cos(
        2 * np.pi * 3_000.0 * t
    )
    freqs, amp = envelope_spectrum(two_rates, FS)
    f, a = peak_near(freqs, amp, 105.0, 5.0, interpolate=False)
    assert f == pytest.approx(107.0) and a == pytest.approx(0.4, rel=1e-6)
    f, a = peak_near(freqs, amp, 150.0, 15.0, interpolate=False)
    assert f == pytest.approx(160.0) and a == pytest.approx(0.9, rel=1e-6)


def test_parabolic_interpolation_locates_an_off_bin_line_within_a_fraction_of_a_bin():
    true_hz = 107.3
    freqs, amp = envelope_spectrum(am_tone(true_hz, 0.4), FS, window="hann")
    f_bin, a_bin = peak_near(freqs, amp, 105.0, 5.0, interpolate=False)
    f_int, a_int = peak_near(freqs, amp, 105.0, 5.0)
    assert abs(f_bin - true_hz) == pytest.approx(0.3, abs=1e-9)
    assert abs(f_int - true_hz) < 0.1
    assert abs(a_int - 0.4) < abs(a_bin - 0.4)  # scalloping loss partly recovered


def test_peak_near_is_batched():
    x = np.stack([am_tone(100.0, 0.2), am_tone(110.0, 0.5)])
    freqs, amp = envelope_spectrum(x, FS)
    f, a = peak_near(freqs, amp, 105.0, 8.0)
    np.testing.assert_allclose(f, [100.0, 110.0], atol=1e-6)
    np.testing.assert_allclose(a, [0.2, 0.5], rtol=1e-6)


def test_bad_inputs_name_the_field():
    with pytest.raises(BearingTwinError, match="fs"):
        envelope_spectrum(np.ones(100), -1.0)
    with pytest.raises(BearingTwinError, match="x contains NaN"):
        envelope(np.array([1.0, np.nan, 2.0]))
    with pytest.raises(BearingTwinError, match="window"):
        envelope_spectrum(np.ones(100), 1.0, window=np.ones(50))
    with pytest.raises(BearingTwinError, match="target_hz"):
        peak_near(np.arange(10.0), np.ones(10), 50.0, 1.0)


def test_peak_near_stays_within_half_a_bin_at_a_band_edge():
    # The band's largest bin is its edge, next to a larger line just outside it:
    # interpolation must not follow the outside line (it once returned -642 Hz).
    freqs = np.arange(0.0, 100.0, 1.0)
    amplitude = np.full(freqs.size, 1e-3)
    amplitude[50] = 2.99e-3  # a slightly larger line just outside the band
    amplitude[49] = 2e-3  # the band's top bin, at its upper edge: nearly flat curvature
    peak_freq, peak_amp = peak_near(freqs, amplitude, target_hz=46.0, tolerance_hz=3.0)
    assert 43.0 <= float(peak_freq) <= 49.0
    assert float(peak_amp) == pytest.approx(2e-3)


@pytest.mark.parametrize("window", [np.zeros(256), np.full(256, np.nan), np.r_[np.ones(128), -np.ones(128)]])
def test_a_window_that_weighs_nothing_is_refused(window):
    """The amplitude is scaled by the window's sum: zeros, a NaN or a zero-sum taper had given NaN or inf lines."""
    x = np.random.default_rng(0).standard_normal(256)
    with pytest.raises(BearingTwinError, match="window must hold finite weights with a positive sum"):
        envelope_spectrum(x, 12000.0, window=window)
