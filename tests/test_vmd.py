"""VMD: equivalence with vmdpy 0.2, the physics of the decomposition, and the fixes over vmdpy."""

import numpy as np
import pytest
from vmdpy import VMD

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal import vmd, vmd_batch

FS = 12_000.0
RNG = np.random.default_rng(7)


def tones_signal(n, tones=((300.0, 1.0), (1_800.0, 0.6), (4_000.0, 0.3)), noise=0.2, rng=RNG):
    t = np.arange(n) / FS
    x = sum(a * np.cos(2 * np.pi * f * t + 0.3 * i) for i, (f, a) in enumerate(tones))
    return x * (1 + 0.3 * np.cos(2 * np.pi * 37.0 * t)) + noise * rng.standard_normal(n)


@pytest.mark.parametrize(
    "k,alpha,tau,init",
    [(3, 2000.0, 0.0, "linear"), (5, 500.0, 0.0, "zero"), (4, 1000.0, 0.1, "linear"), (8, 3000.0, 0.0, "linear"),
     (2, 100.0, 0.5, "zero"), (6, 1500.0, 0.05, "zero")],
)
def test_matches_vmdpy_on_even_length_signals(k, alpha, tau, init):
    x = tones_signal(512)
    ref_modes, _, ref_omega = VMD(x, alpha, tau, k, False, {"zero": 0, "linear": 1}[init], 1e-7)
    modes, omega, n_iter = vmd(x, k, alpha, tau=tau, tol=1e-7, init=init, return_n_iter=True)
    assert modes.shape == ref_modes.shape == (k, 512)
    assert n_iter == len(ref_omega)  # vmdpy keeps one omega row per update, less the last
    np.testing.assert_allclose(modes, ref_modes, rtol=0, atol=1e-6 * np.abs(ref_modes).max())
    np.testing.assert_allclose(omega, ref_omega[-1], rtol=1e-6, atol=1e-12)


def test_matches_vmdpy_with_dc_mode():
    x = tones_signal(256, tones=((1_500.0, 1.0), (4_000.0, 0.5))) + 2.0
    ref_modes, _, ref_omega = VMD(x, 2000.0, 0.0, 3, True, 1, 1e-7)
    modes, omega = vmd(x, 3, 2000.0, dc=True)
    np.testing.assert_allclose(modes, ref_modes, rtol=0, atol=1e-6 * np.abs(ref_modes).max())
    assert omega[0] == 0.0 == ref_omega[-1, 0]
    assert modes[0].mean() == pytest.approx(2.0, rel=0.02)  # the offset lands in the DC mode


def test_modes_sit_on_the_tones_and_rebuild_the_signal():
    tones = ((300.0, 1.0), (1_800.0, 0.6), (4_000.0, 0.3))
    x = tones_signal(2048, tones=tones, noise=0.0)
    modes, omega = vmd(x, 3, 2000.0, tau=0.1, tol=1e-9)
    np.testing.assert_allclose(omega * FS, [f for f, _ in tones], rtol=0.01)
    spectra = np.abs(np.fft.rfft(modes, axis=-1))
    peak_hz = np.fft.rfftfreq(2048, 1 / FS)[np.argmax(spectra, axis=-1)]
    np.testing.assert_allclose(peak_hz, [f for f, _ in tones], atol=2 * FS / 2048)
    inner = slice(100, -100)  # away from the mirror-extension edges
    assert np.abs(modes.sum(axis=0) - x)[inner].max() < 0.02 * np.abs(x).max()


