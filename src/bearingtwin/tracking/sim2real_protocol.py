"""The result of a pre-registered sim2real protocol: its runs' scores beside the physics baseline.

Each version of the protocol is a dated config, ``conf/experiment/sim2real_v<N>.yaml``, stated in
words in ``results/sim2real_protocol.md`` before its runs and never edited afterwards;
``+experiment=sim2real`` selects the version in force (the newest its own rule adopted). A version's
runs carry the tag ``experiment=<name>``;
:func:`protocol_headline` reads every FINISHED one (one per seed) and sets them beside the
physics baseline on the same test records: the envelope analysis of
:func:`bearingtwin.diagnosis.evidence.physics_evidence`, no learning, read on each whole record
and on each of the windows the version's classifier was scored on (the same cuts): a
classifier's windows compare with the physics' windows, its records with the physics' records.
"""

from __future__ import annotations

import csv
import logging
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mlflow import MlflowClient
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR, bearing_config, compose_config
from bearingtwin.data.cwru import load_cwru, parse_cwru_name
from bearingtwin.data.windows import cut_windows
from bearingtwin.diagnosis.evidence import physics_evidence
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.mlflow_logging import find_runs
from bearingtwin.tracking.reports import mean_std
from bearingtwin.tracking.tables import markdown_table

log = logging.getLogger(__name__)

FAULT_CLASSES = ("inner", "ball", "outer")
PROTOCOL_PREFIX = "sim2real_v"
"""Config names (and run tags) of the protocol's versions: ``conf/experiment/sim2real_v<N>.yaml``."""
PROTOCOL_MODEL = "sim2real"
"""The registered model of the protocol on the CWRU records (``register`` in ``conf/experiment/sim2real_v1.yaml``)."""


def protocol_versions(conf_dir: str | Path = CONF_DIR) -> dict[str, str]:
    """Every version of the sim2real protocol, oldest first: config name -> its label, "v2 (2026-11-23)",
    read from the header each version's file opens with ("# Protocol v2 (2026-11-23) of ...")."""
    versions = {}
    files = [path for path in Path(conf_dir, "experiment").glob(f"{PROTOCOL_PREFIX}*.yaml") if protocol_version(path.stem)]
    for path in sorted(files, key=lambda p: int(p.stem.rpartition("v")[2])):
        stated = re.search(r"Protocol (v\d+) \((\d{4}-\d{2}-\d{2})\)", path.read_text())
        if stated is None:
            raise BearingTwinError(f"{path}: a protocol version opens with '# Protocol v<N> (<date>)'")
        versions[path.stem] = f"{stated[1]} ({stated[2]})"
    return versions


def version_in_force(conf_dir: str | Path = CONF_DIR) -> str | None:
    """The version ``+experiment=sim2real`` selects (its config name, ``sim2real_v9``), read from the defaults
    list of ``conf/experiment/sim2real.yaml``; None when that file names no version."""
    path = Path(conf_dir, "experiment", "sim2real.yaml")
    defaults = OmegaConf.load(path).get("defaults", []) if path.exists() else []
    return next((entry for entry in defaults if isinstance(entry, str) and protocol_version(entry)), None)


@dataclass
class ProtocolResult:
    """Scores of a protocol's runs (fractions, one value per seed) and of the physics baseline."""

    experiment: str
    seeds: list[int]
    accuracy: list[float]
    recall: dict[str, list[float]]
    healthy_called_healthy: list[float]
    per_record: dict[str, list[float]]  # test record -> window accuracy per seed
    physics: dict[str, str]  # test records and the healthy record -> the state its envelope spectrum points to
    physics_windows: dict[str, float]  # the same records -> share of their scored windows the physics calls right
    window_length: int  # points per window the version scores
    windows_per_record: dict[str, int]  # the same records -> windows scored
    truth: dict[str, str]  # test record -> its state
    healthy_record: str  # the healthy calibration record, scored apart for false alarms
    physics_decided: list[float] | None = None  # share of test windows the physics decided (physics_first), per seed

    def physics_recall(self, state: str) -> float:
        """Share of the state's test records the physics calls right (NaN when the test holds none)."""
        records = [r for r, t in self.truth.items() if t == state]
        return float(np.mean([self.physics[r] == state for r in records])) if records else math.nan

    def physics_window_recall(self, state: str) -> float:
        """Share of the state's test windows the physics calls right (every record has as many windows;
        NaN when the test holds none of the state's records)."""
        shares = [self.physics_windows[r] for r, t in self.truth.items() if t == state]
        return float(np.mean(shares)) if shares else math.nan

    @property
    def physics_window_accuracy(self) -> float:
        return float(np.mean([self.physics_windows[r] for r in self.truth]))

    @property
    def physics_calls_healthy_record_healthy(self) -> bool:
        return self.physics[self.healthy_record] == "normal"


