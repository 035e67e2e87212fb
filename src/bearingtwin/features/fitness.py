"""Fitness functions that score a VMD decomposition, and the choice of the mode to use.

A fitness takes modes (..., k, n) (leading batch axes allowed) and returns (...,) values
to *minimize*. The paper compares two (section 3.3 and Table 4):

* ``pe_mie``: ``w_pe * PE + w_mie * MIE`` with 1:1 weights. PE, the permutation entropy,
  rewards a regular (fault-periodic) component; MIE, the mutual information between modes,
  rewards independent modes (no mode mixing).
* ``min_envelope_entropy``: the smallest envelope entropy over the modes (the "minEn" variant).

Downstream, each window keeps one mode: the one with minimum envelope entropy
(:func:`optimal_mode`, "Best IMF = argmin E_i" in the paper).
"""

from __future__ import annotations

import functools
import inspect
from typing import Callable

import numpy as np

from bearingtwin.errors import BearingTwinError
from bearingtwin.signal import envelope_entropy, mean_mode_mutual_information, permutation_entropy

PE_OF = ("selected", "mean")


def _check_modes(modes: np.ndarray) -> np.ndarray:
    modes = np.asarray(modes, dtype=np.float64)
    if modes.ndim < 2 or modes.shape[-2] < 2:
        raise BearingTwinError(f"modes must be (..., k, n) with k >= 2 modes, got shape {modes.shape}")
    return modes


def optimal_mode(modes: np.ndarray) -> np.ndarray:
    """Index (0-based) of the mode with minimum envelope entropy, shape (...,) for modes (..., k, n).

    The mode whose envelope is most concentrated in time is the most impulsive one, the one
    carrying the fault's impacts.
    """
    return np.argmin(_entropy_of_modes(modes), axis=-1)


def _entropy_of_modes(modes: np.ndarray) -> np.ndarray:
    """Each mode's envelope entropy, a zero mode's (NaN: no envelope to normalize) taken as infinite, so it is never
    the most impulsive mode: a decomposition of a window holding fewer components than modes leaves modes at 0."""
    entropy = envelope_entropy(_check_modes(modes))
    return np.where(np.isnan(entropy), np.inf, entropy)


def pe_mie(
    modes: np.ndarray,
    w_pe: float = 1.0,
    w_mie: float = 1.0,
    pe_of: str = "selected",
    pe_order: int = 5,
    pe_delay: int = 1,
    mie_bins: int | str = "sturges",
) -> np.ndarray:
    """``w_pe * PE + w_mie * MIE`` of each decomposition (paper section 3.3, weights 1:1).

    The paper does not say whose PE enters. ``pe_of="selected"`` (default) takes the
    normalized PE of the mode with minimum envelope entropy, the mode the features are
    computed from, so the search rewards decompositions whose *used* component is regular;
    ``"mean"`` averages the PE over all modes, which also rewards regular noise modes the
    classifier never sees.

    Args:
        modes: (..., k, n) decompositions.
        w_pe, w_mie: weights of PE and MIE.
        pe_of: ``selected`` or ``mean`` (see above).
        pe_order, pe_delay: embedding dimension and delay (samples) of the PE, normalized to [0, 1]
            by log(order!). Order 5 keeps n >> order! (120) for 2048-point windows, as Bandt and
            Pompe recommend.
        mie_bins: histogram bins of the mutual-information estimate (a count or a rule such as
            ``sturges``: 12 bins for 2048 points).

    Returns:
        (...,) fitness values; MIE is the mean pairwise mutual information (nats) between modes
        (:func:`bearingtwin.signal.entropy.mean_mode_mutual_information`).
    """
    modes = _check_modes(modes)
    if pe_of == "selected":
        index = optimal_mode(modes)
        used = np.take_along_axis(modes, index[..., None, None], axis=-2)[..., 0, :]
        pe = permutation_entropy(used, pe_order, pe_delay, normalize=True)
    elif pe_of == "mean":
        pe = permutation_entropy(modes, pe_order, pe_delay, normalize=True).mean(axis=-1)
    else:
        raise BearingTwinError(f"pe_of={pe_of!r} is not known; choose one of {', '.join(PE_OF)}")
    return w_pe * pe + w_mie * mean_mode_mutual_information(modes, bins=mie_bins)


def min_envelope_entropy(modes: np.ndarray) -> np.ndarray:
    """The smallest envelope entropy over the modes, (...,) for modes (..., k, n) (the paper's minEn); a zero mode
    has none, and a decomposition of zero modes only scores infinity (the worst)."""
    return _entropy_of_modes(modes).min(axis=-1)


FITNESS: dict[str, Callable[..., np.ndarray]] = {"pe_mie": pe_mie, "min_envelope_entropy": min_envelope_entropy}


def resolve_fitness(fitness: str | Callable, **params) -> Callable[[np.ndarray], np.ndarray]:
    """The fitness callable for a name in :data:`FITNESS` (with its parameters bound) or a callable."""
    if callable(fitness):
        if params:
            raise BearingTwinError("fitness_params only apply to a named fitness")
        return fitness
    if fitness not in FITNESS:
        raise BearingTwinError(f"fitness={fitness!r} is not known; choose one of {', '.join(FITNESS)}")
    function = FITNESS[fitness]
    unknown = set(params) - (set(inspect.signature(function).parameters) - {"modes"})
    if unknown:
        raise BearingTwinError(f"fitness_params: unknown key(s) {sorted(unknown)} for {fitness}")
    return functools.partial(function, **params)
