"""The signal functions refuse bad input with one BearingTwinError line that starts with the argument at fault,
as envelope() and vmd() always did, and give valid input exactly what they gave before."""

import numpy as np
import pytest
import scipy.signal as sps

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.envelope import envelope_spectrum
from bearingtwin.signal.entropy import bin_indices, mutual_information
from bearingtwin.signal.kurtogram import kurtogram, spectral_kurtosis
from bearingtwin.signal.vmd import vmd
from bearingtwin.signal.sampling_rate import check_channels, check_sampling_rate
from bearingtwin.signal.speed import SpeedProfile, order_track, tachometer_profile
from bearingtwin.signal.welch import WelchPSD

FS = 12000.0
SIGNALS = np.random.default_rng(0).standard_normal((3, 4096))
WINDOW = sps.get_window("hann", 64)


def _with_nan(x, index):
    x = np.array(x)
    x[index] = np.nan
    return x


BAD_INPUT = {
    # a NaN in one row of a batch had left that row's SK all zeros
    "spectral_kurtosis NaN in a row": (lambda: spectral_kurtosis(_with_nan(SIGNALS, (1, 100)), FS, 64), "x"),
    "spectral_kurtosis fs 0": (lambda: spectral_kurtosis(SIGNALS, 0.0, 64), "fs_hz"),
    "spectral_kurtosis fs negative": (lambda: spectral_kurtosis(SIGNALS, -1.0, 64), "fs_hz"),
    "spectral_kurtosis fs NaN": (lambda: spectral_kurtosis(SIGNALS, np.nan, 64), "fs_hz"),
    "spectral_kurtosis complex": (lambda: spectral_kurtosis(SIGNALS + 1j, FS, 64), "x"),
    "spectral_kurtosis bool": (lambda: spectral_kurtosis(SIGNALS > 0, FS, 64), "x"),
    "spectral_kurtosis 0-d": (lambda: spectral_kurtosis(np.float64(1.0), FS, 64), "x"),
    "kurtogram fs 0": (lambda: kurtogram(SIGNALS[0], 0.0), "fs_hz"),
    "kurtogram fs inf": (lambda: kurtogram(SIGNALS[0], np.inf), "fs_hz"),
    "kurtogram complex": (lambda: kurtogram(SIGNALS[0] + 1j, FS), "x"),
    "kurtogram bool": (lambda: kurtogram(SIGNALS[0] > 0, FS), "x"),
    "kurtogram NaN": (lambda: kurtogram(_with_nan(SIGNALS[0], 7), FS), "x"),
    "kurtogram batch": (lambda: kurtogram(SIGNALS, FS), "x"),
    # window lengths: a float had been a TypeError from inside, 16.9 cut to 16, () "shorter than every length []"
    "kurtogram nperseg float": (lambda: kurtogram(SIGNALS[0], FS, nperseg=1e9), "nperseg"),
    "kurtogram nperseg fraction": (lambda: kurtogram(SIGNALS[0], FS, nperseg=(16.9,)), "nperseg"),
    "kurtogram nperseg empty": (lambda: kurtogram(SIGNALS[0], FS, nperseg=()), "nperseg"),
    "kurtogram nperseg bool": (lambda: kurtogram(SIGNALS[0], FS, nperseg=(True,)), "nperseg"),
    "vmd alpha per mode": (lambda: vmd(SIGNALS[0, :256], 3, [1000.0, 2000.0, 3000.0]), "alpha"),  # a broadcast error
    "WelchPSD fs 0": (lambda: WelchPSD(0.0, WINDOW), "fs_hz"),
    "WelchPSD NaN window": (lambda: WelchPSD(FS, _with_nan(WINDOW, 3)), "window"),
    "WelchPSD complex": (lambda: WelchPSD(FS, WINDOW)(SIGNALS + 1j), "x"),
    "WelchPSD bool": (lambda: WelchPSD(FS, WINDOW)(SIGNALS > 0), "x"),
    "WelchPSD NaN": (lambda: WelchPSD(FS, WINDOW)(_with_nan(SIGNALS, (2, 5))), "x"),
    "WelchPSD 0-d": (lambda: WelchPSD(FS, WINDOW)(np.float64(1.0)), "x"),
    "bin_indices 0 bins": (lambda: bin_indices(SIGNALS[0], 0), "n_bins"),
    "bin_indices negative bins": (lambda: bin_indices(SIGNALS[0], -3), "n_bins"),
    "envelope_spectrum fs text": (lambda: envelope_spectrum(SIGNALS[0], "12000"), "fs"),
    "envelope_spectrum fs None": (lambda: envelope_spectrum(SIGNALS[0], None), "fs"),
    "envelope_spectrum fs bool": (lambda: envelope_spectrum(SIGNALS[0], True), "fs"),
    "WelchPSD zero window": (lambda: WelchPSD(FS, np.zeros(64)), "window"),  # every PSD had been NaN
    # the rate check had raised ZeroDivisionError, TypeError and ValueError from inside, and read True as 1 Hz
    "check_sampling_rate empty": (lambda: check_sampling_rate(np.zeros(0), FS, 1797.0), "signal"),
    "check_sampling_rate fs text": (lambda: check_sampling_rate(SIGNALS[0], "12000", 1797.0), "fs"),
    "check_sampling_rate fs bool": (lambda: check_sampling_rate(SIGNALS[0], True, 1797.0), "fs"),
    "check_sampling_rate rpm None": (lambda: check_sampling_rate(SIGNALS[0], FS, None), "rpm"),
    "check_sampling_rate complex": (lambda: check_sampling_rate(SIGNALS[0] + 1j, FS, 1797.0), "signal"),
    "check_sampling_rate max_fraction 1": (lambda: check_sampling_rate(SIGNALS[0], FS, 1797.0, max_fraction=1),
                                           "max_fraction"),
    # A file's channels: how many samples each is read over follows the rate and speed, refused as the check does.
    "check_channels rpm negative": (lambda: check_channels({"a": SIGNALS[0]}, FS, -5.0), "rpm"),
    "check_channels rpm None": (lambda: check_channels({"a": SIGNALS[0]}, FS, None), "rpm"),
    "check_channels tolerance 0": (lambda: check_channels({"a": SIGNALS[0]}, FS, 1797.0, tolerance=0.0), "tolerance"),
    "check_sampling_rate tolerance negative": (lambda: check_sampling_rate(SIGNALS[0], FS, 1797.0, tolerance=-1),
                                               "tolerance"),
    "check_sampling_rate batch": (lambda: check_sampling_rate(SIGNALS, FS, 1797.0), "signal"),
    # Order tracking had raised scipy's "invalid shape for coordinate array" on a batch; a tachometer's error had
    # named its pulses "signal".
    "order_track batch": (lambda: order_track(SIGNALS, FS, SpeedProfile(np.array([0.1, 0.2]), np.array([1797.0, 1800.0]),
                                                                        0.2, 1797.0, "signal")), "signal"),
    "tachometer_profile batch": (lambda: tachometer_profile(SIGNALS, FS, 1797.0), "pulses"),
    "tachometer_profile NaN": (lambda: tachometer_profile(_with_nan(SIGNALS[0], 9), FS, 1797.0), "pulses"),
}


