"""Sweeps on Ray (``launcher=ray``, the ``ray`` extra): the same jobs give the basic launcher's results.

A Ray cluster is started apart, as a team's would be (``ray start --head --block``, 2 CPUs, on
loopback), from another working directory and with an environment naming another store, cache and
data root: its workers find the sweep's only through its configuration (``conf/launcher/ray.yaml``).
A 2-job multirun of the smallest runs goes through it, and the same multirun through the basic
launcher into a store and cache of its own; every run must agree metric for metric. The Ray jobs
share one cache, two at a time on the same entries, which must end whole. Skipped without the extra.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from mlflow import MlflowClient
from processes import SMOKE, child_env, free_loopback_port, run_module, start, stop, tail

from bearingtwin.models.experiment import TIMING_METRICS

# In the slow tier (python -m pytest -m slow): a Ray cluster's start and its workers' imports take about a
# minute and a half of the suite's two cores, which the default run's ten minutes cannot spare.
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        importlib.util.find_spec("ray") is None or importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None,
        reason='the ray extra is not installed (pip install -c requirements.lock -e ".[ray]")',
    ),
]

# One seed x two classifiers: the two jobs run at once on the two Ray workers and need the same
# simulated records and the same features, missing together.
SWEEP = ["seed=0", "classifier=svm,cnn_bilstm", "trainer.max_epochs=2", *SMOKE]
CLUSTER_START_TIMEOUT_S = 120
SWEEP_TIMEOUT_S = 600
# The cluster and its driver on loopback only: Ray otherwise advertises the machine's outward address
# (its single-machine mode, the default on macOS and Windows), and without token authentication,
# which a throwaway loopback cluster does not need.
RAY_LOCAL = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0"}


def sweep(folder: Path, *args: str, env: dict) -> subprocess.CompletedProcess:
    return run_module("bearingtwin.cli.train", "-m", *SWEEP, *args, cwd=folder, env=env, timeout=SWEEP_TIMEOUT_S)


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    """The Ray cluster's folder and, per launcher, its store's URI, cache folder and finished sweep."""
    root = tmp_path_factory.mktemp("ray")
    cluster_dir, basic_dir, ray_dir = (root / name for name in ("cluster", "basic", "driver"))
    for folder in (cluster_dir, basic_dir, ray_dir):
        folder.mkdir()
    port = free_loopback_port()
    # Its own temporary folder, so that it leaves no "current cluster" behind for a later ray.init on this
    # machine to join; in /tmp, Ray's own default root, since Ray's socket paths must fit in 107 bytes and
    # TMPDIR (inside the test session's folder, tests/conftest.py) may be too deep for them.
    ray_temp = Path(tempfile.mkdtemp(prefix="bt-ray-", dir="/tmp"))
    # The cluster's own environment points elsewhere (where nothing may appear): only the sweep's
    # configuration can lead its workers to the store, cache and data the sweep was started with.
    # No drain on SIGTERM: a node serving nothing would wait out Ray's 30 s (the teardown's 10 s grace, then SIGKILL).
    cluster_env = dict(os.environ, MLFLOW_TRACKING_URI=f"sqlite:///{cluster_dir / 'wrong.db'}",
                       BEARINGTWIN_CACHE=str(cluster_dir / "wrong-cache"), BEARINGTWIN_DATA=str(cluster_dir / "wrong-data"),
                       RAY_GRACEFUL_SHUTDOWN_DRAIN_TIMEOUT_S="0", **RAY_LOCAL)
    cluster_log = root / "cluster.log"
    cluster = start([str(Path(sys.executable).parent / "ray"), "start", "--head", "--block", "--port", str(port),
                     "--num-cpus", "2", "--include-dashboard", "false", "--disable-usage-stats", "--temp-dir", str(ray_temp),
                     # Ray's fixed default ports would collide with another cluster on this machine.
                     "--ray-client-server-port", str(free_loopback_port()),
                     "--dashboard-agent-listen-port", str(free_loopback_port())],
                    cluster_env, cluster_dir, cluster_log)
    try:
        runs = {}
        basic_env = child_env(f"sqlite:///{basic_dir / 'mlflow.db'}")  # the session's cache: its entries are the reference
        runs["basic"] = (basic_env, sweep(basic_dir, f"hydra.sweep.dir={basic_dir / 'multirun'}", env=basic_env))
        deadline = time.monotonic() + CLUSTER_START_TIMEOUT_S
        while "Ray runtime started" not in cluster_log.read_text(errors="replace"):
            if cluster.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"ray start did not start a cluster:\n{tail(cluster_log)}")
            time.sleep(0.2)
        # No hydra.sweep.dir: the default one, resolved where the sweep started (conf/train.yaml).
        ray_env = child_env(f"sqlite:///{ray_dir / 'mlflow.db'}", ray_dir / "cache", **RAY_LOCAL)
        runs["ray"] = (ray_env, sweep(ray_dir, "launcher=ray", f"hydra.launcher.ray.init.address=127.0.0.1:{port}", env=ray_env))
        yield cluster_dir, {name: (env["MLFLOW_TRACKING_URI"], Path(env["BEARINGTWIN_CACHE"]), done)
                            for name, (env, done) in runs.items()}, port
    finally:
        stop(cluster)  # ray start --block ends its node's processes on SIGTERM; the group's leftovers are killed
        shutil.rmtree(ray_temp, ignore_errors=True)


def finished_runs(uri: str) -> dict[str, object]:
    """The store's training runs by config hash; each must be FINISHED."""
    client = MlflowClient(uri)
    experiment = client.get_experiment_by_name("bearingtwin")
    runs = client.search_runs([experiment.experiment_id], "tags.`bt.kind` = 'train'")
    assert [run.info.status for run in runs] == ["FINISHED"] * len(runs)
    return {run.data.tags["config_hash"]: run for run in runs}


