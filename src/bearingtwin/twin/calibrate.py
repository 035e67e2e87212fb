"""Fitting the twin's free parameters to a measurement by minimising the discrepancy.

Both the bare twin (defect depth, damping: dotted simulator-config keys) and each
candidate effect (its class's ``search_space``) are calibrated the same way: a seeded
Optuna TPE search over a box, the objective being the overall discrepancy of
:mod:`bearingtwin.twin.compare`. The sensor gain never enters the search: the
comparison fits it in closed form. Trial counts are modest because every trial is a
simulation; the twin keeps its random seed fixed across trials (common random
numbers), so the search sees the parameters' effect and not a new realization.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import optuna

from bearingtwin.errors import BearingTwinError

Bounds = tuple[float, float, bool]
"""(low, high, log-scale) of one parameter."""


@dataclass
class Fit:
    """The best parameters found, the discrepancy they give, and every trial's value in order."""

    params: dict[str, float]
    error: float
    trial_errors: list[float]


def parse_space(space, where: str) -> dict[str, Bounds]:
    """Validate ``{name: [low, high] | [low, high, "log"]}`` from a config, naming the bad entry."""
    parsed = {}
    for name, bounds in dict(space or {}).items():
        bounds = list(bounds)
        log = len(bounds) == 3 and bounds[2] == "log"
        if len(bounds) not in (2, 3) or (len(bounds) == 3 and not log):
            raise BearingTwinError(f"{where}.{name} must be [low, high] or [low, high, log], got {bounds}")
        low, high = float(bounds[0]), float(bounds[1])
        if not low < high or (log and low <= 0):
            raise BearingTwinError(f"{where}.{name}: need low < high (and low > 0 on a log scale), got {bounds}")
        parsed[name] = (low, high, log)
    return parsed


def minimize(objective: Callable[[dict[str, float]], float], space: dict[str, Bounds], n_trials: int, seed: int,
             start: dict[str, float] | None = None) -> Fit:
    """Seeded TPE search for the parameters in ``space`` that minimise ``objective``.

    ``start`` (e.g. the config's nominal values) is evaluated first, so a calibration is
    never worse than not calibrating. A trial whose parameters the model rejects
    (:class:`BearingTwinError`, e.g. a resonance above Nyquist) counts as failed.
    An empty space evaluates ``objective({})`` once.
    """
    if not space:
        error = float(objective({}))
        return Fit({}, error, [error])
    if n_trials < 1:
        raise BearingTwinError(f"calibration.n_trials must be at least 1, got {n_trials}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(3, n_trials // 3), multivariate=True)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    if start:
        study.enqueue_trial({k: min(max(float(v), space[k][0]), space[k][1])
                             for k, v in start.items() if k in space and v is not None})

    def run(trial: optuna.Trial) -> float:
        params = {name: trial.suggest_float(name, low, high, log=log) for name, (low, high, log) in space.items()}
        try:
            value = float(objective(params))
        except BearingTwinError:
            return math.inf
        return value if math.isfinite(value) else math.inf

    study.optimize(run, n_trials=n_trials)
    values = [t.value for t in study.trials]
    if not np.isfinite(study.best_value):
        raise BearingTwinError("calibration: every trial was rejected by the model; check the search space")
    return Fit(dict(study.best_params), float(study.best_value), values)
