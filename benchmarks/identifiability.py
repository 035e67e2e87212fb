"""Identifiability: hide effects in a measurement, see what ``bearingtwin-twin``'s ranking names.

Two sources of measurements:

* ``twin``: the twin itself at another operating point (load, clearance, defect depth, sensor
  direction), another random realization, a -40 dB sensor noise floor -- a self-test, which
  flatters because measurement and twin share every modelling choice;
* ``rig``: the independent test rig (:mod:`bearingtwin.testrig`: an impulse train through a
  2-DOF housing and sensor path, its own load zone and its own implementations of the effects),
  which shares no code with the twin.

Every case follows the workflow a user follows on a real rig. First a reference record of the
same rig at the same operating point, with nothing hidden, is held against the twin: the
effects found there are the rig's own (its transfer path, its noise floor) and the operating
point fitted there (sensor race and direction, load, clearance, defect size) is the rig's.
Then the case's record, with its hidden effects, is held against the twin with those effects
fixed and that operating point held (the gain is always fitted), as ``bearingtwin-twin
reference=<the reference's twin_report.json>`` holds them: what differs now is what was hidden. Case kinds: one hidden effect, a pair, none
(null), and one the library lacks (rig only). The conditions cycle through speeds, sampling rates
(12, 25.6, 48 kHz) and units (m/s^2, g). Each ranking is the CLI's defaults (every library
effect a candidate) on a 2 s record.

Scores: single -- the hidden effect is the first one added (also counted: first in the first
round's ranking, claimed or not, the goal's own wording); pair -- both are added; null -- none
is added; out of library -- no library effect is added; error halved -- the held-out
discrepancy at least halves when the hidden effect is found. An extra structural mode counts as
found whether it is added as ``resonance`` or, when the reference already needed a
``resonance`` for the rig's own path, as ``second_resonance``.

    python benchmarks/identifiability.py --split dev --jobs 2    # the development cases (seed 1)
    python benchmarks/identifiability.py --split test --jobs 2   # the benchmark: writes results/identifiability.{md,json}

The development split exists to choose the ranking's free constants (``ranking.points_per_view``,
``ranking.view_floor_db``, ``ranking.min_signature_gain``) on rig measurements; its cases use other seeds, parameter values and
conditions than the test split, whose numbers are the result.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.data.recording import Recording
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.testrig import RigOperatingPoint, RigSetup, simulate_rig
from bearingtwin.tracking.tables import markdown_table
from bearingtwin.twin.compare import CompareSettings
from bearingtwin.twin.model import TwinModel
from bearingtwin.twin.rank import deviance, penalty_per_parameter, signature_gain, signature_views, view_floors
from bearingtwin.twin.reference import hold_reference
from bearingtwin.twin.report import build_ranker, twin_for

G = 9.80665
SECONDS = 2.0
# The rig's residual unbalance line is off: "nothing hidden" must mean nothing the twin lacks, and a 1x
# line is exactly what the library's `unbalance` adds.
RIG = RigSetup(residual_1x_db=None)
# Hidden parameters per split: effect -> (twin's parameters, rig's parameters). None of them is a default.
HIDDEN = {
    "dev": {
        "resonance": ({"natural_frequency_hz": 2200.0, "damping_ratio": 0.04}, {"natural_frequency_hz": 2200.0, "damping_ratio": 0.04}),
        "second_resonance": ({"natural_frequency_hz": 1500.0, "damping_ratio": 0.04}, {"frequencies_hz": [1500.0], "damping_ratio": 0.04}),
        "slip": ({"jitter": 0.03}, {"jitter": 0.03}),
        "speed_fluctuation": ({"depth": 0.02, "frequency_hz": 5.0}, {"depth": 0.02, "frequency_hz": 5.0}),
        "noise": ({"snr_db": 3.0, "spectral_slope": 1.0}, {"snr_db": 3.0, "spectral_slope": 1.0}),
        "tones": ({"frequencies_hz": [83.0, 217.0], "levels_db": [-3.0, -6.0]}, {"frequencies_hz": [83.0, 217.0], "levels_db": [-3.0, -6.0]}),
        "lubrication": ({"stiffness_ratio": 0.6, "damping_ns_per_m": 2000.0}, {"stiffness_ratio": 0.6, "damping_ratio": 0.1}),
        "unbalance": ({"level_db": 0.0}, {"level_db": 0.0}),
        "misalignment": ({"level_db": 0.0}, {"level_db": 0.0}),
        "looseness": ({"level_db": 0.0}, {"level_db": 0.0}),
        "line_frequency": ({"supply_hz": 60.0, "level_db": 0.0}, {"supply_hz": 60.0, "level_db": 0.0}),
        "clipping": ({"clip_level": 2.0}, {"level_rms": 2.0}),
    },
    "test": {
        "resonance": ({"natural_frequency_hz": 3200.0, "damping_ratio": 0.03}, {"natural_frequency_hz": 3200.0, "damping_ratio": 0.03}),
        "second_resonance": ({"natural_frequency_hz": 1800.0, "damping_ratio": 0.03}, {"frequencies_hz": [1800.0], "damping_ratio": 0.03}),
        "slip": ({"jitter": 0.04}, {"jitter": 0.04}),
        "speed_fluctuation": ({"depth": 0.03, "frequency_hz": 3.0}, {"depth": 0.03, "frequency_hz": 3.0}),
        "noise": ({"snr_db": 0.0, "spectral_slope": 0.5}, {"snr_db": 0.0, "spectral_slope": 0.5}),
        "tones": ({"frequencies_hz": [47.0, 173.0, 311.0], "levels_db": [0.0, -3.0, -6.0]}, {"frequencies_hz": [47.0, 173.0, 311.0], "levels_db": [0.0, -3.0, -6.0]}),
        "lubrication": ({"stiffness_ratio": 0.5, "damping_ns_per_m": 3000.0}, {"stiffness_ratio": 0.5, "damping_ratio": 0.12}),
        "unbalance": ({"level_db": 3.0}, {"level_db": 3.0}),
        "misalignment": ({"level_db": 3.0}, {"level_db": 3.0}),
        "looseness": ({"level_db": 3.0}, {"level_db": 3.0}),
        "line_frequency": ({"supply_hz": 50.0, "level_db": 3.0}, {"supply_hz": 50.0, "level_db": 3.0}),
        "clipping": ({"clip_level": 1.8}, {"level_rms": 1.8}),
    },
}
# A lone extra mode is `resonance`; `second_resonance` is hidden only beside it, as a pair.
PAIRS = {"dev": [("resonance", "unbalance"), ("slip", "noise"), ("resonance", "second_resonance")],
         "test": [("resonance", "tones"), ("misalignment", "noise"), ("slip", "line_frequency"),
                  ("unbalance", "clipping"), ("resonance", "second_resonance")]}
OUT_OF_LIBRARY_PARAMS = {
    "dev": {"gear_mesh": {"n_teeth": 23, "level_db": 0.0, "modulation_depth": 0.3},
            "am_interference": {"carrier_hz": 2900.0, "modulation_hz": 41.0, "depth": 0.8, "level_db": 0.0}},
    "test": {"gear_mesh": {"n_teeth": 29, "level_db": 0.0, "modulation_depth": 0.4},
             "rub": {"level_db": 0.0, "contact_fraction": 0.1},
             "am_interference": {"carrier_hz": 3300.0, "modulation_hz": 37.0, "depth": 0.8, "level_db": 0.0},
             "cable_crackle": {"rate_per_s": 4.0, "dropout_ms": 2.0, "spike_level_rms": 8.0}},
}
# Conditions: (rpm, fs Hz, unit), cycled through the cases; the operating point the ranking is not told.
CONDITIONS = {"dev": [(1797.0, 12000.0, "g")],
              "test": [(1772.0, 12000.0, "g"), (1750.0, 25600.0, "m/s^2"), (1730.0, 48000.0, "g")]}
OPERATING = {"dev": [{"radial_load_n": 700.0, "clearance_um": 6.0, "sensor_angle_deg": 90.0}],
             "test": [{"radial_load_n": 1200.0, "clearance_um": 4.0, "sensor_angle_deg": 90.0},
                      {"radial_load_n": 500.0, "clearance_um": 8.0, "sensor_angle_deg": 60.0}]}
FAULTS = ("outer", "inner")
SEED = {"dev": 1, "test": 2}


def cases(split: str, sources: list[str]) -> list[dict]:
    """Every case of a split, each with its source, kind, hidden effects, fault and conditions."""
    listed = []
    for source in sources:
        kinds = [("single", (name,)) for name in HIDDEN[split] if name != "second_resonance"]
        kinds += [("pair", pair) for pair in PAIRS[split]]
        kinds += [("null", ())]
        if source == "rig":
            kinds += [("out_of_library", (name,)) for name in OUT_OF_LIBRARY_PARAMS[split]]
        for fault in FAULTS:
            for kind, names in kinds:
                index = len(listed)
                rpm, fs, unit = CONDITIONS[split][index % len(CONDITIONS[split])]
                operating = OPERATING[split][index % len(OPERATING[split])]
                listed.append({"split": split, "source": source, "kind": kind, "hidden": list(names), "fault": fault,
                               "rpm": rpm, "fs": fs, "unit": unit, "operating": operating,
                               "seed": SEED[split] * 1000 + index})
    return listed


def _effect_params(case: dict) -> dict:
    split, column = case["split"], 0 if case["source"] == "twin" else 1
    effects = {name: (OUT_OF_LIBRARY_PARAMS[split][name] if case["kind"] == "out_of_library"
                      else HIDDEN[split][name][column]) for name in case["hidden"]}
    if case["source"] == "rig" and "second_resonance" in effects:
        # The rig's second_resonance adds two modes: the first one's and its own.
        first = effects.pop("resonance")
        effects["second_resonance"] = {**effects["second_resonance"], "frequencies_hz": [
            first["natural_frequency_hz"], *effects["second_resonance"]["frequencies_hz"]]}
    return effects


def measurement(case: dict, cfg) -> Recording:
    """The hidden-effect record of ``case``, ``SECONDS`` long, in its unit."""
    op = case["operating"]
    effects = _effect_params(case)
    if case["source"] == "rig":
        point = RigOperatingPoint(rpm=case["rpm"], fs=case["fs"], duration_s=SECONDS, radial_load_n=op["radial_load_n"],
                                  clearance_um=op["clearance_um"], sensor_angle_deg=op["sensor_angle_deg"],
                                  unit=case["unit"])
        signal = simulate_rig(case["fault"], point, effects, seed=case["seed"], setup=RIG)
    else:
        simulator = OmegaConf.to_container(cfg.simulator, resolve=True)
        simulator.update(rpm=case["rpm"], fs=case["fs"], duration=SECONDS)
        truth = TwinModel(case["fault"], cfg.bearing, simulator, seed=case["seed"])
        base = {"simulator.load_y_n": -op["radial_load_n"], "bearing.clearance_mm": op["clearance_um"] / 1000,
                "simulator.defect.depth_mm": 0.004, "simulator.sensor": "outer_x",
                "simulator.sensor_angle_deg": op["sensor_angle_deg"]}
        clean = truth.signal(base, effects)
        bare = truth.signal(base) if effects else clean
        floor = np.random.default_rng(case["seed"]).standard_normal(clean.size)  # a sensor's -40 dB floor
        signal = clean + 0.01 * np.sqrt(np.mean(bare**2)) * floor
        signal = signal / G if case["unit"] == "g" else signal
    return Recording(signal, case["fs"], case["rpm"], case["fault"], source=f"{case['source']} {case['kind']}",
                     unit=case["unit"])


def ranking_settings(overrides: list[str]) -> dict:
    """The ``ranking`` block ``bearingtwin-twin`` composes with ``overrides``."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=["measured.path=unused", *overrides])
    return OmegaConf.to_container(cfg.ranking, resolve=True)


