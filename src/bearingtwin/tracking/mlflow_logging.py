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
tracking, Hydra and display settings, :data:`UNHASHED_KEYS`, and the contents of the files its
data is read from); a sweep job whose config and files already have a FINISHED run is skipped, so re-launching an interrupted sweep only runs what is missing.
A single run runs again, as MLflow users expect (``tracking.skip_finished=true|false`` decides
for both).

Ending: a multirun prints a summary (finished / failed / skipped, each failed job's
overrides and reason) and exits 1 if any job did not finish. Runs are tagged with the
host and process that opened them, and never left RUNNING (:mod:`.lifecycle`).
"""

from __future__ import annotations

import contextlib
import copy
import fcntl
import functools
import hashlib
import json
import logging
import os
import random
import re
import shutil
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Mapping, Sequence
from urllib.parse import urlparse

import numpy as np
from hydra.experimental.callback import Callback
from mlflow import MlflowClient
from mlflow.entities import Metric, Param, RunStatus, RunTag
from mlflow.exceptions import MlflowException
from omegaconf import DictConfig, OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException

from bearingtwin import cpu_kernels
from bearingtwin.config import absolute_inputs, exit_on_user_error, experiment_name, flatten, refuse_unknown_keys
from bearingtwin.checks import check_seed
from bearingtwin.cli.summary import percent
from bearingtwin.data.build import check_data_settings, require_files
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effects import build_effects
from bearingtwin.tracking.lifecycle import (
    SWEEP_PID_ENV,
    forget_open_run,
    open_owned_run,
    raise_if_interrupted,
    reap_dead_runs,
    start_ray_keeping_signals,
)
from bearingtwin.tracking import open_command
from bearingtwin.tracking.provenance import (code_tag, computed_by_other_code, environment_tags, git_commit,
                                             installed_versions, overrides_tag)
from bearingtwin.tracking.tables import csv_table, markdown_table

log = logging.getLogger(__name__)

# Settings that say where things are or how they are logged or shown, not what is computed.
UNHASHED_KEYS = ("paths", "tracking", "hydra", "trainer.progress_bar", "features.progress", "data.twin.n_jobs")
PINNED_KEYS = {"features.n_jobs": 1, "data.n_jobs": 1}
"""Settings that say how many processes compute, not what (as the feature cache's key knows,
:data:`bearingtwin.features.NOT_AFFECTING_NUMBERS`): hashed at 1 whatever they are set to, the value runs recorded
before this rule had, so those runs keep their hashes and a sweep resumed with more processes skips them."""
HASHED_WHEN_SET_KEYS = ("data.labels", "data.twin.background_snr_db", "data.twin.other_paths", "simulator.oversample",
                        "physics_first")
"""Keys hashed only when not null: each came after runs were recorded, and its null default computes what its
absence did, so those runs keep their hashes (a resumed sweep skips them)."""
PACKAGES = ("bearingtwin", "numpy", "scipy", "torch", "lightning", "scikit-learn", "mlflow", "optuna", "hydra-core",
            "numba", "llvmlite", "pandas")
CONFIG_ARTIFACT = "config.yaml"
SWEEP_RUNS_ARTIFACT = "sweep_runs.json"
MAX_BATCH = 100  # MLflow's limit on params / tags per log_batch call


@dataclass(frozen=True)
class SweepInfo:
    """Where a job sits in a multirun: the sweep's name and dir, the job's place and varied overrides."""

    name: str
    sweep_dir: str
    varied: tuple[str, ...] = ()
    job: int = 0  # Hydra's job number: which of the sweep's jobs, even where two jobs' configs hash alike


@dataclass(frozen=True)
class TrackedRun:
    """The MLflow run a training ended in: its id, its metrics, whether it was an earlier run (skipped),
    and its model (``runs:/<id>/model``, and the registered ``models:/<name>/<version>`` if any)."""

    run_id: str
    metrics: dict
    skipped: bool = False
    model: str = ""
    artifacts: str = ""  # where the run's files are (confusion matrix, per-class and per-record tables, model)
    other_code: str = ""  # for a skipped run computed by other code than this: "at <commit> (this code: <commit>)"


# ---------------------------------------------------------------- store


def open_store(tracking_cfg: DictConfig, must_exist: bool = False) -> tuple[MlflowClient, str]:
    """A client on ``tracking.uri`` and the id of ``tracking.experiment`` (created if new).

    A store that cannot serve is refused in one line before any work: a tracking server that does not
    answer (MLflow would retry for minutes), MLflow 3's retired file store, and with ``must_exist`` (a
    command that only reads) a SQLite file or an experiment that is not there, which would otherwise be
    created empty."""
    uri = str(tracking_cfg.uri)
    name = experiment_name(tracking_cfg, "experiment" if must_exist else "tracking.experiment")  # a report's own key
    check_store(uri, must_exist)
    with _sqlite_init_lock(uri):
        try:
            _make_sqlite_store_whole(uri)
            client = MlflowClient(tracking_uri=uri)  # an SQL store checks its tables' version here
            experiment = client.get_experiment_by_name(name)  # creates the schema of a new database
        except Exception as error:
            if _sqlite_path(uri) and re.search(r"already exists|duplicate column name", str(error)):  # an older store's
                found = re.search(r"table \S+ already exists|duplicate column name: \S+", str(error))  # making stopped
                raise BearingTwinError(f"{store_setting(uri)}: the store's tables are half made ("
                                       f"{found[0] if found else 'a table already exists'}, as its upgrade or making "
                                       "was stopped); move the file aside and run again for a new store") from None
            older = re.search(r"out-of-date database schema \((found version \S+)", str(error))
            if older:  # MLflow's message is a paragraph under a traceback
                raise BearingTwinError(f"{store_setting(uri)}: the store's tables are older than this MLflow's "
                                       f"({older[1].rstrip(',')}); back the store up and upgrade it (mlflow db upgrade "
                                       f"{uri}), or, where its making was stopped, move it aside for a new one") from None
            if not isinstance(error, MlflowException) or not _is_server(uri):
                raise
            # A reply of HTML: another service on the port, a proxy's page. Else MLflow's own refusal (a login it
            # asks for, a store it cannot read), said as it says it.
            body = str(error).split("Response body:", 1)[1].strip(" '\"") if "Response body:" in str(error) else ""
            what = ("the server there does not answer as an MLflow tracking server" if body.startswith("<")
                    else "the tracking server refused")
            raise BearingTwinError(f"{store_setting(uri)}: {what} ({mlflow_reason(error)})") from None
        if experiment is not None and experiment.lifecycle_stage == "deleted":  # MLflow refuses runs in it
            raise BearingTwinError(f"tracking.experiment={name}: deleted in {uri}; restore it (mlflow experiments "
                                   f"restore --experiment-id {experiment.experiment_id}), remove it for good (mlflow "
                                   "gc), or name another experiment")
        if experiment is not None:
            given = tracking_cfg.get("artifact_root")
            if given and not must_exist and experiment.artifact_location != artifact_location(given, name):
                log.warning("tracking.artifact_root=%s not used: experiment %s keeps its artifacts in %s, where MLflow "
                            "placed them when it was made; name a new experiment (tracking.experiment=) to keep them "
                            "there", given, name, experiment.artifact_location)
            return client, experiment.experiment_id
        if must_exist:  # a reader would only find no runs, and leave a misspelled experiment behind
            names = sorted(e.name for e in client.search_experiments())
            raise BearingTwinError(f"experiment={name}: no such experiment in {uri} (it holds: {', '.join(names) or 'none'})")
        location = artifact_location(tracking_cfg.get("artifact_root") or _sqlite_path(uri, "artifacts"), name)
        try:
            return client, client.create_experiment(name, artifact_location=location)
        except MlflowException:
            # Another machine's job created it between our lookup and create (the lock is local).
            experiment = client.get_experiment_by_name(name)
            if experiment is None:
                raise
            return client, experiment.experiment_id


def mlflow_reason(error: Exception) -> str:
    """An MLflow client error in one line: a server's reply body (often a page of HTML) left out."""
    text = " ".join(str(error).split("Response body:")[0].split()).rstrip(".")
    return text or type(error).__name__