def test_both_sweeps_finish_every_job(sweeps):
    _, runs, _ = sweeps
    for name, (uri, _, done) in runs.items():
        assert done.returncode == 0, f"{name}: {done.stderr[-3000:]}"
        assert "2 jobs, 2 finished, 0 failed, 0 skipped" in done.stdout, f"{name}: {done.stdout[-2000:]}"
        assert len(finished_runs(uri)) == 2


def test_ray_jobs_give_the_basic_launchers_results(sweeps):
    _, runs, _ = sweeps
    basic, ray = (finished_runs(runs[name][0]) for name in ("basic", "ray"))
    assert set(ray) == set(basic)  # the same two configurations
    for digest, run in ray.items():
        expected = {k: v for k, v in basic[digest].data.metrics.items() if k not in TIMING_METRICS}
        got = {k: v for k, v in run.data.metrics.items() if k not in TIMING_METRICS}
        assert set(got) == set(expected), run.info.run_name
        # The network's losses are float sums whose order depends on torch's thread count (OMP_NUM_THREADS in the
        # basic launcher's process, one in a one-CPU Ray task): equal to float32 precision. Everything else exactly.
        for key, value in got.items():
            assert value == (pytest.approx(expected[key], rel=1e-6) if key.endswith("_loss") else expected[key]), \
                f"{run.info.run_name}: {key}"
        assert run.data.tags["dataset_key"] == basic[digest].data.tags["dataset_key"]


def test_ray_jobs_are_children_of_the_sweep_started_in_the_drivers_folder(sweeps):
    cluster_dir, runs, _ = sweeps
    uri = runs["ray"][0]
    client = MlflowClient(uri)
    experiment_id = client.get_experiment_by_name("bearingtwin").experiment_id
    (parent,) = client.search_runs([experiment_id], "tags.`bt.kind` = 'sweep'")
    assert parent.info.status == "FINISHED" and parent.data.tags["n_finished"] == "2"
    driver_dir = Path(uri.removeprefix("sqlite:///")).parent
    assert Path(parent.data.tags["sweep_dir"]).parent.parent == driver_dir / "multirun"
    children = finished_runs(uri).values()
    assert {run.data.tags.get("mlflow.parentRunId") for run in children} == {parent.info.run_id}
    assert {run.data.tags["sweep_dir"] for run in children} == {parent.data.tags["sweep_dir"]}
    # Named as the basic launcher's jobs are, by the classifier the sweep varies (a Ray worker has an environment
    # of its own: the sweep hands it the varied keys).
    basic_names = sorted(run.info.run_name for run in finished_runs(runs["basic"][0]).values())
    assert sorted(run.info.run_name for run in children) == basic_names and "classifier=svm" in " ".join(basic_names)
    # Each job's Hydra folder is in the sweep's folder, none in the cluster's working directory.
    assert len(list(Path(parent.data.tags["sweep_dir"]).glob("*/.hydra/config.yaml"))) == 2
    assert sorted(path.name for path in cluster_dir.iterdir()) == []


def test_ray_jobs_shared_one_cache_and_left_it_whole(sweeps):
    _, runs, _ = sweeps
    _, cache, _ = runs["ray"]
    simulated = list((cache / "simulated").iterdir())
    features = list((cache / "features").iterdir())
    assert [path.suffix for path in simulated] == [".npz"]  # one dataset for both jobs, no temporary left
    assert [path.suffix for path in features] == [".npz"]  # one extraction for both, no temporary left
    _, basic_cache, _ = runs["basic"]
    for entry in [*simulated, *features]:
        with np.load(entry) as stored, np.load(basic_cache / entry.parent.name / entry.name) as reference:
            assert sorted(stored.files) == sorted(reference.files)
            for name in stored.files:
                np.testing.assert_array_equal(stored[name], reference[name])


def test_a_terminated_ray_sweep_leaves_no_run_running_and_names_the_runs_it_killed(sweeps, tmp_path):
    """Ray's workers are no children of the sweep: they had gone on after SIGTERM, finishing runs the sweep had
    named KILLED and starting new ones left RUNNING. The sweep leaves Ray first, then marks what is still open."""
    _, _, port = sweeps
    env = child_env(f"sqlite:///{tmp_path / 'mlflow.db'}", tmp_path / "cache", **RAY_LOCAL)
    process = subprocess.Popen(
        [sys.executable, "-m", "bearingtwin.cli.train", "-m", *SMOKE, "classifier=svm", "seed=0,1,2,3,4,5",
         "launcher=ray", f"hydra.launcher.ray.init.address=127.0.0.1:{port}"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    client = MlflowClient(env["MLFLOW_TRACKING_URI"])
    deadline = time.monotonic() + SWEEP_TIMEOUT_S
    while time.monotonic() < deadline and process.poll() is None:
        if (tmp_path / "mlflow.db").exists() and client.search_runs(
                [e.experiment_id for e in client.search_experiments()], "attributes.status = 'FINISHED'"):
            break
        time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err[-3000:]
    (line,) = [line for line in err.splitlines() if line.startswith("interrupted by SIGTERM; marked KILLED: ")]
    time.sleep(5)  # a worker Ray had not yet stopped would show here
    runs = client.search_runs([e.experiment_id for e in client.search_experiments()])
    assert "RUNNING" not in {run.info.status for run in runs}
    named = set(line.split(": ", 1)[1].split(", "))
    killed = {f"{'sweep' if run.data.tags['bt.kind'] == 'sweep' else 'run'} {run.info.run_id}" for run in runs
              if run.info.status == "KILLED"}
    assert named == killed