def rank(case: dict, overrides: list[str], reference: dict | None = None):
    """``bearingtwin-twin``'s ranking of the case's record; with ``reference`` (a reference's twin report),
    what that found held, as ``bearingtwin-twin reference=<its twin_report.json>`` holds it."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=["bearing=cwru_6205", "measured.path=unused", "tracking.enabled=false",
                                         f"seed={case['seed'] % 1000}", *overrides])
    if reference:
        cfg = hold_reference(cfg, reference, case["fault"])
    measured = measurement(case, cfg)
    geometry = BearingGeometry.from_config(cfg.bearing)
    settings = CompareSettings.from_config(OmegaConf.to_container(cfg.compare, resolve=True))
    ranker = build_ranker(cfg, case["fault"])
    start = time.perf_counter()
    fit = ranker.fit(twin_for(measured, cfg), measured, geometry, settings).fit_
    return fit, time.perf_counter() - start


def _reference_key(case: dict) -> tuple:
    return (case["source"], case["fault"], case["rpm"], case["fs"], case["unit"],
            tuple(sorted(case["operating"].items())))


def reference_of(case: dict) -> dict:
    """The case's reference: same rig, operating point and conditions, nothing hidden, another realization."""
    return {**case, "kind": "reference", "hidden": [], "seed": case["seed"] + 500}