def check_store(uri: str, must_exist: bool = False) -> None:
    """Refuse, in one line naming ``tracking.uri``, a store that cannot serve (see :func:`open_store`)."""
    scheme = urlparse(uri).scheme
    if not scheme and Path(uri).expanduser().is_file():  # a database file named as a path (MLflow reads a folder so)
        raise BearingTwinError(f"{store_setting(uri)}: a file's path, not a store's URI; give "
                               f"sqlite:///{Path(uri).expanduser().resolve()} for the SQLite store in it")
    if (scheme == "file" or (not scheme and uri != "databricks")) and os.environ.get("MLFLOW_ALLOW_FILE_STORE") != "true":
        raise BearingTwinError(f"{store_setting(uri)}: MLflow 3 keeps runs in a database or behind a server, not in a "
                               "folder; give sqlite:///<folder>/mlflow.db or http://<server>")
    if scheme in ("http", "https"):
        bound_http_retries()
        _server_answers(uri)
    if scheme and scheme not in ("http", "https", "sqlite", "file", "databricks"):
        _driver_installed(uri)
    path = _sqlite_path(uri)
    if must_exist and path is not None and not Path(path).is_file():
        raise BearingTwinError(f"{store_setting(uri)}: no such store ({path} does not exist)")
    if path is not None and Path(path).is_file():
        _check_sqlite_store(uri, Path(path), must_exist)


def _driver_installed(uri: str) -> None:
    """Refuse a database URI whose driver is not installed (SQLAlchemy imports it when the engine is made,
    connecting to nothing): MLflow would fail with a traceback at the first run."""
    import sqlalchemy

    try:
        sqlalchemy.create_engine(uri)
    except ImportError as error:  # a missing module, or a module missing its system library (unixODBC)
        hint = (" (PostgreSQL: the postgres extra, pip install -c requirements.lock -e \".[postgres]\", installs psycopg 3;"
                " name it in the URI: postgresql+psycopg://...)" if urlparse(uri).scheme.startswith("postgres") else "")
        raise BearingTwinError(f"{store_setting(uri)}: its database driver, {error.name or error}, is not installed{hint}") from None
    except Exception:  # anything else about the URI is the server's and MLflow's to report, as before
        return


def _check_sqlite_store(uri: str, path: Path, must_exist: bool) -> None:
    """Refuse a file that is not an MLflow store before MLflow writes its tables into it (a user's own
    database, a text file); an empty file becomes a new store, unless a store must already be there."""
    import sqlite3

    try:
        with contextlib.closing(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)) as database:
            tables = {row[0] for row in database.execute("select name from sqlite_master where type = 'table'")}
    except sqlite3.DatabaseError as error:
        if getattr(error, "sqlite_errorname", "") == "SQLITE_NOTADB":
            raise BearingTwinError(f"{store_setting(uri)}: {path} is not an SQLite database ({error})") from None
        return  # locked, or a crashed writer's journal a read-only look cannot roll back: MLflow's own connection can
    if tables and "experiments" not in tables:
        raise BearingTwinError(f"{store_setting(uri)}: {path} is an SQLite database but not an MLflow store "
                               f"(its tables: {', '.join(sorted(tables)[:5])}); give another file")
    if not tables and must_exist:
        raise BearingTwinError(f"{store_setting(uri)}: {path} is empty, not an MLflow store")


@functools.lru_cache(maxsize=None)
def _server_answers(uri: str) -> None:
    """Ask the server's liveness route once per process; only silence is refused (:func:`server_silence`)."""
    silence = server_silence(uri)
    if silence is not None:
        raise BearingTwinError(f"{store_setting(uri)}: no tracking server answers there ({silence})")


def server_silence(uri: str) -> str | None:
    """Why no server answers at the tracking server ``uri`` (one line), or None when one does. Any HTTP reply (a
    login a proxy asks for, a route it does not forward) or a certificate MLflow's own TLS settings may accept
    counts as an answer: the rest is MLflow's client's to say."""
    import http.client
    import ssl
    import urllib.error
    import urllib.request

    parts = urlparse(uri)
    try:
        urllib.request.urlopen(parts._replace(path=parts.path.rstrip("/") + "/health", query="").geturl(),
                               timeout=10).close()
    except urllib.error.HTTPError:
        return None
    except urllib.error.URLError as error:
        return None if isinstance(error.reason, ssl.SSLError) else " ".join(str(error.reason).split())
    except (OSError, http.client.HTTPException, ValueError) as error:
        return f"{type(error).__name__}: {' '.join(str(error).split())}"
    return None


def bound_http_retries() -> None:
    """Let a request to a tracking server that went away (its connections refused) fail in about half a minute,
    not four.

    MLflow retries a request 7 times at a backoff factor of 2 (waits doubling up to 2 min: about 4 min), and every
    later request of the command waits as long again: with the server gone mid-run a training hung for 13
    minutes before its traceback. 5 retries at a factor of 1 (about 30 s) still ride out a server's restart. A
    host that stops answering at all still costs MLflow's request timeout per try
    (``MLFLOW_HTTP_REQUEST_TIMEOUT``, 120 s), left as it is for large artifact uploads. A value the environment
    sets is kept."""
    os.environ.setdefault("MLFLOW_HTTP_REQUEST_MAX_RETRIES", "5")
    os.environ.setdefault("MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR", "1")


def artifact_location(root: str | None, experiment: str) -> str | None:
    """Where a new experiment's artifacts go: ``<root>/<experiment>``; None leaves it to the store
    (a tracking server's own artifact store, ``mlflow-artifacts:/``).

    ``root`` is a URI (``s3://bucket/path``, ``mlflow-artifacts:/path``, ``file:///...``), kept as it is,
    or a folder on this machine, made absolute: only a local folder becomes a ``file://`` URI.
    """
    if root is None:
        return None
    root = str(root)
    if urlparse(root).scheme:
        return f"{root.rstrip('/')}/{experiment}"
    return (Path(root).expanduser().resolve() / experiment).as_uri()


def _sqlite_path(uri: str, sibling: str | None = None) -> str | None:
    """The database file of a ``sqlite:///`` URI (or ``sibling`` in its folder); None for other stores."""
    if not uri.startswith("sqlite:///"):
        return None
    path = Path(uri.removeprefix("sqlite:///").split("?")[0])  # a query (?timeout=30) is the driver's
    return str(path if sibling is None else path.parent / sibling)


