"""Variational mode decomposition (Dragomiretskiy & Zosso 2014), batched and compiled.

The algorithm and its defaults are those of vmdpy 0.2 (itself a port of Zosso's MATLAB
code): the signal is mirror-extended to twice its length, its negative frequencies are
zeroed, each mode is updated in turn by a Wiener filter centred on its frequency
(Gauss-Seidel), the centre frequency moves to the mode's spectral centroid, the
Lagrange multiplier takes a dual-ascent step of size ``tau``, and the loop stops when
the squared change of the modes falls below ``tol``. With the same settings the modes
agree with vmdpy to ~1e-12 (see tests/test_vmd.py). Three things vmdpy users hit are
fixed: odd-length signals keep their last sample, only two iterates are stored instead
of the 500-deep history (vmdpy allocates 500 x 2n x k complex numbers, 260 MB for
k = 8, n = 2048), and random initial frequencies come from a ``seed``.

What is returned is what vmdpy returns: the iterate whose next update changed the modes
by less than ``tol`` (the last update only serves the convergence test).

Implementation choice. Profiling vmdpy shows its time goes into numpy call overhead on
short arrays and into the history allocation, not into arithmetic. The whole loop is
therefore one numba kernel that works on the n non-negative frequency bins only (the
negative half is identically zero), with real and imaginary parts in separate arrays, and
that fuses each mode's Wiener update with its centroid and convergence sums in a single
pass. The other modes' sum is taken from a running total of all modes (total minus this
mode's previous value) rather than vmdpy's separate accumulator: the same quantity to
rounding, but one array fewer in the loop, which is what lets LLVM vectorize it (with
vmdpy's accumulator it gave up on the aliasing checks and ran 3x slower). Batches run in
parallel over signals (``prange``), each signal with its own loop and its own stopping
point, so a signal decomposes to the same numbers alone or in a batch; a lone signal
bypasses the thread pool. A torch or vectorized-numpy version would have to run every
signal of a batch for as many iterations as the slowest one and cannot fuse the passes.
Measured numbers are in benchmarks/RESULTS.md.
"""

from __future__ import annotations

import numba
import numpy as np

from bearingtwin.checks import finite_number, whole_number
from bearingtwin.errors import BearingTwinError

INITS = ("zero", "linear", "random")
TOL_MODES = ("absolute", "relative")
_EPS = float(np.spacing(1.0))


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _decompose_one(f_re, f_im, freqs, alpha, omega_init, k, tau, tol, diff_scale, dc, max_iter, out_re, out_im, out_omega):
    """One signal's VMD loop on its non-negative frequency bins; writes into ``out_*``, returns updates done."""
    n_bins = f_re.size
    old_re = np.zeros((k, n_bins))
    old_im = np.zeros((k, n_bins))
    new_re = np.zeros((k, n_bins))
    new_im = np.zeros((k, n_bins))
    total_re = np.zeros(n_bins)  # sum of all modes at their latest update
    total_im = np.zeros(n_bins)
    lam_re = np.zeros(n_bins)
    lam_im = np.zeros(n_bins)
    omega_old = omega_init[:k].copy()
    omega_new = omega_old.copy()
    diff = tol + _EPS
    n_updates = 0
    while diff > tol and n_updates < max_iter - 1:
        change = 0.0
        for m in range(k):
            # Gauss-Seidel: the running total holds the modes before m updated, m and after not yet
            prev_re = old_re[m]
            prev_im = old_im[m]
            mode_re = new_re[m]
            mode_im = new_im[m]
            centre = omega_old[m]
            weighted = 0.0
            power = 0.0
            for j in range(n_bins):
                o_re = total_re[j] - prev_re[j]
                o_im = total_im[j] - prev_im[j]
                offset = freqs[j] - centre
                gain = 1.0 / (1.0 + alpha * offset * offset)
                re = (f_re[j] - o_re - 0.5 * lam_re[j]) * gain
                im = (f_im[j] - o_im - 0.5 * lam_im[j]) * gain
                mode_re[j] = re
                mode_im[j] = im
                total_re[j] = o_re + re
                total_im[j] = o_im + im
                p = re * re + im * im
                weighted += freqs[j] * p
                power += p
                d_re = re - prev_re[j]
                d_im = im - prev_im[j]
                change += d_re * d_re + d_im * d_im
            if dc and m == 0:
                omega_new[m] = 0.0
            elif power > 0.0:
                omega_new[m] = weighted / power
            else:  # an all-zero mode has no centroid: leave it where it is
                omega_new[m] = centre
        if tau != 0.0:
            for j in range(n_bins):
                lam_re[j] += tau * (total_re[j] - f_re[j])
                lam_im[j] += tau * (total_im[j] - f_im[j])
        n_updates += 1
        diff = _EPS + change * diff_scale
        old_re, new_re = new_re, old_re
        old_im, new_im = new_im, old_im
        omega_old, omega_new = omega_new, omega_old
    # after the swap, the iterate before the last update sits in the "new" buffers (max_iter >= 2
    # and the first test always passes, so at least one update has run)
    out_re[:k] = new_re
    out_im[:k] = new_im
    out_omega[:k] = omega_new
    return n_updates


