"""From a composed ``twin`` config to a calibrated, ranked twin: the report, its figures, its MLflow run.

``run_twin`` is the whole of ``bearingtwin-twin``: read the measurement, set the
simulator to its operating point, rank the candidate effects, write
``twin_report.json`` and the PNGs, and log both to MLflow when tracking is enabled.
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from omegaconf import DictConfig, OmegaConf

from bearingtwin.checks import true_or_false
from bearingtwin.config import output_folder
from bearingtwin.data.cwru import BEARING_BY_END, parse_cwru_name
from bearingtwin.data.files import read_raw, recording_from_raw
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal.sampling_rate import require_plausible_rate
from bearingtwin.twin.compare import CompareSettings, plot_comparison
from bearingtwin.twin.model import TwinModel
from bearingtwin.twin.operating_point import OperatingPoint
from bearingtwin.twin.rank import EffectRanker, TwinFit
from bearingtwin.twin.reference import hold_reference, read_reference

if TYPE_CHECKING:
    from mlflow import MlflowClient

log = logging.getLogger(__name__)

REPORT_NAME = "twin_report.json"


def load_measurement(measured_cfg, bearing: BearingGeometry | None = None) -> Recording:
    """The measured record the config points at, with fs, rpm and bearing state all known, and
    its sampling rate checked against its shaft speed (``bearing``'s defect lines as a second witness)."""
    if OmegaConf.is_missing(measured_cfg, "path"):
        raise BearingTwinError("measured.path is missing: give measured.path=<file> (.npy, .npz, .csv, .mat, .wav or .xls)")
    check_fs = true_or_false(measured_cfg.check_fs, "measured.check_fs")
    raw = read_raw(measured_cfg.path)
    recording = recording_from_raw(raw, channel=measured_cfg.channel, fs=measured_cfg.fs, rpm=measured_cfg.rpm,
                                   fault=measured_cfg.fault, channel_key="measured.channel")
    recording.require_vibration()  # before the rate check, which a flat record cannot answer
    for name in ("rpm", "fault"):
        if getattr(recording, name) is None:
            raise BearingTwinError(f"{measured_cfg.path}: the file does not state its {name}; give measured.{name}=...")
    for note in recording.meta.get("notes", []):  # e.g. a nominal speed the twin will run at
        log.warning("%s: %s", measured_cfg.path, note)
    if check_fs:
        # A rate given here or only declared by a data set's convention is refused when the record contradicts
        # it; one the file records itself is kept, the doubt logged.
        require_plausible_rate(recording.signal, recording.fs, recording.rpm, str(measured_cfg.path), "measured.fs",
                               defect_hz=bearing.defect_frequencies(recording.rpm) if bearing is not None else None,
                               refuse=recording.meta.get("fs_origin") in ("config", "declared"), channels=raw.channels)
    with np.errstate(over="ignore"):
        fourth_moment = np.mean(recording.signal**4)  # the largest power the comparison's statistics take
    if not np.isfinite(fourth_moment):
        raise BearingTwinError(
            f"{measured_cfg.path}: samples up to {np.max(np.abs(recording.signal)):.3g} overflow the comparison's "
            "statistics; check the file's unit and scale"
        )
    return recording


def build_ranker(cfg: DictConfig, fault: str) -> EffectRanker:
    """The effect ranker the ``operating_point`` / ``calibration`` / ``ranking`` / ``candidates`` /
    ``effects`` config describes, for a measurement of bearing state ``fault``."""
    operating = OperatingPoint.from_config(
        OmegaConf.to_container(cfg.operating_point, resolve=True), OmegaConf.to_container(cfg.calibration.ranges),
        OmegaConf.to_container(cfg.calibration.base), fault, float(cfg.calibration.sensor_angle_step_deg),
        OmegaConf.to_container(cfg.calibration.base_held))
    return EffectRanker(
        candidates=list(cfg.candidates),
        fixed_effects=OmegaConf.to_container(cfg.effects, resolve=True),
        operating_point=operating,
        n_trials_base=int(cfg.calibration.n_trials_base),
        n_trials_effect=int(cfg.calibration.n_trials_effect),
        n_trials_refine=int(cfg.calibration.n_trials_refine),
        n_polish=int(cfg.calibration.n_polish),
        n_polish_effect=int(cfg.calibration.n_polish_effect),
        max_effects=int(cfg.ranking.max_effects),
        points_per_view=float(cfg.ranking.points_per_view),
        view_floor_db=float(cfg.ranking.view_floor_db),
        min_signature_gain=float(cfg.ranking.min_signature_gain),
        later_points_per_view=None if cfg.ranking.later_points_per_view is None
        else float(cfg.ranking.later_points_per_view),
        n_jobs=int(cfg.ranking.n_jobs),
        seed=int(cfg.seed),
    )


def twin_for(measured: Recording, cfg: DictConfig) -> TwinModel:
    """The simulator at the measurement's operating point (rpm, fs, fault), ``twin.duration`` long."""
    duration = cfg.twin.duration
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not (math.isfinite(duration) and duration > 0):
        raise BearingTwinError(f"twin.duration must be a positive, finite number of seconds, got {duration!r}")
    simulator_cfg = OmegaConf.to_container(cfg.simulator, resolve=True)
    simulator_cfg.update(rpm=float(measured.rpm), fs=float(measured.fs), duration=float(duration))
    return TwinModel(measured.fault, OmegaConf.to_container(cfg.bearing, resolve=True), simulator_cfg, int(cfg.seed))


def write_report(fit: TwinFit, out_dir: Path, figures: bool, measured: dict | None = None) -> list[Path]:
    """``twin_report.json`` (with ``measured``: what was measured, for a later run that takes this one as its
    reference) and, with ``figures``, the comparison views before and after and the error curve."""
    out_dir.mkdir(parents=True, exist_ok=True)
    report = {"measured": measured or {}, **fit.as_dict()}
    report["baseline_comparison"] = fit.steps[0].comparison.as_dict()
    report["final_comparison"] = fit.steps[-1].comparison.as_dict()
    path = out_dir / REPORT_NAME
    path.write_text(json.dumps(report, indent=2, default=float))
    written = [path]
    if figures:
        written += plot_comparison(fit.steps[0].comparison, out_dir, prefix="baseline")
        if len(fit.steps) > 1:
            written += plot_comparison(fit.steps[-1].comparison, out_dir, prefix="final")
        written += plot_steps(fit, out_dir)
    return written


def plot_steps(fit: TwinFit, out_dir: Path) -> list[Path]:
    """Discrepancy against effects added, and the first-round ranking of every candidate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    labels = ["twin"] + [f"+{step}" for step in (fit.added[i].effect for i in range(len(fit.added)))]
    left.plot(range(len(fit.steps)), [s.error for s in fit.steps], "o-")
    left.set_xticks(range(len(fit.steps)), labels, rotation=30, fontsize=8)
    left.set(ylabel="discrepancy (dB)", title="error against effects added")
    names = [f.effect for f in fit.ranking]
    right.barh(range(len(names)), [100 * f.explained for f in fit.ranking])
    right.set_yticks(range(len(names)), names, fontsize=8)
    right.invert_yaxis()
    right.set(xlabel="share of the discrepancy explained (%)", title="each candidate alone on the calibrated twin")
    fig.tight_layout()
    path = out_dir / "error_steps.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def open_twin_run(cfg: DictConfig, measured: Recording) -> tuple[MlflowClient, str]:
    """The command's MLflow run, opened before the calibration with its config: an interrupt marks it
    KILLED and a failure FAILED (:func:`bearingtwin.tracking.lifecycle.stop_cleanly`), and a store
    that cannot serve is named before any work."""
    from mlflow.entities import Param

    from bearingtwin.tracking.lifecycle import owner_tags, reap_dead_runs, register_open_run
    from bearingtwin.tracking.mlflow_logging import flatten, loggable_config, open_store

    client, experiment_id = open_store(cfg.tracking)
    reap_dead_runs(client, experiment_id)
    run = client.create_run(experiment_id, run_name=f"twin {Path(str(measured.source)).name} {measured.fault}",
                            tags={"bt.kind": "twin", "measured": str(measured.source), **owner_tags()})
    run_id = run.info.run_id
    register_open_run(client, run_id)
    params = [Param(k[:250], str(v)[:6000]) for k, v in flatten(loggable_config(cfg)).items()]
    for first in range(0, len(params), 100):  # MLflow takes at most 100 params per batch
        client.log_batch(run_id, params=params[first:first + 100])
    return client, run_id


def log_to_mlflow(client: MlflowClient, run_id: str, fit: TwinFit, files: list[Path]) -> str:
    """The run's results: discrepancy per step and per view, the ranking, the report and figures; FINISHED."""
    from mlflow.entities import Metric, RunStatus

    now = int(time.time() * 1000)
    metrics = [Metric("discrepancy_db", s.error, now, i) for i, s in enumerate(fit.steps)]
    metrics += [Metric(f"view_{v}_db", r.error_db, now, i) for i, s in enumerate(fit.steps)
                for v, r in s.comparison.views.items()]
    metrics += [Metric(f"explained_{f.effect}", f.explained, now, 0) for f in fit.ranking]
    metrics += [Metric(f"evidence_{f.effect}", f.evidence, now, 0) for f in fit.ranking]
    metrics += [Metric(f"signature_gain_{f.effect}", f.signature_gain, now, 0) for f in fit.ranking]
    metrics += [Metric(f"op_{name}", entry["value"], now, 0) for name, entry in fit.operating_point.items()
                if isinstance(entry.get("value"), float)]
    metrics += [Metric("gain", fit.gain, now, 0), Metric("floor_error", fit.floor_error, now, 0)]
    metrics += [Metric("baseline_error", fit.baseline_error, now, 0), Metric("final_error", fit.final_error, now, 0)]
    client.log_batch(run_id, metrics=metrics)
    client.set_tag(run_id, "summary", fit.summary[:5000])
    client.set_tag(run_id, "verdict", fit.verdict)
    if fit.unclaimed is not None:
        client.set_tag(run_id, "unclaimed", fit.unclaimed.effect)
    for path in files:
        client.log_artifact(run_id, str(path))
    client.set_terminated(run_id, RunStatus.to_string(RunStatus.FINISHED))
    return run_id


def run_twin(cfg: DictConfig) -> tuple[TwinFit, list[Path], str | None]:
    """Everything ``bearingtwin-twin`` does; returns the fit, the files written and the MLflow
    run id (None when tracking is disabled)."""
    out = output_folder(cfg.out)
    figures = true_or_false(cfg.figures, "figures")
    tracking = true_or_false(cfg.tracking.enabled, "tracking.enabled")
    geometry = BearingGeometry.from_config(cfg.bearing)
    measured = load_measurement(cfg.measured, geometry)
    named = measured.meta.get("bearing")  # the bearing a file names (a CWRU fan-end record's SKF 6203)
    cwru_name = parse_cwru_name(str(cfg.measured.path)) if measured.meta.get("format") == "cwru-mat" else None
    if named is None and cwru_name is not None and cwru_name.end == "drive":
        named = BEARING_BY_END["drive"]  # a drive-end fault record by its long name: the data set's SKF 6205
    if named is not None and named != cfg.bearing.get("name"):
        log.warning("%s: the record's bearing is %s, the twin's %s: give bearing=%s for its defect frequencies",
                    cfg.measured.path, named, cfg.bearing.get("name"), named)
    if cfg.get("reference") is not None:  # an earlier record of this rig: what it found is held
        cfg = hold_reference(cfg, read_reference(cfg.reference), measured.fault, source=f"reference={cfg.reference}")
    settings = CompareSettings.from_config(OmegaConf.to_container(cfg.compare, resolve=True))
    twin = twin_for(measured, cfg)
    ranker = build_ranker(cfg, measured.fault)
    tracked = open_twin_run(cfg, measured) if tracking else None
    ranker.fit(twin, measured, geometry, settings)
    about = {"path": str(cfg.measured.path), "fault": measured.fault, "fs": measured.fs, "rpm": measured.rpm,
             "unit": measured.unit, "bearing": cfg.bearing.get("name"), "reference": cfg.get("reference")}
    files = write_report(ranker.fit_, out, figures, about)
    run_id = log_to_mlflow(*tracked, ranker.fit_, files) if tracked else None
    return ranker.fit_, files, run_id
