"""WelchPSD: scipy.signal.welch's estimate, its transform built once."""

import numpy as np
import pytest
import scipy.signal as sps

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.welch import WelchPSD


@pytest.mark.parametrize("window, nperseg, n", [("hann", 480, 12000), ("blackmanharris", 6000, 12000),
                                                ("hann", 481, 5003), ("hann", 64, 64)])
def test_equals_scipy_welch_to_the_bit(window, nperseg, n):
    """Odd and even segments, a length that is no whole number of hops, a single segment; batched rows."""
    fs = 12000.0
    x = np.random.default_rng(nperseg).standard_normal((3, n))
    x[1] += 5.0  # a mean, which each segment's detrend removes
    taper = sps.get_window(window, nperseg)
    freqs, psd = WelchPSD(fs, taper)(x)
    expected_freqs, expected = sps.welch(x, fs=fs, window=taper, nperseg=nperseg)
    assert np.array_equal(freqs, expected_freqs)
    assert np.array_equal(psd, expected)
    _, row = WelchPSD(fs, taper)(x[2])
    assert np.array_equal(row, expected[2])


def test_a_line_has_its_power_and_white_noise_its_density():
    """Parseval through the estimate: a sine of amplitude A carries A^2 / 2 over its bins, and white
    noise of variance s^2 has a one-sided density 2 s^2 / fs."""
    fs, n = 10000.0, 100000
    t = np.arange(n) / fs
    welch = WelchPSD(fs, sps.get_window("hann", 1000))
    freqs, psd = welch(3.0 * np.sin(2 * np.pi * 1000.0 * t))
    assert np.sum(psd) * (freqs[1] - freqs[0]) == pytest.approx(4.5, rel=1e-3)
    assert freqs[np.argmax(psd)] == pytest.approx(1000.0)
    _, noise = welch(np.random.default_rng(0).normal(0.0, 2.0, n))
    assert np.median(noise[5:-5]) == pytest.approx(2 * 4.0 / fs, rel=0.1)


def test_a_signal_shorter_than_a_segment_is_refused():
    with pytest.raises(BearingTwinError, match="shorter than one Welch segment"):
        WelchPSD(1000.0, np.hanning(256))(np.zeros(100))
