"""MLflow tracking of training runs and sweeps.

Store: ``tracking.uri`` (default ``sqlite:///<repo>/mlruns/mlflow.db``, or the
``MLFLOW_TRACKING_URI`` environment variable); for a SQLite store the artifacts go
beside the database (``<db dir>/artifacts``) unless ``tracking.artifact_root`` says
otherwise. Everything goes through an explicit :class:`mlflow.MlflowClient` and run ids,
never MLflow's process-global active run, because joblib workers run many jobs in one
process.

Concurrency: parallel sweep jobs write to one SQLite file. MLflow 3.17 sets
``PRAGMA busy_timeout = 20000`` on every session, so ordinary writers wait for each other.
Creating the schema of a *new* database is not safe, measured: four processes opening a
fresh file at once failed with ``table experiments already exists`` despite MLflow's own
init lock. :func:`open_store` therefore opens SQLite stores and creates the experiment
under an exclusive ``flock`` on ``<db>.lock``; ``tests/test_tracking.py`` checks that
four concurrent writers lose no run. (For many machines use a server or PostgreSQL.)

Sweeps: a Hydra callback (:class:`SweepParentRun`) opens a parent run per multirun,
tagged ``bt.kind=sweep``, ``sweep`` (the sweep config's name) and ``sweep_dir`` (the
Hydra sweep dir); each job's run carries the same two tags and ``mlflow.parentRunId``,
and is named ``<features>+<classifier> <data source> [<vmd_params> [<optimizer>]] [varied overrides]
seed=<n>`` (:func:`run_name`), so runs of different configurations read apart.

Resuming: every run is tagged ``config_hash`` (the resolved config without paths,
tracking, Hydra and display settings, :data:`UNHASHED_KEYS`); with ``tracking.skip_finished`` a job whose config already
has a FINISHED run is skipped, so re-launching an interrupted sweep only runs what is
missing.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import importlib.metadata
import logging
import subprocess
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
from hydra.experimental.callback import Callback
from mlflow import MlflowClient
from mlflow.entities import Metric, Param, RunStatus, RunTag
from mlflow.exceptions import MlflowException
from omegaconf import DictConfig, OmegaConf

from bearingtwin.config import REPO_ROOT, exit_on_user_error
from bearingtwin.data.build import require_files
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.tables import csv_table, markdown_table

log = logging.getLogger(__name__)

# Settings that say where things are or how they are logged or shown, not what is computed.
UNHASHED_KEYS = ("paths", "tracking", "hydra", "trainer.progress_bar")
PACKAGES = ("bearingtwin", "numpy", "scipy", "torch", "lightning", "scikit-learn", "mlflow", "optuna", "hydra-core")
CONFIG_ARTIFACT = "config.yaml"
MAX_BATCH = 100  # MLflow's limit on params / tags per log_batch call


@dataclass(frozen=True)
class SweepInfo:
    """Where a job sits in a multirun: the sweep's name and dir, the job's place and varied overrides."""

    name: str
    sweep_dir: str
    varied: tuple[str, ...] = ()


@dataclass(frozen=True)
class TrackedRun:
    """The MLflow run a training ended in: its id, its metrics, whether it was an earlier run (skipped),
    and its model (``runs:/<id>/model``, and the registered ``models:/<name>/<version>`` if any)."""

    run_id: str
    metrics: dict
    skipped: bool = False
    model: str = ""


# ---------------------------------------------------------------- store


def open_store(tracking_cfg: DictConfig) -> tuple[MlflowClient, str]:
    """A client on ``tracking.uri`` and the id of ``tracking.experiment`` (created if new)."""
    uri = str(tracking_cfg.uri)
    name = str(tracking_cfg.experiment)
    with _sqlite_init_lock(uri):
        client = MlflowClient(tracking_uri=uri)
        experiment = client.get_experiment_by_name(name)  # creates the schema of a new database
        if experiment is not None:
            return client, experiment.experiment_id
        artifact_root = tracking_cfg.get("artifact_root") or _sqlite_path(uri, "artifacts")
        location = None if artifact_root is None else (Path(artifact_root).resolve() / name).as_uri()
        try:
            return client, client.create_experiment(name, artifact_location=location)
        except MlflowException:
            # Another machine's job created it between our lookup and create (the lock is local).
            experiment = client.get_experiment_by_name(name)
            if experiment is None:
                raise
            return client, experiment.experiment_id


def _sqlite_path(uri: str, sibling: str | None = None) -> str | None:
    """The database file of a ``sqlite:///`` URI (or ``sibling`` in its folder); None for other stores."""
    if not uri.startswith("sqlite:///"):
        return None
    path = Path(uri.removeprefix("sqlite:///"))
    return str(path if sibling is None else path.parent / sibling)