def protocol_version(tag: str) -> str | None:
    """The protocol version a run's ``experiment`` tag names (``sim2real_v2``), or None. Runs from before
    the versions had files of their own were tagged ``sim2real``: version 1."""
    if tag == "sim2real":
        return f"{PROTOCOL_PREFIX}1"
    return tag if re.fullmatch(rf"{PROTOCOL_PREFIX}\d+", tag) else None


def is_protocol_run(run) -> bool:
    """Whether ``run`` belongs to a version of the pre-registered protocol (reported apart from exploratory runs)."""
    return protocol_version(run.data.tags.get("experiment", "")) is not None


RESULT_GROUPS = ("bearing.", "simulator.", "effects.", "data.", "features.", "classifier.", "model.", "trainer.")
"""Config groups that decide a run's numbers: a protocol run must have logged them as the protocol fixes them."""


def departure_from_protocol(run, name: str) -> str | None:
    """The first setting ``run`` logged otherwise than protocol ``name`` fixes it, or None. Display settings
    (:data:`~bearingtwin.tracking.mlflow_logging.UNHASHED_KEYS`) do not count, nor locations (values with a
    path separator: the data folder, the calibration reports), which differ between machines."""
    from bearingtwin.tracking.mlflow_logging import UNHASHED_KEYS, flatten, loggable_config, physics_first_rule

    seed = run.data.params.get("seed", "0")
    fixed = flatten(loggable_config(compose_config("train", [f"+experiment={name}", f"seed={seed}"])))
    applied, protocol = physics_first_rule(run.data.params), physics_first_rule(fixed)
    if applied != protocol:  # a dict-valued key: its flattened params are not the protocol's keys when it is null
        return f"physics_first={applied} (the protocol: {protocol})"
    for key, value in fixed.items():
        logged = run.data.params.get(key)
        if key.startswith(UNHASHED_KEYS):
            continue
        if key.startswith(RESULT_GROUPS) and logged is not None and logged != value and "/" not in value:
            return f"{key}={logged} (the protocol: {value})"
    return None


def protocol_runs(client: MlflowClient, experiment_id: str, name: str) -> list:
    """The newest FINISHED run of every seed of protocol version ``name`` (none: []). A run tagged with the
    version that departs from it (a smoke test at small sizes, an override) is not the protocol's: it is
    left out, with a warning naming it."""
    tags = [name] + (["sim2real"] if name == f"{PROTOCOL_PREFIX}1" else [])
    runs = [run for tag in tags for run in find_runs(
        client, experiment_id, f"tags.experiment = '{tag}' and tags.`bt.kind` = 'train' and attributes.status = 'FINISHED'")]
    by_seed = {}
    for run in sorted(runs, key=lambda run: run.info.start_time):  # a re-run seed: its newest run
        departure = departure_from_protocol(run, name)
        if departure is not None:
            log.warning("run %s is tagged %s but has %s: left out of the protocol's result", run.info.run_id, name, departure)
            continue
        by_seed[int(run.data.params["seed"])] = run
    return [by_seed[seed] for seed in sorted(by_seed)]


def _per_record(client: MlflowClient, run_id: str) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as folder:
        path = client.download_artifacts(run_id, "per_record.csv", folder)
        return {Path(row["record"]).stem: float(row["accuracy"]) for row in csv.DictReader(open(path))}


