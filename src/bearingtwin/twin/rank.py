"""Which missing effect explains the gap between twin and measurement: greedy forward selection.

The bare twin is calibrated first (its base parameters; the gain is closed form). Then
every candidate effect is added to it in turn, its own parameters calibrated, and
ranked by the discrepancy left; the share of the gap it closes is its explanation.
The best one is kept and the remaining candidates are tried again on top of it, until
the next effect would explain less than ``min_explained`` of what is left. An effect
that explains a large share with physically plausible parameters, and whose view of
largest improvement matches its documented signature, is the named missing effect.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import build_effects
from bearingtwin.twin.calibrate import Bounds, minimize
from bearingtwin.twin.compare import Comparator, Comparison
from bearingtwin.twin.model import TwinModel, effect_defaults, effect_search_space


@dataclass
class EffectFit:
    """One candidate effect calibrated on top of the current twin."""

    effect: str
    params: dict
    error: float
    explained: float
    evidence: str
    comparison: Comparison = field(repr=False)

    def sentence(self) -> str:
        values = ", ".join(f"{k}={v:.3g}" for k, v in self.params.items() if isinstance(v, float))
        return f"`{self.effect}` ({values}) explains {100 * self.explained:.0f}% of the discrepancy; {self.evidence}"

    def as_dict(self) -> dict:
        return {"effect": self.effect, "error": self.error, "params": self.params, "explained": self.explained,
                "evidence": self.evidence}


@dataclass
class Step:
    """The twin after a step of the forward selection."""

    effects: dict
    error: float
    comparison: Comparison = field(repr=False)
    base_params: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"effects": list(self.effects), "error": self.error, "params": self.effects,
                "base_params": self.base_params}


@dataclass
class TwinFit:
    """Outcome of calibrating and ranking: what the report and the CLI write."""

    base_params: dict
    baseline_error: float
    ranking: list[EffectFit]
    steps: list[Step]
    added: list[EffectFit]

    @property
    def final_error(self) -> float:
        return self.steps[-1].error

    @property
    def summary(self) -> str:
        if not self.added:
            best = self.ranking[0].sentence() if self.ranking else "no candidates"
            return (f"no candidate effect explains enough of the discrepancy {self.baseline_error:.2f} dB "
                    f"(best: {best}); the twin still differs: {self.steps[-1].comparison.summary}")
        named = "; then ".join(fit.sentence() for fit in self.added)
        return (f"missing: {named}. Discrepancy {self.baseline_error:.2f} -> {self.final_error:.2f} dB; "
                f"remaining {self.steps[-1].comparison.summary}")

    def as_dict(self) -> dict:
        return {
            "baseline_error": self.baseline_error,
            "base_params": self.base_params,
            "ranking": [fit.as_dict() for fit in self.ranking],
            "steps": [step.as_dict() for step in self.steps],
            "final_error": self.final_error,
            "summary": self.summary,
        }


def _evidence(effect: str, before: Comparison, after: Comparison) -> str:
    """The view that improved most, in the words of the effect's documented signature."""
    drops = {v: before.views[v].error_db - after.views[v].error_db for v in before.views}
    view = max(drops, key=drops.get)
    (instance,) = build_effects({effect: effect_defaults(effect)})
    signature = getattr(instance, "signature", "")
    return (f"signature: {signature}; the {view} view improves most "
            f"({before.views[view].error_db:.1f} -> {after.views[view].error_db:.1f} dB)")


