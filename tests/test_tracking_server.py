"""A team's MLflow tracking server: everything bearingtwin logs and reads goes to it over HTTP.

A real ``mlflow server`` runs as a team's would: a SQL database for runs and the registry (SQLite
here, PostgreSQL in production: README, "Team and cluster") and an artifact store it serves itself
(``--artifacts-destination``), on a loopback port, stopped at the end. The clients are given only
``MLFLOW_TRACKING_URI=http://127.0.0.1:<port>``, the one setting a user changes, and a working
directory of their own: a 2-job multirun (joblib launcher) registering its models, a twin run, a
diagnosis with a registered model, and reports reading runs and artifacts back. Nothing may be
written beside the clients (no local store), every artifact must be in the server's store.
"""

from __future__ import annotations

import subprocess
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from mlflow import MlflowClient
from processes import (SMOKE, assert_done, child_env, free_loopback_port, kill_running_commands, run_module, start, stop,
                       tail, wait_until_answers)

MODEL = "team-model"
SWEEP = ["seed=0", "classifier=svm,cnn_bilstm", "trainer.max_epochs=2", "launcher=joblib", f"register={MODEL}", *SMOKE]
TWIN_SMOKE = ["twin.duration=0.5", "compare.envelope_segment_s=0.25", "calibration.n_trials_base=3",
              "calibration.n_trials_effect=3", "calibration.n_trials_refine=3", "ranking.max_effects=1"]
SERVER_START_TIMEOUT_S = 120
CHILD_TIMEOUT_S = 600


def start_server(server_dir: Path, uri: str, env: dict, log: Path) -> subprocess.Popen:
    """A team's ``mlflow server`` on ``uri`` (runs in SQLite, artifacts served from ``server_dir``), once it answers."""
    # The server's own job runner (GenAI evaluation, trace archival) serves nothing here: off, to spare the cores.
    server = start([sys.executable, "-m", "mlflow", "server", "--backend-store-uri", f"sqlite:///{server_dir / 'db.sqlite'}",
                    "--artifacts-destination", str(server_dir / "artifacts"), "--host", "127.0.0.1",
                    "--port", uri.rsplit(":", 1)[1], "--workers", "1"],
                   {**env, "MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false"}, server_dir, log)
    wait_until_answers(f"{uri}/health", server, log, "mlflow server", SERVER_START_TIMEOUT_S)
    return server


@pytest.fixture(scope="module")
def team(tmp_path_factory):
    """The server's URI and folder, the clients' folder and environment, and each command's log."""
    root = tmp_path_factory.mktemp("team")
    server_dir, work = root / "server", root / "client"
    server_dir.mkdir()
    work.mkdir()
    uri = f"http://127.0.0.1:{free_loopback_port()}"
    env = child_env(uri)
    logs = {}
    pool = ThreadPoolExecutor(max_workers=3)

    def run(log: str, name: str, *args: str) -> Future:
        """A bearingtwin command in the background; its output goes to ``logs[log]`` when it ends."""
        def command() -> None:
            try:
                done = run_module(f"bearingtwin.cli.{name}", *args, cwd=work, env=env, timeout=CHILD_TIMEOUT_S)
            except subprocess.TimeoutExpired as timeout:  # its output so far, for the failure message
                logs[log].write_text(f"{timeout.output or ''}{timeout.stderr or ''}")
                raise AssertionError(f"bearingtwin-{name} ({log}) did not finish in {CHILD_TIMEOUT_S} s:\n"
                                     f"{tail(logs[log])}") from None
            logs[log].write_text(done.stdout + done.stderr)
            assert_done(done, f"bearingtwin-{name} ({log})")
        logs[log] = root / f"{log}.log"
        return pool.submit(command)

    logs["server"] = root / "server.log"
    server = start_server(server_dir, uri, env, logs["server"])
    try:
        simulate = run("simulate", "simulate", "fault=outer", "simulator.fs=12000", "simulator.duration=2.0",
                       f"out={work / 'outer.npz'}")
        sweep = run("sweep", "train", "-m", *SWEEP, f"hydra.sweep.dir={work / 'multirun'}")
        simulate.result()
        twin = run("twin", "twin", f"measured.path={work / 'outer.npz'}", f"out={work / 'twin'}", *TWIN_SMOKE,
                   "figures=false")  # the figures are tested in tests/test_twin_cli.py
        sweep.result()
        diagnose = run("diagnose", "diagnose", f"path={work / 'outer.npz'}", f"model=models:/{MODEL}/1",
                       f"out={work / 'diagnosis'}", "figures=false")
        twin.result()
        diagnose.result()
        yield uri, server_dir, work, env, logs
    finally:
        kill_running_commands()  # none when all went well; after a failure, the others need not finish
        pool.shutdown(cancel_futures=True)
        stop(server)


