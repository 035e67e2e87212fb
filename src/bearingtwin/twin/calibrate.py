"""Fitting the twin's free parameters to a measurement by minimising the discrepancy.

Both the operating point (load, clearance, defect size and further dotted config keys:
:mod:`bearingtwin.twin.operating_point`) and each candidate effect (its class's
``search_space``) are calibrated the same way: a seeded Optuna TPE search over a box, then a
local polish, the objective being the views' deviance (:class:`bearingtwin.twin.rank.Judge`).
The sensor gain never enters the search: the comparison fits it in closed form. Trial counts
are modest because a trial that changes the dynamics is a simulation (a sensor moved, or an
effect acting on the sensor's signal only, reuses the cached one: :mod:`bearingtwin.twin.model`);
the twin keeps its random seed fixed across trials (common random numbers), so the search sees
the parameters' effect and not a new realization.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import optuna

from bearingtwin.checks import is_finite_number, mapping
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.lifecycle import raise_if_interrupted

Bounds = tuple[float, float, bool]
"""(low, high, log-scale) of one parameter."""


@dataclass
class Fit:
    """The best parameters found, the objective they give, and every trial's value and parameters in order."""

    params: dict[str, float]
    error: float
    trial_errors: list[float]
    trial_params: list[dict[str, float]]


def parse_space(space, where: str) -> dict[str, Bounds]:
    """Validate ``{name: [low, high] | [low, high, "log"]}`` from a config, naming the bad entry."""
    parsed = {}
    for name, bounds in mapping(where, space, "each parameter to [low, high] or [low, high, log]").items():
        if not _is_bounds(bounds):
            raise BearingTwinError(f"{where}.{name} must be [low, high] or [low, high, log] of finite numbers, "
                                   f"got {bounds!r}")
        low, high, log = float(bounds[0]), float(bounds[1]), len(bounds) == 3
        if not low < high or (log and low <= 0):
            raise BearingTwinError(f"{where}.{name}: need low < high (and low > 0 on a log scale), got {bounds}")
        parsed[name] = (low, high, log)
    return parsed


def _is_bounds(bounds) -> bool:
    """Whether ``bounds`` is ``[low, high]`` or ``[low, high, "log"]`` with finite numbers for low and high."""
    return (isinstance(bounds, Sequence) and not isinstance(bounds, str) and len(bounds) in (2, 3)
            and all(is_finite_number(bound) for bound in bounds[:2]) and (len(bounds) == 2 or bounds[2] == "log"))


