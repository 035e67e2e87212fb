"""``bearingtwin-train``: train a classifier on a dataset's features and log the run to MLflow.

Single run: ``bearingtwin-train classifier=svm seed=3``. Sweep: ``bearingtwin-train -m
+sweep=table4`` (add ``launcher=joblib`` to run jobs in parallel). A failing job in a sweep is
logged FAILED and the sweep goes on, also one whose joblib worker the OS kills.

Data files a config names are checked before any MLflow run is opened: a single run checks
its own here, a sweep checks every job's in :class:`SweepParentRun`. Absent files end the
command with exit status 2 and a message naming them and ``data.root=``.

A single run ends with a summary (accuracy, F1 per class, its model, the MLflow run and how to
open it, the output folder); a sweep job prints one line, the sweep as a whole is summarised by
:class:`SweepParentRun`.

Exit status: 0 when the run (every job of a sweep) finished or was skipped as already
finished; 1 when a sweep job failed (after all jobs ran, with a summary); 2 for bad input;
130 / 143 / 129 on SIGINT / SIGTERM / SIGHUP, with the open runs marked KILLED.
"""

from __future__ import annotations

import contextlib
import logging
from typing import TYPE_CHECKING

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig

from bearingtwin.checks import progress_bar_settings, show_progress_bar
from bearingtwin.cli.summary import closing_summary, percent
from bearingtwin.config import exit_on_user_error, hydra_command, refuse_unknown_keys
from bearingtwin.data.build import check_data_settings, require_files
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import build_effects
from bearingtwin.tracking.lifecycle import stop_cleanly, watch_sweep_process

if TYPE_CHECKING:
    from bearingtwin.tracking.mlflow_logging import TrackedRun

log = logging.getLogger(__name__)


def training_summary(name: str, tracked: TrackedRun, tracking_uri: str, out: str, records: str | None = None,
                     experiment: str | None = None) -> str:
    """Accuracy and F1 per class of a finished run (calibration accuracy when the data set has one), and
    ``records``: what the data were (:func:`data_words`; which real records a twin-trained run was calibrated and
    tested on)."""
    metrics = tracked.metrics
    lines = {"data": records} if records else {}
    if "n_train" in metrics and "n_test" in metrics:
        lines["windows"] = f"{int(metrics['n_train'])} to train on, {int(metrics['n_test'])} to test on"
    lines["accuracy"] = percent(metrics["accuracy"])
    f1 = {key.removeprefix("f1_"): value for key, value in metrics.items() if key.startswith("f1_")}
    lines["F1 per class"] = ", ".join(f"{state} {value:.3f}" for state, value in f1.items())
    if "calibration_accuracy" in metrics:
        recall = {key.removeprefix("calibration_recall_"): value for key, value in metrics.items()
                  if key.startswith("calibration_recall_")}
        per_class = f" (windows right: {', '.join(f'{state} {percent(value)}' for state, value in recall.items())})"
        lines["calibration accuracy"] = percent(metrics["calibration_accuracy"]) + (per_class if recall else "")
        from bearingtwin.models.experiment import CALIBRATION_RECALL_WARNING, misread_calibration

        missed = misread_calibration(metrics)
        if missed:  # the records the twin was calibrated on, misread: the test records will show it too
            lines["warning"] = (f"the {' and '.join(missed)} calibration record{'s are' if len(missed) > 1 else ' is'} "
                                f"called {'their' if len(missed) > 1 else 'its'} state in under "
                                f"{percent(CALIBRATION_RECALL_WARNING)} of the windows: the twin calibrated on them "
                                "does not resemble them enough to learn from; read their twin reports (base parameters, "
                                "effects, discrepancy left) before trusting this model")
    from bearingtwin.models.experiment import FEATURE_GROUPS

    # The choice is the classifier's own: where the envelope spectrum decides some windows (physics_first), the
    # calibration accuracy above counts those decisions too, and the two figures differ.
    alone = "the classifier alone: " if "physics_decided" in metrics else ""
    for group in FEATURE_GROUPS:  # chosen by the calibration records (band_power_by_calibration, ...)
        if group.kept_metric in metrics:
            lines[group.words] = (f"{'kept' if metrics[group.kept_metric] else 'dropped'} ({alone}calibration windows "
                                  f"right {percent(metrics[group.with_metric])} with {group.pronoun}, "
                                  f"{percent(metrics[group.without_metric])} without)")
    if "physics_decided" in metrics:
        left = (f", right in {percent(metrics['classifier_accuracy_left'])} of them"
                if "classifier_accuracy_left" in metrics else "")
        alone_accuracy = (f"; the classifier alone, on every test window: {percent(metrics['classifier_accuracy'])}"
                          if "classifier_accuracy" in metrics else "")  # runs logged before it was recorded
        lines["physics first"] = (f"{percent(metrics['physics_decided'])} of the test windows decided by the envelope "
                                  f"spectrum (physics_first), the rest by the classifier{left}{alone_accuracy}")
    if tracked.model:
        lines["model"] = tracked.model
    if tracked.artifacts:
        lines["artifacts"] = tracked.artifacts
    if tracked.skipped:
        lines["note"] = ("an earlier run with this exact config had FINISHED, so nothing ran"
                         + (f", computed by the code {tracked.other_code}" if tracked.other_code else "")
                         + " (tracking.skip_finished=false re-runs)")
    return closing_summary(f"bearingtwin-train: {name}", lines, tracked.run_id, tracking_uri, out, experiment)