def _make_sqlite_store_whole(uri: str) -> None:
    """A new SQLite store made whole beside its place, then moved there: MLflow makes its tables one by one, and a
    first command interrupted while it did (Ctrl-C within its first seconds) left a store every later command
    failed on ("table ... already exists"). Called under :func:`_sqlite_init_lock`; an existing store is left as it
    is (an empty file counts as none)."""
    database = _sqlite_path(uri)
    if database in (None, ":memory:") or (Path(database).is_file() and Path(database).stat().st_size > 0):
        return
    query = uri.partition("?")[2]
    for earlier in Path(database).parent.glob(f"{Path(database).name}.*.making*"):  # attempts interrupted, journals
        earlier.unlink(missing_ok=True)
    # A name of its own each time: MLflow keeps a store per URI for the process, bound to the file it first opened.
    making = Path(f"{database}.{os.getpid()}-{time.monotonic_ns()}.making")
    maker = MlflowClient(tracking_uri=f"sqlite:///{making}" + (f"?{query}" if query else ""))
    maker.search_experiments()
    engine = getattr(maker._tracking_client.store, "engine", None)  # its connections, to a file renamed below
    if engine is not None:
        engine.dispose()
    os.replace(making, database)


@contextlib.contextmanager
def _sqlite_init_lock(uri: str):
    database = _sqlite_path(uri)
    if database in (None, ":memory:"):  # no file, nothing another process could be making
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
    """Hash of what a run computes: the resolved config without the :data:`UNHASHED_KEYS` (dotted paths), and the
    contents of the files its data is read from (:func:`~bearingtwin.data.build.input_digest`)."""
    from bearingtwin.data.build import input_digest

    container = loggable_config(cfg)
    files = input_digest(cfg)
    if files:  # simulated data is its config alone: its runs' hashes stay what they were
        container["input_files"] = files
    for key in UNHASHED_KEYS + HASHED_WHEN_SET_KEYS + tuple(PINNED_KEYS):
        *parents, leaf = key.split(".")
        node = container
        for parent in parents:
            node = node.get(parent) if isinstance(node, dict) else None
        if isinstance(node, dict) and key in PINNED_KEYS and leaf in node:
            node[leaf] = PINNED_KEYS[key]
        elif isinstance(node, dict) and (key in UNHASHED_KEYS or node.get(leaf, "set") is None):
            node.pop(leaf, None)
    return hashlib.sha256(OmegaConf.to_yaml(OmegaConf.create(container)).encode()).hexdigest()[:16]


def physics_first_rule(params: dict) -> dict[str, float] | None:
    """The ``physics_first`` rule a run's flattened params hold: its settings as numbers (logged as
    ``physics_first.<setting>``, ``20`` and ``20.0`` alike), None where it applied none (``physics_first=None``, or
    a run from before the key, whose absence computed the same)."""
    return {key.partition(".")[2]: float(value) for key, value in params.items()
            if key.startswith("physics_first.")} or None


def method_name(choices: dict) -> str:
    """``<features>+<classifier>``: the name Table 4 rows and run names use."""
    return f"{choices.get('features', '?')}+{choices.get('classifier', '?')}"


def earlier_model(client: MlflowClient, run_id: str) -> str:
    """The model a finished run logged, as :func:`log_model` names it (``runs:/<id>/model``, and its registered
    version where the run was registered), or "" when it logged none."""
    run = client.get_run(run_id)
    if not (run.outputs and run.outputs.model_outputs):
        return ""
    registered = run.data.tags.get("registered_model")
    return f"runs:/{run_id}/model" + (f" = models:/{registered}" if registered else "")


def run_name(cfg: DictConfig, method: str, sweep: SweepInfo | None) -> str:
    """``<method> [<estimator class>] <data source> [<load or condition>] [<vmd_params> [<optimizer>]] [varied
    overrides] seed=<n>``: what sets runs apart at a glance (a ``classifier=sklearn`` run's estimator class; a CWRU
    load or HUST condition unless the sweep varies it; the VMD settings only where the features search VMD
    parameters; the optimizer only when it is not the default SABO)."""
    source = str(cfg.data.get("source", ""))
    estimator = _estimator_class(cfg)
    parts = [f"{method} {estimator}" if estimator else method, source]
    where = {"cwru": ("load", "hp"), "hust": ("condition", "Hz")}.get(source)  # which records, where a sweep does not say
    varied = {override.partition("=")[0].lstrip("+~") for override in (sweep.varied if sweep else ())}
    if where and cfg.data.get(where[0]) is not None and not varied & {f"data.{where[0]}", "cwru_condition"}:
        parts[-1] += f" {cfg.data[where[0]]}{where[1]}"
    features = cfg.get("features") or {}
    if features.get("kind") == "sabo_vmd":
        parts.append(str(features.get("vmd_params", "")))
        if features.get("optimizer", "sabo") != "sabo":
            parts.append(str(features.optimizer))
    if sweep:
        parts += sweep.varied
    return " ".join(part for part in (*parts, f"seed={cfg.seed}") if part)


def _estimator_class(cfg: DictConfig) -> str:
    """The class of a ``classifier=sklearn`` run's estimator (``RandomForestClassifier``); "" for another classifier."""
    estimator = (cfg.get("classifier") or {}).get("estimator")
    target = estimator.get("_target_") if isinstance(estimator, (dict, DictConfig)) else None
    return str(target).rpartition(".")[2] if target else ""


def _versions() -> dict[str, str]:
    return {f"version.{package}": version or "absent" for package, version in installed_versions(PACKAGES).items()}


# ---------------------------------------------------------------- finding runs


