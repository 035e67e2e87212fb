"""The training entry point: config composition, whole-pipeline determinism, bad input."""

import os

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from processes import run_module

from bearingtwin.config import CONF_DIR, REPO_ROOT, refuse_bad_overrides, unread_overrides
from bearingtwin.models.experiment import TIMING_METRICS, run_experiment

# Small enough for a test, but every stage real: twin simulation, SABO-VMD, CNN-BiLSTM.
SMOKE = [
    "data.samples_per_class=12",
    "data.duration=1.0",
    "search.population=3",
    "search.iterations=1",
    "search.windows=2",
    "features.progress=false",
    "trainer.max_epochs=2",
]


def compose_train(overrides):
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        return compose("train", overrides=overrides)


def test_defaults_compose_to_the_papers_method(monkeypatch):
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)  # the suite sets one; the default is the embedded store
    cfg = compose_train([])
    assert (cfg.data.source, cfg.features.name, cfg.classifier.name) == ("simulated", "sabo_vmd_pemie", "cnn_bilstm")
    assert cfg.tracking.uri == f"sqlite:///{REPO_ROOT}/mlruns/mlflow.db"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "http://tracking.example:5000")
    assert compose_train([]).tracking.uri == "http://tracking.example:5000"
    svm = compose_train(["+method=sabo_pemie_svm"])
    assert (svm.features.name, svm.classifier.name) == ("sabo_vmd_pemie", "svm")
    assert compose_train(["+method=raw_cnn_bilstm"]).features.kind == "raw"


def test_same_seed_same_numbers_other_seed_other_split(tmp_path):
    overrides = SMOKE + [f"paths.cache_dir={tmp_path}/cache"]

    def scores(seed):
        result = run_experiment(compose_train(overrides + [f"seed={seed}"]), root_dir=str(tmp_path))
        return {k: v for k, v in result.metrics.items() if k not in TIMING_METRICS}, result

    first, result = scores(0)
    again, _ = scores(0)
    assert first == again
    other, other_result = scores(1)
    assert other != first  # the random split (and the weights) change with the seed
    assert result.confusion.sum() == result.n_test and np.trace(result.confusion) == pytest.approx(first["accuracy"] * result.n_test)
    assert len(result.history) == 2 and result.vmd_params


def run_cli(args, cwd):
    return run_module("bearingtwin.cli.train", *args, cwd=cwd, timeout=600)


