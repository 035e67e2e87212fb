"""Which base parameters differ and which effects are missing: calibrate, rank, select, and say what is left.

The measurement is cut in two parts: every calibration fits on the first, every decision
is taken on the second, held-out part, so an effect that only fits the first part's
random detail is not added. The two parts compared with each other give the
measurement's own repeatability per view, the floor no twin can go below.

1. **Operating point.** The bare twin's base parameters (sensor race and direction, radial
   load, clearance, defect size; :mod:`bearingtwin.twin.operating_point`) are fitted
   first, the sensor gain in closed form.
2. **Effects.** Every candidate is added in turn, its parameters fitted (from the data's own
   estimate when the effect class offers ``initial_guess``), and ranked. The best is kept
   if it pays for its parameters on the held-out part: a Bayesian information criterion on
   the views' errors, each view's residual variance being the twin's misfit plus the
   measurement's repeatability. And it is claimed only if it also brings the twin closer in
   the views its signature shows in (``signature_views`` of its class): an effect that pays
   only elsewhere (tones lowering the kurtosis any added energy lowers, while the lines view
   stays as it was) explains something it does not name, and the ranking stops there: the
   discrepancy the most evidence points at is not a library effect's, so a runner-up that
   explains less of it is not offered in its place, with one exception: a pair (the best, not
   claimed, is then reported as such beside it). Two effects
   may each hide the other's mark (a shaft line whose harmonics a saturation makes: the line
   alone matches one of them, and the clipping alone has no line to clip; together they match
   all). So the candidates of most evidence are also fitted two by two, and a pair is claimed
   if each of its effects pays beyond the other alone and the one that did not show its
   signature alone shows it beside the other (both do, where neither did alone). The
   signature is judged after the operating point
   and every kept effect are re-fitted together with the candidate (or on the screen, if it gains more
   there): the operating point was fitted without it and may have taken up part of its mark. Then
   the remaining candidates are tried on top, each with the kept effects free again beside it
   (they were fitted without it and took up part of its signature), until none pays. A fixed
   effect (one a reference record found) named among the candidates is tried as changed: its
   parameters fitted again from the held values and paid for like a new effect's, so an
   unbalance that has grown since the reference is named, not left over.
3. **What is left.** A view whose error stays more than twice the measurement's own is
   reported with where it disagrees and which kinds of physics leave such a mark, whether
   or not a library effect was added: a discrepancy no candidate explains is named, never
   pinned on the nearest library effect.

Every fitted value comes with an interval (where the deviance stays within the 95 % chi-square
bound of the best: along the value's slice, the other parameters held, and over the values the
last fit evaluated, the other parameters wherever they were), every ranking with its margin over
the runner-up.
"""

from __future__ import annotations

import itertools
import math
import threading
import zlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from tqdm.auto import tqdm

from bearingtwin.checks import derived_seed
from bearingtwin.data.recording import Recording
from bearingtwin.data.units import acceleration_factor, acceleration_unit
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import effect_class
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.twin.calibrate import SLICE_STEPS, interval_from_trials, minimize, slice_interval, to_unit
from bearingtwin.twin.compare import VIEWS, Comparator, Comparison, CompareSettings
from bearingtwin.twin.model import TwinModel, effect_defaults, effect_search_space
from bearingtwin.twin.operating_point import BASE_PARAMETERS, OperatingPoint, describe_sensor

CHI2_95_ONE_DOF = 3.841
"""Deviance above the best that bounds a 95 % interval of one parameter (Wilks)."""
CLEAR_MARGIN = 2.0
"""An information-criterion margin below this is "not worth more than a bare mention" (Kass & Raftery 1995)."""

WHAT_LEAVES_IT = {
    "psd": "a structural resonance, a broadband source (rub, flow, cavitation) or a noise floor in that band",
    "lines": "a periodic force at that frequency: another machine element (gear mesh, blade or vane pass), "
             "an electrical line, or a shaft-order source",
    "envelope": "a modulation or impact process at a rate other than the bearing's (a second defect, a gear, "
                "a rub once per revolution)",
    "harmonics": "a different defect geometry or impact rhythm (defect size, slip, load-zone modulation)",
    "statistics": "non-stationary events: spikes, dropouts, bursts or saturation of the sensor",
}

CAUSE_WORDS = {"clipping": "saturation", "line_frequency": "electrical line", "load_zone": "load-zone",
               "structural_mode": "structural resonance"}
"""How a library effect is named among the causes of a mark the library left unexplained (:data:`WHAT_LEAVES_IT`,
and :func:`~bearingtwin.twin.compare.line_source` for a line), where not by its name with spaces for underscores."""


def _view_errors(comparison: Comparison) -> dict[str, float]:
    return {v: comparison.views[v].error_db for v in VIEWS}


def view_floors(repeatability_db: Mapping[str, float], view_floor_db: float) -> dict[str, float]:
    """Each view's repeatability, never below ``view_floor_db``: a part-to-part error near 0 (a view
    whose numbers barely move, such as the scale-free statistics) would make matching it by any knob
    worth more than the twin's model form can promise."""
    return {v: max(repeatability_db[v], view_floor_db) for v in VIEWS}


def view_deviances(errors_db: Mapping[str, float], floors_db: Mapping[str, float], weights: Mapping[str, float],
                   points_per_view: float) -> dict[str, float]:
    """Each view's term of the deviance: n w_v ln(e_v^2 + f_v^2)."""
    return {v: points_per_view * weights[v] * math.log(errors_db[v] ** 2 + floors_db[v] ** 2) for v in VIEWS}


def deviance(errors_db: Mapping[str, float], floors_db: Mapping[str, float], weights: Mapping[str, float],
             points_per_view: float) -> float:
    """-2 log-likelihood (up to a constant) of the views' errors: n sum_v w_v ln(e_v^2 + f_v^2) (:class:`Judge`)."""
    return float(sum(view_deviances(errors_db, floors_db, weights, points_per_view).values()))


def signature_gain(before_db: Mapping[str, float], after_db: Mapping[str, float], floors_db: Mapping[str, float],
                   weights: Mapping[str, float], points_per_view: float, views: Sequence[str]) -> float:
    """The deviance drop from the views' errors ``before_db`` to ``after_db`` within ``views`` alone."""
    before = view_deviances(before_db, floors_db, weights, points_per_view)
    after = view_deviances(after_db, floors_db, weights, points_per_view)
    return float(sum(before[v] - after[v] for v in views))


def penalty_per_parameter(points_per_view: float, weights: Mapping[str, float]) -> float:
    """BIC: ln of the number of compared values."""
    return math.log(points_per_view * sum(weights.values()))