def run_reference(case: dict, overrides: list[str]) -> dict:
    """The reference record's twin report (what ``bearingtwin-twin`` writes of it) and its time."""
    fit, seconds = rank(reference_of(case), overrides)
    return {"measured": {"fault": case["fault"]}, **fit.as_dict(), "seconds": seconds}


def run_case(case: dict, overrides: list[str], reference: dict) -> dict:
    fit, seconds = rank(case, overrides, reference)
    added = [f.effect for f in fit.added]
    sensor = fit.operating_point["sensor"]
    held = reference["operating_point"]
    return {
        **case, "reference_effects": list(reference["steps"][-1]["params"]),
        "reference_sensor": [held["sensor"]["race"], held["sensor"]["angle_deg"]],
        "added": added, "verdict": fit.verdict, "seconds": seconds, "reference_seconds": reference["seconds"],
        "reference_base": {name: entry["value"] for name, entry in held.items() if name != "sensor"},
        "ranking": [(f.effect, f.drop_per_point, f.n_parameters, f.evidence) for f in fit.ranking],
        "rounds": fit.rounds, "repeatability_db": fit.repeatability_db,
        "margin": fit.margin, "baseline_error": fit.baseline_error, "final_error": fit.final_error,
        "floor_error": fit.floor_error, "unexplained": [u["view"] for u in fit.unexplained],
        "steps": [s.error for s in fit.steps],
        "step_views": [s.as_dict()["views"] for s in fit.steps],
        "fitted_load_n": fit.operating_point.get("radial_load_n", {}).get("value"),
        "fitted_sensor": [sensor["race"], sensor["angle_deg"], sensor["interval"]],
    }


