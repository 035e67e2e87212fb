"""MLflow logging of a run: what is stored, failures, resuming, and concurrent SQLite writers.

The training step is injected (``train_tracked(..., train=...)``) so these tests check the
tracking alone, against a real SQLite MLflow store in a temporary folder.
"""

import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from mlflow import MlflowClient
from omegaconf import OmegaConf

from bearingtwin import PINNED_CPU_KERNELS, PINS_CPU_KERNELS
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.experiment import ExperimentResult
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.tracking import mlflow_logging, provenance
from bearingtwin.tracking.mlflow_logging import (
    SweepInfo,
    artifact_location,
    config_hash,
    find_sweep_parent,
    flatten,
    format_sweep_summary,
    open_store,
    stored_config,
    sweep_folder,
    sweep_outcomes,
    train_tracked,
)

CHOICES = {"features": "sabo_vmd_pemie", "classifier": "cnn_bilstm"}


def make_cfg(store: Path, seed: int = 0, **tracking) -> OmegaConf:
    return OmegaConf.create(
        {
            "seed": seed,
            "paths": {"repo": "/somewhere", "cache_dir": "/somewhere/.cache"},
            "data": {"source": "simulated", "samples_per_class": 10},
            "simulator": {"fs": 10000.0},
            "features": {"name": "sabo_vmd_pemie", "kind": "sabo_vmd", "vmd_params": "global", "optimizer": "sabo"},
            "classifier": {"name": "cnn_bilstm", "hidden_units": 30},
            "tracking": {"uri": f"sqlite:///{store}/mlflow.db", "experiment": "test", "artifact_root": None, "skip_finished": True, **tracking},
        }
    )


def fake_result(seed: int) -> ExperimentResult:
    """A run's outcome whose numbers depend on the seed, so mix-ups between runs show."""
    confusion = np.diag([15, 15, 15, 15]) + np.eye(4, k=3, dtype=int) * seed
    metrics = {"accuracy": 0.9 + seed / 100, "inference_ms_per_sample": 0.5}
    for name in FAULTS:
        metrics.update({f"precision_{name}": 1.0, f"recall_{name}": 0.9, f"f1_{name}": 0.95})
    history = [{"epoch": e, "train_loss": 1.0 / (e + 1), "train_accuracy": 0.5 + e / 10} for e in range(3)]
    table = [{"scope": "global", "k": 5, "alpha": 1234.5, "optimal_imf": 2}]
    return ExperimentResult(metrics, confusion, FAULTS, history, table, "data-key", "", 42, 18)


def fake_train(cfg, root_dir):
    return fake_result(cfg.seed)


def failing_train(cfg, root_dir):
    raise BearingTwinError("data.samples_per_class must be positive, got -3")


def test_store_puts_artifacts_beside_the_sqlite_database(tmp_path):
    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    location = client.get_experiment(experiment_id).artifact_location
    assert location == (tmp_path / "artifacts" / "test").as_uri()
    assert open_store(make_cfg(tmp_path).tracking)[1] == experiment_id  # found, not created twice


def test_an_artifact_root_uri_is_kept_and_only_a_local_folder_becomes_a_file_uri(tmp_path):
    assert artifact_location("s3://bucket/mlflow/", "test") == "s3://bucket/mlflow/test"
    assert artifact_location("mlflow-artifacts:/team", "test") == "mlflow-artifacts:/team/test"
    assert artifact_location(str(tmp_path / "artifacts"), "test") == (tmp_path / "artifacts" / "test").as_uri()
    assert artifact_location(None, "test") is None  # a server's own store


def test_an_artifact_root_an_existing_experiment_cannot_take_is_said(tmp_path, caplog):
    """MLflow fixes an experiment's artifact location when it is made: a later tracking.artifact_root had been
    passed over without a word."""
    def opened(root):
        with caplog.at_level("WARNING", logger="bearingtwin.tracking.mlflow_logging"):
            open_store(OmegaConf.create({"uri": f"sqlite:///{tmp_path}/m.db", "experiment": "e", "artifact_root": root}))
        said, _ = [r.getMessage() for r in caplog.records], caplog.clear()
        return said

    assert opened(str(tmp_path / "first")) == []  # made there
    assert opened(str(tmp_path / "first")) == [] and opened(None) == []  # there again, or no root asked for
    (said,) = opened(str(tmp_path / "second"))
    assert said.startswith(f"tracking.artifact_root={tmp_path / 'second'} not used: experiment e keeps its artifacts in "
                           f"{(tmp_path / 'first' / 'e').as_uri()}")