@dataclass
class Judge:
    """Scores twins against a measurement: fits on one part, decides on the held-out part.

    ``deviance`` is -2 log-likelihood (up to a constant) of the views' errors under Gaussian
    residuals whose variance per view is the twin's misfit plus the measurement's own
    repeatability (``floors_db``, the part-to-part error): n sum_v w_v ln(e_v^2 + f_v^2).
    Every view counts as ``points_per_view`` independent values: the values within a view
    (neighbouring bins, a line's leakage, harmonics of one process) are correlated, and no
    view may outvote the others by its resolution. The calibration's optimum does not depend
    on it; the information criterion's threshold does, so it is chosen on measurements of the
    independent test rig (results/identifiability.md), not on the twin's own.
    """

    fit_part: Comparator
    check_part: Comparator
    repeatability_db: dict[str, float]  # the part-to-part error of each view
    weights: dict[str, float]
    held_out: bool
    points_per_view: float = 1.0
    view_floor_db: float = 0.5

    @property
    def floors_db(self) -> dict[str, float]:
        """Each view's repeatability, never below ``view_floor_db`` (:func:`view_floors`)."""
        return view_floors(self.repeatability_db, self.view_floor_db)

    @classmethod
    def for_measurement(cls, measured: Recording, geometry: BearingGeometry, settings: CompareSettings,
                        points_per_view: float = 1.0, view_floor_db: float = 0.5) -> "Judge":
        """Cut ``measured`` in two halves when each is long enough for every view, else use it whole for both."""
        half = measured.signal.size // 2
        try:
            first = Comparator(Recording(measured.signal[:half], measured.fs, measured.rpm, measured.fault,
                                         source=measured.source, unit=measured.unit), geometry, settings)
            second = Comparator(Recording(measured.signal[half:2 * half], measured.fs, measured.rpm, measured.fault,
                                          source=measured.source, unit=measured.unit), geometry, settings)
        except BearingTwinError:
            whole = Comparator(measured, geometry, settings)
            return cls(whole, whole, {v: 0.0 for v in VIEWS}, dict(settings.weights), False, points_per_view,
                       view_floor_db)
        repeat = _view_errors(first.compare_profiles(second.measured))
        return cls(first, second, repeat, dict(settings.weights), True, points_per_view, view_floor_db)

    @property
    def penalty_per_parameter(self) -> float:
        return penalty_per_parameter(self.points_per_view, self.weights)

    def deviance(self, comparison: Comparison) -> float:
        return deviance(_view_errors(comparison), self.floors_db, self.weights, self.points_per_view)

    def signature_gain(self, before: Comparison, after: Comparison, views: Sequence[str]) -> float:
        """The deviance drop from ``before`` to ``after`` within ``views`` (:func:`signature_gain`)."""
        return signature_gain(_view_errors(before), _view_errors(after), self.floors_db, self.weights,
                              self.points_per_view, views)

    def unexplained(self, comparison: Comparison) -> list[dict]:
        """Views whose error is more than twice the measurement's own repeatability, worst first."""
        return views_beyond_floor(comparison, self.floors_db, self.weights)


def views_beyond_floor(comparison: Comparison, floors_db: Mapping[str, float], weights: Mapping[str, float]) -> list[dict]:
    """The views of ``comparison`` whose error exceeds twice their floor (the measurement's own part-to-part
    error) and 1 dB, worst first relative to the floor: each with its error, floor, finding and what leaves such a mark."""
    left = []
    for v in VIEWS:
        result = comparison.views[v]
        if weights[v] > 0 and result.error_db > 2 * floors_db[v] and result.error_db > 1.0:
            left.append({"view": v, "error_db": result.error_db, "floor_db": floors_db[v],
                         "where": result.finding, "what_leaves_it": result.what_leaves_it or WHAT_LEAVES_IT[v]})
    return sorted(left, key=lambda u: -u["error_db"] / u["floor_db"])


@dataclass
class EffectFit:
    """One candidate effect fitted on top of the current twin, judged on the held-out part."""

    effect: str
    params: dict
    error: float              # discrepancy on the held-out part with the effect, dB
    explained: float          # share of the held-out discrepancy it closes
    evidence: float           # information-criterion gain on the held-out part (> 0: it pays for its parameters)
    drop_per_point: float     # deviance drop on the held-out part per value a view counts as (points_per_view), before the penalty
    n_parameters: int
    signature: str
    comparison: Comparison = field(repr=False)
    space: dict = field(repr=False)  # the box its parameters were searched in (effect_search_space at the record's rate)
    signature_gain: float = 0.0  # the deviance drop on the held-out part within the views its signature shows in
    intervals: dict = field(default_factory=dict)
    kept_params: dict = field(default_factory=dict, repr=False)  # the kept effects as re-fitted with this one
    changed_from: dict | None = None  # a fixed effect's held parameters, when this fit is that effect changed
    claimed_beside: str | None = None  # the effect whose presence lets this one's signature show (a pair), else None

    def sentence(self, first: bool = True) -> str:
        """The effect, its parameters and how much it closes: of the discrepancy (the first effect found), or of
        what the effects before it left; a fixed effect that changed, from what to what."""
        values = ", ".join(_parameter_words(k, v, self.intervals.get(k)) + _reference_words(self.effect, k)
                           + (_range_words(v, self.intervals.get(k), self.space[k]) if k in self.space else "")
                           for k, v in self.params.items()  # a held effect's settings not searched stay as held: unsaid
                           if isinstance(v, float) and (k in self.space or k not in (self.changed_from or {})))
        of = "the discrepancy" if first else "what was left"
        beside = "" if self.claimed_beside is None else f" (its signature shows only beside {self.claimed_beside})"
        if self.changed_from is None:
            return f"{self.effect} ({values}) closes {100 * self.explained:.0f} % of {of}{beside}; {self.signature}"
        held = ", ".join(_parameter_words(k, float(self.changed_from[k])) for k in self.params
                         if k in self.space and k in self.changed_from)
        return (f"{self.effect}, changed from the held {held} to {values}, closes {100 * self.explained:.0f} % of "
                f"{of}{beside}; {self.signature}")

    def as_dict(self) -> dict:
        return {"effect": self.effect, "error": self.error, "params": self.params, "explained": self.explained,
                "evidence": self.evidence, "drop_per_point": self.drop_per_point, "n_parameters": self.n_parameters,
                "signature": self.signature, "signature_views": list(signature_views(self.effect)),
                "signature_gain": self.signature_gain, "changed_from": self.changed_from,
                "claimed_beside": self.claimed_beside,
                "intervals": {k: list(v) for k, v in self.intervals.items()}}


@dataclass
class Step:
    """The twin after a step of the selection: its effects, base parameters and held-out discrepancy."""

    effects: dict
    error: float
    comparison: Comparison = field(repr=False)
    base_params: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"effects": list(self.effects), "error": self.error, "params": self.effects,
                "base_params": self.base_params, "views": _view_errors(self.comparison)}


LEVEL_CHANGE_DB = 6.0
"""How far (dB) a measurement's overall level may lie from its reference record's before the report names the change:
twice or half the amplitude, a plain step a vibration analyst notes, not fitted to any result."""