def find_runs(client: MlflowClient, experiment_id: str | list[str], filter_string: str, max_results: int = 10000) -> list:
    """All runs matching an MLflow filter in one experiment (or a list of them), newest first, across result pages."""
    runs, token = [], None
    while True:
        page = client.search_runs(
            [experiment_id] if isinstance(experiment_id, str) else experiment_id, filter_string, max_results=min(max_results, 1000), order_by=["attributes.start_time DESC"], page_token=token
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


def sweep_parents(client: MlflowClient, sweep_dir: str, max_results: int = 10000) -> list:
    """The parent runs of the sweeps launched in ``sweep_dir``, newest first, in whichever experiment of the
    store (a sweep may vary tracking.experiment; a relaunched sweep has a parent per launch)."""
    return find_runs(client, all_experiment_ids(client), f"tags.`bt.kind` = 'sweep' and tags.sweep_dir = '{sweep_dir}'",
                     max_results=max_results)


def find_sweep_parent(client: MlflowClient, sweep_dir: str):
    """The newest parent run of the sweep launched in ``sweep_dir``, or None."""
    runs = sweep_parents(client, sweep_dir, max_results=1)
    return runs[0] if runs else None


def sweep_run_ids(client: MlflowClient, sweep_dir: str) -> list[str]:
    """The runs a finished sweep stands for (its jobs' and those it skipped), from its parent runs' record;
    empty for a sweep that recorded none (one still running, or stopped)."""
    ids = []
    for parent in sweep_parents(client, sweep_dir):
        with tempfile.TemporaryDirectory() as folder:
            try:
                ids += json.loads(Path(client.download_artifacts(parent.info.run_id, SWEEP_RUNS_ARTIFACT, folder)).read_text())
            except (MlflowException, OSError):
                continue
    return list(dict.fromkeys(ids))


def all_experiment_ids(client: MlflowClient) -> list[str]:
    """Every experiment of the store: a sweep's jobs may log to other experiments than its parent's."""
    return [experiment.experiment_id for experiment in client.search_experiments()]


# ---------------------------------------------------------------- logging a run


def log_params_and_tags(client: MlflowClient, run_id: str, params: dict[str, str], tags: dict[str, str]) -> None:
    """Log in chunks of MLflow's batch limit; over-long values are cut (the full config is an artifact)."""
    param_list = [Param(k, v[:6000]) for k, v in params.items()]
    tag_list = [RunTag(k, str(v)[:8000]) for k, v in tags.items()]
    for start in range(0, len(param_list), MAX_BATCH):
        client.log_batch(run_id, params=param_list[start : start + MAX_BATCH])
    for start in range(0, len(tag_list), MAX_BATCH):
        client.log_batch(run_id, tags=tag_list[start : start + MAX_BATCH])


def metric_series(result) -> dict[str, list[tuple[int, float]]]:
    """Every metric a run logs, as (step, value) pairs: the scores and window counts at step 0, the training curves
    one step per epoch."""
    series = {key: [(0, float(value))] for key, value in result.metrics.items()}
    for record in result.history:
        for key, value in record.items():
            if key != "epoch":
                series.setdefault(key, []).append((int(record["epoch"]), float(value)))
    series.update(n_train=[(0, float(result.n_train))], n_test=[(0, float(result.n_test))])
    return series


def log_result(client: MlflowClient, run_id: str, result) -> None:
    """Metrics, training curves (as stepped metrics and a PNG), confusion matrix, per-record accuracy, Table 2 / 3 artifacts."""
    now = int(time.time() * 1000)
    metrics = [Metric(key, value, now, step) for key, points in metric_series(result).items() for step, value in points]
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
    # "—": a class with no test windows has no recall or F1 (and no precision when never called)
    rows = [[name, *(f"{metrics[key]:.3f}" if key in metrics else "—"
                     for key in (f"{m}_{name}" for m in ("precision", "recall", "f1")))] for name in class_names]
    (folder / "per_class.csv").write_text(csv_table(header, rows))
    (folder / "per_class.md").write_text(markdown_table(header, rows) + f"\naccuracy: {metrics['accuracy']:.4f}\n")


def _plot_curves(history: list[dict], path: Path) -> None:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8, 3.2))
    loss_axes, accuracy_axes = figure.subplots(1, 2)
    epochs = [record["epoch"] for record in history]
    for stage, label in (("train", "train"), ("test", "test (read only: never stops or chooses)")):
        if f"{stage}_loss" in history[0]:
            loss_axes.plot(epochs, [r[f"{stage}_loss"] for r in history], label=label)
            accuracy_axes.plot(epochs, [r[f"{stage}_accuracy"] for r in history], label=label)
    loss_axes.set(xlabel="epoch", ylabel="cross-entropy loss")
    accuracy_axes.set(xlabel="epoch", ylabel="accuracy")
    accuracy_axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=100)


# ---------------------------------------------------------------- the tracked run


def skips_finished(tracking_cfg: DictConfig, sweep: SweepInfo | None) -> bool:
    """Whether a config that already FINISHED is skipped: ``tracking.skip_finished``, or when
    unset (null), in a sweep (resuming it) but not in a single run (asked for again)."""
    choice = tracking_cfg.get("skip_finished")
    return sweep is not None if choice is None else bool(choice)


def train_tracked(cfg: DictConfig, choices: dict, sweep: SweepInfo | None, root_dir: str | None, train) -> TrackedRun | None:
    """Run ``train(cfg, root_dir) -> ExperimentResult`` inside an MLflow run and log everything.

    Returns the run and its metrics (the earlier run, ``skipped``, when one with this config
    already FINISHED). A failure marks the run FAILED with the error as tag ``error`` and artifact ``error.txt``; inside
    a sweep it is logged and swallowed so the sweep goes on (returns None), in a single run
    it is re-raised so the entry point exits non-zero.
    """
    if check_registration(cfg)[0] and registry_uri(str(cfg.tracking.uri)) != str(cfg.tracking.uri):
        check_store(registry_uri(str(cfg.tracking.uri)))  # refused before the training, not after it
    silence = server_silence(str(cfg.tracking.uri)) if sweep is not None and _is_server(str(cfg.tracking.uri)) else None
    if silence is not None:  # gone since the sweep began (a job before this one said when): not run, at once
        log.error("job %s not run: %s: the tracking server does not answer (%s)", sweep.job,
                  store_setting(str(cfg.tracking.uri)), silence)
        return None
    client, experiment_id = open_store(cfg.tracking)
    if sweep is None:  # a sweep's process reaps once for all its jobs
        reap_dead_runs(client)
    digest = config_hash(cfg)
    if skips_finished(cfg.tracking, sweep):
        done = find_finished_run(client, experiment_id, digest)
        if done is not None:
            other_code = computed_by_other_code(done)
            log.info("skipped: run %s already FINISHED with this config (config_hash %s)%s", done.info.run_id, digest,
                     f", by the code {other_code}; tracking.skip_finished=false runs it again" if other_code else "")
            return TrackedRun(done.info.run_id, dict(done.data.metrics), skipped=True, artifacts=done.info.artifact_uri,
                              model=earlier_model(client, done.info.run_id), other_code=other_code)
    method = method_name(choices)
    tags = {
        "bt.kind": "train",
        "config_hash": digest,
        "method": method,
        "features": choices.get("features", ""),
        "classifier": choices.get("classifier", ""),
        **({"estimator": str(cfg.classifier.estimator._target_)} if _estimator_class(cfg) else {}),
        "experiment": experiment_tag(cfg, choices),
        "seed": str(cfg.seed),
        **({"output_dir": str(root_dir)} if root_dir else {}),  # Hydra's folder of the run: its log, its checkpoints
        "git_commit": git_commit(),
        "code": code_tag(),  # two states of one commit with changes not committed told apart
        "cpu_kernels": cpu_kernels(),  # the network's figures are the same wherever these are (bearingtwin/__init__)
        **_versions(),
        **environment_tags(),
    }
    if sweep is not None:
        tags.update(sweep=sweep.name, sweep_dir=sweep.sweep_dir, sweep_varied=" ".join(sweep.varied), sweep_job=str(sweep.job))
        parent = find_sweep_parent(client, sweep.sweep_dir)
        if parent is not None and parent.info.status != "RUNNING":  # stopped: a job a cluster starts late stays unrun
            log.warning("job %s not started: its sweep's run %s is %s", sweep.job, parent.info.run_id, parent.info.status)
            return None
        if parent is not None:
            tags["mlflow.parentRunId"] = parent.info.run_id
    # A child of its sweep from its first instant: a sweep interrupted before the other tags are logged
    # still finds the run among its RUNNING children and marks it KILLED (its worker is killed, not told).
    child_of = {key: tags[key] for key in ("mlflow.parentRunId", "sweep_job") if key in tags}
    run = open_owned_run(client, experiment_id, run_name(cfg, method, sweep), {"bt.kind": "train", **child_of})
    run_id = run.info.run_id
    try:
        log_params_and_tags(client, run_id, flatten(loggable_config(cfg)), tags)
        client.log_text(run_id, OmegaConf.to_yaml(OmegaConf.create(loggable_config(cfg))), CONFIG_ARTIFACT)
        result = train(cfg, root_dir)
        log_params_and_tags(client, run_id, {}, {"dataset_key": result.dataset_key, "features_key": result.features_key,
                                                 **({"device": result.device} if result.device else {})})
        log_result(client, run_id, result)
        model = log_model(cfg, experiment_id, run_id, result, digest)
    except Exception as error:
        lost = _server_lost(str(cfg.tracking.uri), run_id, error)
        if lost is not None:  # nothing can be marked: the next command that finds the server marks the run KILLED
            forget_open_run(run_id)
            if sweep is None:
                raise lost from None
            log.error("%s (the sweep goes on)", lost)
            return None
        # FAILED first: an artifact store that refuses the error's text must not leave the run RUNNING.
        client.set_terminated(run_id, RunStatus.to_string(RunStatus.FAILED))
        with contextlib.suppress(MlflowException, OSError):
            client.set_tag(run_id, "error", f"{type(error).__name__}: {error}"[:8000])
            client.log_text(run_id, traceback.format_exc(), "error.txt")
        if sweep is None:
            raise
        log.error("run %s FAILED: %s: %s (the sweep goes on)", run_id, type(error).__name__, error)
        return None
    raise_if_interrupted()  # a signal whose exception a C callback swallowed still stops the run: KILLED
    status = client.get_run(run_id).info.status if sweep is not None else "RUNNING"
    if status != "RUNNING":
        # The interrupted sweep closed it (KILLED) while a worker it could not stop at once went on: as it said.
        log.warning("job %s ended after its sweep was stopped: run %s stays %s", sweep.job, run_id, status)
        return None
    client.set_terminated(run_id, RunStatus.to_string(RunStatus.FINISHED))
    return TrackedRun(run_id, {**result.metrics, "n_train": result.n_train, "n_test": result.n_test}, model=model,
                      artifacts=run.info.artifact_uri)