@pytest.mark.parametrize("call, argument", BAD_INPUT.values(), ids=BAD_INPUT.keys())
def test_bad_input_is_refused_naming_the_argument(call, argument):
    with pytest.raises(BearingTwinError) as refused:
        call()
    message = str(refused.value)
    assert message.startswith(f"{argument} ") and "\n" not in message


def test_valid_input_is_unchanged():
    """Batched rows equal single calls and the STFT's own numbers, to the bit; a rate given as a numpy
    scalar or a 0-d array (read from an .npz) still counts as the number it holds."""
    freqs, sk = spectral_kurtosis(SIGNALS, FS, 64)
    _, _, coefficients = sps.stft(SIGNALS, fs=FS, window="hann", nperseg=64, noverlap=48, boundary=None,
                                  padded=False, axis=-1)
    power = np.abs(coefficients) ** 2
    assert np.array_equal(sk, (power**2).mean(axis=-1) / power.mean(axis=-1) ** 2 - 2.0)
    for row, signal in zip(sk, SIGNALS):
        row_freqs, single = spectral_kurtosis(signal, FS, 64)
        assert np.array_equal(row_freqs, freqs) and np.array_equal(single, row)
    for rate in (np.float64(FS), np.array(FS), 12000):
        assert all(np.array_equal(a, b) for a, b in zip(spectral_kurtosis(SIGNALS, rate, 64), (freqs, sk)))
        assert all(np.array_equal(a, b) for a, b in zip(envelope_spectrum(SIGNALS, rate), envelope_spectrum(SIGNALS, FS)))
    assert np.array_equal(bin_indices(SIGNALS, 5), bin_indices(SIGNALS, 5.0))
    # An empty batch is an empty answer, as every other batched function gives (it had been a reshape error).
    assert mutual_information(np.zeros((0, 10)), np.zeros((0, 10))).shape == (0,)


def test_the_kurtograms_band_lies_below_its_upper_limit_and_one_window_length_is_taken():
    """The most impulsive bin of white noise may be centred above the band's upper limit (0.49 fs): its band had
    read (5929.7, 5880.0) Hz, low above high. Now the bin's width below the limit. A window length given as a
    number is one level, as spectral_kurtosis takes it (it had been a TypeError)."""
    noise = np.random.default_rng(0).standard_normal(4096)
    result = kurtogram(noise, FS)
    low, high = result.band_hz
    assert result.best_nperseg == 256 and low < high <= 0.49 * FS
    assert high - low == pytest.approx(FS / result.best_nperseg)
    assert kurtogram(noise, FS, nperseg=16).band_hz == kurtogram(noise, FS, nperseg=(16,)).band_hz


def test_the_rate_checks_in_between_search_may_be_exact():
    """slip=0 seeks the in-between series at observed / k exactly (a value the check had taken before its inputs were
    checked, and must still)."""
    t = np.arange(24000) / FS
    record = sum(np.sin(2 * np.pi * n * 1797.0 / 60.0 * t) for n in range(1, 6))
    assert check_sampling_rate(record, FS, 1797.0, slip=0.0).verdict == "consistent"