def physics_baseline(windows_per_record: dict[Path, int], window_length: int, bearing: str,
                     channel: str = "DE") -> tuple[dict[str, str], dict[str, float]]:
    """Each CWRU record's physics evidence state (whole record, the diagnose defaults), and the share of
    its windows whose evidence names the record's state, the windows cut as training cuts its test and
    validation windows (:func:`cut_windows`). Each record is read once for both."""
    geometry = bearing_config(bearing)
    states, shares = {}, {}
    for path, n_windows in windows_per_record.items():
        recording = load_cwru(path, channel=channel)
        states[path.stem] = physics_evidence(recording.signal, recording.fs, recording.rpm, geometry).evidence_state
        windows, _ = cut_windows(recording.signal, window_length, n_windows)
        window_states = [physics_evidence(window, recording.fs, recording.rpm, geometry).evidence_state for window in windows]
        shares[path.stem] = float(np.mean(np.asarray(window_states) == parse_cwru_name(path.name).fault))
    return states, shares


def protocol_headline(client: MlflowClient, experiment_id: str, name: str, data_root: Path) -> ProtocolResult | None:
    """Protocol version ``name``'s runs (:func:`protocol_runs`) beside the physics baseline; None when it has not run."""
    runs = protocol_runs(client, experiment_id, name)
    if not runs:
        return None
    per_record = {}
    for run in runs:
        for record, accuracy in _per_record(client, run.info.run_id).items():
            per_record.setdefault(record, []).append(accuracy)
    healthy_record = runs[0].data.params["data.calibration.healthy.record"]
    paths = [data_root / f"{record}.mat" for record in [*per_record, healthy_record]]
    missing = [str(path) for path in paths if not path.is_file()]
    if missing:
        raise BearingTwinError(f"the physics baseline reads the test records themselves: {', '.join(missing)} missing")
    bearing = runs[0].data.params.get("data.bearing", "cwru_6205")
    # The windows as the protocol cuts them (its runs logged the same: protocol_runs leaves out any other).
    data = compose_config("train", [f"+experiment={name}"]).data
    window_length = int(data.window_length)
    windows = {path: int(data.test.windows_per_record) for path in paths if path.stem != healthy_record}
    windows[data_root / f"{healthy_record}.mat"] = int(data.calibration.validation_windows_per_record)
    physics, physics_windows = physics_baseline(windows, window_length, bearing)
    return ProtocolResult(
        experiment=name,
        seeds=[int(run.data.params["seed"]) for run in runs],
        accuracy=[run.data.metrics["accuracy"] for run in runs],
        recall={state: [run.data.metrics[f"recall_{state}"] for run in runs] for state in FAULT_CLASSES},
        healthy_called_healthy=[run.data.metrics["calibration_recall_normal"] for run in runs],
        per_record=per_record,
        physics=physics,
        physics_windows=physics_windows,
        window_length=window_length,
        windows_per_record={path.stem: n for path, n in windows.items()},
        truth={record: parse_cwru_name(f"{record}.mat").fault for record in per_record},
        healthy_record=healthy_record,
        physics_decided=([run.data.metrics["physics_decided"] for run in runs]
                         if all("physics_decided" in run.data.metrics for run in runs) else None),
    )


def _pm(values) -> str:
    """Percent, mean ± std over seeds, as every results table gives it (:func:`~bearingtwin.tracking.reports.mean_std`)."""
    mean, std = mean_std(100 * np.asarray(values, dtype=float))
    return f"{mean:.1f} ± {std:.1f}"


def _percent(share: float, digits: int) -> str:
    """A share as a percentage, or "—" where there is none (no test record of that state)."""
    return "—" if math.isnan(share) else f"{100 * share:.{digits}f}"


def _version_label(version: str, result: ProtocolResult, in_force: str | None) -> str:
    """"v8 (2026-11-28)", in bold and said to be in force when ``+experiment=sim2real`` selects it."""
    return f"**{version}, in force**" if result.experiment == in_force else version