def experiment_runs(client: MlflowClient, name: str, kind: str) -> list:
    experiment = client.get_experiment_by_name(name)
    assert experiment is not None, f"no experiment {name} on the server"
    return client.search_runs([experiment.experiment_id], f"tags.`bt.kind` = '{kind}'")


def test_every_sweep_job_finished_on_the_server_with_its_results(team, tmp_path):
    uri, _, _, _, logs = team
    assert "2 jobs, 2 finished, 0 failed, 0 skipped" in logs["sweep"].read_text()
    assert f"(runs in experiment bearingtwin: open {uri})" in logs["sweep"].read_text()  # a server is opened, not a store
    client = MlflowClient(uri)
    (parent,) = experiment_runs(client, "bearingtwin", "sweep")
    assert parent.info.status == "FINISHED"
    runs = experiment_runs(client, "bearingtwin", "train")
    assert sorted(run.data.tags["classifier"] for run in runs) == ["cnn_bilstm", "svm"]
    for run in runs:
        assert run.info.status == "FINISHED" and run.data.tags["mlflow.parentRunId"] == parent.info.run_id
        assert {"accuracy", "f1_normal", "f1_outer", "n_test"} <= set(run.data.metrics)
        artifacts = {artifact.path for artifact in client.list_artifacts(run.info.run_id)}
        assert {"config.yaml", "confusion_matrix.csv", "confusion_matrix.png", "per_class.csv"} <= artifacts
        csv = Path(client.download_artifacts(run.info.run_id, "confusion_matrix.csv", str(tmp_path)))
        confusion = np.array([row.split(",")[1:] for row in csv.read_text().splitlines()[1:]], dtype=int)
        assert run.data.metrics["accuracy"] == pytest.approx(np.trace(confusion) / confusion.sum())
        (model,) = client.search_logged_models([run.info.experiment_id], filter_string=f"source_run_id = '{run.info.run_id}'")
        assert (model.name, str(model.status)) == ("model", "READY")


def test_both_models_are_registered_on_the_server(team):
    uri, _, _, _, _ = team
    client = MlflowClient(uri)
    versions = client.search_model_versions(f"name = '{MODEL}'")
    runs = {run.info.run_id: run for run in experiment_runs(client, "bearingtwin", "train")}
    assert sorted(int(version.version) for version in versions) == [1, 2]
    assert {version.run_id for version in versions} == set(runs)
    for version in versions:
        assert runs[version.run_id].data.tags["registered_model"] == f"{MODEL}/{version.version}"


def test_twin_and_diagnose_runs_logged_there_too(team, tmp_path):
    uri, _, work, _, logs = team
    client = MlflowClient(uri)
    (twin,) = experiment_runs(client, "bearingtwin-twin", "twin")
    assert twin.info.status == "FINISHED" and "final_error" in twin.data.metrics
    assert "twin_report.json" in {artifact.path for artifact in client.list_artifacts(twin.info.run_id)}
    (diagnosis,) = experiment_runs(client, "bearingtwin-diagnose", "diagnose")
    assert diagnosis.info.status == "FINISHED" and diagnosis.data.params["model"] == f"models:/{MODEL}/1"
    logged = Path(client.download_artifacts(diagnosis.info.run_id, "outer/diagnosis.json", str(tmp_path)))
    assert logged.read_text() == (work / "diagnosis" / "outer" / "diagnosis.json").read_text()
    for name in ("twin", "diagnose"):  # the closing summary points at the server
        assert f"(open {uri})" in logs[name].read_text()