def data_words(cfg: DictConfig) -> str | None:
    """What a run's data are, for its closing summary: the twin's bearing and operating point, or the real
    records' set (a twin-to-real run's records are named by :func:`twin_to_real_records`)."""
    from bearingtwin.data.hust import hust_condition

    data = cfg.data
    if data.source == "simulated":
        return (f"the twin's {cfg.bearing.name} bearing at {data.rpm:g} rpm, {data.fs:g} Hz, {data.duration:g} s per "
                "state")
    if data.source == "cwru":
        return f"CWRU records at {data.load} hp, channel {data.channel}, bearing {data.bearing}"
    if data.source == "hust":
        return f"HUST exports at {hust_condition(data.condition)}Hz, axis {data.channel}, bearing {data.bearing}"
    if data.source == "files":
        return f"the recordings in {data.root}, bearing " + (
            data.bearing if data.get("bearing") else f"as the files name it, else the twin's {cfg.bearing.name} (no "
                                                     "data.bearing= given)")
    return None


def twin_to_real_records(cfg: DictConfig) -> str | None:
    """The real records a ``data=twin_to_real`` run calibrated its twin on and tested on; None for other data."""
    if cfg.data.get("source") != "twin_to_real":
        return None
    from bearingtwin.config import plain_config
    from bearingtwin.data.twin_to_real import check_protocol

    calibration, tests = check_protocol(plain_config(cfg.data, "data config"))
    return (f"twin calibrated on {', '.join(path.name for path in calibration)}; tested on {len(tests)} other "
            "records (per_record.csv among the artifacts)")


@hydra_command("train")
def train(cfg: DictConfig) -> float | None:
    hydra_cfg = HydraConfig.get()
    in_sweep = hydra_cfg.mode == RunMode.MULTIRUN
    # The bars shown (auto: for one run in a terminal).
    for node, name, key in progress_bar_settings(cfg):
        if not in_sweep:
            node[name] = exit_on_user_error(show_progress_bar)(node.get(name, "auto"), in_sweep, key)
        else:  # a bad value is left for the classifier's or the features' check, which fails this job alone, in its run
            with contextlib.suppress(BearingTwinError):
                node[name] = show_progress_bar(node.get(name, "auto"), in_sweep, key)
    records = None
    if not in_sweep:  # a sweep checks every job's before the first starts (SweepParentRun)
        exit_on_user_error(refuse_unknown_keys)(hydra_cfg)
        exit_on_user_error(check_data_settings)(cfg)
        exit_on_user_error(require_files)([cfg])
        exit_on_user_error(build_effects)(cfg.get("effects"))  # their parameters, before a run is opened
        # For the closing summary, as read before the run.
        records = exit_on_user_error(twin_to_real_records)(cfg) or data_words(cfg)
    # MLflow, scikit-learn and the models once the input is accepted: a refusal takes a second, not several.
    from bearingtwin.models.experiment import checked_settings, run_experiment
    from bearingtwin.tracking.mlflow_logging import method_name, run_name, sweep_info, train_tracked

    if not in_sweep:  # a bad classifier or features value is refused before a run is opened for it
        exit_on_user_error(checked_settings)(cfg)

    sweep = sweep_info(hydra_cfg)
    choices = dict(hydra_cfg.runtime.choices)
    output_dir = hydra_cfg.runtime.output_dir
    if sweep is None:
        tracked = exit_on_user_error(train_tracked)(cfg, choices, None, output_dir, run_experiment)
    else:
        watch_sweep_process()
        try:
            tracked = train_tracked(cfg, choices, sweep, output_dir, run_experiment)
        except Exception as error:  # before its run existed: Hydra would end the sweep here, without a summary
            log.error("job %s did not start its run: %s: %s (the sweep goes on)", hydra_cfg.job.num, type(error).__name__, error)
            return None
    if tracked is None:
        return None
    name = run_name(cfg, method_name(choices), sweep)
    if sweep is None:
        summary = training_summary(name, tracked, str(cfg.tracking.uri), output_dir, records, str(cfg.tracking.experiment))
    else:
        summary = f"{name}: accuracy {percent(tracked.metrics['accuracy'])} (MLflow run {tracked.run_id})"
    print(summary)
    _into_log_file(summary)
    return tracked.metrics.get("accuracy")


def _into_log_file(text: str) -> None:
    """``text`` into the run's ``train.log`` too (Hydra's file handler), not again on the console: the log kept in
    the run's folder had ended at the features line, without what the run came to."""
    record = logging.LogRecord(log.name, logging.INFO, __file__, 0, text, None, None)
    for handler in logging.getLogger().handlers:
        if isinstance(handler, logging.FileHandler):
            handler.handle(record)


main = stop_cleanly(train)


if __name__ == "__main__":
    main()