def _is_server(uri: str) -> bool:
    return urlparse(uri).scheme in ("http", "https")


def _server_lost(uri: str, run_id: str, error: Exception) -> BearingTwinError | None:
    """The error to stop with when ``error`` came from a tracking server that no longer answers (None otherwise)."""
    if not isinstance(error, MlflowException) or not _is_server(uri):
        return None
    silence = server_silence(uri)
    if silence is None:
        return None
    return BearingTwinError(f"{store_setting(uri)}: the tracking server stopped answering during run {run_id} ({silence}); "
                            "the run stays RUNNING there until the next bearingtwin-train on this host finds the server "
                            "again and marks it KILLED")


def registry_uri(tracking_uri: str) -> str:
    """The Model Registry's store: ``MLFLOW_REGISTRY_URI`` where the user set it, as MLflow's own tools read it
    (``mlflow.pyfunc.load_model``, ``mlflow models serve``), else the tracking store, as theirs default to: a model
    registered here is the one they serve, and one they serve is one a diagnosis finds."""
    return os.environ.get("MLFLOW_REGISTRY_URI") or tracking_uri


def use_registry(tracking_uri: str) -> str:
    """Point MLflow's own calls (``register_model``, ``pyfunc.load_model``) at :func:`registry_uri`, and return it,
    leaving ``MLFLOW_REGISTRY_URI`` as the user set it: MLflow's ``set_registry_uri`` writes the variable too, which
    this process, and every process it starts, would then read as the user's."""
    import mlflow

    registry, before = registry_uri(tracking_uri), os.environ.get("MLFLOW_REGISTRY_URI")
    mlflow.set_registry_uri(registry)
    if before is None:
        os.environ.pop("MLFLOW_REGISTRY_URI", None)
    else:
        os.environ["MLFLOW_REGISTRY_URI"] = before
    return registry


def store_setting(uri: str) -> str:
    """The store ``uri`` as the user set it, for a message: ``MLFLOW_TRACKING_URI=<uri>`` where the environment gave
    it (no ``tracking.uri=`` on the command line; a relative SQLite file's, read from the launch folder under
    ``hydra.job.chdir=true``, too), else ``tracking.uri=<uri>``."""
    from bearingtwin.config import given_on_command_line

    given = os.environ.get("MLFLOW_TRACKING_URI", "")
    if uri == os.environ.get("MLFLOW_REGISTRY_URI") and uri != given and not given_on_command_line("tracking.uri"):
        return f"MLFLOW_REGISTRY_URI={uri}"
    given_file, read_file = _sqlite_path(given), _sqlite_path(uri)
    same = given == uri or bool(given_file and read_file and not Path(given_file).is_absolute()
                                and read_file.endswith(f"/{given_file}"))
    from_environment = bool(given) and same and not given_on_command_line("tracking.uri")
    return f"{'MLFLOW_TRACKING_URI' if from_environment else 'tracking.uri'}={uri}"


def experiment_tag(cfg: DictConfig, choices: Mapping | None = None) -> str:
    """A run's ``experiment`` tag: +experiment=<name>, a protocol's runs. A versioned protocol names itself
    (``protocol: sim2real_v2``), so its runs are found whichever name selected it (+experiment=sim2real selects the
    version in force); version 1's file predates the key and is named by its choice. ``choices``: the config
    groups chosen (Hydra's runtime choices; None: read from the running app, or from a config composed with its
    ``hydra`` node)."""
    if choices is None:
        from hydra.core.hydra_config import HydraConfig

        hydra_cfg = HydraConfig.get() if HydraConfig.initialized() else cfg.get("hydra")
        choices = {} if hydra_cfg is None else hydra_cfg.runtime.choices
    return str(cfg.get("protocol") or choices.get("experiment") or "")


def check_registration(cfg: DictConfig) -> tuple[str | None, str | None]:
    """``register`` and ``register_alias``, checked before any work is done."""
    # MLflow's own rules for the names (a name without '/' or ':'; an alias of letters, digits, '_' and '-',
    # neither 'latest' nor v<number>), read here so a bad one is refused before training, not after it.
    try:
        from mlflow.utils.validation import (_validate_model_alias_name, _validate_model_alias_name_reserved,
                                             _validate_model_name)
        rules_of = {"register": (_validate_model_name,),
                    "register_alias": (_validate_model_alias_name, _validate_model_alias_name_reserved)}
    except ImportError:  # private helpers of MLflow: without them, its registry says so after the training
        rules_of = {}

    name, alias = cfg.get("register"), cfg.get("register_alias")
    if alias and not name:
        raise BearingTwinError(f"register_alias={alias} needs register=<model name> (or register_alias=null)")
    from bearingtwin.tracking.sim2real_protocol import PROTOCOL_MODEL, protocol_version

    data = cfg.get("data") or {}
    if name == PROTOCOL_MODEL and protocol_version(experiment_tag(cfg)) is None:
        # bearingtwin-diagnose model=models:/sim2real@champion is the README's diagnosis of real recordings
        raise BearingTwinError(f"register={name} is the pre-registered protocol's model (bearingtwin-train "
                               f"+experiment=sim2real); register this run's under a name of its own: register=<name>")
    if name == PROTOCOL_MODEL and data.get("source") == "twin_to_real" and data.get("labels"):
        raise BearingTwinError(f"register={name} is the CWRU protocol's model; a model of another rig's records "
                               "(data.labels) is registered under a name of its own: register=<your rig>")
    for key, value in (("register", name), ("register_alias", alias)):
        try:
            for rule in rules_of.get(key, ()) if value is not None else ():
                rule(str(value))
        except MlflowException as error:
            raise BearingTwinError(f"{key}={value}: {' '.join(error.message.split())}") from None
    return name, alias