def minimize(objective: Callable[[dict[str, float]], float], space: dict[str, Bounds], n_trials: int, seed: int,
             start: dict[str, float] | None = None, n_polish: int = 0) -> Fit:
    """Seeded TPE search for the parameters in ``space`` that minimise ``objective``, then a local polish.

    ``start`` (e.g. the config's nominal values) is evaluated first, so a calibration is
    never worse than not calibrating. A trial whose parameters the model rejects
    (:class:`BearingTwinError`, e.g. a resonance above Nyquist) counts as failed.
    An empty space evaluates ``objective({})`` once.

    TPE finds the right basin but, with a few dozen trials, not its bottom; the objective is
    deterministic (common random numbers), so ``n_polish`` further evaluations of a bounded
    Nelder-Mead search (scipy) from the best trial, in coordinates scaled to the box (log
    where the bound says so), walk down to it. Every evaluation is kept as a trial.
    """
    if not space:
        error = float(objective({}))
        return Fit({}, error, [error], [{}])
    if n_trials < 1:
        raise BearingTwinError(f"minimize: n_trials must be at least 1, got {n_trials}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(3, n_trials // 3), multivariate=True)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    if start:
        study.enqueue_trial({k: min(max(float(v), space[k][0]), space[k][1])
                             for k, v in start.items() if k in space and v is not None})

    scored = run_plain(objective)

    # Ask and tell, not study.optimize: an interrupt inside a trial goes straight to the command, which
    # reports it once, where optimize would log it as a failed trial with its traceback first.
    for _ in range(n_trials):
        trial = study.ask()
        study.tell(trial, scored({name: trial.suggest_float(name, low, high, log=log)
                                  for name, (low, high, log) in space.items()}))
    values = [t.value for t in study.trials]
    if not np.isfinite(study.best_value):
        why = f": {scored.first_rejection}" if scored.first_rejection else "; check the search space"
        raise BearingTwinError(f"calibration: every trial was rejected by the model{why}")
    params = [dict(t.params) for t in study.trials]
    # Two starts: the best trial and the best one far from it (another basin, e.g. a load-clearance trade-off).
    order = [i for i in np.argsort(values) if np.isfinite(values[i])]
    starts = [params[order[0]]]
    far = [i for i in order[1:] if _distance(space, params[i], starts[0]) > 0.25]
    if far:
        starts.append(params[far[0]])
    for start_params in starts if n_polish > 0 else []:
        _polish(scored, space, start_params, n_polish // len(starts), values, params)
    best = int(np.argmin(values))
    return Fit(params[best], float(values[best]), values, params)


def run_plain(objective: Callable[[dict[str, float]], float]) -> Callable[[dict[str, float]], float]:
    """``objective`` with a rejected or non-finite evaluation scored as +inf, as a failed trial is; the
    first rejection's reason is kept (``run.first_rejection``), to say why when every trial was rejected."""
    def run(params: dict[str, float]) -> float:
        # A signal raises in the main thread only; the candidates screened in worker threads stop here, at
        # their next evaluation, so an interrupted command does not wait for their whole budgets.
        raise_if_interrupted()
        try:
            value = float(objective(params))
        except BearingTwinError as error:
            if run.first_rejection is None:
                run.first_rejection = str(error)
            return math.inf
        return value if math.isfinite(value) else math.inf
    run.first_rejection = None
    return run


SLICE_STEPS = (0.01, 0.03, 0.1, 0.3, 1.0)
"""Distances (unit-box coordinates) at which an interval's edge is looked for, nearest first."""


def slice_interval(objective: Callable[[dict[str, float]], float], space: dict[str, Bounds], best: dict[str, float],
                   best_value: float, name: str, tolerance: float) -> tuple[float, float]:
    """The range of ``name`` over which ``objective`` stays within ``tolerance`` of ``best_value``,
    the other parameters held at ``best`` (a slice of the likelihood, narrower than a profile
    when parameters trade off). Walks out from the best in both directions at :data:`SLICE_STEPS`
    and interpolates linearly to the crossing; the box's edge bounds it.
    """
    scored = run_plain(objective)
    centre = to_unit(space[name], best[name])
    edges = []
    for direction in (-1.0, 1.0):
        inside_u, inside_value = centre, best_value
        edge = 0.0 if direction < 0 else 1.0
        for step in SLICE_STEPS:
            u = min(max(centre + direction * step, 0.0), 1.0)
            value = scored({**best, name: _from_unit(space[name], u)})
            if value > best_value + tolerance:
                share = (best_value + tolerance - inside_value) / (value - inside_value) if value > inside_value else 0.0
                edge = inside_u + share * (u - inside_u)
                break
            inside_u, inside_value = u, value
            if u in (0.0, 1.0):
                break
        edges.append(_from_unit(space[name], edge))
    return min(edges), max(edges)


def interval_from_trials(fit: Fit, name: str, least: float, tolerance: float) -> tuple[float, float]:
    """The range of ``name`` over the trials of ``fit`` whose objective lies within ``tolerance`` of ``least``.

    Every other parameter took whatever value its trial had, so where parameters trade off (a heavier
    load and a wider clearance give the same load zone) this range follows the ridge that a slice
    (:func:`slice_interval`) cuts across: joined to the slice, it comes nearer the profile interval
    without a single further evaluation. ``least`` is at most ``fit.error`` (the best trial is within).
    """
    if not any(name in trial for trial in fit.trial_params):
        raise KeyError(f"interval_from_trials: no trial of this fit varied {name!r}")
    values = [trial[name] for trial, error in zip(fit.trial_params, fit.trial_errors)
              if name in trial and error <= least + tolerance]
    if not values:
        raise ValueError(f"interval_from_trials: no trial lies within {tolerance} of {least}")
    return min(values), max(values)


def _from_unit(bounds: Bounds, u: float) -> float:
    low, high, log = bounds
    u = min(max(float(u), 0.0), 1.0)
    return low * (high / low) ** u if log else low + u * (high - low)


def _distance(space: dict[str, Bounds], a: dict[str, float], b: dict[str, float]) -> float:
    """Largest coordinate difference of two points in unit-box coordinates."""
    return max(abs(to_unit(space[n], a[n]) - to_unit(space[n], b[n])) for n in space)


def to_unit(bounds: Bounds, value: float) -> float:
    """Where ``value`` lies in ``bounds`` on the range's own scale (log where it says so): 0 at low, 1 at high."""
    low, high, log = bounds
    return math.log(value / low) / math.log(high / low) if log else (value - low) / (high - low)


def _polish(run, space: dict[str, Bounds], start: dict[str, float], n_evaluations: int,
            values: list[float], params: list[dict[str, float]]) -> None:
    """Bounded Nelder-Mead from ``start`` in unit-box coordinates; appends every evaluation."""
    from scipy.optimize import minimize as scipy_minimize

    names = list(space)

    def scored(u):
        trial = {name: _from_unit(space[name], x) for name, x in zip(names, u)}
        value = run(trial)
        values.append(value)
        params.append(trial)
        return value

    x0 = np.array([to_unit(space[name], start[name]) for name in names])
    simplex = np.vstack([x0] + [x0 + np.where(np.arange(len(names)) == i, 0.1 if x0[i] < 0.9 else -0.1, 0.0)
                                for i in range(len(names))])
    scipy_minimize(scored, x0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(names),
                   options={"maxfev": n_evaluations, "initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-3})
