"""The nine time-domain features and the two fitness functions."""

import numpy as np
import pytest
import scipy.special
import scipy.stats

from bearingtwin.errors import BearingTwinError
from bearingtwin.features.fitness import min_envelope_entropy, optimal_mode, pe_mie, resolve_fitness
from bearingtwin.features.time_domain import FEATURE_NAMES, time_domain_features
from bearingtwin.signal import envelope_entropy, mean_mode_mutual_information, permutation_entropy

N = 4096
t = np.arange(N) / N


def column(name):
    return FEATURE_NAMES.index(name)


def test_a_whole_period_sine_has_the_textbook_ratios():
    amplitude = 2.5
    x = amplitude * np.sin(2 * np.pi * 8 * t)
    f = time_domain_features(x)
    assert f.shape == (9,)
    assert f[column("mean")] == pytest.approx(0.0, abs=1e-12)
    assert f[column("variance")] == pytest.approx(amplitude**2 / 2)
    assert f[column("rms")] == pytest.approx(amplitude / np.sqrt(2))
    assert f[column("peak_to_peak")] == pytest.approx(2 * amplitude, rel=1e-6)
    assert f[column("kurtosis")] == pytest.approx(1.5)  # Pearson: E[sin^4] / E[sin^2]^2 = (3/8) / (1/4)
    assert f[column("crest_factor")] == pytest.approx(np.sqrt(2), rel=1e-6)
    assert f[column("shape_factor")] == pytest.approx(np.pi / (2 * np.sqrt(2)), rel=1e-4)  # rms / (2A/pi)
    assert f[column("impulse_factor")] == pytest.approx(np.pi / 2, rel=1e-4)
    # mean(sqrt|sin|) over a period = (1/pi) * integral_0^pi sin^(1/2) = Gamma(3/4) / (sqrt(pi) Gamma(5/4))
    mean_sqrt = scipy.special.gamma(0.75) / (np.sqrt(np.pi) * scipy.special.gamma(1.25))
    # (sqrt|x| has a cusp at the zero crossings: with 256 samples per half period the sampled
    # mean is off by ~256^-1.5 = 2.4e-4 relative, hence the tolerance.)
    assert f[column("margin_factor")] == pytest.approx(1 / mean_sqrt**2, rel=2e-3)  # amplitude cancels


def test_features_agree_with_scipy_and_hand_formulas_on_random_batches():
    rng = np.random.default_rng(0)
    x = rng.standard_t(df=5, size=(3, 2, 1000)) + 0.3
    f = time_domain_features(x)
    assert f.shape == (3, 2, 9)
    np.testing.assert_allclose(f[..., column("kurtosis")], scipy.stats.kurtosis(x, axis=-1, fisher=False))
    np.testing.assert_allclose(f[..., column("variance")], np.var(x, axis=-1))
    np.testing.assert_allclose(f[..., column("peak_to_peak")], np.ptp(x, axis=-1))
    peak = np.abs(x).max(-1)
    np.testing.assert_allclose(f[..., column("margin_factor")], peak / np.mean(np.sqrt(np.abs(x)), -1) ** 2)
    single = time_domain_features(x[1, 0])
    np.testing.assert_allclose(single, f[1, 0])


def test_impulsive_signals_score_higher_on_the_impulsiveness_features():
    rng = np.random.default_rng(1)
    noise = rng.normal(size=N)
    impacts = noise.copy()
    impacts[::256] += 20.0
    calm, spiky = time_domain_features(np.stack([noise, impacts]))
    for name in ("kurtosis", "crest_factor", "impulse_factor", "margin_factor"):
        assert spiky[column(name)] > 2 * calm[column(name)], name
    assert calm[column("kurtosis")] == pytest.approx(3.0, abs=0.3)  # Gaussian, Pearson's convention