@contextlib.contextmanager
def _sqlite_init_lock(uri: str):
    database = _sqlite_path(uri)
    if database is None:
        yield
        return
    Path(database).parent.mkdir(parents=True, exist_ok=True)
    with open(f"{database}.lock", "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


# ---------------------------------------------------------------- run identity


def loggable_config(cfg: DictConfig) -> dict:
    """The resolved config as plain containers, without Hydra's own node."""
    container = OmegaConf.to_container(cfg, resolve=True)
    container.pop("hydra", None)
    return container


def config_hash(cfg: DictConfig) -> str:
    """Hash of what a run computes: the resolved config without the :data:`UNHASHED_KEYS` (dotted paths)."""
    container = loggable_config(cfg)
    for key in UNHASHED_KEYS:
        *parents, leaf = key.split(".")
        node = container
        for parent in parents:
            node = node.get(parent) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(leaf, None)
    return hashlib.sha256(OmegaConf.to_yaml(OmegaConf.create(container)).encode()).hexdigest()[:16]


def flatten(container: dict, prefix: str = "") -> dict[str, str]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": "1"}``; lists become their string form."""
    flat = {}
    for key, value in container.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            flat.update(flatten(value, f"{name}."))
        else:
            flat[name] = str(value)
    return flat


def method_name(choices: dict) -> str:
    """``<features>+<classifier>``: the name Table 4 rows and run names use."""
    return f"{choices.get('features', '?')}+{choices.get('classifier', '?')}"


def run_name(cfg: DictConfig, method: str, sweep: SweepInfo | None) -> str:
    """``<method> <data source> [<vmd_params> [<optimizer>]] [varied overrides] seed=<n>``: what sets
    runs apart at a glance (the VMD settings only where the features search VMD parameters; the
    optimizer only when it is not the default SABO)."""
    parts = [method, str(cfg.data.get("source", ""))]
    features = cfg.get("features") or {}
    if features.get("kind") == "sabo_vmd":
        parts.append(str(features.get("vmd_params", "")))
        if features.get("optimizer", "sabo") != "sabo":
            parts.append(str(features.optimizer))
    if sweep:
        parts += sweep.varied
    return " ".join(part for part in (*parts, f"seed={cfg.seed}") if part)


def _git_commit() -> str:
    try:
        commit = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO_ROOT), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit + ("-dirty" if dirty else "")


def _versions() -> dict[str, str]:
    versions = {}
    for package in PACKAGES:
        try:
            versions[f"version.{package}"] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            versions[f"version.{package}"] = "absent"
    return versions


# ---------------------------------------------------------------- finding runs


def find_runs(client: MlflowClient, experiment_id: str, filter_string: str, max_results: int = 10000) -> list:
    """All runs matching an MLflow filter, newest first, across result pages."""
    runs, token = [], None
    while True:
        page = client.search_runs(
            [experiment_id], filter_string, max_results=min(max_results, 1000), order_by=["attributes.start_time DESC"], page_token=token
        )
        runs.extend(page)
        token = page.token
        if not token or len(runs) >= max_results:
            return runs


def find_finished_run(client: MlflowClient, experiment_id: str, digest: str):
    """The newest FINISHED training run with config hash ``digest``, or None."""
    runs = find_runs(
        client,
        experiment_id,
        f"tags.config_hash = '{digest}' and tags.`bt.kind` = 'train' and attributes.status = 'FINISHED'",
        max_results=1,
    )
    return runs[0] if runs else None


def find_sweep_parent(client: MlflowClient, experiment_id: str, sweep_dir: str):
    runs = find_runs(client, experiment_id, f"tags.`bt.kind` = 'sweep' and tags.sweep_dir = '{sweep_dir}'", max_results=1)
    return runs[0] if runs else None


