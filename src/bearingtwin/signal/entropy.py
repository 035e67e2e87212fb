"""Entropies that score a decomposition: permutation entropy, envelope entropy, mutual information.

The paper's SABO fitness (section 3.3) is PE + MIE: permutation entropy rewards a regular
(fault-periodic) component, and the mean mutual information between modes penalises
redundant, mixed modes. The alternative "minEn" fitness and the IMF selection use the
envelope entropy. Every function works along the last axis and accepts leading batch axes,
so a whole population of decompositions is scored in one call.
"""

from __future__ import annotations

import math

import numpy as np

from bearingtwin.checks import is_finite_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.envelope import envelope
from bearingtwin.signal.inputs import as_signal

BIN_RULES = ("sturges", "sqrt", "rice")


def _shannon(p: np.ndarray, axis: int = -1) -> np.ndarray:
    """-sum p log p in nats, with 0 log 0 = 0."""
    return -np.sum(np.where(p > 0, p * np.log(np.where(p > 0, p, 1.0)), 0.0), axis=axis)


def _counts_per_row(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Occurrence counts of the distinct values in each row of an integer array (rows, m).

    Sorting and counting runs keeps memory at O(rows * m) whatever the code range, so
    high embedding orders (8! patterns) do not need a dense histogram per row.
    """
    rows, m = codes.shape
    codes = np.sort(codes, axis=1)
    starts = np.ones((rows, m), dtype=bool)
    starts[:, 1:] = codes[:, 1:] != codes[:, :-1]
    run_of_sample = np.cumsum(starts.ravel()) - 1
    counts = np.bincount(run_of_sample)
    row_of_run = np.repeat(np.arange(rows), m)[starts.ravel()]
    return counts, row_of_run


def permutation_entropy(x, order: int = 3, delay: int = 1, normalize: bool = True) -> np.ndarray:
    """Permutation entropy (Bandt & Pompe, Phys. Rev. Lett. 88, 174102, 2002).

    The signal is embedded in vectors of ``order`` samples spaced ``delay`` samples apart;
    each vector is replaced by its ordinal pattern (the argsort, ties broken by position) and
    the Shannon entropy of the pattern distribution is taken. Defaults ``order=3, delay=1``
    are the common choice for VMD-mode scoring (bearing studies use orders 3..7 with unit
    delay); the signal needs many more than ``order!`` vectors for the estimate to mean much.

    Args:
        x: (..., n) signal(s).
        order: embedding dimension, 2..10.
        delay: embedding delay in samples.
        normalize: divide by log2(order!) so the result lies in [0, 1]
            (0: one pattern only, e.g. a monotone signal; 1: all patterns equally likely).

    Returns:
        (...) entropy in bits (or normalized), as antropy.perm_entropy.
    """
    x = as_signal(x)
    if int(order) != order or not 2 <= order <= 10:
        raise BearingTwinError(f"order must be an integer in 2..10 (got {order})")
    if int(delay) != delay or delay < 1:
        raise BearingTwinError(f"delay must be a positive integer number of samples (got {delay})")
    order, delay = int(order), int(delay)
    n_vectors = x.shape[-1] - (order - 1) * delay
    if n_vectors < 1:
        raise BearingTwinError(
            f"x has {x.shape[-1]} samples, too few for order={order} and delay={delay} "
            f"(needs at least {(order - 1) * delay + 1})"
        )
    batch_shape = x.shape[:-1]
    rows = x.reshape(-1, x.shape[-1])
    embedded = np.stack([rows[:, i * delay : i * delay + n_vectors] for i in range(order)], axis=-1)
    patterns = np.argsort(embedded, axis=-1, kind="stable")
    codes = patterns @ (order ** np.arange(order, dtype=np.int64))
    counts, row_of_run = _counts_per_row(codes)
    p = counts / n_vectors
    entropy_bits = np.bincount(row_of_run, weights=-p * np.log2(p), minlength=rows.shape[0])
    if normalize:
        entropy_bits = np.clip(entropy_bits / math.log2(math.factorial(order)), 0.0, 1.0)
    return entropy_bits.reshape(batch_shape)


def envelope_entropy(x) -> np.ndarray:
    """Shannon entropy (nats) of the normalized Hilbert envelope, p_i = a_i / sum(a), along the last axis.

    Definition from Tang & Wang, "Parameter optimized variational mode decomposition method
    with application in incipient fault diagnosis of rolling bearing", Journal of Xi'an
    Jiaotong University 49(5), 2015, used by the SABO/VMD bearing papers: an impulsive
    (fault-carrying) component concentrates its envelope in few samples, so its entropy is
    low; a noise-like component spreads it and approaches log(n). A zero signal has no
    envelope to normalize and gets NaN.
    """
    a = envelope(x)
    total = a.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        entropy = _shannon(a / total)
    return np.where(total[..., 0] > 0, entropy, np.nan)


def _n_bins(bins, n: int) -> int:
    if isinstance(bins, str):
        if bins == "sturges":
            return int(math.ceil(math.log2(n))) + 1
        if bins == "sqrt":
            return int(math.ceil(math.sqrt(n)))
        if bins == "rice":
            return int(math.ceil(2.0 * n ** (1.0 / 3.0)))
        raise BearingTwinError(f"bins must be a positive integer or one of {BIN_RULES} (got {bins!r})")
    if not is_finite_number(bins) or int(bins) != bins or bins < 1:
        raise BearingTwinError(f"bins must be a positive integer or one of {BIN_RULES} (got {bins!r})")
    return int(bins)


def bin_indices(x, n_bins: int) -> np.ndarray:
    """Equal-width bin index (0..n_bins-1) of every sample, bins spanning each row's own min..max.

    The rightmost edge is included in the last bin, as in ``numpy.histogram``; a constant
    row falls entirely into bin 0.
    """
    x = as_signal(x)
    n_bins = whole_number("n_bins", n_bins)  # fewer than one bin would index every sample -1
    low = x.min(axis=-1, keepdims=True)
    span = x.max(axis=-1, keepdims=True) - low
    scaled = np.divide(x - low, span, out=np.zeros_like(x), where=span > 0)
    return np.minimum((scaled * n_bins).astype(np.int64), n_bins - 1)


def _mi_from_indices(ia: np.ndarray, ib: np.ndarray, n_bins: int) -> np.ndarray:
    """Plug-in MI (nats) of pre-binned rows (..., n) -> (...)."""
    batch_shape = ia.shape[:-1]
    n = ia.shape[-1]
    if ia.size == 0:  # an empty batch: no rows to count, an empty answer
        return np.zeros(batch_shape)
    ia = ia.reshape(-1, n)
    ib = ib.reshape(-1, n)
    rows = ia.shape[0]
    cell = (np.arange(rows)[:, None] * n_bins + ia) * n_bins + ib
    joint = np.bincount(cell.ravel(), minlength=rows * n_bins * n_bins).reshape(rows, n_bins, n_bins) / n
    pa = joint.sum(axis=2)
    pb = joint.sum(axis=1)
    h = _shannon(pa) + _shannon(pb) - _shannon(joint.reshape(rows, -1))
    return np.maximum(h, 0.0).reshape(batch_shape)


def mutual_information(a, b, bins="sturges") -> np.ndarray:
    """Mutual information I(a; b) in nats, plug-in (histogram) estimator.

    Each signal is cut into ``bins`` equal-width bins between its own minimum and maximum
    (see :func:`bin_indices`), the joint and marginal frequencies are counted, and
    I = H(a) + H(b) - H(a, b) is evaluated on those frequencies (identical to
    ``sklearn.metrics.mutual_info_score`` on the bin labels). The plug-in estimate is biased
    upwards by about (bins - 1)^2 / (2 n) nats for independent signals, so keep bins well
    below sqrt(n).

    Args:
        a, b: (..., n) signals of equal shape.
        bins: number of bins, or a rule on the length n: ``"sturges"`` (ceil(log2 n) + 1,
            the default: 12 bins for 2048 samples), ``"sqrt"`` (ceil(sqrt n)),
            ``"rice"`` (ceil(2 n^(1/3))).

    Returns:
        (...) mutual information in nats; I(a; a) is the entropy of a's binned distribution.
    """
    a = as_signal(a, "a")
    b = as_signal(b, "b")
    if a.shape != b.shape:
        raise BearingTwinError(f"a and b must have the same shape (got {a.shape} and {b.shape})")
    n_bins = _n_bins(bins, a.shape[-1])
    return _mi_from_indices(bin_indices(a, n_bins), bin_indices(b, n_bins), n_bins)


def mean_mode_mutual_information(modes, bins="sturges") -> np.ndarray:
    """Mean mutual information (nats) over all pairs of modes: the paper's "MIE" fitness term.

    Args:
        modes: (..., k, n) decomposition(s) with k >= 2 modes, e.g. the output of ``vmd``.
        bins: as in :func:`mutual_information`; each mode is binned once on its own range.

    Returns:
        (...) mean of I(mode_i; mode_j) over the k (k - 1) / 2 pairs i < j.
    """
    modes = as_signal(modes, "modes")
    if modes.ndim < 2 or modes.shape[-2] < 2:
        raise BearingTwinError(f"modes must have shape (..., k, n) with k >= 2 (got {modes.shape})")
    n_bins = _n_bins(bins, modes.shape[-1])
    binned = bin_indices(modes, n_bins)
    first, second = np.triu_indices(modes.shape[-2], k=1)
    return _mi_from_indices(binned[..., first, :], binned[..., second, :], n_bins).mean(axis=-1)
