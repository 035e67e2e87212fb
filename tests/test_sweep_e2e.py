"""A real Table 4 multirun, smoke-sized, in parallel (joblib) into a fresh SQLite MLflow store.

``search.population=3,1``: every job of 3 must finish, every job of 1 must fail (SABO needs two candidates, which
only the job's own feature settings check, as it starts) and be logged FAILED while the sweep goes on, which then exits 1 with a summary naming them. The SABO methods and the raw method run as two
invocations of the same sweep: the second checks a sequential (basic launcher) sweep too.

The sweep is made once per test session: tests/test_report.py reads the same store, from whichever
worker runs it (the first to need it makes it, under a lock; the other waits and reuses it).
"""

import fcntl
import functools
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from mlflow import MlflowClient
from processes import run_module

SABO_METHODS = "+method=sabo_pemie_cnn_bilstm,sabo_minen_cnn_bilstm,sabo_pemie_svm"
DATA = ["data.samples_per_class=12", "data.duration=1.0", "trainer.max_epochs=2"]
SEARCH = ["search.iterations=1", "search.windows=2", "features.progress=false"]


def sweep(base: Path, *args: str) -> subprocess.CompletedProcess:
    return run_module("bearingtwin.cli.train", "-m", "+sweep=table4", *args, *DATA,
                      f"tracking.uri=sqlite:///{base}/mlflow.db", cwd=base, timeout=900)  # the session's cache


def run_sabo_sweep(base: Path) -> subprocess.CompletedProcess:
    return sweep(base, SABO_METHODS, "seed=0", "search.population=3,1", "launcher=joblib", *SEARCH,
                 f"hydra.sweep.dir={base}/multirun")


