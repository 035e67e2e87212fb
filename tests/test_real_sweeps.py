"""The HUST and CWRU sweeps and their reports.

A HUST sweep on absent files must stop before MLflow sees anything; a smoke-size HUST sweep
on the fixture files (65 Hz committed, 60 / 70 Hz written here by the fixture generator)
runs end to end into a fresh store and ``bearingtwin-report hust`` reads it back. The CWRU
report's arithmetic (mean +- std over seeds, random - block, per-class recall of the classes
present, confusions) is checked on runs logged with known numbers.
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from omegaconf import OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parent / "fixtures"))
from processes import run_module  # noqa: E402

import make_hust_fixtures  # noqa: E402

from bearingtwin.cli.report import main as report_main  # noqa: E402
from bearingtwin.config import CONF_DIR  # noqa: E402
from bearingtwin.data.build import require_files  # noqa: E402
from bearingtwin.errors import BearingTwinError  # noqa: E402
from bearingtwin.physics.geometry import FAULTS  # noqa: E402
from bearingtwin.tracking import paper  # noqa: E402
from bearingtwin.tracking.mlflow_logging import open_store  # noqa: E402
from bearingtwin.tracking.reports import GENERATED  # noqa: E402
from bearingtwin.tracking.tables import csv_table, generated_text  # noqa: E402

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "hust"
HUST_STEMS = ("H", "0.5X_I", "0.5X_B", "0.5X_O")
# Every stage real, sized for a test: the fixture files hold 1280 rows, so windows are 256 samples.
SMOKE = [
    "seed=0",
    "data.samples_per_class=8",
    "data.window_length=256",
    "search.population=3",
    "search.iterations=1",
    "search.windows=2",
    "trainer.max_epochs=2",
    "features.progress=false",
]


def train_sweep(base: Path, *args: str) -> subprocess.CompletedProcess:
    return run_module("bearingtwin.cli.train", "-m", "+sweep=hust", *args, f"tracking.uri=sqlite:///{base}/mlflow.db",
                      f"paths.cache_dir={base}/cache", f"hydra.sweep.dir={base}/multirun", cwd=base, timeout=900)


def stored_runs(uri: str) -> list:
    client = MlflowClient(uri)
    return [run for experiment in client.search_experiments() for run in client.search_runs([experiment.experiment_id])]


def test_the_sweeps_compose_the_papers_conditions():
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        hust = compose("train", overrides=["+sweep=hust"], return_hydra_config=True)
        cwru = compose("train", overrides=["+sweep=cwru"], return_hydra_config=True)
        at = {hp: compose("train", overrides=["+sweep=cwru", f"+cwru_condition={hp}hp"]).data for hp in range(4)}
    assert hust.data.source == "hust" and hust.hydra.sweeper.params["data.condition"] == "60,65,70"
    assert cwru.data.source == "cwru" and cwru.hydra.sweeper.params["data.split"] == "random,block"
    assert [(at[hp].load, list(at[hp].classes)) for hp in range(4)] == [
        (0, ["normal", "inner", "ball", "outer"]), *((hp, ["inner", "ball", "outer"]) for hp in (1, 2, 3))
    ]


def test_require_files_names_only_the_absent_files_and_data_root(tmp_path):
    def hust(condition):
        return OmegaConf.create({"data": {"source": "hust", "root": str(FIXTURES), "condition": condition,
                                          "classes": dict(zip(FAULTS, HUST_STEMS))}})

    require_files([hust(65)])  # the committed fixtures: nothing missing
    with pytest.raises(BearingTwinError) as error:
        require_files([hust(condition) for condition in (60, 65, 70)])
    message = str(error.value)
    missing = message.split(":", 1)[1].split("(found")[0]
    assert sorted(re.findall(r"[\w.]+\.xls", missing)) == sorted(f"{s}_{hz}Hz.xls" for s in HUST_STEMS for hz in (60, 70))
    assert str(FIXTURES) in message and "data.root=" in message


def test_missing_hust_files_are_named_with_the_conditions_the_folder_holds_or_its_subfolder_that_holds_them(tmp_path):
    def hust(root, condition):
        return OmegaConf.create({"data": {"source": "hust", "root": str(root), "condition": condition,
                                          "classes": dict(zip(FAULTS, HUST_STEMS))}})

    (tmp_path / "hust").mkdir()
    for path in FIXTURES.glob("*_65Hz.xls"):
        shutil.copy(path, tmp_path / "hust")
    shutil.copy(FIXTURES / "H_65Hz.xls", tmp_path / "hust" / "h_vs_0_40_0hz.xls")
    shutil.copy(FIXTURES / "H_65Hz.xls", tmp_path / "hust" / "0.5X_O_60Hz.xls")
    with pytest.raises(BearingTwinError) as error:
        require_files([hust(tmp_path / "hust", 56)])
    assert f"; {tmp_path}/hust holds HUST files for data.condition=60, 65, VS_0_40_0. Put" in str(error.value)
    # An archive unpacked one level down: the folder holds none, its subfolder all of them.
    with pytest.raises(BearingTwinError) as error:
        require_files([hust(tmp_path, 65)])
    assert (f"; {tmp_path} holds no HUST file, but its subfolder hust does: data.root={tmp_path}/hust. Put"
            in str(error.value)) and len(str(error.value).splitlines()) == 1


def test_hust_sweep_on_absent_files_exits_2_and_logs_nothing(tmp_path):
    present = tmp_path / "hust"
    present.mkdir()
    for path in FIXTURES.glob("*_65Hz.xls"):
        shutil.copy(path, present)
    done = train_sweep(tmp_path, f"data.root={present}", *SMOKE)
    assert done.returncode == 2, done.stderr[-2000:]
    error = done.stderr.strip().splitlines()[-1]
    for stem in HUST_STEMS:
        assert f"{stem}_60Hz.xls" in error and f"{stem}_70Hz.xls" in error
    assert "data.root=" in error and str(present) in error
    assert not (tmp_path / "mlflow.db").exists() or stored_runs(f"sqlite:///{tmp_path}/mlflow.db") == []


def test_cwru_sweep_on_an_absent_folder_exits_2_and_logs_nothing(tmp_path):
    done = run_module("bearingtwin.cli.train", "-m", "data=cwru", "seed=0,1", f"data.root={tmp_path}/nonexistent",
                      f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"hydra.sweep.dir={tmp_path}/multirun",
                      cwd=tmp_path, timeout=300)
    assert done.returncode == 2, done.stderr[-2000:]
    assert done.stderr.strip().startswith("error: ") and len(done.stderr.strip().splitlines()) == 1
    assert f"{tmp_path}/nonexistent" in done.stderr and "Launching" not in done.stdout
    assert not (tmp_path / "mlflow.db").exists() or stored_runs(f"sqlite:///{tmp_path}/mlflow.db") == []
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        twin_to_real = compose("train", overrides=["data=twin_to_real", "bearing=cwru_6205", f"data.root={tmp_path}/nonexistent"])
    with pytest.raises(BearingTwinError, match=f"{tmp_path}/nonexistent/normal_0_97.mat: no such CWRU record"):
        require_files([twin_to_real])


@pytest.fixture(scope="module")
def hust_store(tmp_path_factory):
    base = tmp_path_factory.mktemp("hust_sweep")
    root = base / "hust"
    root.mkdir()
    for path in FIXTURES.glob("*_65Hz.xls"):
        shutil.copy(path, root)
    for hz in (60, 70):
        make_hust_fixtures.write_class_files(root, hz)
    done = train_sweep(base, f"data.root={root}", *SMOKE)
    assert done.returncode == 0, done.stderr[-3000:]
    return f"sqlite:///{base}/mlflow.db", base


def test_hust_sweep_trains_every_condition_and_split_on_its_own_files(hust_store):
    uri, _ = hust_store
    runs = [run for run in stored_runs(uri) if run.data.tags.get("bt.kind") == "train"]
    assert all(run.info.status == "FINISHED" for run in runs)
    cells = sorted((run.data.params["data.condition"], run.data.params["data.split"]) for run in runs)
    assert cells == [(hz, split) for hz in ("60", "65", "70") for split in ("block", "random")]
    # Each speed reads its own four files, so the datasets differ.
    assert len({run.data.tags["dataset_key"] for run in runs}) == 3
    sweep = [run for run in stored_runs(uri) if run.data.tags.get("bt.kind") == "sweep"]
    assert len(sweep) == 1 and sweep[0].info.status == "FINISHED" and sweep[0].data.tags["n_finished"] == "6"


def table_rows(markdown: str, first_cell: str) -> list[list[str]]:
    rows = [[cell.strip() for cell in line.strip("|").split("|")] for line in markdown.splitlines() if line.startswith("|")]
    return [row for row in rows if row[0].startswith(first_cell)]


def test_hust_report_sets_the_papers_figure_beside_each_speed(hust_store, capsys):
    uri, base = hust_store
    out = base / "hust.md"
    assert report_main(["hust", f"uri={uri}", f"out={out}"]) == 0
    markdown = generated_text(out, GENERATED)  # the file holds the report between its two marker lines
    assert markdown in capsys.readouterr().out
    runs = {(r.data.params["data.condition"], r.data.params["data.split"]): r
            for r in stored_runs(uri) if r.data.tags.get("bt.kind") == "train"}
    rows = table_rows(markdown, "")
    for hz, published in paper.HUST.items():
        for split in ("random", "block"):
            row = next(r for r in rows if r[0] == f"{hz} Hz" and r[1] == split)
            ours = 100 * runs[(str(hz), split)].data.metrics["accuracy"]
            assert row[3] == f"{ours:.2f} ± 0.00" and row[4] == "1"
            assert row[7] == f"{published:.2f}" and row[8] == f"{ours - published:+.2f}"
        leak = next(r for r in rows if r[0] == f"{hz} Hz" and len(r) == 5)
        gap = 100 * (runs[(str(hz), "random")].data.metrics["accuracy"] - runs[(str(hz), "block")].data.metrics["accuracy"])
        assert leak[4] == f"{gap:+.2f}"
    reports = [r for r in stored_runs(uri) if r.data.tags.get("bt.kind") == "report"]
    assert [r.data.tags["report"] for r in reports] == ["hust"]
    # condition= keeps one speed.
    assert report_main(["hust", f"uri={uri}", f"out={base / 'hust65.md'}", "condition=65"]) == 0
    assert {row[0] for row in table_rows((base / "hust65.md").read_text(), "")} & {"60 Hz", "70 Hz"} == set()


def log_real_run(client, experiment_id, data, classes, split, seed, confusion, dataset_key="records", **params):
    """A FINISHED real-data training run carrying what train_tracked logs that the report reads (a class with no test
    windows has no recall): ``data``, the data.* params naming its source, condition and classes; and ``params``
    (dotted keys as ``data__samples_per_class``)."""
    confusion = np.asarray(confusion)
    labels = [FAULTS.index(name) for name in classes]
    full = np.zeros((4, 4), dtype=int)
    full[np.ix_(labels, labels)] = confusion
    run = client.create_run(experiment_id, tags={"bt.kind": "train", "method": paper.PROPOSED, "seed": str(seed),
                                                 "dataset_key": dataset_key})
    run_id = run.info.run_id
    for key, value in {**data, "data.split": split,
                       **{key.replace("__", "."): str(value) for key, value in params.items()}}.items():
        client.log_param(run_id, key, value)
    client.log_metric(run_id, "accuracy", np.trace(full) / full.sum())
    for index, name in enumerate(FAULTS):
        if full[index].sum():
            client.log_metric(run_id, f"recall_{name}", full[index, index] / full[index].sum())
    client.log_text(run_id, csv_table(["true \\ predicted", *FAULTS], [[n, *row] for n, row in zip(FAULTS, full)]), "confusion_matrix.csv")
    client.set_terminated(run_id, "FINISHED")


def log_cwru_run(client, experiment_id, load, classes, split, seed, confusion, dataset_key="records", **params):
    log_real_run(client, experiment_id, {"data.source": "cwru", "data.load": str(load), "data.classes": str(list(classes))},
                 classes, split, seed, confusion, dataset_key, **params)


def log_hust_run(client, experiment_id, condition, stems, split, seed, confusion, channel="X", dataset_key="records"):
    log_real_run(client, experiment_id, {"data.source": "hust", "data.condition": condition, "data.channel": channel,
                                         **{f"data.classes.{fault}": stem for fault, stem in stems.items()}},
                 list(stems), split, seed, confusion, dataset_key)


def test_a_hust_run_on_other_files_than_the_papers_stands_beside_no_paper_figure_and_says_what_it_read(tmp_path, capsys):
    """A run on the severe faults (H, I, B, O) or on channel Y is another experiment than Table 5's (the medium faults
    on X): its row names the files and channel it read and stands beside no paper figure. A condition logged as 65.0
    is the same 65 Hz as the files name it, for the table's rows and for condition= alike."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client, experiment_id = open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
    perfect = np.eye(4, dtype=int) * 10
    log_hust_run(client, experiment_id, "65", paper.HUST_CLASSES, "random", 0, perfect)
    log_hust_run(client, experiment_id, "65.0", paper.HUST_CLASSES, "random", 1, perfect)
    severe = {"normal": "H", "inner": "I", "ball": "B", "outer": "O"}
    log_hust_run(client, experiment_id, "65", severe, "random", 0, perfect, dataset_key="severe")
    log_hust_run(client, experiment_id, "65", paper.HUST_CLASSES, "random", 0, perfect, channel="Y", dataset_key="y")
    log_hust_run(client, experiment_id, "60", paper.HUST_CLASSES, "random", 0, perfect, dataset_key="sixty")
    for index, condition in enumerate(([], ["condition=65.0"], ["condition=65"])):
        out = tmp_path / f"hust{index}.md"
        assert report_main(["hust", f"uri={uri}", f"out={out}", *condition]) == 0
        # The runs behind the numbers: those of the condition asked for alone (its record counts no 60 Hz run).
        assert f'"runs": [{4.0 if condition else 5.0}]' in out.read_text()
        rows = {row[3]: row for row in table_rows(generated_text(out, GENERATED), "65 Hz")}
        assert sorted(rows) == ["H, 0.5X_I, 0.5X_B, 0.5X_O, channel X (dataset records)",
                                "H, 0.5X_I, 0.5X_B, 0.5X_O, channel Y (dataset y)", "H, I, B, O, channel X (dataset severe)"]
        papers = rows["H, 0.5X_I, 0.5X_B, 0.5X_O, channel X (dataset records)"]
        assert papers[5] == "2" and papers[8:] == [f"{paper.HUST[65]:.2f}", f"{100 - paper.HUST[65]:+.2f}"]
        assert rows["H, I, B, O, channel X (dataset severe)"][8] == "—"
        assert rows["H, 0.5X_I, 0.5X_B, 0.5X_O, channel Y (dataset y)"][8] == "—"
    with pytest.raises(SystemExit) as exit_:
        report_main(["hust", f"uri={uri}", f"out={tmp_path / 'hust.md'}", "condition=65Hz"])
    assert exit_.value.code == 2 and "condition='65Hz' is not a HUST condition (without Hz" in capsys.readouterr().err


