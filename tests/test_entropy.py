"""Entropies behave as their definitions demand and agree with antropy / scikit-learn."""

import math

import antropy
import numpy as np
import pytest
from sklearn.metrics import mutual_info_score

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal import (
    bin_indices,
    envelope_entropy,
    mean_mode_mutual_information,
    mutual_information,
    permutation_entropy,
)

RNG = np.random.default_rng(20250101)


def structured_signals(n=1500):
    t = np.arange(n)
    return {
        "noise": RNG.standard_normal(n),
        "sine": np.sin(2 * np.pi * t / 37.3),
        "chirp_plus_noise": np.sin(2 * np.pi * t**2 / 9000.0) + 0.3 * RNG.standard_normal(n),
        "ties": np.round(RNG.standard_normal(n)),  # many equal values: tie-breaking by position
        "random_walk": np.cumsum(RNG.standard_normal(n)),
    }


@pytest.mark.parametrize("order,delay", [(3, 1), (4, 2), (5, 1), (6, 3)])
@pytest.mark.parametrize("normalize", [True, False])
def test_permutation_entropy_matches_antropy(order, delay, normalize):
    signals = structured_signals()
    ours = permutation_entropy(np.stack(list(signals.values())), order=order, delay=delay, normalize=normalize)
    reference = [antropy.perm_entropy(s, order=order, delay=delay, normalize=normalize) for s in signals.values()]
    np.testing.assert_allclose(ours, reference, rtol=1e-12, atol=1e-12)


def test_permutation_entropy_of_monotone_signal_is_zero_and_of_white_noise_near_one():
    assert permutation_entropy(np.linspace(-3.0, 5.0, 500), order=5) == 0.0
    assert permutation_entropy(np.exp(-np.arange(400) / 50.0), order=4) == 0.0
    noise = RNG.standard_normal((4, 20_000))
    pe = permutation_entropy(noise, order=4)
    assert pe.shape == (4,)
    assert np.all(pe > 0.995) and np.all(pe <= 1.0)


def test_permutation_entropy_keeps_leading_batch_axes():
    x = RNG.standard_normal((2, 3, 300))
    pe = permutation_entropy(x, order=3)
    assert pe.shape == (2, 3)
    assert pe[1, 2] == permutation_entropy(x[1, 2], order=3)


def test_envelope_entropy_is_low_for_impulses_and_near_log_n_for_noise():
    n, fs = 4096, 12_000.0
    t = np.arange(n) / fs
    impacts = np.zeros(n)
    impacts[:: int(fs / 105.0)] = 1.0  # a 105 Hz impact train ringing a 3 kHz resonance
    ring = np.exp(-t[:200] * 800.0) * np.sin(2 * np.pi * 3000.0 * t[:200])
    impulsive = np.convolve(impacts, ring)[:n]
    noise = RNG.standard_normal(n)
    e_imp, e_noise = envelope_entropy(np.stack([impulsive, noise]))
    assert e_imp < e_noise - 0.5
    assert math.log(n) - 0.5 < e_noise < math.log(n)  # Rayleigh envelope: ~0.2 nats below uniform


def test_envelope_entropy_of_constant_envelope_is_log_n_and_of_zero_is_nan():
    n = 1000
    tone = np.cos(2 * np.pi * 50 * np.arange(n) / n)  # whole periods: flat envelope
    assert envelope_entropy(tone) == pytest.approx(math.log(n), abs=1e-9)
    assert np.isnan(envelope_entropy(np.zeros(n)))


@pytest.mark.parametrize("bins", [8, "sturges", "sqrt", "rice"])
def test_mutual_information_matches_sklearn_on_the_same_binning(bins):
    n = 3000
    a = RNG.standard_normal((3, n))
    b = np.stack([a[0] ** 2 + 0.2 * RNG.standard_normal(n), RNG.standard_normal(n), np.sin(3 * a[2])])
    ours = mutual_information(a, b, bins=bins)
    n_bins = {"sturges": 13, "sqrt": 55, "rice": 29}.get(bins, bins)  # rules for n = 3000
    la, lb = bin_indices(a, n_bins), bin_indices(b, n_bins)
    reference = [mutual_info_score(la[i], lb[i]) for i in range(3)]
    np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-12)


def test_mutual_information_of_independent_signals_is_near_zero_and_of_identical_is_entropy():
    n, bins = 20_000, 10
    a, b = RNG.standard_normal((2, n))
    mi_independent = mutual_information(a, b, bins=bins)
    assert mi_independent < 2 * (bins - 1) ** 2 / (2 * n)  # plug-in bias bound
    labels = bin_indices(a, bins)
    p = np.bincount(labels, minlength=bins) / n
    h = -np.sum(p[p > 0] * np.log(p[p > 0]))
    assert mutual_information(a, a, bins=bins) == pytest.approx(h, rel=1e-12)
    assert mutual_information(a, 3.0 * a - 1.0, bins=bins) == pytest.approx(h, rel=1e-12)


def test_mean_mode_mutual_information_averages_the_pairs():
    modes = RNG.standard_normal((2, 4, 1000))
    modes[1, 3] = modes[1, 0]  # one redundant mode: a mixed decomposition scores worse
    mie = mean_mode_mutual_information(modes, bins=10)
    assert mie.shape == (2,)
    for d in range(2):
        pairs = [mutual_information(modes[d, i], modes[d, j], bins=10) for i in range(4) for j in range(i + 1, 4)]
        assert mie[d] == pytest.approx(np.mean(pairs), rel=1e-12)
    assert mie[1] > mie[0] + 0.1


def test_bad_inputs_name_the_field():
    with pytest.raises(BearingTwinError, match="order"):
        permutation_entropy(np.arange(100.0), order=1)
    with pytest.raises(BearingTwinError, match="delay"):
        permutation_entropy(np.arange(100.0), delay=0)
    with pytest.raises(BearingTwinError, match="too few"):
        permutation_entropy(np.arange(5.0), order=4, delay=2)
    with pytest.raises(BearingTwinError, match="bins"):
        mutual_information(np.arange(10.0), np.arange(10.0), bins="scott")
    with pytest.raises(BearingTwinError, match="same shape"):
        mutual_information(np.arange(10.0), np.arange(11.0))
    with pytest.raises(BearingTwinError, match="modes"):
        mean_mode_mutual_information(np.ones((1, 10)))