class EffectRanker:
    """Calibrate the twin to a measurement and rank candidate effects by the gap they close.

    Args:
        candidates: effect names to try (each needs a class with a ``search_space`` and a
            ``conf/effects/<name>.yaml``).
        fixed_effects: effects known to be present, name -> parameters, always in the twin.
        base_space: base parameters to calibrate, dotted config key -> (low, high, log).
        n_trials_base, n_trials_effect: Optuna trials for the base twin and per candidate.
        n_trials_refine: trials re-fitting the base parameters jointly with each added effect.
        min_explained: stop adding effects when the best explains less than this share of
            the remaining discrepancy.
        max_effects: at most this many effects are added.
        seed: seeds every Optuna sampler (each search gets its own derived seed).
    """

    def __init__(self, candidates: Sequence[str], fixed_effects: Mapping[str, Mapping] | None = None,
                 base_space: Mapping[str, Bounds] | None = None, n_trials_base: int = 12,
                 n_trials_effect: int = 16, n_trials_refine: int = 16, min_explained: float = 0.2,
                 max_effects: int = 3, seed: int = 0):
        self.candidates = list(candidates)
        self.fixed_effects = {k: dict(v or {}) for k, v in dict(fixed_effects or {}).items()}
        self.base_space = dict(base_space or {})
        self.n_trials_base = n_trials_base
        self.n_trials_effect = n_trials_effect
        self.n_trials_refine = n_trials_refine
        self.min_explained = min_explained
        self.max_effects = max_effects
        self.seed = seed

    def fit(self, twin: TwinModel, comparator: Comparator) -> "EffectRanker":
        """Calibrate, rank and select; the outcome is in ``fit_`` (a :class:`TwinFit`)."""
        if not 0.0 <= self.min_explained < 1.0:
            raise BearingTwinError(f"ranking.min_explained must lie in [0, 1), got {self.min_explained}")
        overlap = set(self.candidates) & set(self.fixed_effects)
        if overlap:
            raise BearingTwinError(f"candidates: {sorted(overlap)[0]} is already among the fixed effects")
        spaces = {name: effect_search_space(name) for name in self.candidates}
        defaults = {name: effect_defaults(name) for name in self.candidates}

        def error(base: Mapping, effects: Mapping) -> Comparison:
            return comparator(twin.signal(base, effects))

        start = {key: twin.value(key) for key in self.base_space}
        base_fit = minimize(lambda p: error(p, self.fixed_effects).discrepancy_db, self.base_space,
                            self.n_trials_base, self.seed, start=start)
        base = base_fit.params
        current_effects = dict(self.fixed_effects)
        current = error(base, current_effects)
        steps = [Step(dict(current_effects), current.discrepancy_db, current, dict(base))]
        ranking: list[EffectFit] = []
        added: list[EffectFit] = []
        remaining = list(self.candidates)
        round_index = 0
        while remaining and len(added) < self.max_effects:
            fits = []
            for index, name in enumerate(remaining):
                fitted = self._calibrate_effect(name, spaces[name], defaults[name], base, current_effects, error,
                                                seed=self.seed + 1000 * (round_index + 1) + index)
                fits.append(self._fit_record(name, fitted, current))
            fits.sort(key=lambda fit: fit.error)
            if round_index == 0:
                ranking = fits
            best = fits[0]
            if best.explained < self.min_explained:
                break
            base, best = self._refine(best, base, current_effects, current, error,
                                      seed=self.seed + 1000 * (round_index + 1) + 999)
            added.append(best)
            current_effects[best.effect] = best.params
            current = best.comparison
            steps.append(Step(dict(current_effects), current.discrepancy_db, current, dict(base)))
            remaining.remove(best.effect)
            round_index += 1
        self.fit_ = TwinFit(base, steps[0].error, ranking, steps, added)
        return self

    def _refine(self, best: EffectFit, base, current_effects, current, error, seed):
        """Re-fit the base parameters together with the chosen effect's.

        The base twin was calibrated without the effect, so it absorbed part of it (a
        deeper defect standing in for a resonance); once the effect is in, both move.
        """
        if not self.base_space or self.n_trials_refine < 1:
            return base, best
        effect_space = effect_search_space(best.effect)
        space = {**{f"base:{k}": v for k, v in self.base_space.items()},
                 **{f"effect:{k}": v for k, v in effect_space.items()}}

        def split(params):
            new_base = {k[5:]: v for k, v in params.items() if k.startswith("base:")}
            effect = {**best.params, **{k[7:]: v for k, v in params.items() if k.startswith("effect:")}}
            return new_base, {**current_effects, best.effect: effect}

        start = {**{f"base:{k}": v for k, v in base.items()},
                 **{f"effect:{k}": v for k, v in best.params.items() if k in effect_space}}
        fit = minimize(lambda p: error(*split(p)).discrepancy_db, space, self.n_trials_refine, seed, start=start)
        new_base, effects = split(fit.params)
        return new_base, self._fit_record(best.effect, (effects[best.effect], error(new_base, effects)), current)

    def _calibrate_effect(self, name, space, nominal, base, current_effects, error, seed):
        def with_effect(params):
            return {**current_effects, name: {**nominal, **params}}

        fit = minimize(lambda p: error(base, with_effect(p)).discrepancy_db, space, self.n_trials_effect, seed,
                       start={k: nominal[k] for k in space if k in nominal})
        params = with_effect(fit.params)[name]
        return params, error(base, with_effect(fit.params))

    def _fit_record(self, name, fitted, current: Comparison) -> EffectFit:
        params, comparison = fitted
        explained = (current.discrepancy_db - comparison.discrepancy_db) / current.discrepancy_db \
            if current.discrepancy_db > 0 else 0.0
        return EffectFit(name, params, comparison.discrepancy_db, explained, _evidence(name, current, comparison),
                         comparison)