MODE = {"second_resonance": "resonance", "structural_mode": "resonance"}
"""An extra structural mode is one finding, under either name."""


def score(result: dict) -> dict:
    kind = result["kind"]
    hidden = [MODE.get(name, name) for name in result["hidden"]]
    added = [MODE.get(name, name) for name in result["added"]]
    if kind == "pair" and hidden == ["resonance", "resonance"]:
        return {"right": added.count("resonance") >= 2, "halved": None, "ranked_first": None}
    ranked_first = None
    if kind == "single":
        right = bool(added) and added[0] == hidden[0]
        ranked_first = bool(result["ranking"]) and MODE.get(result["ranking"][0][0], result["ranking"][0][0]) == hidden[0]
    elif kind == "pair":
        right = set(hidden) <= set(added)
    else:
        right = not added
    found = [h for h in hidden if h in added]
    halved = None
    if kind in ("single", "pair") and found:
        halved = result["final_error"] <= 0.5 * result["baseline_error"]
    return {"right": right, "halved": halved, "ranked_first": ranked_first}


POINTS_GRID = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)
VIEW_FLOOR_GRID = (0.3, 0.5, 1.0, 2.0)
SIGNATURE_GAIN_GRID = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0)


def first_round_evidence(result: dict, points_per_view: float, view_floor_db: float) -> list[tuple[float, float, str]]:
    """Each first-round candidate's evidence and signature gain as the judge would give them with these
    constants (the judge's own deviance and penalty, the views weighted as configured by default): the
    deviance's drop from the twin before the round minus the candidate's parameters times the penalty,
    and the drop within the views its signature shows in."""
    floors = view_floors(result["repeatability_db"], view_floor_db)
    weights = CompareSettings().weights
    before = deviance(result["step_views"][0], floors, weights, points_per_view)
    penalty = penalty_per_parameter(points_per_view, weights)
    return [(before - deviance(c["views"], floors, weights, points_per_view) - c["n_parameters"] * penalty,
             signature_gain(result["step_views"][0], c["views"], floors, weights, points_per_view,
                            signature_views(c["effect"])),
             c["effect"]) for c in (result["rounds"][0] if result["rounds"] else [])]


def first_round_right(result: dict, points_per_view: float, view_floor_db: float, min_signature_gain: float) -> bool:
    """Whether the first round's decision would be right with these constants: the candidate with the
    most evidence, if it pays and gains ``min_signature_gain`` in its signature's views, else none."""
    evidence = first_round_evidence(result, points_per_view, view_floor_db)
    best, gain, name = max(evidence) if evidence else (-1.0, 0.0, None)
    first = MODE.get(name, name) if best > 0 and gain >= min_signature_gain else None
    hidden = [MODE.get(h, h) for h in result["hidden"]]
    if result["kind"] in ("single", "pair"):
        return first in hidden
    return first is None