def test_the_sweep_folder_is_taken_from_where_the_sweep_started_not_the_asking_process(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a worker's working directory, elsewhere
    started = tmp_path / "driver"
    relative = OmegaConf.create({"runtime": {"cwd": str(started)}, "sweep": {"dir": "multirun/x"}})
    assert sweep_folder(relative) == str(started / "multirun" / "x")
    absolute = OmegaConf.create({"runtime": {"cwd": str(started)}, "sweep": {"dir": str(tmp_path / "sweeps")}})
    assert sweep_folder(absolute) == str(tmp_path / "sweeps")


def test_config_hash_ignores_where_and_how_but_not_what(tmp_path):
    base = make_cfg(tmp_path)
    assert config_hash(base) == config_hash(make_cfg(tmp_path / "elsewhere"))
    moved = make_cfg(tmp_path)
    moved.paths.cache_dir = "/other"
    assert config_hash(base) == config_hash(moved)
    assert config_hash(base) != config_hash(make_cfg(tmp_path, seed=1))
    assert flatten({"a": {"b": 1, "c": [1, 2]}, "d": {}}) == {"a.b": "1", "a.c": "[1, 2]", "d": "{}"}
    shown = make_cfg(tmp_path)
    shown.trainer = {"max_epochs": 2, "progress_bar": True}
    hidden = make_cfg(tmp_path)
    hidden.trainer = {"max_epochs": 2, "progress_bar": False}
    assert config_hash(shown) == config_hash(hidden)  # how a run is shown is not what it computes
    # Nor how many workers extract its features or simulate its data: hashed at the 1 that runs recorded before
    # had, so a run recorded with 1 is the run a sweep resumed with 2 finds.
    recorded, resumed = make_cfg(tmp_path), make_cfg(tmp_path)
    for key in ("features.n_jobs", "data.n_jobs"):
        OmegaConf.update(recorded, key, 1, force_add=True)
        OmegaConf.update(resumed, key, 2, force_add=True)
    assert config_hash(recorded) == config_hash(resumed)
    hidden.trainer.max_epochs = 3
    assert config_hash(shown) != config_hash(hidden)


@pytest.mark.parametrize("key, value", [("data.labels", "labels.csv"), ("data.twin.background_snr_db", [10.0, 0.0]),
                                        ("data.twin.other_paths", {"hearings": 2, "modes": 6, "natural_frequency_hz": [500.0, 5500.0],
                                                                    "damping_ratio": [0.005, 0.05]}),
                                        ("simulator.oversample", 4)])
def test_an_optional_key_at_its_null_default_keeps_the_hash_runs_had_before_it_existed(tmp_path, key, value):
    before = make_cfg(tmp_path)  # a config recorded before the key existed
    before.data.twin = {"duration": 4.0}
    unset = make_cfg(tmp_path)
    unset.data.twin = {"duration": 4.0}
    OmegaConf.update(unset, key, None, force_add=True)
    assert config_hash(unset) == config_hash(before)  # a resumed sweep skips the runs it finished
    given = make_cfg(tmp_path)
    given.data.twin = {"duration": 4.0}
    OmegaConf.update(given, key, value, force_add=True)
    assert config_hash(given) != config_hash(before)
    assert OmegaConf.select(unset, key, default="absent") is None  # the hash left the config it was given as it was


def test_a_run_logs_config_metrics_curves_and_tables(tmp_path):
    cfg = make_cfg(tmp_path, seed=2)
    tracked = train_tracked(cfg, CHOICES, None, None, fake_train)
    assert tracked.metrics["accuracy"] == pytest.approx(0.92) and not tracked.skipped
    assert {"n_train", "n_test"} <= set(tracked.metrics)  # the closing summary counts the windows
    client, experiment_id = open_store(cfg.tracking)
    (run,) = client.search_runs([experiment_id])
    assert run.info.status == "FINISHED" and run.info.run_id == tracked.run_id
    assert run.info.run_name == "sabo_vmd_pemie+cnn_bilstm simulated global seed=2"
    assert run.data.params["classifier.hidden_units"] == "30" and run.data.params["data.source"] == "simulated"
    tags = run.data.tags
    assert tags["config_hash"] == config_hash(cfg) and tags["dataset_key"] == "data-key"
    assert tags["method"] == "sabo_vmd_pemie+cnn_bilstm" and tags["version.torch"].startswith("2.")
    assert tags["git_commit"]
    # MLflow's own context tags, which its UI shows and searches (a run created by MlflowClient has none of itself).
    assert tags["mlflow.user"] and tags["mlflow.source.type"] == "LOCAL" and "mlflow.source.name" in tags
    assert tags["mlflow.source.git.commit"] == tags["git_commit"].removesuffix("-dirty")
    assert tags["cpu_kernels"] == ", ".join(f"{name}={os.environ.get(name, 'the machine')}" for name in PINNED_CPU_KERNELS)
    if PINS_CPU_KERNELS:  # set in this process by importing bearingtwin, unless the environment set them first
        assert "the machine" not in tags["cpu_kernels"]
    assert run.data.metrics["recall_normal"] == pytest.approx(0.9)
    curve = client.get_metric_history(run.info.run_id, "train_loss")
    assert sorted((m.step, m.value) for m in curve) == [(0, 1.0), (1, 0.5), (2, pytest.approx(1 / 3))]
    names = {a.path for a in client.list_artifacts(run.info.run_id)}
    assert {"config.yaml", "confusion_matrix.csv", "confusion_matrix.png", "per_class.md", "vmd_params.csv", "training_curves.png"} <= names
    folder = Path(client.download_artifacts(run.info.run_id, "confusion_matrix.csv", str(tmp_path / "dl")))
    rows = [line.split(",") for line in folder.read_text().splitlines()]
    assert rows[0][1:] == list(FAULTS) and rows[1] == ["normal", "15", "0", "0", "2"]
    vmd = client.download_artifacts(run.info.run_id, "vmd_params.md", str(tmp_path / "dl"))
    assert "| global | 5 | 1234.5 | 2 |" in Path(vmd).read_text()
    assert stored_config(client, run.info.run_id).classifier.hidden_units == 30


def test_a_real_data_runs_name_says_which_records_unless_its_sweep_does():
    from bearingtwin.tracking.mlflow_logging import run_name

    cwru = OmegaConf.create({"seed": 0, "data": {"source": "cwru", "load": 2}, "features": {"kind": "raw"}})
    hust = OmegaConf.create({"seed": 0, "data": {"source": "hust", "condition": 65}, "features": {"kind": "raw"}})
    assert run_name(cwru, "raw+svm", None) == "raw+svm cwru 2hp seed=0"
    assert run_name(hust, "raw+svm", None) == "raw+svm hust 65Hz seed=0"
    assert run_name(cwru, "raw+svm", SweepInfo("cwru", "/s", ("data.load=2",))) == "raw+svm cwru data.load=2 seed=0"
    assert run_name(cwru, "raw+svm", SweepInfo("cwru", "/s", ("+cwru_condition=2hp",))) == \
        "raw+svm cwru +cwru_condition=2hp seed=0"


def test_a_failing_run_is_failed_with_its_error(tmp_path):
    cfg = make_cfg(tmp_path)
    with pytest.raises(BearingTwinError, match="samples_per_class"):
        train_tracked(cfg, CHOICES, None, None, failing_train)  # single run: re-raised -> exit 2
    sweep = SweepInfo("table4", str(tmp_path / "multirun"), ("features.vmd_params=global",))
    assert train_tracked(make_cfg(tmp_path, seed=1), CHOICES, sweep, None, failing_train) is None  # sweep goes on
    client, experiment_id = open_store(cfg.tracking)
    runs = client.search_runs([experiment_id])
    assert [r.info.status for r in runs] == ["FAILED", "FAILED"]
    assert all("samples_per_class must be positive" in r.data.tags["error"] for r in runs)
    in_sweep = next(r for r in runs if r.data.tags.get("sweep") == "table4")
    assert in_sweep.info.run_name == "sabo_vmd_pemie+cnn_bilstm simulated global features.vmd_params=global seed=1"
    assert "error.txt" in {a.path for a in client.list_artifacts(in_sweep.info.run_id)}


def test_a_job_the_interrupted_sweep_could_not_stop_stays_killed_and_a_later_one_does_not_start(tmp_path):
    """A cluster's worker is no child of the sweep: interrupted, the sweep marks its open runs KILLED while such a
    worker may finish its job (it had turned the run FINISHED) or start the next (a run left RUNNING)."""
    cfg = make_cfg(tmp_path)
    client, experiment_id = open_store(cfg.tracking)
    sweep_dir = str(tmp_path / "multirun")
    parent = client.create_run(experiment_id, tags={"bt.kind": "sweep", "sweep_dir": sweep_dir})
    sweep = SweepInfo("s", sweep_dir, ("seed=0",))

    def interrupted_meanwhile(cfg, root_dir):  # what the sweep's process does on SIGTERM, while this job trains
        for run in client.search_runs([experiment_id], "attributes.status = 'RUNNING'"):
            client.set_terminated(run.info.run_id, "KILLED")
        return fake_train(cfg, root_dir)

    assert train_tracked(cfg, CHOICES, sweep, None, interrupted_meanwhile) is None
    assert train_tracked(make_cfg(tmp_path, seed=1), CHOICES, sweep, None, fake_train) is None
    runs = client.search_runs([experiment_id])
    assert [run.info.status for run in runs] == ["KILLED", "KILLED"]  # the job's and the sweep's; no run for seed 1
    assert {run.info.run_id for run in runs} > {parent.info.run_id}


def test_finished_configs_are_skipped_and_failed_ones_retried(tmp_path, caplog, monkeypatch):
    cfg = make_cfg(tmp_path)
    with pytest.raises(BearingTwinError):
        train_tracked(cfg, CHOICES, None, None, failing_train)
    done = train_tracked(cfg, CHOICES, None, None, fake_train)  # the failed run does not count as done
    again = train_tracked(cfg, CHOICES, None, None, failing_train)  # would fail if it ran
    assert again.skipped and again.run_id == done.run_id and again.metrics["accuracy"] == pytest.approx(0.9)
    assert again.model == done.model == ""  # the fake training logs no model, and the skipped run names none
    client, experiment_id = open_store(cfg.tracking)
    assert sorted(r.info.status for r in client.search_runs([experiment_id])) == ["FAILED", "FINISHED"]
    # A run another version of the code finished is skipped too, and the log says by which code and how to run it again.
    client.set_tag(done.run_id, "git_commit", "0123456789abcdef")
    with caplog.at_level("INFO", logger="bearingtwin.tracking.mlflow_logging"):
        skipped = train_tracked(cfg, CHOICES, None, None, failing_train)
    assert skipped.skipped and skipped.other_code.startswith("at 0123456789ab (this code: ")  # for the closing summary
    assert "by the code at 0123456789ab (this code: " in caplog.text and "tracking.skip_finished=false" in caplog.text
    # The same commit with the checkout changed since (or then): the two differ by -dirty, and the log shows it.
    now = provenance.git_commit().removesuffix("-dirty")
    client.set_tag(done.run_id, "git_commit", now + "-dirty")
    monkeypatch.setattr(provenance, "git_commit", lambda: now)
    caplog.clear()
    with caplog.at_level("INFO", logger="bearingtwin.tracking.mlflow_logging"):
        assert train_tracked(cfg, CHOICES, None, None, failing_train).skipped
    assert f"by the code at {now[:12]}-dirty (this code: {now[:12]});" in caplog.text
    # Two states of one commit with changes not committed: the same git_commit tag, told apart by the code's key (a
    # sweep re-launched after an edit had reused the runs of the code before it, unsaid).
    client.set_tag(done.run_id, "git_commit", now + "-dirty")
    client.set_tag(done.run_id, "code", "0123456789ab")
    monkeypatch.setattr(provenance, "git_commit", lambda: now + "-dirty")
    caplog.clear()
    with caplog.at_level("INFO", logger="bearingtwin.tracking.mlflow_logging"):
        assert train_tracked(cfg, CHOICES, None, None, failing_train).skipped
    assert (f"by the code at {now[:12]}-dirty with other changes not committed (code 0123456789ab; this code: "
            f"{provenance.code_tag()});") in caplog.text
    client.set_tag(done.run_id, "code", provenance.code_tag())  # this very code: nothing to say
    caplog.clear()
    with caplog.at_level("INFO", logger="bearingtwin.tracking.mlflow_logging"):
        assert train_tracked(cfg, CHOICES, None, None, failing_train).skipped
    assert "by the code at" not in caplog.text
    train_tracked(make_cfg(tmp_path, skip_finished=False), CHOICES, None, None, fake_train)
    assert len(client.search_runs([experiment_id])) == 3


def test_by_default_a_sweep_job_resumes_and_a_single_run_runs_again(tmp_path):
    cfg = make_cfg(tmp_path, skip_finished=None)
    sweep = SweepInfo("cli", str(tmp_path / "multirun"))
    train_tracked(cfg, CHOICES, None, None, fake_train)
    train_tracked(cfg, CHOICES, None, None, fake_train)  # asked again: runs again
    assert train_tracked(cfg, CHOICES, sweep, None, failing_train).metrics["accuracy"] == pytest.approx(0.9)  # resumed: skipped
    client, experiment_id = open_store(cfg.tracking)
    assert [r.info.status for r in client.search_runs([experiment_id])] == ["FINISHED", "FINISHED"]


def _log_runs(store: str, worker: int, n_runs: int) -> int:
    for i in range(n_runs):
        train_tracked(make_cfg(Path(store), seed=100 * worker + i), CHOICES, None, None, fake_train)
    return n_runs


def test_concurrent_writers_on_one_sqlite_store_lose_no_run(tmp_path):
    """Four processes log three runs each into one fresh SQLite file (schema creation included)."""
    with ProcessPoolExecutor(max_workers=4) as pool:
        done = sum(pool.map(_log_runs, [str(tmp_path)] * 4, range(4), [3] * 4))
    client = MlflowClient(f"sqlite:///{tmp_path}/mlflow.db")
    runs = client.search_runs([client.get_experiment_by_name("test").experiment_id], max_results=100)
    assert done == 12 and len(runs) == 12
    assert all(r.info.status == "FINISHED" and "accuracy" in r.data.metrics for r in runs)
    assert sorted(int(r.data.tags["seed"]) for r in runs) == sorted(100 * w + i for w in range(4) for i in range(3))


def test_jobs_are_told_apart_by_their_number_and_found_in_any_experiment(tmp_path):
    """Two jobs whose configs hash alike (they differ in trainer.progress_bar, which a run's result does not
    depend on) each have their own outcome; a job logging to another experiment (a swept
    tracking.experiment) is still the sweep's child, counted, and closed when the sweep is stopped."""
    from bearingtwin.tracking.lifecycle import _open_runs, close_open_runs, register_open_run

    sweep = SweepInfo("cli", str(tmp_path / "multirun"))
    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    parent = client.create_run(experiment_id, tags={"bt.kind": "sweep", "sweep_dir": sweep.sweep_dir})
    assert train_tracked(make_cfg(tmp_path, seed=0), CHOICES, replace(sweep, job=0), None, failing_train) is None
    train_tracked(make_cfg(tmp_path, seed=0), CHOICES, replace(sweep, job=1), None, fake_train)  # the same hash
    elsewhere = make_cfg(tmp_path, seed=5)
    elsewhere.tracking.experiment = "other"
    train_tracked(elsewhere, CHOICES, replace(sweep, job=2), None, failing_train)

    def job(seed, progress):
        cfg = make_cfg(tmp_path, seed=seed)
        cfg.hydra = {"overrides": {"task": [f"seed={seed}", f"trainer.progress_bar={progress}"]}}
        return cfg

    outcomes = sweep_outcomes(client, parent.info.run_id, [job(0, "maybe"), job(0, "false"), job(5, "false")])
    assert [o.status for o in outcomes] == ["FAILED", "FINISHED", "FAILED"], outcomes
    other = client.get_experiment_by_name("other").experiment_id
    running = client.create_run(other, tags={"mlflow.parentRunId": parent.info.run_id})
    _open_runs.clear()
    register_open_run(client, parent.info.run_id, label="sweep", with_children=True)
    assert f"run {running.info.run_id}" in close_open_runs("KILLED")
    assert client.get_run(running.info.run_id).info.status == "KILLED"


def test_a_report_of_a_sweep_reads_the_runs_it_skipped_too(tmp_path):
    """A sweep skips a job another sweep had finished; that run carries the other sweep's sweep_dir, so the
    report of this sweep finds it through the list of runs the sweep recorded at its end."""
    from bearingtwin.tracking.mlflow_logging import SWEEP_RUNS_ARTIFACT
    from bearingtwin.tracking.reports import ReportInput

    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    earlier = train_tracked(make_cfg(tmp_path, seed=1), CHOICES, SweepInfo("cli", str(tmp_path / "a")), None, fake_train)
    sweep = SweepInfo("cli", str(tmp_path / "b"))
    parent = client.create_run(experiment_id, tags={"bt.kind": "sweep", "sweep_dir": sweep.sweep_dir})
    own = train_tracked(make_cfg(tmp_path, seed=0), CHOICES, replace(sweep, job=0), None, fake_train)
    source = ReportInput(client, experiment_id, {"sweep_dir": sweep.sweep_dir, "source": "all"})
    assert [run.info.run_id for run in source.training_runs()] == [own.run_id]  # no record yet: its own runs
    client.log_dict(parent.info.run_id, [own.run_id, earlier.run_id], SWEEP_RUNS_ARTIFACT)
    assert {run.info.run_id for run in source.training_runs()} == {own.run_id, earlier.run_id}


def test_a_sweep_summary_says_what_became_of_every_job(tmp_path):
    sweep = SweepInfo("cli", str(tmp_path / "multirun"))
    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    parent = client.create_run(experiment_id, tags={"bt.kind": "sweep", "sweep_dir": sweep.sweep_dir})
    train_tracked(make_cfg(tmp_path, seed=1), CHOICES, None, None, fake_train)  # finished before the sweep
    train_tracked(make_cfg(tmp_path, seed=0), CHOICES, replace(sweep, job=0), None, fake_train)
    train_tracked(make_cfg(tmp_path, seed=2), CHOICES, replace(sweep, job=2), None, failing_train)
    assert find_sweep_parent(client, sweep.sweep_dir).info.run_id == parent.info.run_id

    def job(seed):  # a job's composed config as Hydra's sweeper makes it
        cfg = make_cfg(tmp_path, seed=seed)
        cfg.hydra = {"overrides": {"task": [f"seed={seed}", "data.samples_per_class=10"]}}
        return cfg

    outcomes = sweep_outcomes(client, parent.info.run_id, [job(0), job(1), job(2), job(3)])
    assert [(o.overrides, o.status) for o in outcomes] == [
        ("seed=0", "FINISHED"), ("seed=1", "SKIPPED"), ("seed=2", "FAILED"), ("seed=3", "NOT RUN")]
    assert outcomes[2].reason == "BearingTwinError: data.samples_per_class must be positive, got -3"
    summary = format_sweep_summary("cli", parent.info.run_id, outcomes).splitlines()
    assert summary[0] == f"sweep cli (run {parent.info.run_id}): 4 jobs, 1 finished, 2 failed, 1 skipped (already finished)"
    # Each finished job's accuracy, the skipped one's too (its earlier run's), as no launcher's worker may have shown it.
    finished = {o.overrides: o.accuracy for o in outcomes if o.status in ("FINISHED", "SKIPPED")}
    assert summary[1] == f"  accuracy: {100 * finished['seed=0']:.2f} % (seed=0); {100 * finished['seed=1']:.2f} % (seed=1)"
    assert summary[2:] == ["  FAILED: seed=2: BearingTwinError: data.samples_per_class must be positive, got -3",
                           "  NOT RUN: seed=3: the job ended before its MLflow run was created (see its log)"]
    many = format_sweep_summary("cli", parent.info.run_id, outcomes, max_listed=1).splitlines()
    low, high = sorted(finished.values())
    assert many[1] == (f"  accuracy: {100 * low:.2f} % to {100 * high:.2f} %, mean {50 * (low + high):.2f} % over 2 jobs "
                       "(each in its run)")
    # A job skipped for a run another commit computed is said to be so where the counts are, not only in the log.
    client.set_tag(outcomes[1].run_id, "git_commit", "0123456789abcdef")
    outcomes = sweep_outcomes(client, parent.info.run_id, [job(0), job(1), job(2), job(3)])
    assert outcomes[1].reason.startswith("at 0123456789ab (this code: ")
    assert format_sweep_summary("cli", parent.info.run_id, outcomes).splitlines()[1] == (
        f"  1 of the skipped was computed by other code, the first {outcomes[1].reason}: "
        "tracking.skip_finished=false runs them again")


def test_a_store_that_cannot_serve_is_named_before_any_work(tmp_path):
    """MLflow would retry a silent server for minutes, stop on its retired file store with a traceback, and
    create an empty database where a command only reads: each is one line naming tracking.uri."""
    from bearingtwin.tracking.mlflow_logging import check_store

    with pytest.raises(BearingTwinError, match=r"^tracking.uri=file:///x: MLflow 3 keeps runs in a database"):
        check_store("file:///x")
    database = tmp_path / "mlflow.db"
    MlflowClient(f"sqlite:///{database}").search_experiments()  # a store, named by its file's path
    with pytest.raises(BearingTwinError, match=rf"^tracking.uri={database}: a file's path, not a store's URI; give "
                                               rf"sqlite:///{database} for the SQLite store in it$"):
        check_store(str(database))
    with pytest.raises(BearingTwinError, match=r"^tracking.uri=http://127.0.0.1:9: no tracking server answers there"):
        check_store("http://127.0.0.1:9")
    with mock.patch.dict(os.environ, {"MLFLOW_TRACKING_URI": "http://127.0.0.1:9"}):  # named where the user set it
        with pytest.raises(BearingTwinError, match=r"^MLFLOW_TRACKING_URI=http://127.0.0.1:9: no tracking server"):
            check_store("http://127.0.0.1:9")
    missing = f"sqlite:///{tmp_path}/none/mlflow.db"
    with pytest.raises(BearingTwinError, match=r"no such store \(.*none/mlflow.db does not exist\)"):
        check_store(missing, must_exist=True)
    check_store(missing)  # a command that writes creates it
    assert not (tmp_path / "none").exists()
    check_store("databricks")  # MLflow's own name for a Databricks workspace
    check_store("sqlite://", must_exist=True)  # in memory
    # A file that is not an MLflow store is named before MLflow writes its tables into it.
    import sqlite3

    own = tmp_path / "own.db"
    with sqlite3.connect(own) as database:
        database.execute("create table measurements (x)")
    with pytest.raises(BearingTwinError, match=r"own.db is an SQLite database but not an MLflow store \(its tables: measurements\)"):
        check_store(f"sqlite:///{own}")
    with sqlite3.connect(own) as database:
        assert [row[0] for row in database.execute("select name from sqlite_master")] == ["measurements"]
    (tmp_path / "notes.db").write_text("not a database\n")
    with pytest.raises(BearingTwinError, match=r"notes.db is not an SQLite database"):
        check_store(f"sqlite:///{tmp_path}/notes.db")
    (tmp_path / "empty.db").touch()
    check_store(f"sqlite:///{tmp_path}/empty.db")  # a command that writes makes it a store
    with pytest.raises(BearingTwinError, match=r"empty.db is empty, not an MLflow store"):
        check_store(f"sqlite:///{tmp_path}/empty.db", must_exist=True)
    # A store a read-only look cannot read now (locked; a crashed writer's journal to roll back) is left to MLflow.
    real_connect = sqlite3.connect

    def locked(*args, **kwargs):
        raise sqlite3.OperationalError("database is locked")

    sqlite3.connect = locked
    try:
        check_store(f"sqlite:///{own}")
    finally:
        sqlite3.connect = real_connect


def test_a_server_that_answers_at_all_is_left_to_mlflow():
    """A login a proxy asks for, or a route it does not forward, is an answer: only silence is refused."""
    import http.server
    import threading

    from bearingtwin.tracking.mlflow_logging import check_store

    class AsksForLogin(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_response(401)
            self.end_headers()

        def log_message(self, *args):
            pass

    server = http.server.HTTPServer(("127.0.0.1", 0), AsksForLogin)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        check_store(f"http://127.0.0.1:{server.server_port}/mlflow")
    finally:
        server.shutdown()


def test_a_run_on_files_is_its_config_and_its_files(tmp_path):
    """Recordings added to a folder, a labels table corrected: another run, though the config reads the same
    (a resumed sweep skipped such a job and reported the earlier data's accuracy). Simulated data is its config."""
    (tmp_path / "a.npy").write_bytes(b"one")
    (tmp_path / "labels.csv").write_text("record,state\na.npy,normal\n")
    files = OmegaConf.create({"seed": 0, "data": {"source": "files", "root": str(tmp_path), "labels": None}})
    before = config_hash(files)
    assert config_hash(files) == before
    (tmp_path / "b.npy").write_bytes(b"two")
    added = config_hash(files)
    (tmp_path / "labels.csv").write_text("record,state\na.npy,outer\n")
    assert len({before, added, config_hash(files)}) == 3
    simulated = OmegaConf.create({"seed": 0, "data": {"source": "simulated", "root": str(tmp_path)}})
    unchanged = config_hash(simulated)
    (tmp_path / "b.npy").write_bytes(b"three")
    assert config_hash(simulated) == unchanged


def test_a_deleted_experiment_is_named_with_the_ways_out(tmp_path):
    from bearingtwin.errors import BearingTwinError
    from bearingtwin.tracking.mlflow_logging import open_store

    cfg = make_cfg(tmp_path)
    client, experiment_id = open_store(cfg.tracking)
    client.delete_experiment(experiment_id)
    with pytest.raises(BearingTwinError, match=rf"^tracking.experiment=test: deleted in .*mlflow experiments restore "
                                               rf"--experiment-id {experiment_id}\), remove it for good \(mlflow gc\)"):
        open_store(cfg.tracking)


def test_a_command_line_sweeps_varied_keys_name_its_runs_apart(monkeypatch):
    """`-m seed=0,1 data.samples_per_class=12,24`: no sweep file says what varies, so the parent finds the keys
    whose values differ between its jobs and each job's run name carries them."""
    from bearingtwin.tracking.mlflow_logging import SWEEP_VARIED_ENV, run_name, sweep_info, varied_keys

    jobs = [OmegaConf.create({"hydra": {"overrides": {"task": [f"seed={seed}", f"data.samples_per_class={n}",
                                                              "classifier=svm"]}}})
            for seed in (0, 1) for n in (12, 24)]
    assert varied_keys(jobs) == ["data.samples_per_class", "seed"]
    monkeypatch.setenv(SWEEP_VARIED_ENV, " ".join(varied_keys(jobs)))
    hydra_cfg = OmegaConf.create({"mode": "MULTIRUN", "sweeper": {"params": None}, "runtime": {"choices": {}, "cwd": "/tmp"},
                                  "overrides": {"task": ["seed=1", "data.samples_per_class=24", "classifier=svm"]},
                                  "job": {"num": 3}, "sweep": {"dir": "/tmp/sweep"}, "run": {"dir": "."}})
    from hydra.types import RunMode

    hydra_cfg.mode = RunMode.MULTIRUN
    info = sweep_info(hydra_cfg)
    assert info.varied == ("data.samples_per_class=24",)
    cfg = OmegaConf.create({"seed": 1, "data": {"source": "simulated"}, "features": {"kind": "raw"}})
    assert run_name(cfg, "raw+svm", info) == "raw+svm simulated data.samples_per_class=24 seed=1"


def test_a_database_whose_driver_is_missing_is_named_with_what_to_install(monkeypatch):
    """SQLAlchemy imports a database's driver when MLflow first opens the store: a traceback at the first run."""
    import sqlalchemy

    from bearingtwin.tracking.mlflow_logging import check_store

    def missing(uri, *args, **kwargs):  # as SQLAlchemy fails where the driver is not installed
        raise ModuleNotFoundError(f"No module named '{uri.split('+')[-1].split(':')[0]}'", name="psycopg")

    monkeypatch.setattr(sqlalchemy, "create_engine", missing)
    with pytest.raises(BearingTwinError, match=r"^tracking.uri=postgresql\+psycopg://x@127.0.0.1:1/db: its database "
                                               r"driver, psycopg, is not installed \(PostgreSQL: the postgres extra"):
        check_store("postgresql+psycopg://x@127.0.0.1:1/db")
    monkeypatch.setattr(sqlalchemy, "create_engine", lambda *args, **kwargs: None)  # installed: nothing to say
    check_store("postgresql+psycopg://x@127.0.0.1:1/db")


def test_a_server_that_answers_but_not_as_mlflow_is_named_in_one_line(tmp_path):
    """Another service on the port (here a plain file server) answers every MLflow request with a page of HTML:
    opening the store, and loading a model from it, each say so in one line, the page left out."""
    import http.server
    import threading

    from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model
    from bearingtwin.tracking.mlflow_logging import open_store

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    uri = f"http://127.0.0.1:{server.server_address[1]}"
    try:
        with pytest.raises(BearingTwinError) as opened:
            open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
        with pytest.raises(BearingTwinError) as loaded:
            load_diagnosis_model("models:/diag@champion", uri)
    finally:
        server.shutdown()
    assert str(opened.value) == (f"tracking.uri={uri}: the server there does not answer as an MLflow tracking server "
                                 "(API request to endpoint /api/2.0/mlflow/experiments/get-by-name failed with error "
                                 "code 404 != 200)")
    assert str(loaded.value).startswith(f"model=models:/diag@champion: cannot load it from {uri} (API request")
    assert "<" not in str(loaded.value) and "\n" not in str(loaded.value)


def test_a_tracking_server_that_refuses_says_so_in_its_own_words():
    """An MLflow server that asks for a login (403 with MLflow's JSON error) is no 'other service': its refusal is
    passed on in one line."""
    import http.server
    import json
    import threading

    from bearingtwin.tracking.mlflow_logging import open_store

    class Refusing(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            body = json.dumps({"error_code": "PERMISSION_DENIED", "message": "Permission denied"}).encode()
            self.send_response(403)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Refusing)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    uri = f"http://127.0.0.1:{server.server_address[1]}"
    try:
        with pytest.raises(BearingTwinError) as opened:
            open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
    finally:
        server.shutdown()
    assert str(opened.value).startswith(f"tracking.uri={uri}: the tracking server refused (")
    assert "Permission denied" in str(opened.value) and "\n" not in str(opened.value)


def test_a_tracking_servers_requests_give_up_in_half_a_minute_unless_the_environment_says_otherwise(monkeypatch):
    """MLflow's own settings, read as MLflow reads them: 5 retries at a backoff factor of 1 (waits of up to 2, 4, 8,
    16 s; its defaults: 7 at 2, about 4 min per refused request); a user's own values are kept."""
    from mlflow.environment_variables import MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR, MLFLOW_HTTP_REQUEST_MAX_RETRIES

    from bearingtwin.tracking.mlflow_logging import bound_http_retries

    for name in ("MLFLOW_HTTP_REQUEST_MAX_RETRIES", "MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR"):
        monkeypatch.setenv(name, "")  # recorded, so that what bound_http_retries sets is undone after the test
        monkeypatch.delenv(name)
    assert (MLFLOW_HTTP_REQUEST_MAX_RETRIES.get(), MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR.get()) == (7, 2)
    bound_http_retries()
    assert (MLFLOW_HTTP_REQUEST_MAX_RETRIES.get(), MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR.get()) == (5, 1)
    monkeypatch.setenv("MLFLOW_HTTP_REQUEST_MAX_RETRIES", "9")
    bound_http_retries()
    assert MLFLOW_HTTP_REQUEST_MAX_RETRIES.get() == 9


def test_a_sweep_is_named_by_its_sweep_file_else_its_experiment():
    """``-m +experiment=sim2real seed=0,1`` is the sim2real experiment's sweep (its parent run had read "sweep cli")."""
    from bearingtwin.tracking.mlflow_logging import sweep_name

    assert sweep_name({"sweep": "table4", "experiment": "sim2real"}) == "table4"
    assert sweep_name({"sweep": None, "experiment": "sim2real"}) == "sim2real"
    # A sweep of command-line values alone is named by the keys its jobs differ in, not by a word they all share.
    assert sweep_name({"classifier": "svm"}, ["classifier", "seed"]) == "over classifier, seed"
    assert sweep_name({"classifier": "svm"}) == "of one setting"  # nothing varied: "sweep cli" had read as a name


def test_a_launcher_chosen_hydras_way_is_warned_of_and_the_projects_is_not(capsys):
    """hydra/launcher=joblib (Hydra's way to choose a launcher) runs Hydra's own, on which an OS-killed job ends the
    sweep; hydra/launcher=ray and =submitit_slurm run without the store, cache and data the project's give every job.
    launcher=<name> runs the project's. The first are said in a line, the second not."""
    from bearingtwin.config import compose_config
    from bearingtwin.tracking.mlflow_logging import warn_of_hydras_launcher

    for override, warned in (("hydra/launcher=joblib", "launcher=joblib runs the project's"),
                             ("hydra/launcher=ray", "launcher=ray sets them"),
                             ("hydra/launcher=submitit_slurm", "launcher=submitit_slurm sets them"),
                             ("launcher=joblib", None), ("launcher=ray", None), ("launcher=submitit_slurm", None),
                             ("hydra/launcher=basic", None)):
        warn_of_hydras_launcher(compose_config("train", [override], hydra_node=True).hydra.runtime.choices)
        said = capsys.readouterr().err
        assert (said.startswith(f"warning: {override} is ") and warned in said) if warned else said == "", (override, said)


def test_a_model_misreading_its_calibration_records_is_registered_but_not_made_the_alias(tmp_path):
    """A twin-trained model that calls an own calibration record (the records its twin was made from) its state in
    few windows misreads the rig: registered as a version, it is not made @champion, which a user's diagnoses
    reach (an own rig's model at 33 % had become it); one that reads them is."""
    from mlflow.exceptions import MlflowException

    from bearingtwin.diagnosis.pipeline import DiagnosisPipeline
    from bearingtwin.features.extractor import RawFeatures
    from bearingtwin.models.svm import SvmClassifier

    rng = np.random.default_rng(0)
    windows, labels = rng.normal(size=(24, 64)), np.repeat([0, 1, 2, 3], 6)
    pipeline = DiagnosisPipeline(RawFeatures().fit(windows), SvmClassifier().fit(windows, labels), 64, 10000.0)
    store = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(tracking_uri=store, registry_uri=store)  # not a registry an earlier test pointed MLflow at
    for seed, outer_recall in ((0, 0.02), (1, 0.9)):
        result = fake_result(seed)
        result.metrics.update(calibration_accuracy=0.5, calibration_recall_normal=0.95,
                              calibration_recall_outer=outer_recall)
        result.pipeline, result.example_windows = pipeline, windows[:2]
        cfg = make_cfg(tmp_path, seed=seed)
        cfg.register, cfg.register_alias = "my_rig", "champion"
        tracked = train_tracked(cfg, CHOICES, None, str(tmp_path), lambda cfg, root_dir, result=result: result)
        if outer_recall < 0.5:
            assert "not made @champion: it misreads its outer calibration record" in tracked.model
            with pytest.raises(MlflowException):
                client.get_model_version_by_alias("my_rig", "champion")
    assert int(client.get_model_version_by_alias("my_rig", "champion").version) == 2
    # Each version says what it is (the registry had shown them bare), and a moved alias says from where.
    version = client.get_model_version("my_rig", "2")
    assert version.description.endswith("seed=1: 91.00 % of its test windows right") and version.tags["seed"] == "1"
    assert version.tags["accuracy"] == "0.91" and version.tags["run_id"] == version.run_id
    result = fake_result(2)
    result.pipeline, result.example_windows = pipeline, windows[:2]
    cfg = make_cfg(tmp_path, seed=2)
    cfg.register, cfg.register_alias = "my_rig", "champion"
    tracked = train_tracked(cfg, CHOICES, None, str(tmp_path), lambda cfg, root_dir: result)
    assert tracked.model.endswith("= models:/my_rig/3 = models:/my_rig@champion (moved from version 2)")


def test_a_store_whose_making_was_interrupted_is_made_anew_and_an_older_one_is_named(tmp_path, monkeypatch):
    """Ctrl-C in the first seconds of a first command had left a store of half its tables, on which every later
    command failed with a page of SQLAlchemy traceback. A new store is now made beside its place and moved there
    whole; a store of older tables is refused in one line saying how to upgrade it, one half made in one line too."""
    import shutil
    import sqlite3

    import mlflow.store.db.utils

    uri = f"sqlite:///{tmp_path}/m.db"
    tracking = OmegaConf.create({"uri": uri, "experiment": "e", "artifact_root": None})
    made = mlflow.store.db.utils._initialize_tables

    def interrupted(engine):  # MLflow's first tables made, then Ctrl-C before the rest
        with engine.begin() as connection:
            connection.exec_driver_sql("create table experiments (experiment_id integer)")
        raise KeyboardInterrupt

    with monkeypatch.context() as patched:
        patched.setattr(mlflow.store.db.utils, "_initialize_tables", interrupted)
        with pytest.raises(KeyboardInterrupt):
            open_store(tracking)
    assert mlflow.store.db.utils._initialize_tables is made
    assert not (tmp_path / "m.db").exists() and list(tmp_path.glob("m.db.*.making"))  # nothing half made in its place
    client, _ = open_store(tracking)  # made anew, whole; the interrupted attempt's file gone
    assert {e.name for e in client.search_experiments()} == {"e", "Default"} and not list(tmp_path.glob("*.making*"))
    shutil.copy(tmp_path / "m.db", tmp_path / "old.db")  # another URI: MLflow checks a store's tables once a process
    older = f"sqlite:///{tmp_path}/old.db"
    with sqlite3.connect(tmp_path / "old.db") as database:  # as a store of an older MLflow has it
        database.execute("update alembic_version set version_num = 'bf29a5ff90ea'")
    with pytest.raises(BearingTwinError) as refused:
        open_store(OmegaConf.create({"uri": older, "experiment": "f", "artifact_root": None}))
    assert str(refused.value) == (f"tracking.uri={older}: the store's tables are older than this MLflow's (found version "
                                  f"bf29a5ff90ea); back the store up and upgrade it (mlflow db upgrade {older}), or, "
                                  "where its making was stopped, move it aside for a new one")

    def half_made(*args, **kwargs):  # as MLflow fails on a store whose upgrade stopped half way
        raise RuntimeError("(sqlite3.OperationalError) table secrets already exists [SQL: CREATE TABLE secrets (...)]")

    monkeypatch.setattr(mlflow_logging, "MlflowClient", half_made)
    with pytest.raises(BearingTwinError) as refused:
        open_store(tracking)
    assert str(refused.value) == (f"tracking.uri={uri}: the store's tables are half made (table secrets already exists,"
                                  " as its upgrade or making was stopped); move the file aside and run again for a new "
                                  "store")


def test_a_sweep_whose_tracking_server_went_away_runs_no_more_jobs_and_ends_in_one_line(tmp_path, monkeypatch, caplog,
                                                                                      capsys):
    """A server gone mid-sweep: each job left had spent half a minute in MLflow's retries before failing, and the sweep
    had ended, after another minute, with exit 2 and a raw exception. Now a job finding the server silent is not run,
    and the sweep ends at once with one line and exit 1, its parent left for the next command that finds the server."""
    from bearingtwin.tracking import lifecycle, mlflow_logging
    from bearingtwin.tracking.mlflow_logging import SweepParentRun

    uri = "http://127.0.0.1:9"  # nothing answers there
    monkeypatch.setattr(mlflow_logging, "server_silence", lambda uri: "Connection refused")
    cfg = make_cfg(tmp_path, uri=uri)
    trained = []
    with caplog.at_level("ERROR", logger="bearingtwin.tracking.mlflow_logging"):
        assert train_tracked(cfg, CHOICES, SweepInfo("cli", str(tmp_path / "multirun"), job=3), None,
                             lambda cfg, root_dir: trained.append(1)) is None
    assert trained == [] and caplog.messages == [
        f"job 3 not run: tracking.uri={uri}: the tracking server does not answer (Connection refused)"]
    callback = SweepParentRun()
    callback._random_state, callback._tracking, callback._parent_id = None, OmegaConf.create({"uri": uri}), "p1"
    lifecycle.register_open_run(None, "p1", label="sweep", with_children=True)
    monkeypatch.setattr(callback, "_jobs", lambda config: [])
    hydra = OmegaConf.create({"hydra": {"runtime": {"cwd": str(tmp_path)}, "sweep": {"dir": str(tmp_path / "m")}}})
    with pytest.raises(SystemExit) as ended:
        callback.on_multirun_end(hydra)
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert ended.value.code == 1 and line.startswith(
        f"error: the sweep's outcome could not be recorded: tracking.uri={uri}: the tracking server stopped answering "
        "(Connection refused); its runs stay as they are there")
    assert lifecycle.close_open_runs("FAILED") == []  # nothing left for the exit to try to close on a silent server


def test_reading_the_commit_leaves_the_checkout_s_git_index_as_it_was(tmp_path, monkeypatch):
    """A tracked run reads the commit with git status, which refreshes a stale index and rewrites it under its lock:
    beside a user's own git command in the same checkout, one of the two would fail on the lock."""
    import subprocess

    import bearingtwin.config

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True,
                       env={**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
                            "GIT_COMMITTER_EMAIL": "t@t"})

    git("init", "-q")
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "module.py").write_text("x = 1\n")
    git("add", ".")
    git("commit", "-qm", "one")
    index = tmp_path / ".git" / "index"
    os.utime(tmp_path / "src" / "module.py", (1e9, 1e9))  # the index's stat data stale, its content the same
    before = index.stat().st_mtime_ns, index.read_bytes()
    monkeypatch.setattr(bearingtwin.config, "REPO_ROOT", tmp_path)
    assert not provenance.git_commit.__wrapped__().endswith("-dirty")
    assert (index.stat().st_mtime_ns, index.read_bytes()) == before