def log_model(cfg: DictConfig, experiment_id: str, run_id: str, result, digest: str) -> str:
    """The run's fitted pipeline as its MLflow model ``model``; registered as ``register`` (alias
    ``register_alias``) when the config asks. Returns the model's URIs, for the closing summary."""
    from bearingtwin.diagnosis.mlflow_model import log_diagnosis_model, register_model

    if result.pipeline is None:  # a result made without fitting one (a stand-in trainer) has no model to log
        return ""
    result.pipeline.config_hash = digest
    uri = str(cfg.tracking.uri)
    info = log_diagnosis_model(uri, experiment_id, run_id, result.pipeline, result.example_windows, result.example_rpm)
    name, alias = check_registration(cfg)
    if name:
        from bearingtwin.models.experiment import misread_calibration

        misread = misread_calibration(result.metrics)
        withheld = alias if alias and misread else None  # not made the one a user's models:/<name>@<alias> reaches
        alias = None if withheld else alias
        scored = {key: f"{result.metrics[key]:.6g}" for key in ("accuracy", "calibration_accuracy")
                  if key in result.metrics}
        client = MlflowClient(tracking_uri=uri)
        version, before = register_model(
            uri, info.model_uri, str(name), None if alias is None else str(alias),
            description=(f"{client.get_run(run_id).info.run_name}"
                         + (f": {100 * result.metrics['accuracy']:.2f} % of its test windows right"
                            if "accuracy" in result.metrics else "")),
            tags={"run_id": run_id, "config_hash": digest, "seed": str(cfg.seed), **scored})
        moved = f" (moved from version {before})" if before and before != version else ""
        log.info("registered %s version %s%s%s", name, version, f" as @{alias}" if alias else "", moved)
        client.set_tag(run_id, "registered_model", f"{name}/{version}")
        return (f"runs:/{run_id}/model = models:/{name}/{version}" + (f" = models:/{name}@{alias}{moved}" if alias else "")
                + (f" (not made @{withheld}: it misreads its {' and '.join(misread)} calibration record"
                   f"{'s' if len(misread) > 1 else ''}, as the warning says)" if withheld else ""))
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
            job_config = loader.load_sweep_config(config, list(job))
            if job_config.hydra.job.get("chdir"):  # the paths its task will read, as it will read them
                absolute_inputs(job_config, str(config.hydra.runtime.cwd))
            yield job_config


@dataclass(frozen=True)
class JobOutcome:
    """What became of one job of a multirun: ``FINISHED``, ``SKIPPED`` (an earlier run had
    finished this config), or anything else (``FAILED``, ``KILLED``, ``NOT RUN``) with a reason."""

    overrides: str
    status: str
    reason: str = ""
    run_id: str | None = None  # the job's run, or for a skipped job the earlier FINISHED run it stands for
    accuracy: float | None = None  # that run's, where it logged one
    method: str = ""  # that run's method (features+classifier), where it logged one


def sweep_outcomes(client: MlflowClient, parent_run_id: str, jobs: list[DictConfig]) -> list[JobOutcome]:
    """Each job's outcome: the parent's child run of its job number (in any experiment of the store), else an
    earlier FINISHED run of its config hash (skipped)."""
    children = {}
    for child in find_runs(client, all_experiment_ids(client), f"tags.`mlflow.parentRunId` = '{parent_run_id}'"):
        children.setdefault(child.data.tags.get("sweep_job"), child)  # newest first
    # Overrides every job shares (store, sizes) say nothing about which job it was.
    shared = set.intersection(*(set(job.hydra.overrides.task) for job in jobs)) if len(jobs) > 1 else set()
    outcomes = []
    for number, job in enumerate(jobs):  # in Hydra's order, which numbers the jobs
        overrides = " ".join(o for o in job.hydra.overrides.task if o not in shared)
        try:
            digest = config_hash(_task_config(job))
        except OmegaConfBaseException as error:  # the job failed on the same config before logging anything
            outcomes.append(JobOutcome(overrides, "NOT RUN", f"{type(error).__name__}: {error}"))
            continue
        child = children.get(str(number))
        if child is not None:
            reason = child.data.tags.get("error") or child.data.tags.get("bt.killed") or ""
            if child.info.status == "KILLED" and not reason:
                reason = "interrupted"
            outcomes.append(JobOutcome(overrides, child.info.status, reason.splitlines()[0] if reason else "",
                                       child.info.run_id, child.data.metrics.get("accuracy"),
                                       child.data.tags.get("method", "")))
        elif (earlier := _finished_in_own_experiment(client, job, digest)) is not None:
            outcomes.append(JobOutcome(overrides, "SKIPPED", computed_by_other_code(earlier), earlier.info.run_id,
                                       earlier.data.metrics.get("accuracy"), earlier.data.tags.get("method", "")))
        else:
            outcomes.append(JobOutcome(overrides, "NOT RUN", "the job ended before its MLflow run was created (see its log)"))
    return outcomes


def sweep_accuracies(outcomes: list[JobOutcome]) -> dict[str, float]:
    """A sweep's jobs' accuracies at a glance, where the runs list shows it beside others: their mean, spread, least
    and most (``accuracy_mean``, ...) where they are of one method; of each method apart (``accuracy_mean/<method>``,
    its ``+`` a ``-``, which a metric's name cannot hold) where they are of several, whose mean together is of
    nothing."""
    by_method: dict[str, list[float]] = {}
    for outcome in outcomes:
        if outcome.status in ("FINISHED", "SKIPPED") and outcome.accuracy is not None:
            by_method.setdefault(outcome.method, []).append(outcome.accuracy)
    metrics = {}
    for method, scores in by_method.items():
        suffix = f"/{method.replace('+', '-')}" if len(by_method) > 1 else ""
        metrics.update({f"accuracy_mean{suffix}": np.mean(scores), f"accuracy_std{suffix}": np.std(scores),
                        f"accuracy_min{suffix}": min(scores), f"accuracy_max{suffix}": max(scores)})
    return metrics


def _finished_in_own_experiment(client: MlflowClient, job: DictConfig, digest: str):
    """The FINISHED run a job skipped for, looked up where the job logs (a sweep may vary tracking.experiment)."""
    experiment = client.get_experiment_by_name(str(job.tracking.experiment))
    return None if experiment is None else find_finished_run(client, experiment.experiment_id, digest)


def _task_config(job: DictConfig) -> DictConfig:
    """A job's config as its task sees it: without the ``hydra`` node, as Hydra's ``run_job``
    removes it (its unset runtime fields could not be resolved here)."""
    task = copy.deepcopy(job)
    with open_dict(task):
        del task["hydra"]
    return task


def format_sweep_summary(name: str, parent_run_id: str, outcomes: list[JobOutcome], max_listed: int = 15) -> str:
    """One screen: the counts, the accuracies of the jobs that finished (each with its overrides, up to
    ``max_listed``; their range beyond: a launcher's workers may print their own lines to their logs alone), then each
    job that did not finish with its overrides and reason."""
    counts = {status: sum(o.status == status for o in outcomes) for status in ("FINISHED", "SKIPPED")}
    failed = [o for o in outcomes if o.status not in counts]
    lines = [
        f"sweep {name} (run {parent_run_id}): {len(outcomes)} job{'s' * (len(outcomes) != 1)}, "
        f"{counts['FINISHED']} finished, {len(failed)} failed, {counts['SKIPPED']} skipped (already finished)"
    ]
    by_other_code = [o for o in outcomes if o.status == "SKIPPED" and o.reason]
    if by_other_code:  # their numbers are another code's: said where the counts are, not only in the log
        lines.append(f"  {len(by_other_code)} of the skipped {'was' if len(by_other_code) == 1 else 'were'} computed by "
                     "other code, the first "
                     f"{by_other_code[0].reason}: tracking.skip_finished=false runs them again")
    scored = [o for o in outcomes if o.status in counts and o.accuracy is not None]
    if len(scored) > max_listed:
        accuracies = [o.accuracy for o in scored]
        lines.append(f"  accuracy: {percent(min(accuracies))} to {percent(max(accuracies))}, mean "
                     f"{percent(float(np.mean(accuracies)))} over {len(scored)} jobs (each in its run)")
    elif scored:
        lines.append("  accuracy: " + "; ".join(f"{percent(o.accuracy)} ({o.overrides or 'no overrides'})" for o in scored))
    for outcome in failed[:max_listed]:
        reason = outcome.reason if len(outcome.reason) <= 160 else outcome.reason[:157] + "..."
        lines.append(f"  {outcome.status}: {outcome.overrides or '(no overrides)'}: {reason}")
    if len(failed) > max_listed:
        lines.append(f"  ... and {len(failed) - max_listed} more (tags.error of the sweep's child runs in MLflow)")
    return "\n".join(lines)