def test_cwru_report_measures_leakage_as_random_minus_block(tmp_path, capsys):
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client, experiment_id = open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
    four, three = list(FAULTS), ["inner", "ball", "outer"]
    perfect4, perfect3 = np.eye(4, dtype=int) * 10, np.eye(3, dtype=int) * 10
    ball_as_outer = perfect3.copy()
    ball_as_outer[1] = [0, 6, 4]  # ball recall 60 %
    log_cwru_run(client, experiment_id, 0, four, "random", 0, perfect4)
    log_cwru_run(client, experiment_id, 0, four, "random", 1, perfect4)
    log_cwru_run(client, experiment_id, 2, three, "random", 0, perfect3)
    log_cwru_run(client, experiment_id, 2, three, "block", 0, ball_as_outer)
    log_cwru_run(client, experiment_id, 2, three, "block", 1, perfect3)
    out = tmp_path / "cwru.md"
    assert report_main(["cwru", f"uri={uri}", f"out={out}"]) == 0
    markdown = generated_text(out, GENERATED)
    assert "no published figure" in markdown and "paper %" not in markdown
    rows = table_rows(markdown, "")
    zero = next(r for r in rows if r[:2] == ["0 hp", "random"])
    assert zero[3:5] == ["100.00 ± 0.00", "2"] and zero[6] == "none"
    assert all(name in zero[5] for name in FAULTS)
    block = next(r for r in rows if r[:2] == ["2 hp", "block"])
    block_accuracies = np.array([26 / 30, 1.0]) * 100
    assert block[3] == f"{block_accuracies.mean():.2f} ± {block_accuracies.std():.2f}"
    assert "normal" not in block[5] and "ball 80.0 ± 20.0" in block[5]  # no healthy record at 2 hp
    assert block[6] == "ball→outer 4"
    leak = next(r for r in rows if r[0] == "2 hp" and len(r) == 5)
    assert leak[4] == f"{100 - block_accuracies.mean():+.2f}"
    assert not any(r[0] == "0 hp" and len(r) == 5 for r in rows)  # 0 hp has no block runs
    assert markdown in capsys.readouterr().out