@numba.njit(cache=True, parallel=True)
def _decompose_batch(f_re, f_im, freqs, alphas, omega_init, ks, tau, tol, diff_scales, dc, max_iter, out_re, out_im, out_omega, n_updates):
    for b in numba.prange(f_re.shape[0]):
        n_updates[b] = _decompose_one(
            f_re[b], f_im[b], freqs, alphas[b], omega_init[b], ks[b], tau, tol, diff_scales[b], dc, max_iter,
            out_re[b], out_im[b], out_omega[b],
        )


def _initial_omega(init: str, ks: np.ndarray, k_max: int, n: int, dc: bool, seed) -> np.ndarray:
    """Starting centre frequencies in cycles per sample, (batch, k_max), as vmdpy's init 0 / 1 / 2."""
    omega = np.zeros((ks.size, k_max))
    if init == "linear":
        for row, k in zip(omega, ks):
            row[:k] = 0.5 / k * np.arange(k)
    elif init == "random":
        # log-uniform between one cycle per signal and Nyquist, sorted (vmdpy's rule, seeded); every signal
        # draws afresh from the seed, so its decomposition does not hang on its place in a batch
        for row, k in zip(omega, ks):
            draws = np.random.default_rng(seed).random(k)
            row[:k] = np.sort(np.exp(np.log(1.0 / n) + (np.log(0.5) - np.log(1.0 / n)) * draws))
    elif init != "zero":
        raise BearingTwinError(f"init must be one of {INITS} (got {init!r})")
    if dc:
        omega[:, 0] = 0.0
    return omega


def _validate(x, tau, tol, tol_mode, max_iter) -> np.ndarray:
    x = np.asarray(x)
    if not np.issubdtype(x.dtype, np.number) or np.iscomplexobj(x):
        raise BearingTwinError(f"x must be a real numeric array (got dtype {x.dtype})")
    if x.ndim not in (1, 2) or x.shape[-1] < 2 or x.size == 0:
        raise BearingTwinError(f"x must have shape (n,) or (batch, n) with batch >= 1, n >= 2 (got {x.shape})")
    x = x.astype(np.float64)
    if not np.all(np.isfinite(x)):
        raise BearingTwinError("x contains NaN or infinite values")
    if not (np.isfinite(tau) and tau >= 0):
        raise BearingTwinError(f"tau must be a non-negative dual-ascent step (got {tau})")
    if not (np.isfinite(tol) and tol > 0):
        raise BearingTwinError(f"tol must be positive (got {tol})")
    if tol_mode not in TOL_MODES:
        raise BearingTwinError(f"tol_mode must be one of {TOL_MODES} (got {tol_mode!r})")
    if int(max_iter) != max_iter or max_iter < 2:
        raise BearingTwinError(f"max_iter must be an integer >= 2 (got {max_iter})")
    return x