def test_reports_read_runs_and_artifacts_from_the_server(team):
    uri, _, work, env, _ = team
    client = MlflowClient(uri)
    svm = next(run for run in experiment_runs(client, "bearingtwin", "train") if run.data.tags["classifier"] == "svm")
    # seeds reads the runs; repeat reads a run's config.yaml artifact and trains it again. Side by side.
    settings = {"seeds": [], "repeat": [f"run_id={svm.info.run_id}"]}
    with ThreadPoolExecutor(max_workers=2) as pool:
        reports = {name: pool.submit(run_module, "bearingtwin.cli.report", name, *args, f"out={work / name}.md",
                                     cwd=work, env=env, timeout=CHILD_TIMEOUT_S) for name, args in settings.items()}
    for name, report in reports.items():
        assert_done(report.result(), f"bearingtwin-report {name}")
    seeds, repeat = (reports[name].result().stdout + reports[name].result().stderr for name in settings)
    assert "sabo_vmd_pemie+svm" in seeds and f"0: {100 * svm.data.metrics['accuracy']:.2f}" in seeds
    assert "every metric matches" in repeat
    assert {run.data.tags["report"] for run in experiment_runs(client, "bearingtwin", "report")} == {"seeds", "repeat"}


def test_artifacts_live_in_the_servers_store_and_nothing_beside_the_clients(team):
    uri, server_dir, work, _, _ = team
    client = MlflowClient(uri)
    for name in ("bearingtwin", "bearingtwin-twin", "bearingtwin-diagnose"):
        location = client.get_experiment_by_name(name).artifact_location
        assert location.startswith("mlflow-artifacts:"), f"{name}: {location}"  # the server's, no client path
    stored = {path.name for path in (server_dir / "artifacts").rglob("*") if path.is_file()}
    assert {"confusion_matrix.csv", "twin_report.json", "diagnosis.json", "MLmodel"} <= stored
    written = {path.name for path in work.iterdir()}  # what the commands were told to write, and no more
    assert {"outer.npz", "multirun", "twin", "diagnosis"} <= written <= {"outer.npz", "multirun", "twin", "diagnosis",
                                                                      "seeds.md", "repeat.md"}
    assert not list(work.rglob("*.db")) and not list(work.rglob("mlruns")) and not list(work.rglob("mlartifacts"))


def test_a_server_that_dies_mid_run_ends_the_training_in_one_line_and_its_run_is_killed_when_it_is_back(tmp_path):
    """The server goes away while a training runs: the command stops with one line naming the run (MLflow's own
    retries, two tried here, not the four minutes of its defaults per request), and the next training that finds
    the server again marks the orphaned run KILLED."""
    server_dir, work = tmp_path / "server", tmp_path / "client"
    server_dir.mkdir()
    work.mkdir()
    uri = f"http://127.0.0.1:{free_loopback_port()}"
    env = child_env(uri, MLFLOW_HTTP_REQUEST_MAX_RETRIES="2")
    server = start_server(server_dir, uri, env, tmp_path / "server.log")
    pool = ThreadPoolExecutor(max_workers=1)
    try:
        # Long enough to be caught running: the network trains for many epochs on the smoke data set.
        training = pool.submit(run_module, "bearingtwin.cli.train", *SMOKE, "classifier=cnn_bilstm",
                               "trainer.max_epochs=400", cwd=work, env=env, timeout=CHILD_TIMEOUT_S)
        client = MlflowClient(uri)
        deadline = time.monotonic() + 300
        running = []
        while not running and time.monotonic() < deadline and not training.done():
            time.sleep(0.5)
            experiment = client.get_experiment_by_name("bearingtwin")
            running = [] if experiment is None else client.search_runs([experiment.experiment_id], "attributes.status = 'RUNNING'")
        assert running, "the training never showed a RUNNING run"
        stop(server)
        done = training.result()
        assert done.returncode == 2, done.stdout[-2000:] + done.stderr[-2000:]
        (line,) = [line for line in done.stderr.splitlines() if line.startswith("error:")]
        assert f"the tracking server stopped answering during run {running[0].info.run_id}" in line
        assert "Traceback" not in done.stderr
        server = start_server(server_dir, uri, env, tmp_path / "server_again.log")
        again = run_module("bearingtwin.cli.train", *SMOKE, "classifier=svm", cwd=work, env=env, timeout=CHILD_TIMEOUT_S)
        assert_done(again, "bearingtwin-train after the server came back")
        assert client.get_run(running[0].info.run_id).info.status == "KILLED"
        # MLflow prints "View run <name> at <url>" as a server's run ends: not on a command's stdout, which holds its
        # closing block alone (the run and how to open it are named there).
        assert "View run" not in again.stdout and again.stdout.startswith("== bearingtwin-train: "), again.stdout[-2000:]
    finally:
        kill_running_commands()
        pool.shutdown(cancel_futures=True)
        stop(server)
