"""The subtraction-average-based optimizer (SABO) as an Optuna sampler.

The paper tunes VMD's (k, alpha) with SABO (Ma & Zhu 2025, Algorithm 1; Trojovsky &
Dehghani 2023). Running it as an Optuna sampler makes a search an ordinary
:class:`optuna.Study` - stored, inspected and compared with TPE or CMA-ES on the same
trial budget - instead of a bespoke loop.

Algorithm 1, as implemented here, for a population of N agents in m dimensions:

1. N agents are drawn uniformly within the bounds and evaluated (N trials).
2. Each generation visits the agents in order i = 0..N-1. For agent i, with
   ``I_ij = round(1 + rand + rand)`` drawn per j (a value in {1, 2, 3}),
   ``DX_i = sum_j (X_j - I_ij * X_i) * sign(f_i - f_j)``, then
   ``X_new = clip(X_i + r * DX_i / N, lo, hi)`` with ``r`` uniform per dimension.
   ``X_new`` is evaluated (one trial) and replaces ``X_i`` if it scores strictly lower.
   The update is in place: agent i+1 already sees agent i's accepted position and score.

Random numbers are drawn from one ``numpy.random.default_rng(seed)`` in this order:
the initial population as ``rng.random((N, m))``, then per agent move ``rng.random((N, 2))``
(the two uniforms of each ``I_ij``, j in order) followed by ``rng.random(m)`` (``r``).

**Integer and log parameters.** The agent keeps a continuous position; only the value handed
to the trial is rounded. An ``IntDistribution`` dimension moves in ``[low, high]`` and is
rounded to the nearest admissible integer for evaluation (so k = 3.4 is evaluated as 3 but
keeps its 0.4 for the next move; the end values 3 and 10 own half-width intervals). A log
distribution moves in log space. The continuous position is stored on each trial as the
system attribute ``sabo:position``, next to ``sabo:generation`` and ``sabo:agent``.

**Sequential semantics versus batched evaluation.** SABO proposes agent i+1 from the
population after agent i's greedy acceptance, which needs agent i's score: within a
generation the moves cannot be evaluated together without changing the algorithm. Only
the initial population is independent. :meth:`SaboSampler.ready` tells a driver how many
trials it may ask before it has to tell results (N for the initial population, then 1), so
a driver can batch the first N evaluations and stay exactly on Algorithm 1's trajectory
afterwards. Asking a generation's next agent while the previous one is still running raises.

A failed trial (exception, NaN) scores +inf: the agent never moves there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import optuna
from optuna.distributions import BaseDistribution, FloatDistribution, IntDistribution
from optuna.samplers import BaseSampler
from optuna.trial import FrozenTrial, TrialState

from bearingtwin.errors import BearingTwinError


@dataclass(frozen=True)
class _Dimension:
    """One search-space axis: the continuous range an agent moves in and how to read a value off it."""

    name: str
    distribution: BaseDistribution

    @property
    def is_log(self) -> bool:
        return bool(self.distribution.log)

    @property
    def bounds(self) -> tuple[float, float]:
        low, high = float(self.distribution.low), float(self.distribution.high)
        return (math.log(low), math.log(high)) if self.is_log else (low, high)

    def value(self, position: float) -> Any:
        """The parameter value evaluated for a continuous position (rounded for integers and steps)."""
        low, high = self.distribution.low, self.distribution.high
        raw = math.exp(position) if self.is_log else position
        step = self.distribution.step  # an IntDistribution's is always a whole number (1 unless given)
        if step is not None:
            raw = low + round((raw - low) / step) * step
        raw = min(max(raw, low), high)
        return int(raw) if isinstance(self.distribution, IntDistribution) else float(raw)


def _dimensions(search_space: dict[str, BaseDistribution]) -> tuple[_Dimension, ...]:
    if not search_space:
        raise BearingTwinError("search_space: SABO needs at least one parameter to search")
    dimensions = []
    for name, distribution in search_space.items():
        if not isinstance(distribution, (FloatDistribution, IntDistribution)):
            raise BearingTwinError(
                f"search_space.{name}: SABO moves through numeric ranges, "
                f"got {type(distribution).__name__}"
            )
        if not distribution.high > distribution.low:
            raise BearingTwinError(f"search_space.{name}: the range [{distribution.low}, {distribution.high}] is empty")
        dimensions.append(_Dimension(name, distribution))
    return tuple(dimensions)


def sign_of_difference(score_i: float, scores: np.ndarray) -> np.ndarray:
    """``sign(score_i - scores)`` that stays defined when failed trials score +inf."""
    return (score_i > scores).astype(float) - (score_i < scores).astype(float)


class SaboSampler(BaseSampler):
    """Optuna sampler running SABO (Algorithm 1) on a fixed numeric search space.

    Args:
        search_space: parameter name -> ``FloatDistribution`` / ``IntDistribution``, in the order
            of the position vector (this order also fixes the random-number stream).
        population: N, the number of agents; a generation is N trials.
        seed: seeds the one generator behind the initial population and every move.

    One sampler drives one study: the population lives in the sampler and is advanced by
    :meth:`after_trial`.
    """

    def __init__(self, search_space: dict[str, BaseDistribution], population: int = 15, seed: int | None = 0) -> None:
        if int(population) < 2:
            raise BearingTwinError(f"search.population must be at least 2 agents, got {population}")
        self._search_space = dict(search_space)
        self._dimensions = _dimensions(self._search_space)
        self._population = int(population)
        self._rng = np.random.default_rng(seed)
        bounds = np.array([dimension.bounds for dimension in self._dimensions])
        self._low, self._high = bounds[:, 0], bounds[:, 1]
        self._positions: np.ndarray | None = None
        self._scores = np.full(self._population, np.nan)
        self._generation = 0
        self._next_agent = 0
        self._pending: dict[int, tuple[int, int, np.ndarray]] = {}

    @property
    def population(self) -> int:
        return self._population

    @property
    def positions(self) -> np.ndarray | None:
        """(N, m) current agent positions (continuous; log axes in log space); None before the first trial."""
        return None if self._positions is None else self._positions.copy()

    @property
    def scores(self) -> np.ndarray:
        """(N,) current agent scores (NaN until evaluated)."""
        return self._scores.copy()

    def ready(self) -> int:
        """How many trials may be asked now without waiting for a result (keeps Algorithm 1 exact)."""
        if self._generation == 0:
            return self._population - self._next_agent
        return 0 if self._pending else 1

    def reseed_rng(self) -> None:
        # Optuna reseeds samplers for parallel workers; SABO's stream must stay the seeded one.
        pass

    def infer_relative_search_space(self, study: optuna.Study, trial: FrozenTrial) -> dict[str, BaseDistribution]:
        return dict(self._search_space)

    def sample_relative(
        self, study: optuna.Study, trial: FrozenTrial, search_space: dict[str, BaseDistribution]
    ) -> dict[str, Any]:
        generation, agent, position = self._propose()
        self._pending[trial.number] = (generation, agent, position)
        storage = study._storage
        storage.set_trial_system_attr(trial._trial_id, "sabo:generation", generation)
        storage.set_trial_system_attr(trial._trial_id, "sabo:agent", agent)
        storage.set_trial_system_attr(trial._trial_id, "sabo:position", [float(p) for p in position])
        return {dimension.name: dimension.value(p) for dimension, p in zip(self._dimensions, position)}

    def sample_independent(
        self, study: optuna.Study, trial: FrozenTrial, param_name: str, param_distribution: BaseDistribution
    ) -> Any:
        raise BearingTwinError(
            f"{param_name}: not in the SABO search space ({', '.join(self._search_space)}) "
            "or suggested with a different distribution"
        )

    def after_trial(
        self, study: optuna.Study, trial: FrozenTrial, state: TrialState, values: list[float] | None
    ) -> None:
        if trial.number not in self._pending:
            return
        generation, agent, position = self._pending.pop(trial.number)
        score = float(values[0]) if state == TrialState.COMPLETE and values else math.inf
        if math.isnan(score):
            score = math.inf
        if generation == 0:
            self._scores[agent] = score
            if self._next_agent == self._population and not self._pending:
                self._generation, self._next_agent = 1, 0
        else:
            if score < self._scores[agent]:
                self._positions[agent] = position
                self._scores[agent] = score
            self._next_agent += 1
            if self._next_agent == self._population:
                self._generation, self._next_agent = self._generation + 1, 0

    def _propose(self) -> tuple[int, int, np.ndarray]:
        if self._positions is None:
            unit = self._rng.random((self._population, len(self._dimensions)))
            self._positions = self._low + unit * (self._high - self._low)
        if self._generation == 0:
            if self._next_agent == self._population:
                raise BearingTwinError(
                    "SABO: the initial population is being evaluated; tell all of its trials before asking for more"
                )
            agent = self._next_agent
            self._next_agent += 1
            return 0, agent, self._positions[agent].copy()
        if self._pending:
            raise BearingTwinError(
                "SABO: a generation's moves are sequential (agent i+1 moves after agent i's result); "
                f"tell trial(s) {sorted(self._pending)} before asking for the next"
            )
        agent = self._next_agent
        return self._generation, agent, self._move(agent)

    def _move(self, agent: int) -> np.ndarray:
        x_i = self._positions[agent]
        uniforms = self._rng.random((self._population, 2))
        intensity = np.round(1.0 + uniforms.sum(axis=1))
        signs = sign_of_difference(self._scores[agent], self._scores)
        difference = np.zeros_like(x_i)
        for j in range(self._population):  # summed in Algorithm 1's order, so results are bit-reproducible
            difference += (self._positions[j] - intensity[j] * x_i) * signs[j]
        r = self._rng.random(len(self._dimensions))
        return np.clip(x_i + r * difference / self._population, self._low, self._high)