@dataclass
class TwinFit:
    """Outcome of calibrating and ranking: what the report and the CLI write."""

    operating_point: dict      # name -> {value, interval, unit, held}
    base_params: dict          # dotted config keys of the final twin (what data=twin_to_real reads)
    gain: float
    baseline_error: float
    ranking: list[EffectFit]
    steps: list[Step]
    added: list[EffectFit]
    unexplained: list[dict]
    floor_error: float
    held_out: bool
    rounds: list[list[dict]] = field(default_factory=list)  # every round's candidates: effect, evidence, views
    repeatability_db: dict = field(default_factory=dict)    # each view's part-to-part error
    unclaimed: EffectFit | None = None  # the candidate that paid, but not in its own signature's views
    min_signature_gain: float = 0.0
    not_tried: str = ""  # why no candidate was tried (none given, ranking.max_effects=0, each needs another), else ""
    pairs: list[dict] = field(default_factory=list)  # every pair tried where the best fell short (EffectRanker._pair)
    # The views in which this measurement differs from a reference record of the rig (measurement against
    # measurement, no twin: :func:`views_beyond_floor`); None when no reference record was compared, and why.
    since_reference: list[dict] | None = None
    reference_note: str = ""  # why a reference record was not compared ("it is this record itself"), else ""
    # This measurement's overall (RMS) level over the reference record's, dB, in one unit (None: not compared, or a
    # unit of either unknown); the views above compare shapes after a gain between the two.
    level_since_reference_db: float | None = None
    level_not_compared: str = ""  # why the overall level was not held against the reference record's (their units)
    passed_over: str = ""  # candidates not offered on this record's bearing state, and why, where others were tried
    # Candidates offered only once another effect is in the twin, which it never took (second_resonance without
    # resonance): the report's, not the summary's (with the default candidates nearly every run has one).
    awaiting: str = ""
    unit: str = ""  # the measurement's unit, which the sensor gain converts the twin's m/s^2 into
    # First-round candidates whose best fit left the twin as it was (a clipping level above every peak, tones where
    # no line stands out, a held effect tried as changed and found as held): they found nothing to fit, so they are
    # not ranked, where they would stand above every candidate that made the twin worse.
    found_nothing: list[str] = field(default_factory=list)
    # RMS (m/s^2) of the final twin's signal its noise acts on, which noise.snr_db refers to (None: no noise, or one
    # at an absolute level already): a later run that takes this report as its reference holds the noise at this
    # absolute level, the sensor's floor, where the ratio would scale it with whatever the bearing's signal became.
    noise_reference_rms: float | None = None

    @property
    def final_error(self) -> float:
        return self.steps[-1].error

    @property
    def margin(self) -> float | None:
        """Information-criterion lead of the first-ranked candidate over the runner-up."""
        return self.ranking[0].evidence - self.ranking[1].evidence if len(self.ranking) > 1 else None

    @property
    def new_unexplained(self) -> list[dict]:
        """The unexplained views, less those in which nothing changed since a reference record: there the twin
        misses what the rig showed before too (its own path or floor), not something new."""
        if self.since_reference is None:
            return self.unexplained
        changed = {entry["view"] for entry in self.since_reference}
        return [left for left in self.unexplained if left["view"] in changed]

    @property
    def verdict(self) -> str:
        if self.added:
            return "effects missing"
        if not self.ranking and not self.found_nothing:  # never offered a candidate: the summary names the views left
            return "no effect tried"
        return "unexplained discrepancy" if self.new_unexplained or self.unclaimed is not None else "no effect needed"

    @property
    def own_discrepancy_words(self) -> str:
        """The measurement's own part-to-part discrepancy, or why there is none to give."""
        if self.held_out:
            return f"the measurement's own part-to-part discrepancy: {self.floor_error:.2f} dB"
        return ("the record is too short to hold out half of it: every effect was fitted and judged on the whole "
                "record, and its own part-to-part discrepancy is unknown")

    @property
    def summary(self) -> str:
        part = "held-out part" if self.held_out else "record"
        lines = ["Base parameters that differed: " + _operating_point_words(self.operating_point, self.gain, self.unit) + "."]
        if self.added:
            found = "; then ".join(fit.sentence(first=index == 0) for index, fit in enumerate(self.added))
            what = "missing or changed" if any(fit.changed_from is not None for fit in self.added) else "missing"
            lines.append(f"Effects that were {what}, in order: {found}. "
                         f"Discrepancy {self.baseline_error:.2f} -> {self.final_error:.2f} dB on the {part} "
                         f"({self.own_discrepancy_words}).")
            if self.margin is not None and self.added[0].effect == self.ranking[0].effect:
                runner = self.ranking[1].effect
                if self.ranking[1].evidence <= 0:  # close behind, yet short of what its parameters cost
                    runner += " (which does not pay for its parameters)"
                lines.append(f"Uncertain: {self.ranking[0].effect} leads {runner} by only {self.margin:.1f} "
                             "information-criterion units." if self.margin < CLEAR_MARGIN else
                             f"{self.ranking[0].effect} leads the runner-up, {runner}, by {self.margin:.1f} "
                             "information-criterion units.")
            if self.unclaimed is not None:
                lines.append(f"Not claimed: {self._unclaimed_words()}.")
        elif self.unclaimed is not None:
            lines.append(f"No library effect claimed: {self._unclaimed_words()}. Discrepancy {self.baseline_error:.2f} dB "
                         f"({self.own_discrepancy_words}).")
        elif not self.ranking and not self.found_nothing:
            lines.append(f"No effect tried: {self.not_tried}. Discrepancy "
                         f"{self.baseline_error:.2f} dB ({self.own_discrepancy_words}).")
        else:
            # "Needed" only where nothing new is left unexplained; otherwise the library simply has nothing that pays.
            head = "No effect needed" if not self.new_unexplained else "No library effect added"
            best = (f"the best candidate, {self.ranking[0].effect}, does not pay for its parameters on the {part}"
                    if self.ranking else "no candidate changed the twin")
            lines.append(f"{head}: {best}. Discrepancy {self.baseline_error:.2f} dB ({self.own_discrepancy_words}).")
        if self.found_nothing:
            lines.append(f"Found nothing to fit: {', '.join(self.found_nothing)} (at its best fit the twin was as it "
                         "was before it was tried: nothing to clip, no line to add, or an effect held as it was).")
        if self.passed_over:
            lines.append(f"Not offered on this record: {self.passed_over}.")
        lines += self._reference_lines()
        new = self.new_unexplained
        by = "the library" if self.ranking else "the twin"  # with nothing tried, the library was not asked
        added = {fit.effect for fit in self.added}
        for left in self.unexplained:
            own = "the measurement's own" if self.held_out else f"the {left['floor_db']:.1f} dB counted at least"
            since = "" if left in new else ", unchanged since the reference record (the rig's own, not new)"
            # A cause the library holds was a candidate: said so, or the mark's causes read as left untried.
            tried = [fit.effect for fit in self.ranking if fit.effect not in added
                     and CAUSE_WORDS.get(fit.effect, fit.effect.replace("_", " ")) in left["what_leaves_it"]]
            verdict = (f"; the library's {_listed(tried)} {'were' if len(tried) > 1 else 'was'} tried here and not "
                       "added" if tried else "")
            lines.append(f"Not explained by {by}{since}: the {left['view']} view ({left['error_db']:.1f} dB, "
                         f"{left['error_db'] / left['floor_db']:.0f} times {own}): {left['where']}. "
                         f"Such a mark is left by {left['what_leaves_it']}{verdict}.")
        return "\n".join(lines)

    @property
    def level_change(self) -> str:
        """The overall level's change since the reference record, in words, where it is :data:`LEVEL_CHANGE_DB` or
        more ("" otherwise): the views compare shapes after a gain between the two records, which takes it up."""
        level = self.level_since_reference_db
        if level is None and self.level_not_compared:
            return f"the overall level is not compared with the reference record's: {self.level_not_compared}"
        if level is None or abs(level) < LEVEL_CHANGE_DB:
            return ""
        return (f"the overall level is {abs(level):.1f} dB {'above' if level > 0 else 'below'} the reference record's "
                f"(x {10 ** (level / 20):.3g}): a {'louder' if level > 0 else 'quieter'} machine, or a sensor, mount or "
                "gain that changed")

    def _reference_lines(self) -> list[str]:
        """What changed since the reference record, measured against it directly (or why it was not)."""
        if self.since_reference is None:
            return [f"Not compared with the reference record: {self.reference_note}."] if self.reference_note else []
        level = f" Beside the shapes, {self.level_change}." if self.level_change else ""
        if not self.since_reference:
            also = (f" What was added ({', '.join(fit.effect for fit in self.added)}) was then in the reference record "
                    "too, where it was not found." if self.added else "")
            return ["Since the reference record (this measurement against it, no twin): nothing changed beyond the "
                    f"measurement's own part-to-part scatter{' in the shapes the views compare' if level else ''}."
                    f"{also}{level}"]
        changes = "; ".join(f"the {entry['view']} view ({entry['error_db']:.1f} dB, {entry['error_db'] / entry['floor_db']:.0f} "
                            f"times the measurement's own): {entry['where']}" for entry in self.since_reference)
        return [f"Changed since the reference record (this measurement against it, no twin): {changes}.{level}"]

    def _unclaimed_words(self) -> str:
        fit = self.unclaimed
        views = _listed(list(signature_views(fit.effect)))
        moved = (f"come only {fit.signature_gain:.1f} deviance units closer" if fit.signature_gain >= 0.05 else
                 "come no closer" if fit.signature_gain > -0.05 else
                 f"move {-fit.signature_gain:.1f} deviance units farther")
        return (f"{fit.effect} would pay for its parameters, but its signature's views ({views}) {moved} "
                f"(it needs {self.min_signature_gain:g} closer): what it would close lies elsewhere")

    def as_dict(self) -> dict:
        return {
            "verdict": self.verdict,
            "operating_point": self.operating_point,
            "gain": self.gain,
            "baseline_error": self.baseline_error,
            "floor_error": self.floor_error,
            "held_out": self.held_out,
            "base_params": self.base_params,
            "ranking": [fit.as_dict() for fit in self.ranking],
            "rounds": self.rounds,
            "pairs": self.pairs,
            "repeatability_db": self.repeatability_db,
            "margin": self.margin,
            "steps": [step.as_dict() for step in self.steps],
            "added": [fit.effect for fit in self.added],
            # each as kept: the re-fit's parameters and intervals, what it gains in its views (the ranking: the screen's)
            "added_effects": [fit.as_dict() for fit in self.added],
            "unexplained": self.unexplained,
            "unclaimed": None if self.unclaimed is None else self.unclaimed.as_dict(),
            "not_tried": self.not_tried,
            "found_nothing": self.found_nothing,
            "passed_over": self.passed_over,
            "awaiting": self.awaiting,
            "since_reference": self.since_reference,
            "level_since_reference_db": self.level_since_reference_db,
            "noise_reference_rms": self.noise_reference_rms,
            "level_not_compared": self.level_not_compared or None,
            "reference_note": self.reference_note,
            "final_error": self.final_error,
            "summary": self.summary,
        }