def test_bad_value_exits_2_naming_the_field_before_a_run_is_opened(tmp_path):
    """A classifier's or the features' bad value is refused before MLflow is opened: no store, no FAILED run
    for a typo (a job of a sweep fails in its own run instead, and the sweep goes on: test_sweep_e2e)."""
    for bad in ("classifier.C=-1", "search.population=0"):
        done = run_cli(["classifier=svm", bad, f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
        assert done.returncode == 2, done.stderr
        (line,) = done.stderr.strip().splitlines()
        assert line.startswith(f"error: {bad.split('=')[0]} ") and "Traceback" not in done.stderr, line
    assert not (tmp_path / "mlflow.db").exists()
    # Nor a folder: Hydra made outputs/<date>/<time>/ with the config and an empty log; the refusal removes it.
    assert not (tmp_path / "outputs").exists(), sorted(str(p) for p in (tmp_path / "outputs").rglob("*"))
    (tmp_path / "outputs" / "mine").mkdir(parents=True)  # a folder of the user's beside it is kept
    done = run_cli(["classifier=svm", "classifier.C=-1", f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert done.returncode == 2 and [p.name for p in (tmp_path / "outputs").iterdir()] == ["mine"]
    # A run folder the user named may have been there before (empty): it is never removed, nor a folder above it.
    (tmp_path / "named" / "run1").mkdir(parents=True)
    done = run_cli(["classifier=svm", "classifier.C=-1", "hydra.run.dir=named/run1"], tmp_path)
    assert done.returncode == 2 and (tmp_path / "named" / "run1").is_dir()


def test_unknown_key_is_refused(tmp_path):
    done = run_cli(["classifier.hidden_unitz=3", f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert done.returncode != 0 and "hidden_unitz" in done.stderr
    added = run_cli(["+unknown.key=1", f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert added.returncode == 2 and added.stderr.strip().splitlines() == [
        "error: +unknown.key=1: unknown.key is not a setting of train (no config declares it); "
        "check its spelling, or set a declared key without '+'"]
    assert not (tmp_path / "mlflow.db").exists()


def test_a_key_no_config_declares_in_an_experiment_file_of_ones_own_is_refused_naming_the_file(tmp_path):
    """``seeed: 3`` or ``trainer: {max_epoch: 5}`` in an experiment of one's own had been carried along unread (logged as
    a param beside the default that ran), where the same typo on the command line is refused: refused alike, in a
    single run and in a sweep, before a store is opened. Filling in a map a config declares null (``physics_first``)
    or a class's arguments is not a typo."""
    (tmp_path / "conf" / "experiment").mkdir(parents=True)
    for name, body in (("typo", "seeed: 3\n"), ("nested", "trainer:\n  max_epoch: 5\n"),
                       ("fine", "seed: 3\nphysics_first:\n  threshold_db: 20.0\n  margin_db: 10.0\n")):
        (tmp_path / "conf" / "experiment" / f"{name}.yaml").write_text(f"# @package _global_\n{body}")
    store = [f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"hydra.sweep.dir={tmp_path}/multirun"]
    for mode, (name, said) in ((["--config-dir", str(tmp_path / "conf")], ("typo", "seeed is not a setting of train (no config declares it); did you mean seed?")),
                               (["-m", "--config-dir", str(tmp_path / "conf")], ("nested", "trainer.max_epoch is not a setting of train (no config "
                                                                "declares it); did you mean trainer.max_epochs?"))):
        done = run_cli([*mode, f"+experiment={name}", "seed=0,1" if "-m" in mode else "seed=0", "classifier=svm",
                        *store], tmp_path)
        assert done.returncode == 2 and done.stderr.strip().splitlines() == [f"error: +experiment={name}: {said}"], (
            done.stderr[-2000:])
    assert not (tmp_path / "mlflow.db").exists()
    fine = run_cli(["--config-dir", str(tmp_path / "conf"), "+experiment=fine", "classifier=svm", "--cfg", "job"], tmp_path)
    assert fine.returncode == 0 and "threshold_db: 20.0" in fine.stdout, fine.stderr[-2000:]


def test_another_commands_config_named_with_cn_is_refused_in_one_line(tmp_path):
    """``bearingtwin-train -cn simulate`` ran simulate.yaml as training's config and failed on a key it lacks, with
    Hydra's multi-line error and exit 1."""
    done = run_cli(["-cn", "simulate", f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        "error: -cn simulate: conf/simulate.yaml is bearingtwin-simulate's config, without this command's settings; "
        "this command composes conf/train.yaml (a copy of it of your own: -cd <folder> -cn <name>)"], done.stderr[-2000:]


def test_a_misspelt_key_in_a_sweep_is_named_with_the_setting_it_is_closest_to(tmp_path):
    """``-m classifer=svm,knn`` is composed job by job; the line had said "check its spelling", where a single run's
    names the setting meant."""
    done = run_cli(["-m", "classifer=svm,sklearn", f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        "error: classifer: not a setting (no config declares it); did you mean classifier?"], done.stderr[-2000:]
    assert not (tmp_path / "mlflow.db").exists()


def test_a_sweep_lives_in_the_store_its_jobs_log_to_and_only_one(tmp_path):
    """The store a sweep file's params set is the jobs' and so the parent run's (the sweep's own config lacks it,
    and MLflow sets MLFLOW_TRACKING_URI as a job logs its model); jobs over several stores are refused, before any
    job runs: one parent run cannot stand in all of them."""
    (tmp_path / "conf" / "sweep").mkdir(parents=True)
    (tmp_path / "conf" / "sweep" / "mine.yaml").write_text(
        f"# @package _global_\nhydra:\n  sweeper:\n    params:\n      tracking.uri: sqlite:///{tmp_path}/own.db\n")
    quick = ["classifier=svm", "features=raw", "data.samples_per_class=12", "data.duration=1.0",
             f"paths.cache_dir={tmp_path}/cache", f"hydra.sweep.dir={tmp_path}/multirun"]
    done = run_cli(["-m", "--config-dir", str(tmp_path / "conf"), "+sweep=mine", *quick], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"runs in experiment bearingtwin: mlflow ui --backend-store-uri sqlite:///{tmp_path}/own.db" in done.stdout
    assert "[HYDRA]" in done.stderr and "[HYDRA]" not in done.stdout  # Hydra's own lines beside the log's
    client = MlflowClient(f"sqlite:///{tmp_path}/own.db")
    runs = client.search_runs([client.get_experiment_by_name("bearingtwin").experiment_id])
    assert sorted((r.data.tags["bt.kind"], r.info.status) for r in runs) == [("sweep", "FINISHED"), ("train", "FINISHED")]
    several = run_cli(["-m", f"tracking.uri=sqlite:///{tmp_path}/a.db,sqlite:///{tmp_path}/b.db", *quick], tmp_path)
    assert several.returncode == 2 and several.stderr.strip().splitlines() == [
        f"error: tracking.uri differs between the sweep's jobs (sqlite:///{tmp_path}/a.db, sqlite:///{tmp_path}/b.db): "
        "a sweep logs to one store, where its parent run is; run one sweep per store"]
    assert not list(tmp_path.glob("[ab].db"))


def test_a_shuffled_sweep_names_each_job_by_its_own_overrides(tmp_path):
    """Hydra's shuffle() orders the jobs at random; the summary still names the failing job by its overrides."""
    done = run_cli(["-m", "classifier=svm", "features=raw", "data.samples_per_class=12", "data.duration=1.0",
                    "classifier.C=shuffle(1,2,-1,3,-2,4)", f"paths.cache_dir={tmp_path}/cache",
                    f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"hydra.sweep.dir={tmp_path}/multirun"], tmp_path)
    assert done.returncode == 1, done.stderr[-2000:]
    failed = [line.split(": ")[1] for line in done.stdout.splitlines() if line.startswith("  FAILED: ")]
    assert sorted(failed) == ["classifier.C=-1", "classifier.C=-2"], done.stdout[-2000:]  # another order: right by chance 1 in 15
    assert "6 jobs, 4 finished, 2 failed" in done.stdout


def test_an_effect_parameter_is_refused_before_a_run_is_opened(tmp_path):
    """Effects are built from their parameters first: a bad one leaves no FAILED run behind (as simulate refuses it)."""
    done = run_cli(["classifier=svm", "features=raw", "effects=[noise]", "effects.noise.snr_db=[1,2]",
                    f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"], tmp_path)
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        "error: effects.noise.snr_db must be finite, got [1, 2]"]
    assert not (tmp_path / "mlflow.db").exists()


def test_stdout_holds_the_closing_summary_alone_and_log_lines_go_to_stderr(tmp_path):
    """`bearingtwin-train ... > result.txt` keeps the closing block: Hydra's log lines (a feature cache's
    hit, a registration) went to stdout before it."""
    done = run_cli(["classifier=svm", "features=raw", "data.samples_per_class=12", "data.duration=1.0",
                    f"paths.cache_dir={tmp_path}/cache", f"tracking.uri=sqlite:///{tmp_path}/m.db",
                    f"hydra.run.dir={tmp_path}/out", "register=quiet"], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("== bearingtwin-train: ") and "registered" not in done.stdout, done.stdout
    assert "registered quiet version 1" in done.stderr
    log_text = (tmp_path / "out" / "train.log").read_text()
    assert "registered quiet version 1" in log_text  # the run's log keeps them, and what the run came to
    assert done.stdout.strip() in log_text and done.stderr.count("== bearingtwin-train: ") == 0
    # Hydra's own logging choices replace the project's whole (a patch of the console's stream had left
    # hydra/job_logging=disabled a handler to patch that it lacks: ValueError, exit 1).
    done = run_cli(["classifier=svm", "features=raw", "data.samples_per_class=12", "data.duration=1.0",
                    f"paths.cache_dir={tmp_path}/cache", f"tracking.uri=sqlite:///{tmp_path}/m.db",
                    f"hydra.run.dir={tmp_path}/quiet", "hydra/job_logging=disabled", "hydra/hydra_logging=disabled"],
                   tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("== bearingtwin-train: ") and "[INFO]" not in done.stderr
    assert not (tmp_path / "quiet" / "train.log").exists()


def test_a_setting_the_run_never_reads_is_said_and_the_run_goes_on(capsys):
    """The twin's settings where the data are recordings, the Lightning trainer's where the classifier is no network:
    accepted, logged and ignored without a word, they had passed for settings of the run."""
    overrides = ["data=cwru", "classifier=svm", "simulator.rpm=100", "effects=[noise]", "trainer.max_epochs=-3"]
    unread = unread_overrides(compose_train(overrides), overrides)
    assert [line.split(" not read: ")[0] for line in unread] == ["simulator.rpm=100", "effects=[noise]",
                                                                 "trainer.max_epochs=-3"]
    assert "data=cwru reads recordings" in unread[0] and "classifier=svm trains without it" in unread[2]
    assert unread_overrides(compose_train(["trainer.max_epochs=3"]), ["trainer.max_epochs=3"]) == []  # the network's
    # A sweep over the classifiers reads the trainer in some of its jobs: nothing said (composed, the sweep's config
    # shows one classifier of them, here the SVM).
    swept = ["classifier=svm,cnn_bilstm", "trainer.max_epochs=3"]
    assert unread_overrides(compose_train(["classifier=svm", "trainer.max_epochs=3"]), swept) == []
    swept = ["data=cwru,simulated", "simulator.rpm=100"]
    assert unread_overrides(compose_train(["data=cwru", "simulator.rpm=100"]), swept) == []
    refuse_bad_overrides("train", ["classifier=svm", "trainer.max_epochs=3"])  # said before the run, on stderr
    assert capsys.readouterr().err == ("warning: trainer.max_epochs=3 not read: the trainer is the CNN-BiLSTM's, and "
                                       "classifier=svm trains without it\n")



def test_mlflows_experiment_variable_names_every_commands_experiment(monkeypatch):
    """MLFLOW_EXPERIMENT_NAME, which MLflow reads, is each command's experiment where set (it had been passed over
    without a word, as MLFLOW_TRACKING_URI never was); each command's own name otherwise."""
    from bearingtwin.config import compose_config

    monkeypatch.delenv("MLFLOW_EXPERIMENT_NAME", raising=False)
    overrides = {"train": [], "twin": ["measured.path=x.npy"], "diagnose": ["path=x.npy", "model=runs:/x/model"]}
    assert {name: compose_config(name, o).tracking.experiment for name, o in overrides.items()} == {
        "train": "bearingtwin", "twin": "bearingtwin-twin", "diagnose": "bearingtwin-diagnose"}
    monkeypatch.setenv("MLFLOW_EXPERIMENT_NAME", "rig-7")
    assert {compose_config(name, o).tracking.experiment for name, o in overrides.items()} == {"rig-7"}


def test_without_home_the_cache_is_the_users_own_not_a_folder_everyone_shares(monkeypatch):
    """HOME unset (a cron job, a service) had put the cache in /tmp/.cache/bearingtwin, which every user of the machine
    shares and may plant entries in; now the user's home from the password database, as Python finds it."""
    import pwd

    from bearingtwin.config import compose_config

    for name in ("HOME", "BEARINGTWIN_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    home = pwd.getpwuid(os.getuid()).pw_dir
    assert compose_config("train", []).paths.cache_dir == f"{home}/.cache/bearingtwin"


def test_an_empty_environment_variable_is_read_as_unset(monkeypatch):
    """``BEARINGTWIN_CACHE=`` had put the cache in the current folder, ``XDG_CACHE_HOME=`` at /bearingtwin, and
    ``BEARINGTWIN_DATA=`` read the data from the current folder; empty, each now means its default, as the XDG base
    directory specification and MLflow read theirs (``MLFLOW_TRACKING_URI=``: MLflow's own default store)."""
    from bearingtwin.config import REPO_ROOT, compose_config

    monkeypatch.setenv("HOME", "/home/someone")
    for name in ("BEARINGTWIN_CACHE", "XDG_CACHE_HOME", "BEARINGTWIN_DATA", "MLFLOW_TRACKING_URI", "MLFLOW_EXPERIMENT_NAME"):
        monkeypatch.setenv(name, "")
    cfg = compose_config("train", [])
    assert cfg.paths.cache_dir == "/home/someone/.cache/bearingtwin"
    assert cfg.paths.data_root == str(REPO_ROOT.parent / "shared" / "data")  # printed without a ".." in it
    assert (cfg.tracking.uri, cfg.tracking.experiment) == (f"sqlite:///{REPO_ROOT}/mlruns/mlflow.db", "bearingtwin")
    monkeypatch.setenv("XDG_CACHE_HOME", "/var/cache/someone")
    assert compose_config("train", []).paths.cache_dir == "/var/cache/someone/bearingtwin"


def test_bt_env_gives_text_like_oc_env_and_says_when_a_variable_has_no_default(monkeypatch):
    from omegaconf import OmegaConf

    import bearingtwin.config  # noqa: F401  (registers the resolver)

    monkeypatch.delenv("BT_UNSET", raising=False)
    cfg = OmegaConf.create({"n": "${bt_env:BT_UNSET,30}", "none": "${bt_env:BT_UNSET,null}", "bare": "${bt_env:BT_UNSET}"})
    assert cfg.n == "30" and cfg.none is None
    with pytest.raises(Exception, match="environment variable 'BT_UNSET' is not set"):
        cfg.bare
    monkeypatch.setenv("BT_UNSET", "sqlite:///a,b.db")
    assert cfg.n == "sqlite:///a,b.db" and cfg.bare == "sqlite:///a,b.db"


def test_under_hydra_job_chdir_inputs_and_a_sqlite_store_are_read_from_the_launch_folder(tmp_path):
    """What the user names relative to where they started stays there when the task runs in its run's folder; URIs
    of other kinds, home-relative and absolute paths, and what the run writes (out=) are left as given."""
    from hydra.core.hydra_config import HydraConfig
    from omegaconf import OmegaConf, open_dict

    from bearingtwin.config import compose_config, inputs_from_launch_folder

    def in_job(cfg):
        HydraConfig.instance().set_config(cfg)
        try:
            inputs_from_launch_folder(cfg)
        finally:
            HydraConfig.instance().cfg = None  # as outside a Hydra app, for the tests after this one
        return cfg

    def read_in_job(cfg) -> tuple:
        cfg = in_job(cfg)
        return cfg.path, cfg.labels, cfg.model, cfg.tracking.uri, cfg.out

    def composed(chdir: str, uri: str):
        cfg = compose_config("diagnose", ["model=runs:/abc/model", f"hydra.job.chdir={chdir}"], hydra_node=True)
        with open_dict(cfg):
            cfg.path, cfg.labels = "records/*.mat", "~/labels.csv"  # a glob, a home-relative file
            cfg.tracking.uri = uri
            cfg.hydra.runtime.cwd = str(tmp_path)
        return cfg

    given = ("records/*.mat", "~/labels.csv", "runs:/abc/model", "sqlite:///stores/team.db", "diagnosis")
    # Hydra's default: the task starts where the command did, and nothing changes.
    assert read_in_job(composed("false", "sqlite:///stores/team.db")) == given
    assert read_in_job(composed("true", "sqlite:///stores/team.db")) == (
        f"{tmp_path}/records/*.mat", "~/labels.csv", "runs:/abc/model", f"sqlite:///{tmp_path}/stores/team.db",
        "diagnosis")
    for uri in ("http://mlflow.example:5000", "databricks", "file:mlruns", "sqlite:////srv/team.db"):  # as given
        assert read_in_job(composed("true", uri))[3] == uri
    assert read_in_job(composed("true", "sqlite:///~/team.db"))[3] == f"sqlite:///{tmp_path}/~/team.db"  # as SQLite
    artifacts = composed("true", "sqlite:///stores/team.db")
    with open_dict(artifacts):
        artifacts.tracking.artifact_root = "mlflow-artifacts:/team"  # a server's artifact store, not a folder
    assert in_job(artifacts).tracking.artifact_root == "mlflow-artifacts:/team"
    unresolved = composed("true", "sqlite:///stores/team.db")
    with open_dict(unresolved):
        unresolved.labels = "${data_root_not_given}/labels.csv"  # left for the command to name, as without chdir
    in_job(unresolved)
    assert OmegaConf.to_container(unresolved, resolve=False)["labels"] == "${data_root_not_given}/labels.csv"
    assert unresolved.path == f"{tmp_path}/records/*.mat"