def test_runs_on_other_classes_or_recordings_are_other_rows_not_seeds(tmp_path):
    """Averaged as seeds, a three-class and a four-class run made one 'mean', and a class one of them never
    tested (no recall) ended the report in a KeyError."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client, experiment_id = open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
    untested_ball = np.eye(4, dtype=int) * 10
    untested_ball[2, 2] = 0  # its ball records gave no test window
    log_cwru_run(client, experiment_id, 1, list(FAULTS), "block", 0, untested_ball)
    log_cwru_run(client, experiment_id, 1, ["normal", "inner", "outer"], "block", 1, np.eye(3, dtype=int) * 10)
    log_cwru_run(client, experiment_id, 1, list(FAULTS), "block", 2, np.eye(4, dtype=int) * 10, dataset_key="other")
    out = tmp_path / "cwru.md"
    assert report_main(["cwru", f"uri={uri}", f"out={out}"]) == 0
    rows = table_rows(generated_text(out, GENERATED), "1 hp")
    assert sorted((row[3], row[5]) for row in rows) == [
        ("normal, inner, ball, outer (dataset other)", "1"), ("normal, inner, ball, outer (dataset records)", "1"),
        ("normal, inner, outer (dataset records)", "1")]
    untested = next(row for row in rows if row[3] == "normal, inner, ball, outer (dataset records)")
    assert "ball —" in untested[6]
    # A smoke-size run beside a full one: its row says its size, not only its dataset's key.
    log_cwru_run(client, experiment_id, 3, list(FAULTS), "block", 0, np.eye(4, dtype=int) * 10, dataset_key="small",
                 data__samples_per_class=40, trainer__max_epochs=10, classifier__name="cnn_bilstm")
    log_cwru_run(client, experiment_id, 3, list(FAULTS), "block", 0, np.eye(4, dtype=int) * 10, dataset_key="full",
                 data__samples_per_class=300, trainer__max_epochs=150, classifier__name="cnn_bilstm")
    # An SVM logs the trainer's epochs too, which it never runs: its row gives none.
    log_cwru_run(client, experiment_id, 3, list(FAULTS), "block", 0, np.eye(4, dtype=int) * 10, dataset_key="svm",
                 data__samples_per_class=40, trainer__max_epochs=100, classifier__name="svm")
    assert report_main(["cwru", f"uri={uri}", f"out={out}"]) == 0
    assert sorted(row[3] for row in table_rows(generated_text(out, GENERATED), "3 hp")) == [
        "normal, inner, ball, outer (dataset full; windows per class 300, epochs 150)",
        "normal, inner, ball, outer (dataset small; windows per class 40, epochs 10)",
        "normal, inner, ball, outer (dataset svm; windows per class 40)"]


def test_reports_without_runs_say_what_is_missing(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        report_main(["hust", f"uri=sqlite:///{tmp_path}/empty.db", f"out={tmp_path}/x.md"])
    assert exit_.value.code == 2  # a typo in uri= would otherwise create an empty store and say it has no runs
    # Named by the key this command takes (uri=), not the training config's tracking.uri=.
    assert f"error: uri=sqlite:///{tmp_path}/empty.db: no such store ({tmp_path}/empty.db does not exist)" in \
        capsys.readouterr().err
    from omegaconf import OmegaConf

    from bearingtwin.tracking.mlflow_logging import open_store

    open_store(OmegaConf.create({"uri": f"sqlite:///{tmp_path}/empty.db", "experiment": "bearingtwin"}))
    with pytest.raises(SystemExit) as exit_:
        report_main(["hust", f"uri=sqlite:///{tmp_path}/empty.db", f"out={tmp_path}/x.md"])
    assert exit_.value.code == 2
    assert "data.source=hust" in capsys.readouterr().err


def test_a_run_at_other_settings_is_a_row_of_its_own_not_a_seed_that_displaces_the_tables():
    """An ablation run (the SVM at classifier.C=0.001) logged after a method's sweep neither replaces the sweep's
    runs of its seed nor averages with them: Table 4 and the seeds list give it a row named by what differs. A
    param a run's code did not log yet is no difference, and neither are the seed, the store or the size."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        uri = f"sqlite:///{scratch}/mlflow.db"
        client, experiment_id = open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))

        def log(seed, accuracy, **params):
            run = client.create_run(experiment_id, tags={"bt.kind": "train", "method": "sabo_vmd_pemie+svm",
                                                         "seed": str(seed)})
            logged = {"data.source": "simulated", "features.vmd_params": "global", "classifier.C": "1.0",
                      "seed": str(seed), "tracking.uri": uri, "data.duration": "30.0", "data.fs": "10000.0", **params}
            for key, value in logged.items():
                client.log_param(run.info.run_id, key, value)
            client.log_metric(run.info.run_id, "accuracy", accuracy)
            client.set_terminated(run.info.run_id, "FINISHED")

        log(0, 0.90, **{"features.rates": "all", "features.population": "15", "simulator.seed": "0"})
        log(1, 0.92, **{"simulator.seed": "1"})  # logged before features.rates existed: the same setting
        log(0, 0.20, **{"classifier.C": "0.001"})
        # A smoke run of the sweep's setting (the features copy the search's size) is a smaller run, left out.
        log(2, 0.50, **{"data.duration": "2.0", "features.population": "4"})
        # Another rate is another setting, as another C is.
        log(3, 0.70, **{"data.fs": "8000.0"})
        out = Path(scratch) / "table4.md"
        assert report_main(["table4", f"uri={uri}", f"out={out}"]) == 0
        rows = {row[0]: row[2:4] for row in table_rows(generated_text(out, GENERATED), "SABO-VMD-SVM")}
        assert rows == {"SABO-VMD-SVM (PE-MIE) (classifier.C=1.0, data.fs=10000.0)": ["91.00 ± 1.00", "2"],
                        "SABO-VMD-SVM (PE-MIE) (classifier.C=0.001, data.fs=10000.0)": ["20.00 ± 0.00", "1"],
                        "SABO-VMD-SVM (PE-MIE) (classifier.C=1.0, data.fs=8000.0)": ["70.00 ± 0.00", "1"]}
        assert report_main(["seeds", f"uri={uri}", f"out={out}"]) == 0
        listed = {row[0]: row[1] for row in table_rows(generated_text(out, GENERATED), "sabo_vmd_pemie+svm")}
        assert listed == {"sabo_vmd_pemie+svm (classifier.C=1.0, data.fs=10000.0)": "0: 90.00, 1: 92.00",
                          "sabo_vmd_pemie+svm (classifier.C=0.001, data.fs=10000.0)": "0: 20.00",
                          "sabo_vmd_pemie+svm (classifier.C=1.0, data.fs=8000.0)": "3: 70.00"}