def _decompose(x2d, ks, alphas, tau, tol, init, max_iter, seed, dc, tol_mode):
    """Core shared by :func:`vmd` and :func:`vmd_batch`: x2d (batch, n), per-signal ks and alphas."""
    batch, n = x2d.shape
    if np.any(ks < 1) or np.any(ks > n):
        raise BearingTwinError(f"k must be an integer between 1 and the signal length {n} (got {ks.tolist()})")
    if not np.all(np.isfinite(alphas)) or np.any(alphas < 0):
        raise BearingTwinError(f"alpha must be a non-negative bandwidth penalty (got {alphas.tolist()})")
    left = n // 2  # mirror extension to 2n samples; for even n exactly vmdpy's
    mirrored = np.concatenate([x2d[:, :left][:, ::-1], x2d, x2d[:, left:][:, ::-1]], axis=1)
    total = 2 * n
    spectrum = np.fft.rfft(mirrored, axis=1)[:, :n]  # the n bins from 0 (inclusive) to Nyquist (exclusive)
    freqs = np.arange(n) / total
    if tol_mode == "absolute":
        diff_scales = np.full(batch, 1.0 / total)
    else:
        energy = np.sum(spectrum.real**2 + spectrum.imag**2, axis=1)
        diff_scales = np.divide(1.0, energy, out=np.full(batch, 1.0 / total), where=energy > 0)
    k_max = int(ks.max())
    omega_init = _initial_omega(init, ks, k_max, n, dc, seed)
    out_re = np.zeros((batch, k_max, n))
    out_im = np.zeros((batch, k_max, n))
    out_omega = np.full((batch, k_max), np.nan)
    n_updates = np.zeros(batch, dtype=np.int64)
    f_re, f_im = np.ascontiguousarray(spectrum.real), np.ascontiguousarray(spectrum.imag)
    alphas, ks = alphas.astype(np.float64), ks.astype(np.int64)
    tau, tol, dc, max_iter = float(tau), float(tol), bool(dc), int(max_iter)
    if batch == 1:  # skip the thread-pool launch, whose idle workers would spin for nothing
        n_updates[0] = _decompose_one(
            f_re[0], f_im[0], freqs, alphas[0], omega_init[0], ks[0], tau, tol, diff_scales[0], dc, max_iter,
            out_re[0], out_im[0], out_omega[0],
        )
    else:
        _decompose_batch(
            f_re, f_im, freqs, alphas, omega_init, ks, tau, tol, diff_scales, dc, max_iter,
            out_re, out_im, out_omega, n_updates,
        )
    half = np.zeros((batch, k_max, n + 1), dtype=np.complex128)
    half[..., :n] = out_re + 1j * out_im
    # Zosso's reconstruction (kept by vmdpy) fills the Nyquist bin with the highest bin's value;
    # copied so the modes match the reference implementation, not just its iteration
    half[..., n] = out_re[..., n - 1]
    modes = np.fft.irfft(half, n=total, axis=-1)[..., left : left + n]
    return modes, out_omega, n_updates


