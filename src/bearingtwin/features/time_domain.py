"""The paper's nine time-domain features of the selected mode (section 4.2).

They summarise a window by its level (mean, variance, RMS), its impulsiveness (kurtosis,
crest, impulse and margin factors), which rises with the sharp transients of a localized
defect, and its waveform shape (peak-to-peak, shape factor).
"""

from __future__ import annotations

import numpy as np

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.inputs import as_signal

FEATURE_NAMES = (
    "mean",
    "variance",
    "peak_to_peak",
    "kurtosis",
    "rms",
    "crest_factor",
    "shape_factor",
    "impulse_factor",
    "margin_factor",
)


def time_domain_features(x: np.ndarray) -> np.ndarray:
    """The nine features of each signal along the last axis.

    With ``mu = mean(x)``, ``var = mean((x - mu)^2)`` (population variance, ddof = 0),
    ``rms = sqrt(mean(x^2))`` and ``peak = max|x|``, the features, in :data:`FEATURE_NAMES` order, are

    ========== ==================================================
    mean        ``mu``
    variance    ``var``
    peak-to-peak ``max(x) - min(x)``
    kurtosis    ``mean((x - mu)^4) / var^2``, Pearson's (3 for a Gaussian, 1.5 for a sine);
                ``scipy.stats.kurtosis(x, fisher=False)``
    RMS         ``rms``
    crest       ``peak / rms``
    shape       ``rms / mean|x|``
    impulse     ``peak / mean|x|``
    margin      ``peak / mean(sqrt|x|)^2``
    ========== ==================================================

    Args:
        x: (..., n) signals in any unit; n >= 2.

    Returns:
        (..., 9) float64. Level features carry x's unit (variance its square); the rest are ratios.

    Raises:
        BearingTwinError: a constant signal (kurtosis undefined) or non-finite values.
    """
    x = as_signal(x, "time_domain_features: x")
    mean = x.mean(axis=-1)
    centred = x - mean[..., None]
    variance = np.mean(centred**2, axis=-1)
    # Every sample equal: the rounded mean leaves a variance of 1e-33 or so, not 0, for most constants.
    constant = (np.ptp(x, axis=-1) == 0) | (variance <= np.finfo(np.float64).tiny)
    if np.any(constant):
        which = "the signal" if x.ndim == 1 else f"signal {tuple(int(i) for i in np.argwhere(constant)[0])}"
        raise BearingTwinError(f"time_domain_features: {which} is constant, so its kurtosis is undefined")
    magnitude = np.abs(x)
    peak = magnitude.max(axis=-1)
    rms = np.sqrt(np.mean(x**2, axis=-1))
    mean_magnitude = magnitude.mean(axis=-1)
    return np.stack(
        [
            mean,
            variance,
            x.max(axis=-1) - x.min(axis=-1),
            np.mean(centred**4, axis=-1) / variance**2,
            rms,
            peak / rms,
            rms / mean_magnitude,
            peak / mean_magnitude,
            peak / np.mean(np.sqrt(magnitude), axis=-1) ** 2,
        ],
        axis=-1,
    )