@pytest.mark.parametrize("n", [511, 1001])
def test_odd_length_signals_keep_every_sample(n):
    tones = ((500.0, 1.0), (3_000.0, 0.5))
    x = tones_signal(n, tones=tones, noise=0.0)
    modes, omega = vmd(x, 2, 2000.0, tau=0.1, tol=1e-9)
    assert modes.shape == (2, n)
    np.testing.assert_allclose(omega * FS, [500.0, 3_000.0], rtol=0.02)
    # the last sample is decomposed like the others, not dropped or zero
    assert abs(modes[:, -1].sum() - x[-1]) < 0.05 * np.abs(x).max()
    # an odd-length signal gives what its even-length prefix would, except near the end
    even_modes, _ = vmd(x[:-1], 2, 2000.0, tau=0.1, tol=1e-9)
    np.testing.assert_allclose(modes[:, 50 : n // 2], even_modes[:, 50 : n // 2], atol=0.05)


def test_batch_gives_each_signal_its_own_result_and_stopping_point():
    x = np.stack([tones_signal(512, noise=s) for s in (0.0, 0.2, 1.0)] + [5.0 * tones_signal(512)])
    modes, omega, n_iter = vmd(x, 4, 1500.0, return_n_iter=True)
    assert modes.shape == (4, 4, 512) and omega.shape == (4, 4) and n_iter.shape == (4,)
    assert len(set(n_iter.tolist())) > 1  # they really stop at different iterations
    for i in range(4):
        m_i, w_i, n_i = vmd(x[i], 4, 1500.0, return_n_iter=True)
        assert n_iter[i] == n_i
        np.testing.assert_allclose(modes[i], m_i, rtol=0, atol=1e-12 * np.abs(m_i).max())
        np.testing.assert_allclose(omega[i], w_i, rtol=1e-12)


def test_vmd_batch_mixes_k_and_alpha_like_separate_calls():
    x = tones_signal(512)
    ks, alphas = [3, 7, 5, 3], [200.0, 2500.0, 1000.0, 2900.0]
    modes, omegas = vmd_batch(x, ks, alphas, tau=0.0)
    assert [m.shape for m in modes] == [(k, 512) for k in ks]
    for k, alpha, m, w in zip(ks, alphas, modes, omegas):
        m_ref, w_ref = vmd(x, k, alpha)
        np.testing.assert_allclose(m, m_ref, rtol=0, atol=1e-12 * np.abs(m_ref).max())
        np.testing.assert_allclose(w, w_ref, rtol=1e-12)


def test_random_init_is_seeded():
    x = tones_signal(512)
    a = vmd(x, 4, 1000.0, init="random", seed=3, max_iter=3)
    b = vmd(x, 4, 1000.0, init="random", seed=3, max_iter=3)
    c = vmd(x, 4, 1000.0, init="random", seed=4, max_iter=3)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.allclose(a[1], c[1])
    # max_iter=2 is one update: the returned iterate is the initial guess, which lies log-uniformly
    # between one cycle per signal and Nyquist and is sorted
    _, start = vmd(x, 4, 1000.0, init="random", seed=3, max_iter=2)
    assert np.all(np.diff(start) > 0) and 1 / 512 <= start[0] and start[-1] < 0.5
    # A window decomposes alike alone and third in a batch (a diagnosis reads one, training a chunk).
    batch = np.stack([tones_signal(512) * scale for scale in (0.5, 2.0)] + [x])
    modes, omega = vmd(batch, 4, 1000.0, init="random", seed=3, max_iter=50)
    alone_modes, alone_omega = vmd(x, 4, 1000.0, init="random", seed=3, max_iter=50)
    np.testing.assert_allclose(modes[2], alone_modes, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(omega[2], alone_omega, rtol=1e-12)


def test_relative_tolerance_is_scale_free_and_absolute_is_not():
    x = tones_signal(512)
    _, _, n_small = vmd(x, 4, 1000.0, tol=1e-7, return_n_iter=True)
    _, _, n_large = vmd(1000.0 * x, 4, 1000.0, tol=1e-7, return_n_iter=True)
    assert n_large > n_small  # vmdpy's rule: a louder signal needs more iterations
    m_small, _, r_small = vmd(x, 4, 1000.0, tol=1e-8, tol_mode="relative", return_n_iter=True)
    m_large, _, r_large = vmd(1000.0 * x, 4, 1000.0, tol=1e-8, tol_mode="relative", return_n_iter=True)
    assert r_small == r_large
    np.testing.assert_allclose(m_large, 1000.0 * m_small, rtol=0, atol=1e-9 * np.abs(m_large).max())


def test_max_iter_bounds_the_updates():
    x = tones_signal(512)
    _, _, n_iter = vmd(x, 5, 2000.0, tol=1e-30, max_iter=17, return_n_iter=True)
    assert n_iter == 16


def test_bad_inputs_name_the_field():
    x = tones_signal(128)
    cases = [
        (dict(init="uniform"), "init"),
        (dict(tol=0.0), "tol"),
        (dict(tau=-1.0), "tau"),
        (dict(tol_mode="scaled"), "tol_mode"),
        (dict(max_iter=1), "max_iter"),
    ]
    for kwargs, field in cases:
        with pytest.raises(BearingTwinError, match=field):
            vmd(x, 3, 1000.0, **kwargs)
    with pytest.raises(BearingTwinError, match="k must"):
        vmd(x, 0, 1000.0)
    with pytest.raises(BearingTwinError, match="alpha"):
        vmd(x, 3, -5.0)
    with pytest.raises(BearingTwinError, match="x contains NaN"):
        vmd(np.r_[x, np.nan], 3, 1000.0)
    with pytest.raises(BearingTwinError, match="shape"):
        vmd(np.ones((2, 2, 8)), 2, 100.0)
    with pytest.raises(BearingTwinError, match="batch >= 1"):
        vmd(np.ones((0, 8)), 2, 100.0)
    with pytest.raises(BearingTwinError, match="ks and alphas"):
        vmd_batch(x, [3, 4], [100.0])


def test_silent_signal_gives_silent_modes_not_nan():
    """A dead sensor window (all zeros) must not poison a batch with NaN centre frequencies."""
    x = np.stack([np.zeros(256), tones_signal(256)])
    modes, omega = vmd(x, 3, 1000.0)
    assert np.all(modes[0] == 0.0)
    np.testing.assert_array_equal(omega[0], 0.5 / 3 * np.arange(3))  # stays at the linear start
    assert np.all(np.isfinite(omega))