def headline_markdown(results: dict[str, ProtocolResult], in_force: str | None = None) -> str:
    """The headline table: each version's test accuracy, per fault type and false alarms, beside the physics
    baseline. ``results``: label -> result, oldest first; ``in_force``: the config name of the version
    ``+experiment=sim2real`` selects, marked as such."""
    rows = [[f"{_version_label(version, result, in_force)} (`+experiment={result.experiment}`, "
             f"seeds {', '.join(map(str, result.seeds))})",
             _pm(result.accuracy), *(_pm(result.recall[state]) for state in FAULT_CLASSES),
             _pm(result.healthy_called_healthy)] for version, result in results.items()]
    # Where a version lets the physics decide windows (physics_first), how many it decided: its own column.
    decided = any(result.physics_decided is not None for result in results.values())
    if decided:
        for row, result in zip(rows, results.values()):
            row.append("—" if result.physics_decided is None else _pm(result.physics_decided))
    newest = list(results.values())[-1]
    scored_alike = {}  # versions scored on the same windows share one physics row
    for version, result in results.items():
        key = (result.window_length, tuple(sorted(result.windows_per_record.items())))
        scored_alike.setdefault(key, ([], result))[0].append(version.split(" ")[0])
    for versions, result in scored_alike.values():
        rows.append([f"physics baseline on the windows of {', '.join(versions)} ({result.window_length} points; "
                     "envelope analysis, no learning)",
                     f"{100 * result.physics_window_accuracy:.1f}",
                     *(_percent(result.physics_window_recall(state), 1) for state in FAULT_CLASSES),
                     f"{100 * result.physics_windows[result.healthy_record]:.1f}"])
    physics_records = [newest.physics[r] == newest.truth[r] for r in newest.per_record]
    rows.append(["physics baseline on the whole records (envelope analysis, no learning)",
                 f"{100 * np.mean(physics_records):.1f} ({sum(physics_records)}/{len(physics_records)} records)",
                 *(_percent(newest.physics_recall(state), 0) for state in FAULT_CLASSES),
                 f"(record {newest.healthy_record}: {'healthy' if newest.physics_calls_healthy_record_healthy else 'not healthy'})"])
    header = ["", "test windows right %", "inner %", "ball %", "outer %", f"{newest.healthy_record} windows called healthy %"]
    if decided:
        header.append("test windows the physics decided %")
        rows = [row + [""] * (len(header) - len(row)) for row in rows]
    return markdown_table(header, rows)


def per_record_markdown(results: dict[str, ProtocolResult]) -> str:
    """Every test record, one column of windows right per version, beside the physics baseline."""
    newest = list(results.values())[-1]
    records = sorted(newest.per_record, key=lambda r: (FAULT_CLASSES.index(newest.truth[r]), r))
    record_rows = [[record, newest.truth[record],
                    *(_pm(result.per_record[record]) if record in result.per_record else "-" for result in results.values()),
                    f"{100 * newest.physics_windows[record]:.0f}", newest.physics[record]] for record in records]
    versions = [version.split(" ")[0] for version in results]
    return ("Per test record (windows right, mean ± std over seeds; the physics baseline on the newest "
            "version's windows and on the whole record):\n\n") + markdown_table(
        ["record", "true state", *(f"{v} windows right %" for v in versions), "physics windows right %", "physics says"], record_rows)


def plot_headline(results: dict[str, ProtocolResult], path: Path, in_force: str | None = None) -> Path:
    """Per fault type: each version's window recall (mean and spread over seeds) beside the physics baseline;
    the version in force (``in_force``, a config name) is named so in the legend."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(7.5, 4.4))
    axes = figure.subplots()
    x = np.arange(len(FAULT_CLASSES) + 1)
    width = 0.8 / (len(results) + 1)
    for index, (version, result) in enumerate(results.items()):
        values = [result.recall[s] for s in FAULT_CLASSES] + [result.healthy_called_healthy]
        axes.bar(x + (index - len(results) / 2) * width, [100 * mean_std(v)[0] for v in values], width,
                 yerr=[100 * mean_std(v)[1] for v in values], label=f"twin-trained, {version}" + (", in force" if result.experiment == in_force else ""))
    newest = list(results.values())[-1]
    physics = [newest.physics_window_recall(s) for s in FAULT_CLASSES] + [newest.physics_windows[newest.healthy_record]]
    axes.bar(x + len(results) / 2 * width, 100 * np.asarray(physics), width,
             label=f"physics baseline ({newest.window_length}-point windows)", color="0.45")
    axes.set_xticks(x, [*FAULT_CLASSES, f"healthy {newest.healthy_record}\n(calibration)"])
    axes.set(ylabel="right (%)", ylim=(0, 105), title="Real CWRU records at 1-3 hp, twin-trained classifier vs envelope analysis")
    axes.axhline(90, color="grey", lw=0.7, ls=":")
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8, frameon=False)  # clear of the bars
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    return path