_UNITS = {"_hz": "Hz", "_db": "dB", "_n": "N", "_um": "um", "_mm": "mm", "_deg": "deg", "_ns_per_m": "N s/m"}


def _listed(names: list[str]) -> str:
    """"a", "a and b", "a, b and c"."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _number(value: float) -> str:
    """Three significant digits, in positional notation where an engineer would write it so."""
    if value != 0 and not 1e-3 <= abs(value) < 1e5:
        return f"{value:.3g}"
    return f"{float(f'{value:.3g}'):,.10g}".replace(",", "")


def _span(low: float, high: float) -> str:
    """"20-5000", or "-21.9 to -11" where a hyphen would read as a minus sign."""
    return f"{_number(low)} to {_number(high)}" if min(low, high) < 0 else f"{_number(low)}-{_number(high)}"


def _value(value: float, interval, unit: str = "") -> str:
    unit = f" {unit}" if unit else ""
    if interval is None or np.isclose(interval[0], interval[1], rtol=1e-6):
        return f"{_number(value)}{unit}"
    return f"{_number(value)}{unit} ({_span(*interval)})"


HARDLY_IDENTIFIED_SHARE = 0.9
"""An interval covering this share of its search range (on the range's own scale) leaves the value hardly identified."""


def sensor_not_identified(sensor: Mapping) -> bool:
    """Whether a fitted sensor direction's interval (the report's ``sensor`` entry) spans the half turn: the record
    tells hardly any direction from another."""
    interval = sensor.get("interval")
    return bool(interval) and interval[1] - interval[0] >= 180.0


def not_identified(entry: Mapping) -> bool:
    """Whether a fitted base parameter's interval spans its whole search range: any value in it fits as well."""
    search, interval = entry.get("range"), entry.get("interval")
    if not search or not interval:
        return False
    low, high = search
    slack = 1e-6 * (high - low)  # rounding of bounds of either sign
    return interval[0] <= low + slack and interval[1] >= high - slack


def interval_share(entry: Mapping) -> float:
    """The share of its search range a fitted base parameter's interval covers, on the range's own scale (0 in
    reports older than the ``scale`` key, and where there is no interval: none claimed)."""
    search, interval = entry.get("range"), entry.get("interval")
    if not search or not interval or not entry.get("scale"):
        return 0.0
    bounds = (search[0], search[1], entry["scale"] == "log")
    return to_unit(bounds, interval[1]) - to_unit(bounds, interval[0])


def hardly_identified(entry: Mapping) -> bool:
    """Whether a fitted operating-point value means little: any value in its search range fits as well, or nearly
    any (:data:`HARDLY_IDENTIFIED_SHARE`), or, for the sensor, any direction."""
    return (not_identified(entry) or interval_share(entry) >= HARDLY_IDENTIFIED_SHARE
            or sensor_not_identified(entry) or bool(entry.get("every_direction_fits")))


def identification_words(entry: Mapping) -> str:
    """What a fitted base parameter's interval says against its search range: nothing when it is inside, else that
    the value sits at an edge of the range, or that any value (or nearly any) in the range fits: then the number
    means little."""
    search, interval = entry.get("range"), entry.get("interval")
    if not search or not interval:
        return ""
    low, high = search
    if not_identified(entry):
        return f", not identified: anywhere in the searched {_span(low, high)} fits as well"
    share = interval_share(entry)
    if share >= HARDLY_IDENTIFIED_SHARE:
        # rounded down: an interval short of the whole range never reads "100 %"
        return f", hardly identified: its interval covers {math.floor(100 * share)}% of the searched {_span(low, high)}"
    for end, edge, side in ((interval[0], low, "lower"), (interval[1], high, "upper")):
        if not edge_words(entry["value"], low, high) and np.isclose(end, edge, rtol=1e-3):
            return f", its interval reaching the {side} edge of the searched {_span(low, high)}: the value may lie beyond it"
    return edge_words(entry["value"], low, high)


PARAMETER_REFERENCES = {"clip_level": "times the RMS", "one_x_db": "re the 2x line",
                        "half_order_db": "re the whole orders' lines", "fundamental_db": "re the 2x supply line",
                        "level_db": "re the bearing signal's RMS"}
"""What an effect parameter's number is relative to, as an engineer reads it beside the number
(:mod:`bearingtwin.physics.effect_library`'s docstrings); by effect where one differs (:data:`EFFECT_REFERENCES`)."""
EFFECT_REFERENCES = {("structural_mode", "level_db"): "re the direct path at its natural frequency",
                     ("tones", "level_offset_db"): "on every line's level as read"}


def _reference_words(effect: str, name: str) -> str:
    """" re the bearing signal's RMS" for a line's ``level_db``: what the parameter's number is relative to."""
    words = EFFECT_REFERENCES.get((effect, name), PARAMETER_REFERENCES.get(name))
    return f" {words}" if words else ""


def _range_words(value: float, interval, search: tuple) -> str:
    """What an effect parameter's value and interval say against its search range ``(low, high, log)``, as a base
    parameter's are said (:func:`identification_words`): hardly or not identified, or on an edge."""
    low, high, log = search[:3]
    if interval is None:
        return edge_words(value, low, high)
    return identification_words({"range": (low, high), "interval": interval, "value": value,
                                 "scale": "log" if log else "linear"})


def edge_words(value: float, low: float, high: float) -> str:
    """", at the lower edge of the searched 20-5000: the value may lie beyond it" where ``value`` sits on an edge of
    its search range, else ""."""
    for edge, side in ((low, "lower"), (high, "upper")):
        if np.isclose(value, edge, rtol=1e-3):
            return f", at the {side} edge of the searched {_span(low, high)}: the value may lie beyond it"
    return ""


def _parameter_words(name: str, value: float, interval=None) -> str:
    """"natural frequency 2260 Hz (2100-2400)" for ``natural_frequency_hz``."""
    for suffix, unit in sorted(_UNITS.items(), key=lambda item: -len(item[0])):
        if name.endswith(suffix):
            return f"{name[:-len(suffix)].replace('_', ' ')} {_value(value, interval, unit)}"
    return f"{name.replace('_', ' ')} {_value(value, interval)}"


def gain_words(gain: float, unit: str) -> str:
    """The sensor gain beside the one a record in ``unit`` at the twin's own level would give (1 in m/s^2, 0.102
    in g): the factor by which the record is stronger or weaker than the twin, which the gain takes up."""
    words = f"sensor gain {_number(gain)} (measurement unit per m/s^2"
    if acceleration_unit(unit) is None:
        return words + ")"
    return words + f"; a record in {acceleration_unit(unit)} at the twin's level gives {_number(acceleration_factor('m/s^2', unit))})"


def _operating_point_words(operating: Mapping, gain: float, unit: str = "") -> str:
    """The fitted base parameters with their intervals, then, apart, those the record does not identify (any value in
    the searched range fits as well): their fitted numbers mean little, so only the range is said."""
    parts, unidentified = [], []
    for name, entry in operating.items():
        if entry.get("held"):
            continue
        if name == "sensor":
            interval = entry.get("interval")
            within = ""
            if interval and sensor_not_identified(entry):
                within = (" (its direction not identified: every direction fits as well)" if entry.get("every_direction_fits")
                          else " (its direction hardly identified: the directions that fit span the half turn)")
            elif interval:
                within = f" (within {interval[0]:.0f} to {interval[1]:.0f} deg)"
            other = [r for r in entry["races_within_bound"] if r != entry["race"]]
            parts.append(f"sensor on the {entry['value']}{within}"
                         + (f", the {other[0]} race fits almost as well" if other else ""))
            continue
        label = BASE_PARAMETERS[name].description if name in BASE_PARAMETERS else name
        if not_identified(entry):
            unidentified.append(f"{label} over {_span(*entry['range'])} {entry.get('unit', '')}".rstrip())
        else:
            parts.append(f"{label} {_value(entry['value'], entry.get('interval'), entry.get('unit', ''))}"
                         + identification_words(entry))
    # The twin's level moves with what sets its impacts' force: where the record fixes one of those only loosely, the
    # gain takes up what it leaves, and only their product (the record's level) is the record's.
    loose = [BASE_PARAMETERS[name].description for name, entry in operating.items()
             if name in BASE_PARAMETERS and not entry.get("held") and hardly_identified(entry)]
    verb = "sets" if len(loose) == 1 else "set"
    parts.append(gain_words(gain, unit) + (f", not identified apart from the {' and the '.join(loose)}, which {verb} "
                                           "the twin's level too: only their product with it, the record's level, is"
                                           if loose else ""))
    text = "; ".join(parts)
    if unidentified:
        text += (". Not identified by this record (anywhere in the searched range fits as well): "
                 + ", ".join(unidentified))
    return text


class StageProgress:
    """A bar on stderr for each of the ranking's stages (the operating point, each round's candidates, each re-fit,
    the intervals), counting evaluations of the objective against the stage's budget; a search that converges
    early ends its stage short of it. Disabled (no one watching: a test, a benchmark, a log file), it shows nothing."""

    def __init__(self, enabled: bool):
        self._enabled = enabled
        self._bar = tqdm(disable=True)  # counts nothing until the first stage
        self._lock = threading.Lock()  # the candidates of a round are fitted in threads

    def __enter__(self) -> "StageProgress":
        return self

    def __exit__(self, *exc) -> None:
        self._bar.close()

    def stage(self, name: str, budget: int) -> None:
        self._bar.close()
        self._bar = tqdm(total=budget, desc=name, unit="eval", leave=False, disable=not self._enabled)

    def counted(self, objective: Callable[..., float]) -> Callable[..., float]:
        """``objective``, advancing the bar by one at each evaluation (one rejected by the model too)."""
        def run(*args):
            try:
                return objective(*args)
            finally:
                with self._lock:
                    self._bar.update()
        return run


class EffectRanker:
    """Calibrate the twin's operating point to a measurement, then find the effects it misses.

    Args:
        candidates: effect names to try (each needs a class with a ``search_space`` and a
            ``conf/effects/<name>.yaml``); one that ``requires`` others is offered once they are in. A
            fixed effect among them is offered as changed: its parameters fitted again from the held values
            (a reference's unbalance that has grown since), paid for as a new effect's.
        fixed_effects: effects known to be present, name -> parameters, always in the twin, held at these
            values unless named among the candidates and found changed.
        operating_point: what of the operating point is held and what fitted.
        n_trials_base: Optuna trials for the operating point.
        n_trials_effect: trials per candidate and round.
        n_trials_refine: trials re-fitting the operating point and every kept effect together.
        n_polish: local (Nelder-Mead) evaluations after the operating-point search and each re-fit.
        n_polish_effect: the same after each candidate's search (a screen: the one kept is re-fitted).
        max_effects: at most this many effects are added.
        points_per_view: independent values each view counts as in the information criterion (:class:`Judge`).
        view_floor_db: least repeatability assumed of any view, dB (:attr:`Judge.floors_db`).
        min_signature_gain: deviance drop an effect must bring within its signature's views to be claimed
            (module docstring; 0: the information criterion alone decides).
        pair_candidates: when the best candidate falls short of its signature, the candidates of most evidence
            that pay, this many, are fitted two by two, and a pair that shows both signatures is claimed
            (module docstring; 0 or 1: no pairs).
        n_jobs: threads screening the candidates of a round (each with its own twin; same result for any number).
        later_points_per_view: ``points_per_view`` of the information criterion and the signature rule from the
            second round on (None: the same); the fits do not depend on it.
        seed: seeds every Optuna sampler (each search gets its own derived seed; a candidate's screen from the
            round and its name, so the candidates offered beside it do not change it).
        progress: show the stages on stderr (:class:`StageProgress`).

    The arguments are taken as given: ``bearingtwin-twin`` checks them as settings
    (:func:`bearingtwin.twin.report.ranker_settings`) before it reads the measurement.
    """

    def __init__(self, candidates: Sequence[str], fixed_effects: Mapping[str, Mapping] | None = None,
                 operating_point: OperatingPoint | None = None, n_trials_base: int = 30,
                 n_trials_effect: int = 10, n_trials_refine: int = 16, n_polish: int = 30, n_polish_effect: int = 10,
                 max_effects: int = 3, points_per_view: float = 1.0, view_floor_db: float = 0.5,
                 min_signature_gain: float = 1.0, pair_candidates: int = 3, n_jobs: int = 1,
                 later_points_per_view: float | None = 6.0, seed: int = 0, progress: bool = False):
        self.candidates = list(candidates)
        self.fixed_effects = {k: dict(v or {}) for k, v in dict(fixed_effects or {}).items()}
        self.operating_point = operating_point or OperatingPoint()
        self.n_trials_base = n_trials_base
        self.n_trials_effect = n_trials_effect
        self.n_trials_refine = n_trials_refine
        self.n_polish = n_polish
        self.n_polish_effect = n_polish_effect
        self.points_per_view = points_per_view
        self.view_floor_db = view_floor_db
        self.min_signature_gain = min_signature_gain
        self.pair_candidates = pair_candidates
        self.n_jobs = n_jobs
        self.max_effects = max_effects
        self.later_points_per_view = later_points_per_view
        self.seed = seed
        self.progress = progress

    def fit(self, twin: TwinModel, measured: Recording, geometry: BearingGeometry,
            settings: CompareSettings | None = None) -> "EffectRanker":
        """Calibrate, rank and select; the outcome is in ``fit_`` (a :class:`TwinFit`)."""
        with StageProgress(self.progress) as progress:
            return self._fit(twin, measured, geometry, settings, progress)

    def _fit(self, twin: TwinModel, measured: Recording, geometry: BearingGeometry, settings: CompareSettings | None,
             progress: StageProgress) -> "EffectRanker":
        spaces = {name: effect_search_space(name, measured.fs) for name in self.candidates}
        held = set(self.fixed_effects)  # at their given values; a fixed effect found changed is fitted from then on
        judge = Judge.for_measurement(measured, geometry, settings or CompareSettings(), self.points_per_view,
                                      self.view_floor_db)
        # Later rounds may weigh the views otherwise: they judge what is left once an effect is in.
        later = judge if self.later_points_per_view is None else replace(judge, points_per_view=self.later_points_per_view)
        op = self.operating_point
        for group, keys in (("calibration.base", op.extra), ("calibration.base_held", op.extra_known)):
            for key in keys:
                twin.value(key, group)  # an unknown extra key is named before any simulation

        # 1. The operating point: the sensor on its grid inside every trial (no simulation), the rest by TPE.
        sensor_search: dict[tuple, tuple[dict, list]] = {}

        def base_deviance(values: Mapping) -> float:
            scored = []
            for sensor in op.sensor_options():
                signal = twin.signal(op.to_base(values, sensor), self.fixed_effects)
                scored.append((judge.deviance(judge.fit_part(signal)), sensor))
            best = min(scored, key=lambda s: s[0])
            sensor_search[_key(values)] = (best[1], scored)
            return best[0]

        def compare(base: Mapping, effects: Mapping, part: Comparator) -> Comparison:
            return part(twin.signal(base, effects))

        progress.stage("operating point", self.n_trials_base + self.n_polish if op.space else 1)
        base_fit = minimize(progress.counted(base_deviance), op.space, self.n_trials_base, self.seed,
                            start=op.start(twin.value), n_polish=self.n_polish)
        sensor, scored = sensor_search[_key(base_fit.params)]
        base_values = dict(base_fit.params)
        # The evaluations of the last fit of the final twin (the operating point's, or the last re-fit's):
        # the intervals follow them along ridges where parameters trade off.
        last_fit, base_prefix = base_fit, ""
        current_effects = dict(self.fixed_effects)
        base = op.to_base(base_values, sensor)
        current = compare(base, current_effects, judge.check_part)
        steps = [Step(dict(current_effects), current.discrepancy_db, current, dict(base))]

        # 2. Effects, greedily, each judged on the held-out part.
        ranking: list[EffectFit] = []
        found_nothing: list[str] = []
        rounds: list[list[dict]] = []
        added: list[EffectFit] = []
        pairs: list[dict] = []
        unclaimed = None
        remaining = [name for name in self.candidates if _offered_on(name, twin.fault)]
        round_index = 0

        def refitted(fit: EffectFit, scorer: Judge, attempt: int = 0):
            """The operating point and every kept effect re-fitted with ``fit`` in (``attempt``: which re-fit of
            the round, for its seed), and its signature's gain there over the twin before it, by ``scorer``."""
            progress.stage(f"re-fit with {fit.effect}", self.n_trials_refine + self.n_polish)
            refit_values, refit_sensor, effects, refit_fit, refit_scored = self._refit(
                fit, base_values, sensor, current_effects, held - {fit.effect}, judge, twin,
                seed=self.seed + 1000 * (round_index + 1) + 999 + attempt, progress=progress)
            refit = compare(op.to_base(refit_values, refit_sensor), effects, judge.check_part)
            gain = scorer.signature_gain(current, refit, signature_views(fit.effect))
            return (refit_values, refit_sensor, effects, refit_fit, refit_scored, refit), gain

        def keep(fit: EffectFit, refit_result, gain: float) -> None:
            nonlocal base_values, sensor, scored, last_fit, base_prefix, base, current, current_effects, unclaimed
            refit_values, refit_sensor, effects, refit_fit, refit_scored, refit = refit_result
            if unclaimed is not None and unclaimed.effect == fit.effect:  # passed over by a pair, claimed since
                unclaimed = None
            held.discard(fit.effect)
            base_values, sensor, scored = refit_values, refit_sensor, refit_scored
            last_fit, base_prefix = refit_fit, "base:"
            base = op.to_base(base_values, sensor)
            before, current = current, refit
            # The effect as kept (the re-fit): what it gains in its views, its parameters; the ranking keeps
            # the screen's.
            added.append(replace(fit, comparison=current, error=current.discrepancy_db,
                                 params=effects[fit.effect], explained=_explained(before, current),
                                 signature_gain=gain))
            current_effects = effects
            steps.append(Step(dict(current_effects), current.discrepancy_db, current, dict(base)))
            remaining.remove(fit.effect)

        while remaining and len(added) < self.max_effects:
            offered = [name for name in remaining if not _missing_requirements(name, current_effects)]
            seeds = [_screen_seed(self.seed, round_index, name) for name in offered]
            matched = _gain_matched(judge, twin.signal(base, current_effects))
            scorer = judge if round_index == 0 else later
            progress.stage(f"round {round_index + 1}: {len(offered)} candidate" + "s" * (len(offered) != 1),
                           len(offered) * (self.n_trials_effect + self.n_polish_effect))
            with ThreadPoolExecutor(max_workers=self.n_jobs) as pool:  # the solver and numpy release the GIL
                fits = list(pool.map(lambda name, seed: self._fit_candidate(
                    name, spaces[name], base, current_effects, held, current, judge, twin.fresh(), matched,
                    seed=seed, scorer=scorer, progress=progress), offered, seeds))
            if not fits:
                break
            fits.sort(key=lambda fit: -fit.evidence)
            rounds.append([{"effect": fit.effect, "evidence": fit.evidence, "error": fit.error,
                            "n_parameters": fit.n_parameters, "signature_gain": fit.signature_gain,
                            "views": _view_errors(fit.comparison)} for fit in fits])
            if round_index == 0:
                as_it_was = _view_errors(current)
                found_nothing = [fit.effect for fit in fits if _view_errors(fit.comparison) == as_it_was]
                ranking = [fit for fit in fits if fit.effect not in found_nothing]
            best = fits[0]
            if best.evidence <= 0:
                break

            refit_result, refit_gain = refitted(best, scorer)
            # The screen held the operating point, which was fitted without the candidate and may hold part of
            # its mark (a shallower defect, a heavier load standing in for a noise floor): the signature is
            # judged by the better of the screen and the re-fit with the operating point free.
            judged_gain = max(best.signature_gain, refit_gain)
            if judged_gain >= self.min_signature_gain:
                keep(best, refit_result, refit_gain)
            else:  # it pays, but not where its own mark would be: unless two candidates hide each other's mark
                pair = None
                if len(added) + 2 <= self.max_effects:
                    pair, tried = self._pair(fits, base, current_effects, held, judge, twin, round_index, scorer,
                                             progress)
                    pairs += tried
                if pair is None or best.effect not in (fit.effect for fit in pair):
                    # The ranking keeps what the screen saw; a pair claimed without it says why it was passed over.
                    unclaimed = replace(best, signature_gain=judged_gain)
                if pair is None:
                    break
                lead, follower = pair
                if lead.effect != best.effect:  # the best leading: its re-fit is the one above
                    refit_result, refit_gain = refitted(lead, scorer)
                keep(lead, refit_result, refit_gain)
                # The second from the first's re-fit (the operating point and the kept effects as it left them).
                keep(follower, *refitted(replace(follower, kept_params={}), scorer, attempt=1))
            round_index += 1

        # Intervals: each fitted value's slice of the final deviance on the first part, widened to the values
        # the last fit evaluated within the same tolerance.
        @progress.counted
        def final_deviance(values, effects):
            return judge.deviance(judge.fit_part(twin.signal(op.to_base(values, sensor), effects)))

        n_intervals = len(op.space) + sum(len(fit.space) for fit in added)
        progress.stage("intervals", 1 + 2 * len(SLICE_STEPS) * n_intervals)  # at most, both ways at every step
        best_deviance = final_deviance(base_values, current_effects)
        least = min(last_fit.error, best_deviance)  # a sensor placement tried after the last fit may fit better

        def widened(interval: tuple[float, float], trial_key: str) -> tuple[float, float]:
            if last_fit.error > least + CHI2_95_ONE_DOF:  # its trials ran at a placement far worse than the final one
                return interval
            seen = interval_from_trials(last_fit, trial_key, least, CHI2_95_ONE_DOF)
            return min(interval[0], seen[0]), max(interval[1], seen[1])

        for fit in added:
            fit.params = current_effects[fit.effect]  # as the last re-fit left it, which the report states
            space = fit.space

            def with_params(params, name=fit.effect):
                return final_deviance(base_values, {**current_effects, name: {**current_effects[name], **params}})

            fit.intervals = {k: widened(slice_interval(with_params, space, {k2: fit.params[k2] for k2 in space},
                                                       best_deviance, k, CHI2_95_ONE_DOF), f"effect:{fit.effect}:{k}")
                             for k in space}
        intervals = {name: widened(slice_interval(lambda p: final_deviance({**base_values, **p}, current_effects),
                                                  op.space, base_values, best_deviance, name, CHI2_95_ONE_DOF),
                                   base_prefix + name) for name in op.space}
        operating = self._operating_point_report(base_values, sensor, scored, intervals)
        floor = judge.fit_part.compare_profiles(judge.check_part.measured).discrepancy_db if judge.held_out else 0.0
        not_tried = self._not_tried(twin.fault)
        # Where nothing was tried, not_tried says why; otherwise the candidates this state could not tell, and those
        # whose required effects the twin never took, are named apart.
        passed_over = "" if not_tried else "; ".join(self._not_offered(twin.fault))
        awaiting = "" if not_tried else "; ".join(
            f"{name} (needs {_listed(list(missing))}, which the twin did not take)" for name, missing in
            self._waiting(twin.fault, current_effects))
        relative_noise = "noise" in current_effects and current_effects["noise"].get("reference_rms") is None
        self.fit_ = TwinFit(operating, dict(base), current.gain, steps[0].error, ranking, steps, added,
                            judge.unexplained(current), floor, judge.held_out, rounds, dict(judge.repeatability_db),
                            unclaimed, self.min_signature_gain, not_tried, pairs, passed_over=passed_over,
                            awaiting=awaiting, unit=measured.unit, found_nothing=found_nothing,
                            noise_reference_rms=twin.level_under("noise", base, current_effects) if relative_noise
                            else None)
        return self

    def _not_tried(self, fault: str) -> str:
        """Why the selection could try no candidate on a record of a ``fault`` bearing, in the setting's own
        words ("" when it could)."""
        if not self.candidates:
            return "the candidate list is empty (candidates=[])"
        if self.max_effects == 0:
            return "ranking.max_effects=0"
        elsewhere = self._not_offered(fault)
        waiting = [f"{name} needs {_listed(list(missing))}" for name, missing in self._waiting(fault, self.fixed_effects)]
        if len(waiting) == len(self.candidates):
            return f"each candidate needs another effect in the twin first ({'; '.join(waiting)})"
        if len(waiting) + len(elsewhere) == len(self.candidates):
            return f"no candidate could be offered: {'; '.join(elsewhere + waiting)}"
        return ""

    def _waiting(self, fault: str, effects) -> list[tuple[str, tuple[str, ...]]]:
        """The candidates a record of a ``fault`` bearing could be offered but for effects not among ``effects``,
        each with those it still needs."""
        return [(name, missing) for name in self.candidates
                if _offered_on(name, fault) and (missing := _missing_requirements(name, effects))]

    def _not_offered(self, fault: str) -> list[str]:
        """The candidates a record of a ``fault`` bearing cannot tell, each with why (:func:`_offered_only_words`)."""
        return [_offered_only_words(name) for name in self.candidates if not _offered_on(name, fault)]

    def _fit_candidate(self, name, space, base, current_effects, held, current, judge: Judge, twin, matched,
                       seed, scorer: Judge, progress: StageProgress) -> EffectFit:
        """Fit one candidate on the first part (starting from the data's own estimate when the effect
        offers one, read against ``matched``: the current twin, gain-matched; a fixed effect from its held
        values) and judge it on the held-out part, its evidence and signature gain by ``scorer`` (``judge``
        with the round's points per view).

        The effects already kept are fitted again with it: they were fitted without the candidate, so
        they took up part of its signature (a noise floor lowering the kurtosis a misalignment line
        also lowers), and held there they would make the missing effect look redundant. Only the
        candidate's parameters are new, so only they are paid for.
        """
        changed_from = dict(current_effects[name]) if name in held else None
        nominal = changed_from or {**effect_defaults(name), **(_initial_guess(name, judge, matched) or {})}
        kept = [other for other in current_effects if other not in held and other != name]
        trial_effects = {**current_effects, name: nominal}
        joint, start = _effects_space(trial_effects, [name, *kept], judge.fit_part.fs)

        def with_effect(params):
            return _with_effect_params(trial_effects, params)

        fit = minimize(progress.counted(lambda p: judge.deviance(judge.fit_part(twin.signal(base, with_effect(p))))),
                       joint, self.n_trials_effect, seed, start=start, n_polish=self.n_polish_effect)
        effects = with_effect(fit.params)
        checked = judge.check_part(twin.signal(base, effects))
        drop = (scorer.deviance(current) - scorer.deviance(checked)) / scorer.points_per_view
        evidence = scorer.points_per_view * drop - len(space) * scorer.penalty_per_parameter
        return EffectFit(name, effects[name], checked.discrepancy_db, _explained(current, checked), evidence, drop,
                         len(space), _signature(name), checked, space,
                         scorer.signature_gain(current, checked, signature_views(name)),
                         kept_params={other: effects[other] for other in kept}, changed_from=changed_from)

    def _pair(self, fits: Sequence[EffectFit], base, current_effects, held, judge: Judge, twin, round_index: int,
              scorer: Judge, progress: StageProgress) -> tuple[tuple[EffectFit, EffectFit] | None, list[dict]]:
        """The pair of the round's candidates that shows both signatures, in the order to claim them, or None;
        and every pair tried (its effects, each one's evidence and signature gain beside the other, qualified).

        The ``pair_candidates`` candidates of most evidence that pay (``fits``, most evidence first) are fitted
        two by two (the kept effects free beside them, as in a screen), each pair in the order it would be
        kept: the effect that shows its signature alone on its screen first, else the one of more evidence. A
        pair qualifies if each of its effects pays for its parameters beyond the other's screen, and the second
        (the first too, unless it showed its signature alone) brings its own signature's views
        ``min_signature_gain`` closer than that screen; of those, the one closest to the measurement is taken. The first is returned as its screen, the second as fitted in the pair, with
        ``claimed_beside`` naming the first; the first names the second only where it did not show its
        signature alone.
        """
        paying = [fit for fit in fits if fit.evidence > 0][:self.pair_candidates]
        qualified, tried = [], []
        for pair in itertools.combinations(paying, 2):
            lead, follower = sorted(pair, key=lambda fit: fit.signature_gain < self.min_signature_gain)
            names = (lead.effect, follower.effect)
            kept = [other for other in current_effects if other not in held and other not in names]
            trial_effects = {**current_effects, **lead.kept_params, lead.effect: lead.params,
                             follower.effect: follower.params}
            joint, start = _effects_space(trial_effects, [*names, *kept], judge.fit_part.fs)
            progress.stage(f"pair {' + '.join(names)}", self.n_trials_effect + self.n_polish_effect)
            fit = minimize(progress.counted(lambda p: judge.deviance(judge.fit_part(twin.signal(
                base, _with_effect_params(trial_effects, p))))), joint, self.n_trials_effect,
                _screen_seed(self.seed, round_index, "+".join(names)), start=start, n_polish=self.n_polish_effect)
            effects = _with_effect_params(trial_effects, fit.params)
            checked = judge.check_part(twin.signal(base, effects))
            beside = {}
            for one, other in ((lead, follower), (follower, lead)):
                drop = (scorer.deviance(other.comparison) - scorer.deviance(checked)) / scorer.points_per_view
                beside[one.effect] = replace(
                    one, params=effects[one.effect], error=checked.discrepancy_db, drop_per_point=drop,
                    explained=_explained(other.comparison, checked), comparison=checked,
                    evidence=scorer.points_per_view * drop - one.n_parameters * scorer.penalty_per_parameter,
                    signature_gain=scorer.signature_gain(other.comparison, checked, signature_views(one.effect)),
                    kept_params={name: effects[name] for name in kept}, claimed_beside=other.effect)
            # The first, if it showed its signature alone, has passed the rule a single effect passes: beside the
            # second it need only pay (a strong 1x line alone lowers the kurtosis a saturation lowers too).
            first, second, least = beside[lead.effect], beside[follower.effect], self.min_signature_gain
            shows = (first.evidence > 0 and second.evidence > 0 and second.signature_gain >= least
                     and (lead.signature_gain >= least or first.signature_gain >= least))
            tried.append({"round": round_index, "effects": list(names), "error": checked.discrepancy_db,
                          "evidence": {name: fit.evidence for name, fit in beside.items()},
                          "signature_gain": {name: fit.signature_gain for name, fit in beside.items()},
                          "qualified": shows})
            if shows:
                qualified.append((scorer.deviance(checked), lead, follower, beside))
        if not qualified:
            return None, tried
        _, lead, follower, beside = min(qualified, key=lambda entry: entry[0])
        alone = lead.signature_gain >= self.min_signature_gain
        return (replace(lead, claimed_beside=None if alone else follower.effect), beside[follower.effect]), tried

    def _refit(self, best: EffectFit, base_values, sensor, current_effects, held, judge: Judge, twin, seed,
               progress: StageProgress):
        """Re-fit the operating point together with every kept effect and the new one (the ``held`` fixed
        effects stay as they are).

        The operating point was fitted without the effect, so it absorbed part of it (a deeper
        defect standing in for a resonance); once the effect is in, all of them move.
        """
        op = self.operating_point
        effects = {**current_effects, **best.kept_params, best.effect: best.params}
        fitted = [name for name in effects if name not in held]
        effects_space, effects_start = _effects_space(effects, fitted, judge.fit_part.fs, prefix="effect:")
        space = {**{f"base:{k}": v for k, v in op.space.items()}, **effects_space}
        angle = sensor["simulator.sensor_angle_deg"]
        if op.angle_fitted:  # a direction: half a turn either side of the one placed reaches every other
            space["sensor:angle"] = (angle - 90.0, angle + 90.0, False)
        start = {**{f"base:{k}": v for k, v in base_values.items()}, **effects_start,
                 **({"sensor:angle": angle} if op.angle_fitted else {})}

        def split(params):
            values = {k[5:]: v for k, v in params.items() if k.startswith("base:")}
            new_sensor = dict(sensor)
            if "sensor:angle" in params:
                new_sensor["simulator.sensor_angle_deg"] = float(params["sensor:angle"] % 180.0)
            return values, new_sensor, _with_effect_params(effects, params, prefix="effect:")

        def deviance(params):
            values, new_sensor, new_effects = split(params)
            return judge.deviance(judge.fit_part(twin.signal(op.to_base(values, new_sensor), new_effects)))

        fit = minimize(progress.counted(deviance), space, self.n_trials_refine, seed, start=start,
                       n_polish=self.n_polish)
        values, new_sensor, new_effects = split(fit.params)
        # The sensor was placed without the effect; with it in, another race or direction may fit better.
        scored = [(judge.deviance(judge.fit_part(twin.signal(op.to_base(values, option), new_effects))), option)
                  for option in op.sensor_options()]
        score, option = min(scored, key=lambda s: s[0])
        if score < fit.error:
            new_sensor = option
        scored.append((min(score, fit.error), new_sensor))  # the placement chosen, with its deviance
        return values, new_sensor, new_effects, fit, scored

    def _operating_point_report(self, base_values, sensor, scored, intervals: Mapping) -> dict:
        """Each parameter held or fitted with its interval; the sensor's race and direction from the
        latest grid of placements (those within the 95 % bound of the best)."""
        op = self.operating_point
        report = {}
        for name, value in op.known.items():
            report[name] = {"value": value, "unit": BASE_PARAMETERS[name].unit, "held": True}

        def fitted(name: str, unit: str) -> dict:
            low, high, log = op.space[name]
            return {"value": base_values[name], "unit": unit, "held": False, "interval": list(intervals[name]),
                    "range": [low, high], "scale": "log" if log else "linear"}

        for name in op.free:
            report[name] = fitted(name, BASE_PARAMETERS[name].unit)
        for name, value in op.extra_known.items():
            report[name] = {"value": value, "unit": "", "held": True}
        for name in op.extra:
            report[name] = fitted(name, "")
        best = min(score for score, _ in scored)
        near = [s for score, s in scored if score <= best + CHI2_95_ONE_DOF]
        races = sorted({s["simulator.sensor"].split("_")[0] for s in near})
        chosen = sensor["simulator.sensor_angle_deg"]
        # Directions, not angles: 170 deg lies 10 deg from 0 deg, so the interval is read as offsets from the chosen
        # direction (within half a turn) and may run below 0 or past 180 (-30 to 30, 150 to 210: either side of
        # horizontal).
        offsets = [(s["simulator.sensor_angle_deg"] - chosen + 90.0) % 180.0 - 90.0
                   for s in near if s["simulator.sensor"] == sensor["simulator.sensor"]]
        # The bound ends somewhere before the nearest grid direction outside it: a grid step either side, or the
        # whole half turn where that reaches round (a lone direction within the bound is no 0-wide interval).
        step = op.angle_step_deg
        low, high = min(offsets) - step, max(offsets) + step
        if high - low >= 180.0:
            low, high = -90.0, 90.0
        interval = [chosen + low, chosen + high] if op.angle_fitted else None
        grid = len(op.sensor_options()) // len(op.races)  # directions searched on each race
        report["sensor"] = {"value": describe_sensor(sensor), "race": sensor["simulator.sensor"].split("_")[0],
                            "angle_deg": sensor["simulator.sensor_angle_deg"],
                            "held": len(op.races) == 1 and not op.angle_fitted,
                            "races_within_bound": races, "interval": interval,
                            "every_direction_fits": op.angle_fitted and len(set(offsets)) == grid}
        return report


def _screen_seed(seed: int, round_index: int, name: str) -> int:
    """The seed of a candidate's screen in a round: from the run's seed, the round and the effect's name, so a
    candidate is screened alike whatever others are offered beside it (``candidates=[...]`` narrowed or not)."""
    return derived_seed(seed, round_index, zlib.crc32(name.encode()))


def _key(values: Mapping) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in values.items()))


