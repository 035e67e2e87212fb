"""Signal processing in the style of scipy.signal: arrays in, arrays out, batched along the leading axis."""

from bearingtwin.signal.entropy import (
    bin_indices,
    envelope_entropy,
    mean_mode_mutual_information,
    mutual_information,
    permutation_entropy,
)
from bearingtwin.signal.envelope import cepstral_prewhiten, envelope, envelope_spectrum, peak_near
from bearingtwin.signal.vmd import vmd, vmd_batch

__all__ = [
    "bin_indices",
    "cepstral_prewhiten",
    "envelope",
    "envelope_entropy",
    "envelope_spectrum",
    "mean_mode_mutual_information",
    "mutual_information",
    "peak_near",
    "permutation_entropy",
    "vmd",
    "vmd_batch",
]