# ---------------------------------------------------------------- logging a run


def log_params_and_tags(client: MlflowClient, run_id: str, params: dict[str, str], tags: dict[str, str]) -> None:
    """Log in chunks of MLflow's batch limit; over-long values are cut (the full config is an artifact)."""
    param_list = [Param(k, v[:6000]) for k, v in params.items()]
    tag_list = [RunTag(k, str(v)[:8000]) for k, v in tags.items()]
    for start in range(0, len(param_list), MAX_BATCH):
        client.log_batch(run_id, params=param_list[start : start + MAX_BATCH])
    for start in range(0, len(tag_list), MAX_BATCH):
        client.log_batch(run_id, tags=tag_list[start : start + MAX_BATCH])


def log_result(client: MlflowClient, run_id: str, result) -> None:
    """Metrics, training curves (as stepped metrics and a PNG), confusion matrix, per-record accuracy, Table 2 / 3 artifacts."""
    now = int(time.time() * 1000)
    metrics = [Metric(k, float(v), now, 0) for k, v in result.metrics.items()]
    for record in result.history:
        metrics += [Metric(k, float(v), now, int(record["epoch"])) for k, v in record.items() if k != "epoch"]
    metrics += [Metric("n_train", result.n_train, now, 0), Metric("n_test", result.n_test, now, 0)]
    for start in range(0, len(metrics), 1000):
        client.log_batch(run_id, metrics=metrics[start : start + 1000])
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        _write_confusion(folder, result.confusion, result.class_names)
        _write_per_class(folder, result.metrics, result.class_names)
        if result.vmd_params:
            header = list(result.vmd_params[0])
            rows = [[row.get(k, "") for k in header] for row in result.vmd_params]
            (folder / "vmd_params.csv").write_text(csv_table(header, rows))
            (folder / "vmd_params.md").write_text(markdown_table(header, rows))
        if result.history:
            _plot_curves(result.history, folder / "training_curves.png")
        if result.per_record:
            header = list(result.per_record[0])
            rows = [[row[k] if k != "accuracy" else f"{row[k]:.4f}" for k in header] for row in result.per_record]
            (folder / "per_record.csv").write_text(csv_table(header, rows))
        client.log_artifacts(run_id, str(folder))


def _write_confusion(folder: Path, confusion: np.ndarray, class_names) -> None:
    header = ["true \\ predicted", *class_names]
    rows = [[name, *map(int, row)] for name, row in zip(class_names, confusion)]
    (folder / "confusion_matrix.csv").write_text(csv_table(header, rows))
    from matplotlib.figure import Figure

    figure = Figure(figsize=(4.5, 4))
    axes = figure.subplots()
    axes.imshow(confusion, cmap="Blues")
    for (i, j), count in np.ndenumerate(confusion):
        axes.text(j, i, str(count), ha="center", va="center", color="black")
    axes.set_xticks(range(len(class_names)), class_names, rotation=30)
    axes.set_yticks(range(len(class_names)), class_names)
    axes.set_xlabel("predicted")
    axes.set_ylabel("true")
    figure.tight_layout()
    figure.savefig(folder / "confusion_matrix.png", dpi=100)


def _write_per_class(folder: Path, metrics: dict, class_names) -> None:
    header = ["class", "precision", "recall", "f1"]
    rows = [[name, *(f"{metrics[f'{m}_{name}']:.3f}" for m in ("precision", "recall", "f1"))] for name in class_names]
    (folder / "per_class.csv").write_text(csv_table(header, rows))
    (folder / "per_class.md").write_text(markdown_table(header, rows) + f"\naccuracy: {metrics['accuracy']:.4f}\n")


def _plot_curves(history: list[dict], path: Path) -> None:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8, 3.2))
    loss_axes, accuracy_axes = figure.subplots(1, 2)
    epochs = [record["epoch"] for record in history]
    for stage in ("train", "val"):
        if f"{stage}_loss" in history[0]:
            loss_axes.plot(epochs, [r[f"{stage}_loss"] for r in history], label=stage)
            accuracy_axes.plot(epochs, [r[f"{stage}_accuracy"] for r in history], label=stage)
    loss_axes.set(xlabel="epoch", ylabel="cross-entropy loss")
    accuracy_axes.set(xlabel="epoch", ylabel="accuracy")
    accuracy_axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=100)