class SweepParentRun(Callback):
    """Hydra callback: one parent MLflow run per multirun, closed with the children's outcome.

    Created before any job starts (so parallel jobs also find an initialised store), and
    only once every job's overrides compose into a config, name declared keys, and its data files are present:
    otherwise the sweep exits with status 2 naming them and logs nothing. At the end it prints a summary and ends
    FINISHED when every job finished or was skipped; otherwise FAILED, and the command
    exits 1. (Exiting, not raising: Hydra turns a callback's exception into a warning.)
    """

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        # Hydra's shuffle() draws from Python's global random state, and the sweeper expands its jobs after this
        # callback: expanded from the state it will start from, the jobs here and at the end are Hydra's, in its order.
        self._random_state = random.getstate()
        try:
            self._open_parent(config)
        except Exception as error:  # Hydra would warn and run the jobs unparented, then exit 0
            print(f"error: the sweep could not start: {type(error).__name__}: {error}", file=sys.stderr)
            sys.exit(1)
        finally:
            random.setstate(self._random_state)

    def _jobs(self, config: DictConfig) -> list[DictConfig]:
        """The sweep's jobs, composed, in the order Hydra numbers them (also under ``shuffle()``)."""
        now = random.getstate()
        random.setstate(self._random_state)
        try:
            return list(sweep_job_configs(config))
        finally:
            random.setstate(now)

    def _open_parent(self, config: DictConfig) -> None:
        from bearingtwin.models.build import classifier_settings

        jobs = exit_on_user_error(self._jobs)(config)
        for job in jobs:
            exit_on_user_error(refuse_unknown_keys)(job.hydra)
            # A bad value in a swept list (seed=0,1,x) fails its jobs alone; refused here, it leaves no FAILED runs.
            exit_on_user_error(check_seed)(job.seed)
            exit_on_user_error(check_data_settings)(job)
            exit_on_user_error(classifier_settings)(job.classifier, job.trainer)  # a config file's misspelt key
            exit_on_user_error(build_effects)(job.get("effects"))  # their parameters, before any job starts
            exit_on_user_error(check_registration)(job)  # a bad model name, before a parent run is opened
        exit_on_user_error(require_files)(jobs)
        exit_on_user_error(refuse_alias_in_sweep)(jobs)
        self._tracking = exit_on_user_error(sweep_tracking)(config, jobs)
        exit_on_user_error(refuse_slurm_without_slurm)(config.hydra.launcher)
        warn_of_hydras_launcher(config.hydra.runtime.choices)
        varied_list = varied_keys(jobs)
        varied = " ".join(varied_list)  # for the jobs' run names
        if str(config.hydra.launcher.get("_target_", "")).endswith(".ray_launcher.RayLauncher"):
            # Before any run is open: Ray may not start. Its workers have environments of their own: the varied
            # keys are handed to them as the store and cache are (conf/launcher/ray.yaml).
            init = OmegaConf.create(OmegaConf.to_container(config.hydra.launcher.ray.init, resolve=True))
            runtime_env = init.get("runtime_env") or {}
            init.runtime_env = {**runtime_env, "env_vars": {**(runtime_env.get("env_vars") or {}), SWEEP_VARIED_ENV: varied}}
            exit_on_user_error(start_ray_keeping_signals)(init)
        client, experiment_id = exit_on_user_error(open_store)(self._tracking)
        reap_dead_runs(client)
        name = sweep_name(config.hydra.runtime.choices, varied_list)
        sweep_dir = sweep_folder(config.hydra)
        self._parent_id = open_owned_run(
            client, experiment_id, f"sweep {name} {Path(sweep_dir).parent.name}/{Path(sweep_dir).name}",  # <date>/<time>
            {"bt.kind": "sweep", "sweep": name, "sweep_dir": sweep_dir,
             "overrides": overrides_tag(config.hydra.overrides.task)},  # the command's, swept lists as given
            label="sweep", with_children=True).info.run_id
        os.environ[SWEEP_PID_ENV] = str(os.getpid())  # inherited by joblib's workers, which watch it
        os.environ[SWEEP_VARIED_ENV] = varied  # so are the keys that tell its jobs apart

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        jobs = self._jobs(config)
        # The store resolved at the start: a job may have changed what the config's interpolations read since
        # (MLflow sets MLFLOW_TRACKING_URI as a job logs its model).
        tracking = self._tracking
        uri = str(tracking.uri)
        silence = server_silence(uri) if _is_server(uri) else None
        if silence is not None:  # MLflow would retry each of the calls below for half a minute, then fail anyway
            forget_open_run(self._parent_id)  # nothing can close it now; the next command that finds the server does
            print(f"error: the sweep's outcome could not be recorded: {store_setting(uri)}: the tracking server stopped "
                  f"answering ({silence}); its runs stay as they are there until a command on this host finds the "
                  f"server again and marks those left RUNNING KILLED (sweep outputs: {sweep_folder(config.hydra)})",
                  file=sys.stderr, flush=True)
            sys.exit(1)
        client, _ = exit_on_user_error(open_store)(tracking)
        sweep_dir = sweep_folder(config.hydra)
        parent = find_sweep_parent(client, sweep_dir)
        if parent is None:
            return
        parent_id = parent.info.run_id
        # Hydra turns an exception raised here into a warning and exits 0: whatever fails while the sweep's
        # outcome is recorded, the parent is closed and the exit code says the sweep did not end well.
        try:
            outcomes = sweep_outcomes(client, parent_id, jobs)
            n_failed = sum(o.status not in ("FINISHED", "SKIPPED") for o in outcomes)
            client.set_terminated(parent_id, "FAILED" if n_failed else "FINISHED")
            for tag, count in (("n_finished", sum(o.status == "FINISHED" for o in outcomes)), ("n_failed", n_failed),
                               ("n_skipped", sum(o.status == "SKIPPED" for o in outcomes))):
                client.set_tag(parent_id, tag, str(count))
            client.log_batch(parent_id, metrics=[Metric(key, float(value), int(time.time() * 1000), 0)
                                                 for key, value in sweep_accuracies(outcomes).items()])
            # The runs the sweep stands for, those it skipped included (they carry another sweep's sweep_dir):
            # what `bearingtwin-report sweep_dir=<this sweep>` reads.
            client.log_dict(parent_id, [o.run_id for o in outcomes if o.status in ("FINISHED", "SKIPPED")],
                            SWEEP_RUNS_ARTIFACT)
        except Exception as error:  # any failure of the store: said in one line, never a warning
            with contextlib.suppress(Exception):
                client.set_terminated(parent_id, "FAILED")
            print(f"error: the sweep's outcome could not be recorded in {tracking.uri} ({type(error).__name__}: "
                  f"{str(error).strip().splitlines()[0] if str(error).strip() else ''}); sweep run {parent_id} marked "
                  "FAILED", file=sys.stderr, flush=True)
            sys.exit(1)
        experiments = sorted({str(job.tracking.experiment) for job in jobs} | {str(tracking.experiment)})
        print(f"sweep outputs: {sweep_dir} (runs in experiment{'s' * (len(experiments) > 1)} {', '.join(experiments)}: "
              f"{open_command(tracking.uri)})", flush=True)
        print(format_sweep_summary(parent.data.tags.get("sweep", "of one setting"), parent_id, outcomes), flush=True)
        if n_failed:
            sys.exit(1)