@functools.lru_cache(maxsize=None)
def smoke_sweep_store(base: Path) -> tuple[str, str]:
    """Run the smoke sweep once per session into ``base``; returns the tracking URI and the
    SABO sweep's standard output (its summary)."""
    summary = base / "sabo_sweep.stdout"
    with open(f"{base}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another worker may be making it: wait for it
        if not summary.exists():
            if base.exists():
                pytest.fail(f"the smoke sweep in {base} failed earlier in this session (see that test's error)")
            base.mkdir(parents=True)
            sabo = run_sabo_sweep(base)
            assert sabo.returncode == 1, sabo.stderr[-3000:]  # some jobs failed: the exit status says so
            raw = sweep(base, "+method=raw_cnn_bilstm", "seed=0", "search.population=3", f"hydra.sweep.dir={base}/multirun_raw")
            assert raw.returncode == 0, raw.stderr[-3000:]
            summary.write_text(sabo.stdout)
    return f"sqlite:///{base}/mlflow.db", summary.read_text()


def session_folder(tmp_path_factory) -> Path:
    """The smoke sweep's folder: in the session's base temporary folder, which every xdist worker shares."""
    base = tmp_path_factory.getbasetemp()
    return (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "smoke_sweep"


@pytest.fixture(scope="session")
def sweep_output(tmp_path_factory):
    return smoke_sweep_store(session_folder(tmp_path_factory))


@pytest.fixture(scope="session")
def store(sweep_output):
    client = MlflowClient(sweep_output[0])
    return client, client.get_experiment_by_name("bearingtwin").experiment_id


def training_runs(client, experiment_id):
    return client.search_runs([experiment_id], "tags.`bt.kind` = 'train'", max_results=1000)


def test_every_good_job_finished_with_metrics_and_artifacts(store, tmp_path):
    client, experiment_id = store
    finished = [r for r in training_runs(client, experiment_id) if r.info.status == "FINISHED"]
    assert sorted(r.info.run_name for r in finished) == [
        "raw+cnn_bilstm simulated seed=0",
        "sabo_vmd_minen+cnn_bilstm simulated global search.population=3 seed=0",  # the value it varies by is named
        "sabo_vmd_pemie+cnn_bilstm simulated global search.population=3 seed=0",
        "sabo_vmd_pemie+svm simulated global search.population=3 seed=0",
    ]
    for run in finished:
        artifacts = {a.path for a in client.list_artifacts(run.info.run_id)}
        assert {"config.yaml", "confusion_matrix.csv", "confusion_matrix.png", "per_class.csv"} <= artifacts
        assert ("vmd_params.csv" in artifacts) == (run.data.tags["features"] != "raw")
        assert ("training_curves.png" in artifacts) == (run.data.tags["classifier"] == "cnn_bilstm")
        assert run.data.metrics["inference_ms_per_sample"] > 0
        csv = Path(client.download_artifacts(run.info.run_id, "confusion_matrix.csv", str(tmp_path / run.info.run_id)))
        confusion = np.array([row.split(",")[1:] for row in csv.read_text().splitlines()[1:]], dtype=int)
        assert run.data.metrics["accuracy"] == pytest.approx(np.trace(confusion) / confusion.sum())
        assert confusion.sum() == run.data.metrics["n_test"]
        if run.data.tags["classifier"] == "cnn_bilstm":
            curve = client.get_metric_history(run.info.run_id, "test_accuracy")  # the test windows, epoch by epoch
            assert [m.step for m in curve] == [0, 1] and "val_accuracy" not in run.data.metrics
        # Where the network trained, as trainer.accelerator=auto resolved it (a machine without a GPU: its CPU).
        import torch

        here = "cuda" if torch.cuda.is_available() else "mps" if torch.backends.mps.is_available() else "cpu"
        assert run.data.tags.get("device") == (here if run.data.tags["classifier"] == "cnn_bilstm" else None)
        # How the job was asked for (its own overrides, the sweep's among them) and from which lock it was installed.
        assert f"seed={run.data.tags['seed']}" in run.data.tags["overrides"].split()
        assert (Path(run.data.tags["output_dir"]) / "train.log").is_file()  # the job's Hydra folder, its log there
        assert len(run.data.tags["requirements_lock"]) == 16 and run.data.tags["version.numba"] != "absent"


def test_failing_jobs_are_failed_and_grouped_under_the_sweep(store):
    client, experiment_id = store
    runs = training_runs(client, experiment_id)
    failed = [r for r in runs if r.info.status == "FAILED"]
    assert len(failed) == 3 and all("search.population must be an integer of at least 2" in r.data.tags["error"]
                                    for r in failed)
    (parent,) = client.search_runs([experiment_id], "tags.`bt.kind` = 'sweep' and tags.sweep_dir LIKE '%multirun'")
    assert parent.data.tags["sweep"] == "table4" and parent.info.status == "FAILED"
    sweep_dir = Path(parent.data.tags["sweep_dir"])  # named by its folder's last two parts (Hydra's <date>/<time>)
    assert parent.info.run_name == f"sweep table4 {sweep_dir.parent.name}/{sweep_dir.name}"
    assert parent.data.tags["mlflow.user"] and "mlflow.source.name" in parent.data.tags
    assert "search.population=3,1" in parent.data.tags["overrides"]  # the command's, its swept list as given
    finished = {}  # its jobs' accuracies at a glance: by method, a mean over several methods being of nothing
    for r in runs:
        if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id and r.info.status == "FINISHED":
            finished.setdefault(r.data.tags["method"].replace("+", "-"), []).append(r.data.metrics["accuracy"])
    assert len(finished) > 1 and "accuracy_mean" not in parent.data.metrics
    for method, scores in finished.items():
        assert parent.data.metrics[f"accuracy_mean/{method}"] == pytest.approx(np.mean(scores))
        assert parent.data.metrics[f"accuracy_max/{method}"] == pytest.approx(max(scores))
    assert (parent.data.tags["n_finished"], parent.data.tags["n_failed"]) == ("3", "3")
    children = [r for r in runs if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id]
    assert len(children) == 6 and {r.data.tags["sweep_dir"] for r in children} == {parent.data.tags["sweep_dir"]}
    # The runs the sweep stands for, what a report of it reads: its three finished jobs.
    from bearingtwin.tracking.mlflow_logging import sweep_run_ids

    assert set(sweep_run_ids(client, parent.data.tags["sweep_dir"])) == {r.info.run_id for r in children
                                                                          if r.info.status == "FINISHED"}


def test_the_sweep_ends_with_a_summary_of_every_job(store, sweep_output):
    lines = [line for line in sweep_output[1].splitlines() if not line.startswith("[")]
    summary = lines[next(i for i, line in enumerate(lines) if line.startswith("sweep table4 (run ")):]  # after the jobs' lines
    assert summary[0].startswith("sweep table4 (run ")
    assert summary[0].endswith("6 jobs, 3 finished, 3 failed, 0 skipped (already finished)")
    # The three finished jobs' accuracies, each with the overrides that tell it apart, then the failed jobs.
    assert summary[1].startswith("  accuracy: ") and summary[1].count(" % (+method=") == 3, summary[1]
    failed = summary[2:]
    assert len(failed) == 3 and all(line.startswith("  FAILED: +method=") for line in failed)
    assert all("search.population=1: BearingTwinError: search.population must be an integer of at least 2" in line
               for line in failed)
    assert not any("tracking.uri" in line for line in failed)  # overrides shared by every job are left out


def test_relaunching_the_sweep_skips_finished_jobs(store, tmp_path_factory):
    client, experiment_id = store
    before = {r.info.run_id: r.info.status for r in training_runs(client, experiment_id)}
    done = run_sabo_sweep(session_folder(tmp_path_factory))
    assert done.returncode == 1, done.stderr[-3000:]
    assert "6 jobs, 0 finished, 3 failed, 3 skipped (already finished)" in done.stdout
    after = {r.info.run_id: r.info.status for r in training_runs(client, experiment_id)}
    new = set(after) - set(before)
    assert all(after[run_id] == "FAILED" for run_id in new) and len(new) == 3  # only the failed jobs re-ran


def test_every_finished_job_logged_its_fitted_pipeline_as_a_model(store):
    client, experiment_id = store
    finished = [r for r in training_runs(client, experiment_id) if r.info.status == "FINISHED"]
    for run in finished:
        models = client.search_logged_models([experiment_id], filter_string=f"source_run_id = '{run.info.run_id}'")
        assert [(m.name, str(m.status)) for m in models] == [("model", "READY")]


def test_a_sweep_run_in_its_jobs_folders_reads_and_skips_as_one_started_where_it_is(tmp_path):
    """hydra.job.chdir=true: each job reads data.root=recs and the sqlite:///store.db from where the sweep started.
    The sweep's own check hashed the jobs' configs with the paths as typed, the jobs with the paths they read: run
    again, its skipped jobs had been reported NOT RUN and the sweep FAILED."""
    recordings = tmp_path / "recs"
    recordings.mkdir()
    rng = np.random.default_rng(0)
    rows = ["record,state"]
    for state in ("normal", "inner", "outer", "ball"):
        for index in range(2):
            np.savez(recordings / f"{state}{index}.npz", signal=rng.normal(size=12000), fs=12000.0, rpm=1797.0)
            rows.append(f"{state}{index},{state}")
    (recordings / "labels.csv").write_text("\n".join(rows) + "\n")
    args = ["-m", "data=files", "data.root=recs", "data.windows_per_record=6", "classifier=svm", "features=raw",
            "tracking.experiment=rig_a,rig_b", "hydra.job.chdir=true", "tracking.uri=sqlite:///store.db",
            f"paths.cache_dir={tmp_path}/cache"]
    first = run_module("bearingtwin.cli.train", *args, cwd=tmp_path, timeout=600)
    assert first.returncode == 0, first.stderr[-3000:]
    assert "2 jobs, 2 finished" in first.stdout and (tmp_path / "store.db").is_file()
    assert "(runs in experiments bearingtwin, rig_a, rig_b: mlflow ui" in first.stdout  # the sweep's run, the jobs
    again = run_module("bearingtwin.cli.train", *args, cwd=tmp_path, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "2 jobs, 0 finished, 0 failed, 2 skipped (already finished)" in again.stdout
    client = MlflowClient(f"sqlite:///{tmp_path}/store.db")
    runs = client.search_runs([e.experiment_id for e in client.search_experiments()], "tags.`bt.kind` = 'train'")
    assert len(runs) == 2 and {run.data.params["data.root"] for run in runs} == {str(recordings)}