def _effects_space(effects: Mapping, names: Sequence[str], fs: float, prefix: str = "") -> tuple[dict, dict]:
    """The search space of the named effects' parameters on a record sampled at ``fs`` (Hz), keyed
    ``<prefix><effect>:<parameter>``, and its start: their values in ``effects``."""
    space, start = {}, {}
    for name in names:
        for parameter, bounds in effect_search_space(name, fs).items():
            space[f"{prefix}{name}:{parameter}"] = bounds
            if parameter in effects[name]:
                start[f"{prefix}{name}:{parameter}"] = effects[name][parameter]
    return space, start


def _with_effect_params(effects: Mapping, params: Mapping, prefix: str = "") -> dict:
    """Copies of ``effects`` with the values of ``params`` keyed as :func:`_effects_space` keys them set."""
    updated = {name: dict(values) for name, values in effects.items()}
    for key, value in params.items():
        if key.startswith(prefix):
            name, parameter = key[len(prefix):].split(":", 1)
            updated[name][parameter] = value
    return updated


def _explained(before: Comparison, after: Comparison) -> float:
    return (before.discrepancy_db - after.discrepancy_db) / before.discrepancy_db if before.discrepancy_db > 0 else 0.0


def _missing_requirements(name: str, effects) -> tuple[str, ...]:
    """The effects candidate ``name`` needs in the twin before it is offered (its class's ``requires``) that
    ``effects`` lacks."""
    return tuple(required for required in getattr(effect_class(name), "requires", ()) if required not in effects)