def first_round_rates(results: list[dict], kinds: list[str], points_per_view: float, view_floor_db: float,
                      min_signature_gain: float) -> list[float]:
    """Per case kind, the share of cases whose first-round decision would be right with these constants."""
    return [float(np.mean([first_round_right(r, points_per_view, view_floor_db, min_signature_gain)
                           for r in results if r["kind"] == kind])) for kind in kinds]


def choose_decision_constants(results: list[dict], min_signature_gain: float) -> tuple[tuple[float, float], list[list[str]]]:
    """The (points_per_view, view_floor_db) whose first-round decisions are right most often, each case
    kind weighing the same; ties go to fewer points, then to the lower floor."""
    kinds = sorted({r["kind"] for r in results})
    rows, best = [], (-1.0, 0.0, 0.0)
    for floor in VIEW_FLOOR_GRID:
        for points in POINTS_GRID:
            rates = first_round_rates(results, kinds, points, floor, min_signature_gain)
            rows.append([f"{points:g}", f"{floor:g}", *[f"{rate:.0%}" for rate in rates], f"{np.mean(rates):.0%}"])
            best = max(best, (float(np.mean(rates)), -points, -floor))
    return (-best[1], -best[2]), [["points_per_view", "view_floor_db", *kinds, "mean"], *rows]


def choose_signature_gain(results: list[dict], points_per_view: float, view_floor_db: float):
    """The ``ranking.min_signature_gain`` of :data:`SIGNATURE_GAIN_GRID` whose first-round decisions are
    right most often at the configured constants, each case kind weighing the same; ties go to the lower."""
    kinds = sorted({r["kind"] for r in results})
    rows, best = [], (-1.0, 0.0)
    for gain in SIGNATURE_GAIN_GRID:
        rates = first_round_rates(results, kinds, points_per_view, view_floor_db, gain)
        rows.append([f"{gain:g}", *[f"{rate:.0%}" for rate in rates], f"{np.mean(rates):.0%}"])
        best = max(best, (float(np.mean(rates)), -gain))
    return -best[1], [["min_signature_gain", *kinds, "mean"], *rows]


def summarize(results: list[dict]) -> dict:
    """Per source and kind: cases right out of all, and cases with the error halved."""
    table = {}
    for r in results:
        s = score(r)
        entry = table.setdefault(r["source"], {}).setdefault(r["kind"], {"right": 0, "n": 0, "halved": 0, "found": 0,
                                                                        "ranked_first": 0})
        entry["n"] += 1
        entry["right"] += s["right"]
        entry["ranked_first"] += bool(s["ranked_first"])
        if s["halved"] is not None:
            entry["found"] += 1
            entry["halved"] += s["halved"]
    return table


def confusion(results: list[dict], source: str) -> str:
    """Single-effect cases: hidden effect (rows) against the first effect added (columns)."""
    singles = [r for r in results if r["source"] == source and r["kind"] == "single"]
    names = list(dict.fromkeys(r["hidden"][0] for r in singles))
    columns = names + sorted({(r["added"] or ["none"])[0] for r in singles} - set(names))
    counts = Counter((r["hidden"][0], (r["added"] or ["none"])[0]) for r in singles)
    rows = [[name] + [str(counts[(name, c)] or "") for c in columns] for name in names]
    return markdown_table(["hidden \\ added first", *columns], rows)