def test_bad_signals_are_refused_with_the_reason():
    with pytest.raises(BearingTwinError, match=r"signal \(1,\) is constant"):
        time_domain_features(np.stack([np.sin(t), np.ones(N)]))
    # Constants whose mean rounds: their variance came out 1e-33 to 1e-22, not 0, and they had been given a
    # kurtosis of 1 and a crest factor of 1.
    for level, length in ((0.3, 2048), (0.1, 2048), (100000.1, 1000)):
        with pytest.raises(BearingTwinError, match="the signal is constant"):
            time_domain_features(np.full(length, level))
    with pytest.raises(BearingTwinError, match="real numeric array"):
        time_domain_features(np.sin(t) + 1j)  # had been cut to its real part
    with pytest.raises(BearingTwinError, match="NaN"):
        time_domain_features(np.array([1.0, np.nan, 2.0]))
    with pytest.raises(BearingTwinError, match="at least 2 samples"):
        time_domain_features(np.array([1.0]))


def two_mode_decomposition(fault_rate_hz=50.0, resonance_hz=600.0):
    """A smooth tone and a burst train (impacts ringing at a resonance), as two 'modes'."""
    fs = 4096.0
    time = np.arange(N) / fs
    tone = np.sin(2 * np.pi * 30 * time)
    since_impact = np.mod(time, 1 / fault_rate_hz)
    bursts = np.exp(-since_impact * 400) * np.sin(2 * np.pi * resonance_hz * since_impact)
    return np.stack([tone, bursts])


def test_the_optimal_mode_is_the_impulsive_one():
    modes = two_mode_decomposition()
    assert optimal_mode(modes) == 1
    assert optimal_mode(modes[::-1]) == 0
    batch = np.stack([modes, modes[::-1]])
    np.testing.assert_array_equal(optimal_mode(batch), [1, 0])


def test_a_zero_mode_is_never_the_optimal_one():
    """A zero mode has no envelope entropy (NaN); np.argmin had chosen it, and minEn had been NaN."""
    modes = np.stack([np.sin(t), np.zeros(N), np.zeros(N)])
    assert optimal_mode(modes) == 0
    assert min_envelope_entropy(modes) == pytest.approx(envelope_entropy(modes[0]))
    assert min_envelope_entropy(np.zeros((2, N))) == np.inf  # nothing to choose: the worst fitness


def test_min_envelope_entropy_is_the_smallest_mode_entropy():
    modes = two_mode_decomposition()
    assert min_envelope_entropy(modes) == pytest.approx(envelope_entropy(modes).min())
    assert min_envelope_entropy(modes) == pytest.approx(envelope_entropy(modes[1]))


def test_pe_mie_adds_the_selected_modes_pe_and_the_mean_mutual_information():
    rng = np.random.default_rng(2)
    modes = two_mode_decomposition() + 0.05 * rng.normal(size=(2, N))
    pe_selected = permutation_entropy(modes[optimal_mode(modes)], 5, 1, normalize=True)
    pe_mean = permutation_entropy(modes, 5, 1, normalize=True).mean()
    mie = mean_mode_mutual_information(modes)
    assert pe_selected != pytest.approx(pe_mean)
    assert pe_mie(modes) == pytest.approx(pe_selected + mie)
    assert pe_mie(modes, pe_of="mean") == pytest.approx(pe_mean + mie)
    assert pe_mie(modes, w_pe=2.0, w_mie=0.5) == pytest.approx(2 * pe_selected + 0.5 * mie)
    batch = np.stack([modes, modes[::-1]])
    np.testing.assert_allclose(pe_mie(batch), pe_mie(modes))  # mode order does not matter


def test_mixed_modes_cost_more_than_separated_ones():
    """The MIE term penalizes mode mixing: two copies of one component are fully redundant."""
    modes = two_mode_decomposition()
    mixed = np.stack([modes.sum(0), modes.sum(0) + 0.01 * modes[0]])
    assert pe_mie(mixed, w_pe=0.0) > pe_mie(modes, w_pe=0.0)


def test_fitness_names_and_parameters_are_checked():
    with pytest.raises(BearingTwinError, match="fitness='kurtosis'"):
        resolve_fitness("kurtosis")
    with pytest.raises(BearingTwinError, match=r"\['w_pe'\] for min_envelope_entropy"):
        resolve_fitness("min_envelope_entropy", w_pe=1.0)
    with pytest.raises(BearingTwinError, match="pe_of='median'"):
        resolve_fitness("pe_mie", pe_of="median")(two_mode_decomposition())
    with pytest.raises(BearingTwinError, match="k >= 2 modes"):
        pe_mie(np.ones((1, 10)))