def vmd(
    x,
    k: int,
    alpha: float,
    tau: float = 0.0,
    tol: float = 1e-7,
    init: str = "linear",
    max_iter: int = 500,
    *,
    seed=None,
    dc: bool = False,
    tol_mode: str = "absolute",
    return_n_iter: bool = False,
):
    """Decompose signal(s) into ``k`` band-limited modes.

    Args:
        x: (n,) or (batch, n) real signal(s); any length n >= 2 (odd lengths are kept whole).
        k: number of modes.
        alpha: bandwidth penalty; larger means narrower modes (same for all modes).
        tau: dual-ascent step; 0 lets the modes not sum exactly to the signal (noise slack).
        tol: stopping threshold on the mode change, see ``tol_mode``.
        init: starting centre frequencies: ``"zero"`` (all at 0), ``"linear"`` (i * 0.5 / k),
            ``"random"`` (log-uniform, from ``seed``) - vmdpy's init 0, 1, 2.
        max_iter: iteration limit counted as vmdpy's ``Niter``: at most ``max_iter - 1`` updates.
        seed: seed for ``init="random"`` (int or numpy SeedSequence-compatible); every signal of a
            batch draws its frequencies from it afresh, as it would alone.
        dc: hold the first mode at 0 Hz.
        tol_mode: ``"absolute"`` (vmdpy's rule: sum over modes of ||delta u_hat||^2 / (2n) < tol,
            which scales with the signal's power and length) or ``"relative"``
            (the same change divided by the energy of the signal's one-sided spectrum, so one
            tol fits signals of any amplitude and length; 1e-6 to 1e-8 are typical).
        return_n_iter: also return the number of updates each signal took.

    Returns:
        modes: (k, n) or (batch, k, n), in the unit of x, ordered as initialised (by
            frequency for the "linear" and "random" inits).
        omega: (k,) or (batch, k) final centre frequencies in cycles per sample
            (multiply by fs for Hz).
        n_iter (if asked): int or (batch,) updates performed.
    """
    x = _validate(x, tau, tol, tol_mode, max_iter)
    single = x.ndim == 1
    x2d = np.atleast_2d(x)
    ks = np.full(x2d.shape[0], whole_number("k", k), dtype=np.int64)  # "3" or None: no number of modes
    if np.ndim(alpha) != 0:  # one penalty for every mode and signal; vmd_batch takes one per signal
        raise BearingTwinError(f"alpha must be one number (got {alpha!r}); vmd_batch takes one per signal")
    finite_number("alpha", alpha)  # "2000" or None: no penalty
    alphas = np.full(x2d.shape[0], alpha, dtype=np.float64)
    modes, omega, n_updates = _decompose(x2d, ks, alphas, tau, tol, init, max_iter, seed, dc, tol_mode)
    if single:
        modes, omega, n_updates = modes[0], omega[0], int(n_updates[0])
    return (modes, omega, n_updates) if return_n_iter else (modes, omega)


def vmd_batch(
    x,
    ks,
    alphas,
    tau: float = 0.0,
    tol: float = 1e-7,
    init: str = "linear",
    max_iter: int = 500,
    *,
    seed=None,
    dc: bool = False,
    tol_mode: str = "absolute",
):
    """Decompose with a different (k, alpha) per batch member, in one parallel call.

    Built for population-based searches (SABO evaluates 15 candidate (k, alpha) pairs on the
    same signal per generation): each member runs only its own k modes, so mixing k = 3 and
    k = 10 costs what the two cost separately. Arguments as in :func:`vmd`, except

    Args:
        x: (n,) one signal shared by all members, or (p, n) one signal per member.
        ks: (p,) integer mode counts.
        alphas: (p,) bandwidth penalties.

    Returns:
        modes: list of p arrays (k_i, n).
        omegas: list of p arrays (k_i,), cycles per sample.
    """
    x = _validate(x, tau, tol, tol_mode, max_iter)
    ks_arr = np.asarray(ks)
    alphas_arr = np.asarray(alphas, dtype=np.float64)
    if ks_arr.ndim != 1 or alphas_arr.shape != ks_arr.shape or ks_arr.size == 0:
        raise BearingTwinError(f"ks and alphas must be 1-D of equal length (got {ks_arr.shape} and {alphas_arr.shape})")
    if not np.all(ks_arr == np.round(ks_arr)):
        raise BearingTwinError(f"ks must be integer mode counts (got {ks_arr.tolist()})")
    ks_arr = ks_arr.astype(np.int64)
    x2d = np.broadcast_to(x, (ks_arr.size, x.shape[-1])) if x.ndim == 1 else x
    if x2d.shape[0] != ks_arr.size:
        raise BearingTwinError(f"x has {x2d.shape[0]} signals but ks has {ks_arr.size} entries")
    modes, omega, _ = _decompose(np.ascontiguousarray(x2d), ks_arr, alphas_arr, tau, tol, init, max_iter, seed, dc, tol_mode)
    return [m[:k] for m, k in zip(modes, ks_arr)], [w[:k] for w, k in zip(omega, ks_arr)]