def plot_rates(table: dict, goals: dict, path: Path) -> None:
    """Share of cases right per kind, twin -> twin beside twin -> rig, with the goals marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = list(goals)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for offset, (source, label) in zip((-0.2, 0.2), (("twin", "twin -> twin (self-test)"),
                                                    ("rig", "twin -> independent rig"))):
        rates = [table.get(source, {}).get(k, {}) for k in kinds]
        heights = [100 * e["right"] / e["n"] if e else np.nan for e in rates]
        ax.bar(np.arange(len(kinds)) + offset, heights, width=0.4, label=label)
    for index, kind in enumerate(kinds):
        ax.hlines(100 * goals[kind], index - 0.4, index + 0.4, colors="k", linestyles="--", lw=1)
    ax.set_xticks(range(len(kinds)), [k.replace("_", " ") for k in kinds])
    ax.set(ylabel="cases right (%)", ylim=(0, 105), title="dashed: goal")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


DISCUSSION = "\n## Discussion\n"
"""The heading from which results/identifiability.md is written by hand (kept when the tables are regenerated)."""


def write_results(results: list[dict], out: Path, command: str, wall_s: float) -> None:
    table = summarize(results)
    rate = {"single": "hidden single effect added first", "pair": "both effects of a pair added",
            "null": "nothing added on a null case", "out_of_library": "no library effect claimed (out of library)"}
    goals = {"single": 0.9, "pair": 0.8, "null": 0.9, "out_of_library": 0.8}
    # The goal's own wording for single effects: first in the ranking, whether claimed or not.
    counted = [(rate["single"], "single", "right"),
               ("hidden single effect ranked first (claimed or not)", "single", "ranked_first"),
               *((rate[kind], kind, "right") for kind in ("pair", "null", "out_of_library"))]
    rows = []
    for label, kind, key in counted:
        row = [label, f"{goals[kind]:.0%}"]
        for source in ("twin", "rig"):
            entry = table.get(source, {}).get(kind)
            row.append(f"{entry[key]}/{entry['n']} ({entry[key] / entry['n']:.0%})" if entry else "—")
        rows.append(row)
    halved = []
    for source in ("twin", "rig"):
        found = sum(e["found"] for k, e in table.get(source, {}).items())
        ok = sum(e["halved"] for k, e in table.get(source, {}).items())
        halved.append(f"{ok}/{found}" if found else "—")
    rows.append(["error at least halved when a hidden effect is found", "all", *halved])
    times = [r["seconds"] for r in results]
    by_fs = {fs: np.median([r["seconds"] for r in results if r["fs"] == fs]) for fs in sorted({r["fs"] for r in results})}
    misses = [[r["source"], r["kind"], r["fault"], ", ".join(r["hidden"]) or "none", f"{r['fs']:g}", r["unit"],
               ", ".join(r["added"]) or "none",
               ", ".join(f"{c['effect']} {c['evidence']:.1f} ({c['signature_gain']:.1f})" for c in r["rounds"][0][:3])
               if r["rounds"] else "—",
               ", ".join(r["unexplained"]) or "—"]
              for r in results if not score(r)["right"]]
    machine = f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    text = [
        "# Identifiability: does the ranking name the missing physics?", "",
        "Effects hidden in a measurement, named (or not) by `bearingtwin-twin`'s compare-calibrate-rank with its "
        "defaults: the operating point fitted (sensor race and direction, load, clearance, defect size, gain), "
        "then every library effect a candidate, added only when it pays for its parameters on the held-out half "
        "and brings the twin closer in the views its own signature shows in. "
        "`twin` measurements come from the twin itself (a self-test); `rig` measurements from the independent "
        "test rig, which shares no code with the twin.", "",
        markdown_table(["case kind", "goal", "twin -> twin (self-test)", "twin -> independent rig"], rows), "",
        "![cases right per kind against the goals](identifiability.png)", "",
        f"Regenerate ({wall_s / 60:.0f} min on {machine}):", "", "```bash", command, "```", "",
        "## Hidden single effects: what was added first", "",
        "### Twin -> independent rig", "", confusion(results, "rig"), "",
        "### Twin -> twin (self-test)", "", confusion(results, "twin"), "",
        "## How the cases were made", "",
        f"Each case is a {SECONDS:g} s record at one of the conditions (rpm, fs, unit) "
        f"{', '.join(f'({r:g}, {f:g} Hz, {u})' for r, f, u in CONDITIONS['test'])}, an outer- or inner-race "
        "defect, and an operating point the ranking is not told "
        f"({'; '.join(', '.join(f'{k} {v:g}' for k, v in o.items()) for o in OPERATING['test'])}). "
        "Hidden parameters differ from every configured default and from the development split's, on which "
        "`ranking.points_per_view`, `ranking.view_floor_db` and `ranking.min_signature_gain` were chosen "
        "(`--split dev`).", "",
        f"Speed: median compare-calibrate-rank {np.median(times):.0f} s per case "
        f"({', '.join(f'{fs / 1000:g} kHz {t:.0f} s' for fs, t in by_fs.items())}), {len(results[0]['ranking'])} "
        "candidates offered in the first round, one process per case.", "",
        "## Misses", "",
        markdown_table(["source", "kind", "fault", "hidden", "fs", "unit", "added", "first-round evidence (signature gain)",
                        "unexplained views"], misses) if misses else "None.", "",
    ]
    out.mkdir(parents=True, exist_ok=True)
    plot_rates(table, goals, out / "identifiability.png")
    path = out / "identifiability.md"
    # The discussion is written by hand below the generated sections; a new run keeps it.
    kept = path.read_text() if path.is_file() else ""
    kept = kept[kept.index(DISCUSSION):] if DISCUSSION in kept else ""
    path.write_text("\n".join(text) + kept)
    (out / "identifiability.json").write_text(json.dumps(results, indent=1, default=float))
    print(out / "identifiability.md")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", choices=("dev", "test"), default="test")
    parser.add_argument("--sources", default="twin,rig")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default=None,
                        help="folder for identifiability.{md,json,png} (default: results for the whole test split, "
                             "else a folder under the system's temporary directory)")
    parser.add_argument("--faults", default="outer,inner", help="defect types of the cases")
    parser.add_argument("--limit", type=int, default=None, help="run only the first N cases (a quick look)")
    parser.add_argument("overrides", nargs="*", help="bearingtwin-twin overrides, e.g. ranking.points_per_view=3")
    args = parser.parse_args()
    # The committed results are the whole test split's at the defaults: a part of it, another split or other
    # settings are written elsewhere, and never over them.
    whole = (args.split == "test" and args.sources == "twin,rig" and args.faults == "outer,inner"
             and args.limit is None and all(o.startswith("ranking.n_jobs=") for o in args.overrides))
    if args.out is None:
        args.out = "results" if whole else str(Path(tempfile.gettempdir()) / f"bearingtwin-identifiability-{args.split}")
    elif not whole and Path(args.out).resolve() == (Path(__file__).resolve().parents[1] / "results"):
        parser.error(f"--out {args.out}: the committed results are the whole test split's at the defaults; "
                     "write a part, another split or other settings elsewhere")
    import joblib
    from tqdm.auto import tqdm

    todo = [case for case in cases(args.split, args.sources.split(",")) if case["fault"] in args.faults.split(",")]
    todo = todo[: args.limit]
    start = time.perf_counter()
    keys = list(dict.fromkeys(_reference_key(case) for case in todo))
    first_of = {key: next(case for case in todo if _reference_key(case) == key) for key in keys}
    references = dict(zip(keys, tqdm(joblib.Parallel(n_jobs=args.jobs, return_as="generator")(
        joblib.delayed(run_reference)(first_of[key], args.overrides) for key in keys), total=len(keys),
        desc="references")))
    results = list(tqdm(joblib.Parallel(n_jobs=args.jobs, return_as="generator")(
        joblib.delayed(run_case)(case, args.overrides, references[_reference_key(case)]) for case in todo),
        total=len(todo), desc="cases"))
    wall = time.perf_counter() - start
    table = summarize(results)
    for source, kinds in table.items():
        print(source, {k: f"{e['right']}/{e['n']}, halved {e['halved']}/{e['found']}" for k, e in kinds.items()})
    if args.split == "dev":
        Path(args.out).mkdir(parents=True, exist_ok=True)
        Path(args.out, "identifiability_dev.json").write_text(json.dumps(results, indent=1, default=float))
        print(f"written: {Path(args.out, 'identifiability_dev.json')}")
        ranking = ranking_settings(args.overrides)
        gain, rows = choose_signature_gain(results, ranking["points_per_view"], ranking["view_floor_db"])
        print(markdown_table(rows[0], rows[1:]))
        print(f"ranking.min_signature_gain={gain:g} decides the first round right most often at "
              f"ranking.points_per_view={ranking['points_per_view']:g} ranking.view_floor_db={ranking['view_floor_db']:g}"
              " (ties: the lower gain)")
        (points, floor), rows = choose_decision_constants(results, ranking["min_signature_gain"])
        print(markdown_table(rows[0], rows[1:]))
        print(f"ranking.points_per_view={points:g} ranking.view_floor_db={floor:g} decide the first round right "
              f"most often at ranking.min_signature_gain={ranking['min_signature_gain']:g} (ties: fewer points, "
              "then the lower floor)")
        return 0
    command = "python benchmarks/identifiability.py " + " ".join(sys.argv[1:])
    write_results(results, Path(args.out), command.strip(), wall)
    return 0


if __name__ == "__main__":
    sys.exit(main())