def test_a_sweep_whose_search_seed_follows_the_seed_is_one_row_beside_one_that_holds_it():
    """results/table3.md's second command (features.seed=${seed}) beside the table's sweep (features.seed held at 0):
    two rows, the first named by its held seed, the second by ${seed}, each with its seeds; not a row per seed."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        uri = f"sqlite:///{scratch}/mlflow.db"
        client, experiment_id = open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin", "artifact_root": None}))
        for seed, search_seed, accuracy in ((0, 0, 0.90), (1, 0, 0.92), (2, 0, 0.94), (1, 1, 0.80), (2, 2, 0.82)):
            run = client.create_run(experiment_id, tags={"bt.kind": "train", "method": "sabo_vmd_pemie+svm",
                                                         "seed": str(seed)})
            for key, value in {"data.source": "simulated", "features.vmd_params": "global", "seed": str(seed),
                               "features.seed": str(search_seed), "data.duration": "30.0"}.items():
                client.log_param(run.info.run_id, key, value)
            client.log_metric(run.info.run_id, "accuracy", accuracy)
            client.set_terminated(run.info.run_id, "FINISHED")
        out = Path(scratch) / "table4.md"
        assert report_main(["table4", f"uri={uri}", f"out={out}"]) == 0
        rows = {row[0]: row[2:4] for row in table_rows(generated_text(out, GENERATED), "SABO-VMD-SVM")}
        assert rows == {"SABO-VMD-SVM (PE-MIE) (features.seed=0)": ["92.00 ± 1.63", "3"],
                        "SABO-VMD-SVM (PE-MIE) (features.seed=${seed})": ["81.00 ± 1.00", "2"]}