def refuse_alias_in_sweep(jobs: list[DictConfig]) -> None:
    """Refuse a registry alias given to the jobs of a sweep: each job would move it to its own model, so it would
    end on whichever job finished last (a protocol's champion on seed 4, not seed 0)."""
    aliased = [job for job in jobs if job.get("register_alias") is not None]
    if len(jobs) > 1 and aliased:
        alias = aliased[0].register_alias
        raise BearingTwinError(
            f"register_alias={alias} in a sweep of {len(jobs)} jobs: each job would move @{alias} to its own model, "
            f"leaving it on whichever finished last. Run the sweep with register_alias=null (and register=null to "
            f"register nothing), then train the chosen configuration alone with register_alias={alias}")


def sweep_tracking(config: DictConfig, jobs: list[DictConfig]) -> DictConfig:
    """The sweep's ``tracking`` settings with its jobs' store, resolved: the store its parent run belongs in.

    The jobs' store, not the sweep's own config's, which lacks a store a sweep file's params set; and
    resolved once, as the interpolations read the environment, which a job may change. Jobs logging to
    several stores are refused: one parent run cannot stand in all of them.
    """
    uris = sorted({str(job.tracking.uri) for job in jobs} or {str(config.tracking.uri)})
    if len(uris) > 1:
        raise BearingTwinError(f"tracking.uri differs between the sweep's jobs ({', '.join(uris)}): a sweep logs to "
                               "one store, where its parent run is; run one sweep per store")
    tracking = OmegaConf.to_container(config.tracking, resolve=True)
    return OmegaConf.create({**tracking, "uri": uris[0]})


def sweep_name(choices, varied: Sequence[str] = ()) -> str:
    """A sweep's name, as its parent run and its jobs' tags give it: the sweep file's (``+sweep=table4``), else the
    experiment's (``+experiment=sim2real``), else the keys a sweep of command-line values alone varies
    (``over classifier, seed``; ``of one setting`` where nothing varies: one job, or the same one repeated)."""
    return str(choices.get("sweep") or choices.get("experiment") or ("over " + ", ".join(varied) if varied else
                                                                      "of one setting"))


def sweep_folder(hydra_cfg) -> str:
    """The sweep's folder (``hydra.sweep.dir``) as an absolute path, the same in the sweep's process and
    in every job's: a relative one is taken from where the sweep was started (``hydra.runtime.cwd``, which
    travels in each job's config), never from the asking process's own working directory, which on a Ray
    worker or a Slurm node may be another. It names the sweep's parent run, so both sides must agree."""
    return str((Path(str(hydra_cfg.runtime.cwd)) / str(hydra_cfg.sweep.dir)).resolve())


LAUNCHED_HYDRAS_WAY = {
    "joblib": "Hydra's own joblib launcher: a job whose process is killed (out of memory) ends the whole sweep; "
              "launcher=joblib runs the project's, where such a job fails alone",
    "ray": "Hydra's Ray launcher with its defaults: its jobs are not given the sweep's MLflow store, cache and data "
           "folders (a worker of a cluster started elsewhere logs to its own), and it joins whatever cluster this "
           "machine last started; launcher=ray sets them",
    "submitit_slurm": "Hydra's submitit launcher with its defaults: its jobs are not given the sweep's MLflow store, "
                      "cache and data folders (sbatch --export=NONE starts them without this shell's), and are "
                      "stopped after an hour; launcher=submitit_slurm sets them (2 hours, 2 CPUs, 8 GB a job)",
    "submitit_local": "Hydra's submitit launcher with its defaults: its jobs are stopped after an hour; "
                      "launcher=submitit_local gives them 2 hours and a CPU each",
}
"""A launcher chosen Hydra's way (``hydra/launcher=<name>``) where ``launcher=<name>`` would run it with the
project's settings (conf/launcher), and what the first lacks."""


def warn_of_hydras_launcher(choices) -> None:
    """A line on stderr where a sweep's launcher was chosen as Hydra's plugin alone (``hydra/launcher=<name>``, Hydra's
    way of choosing one) and the project's ``launcher=<name>`` would have added its settings."""
    name = choices.get("hydra/launcher")
    if choices.get("launcher") is None and name in LAUNCHED_HYDRAS_WAY:
        print(f"warning: hydra/launcher={name} is {LAUNCHED_HYDRAS_WAY[name]}", file=sys.stderr, flush=True)


def refuse_slurm_without_slurm(launcher_cfg) -> None:
    """Refuse a SLURM launcher where SLURM's commands are not on PATH, before the sweep's run is opened (submitit
    fails on it inside the launch, with a traceback, and leaves an empty FAILED sweep run)."""
    if str(launcher_cfg.get("_target_", "")).endswith(".SlurmLauncher"):
        absent = [command for command in ("sbatch", "srun") if shutil.which(command) is None]
        if absent:
            raise BearingTwinError(f"launcher=submitit_slurm: no SLURM here ({' and '.join(absent)} not on PATH); run "
                                   "the sweep on the cluster's login node, or try it here with launcher=submitit_local")


SWEEP_VARIED_ENV = "BEARINGTWIN_SWEEP_VARIED"
"""The override keys whose values differ between a sweep's jobs, as its parent found them (for the jobs' run names)."""


def varied_keys(jobs: list[DictConfig]) -> list[str]:
    """The override keys whose values differ between ``jobs`` (``seed=0,1 data.samples_per_class=12,24``: both)."""
    # Each job's overrides as key -> value; a key one job leaves out differs from the jobs that give it.
    per_job = [dict(o.lstrip("+~").partition("=")[::2] for o in job.hydra.overrides.task) for job in jobs]
    keys = set().union(*per_job)
    return sorted(key for key in keys if len({overrides.get(key) for overrides in per_job}) > 1)


def sweep_info(hydra_cfg) -> SweepInfo | None:
    """The job's place in a multirun (None for a single run), from Hydra's runtime config."""
    from hydra.types import RunMode

    if hydra_cfg.mode != RunMode.MULTIRUN:
        return None
    # The sweep file's params are the varied keys, and those a command line's sweep varies (a job sees its own
    # values only: the sweep's parent says which keys differ between its jobs, SWEEP_VARIED_ENV).
    swept = {key.lstrip("+~") for key in (hydra_cfg.sweeper.get("params") or {})}
    swept |= set(os.environ.get(SWEEP_VARIED_ENV, "").split())
    varied = tuple(
        o.lstrip("+~")
        for o in hydra_cfg.overrides.task
        if o.split("=", 1)[0].lstrip("+~") in swept - {"seed", "method"}
    )
    return SweepInfo(
        name=sweep_name(hydra_cfg.runtime.choices, os.environ.get(SWEEP_VARIED_ENV, "").split()),
        sweep_dir=sweep_folder(hydra_cfg),
        varied=varied,
        job=int(hydra_cfg.job.num),
    )
