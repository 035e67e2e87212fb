"""Budgeted minimization as an Optuna study, and the VMD parameter search built on it.

SABO, TPE and CMA-ES all run through the same ask-and-tell loop with the same trial
budget (SABO's N * (T + 1): the initial population plus T generations), so swapping the
optimizer in a config compares optimizers and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import optuna
from optuna.distributions import BaseDistribution, FloatDistribution, IntDistribution

from bearingtwin.checks import is_finite_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.optim.sabo import SaboSampler

OPTIMIZERS = ("sabo", "tpe", "cmaes")


def make_sampler(
    optimizer: str, search_space: dict[str, BaseDistribution], population: int, seed: int
) -> optuna.samplers.BaseSampler:
    """The Optuna sampler named ``optimizer``, seeded.

    TPE starts from ``population`` random trials and CMA-ES uses ``population`` as its
    population size, so each begins from as much random exploration as SABO's initial population.
    """
    if optimizer == "sabo":
        return SaboSampler(search_space, population=population, seed=seed)
    if optimizer == "tpe":
        return optuna.samplers.TPESampler(n_startup_trials=population, seed=seed)
    if optimizer == "cmaes":
        return optuna.samplers.CmaEsSampler(popsize=population, seed=seed, warn_independent_sampling=False)
    raise BearingTwinError(f"optimizer={optimizer!r} is not known; choose one of {', '.join(OPTIMIZERS)}")


def minimize(
    evaluate: Callable[[list[dict]], Sequence[float]],
    search_space: dict[str, BaseDistribution],
    optimizer: str = "sabo",
    population: int = 15,
    iterations: int = 20,
    seed: int = 0,
    study: optuna.Study | None = None,
) -> optuna.Study:
    """Minimize over ``search_space`` with ``population * (iterations + 1)`` evaluations.

    Args:
        evaluate: takes a list of parameter dicts, returns one value per dict. It receives as
            many as the sampler can propose without a result (SABO's whole initial population,
            then one at a time), so an evaluator that batches gains on the first N.
        search_space: parameter name -> Optuna distribution.
        optimizer: ``sabo``, ``tpe`` or ``cmaes``.
        population, iterations: N and T of Algorithm 1; they fix the budget for every optimizer.
        seed: seeds the sampler.
        study: an empty study created with the sampler from :func:`make_sampler` (to choose its
            storage or name); by default an in-memory study.

    Returns:
        The study, its trials holding the parameters and values.
    """
    if int(iterations) < 0:
        raise BearingTwinError(f"iterations must be >= 0, got {iterations}")
    budget = int(population) * (int(iterations) + 1)
    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # one INFO line per trial would drown the progress bars
    try:
        if study is None:
            sampler = make_sampler(optimizer, search_space, int(population), seed)
            study = optuna.create_study(direction="minimize", sampler=sampler)
        done = 0
        while done < budget:
            ready = study.sampler.ready() if isinstance(study.sampler, SaboSampler) else 1
            trials = [study.ask(search_space) for _ in range(min(ready, budget - done))]
            values = evaluate([trial.params for trial in trials])
            for trial, value in zip(trials, values, strict=True):
                study.tell(trial, float(value))
            done += len(trials)
    finally:
        optuna.logging.set_verbosity(verbosity)
    return study


@dataclass
class SearchResult:
    """The best VMD parameters found and the study that found them."""

    k: int
    alpha: float
    value: float
    study: optuna.Study


def vmd_search_space(k_range: Sequence[int], alpha_range: Sequence[float]) -> dict[str, BaseDistribution]:
    """k as an integer and alpha as a float, within the inclusive ranges (paper: [3, 10], [100, 3000]).
    Every fitness compares modes with one another, so k starts at 2."""
    k_low, k_high = _pair("k_range", k_range)
    if not (all(is_finite_number(k) and int(k) == k for k in (k_low, k_high)) and 2 <= k_low < k_high):
        raise BearingTwinError(f"k_range must be two whole numbers 2 <= low < high, got {[k_low, k_high]}")
    alpha_low, alpha_high = _pair("alpha_range", alpha_range)
    if not (is_finite_number(alpha_low) and is_finite_number(alpha_high) and 0 < alpha_low < alpha_high):
        raise BearingTwinError(f"alpha_range must be two numbers 0 < low < high, got {[alpha_low, alpha_high]}")
    return {"k": IntDistribution(int(k_low), int(k_high)), "alpha": FloatDistribution(float(alpha_low), float(alpha_high))}


def _pair(name: str, values: Sequence) -> tuple:
    values = tuple(values) if isinstance(values, Sequence) and not isinstance(values, str) else (values,)
    if len(values) != 2:
        raise BearingTwinError(f"{name} must hold two values [low, high], got {list(values)}")
    return values


def search_vmd_params(
    signals: np.ndarray,
    fitness: str | Callable[[np.ndarray], np.ndarray],
    optimizer: str = "sabo",
    population: int = 15,
    iterations: int = 20,
    k_range: Sequence[int] = (3, 10),
    alpha_range: Sequence[float] = (100.0, 3000.0),
    seed: int = 0,
    vmd_options: dict | None = None,
) -> SearchResult:
    """The VMD (k, alpha) minimizing ``fitness``, averaged over the given signals.

    Args:
        signals: (n,) one signal or (b, n) signals that share the parameters; the value of a
            trial is the mean fitness over them.
        fitness: a name in :data:`bearingtwin.features.fitness.FITNESS` or a callable taking
            modes (b, k, n) and returning (b,) values to minimize.
        optimizer, population, iterations, seed: see :func:`minimize`.
        k_range, alpha_range: inclusive search ranges.
        vmd_options: passed on to :func:`bearingtwin.signal.vmd` (``tau``, ``tol``, ``max_iter``, ``init``);
            the decomposition is seeded with ``seed``.
    """
    from bearingtwin.features.fitness import resolve_fitness
    from bearingtwin.signal import vmd_batch

    signals = np.atleast_2d(np.asarray(signals, dtype=np.float64))
    if signals.ndim != 2:
        raise BearingTwinError(f"signals must be (n,) or (batch, n), got shape {signals.shape}")
    score = resolve_fitness(fitness)
    options = dict(vmd_options or {})
    n_signals = signals.shape[0]

    known: dict[tuple[int, float], float] = {}

    def evaluate(params: list[dict]) -> list[float]:
        # Agents clipped to a bound and rounded k repeat parameters (about half of a 315-trial
        # SABO run): the decomposition is deterministic, so each distinct (k, alpha) is computed once.
        # The rest go to one parallel VMD call for every (candidate, signal) pair.
        keys = [(int(p["k"]), float(p["alpha"])) for p in params]
        new = list(dict.fromkeys(key for key in keys if key not in known))
        if new:
            modes, _ = vmd_batch(
                np.tile(signals, (len(new), 1)),
                np.repeat([k for k, _ in new], n_signals),
                np.repeat([alpha for _, alpha in new], n_signals),
                seed=seed,
                **options,
            )
            for i, key in enumerate(new):
                known[key] = float(np.mean(score(np.stack(modes[i * n_signals : (i + 1) * n_signals]))))
        return [known[key] for key in keys]

    study = minimize(
        evaluate, vmd_search_space(k_range, alpha_range), optimizer, population, iterations, seed
    )
    best = study.best_trial
    return SearchResult(k=int(best.params["k"]), alpha=float(best.params["alpha"]), value=float(best.value), study=study)
