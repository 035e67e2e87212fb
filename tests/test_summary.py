"""The closing block every command prints, and when training shows its progress bar."""

import pytest
from processes import run_module

from bearingtwin.cli.summary import closing_summary
from bearingtwin.tracking import open_command
from bearingtwin.checks import show_progress_bar
from bearingtwin.cli.train import training_summary
from bearingtwin.config import compose_config
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.mlflow_logging import TrackedRun


def test_the_block_names_what_ran_its_results_the_run_and_how_to_open_it():
    text = closing_summary("bearingtwin-x: y", {"accuracy": "96.00 %"}, "abc123", "sqlite:////data/mlflow.db", "/out")
    assert text.splitlines() == [
        "== bearingtwin-x: y ==",
        "  accuracy: 96.00 %",
        "  MLflow run: abc123  (mlflow ui --backend-store-uri sqlite:////data/mlflow.db)",
        "  output: /out",
    ]
    assert closing_summary("t", ["a line"]) == "== t ==\n  a line"  # nothing logged, nothing written: no such lines
    # The experiment the run is in: MLFLOW_EXPERIMENT_NAME in the shell changes it, and the list a user opens first.
    assert "  MLflow run: abc123 in experiment rig-7  (mlflow ui" in closing_summary(
        "t", [], "abc123", "sqlite:////data/mlflow.db", experiment="rig-7")
    assert open_command("http://mlflow.example:5000") == "open http://mlflow.example:5000"


def test_a_relative_sqlite_store_is_opened_by_its_absolute_path(tmp_path, monkeypatch):
    """sqlite:///rel.db is read from the working directory, which hydra.job.chdir=true makes the run's folder: the
    command printed had opened another (empty) store from the folder the user is in."""
    monkeypatch.chdir(tmp_path)
    assert open_command("sqlite:///runs/m.db") == f"mlflow ui --backend-store-uri sqlite:///{tmp_path / 'runs' / 'm.db'}"
    assert open_command("sqlite:////abs/m.db") == "mlflow ui --backend-store-uri sqlite:////abs/m.db"


def test_training_summary_gives_accuracy_and_f1_per_class_and_says_when_nothing_ran():
    metrics = {"accuracy": 0.95, "f1_normal": 1.0, "f1_inner": 0.9, "precision_inner": 0.8, "inference_ms_per_sample": 1.0}
    text = training_summary("m simulated global seed=0", TrackedRun("r1", metrics), "sqlite:///s.db", "/o")
    assert "  accuracy: 95.00 %" in text and "  F1 per class: normal 1.000, inner 0.900" in text
    assert "skip_finished" not in text
    assert "skip_finished=false" in training_summary("m", TrackedRun("r0", metrics, skipped=True), "sqlite:///s.db", "/o")
    counted = training_summary("m", TrackedRun("r2", {**metrics, "n_train": 420.0, "n_test": 180.0},
                                                artifacts="file:///store/artifacts/r2/artifacts"), "sqlite:///s.db", "/o")
    assert "  windows: 420 to train on, 180 to test on\n  accuracy: 95.00 %" in counted
    assert "  artifacts: file:///store/artifacts/r2/artifacts" in counted



def test_a_calibration_record_its_run_misreads_is_shown_per_class_and_warned_of():
    """A twin-trained run's calibration records are where a false alarm shows first: the healthy record called
    healthy in 10 % of its windows is said, not averaged away into a 55 % calibration accuracy."""
    metrics = {"accuracy": 0.99, "calibration_accuracy": 0.55, "calibration_recall_normal": 0.10,
               "calibration_recall_outer": 1.0}
    text = training_summary("m", TrackedRun("r", metrics), "sqlite:///s.db", "/o")
    assert "  calibration accuracy: 55.00 % (windows right: normal 10.00 %, outer 100.00 %)" in text
    assert "  warning: the normal calibration record is called its state in under 50.00 % of the windows" in text
    fine = training_summary("m", TrackedRun("r", {**metrics, "calibration_recall_normal": 0.9}), "sqlite:///s.db", "/o")
    assert "warning" not in fine