def _offered_on(name: str, fault: str) -> bool:
    """Whether a record of a ``fault`` bearing can tell the effect (its class's ``bearing_states``)."""
    states = effect_class(name).bearing_states
    return not states or fault in states


_STATE_WORDS = {"normal": "healthy", "inner": "inner-race faulty", "ball": "ball faulty", "outer": "outer-race faulty"}


def _offered_only_words(name: str) -> str:
    """``roughness (offered on a healthy bearing's record only)``."""
    states = " or ".join(_STATE_WORDS[state] for state in effect_class(name).bearing_states)
    return f"{name} (offered on a {states} bearing's record only)"


def signature_views(name: str) -> tuple[str, ...]:
    """The views the effect's signature shows in (every view if its class does not say)."""
    return tuple(getattr(effect_class(name), "signature_views", ())) or VIEWS


def _signature(name: str) -> str:
    return f"signature: {getattr(effect_class(name), 'signature', '')}"


def _gain_matched(judge: Judge, signal: np.ndarray) -> np.ndarray:
    """The twin's signal scaled by the gain that matches it to the first part of the measurement."""
    return judge.fit_part(signal).gain * signal[:judge.fit_part.measured_signal.size]


def _initial_guess(name, judge: Judge, matched: np.ndarray) -> dict | None:
    """The effect's own estimate from the measurement against the gain-matched current twin, if it offers one."""
    guess = getattr(effect_class(name), "initial_guess", None)
    if guess is None:
        return None
    return guess(judge.fit_part.measured_signal, matched, judge.fit_part.fs, judge.fit_part.rpm / 60.0)