# ---------------------------------------------------------------- the tracked run


def train_tracked(cfg: DictConfig, choices: dict, sweep: SweepInfo | None, root_dir: str | None, train) -> TrackedRun | None:
    """Run ``train(cfg, root_dir) -> ExperimentResult`` inside an MLflow run and log everything.

    Returns the run and its metrics (the earlier run, ``skipped``, when one with this config
    already FINISHED). A failure marks the run FAILED with the error as tag ``error`` and artifact ``error.txt``; inside
    a sweep it is logged and swallowed so the sweep goes on (returns None), in a single run
    it is re-raised so the entry point exits non-zero.
    """
    check_registration(cfg)
    client, experiment_id = open_store(cfg.tracking)
    digest = config_hash(cfg)
    if cfg.tracking.skip_finished:
        done = find_finished_run(client, experiment_id, digest)
        if done is not None:
            log.info("skipped: run %s already FINISHED with this config (config_hash %s)", done.info.run_id, digest)
            return TrackedRun(done.info.run_id, dict(done.data.metrics), skipped=True)
    method = method_name(choices)
    tags = {
        "bt.kind": "train",
        "config_hash": digest,
        "method": method,
        "features": choices.get("features", ""),
        "classifier": choices.get("classifier", ""),
        "experiment": choices.get("experiment") or "",  # +experiment=<name>: a protocol's runs
        "seed": str(cfg.seed),
        "git_commit": _git_commit(),
        **_versions(),
    }
    if sweep is not None:
        tags.update(sweep=sweep.name, sweep_dir=sweep.sweep_dir, sweep_varied=" ".join(sweep.varied))
        parent = find_sweep_parent(client, experiment_id, sweep.sweep_dir)
        if parent is not None:
            tags["mlflow.parentRunId"] = parent.info.run_id
    run = client.create_run(experiment_id, run_name=run_name(cfg, method, sweep), tags={"bt.kind": "train"})
    run_id = run.info.run_id
    try:
        log_params_and_tags(client, run_id, flatten(loggable_config(cfg)), tags)
        client.log_text(run_id, OmegaConf.to_yaml(OmegaConf.create(loggable_config(cfg))), CONFIG_ARTIFACT)
        result = train(cfg, root_dir)
        log_params_and_tags(client, run_id, {}, {"dataset_key": result.dataset_key, "features_key": result.features_key})
        log_result(client, run_id, result)
        model = log_model(cfg, experiment_id, run_id, result, digest)
    except Exception as error:
        client.set_tag(run_id, "error", f"{type(error).__name__}: {error}"[:8000])
        client.log_text(run_id, traceback.format_exc(), "error.txt")
        client.set_terminated(run_id, RunStatus.to_string(RunStatus.FAILED))
        if sweep is None:
            raise
        log.error("run %s FAILED: %s: %s (the sweep goes on)", run_id, type(error).__name__, error)
        return None
    client.set_terminated(run_id, RunStatus.to_string(RunStatus.FINISHED))
    return TrackedRun(run_id, result.metrics, model=model)


def check_registration(cfg: DictConfig) -> tuple[str | None, str | None]:
    """``register`` and ``register_alias``, checked before any work is done."""
    name, alias = cfg.get("register"), cfg.get("register_alias")
    if alias and not name:
        raise BearingTwinError(f"register_alias={alias} needs register=<model name> (or register_alias=null)")
    return name, alias


def log_model(cfg: DictConfig, experiment_id: str, run_id: str, result, digest: str) -> str:
    """The run's fitted pipeline as its MLflow model ``model``; registered as ``register`` (alias
    ``register_alias``) when the config asks. Returns the model's URIs, for the closing summary."""
    from bearingtwin.diagnosis.mlflow_model import log_diagnosis_model, register_model

    result.pipeline.config_hash = digest
    uri = str(cfg.tracking.uri)
    info = log_diagnosis_model(uri, experiment_id, run_id, result.pipeline, result.example_windows, result.example_rpm)
    name, alias = check_registration(cfg)
    if name:
        version = register_model(uri, info.model_uri, str(name), None if alias is None else str(alias))
        log.info("registered %s version %s%s", name, version, f" as @{alias}" if alias else "")
        MlflowClient(tracking_uri=uri).set_tag(run_id, "registered_model", f"{name}/{version}")
        return f"runs:/{run_id}/model = models:/{name}/{version}" + (f" = models:/{name}@{alias}" if alias else "")
    return f"runs:/{run_id}/model"