def test_a_feature_groups_choice_says_it_was_the_classifiers_alone_where_the_physics_decides_windows_too():
    """Calibration accuracy 100 % beside 'band power kept (calibration windows right 50 % with it)' read as a
    contradiction: the choice is the classifier's alone, the accuracy counts the envelope's decisions too."""
    metrics = {"accuracy": 0.9, "calibration_accuracy": 1.0, "physics_decided": 0.5, "band_power_kept": 1.0,
               "band_power_calibration_accuracy": 0.5, "lines_only_calibration_accuracy": 0.5}
    text = training_summary("m", TrackedRun("r", metrics), "sqlite:///s.db", "/o")
    assert "  band power: kept (the classifier alone: calibration windows right 50.00 % with it, 50.00 % without)" in text
    without_physics = {key: value for key, value in metrics.items() if key != "physics_decided"}
    assert "(calibration windows right 50.00 % with it" in training_summary("m", TrackedRun("r", without_physics),
                                                                           "sqlite:///s.db", "/o")


def test_the_progress_bar_shows_for_one_watched_run_only(monkeypatch):
    assert show_progress_bar(True, in_sweep=True) and not show_progress_bar(False, in_sweep=False)
    monkeypatch.setattr("sys.stderr.isatty", lambda: True)
    monkeypatch.delenv("CI", raising=False)
    assert show_progress_bar("auto", in_sweep=False)
    assert not show_progress_bar("auto", in_sweep=True)  # parallel jobs would interleave their bars
    monkeypatch.setenv("CI", "true")
    assert not show_progress_bar("auto", in_sweep=False)
    with pytest.raises(BearingTwinError, match="trainer.progress_bar must be auto, true or false"):
        show_progress_bar("maybe", in_sweep=False)


def test_the_vmd_features_bars_show_for_one_watched_run_only(monkeypatch, tmp_path):
    """features.progress=auto (the default) as the trainer's bar: in a terminal, not in CI nor where stderr is a
    log; a bad value is refused naming it, before any run."""
    from bearingtwin.features.extractor import SaboVmdFeatures

    monkeypatch.setattr("sys.stderr.isatty", lambda: True)
    monkeypatch.delenv("CI", raising=False)
    assert compose_config("train").features.progress == "auto"
    assert SaboVmdFeatures(progress="auto").shows_progress and not SaboVmdFeatures(progress=False).shows_progress
    monkeypatch.setattr("sys.stderr.isatty", lambda: False)  # a log file, a pipe
    assert not SaboVmdFeatures(progress="auto").shows_progress
    with pytest.raises(BearingTwinError, match="features.progress must be auto, true or false, got 'maybe'"):
        SaboVmdFeatures(progress="maybe").check_params()
    done = run_module("bearingtwin.cli.train", "features.progress=maybe", f"tracking.uri=sqlite:///{tmp_path}/m.db",
                      cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        "error: features.progress must be auto, true or false, got 'maybe'"]
    assert not (tmp_path / "m.db").exists()


@pytest.mark.parametrize("overrides, words", [
    (["data.rpm=1480", "data.fs=25600", "bearing=cwru_6205"],
     "the twin's cwru_6205 bearing at 1480 rpm, 25600 Hz, 30 s per state"),
    (["data=cwru", "data.load=2"], "CWRU records at 2 hp, channel DE, bearing cwru_6205"),
    (["data=hust", "data.condition=60"], "HUST exports at 60Hz, axis X, bearing er16k"),
    (["data=hust", "data.condition=VS_0_40_0"], "HUST exports at VS_0_40_0Hz, axis X, bearing er16k"),
    (["data=files", "data.root=/my/rig"],
     "the recordings in /my/rig, bearing as the files name it, else the twin's paper (no data.bearing= given)"),
    (["data=files", "data.root=/my/rig", "data.bearing=cwru_6203"], "the recordings in /my/rig, bearing cwru_6203"),
])
def test_a_training_summary_says_what_the_data_were(overrides, words):
    """The speed, rate and bearing a simulated set was made at (its params had shown the simulator's defaults)."""
    from bearingtwin.cli.train import data_words
    from bearingtwin.config import compose_config

    assert data_words(compose_config("train", overrides)) == words
