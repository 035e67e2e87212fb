"""Signal processing in the style of scipy.signal: arrays in, arrays out, batched along the leading axis, but for
what reads one whole record at once (the kurtogram, the rate check, the speed profiles, order tracking), which takes
one 1-D record and refuses more in one line."""

from bearingtwin.signal.entropy import (
    bin_indices,
    envelope_entropy,
    mean_mode_mutual_information,
    mutual_information,
    permutation_entropy,
)
from bearingtwin.signal.envelope import cepstral_prewhiten, envelope, envelope_spectrum, peak_near
from bearingtwin.signal.kurtogram import Kurtogram, kurtogram, spectral_kurtosis
from bearingtwin.signal.sampling_rate import ShaftLineCheck, check_sampling_rate
from bearingtwin.signal.speed import SpeedProfile, order_track, speed_profile, steady_times, tachometer_profile
from bearingtwin.signal.vmd import vmd, vmd_batch
from bearingtwin.signal.welch import WelchPSD

__all__ = [
    "Kurtogram",
    "ShaftLineCheck",
    "SpeedProfile",
    "WelchPSD",
    "bin_indices",
    "cepstral_prewhiten",
    "check_sampling_rate",
    "envelope",
    "envelope_entropy",
    "envelope_spectrum",
    "kurtogram",
    "mean_mode_mutual_information",
    "mutual_information",
    "order_track",
    "peak_near",
    "permutation_entropy",
    "spectral_kurtosis",
    "speed_profile",
    "steady_times",
    "tachometer_profile",
    "vmd",
    "vmd_batch",
]