def stored_config(client: MlflowClient, run_id: str) -> DictConfig:
    """The resolved config a run logged, in struct mode (unknown keys fail as in Hydra)."""
    with tempfile.TemporaryDirectory() as folder:
        try:
            path = client.download_artifacts(run_id, CONFIG_ARTIFACT, folder)
        except MlflowException as error:
            raise BearingTwinError(f"run_id={run_id}: no {CONFIG_ARTIFACT} artifact to re-run from ({error})") from error
        cfg = OmegaConf.load(path)
    OmegaConf.set_struct(cfg, True)
    return cfg


# ---------------------------------------------------------------- sweeps


def sweep_job_configs(config: DictConfig) -> Iterator[DictConfig]:
    """Every job's composed config, expanded and composed as Hydra's basic sweeper does."""
    from hydra._internal.core_plugins.basic_sweeper import BasicSweeper  # its job expansion, reused as is
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.override_parser.overrides_parser import OverridesParser

    params = [f"{key}={value}" for key, value in (config.hydra.sweeper.get("params") or {}).items()]
    overrides = OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task))
    loader = GlobalHydra.instance().config_loader()
    for batch in BasicSweeper.split_arguments(overrides, None):
        for job in batch:
            yield loader.load_sweep_config(config, list(job))


class SweepParentRun(Callback):
    """Hydra callback: one parent MLflow run per multirun, closed with the children's outcome.

    Created before any job starts (so parallel jobs also find an initialised store), and
    only once every job's data files are present: a sweep on absent files exits with
    status 2 naming them (exiting, not raising: Hydra turns a callback's exception into a
    warning and goes on) and logs nothing. Ends FINISHED when every child run finished,
    FAILED otherwise, with counts as tags.
    """

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        exit_on_user_error(require_files)(sweep_job_configs(config))
        client, experiment_id = open_store(config.tracking)
        name = str(config.hydra.runtime.choices.get("sweep") or "cli")
        sweep_dir = str(Path(config.hydra.sweep.dir).resolve())
        client.create_run(
            experiment_id,
            run_name=f"sweep {name} {Path(sweep_dir).name}",
            tags={"bt.kind": "sweep", "sweep": name, "sweep_dir": sweep_dir},
        )

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        client, experiment_id = open_store(config.tracking)
        sweep_dir = str(Path(config.hydra.sweep.dir).resolve())
        parent = find_sweep_parent(client, experiment_id, sweep_dir)
        if parent is None:
            return
        children = find_runs(client, experiment_id, f"tags.`mlflow.parentRunId` = '{parent.info.run_id}'")
        statuses = [child.info.status for child in children]
        n_failed = sum(status != "FINISHED" for status in statuses)
        client.set_tag(parent.info.run_id, "n_finished", str(len(statuses) - n_failed))
        client.set_tag(parent.info.run_id, "n_failed", str(n_failed))
        client.set_terminated(parent.info.run_id, "FAILED" if n_failed else "FINISHED")


def sweep_info(hydra_cfg) -> SweepInfo | None:
    """The job's place in a multirun (None for a single run), from Hydra's runtime config."""
    from hydra.types import RunMode

    if hydra_cfg.mode != RunMode.MULTIRUN:
        return None
    # The sweep file's params are the varied keys (a job sees its own values only).
    swept = {key.lstrip("+~") for key in (hydra_cfg.sweeper.get("params") or {})}
    varied = tuple(
        o.lstrip("+~")
        for o in hydra_cfg.overrides.task
        if o.split("=", 1)[0].lstrip("+~") in swept - {"seed", "method"}
    )
    return SweepInfo(
        name=str(hydra_cfg.runtime.choices.get("sweep") or "cli"),
        sweep_dir=str(Path(hydra_cfg.sweep.dir).resolve()),
        varied=varied,
    )
