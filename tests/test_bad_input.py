"""Every bad input found by probing the commands gives one line naming the file or field, exit 2.

Where the command-line layer matters (Hydra, the exit status) the command runs as a
subprocess; where only the message does, the function behind it is called, since every
entry point turns a BearingTwinError into that line and status 2 the same way.
"""

import importlib.util
import logging
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from processes import run_module

from bearingtwin.cli.report import main as report_main
from bearingtwin.config import CONF_DIR, REPO_ROOT, compose_config, data_root, load_bearing, refuse_unknown_keys
from bearingtwin.data.build import check_data_settings
from bearingtwin.data.formats import read_raw
from bearingtwin.data.recording import Recording
from bearingtwin.data.windows import cut_windows, split_indices
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.experiment import run_experiment
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal import order_track, peak_near
from bearingtwin.signal.entropy import mutual_information
from bearingtwin.signal.vmd import vmd
from bearingtwin.twin.compare import Comparator
from bearingtwin.twin.report import load_measurement, twin_for

CWRU = data_root() / "cwru"
RECORD_130 = CWRU / "12k_Drive_End_OR007@6_0_130.mat"


def command(module: str, *overrides: str, cwd: Path) -> subprocess.CompletedProcess:
    return run_module(f"bearingtwin.cli.{module}", *overrides, cwd=cwd, timeout=300)


def assert_one_line_exit_2(done: subprocess.CompletedProcess, *named: str) -> None:
    assert done.returncode == 2, done.stderr[-2000:]
    lines = [line for line in done.stderr.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr[-2000:]
    assert all(name in lines[0] for name in named), lines[0]


@pytest.mark.parametrize("module, overrides", [
    ("train", ["-m", "seed=0,1", "+simulator.foo=1"]),  # every job of a sweep, before any starts
    ("simulate", ["+simulator.foo=1"]),
    ("twin", ["measured.path=x.npy", "+unknown.key=1"]),
])
def test_an_unknown_added_key_is_refused(tmp_path, module, overrides):
    """(bearingtwin-train as a single run, and bearingtwin-inspect: tests/test_train_cli.py, tests/test_inspect_cli.py)"""
    sweep_dir = [f"hydra.sweep.dir={tmp_path}/multirun"] if "-m" in overrides else []
    done = command(module, *overrides, *sweep_dir, cwd=tmp_path)
    key = overrides[-1].split("=")[0].lstrip("+")
    assert_one_line_exit_2(done, key, "not a setting")
    assert not (tmp_path / "mlflow.db").exists() and not list(tmp_path.glob("*.npz"))


@pytest.mark.parametrize("module, overrides, named", [
    ("train", ["classifier=does_not_exist"], ["classifier=does_not_exist", "cnn_bilstm, sklearn, svm"]),
    ("train", ["not_a_key=3"], ["not_a_key", "not a setting"]),
    ("train", ["-m", "classifier=svm,does_not_exist"], ["classifier=does_not_exist"]),  # a sweep job's, before any starts
    ("train", ["-m", "seed=0,1", "trainer.not_a_key=3"], ["trainer.not_a_key", "not a setting"]),
    ("twin", ["measured.path=x.npy", "bearing=nope"], ["bearing=nope", "cwru_6205"]),
    ("twin", ["measured.path=x.npy", "measured.not_a_key=1"], ["measured.not_a_key", "not a setting"]),
    ("simulate", ["simulator.rpm=[1797"], ["simulator.rpm=[1797"]),
    # A file name Hydra reads only in quotes (letters outside ASCII, brackets): the line says how to quote it.
    ("diagnose", ["path=/tmp/泵_外圈.npz", "model=x"], ["""give the value in quotes: 'path="/tmp/泵_外圈.npz"'"""]),
    ("twin", ["measured.path=Pumpe 3 (außen).npz"], ["""'measured.path="Pumpe 3 (außen).npz"'"""]),
    ("diagnose", ["path=cwru/12k_*_[123]_*.mat", "model=x"], ["""'path="cwru/12k_*_[123]_*.mat"'"""]),  # a glob's range
    ("twin", ["measured.path=x.npy", "measured.unit=m/s^2"], ["""give the value in quotes: 'measured.unit="m/s^2"'"""]),
    ("inspect", ["--cfg", "job", "path=x.npy", "bearing=nope"], ["bearing=nope", "er16k"]),
    ("inspect", ["path=x.npy", "bearing=null"], ["bearing=null: a config group takes one of its options", "er16k"]),
    ("train", ["classifier=null"], ["classifier=null", "cnn_bilstm, sklearn, svm"]),  # Hydra's own ValueError, a traceback
    # A bearing by its number: Hydra reads 6205 as an int, its ValueError a traceback.
    ("twin", ["measured.path=x.npy", "bearing=6205"], ["bearing=6205: a config group takes the name of one of its "
                                                       "options (cwru_6203, cwru_6205, er16k, paper): bearing=cwru_6205?"]),
    ("diagnose", ["path=x.npy", "model=runs:/x/model", "bearing=6205.0"], ["bearing=6205.0: a config group takes"]),
    # A unit or scale for every file, refused once before any is read (each file had failed alike, a run open).
    ("diagnose", ["path=x.npy", "model=x", "unit=furlongs"], ["unit='furlongs' is no unit known here"]),
    ("diagnose", ["path=x.npy", "model=x", "scale=10"], ["scale=10 needs unit=<unit>"]),
    # A group given a map of settings: it had read as a setting only some other option has.
    ("train", ["classifier={name: svm, C: 2}"], ["a config group takes the name of one of its options",
                                                  "classifier=<option> classifier.<key>=<value>"]),
    # effects takes a list of options: the settings go under each option's name
    ("simulate", ["effects={noise: {snr_db: 5}}"], ["effects takes a list of its options' names",
                                                     "effects=[<option>,...] effects.<option>.<key>=<value>"]),
    # Hydra merges a list of a group's options into one config: a TypeError deep in the classifier, and a run left
    ("train", ["classifier=[svm,cnn_bilstm]"], ["classifier=[svm,cnn_bilstm]: choose one classifier", "-m classifier=a,b"]),
    ("train", ["--cfg", "job", "-m", "+sweep=table4"], ["-m and --cfg job go one at a time"]),  # Hydra's ValueError
    ("train", ["-m", "--info", "all", "seed=0,1"], ["-m and --info go one at a time"]),  # its traceback too
    ("train", ["-m", "seed=interval(0,1)"], ["seed=interval(0,1): interval() asks a sweeper that draws values"]),  # exit 1
    ("train", ["+classifier=svm"], ["+classifier=svm: classifier has a default choice", "choose it with classifier=svm"]),
    ("train", ["-cd", "my_conf"], ["--config-dir my_conf: no such folder"]),  # Hydra's three lines, exit 1
    # A flag for a setting, or a record given bare: argparse's usage over many lines, exit 2; Hydra's parse error.
    ("diagnose", ["--model", "models:/m@champion", "path=r.npz"], ["--model: not a flag of this command; settings are "
                                                                   "given as key=value: model=<value>"]),
    ("train", ["--seed=3"], ["--seed=3: not a flag of this command", "seed=3 (--help lists them)"]),
    ("inspect", ["recs/pump 3.mat"], ["recs/pump 3.mat: a file, folder or glob is given as path='recs/pump 3.mat'"]),
    ("diagnose", ["cwru/*.mat", "model=x"], ["cwru/*.mat: a file, folder or glob is given as path='cwru/*.mat'"]),
    # Hydra's folder for the run, or the sweep, that cannot be made: Hydra's traceback, exit 1 (a FAILED sweep run)
    ("train", ["hydra.run.dir=/dev/null/run"], ["hydra.run.dir=/dev/null/run: /dev/null is a file, not a folder"]),
    ("train", ["effects=[gear]"], ["effects=gear: no such effects config", "tones"]),  # Hydra lists no options for it
    ("train", ["seed=${foo}"], ["seed=${foo}: Interpolation key 'foo' not found"]),  # OmegaConf's traceback
    ("train", ["simulator.fs=-1"], ["simulator.fs=-1: the simulated data set runs the simulator at data.fs"]),  # ignored
    ("twin", ["measured.path=x.npy", "seed=${foo}"], ["seed=${foo}: Interpolation key 'foo' not found"]),
    ("train", ["tracking.experiment="], ["tracking.experiment is empty"]),  # MLflow's traceback (an unset variable)
    ("report", ["table4", "experiment="], ["experiment is empty"]),
    # A misspelt key, or the name another data source gives a setting: the declared one is named.
    ("train", ["trainer.max_epoch=3"], ["trainer.max_epoch: not a setting", "did you mean trainer.max_epochs?"]),
    ("train", ["data=hust", "data.windows_per_record=3"], ["did you mean data.samples_per_class?"]),
    ("simulate", ["simulator.rmp=100"], ["simulator.rmp: not a setting", "did you mean simulator.rpm?"]),  # swapped
    # A launcher's setting given to another launcher: the one that has it is named.
    ("train", ["-m", "seed=0,1", "hydra.launcher.n_jobs=2"], ["hydra.launcher.n_jobs: not a setting of this launcher; "
                                                              "launcher=joblib has it"]),
    ("train", ["-m", "seed=0,1", "launcher=joblib", "hydra.launcher.n_job=2"], ["--cfg hydra lists the launcher's"]),
    # A setting of some options of a group, given with one that lacks it: those that have it are named, not a typo.
    ("train", ["classifier=svm", "classifier.learning_rate=0.01"],
     ["classifier.learning_rate: only classifier=cnn_bilstm has it, not the classifier chosen"]),
    ("train", ["-m", "features=raw,sabo_vmd_minen", "features.vmd_params=global"],
     ["features.vmd_params: only features=sabo_vmd_minen and features=sabo_vmd_pemie have it"]),
])
def test_an_override_hydra_cannot_compose_is_one_line_and_exit_2(tmp_path, module, overrides, named):
    """Hydra alone would print the options and its search path over many lines, and exit 1."""
    sweep_dir = [f"hydra.sweep.dir={tmp_path}/multirun"] if "-m" in overrides else []
    done = command(module, *overrides, *sweep_dir, cwd=tmp_path)
    assert_one_line_exit_2(done, *named)
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert list(tmp_path.iterdir()) == []  # stopped before any output folder, store or run


def test_a_group_the_command_needs_removed_with_tilde_is_one_line_and_exit_2(tmp_path):
    """OmegaConf would end the run with a traceback when the task reads the group; no store is opened."""
    done = command("train", "~classifier", cwd=tmp_path)
    assert_one_line_exit_2(done, "classifier is needed, and ~classifier removed it")
    assert not list(tmp_path.rglob("*.db"))


def test_a_sweeps_config_in_one_run_says_its_parameters_are_not_swept(tmp_path):
    shown = command("train", "+sweep=table4", "--cfg", "job", cwd=tmp_path)  # showing the config: no warning
    assert shown.returncode == 0 and "warning" not in shown.stderr, shown.stderr
    from bearingtwin.config import refuse_bad_overrides

    import contextlib
    import io

    said = io.StringIO()
    with contextlib.redirect_stderr(said):
        refuse_bad_overrides("train", ["+sweep=table4", "seed=3"])  # the seed given: only the method is not swept
    assert said.getvalue().startswith("warning: one run, not a sweep: method take their defaults, not the sweep's "
                                      "values (method: sabo_pemie_cnn_bilstm,"), said.getvalue()


def test_hydra_flags_still_work_with_the_overrides_checked_first(tmp_path):
    shown = command("twin", "--cfg", "job", "measured.path=x.npy", "bearing=er16k", cwd=tmp_path)
    assert shown.returncode == 0 and "path: x.npy" in shown.stdout, shown.stderr
    helped = command("train", "--help", cwd=tmp_path)
    assert helped.returncode == 0 and "classifier: cnn_bilstm, sklearn, svm" in helped.stdout, helped.stderr


@pytest.mark.parametrize("module, usage, setting", [
    ("train", "Usage: bearingtwin-train [group=option ...]", "register_alias"),
    ("twin", "Usage: bearingtwin-twin measured.path=<file>", "operating_point.*"),
    ("diagnose", "Usage: bearingtwin-diagnose path=<file|folder|glob> model=<model URI>", "labels"),
    ("simulate", "Usage: bearingtwin-simulate fault=<normal|inner|ball|outer>", "simulator.*"),
])
def test_each_command_helps_with_its_own_usage_and_settings(tmp_path, module, usage, setting):
    helped = command(module, "--help", cwd=tmp_path)
    assert helped.returncode == 0 and usage in helped.stdout and setting in helped.stdout, helped.stdout[-2000:]
    assert "powered by Hydra" not in helped.stdout and "== Config ==" in helped.stdout
    assert list(tmp_path.iterdir()) == []  # help writes nothing
    if module == "simulate":  # it composes no classifier, data, sweep ...: its help lists no groups it refuses
        assert "classifier:" not in helped.stdout and "sweep:" not in helped.stdout
    if module == "train":  # the groups no default selects take a +
        assert "+experiment=sim2real, -m +sweep=table4" in helped.stdout


def test_an_unknown_report_setting_is_refused(capsys):
    with pytest.raises(SystemExit) as stop:
        report_main(["table4", "+unknown.key=1"])
    assert stop.value.code == 2 and "table4 does not take +unknown.key" in capsys.readouterr().err


def train_hydra_node(*overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("train", overrides=list(overrides), return_hydra_config=True).hydra


def test_a_key_added_into_a_free_form_map_is_accepted():
    """data.fs_by_record and data.twin.variants are declared empty: adding into them is their purpose."""
    refuse_unknown_keys(train_hydra_node("data=cwru", "+data.fs_by_record.97=48000"))
    refuse_unknown_keys(train_hydra_node("data=twin_to_real", "bearing=cwru_6205", "+data.twin.variants.spin_slip.jitter=[0.1]"))
    refuse_unknown_keys(train_hydra_node("+method=raw_cnn_bilstm", "++seed=3"))  # a group, and a declared key
    # An experiment fills data.twin.variants in (spin_slip); the map stays free-form beside it.
    refuse_unknown_keys(train_hydra_node("+experiment=sim2real", "+data.twin.variants.preload.interference_um=[null,20.0]"))
    refuse_unknown_keys(train_hydra_node("+experiment=sim2real", "+data.twin.variants.spin_slip.mean=[0.1]"))  # beside jitter
    with pytest.raises(BearingTwinError, match=r"data.twin.variant.preload.interference_um is not a setting of train"):
        refuse_unknown_keys(train_hydra_node("+experiment=sim2real", "+data.twin.variant.preload.interference_um=[20.0]"))
    with pytest.raises(BearingTwinError, match=r"data.twin.duraton is not a setting of train"):
        refuse_unknown_keys(train_hydra_node("+experiment=sim2real", "+data.twin.duraton=2.0"))
    with pytest.raises(BearingTwinError, match=r"\+data.fs_by_record.97=48000: data.fs_by_record.97 is not a setting of train"):
        refuse_unknown_keys(train_hydra_node("+data.fs_by_record.97=48000"))  # simulated data has no such map


def test_too_few_windows_per_class_for_a_split(tmp_path):
    cfg = compose_config("train", ["data.samples_per_class=1", "data.duration=0.3", "classifier=svm", "features=raw",
                                   f"paths.cache_dir={tmp_path}"])
    with pytest.raises(BearingTwinError, match="1 in the smallest class.*raise data.samples_per_class"):
        run_experiment(cfg, root_dir=str(tmp_path))
    labels = np.repeat(np.arange(4), 2)  # data.samples_per_class=2: 8 windows, 2 test windows for 4 classes
    with pytest.raises(BearingTwinError, match="2 in the smallest class.*raise data.samples_per_class"):
        split_indices(labels, labels, np.zeros(8), np.full(4, 100), 10, method="random")


@pytest.mark.parametrize("overrides, named", [
    (["data.split=blok"], "data.split='blok'"),
    (["data=files", "data.root=.", "data.windows_per_record=0"], "data.windows_per_record"),
    (["data.samples_per_class=2"], "too few windows for a stratified split: 8 windows (2 in the smallest class)"),
    # A bad value in a swept list: refused before the sweep starts, not a FAILED run for each of its jobs.
    (["-m", "seed=0,1,x"], "seed must be a non-negative integer, got 'x'"),
    (["-m", "seed=0,1", "data.split=random,blok"], "data.split='blok'"),
])
def test_a_bad_data_value_is_refused_before_a_run_is_opened(tmp_path, overrides, named):
    store = f"sqlite:///{tmp_path}/mlflow.db"
    sweep_dir = [f"hydra.sweep.dir={tmp_path}/multirun"] if "-m" in overrides else []
    done = command("train", *overrides, "classifier=svm", f"tracking.uri={store}", f"paths.cache_dir={tmp_path}",
                   *sweep_dir, cwd=tmp_path)
    assert_one_line_exit_2(done, named)
    assert not (tmp_path / "mlflow.db").exists()  # no store opened, so no FAILED run left in it


@pytest.mark.parametrize("overrides, named", [
    (["data.duration=0"], "data.duration"),
    (["data.duration=0.1"], "data.duration=0.1 s at data.fs=10000 Hz gives 1000 samples a state, shorter than one "
                            "window of data.window_length=2048: give data.duration=0.2048 or more"),
    # Counted as the simulator keeps them (round(1023.6) = 1024, one short); the duration suggested gives 1026.
    (["data.fs=12000", "data.window_length=1025", "data.duration=0.0853"], "give data.duration=0.0855 or more"),
    (["data.train_fraction=1.5"], "data.train_fraction"),
    (["data=cwru", "data.samples_per_class=true"], "data.samples_per_class"),
    (["data=hust", "data.split=none"], "data.split='none'"),
    (["data.split=record"], "data.split=record needs two records or more of each state; the simulated data set has one"),
    (["data=hust", "data.channel=speed"], "data.channel='speed' is not a HUST accelerometer axis"),
    (["data=hust", "data.condition=65Hz"], "data.condition='65Hz' is not a HUST condition (without Hz"),
    (["data=hust", "data.condition=[60,65]"], "data.condition=[60, 65] is not a HUST condition"),
    (["data=hust", "data.classes.inner=C"], "data.classes.inner='C' names C_65Hz.xls, whose name states inner and outer"),
    (["data=hust", "data.classes.ball=0.5X_O"], "data.classes.ball='0.5X_O' names 0.5X_O_65Hz.xls, whose name states outer"),
    (["data=hust", f"data.root={Path(__file__)}"], "is a file; point it at the folder of the HUST files"),
    (["data=files", "data.root=.", "data.rpm=-3"], "data.rpm"),
    (["+experiment=sim2real", "data.test.windows_per_record=0"], "data.test.windows_per_record"),
    (["data=twin_to_real"], "bearing=cwru_6205"),
    (["data.source=tape"], "data.source='tape'"),
])
def test_every_data_source_checks_its_values_from_the_config_alone(overrides, named):
    cfg = compose_config("train", overrides)
    with pytest.raises(BearingTwinError, match=re.escape(named)):
        check_data_settings(cfg)


@pytest.mark.parametrize("source", [[], ["data=cwru"], ["data=hust"], ["data=files", "data.root=."],
                                    ["+experiment=sim2real"]])
def test_each_data_sources_defaults_pass_its_check(source):
    check_data_settings(compose_config("train", source))


GEOMETRY_6308 = "name: my6308\nball_diameter_mm: 15.081\npitch_diameter_mm: 65.0\nn_balls: 8\nouter_diameter_mm: 90.0\ninner_diameter_mm: 40.0\n"


@pytest.mark.parametrize("text, named", [
    ("defaults: [paper]\n" + GEOMETRY_6308.replace("ball_diameter_mm", "ball_diam_mm"),
     "bearing=my6308: ball_diam_mm is not a bearing setting"),
    (GEOMETRY_6308, "bearing=my6308: contact_angle_deg is missing; start the file with 'defaults: [paper]'"),
    ("defaults: [paper]\n" + GEOMETRY_6308 + "n_balls: 8: 9\n", "my6308.yaml, line 8: not valid YAML"),
    ("defaults: [paper]\n" + GEOMETRY_6308.replace("n_balls: 8\n", ""),
     "my6308.yaml: gives no n_balls; a bearing's file states its sizes"),
])
def test_a_bearing_file_of_ones_own_that_the_twin_cannot_read_as_written_is_one_line(tmp_path, text, named):
    """A misspelt key would leave Table 1's value in its place without a word; a file without the defaults lacks
    the masses (a KeyError deep in the simulator before); a file that is no YAML (a traceback of 89 lines); a size left
    out had been Table 1's, its 9 balls in place of 8 (every defect frequency off, exit 0)."""
    (tmp_path / "conf" / "bearing").mkdir(parents=True)
    (tmp_path / "conf" / "bearing" / "my6308.yaml").write_text(text)
    assert_one_line_exit_2(command("simulate", f"hydra.searchpath=[file://{tmp_path / 'conf'}]", "bearing=my6308",
                                   f"out={tmp_path}/x.npz", cwd=tmp_path), named)


def test_a_bearing_file_may_take_its_sizes_from_another_bearings_file_or_the_command_line(tmp_path):
    """Only Table 1's sizes standing in for a bearing's own are refused: a 6205 of C3 play inherits the 6205's, and
    a size left out of the file may be given as bearing.<size>=."""
    from bearingtwin.config import refuse_bad_overrides

    (tmp_path / "bearing").mkdir()
    (tmp_path / "bearing" / "my6205c3.yaml").write_text("defaults: [cwru_6205, _self_]\nname: my6205c3\nclearance_mm: 0.012\n")
    (tmp_path / "bearing" / "my6308.yaml").write_text("defaults: [paper]\n" + GEOMETRY_6308.replace("n_balls: 8\n", ""))
    search_path = f"hydra.searchpath=[file://{tmp_path}]"
    refuse_bad_overrides("simulate", [search_path, "bearing=my6205c3"])
    refuse_bad_overrides("simulate", [search_path, "bearing=my6308", "bearing.n_balls=8"])
    with pytest.raises(BearingTwinError, match="my6308.yaml: gives no n_balls"):
        refuse_bad_overrides("simulate", [search_path, "bearing=my6308"])


@pytest.mark.parametrize("overrides, named", [
    (["bearing=conf/bearing/my6308.yaml"], "a config group takes the name of a config, not a file"),
    (["hydra.searchpath=[file:///no/such/folder]", "bearing=my6308"], "file:///no/such/folder is not a folder"),
    (["hydra.searchpath=[file://no/such/folder]", "bearing=my6308"], "an absolute path is file:///<path>, three slashes"),
])
def test_a_bearing_of_ones_own_pointed_at_wrongly_is_named_so(tmp_path, overrides, named):
    assert_one_line_exit_2(command("simulate", *overrides, f"out={tmp_path}/x.npz", cwd=tmp_path), named)


def test_a_search_path_given_as_the_bearing_folder_itself_names_the_folder_meant(tmp_path):
    """``<folder>/bearing`` where ``<folder>`` is meant: Hydra found no bearing=my6308 and listed the project's."""
    (tmp_path / "conf" / "bearing").mkdir(parents=True)
    (tmp_path / "conf" / "bearing" / "my6308.yaml").write_text("defaults: [paper]\n" + GEOMETRY_6308)
    assert_one_line_exit_2(command("simulate", f"hydra.searchpath=[file://{tmp_path}/conf/bearing]", "bearing=my6308",
                                   f"out={tmp_path}/x.npz", cwd=tmp_path),
                           f"is a bearing folder itself; give the folder that holds it, file://{tmp_path}/conf")


@pytest.mark.parametrize("name", sorted(path.stem for path in Path(CONF_DIR, "bearing").glob("*.yaml")))
def test_every_shipped_bearing_holds_the_bearing_settings(name):
    from bearingtwin.config import bearing_config

    assert bearing_config(name)["name"] == name


@pytest.mark.skipif(importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None,
                    reason='the ray extra is not installed (pip install -c requirements.lock -e ".[ray]")')
def test_a_ray_address_no_cluster_answers_at_is_refused_at_once():
    """Ray retries such an address for ever, printing a warning every 5 s."""
    from omegaconf import OmegaConf
    from processes import free_loopback_port

    from bearingtwin.tracking.lifecycle import start_ray_keeping_signals

    port = free_loopback_port()
    with pytest.raises(BearingTwinError, match=rf"address=127.0.0.1:{port}: no Ray cluster answers there"):
        start_ray_keeping_signals(OmegaConf.create({"address": f"127.0.0.1:{port}"}))


def test_a_missing_mandatory_value_is_named(tmp_path):
    assert_one_line_exit_2(command("twin", cwd=tmp_path), "measured.path is missing")


def test_a_non_finite_simulator_setting(tmp_path):
    assert_one_line_exit_2(command("simulate", "simulator.duration=inf", f"out={tmp_path}/x.npz", cwd=tmp_path),
                           "simulator.duration", "finite")


def twin_config(*overrides):
    return compose_config("twin", list(overrides))


def test_measurement_files_that_are_not_measurements(tmp_path, caplog):
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(BearingTwinError, match="binary.csv: not a text file"):
        read_raw(binary)
    with pytest.raises(BearingTwinError, match=f"{tmp_path}: is a folder"):
        read_raw(tmp_path)
    huge = tmp_path / "huge.npy"
    np.save(huge, np.full(4000, 1e300) * np.sign(np.sin(np.arange(4000))))
    cfg = twin_config(f"measured.path={huge}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer")
    with pytest.raises(BearingTwinError, match="huge.npy: channel 0's largest magnitude, 1e\\+300, lies outside"):
        load_measurement(cfg.measured)
    channels = tmp_path / "two.npy"
    np.save(channels, np.ones((2, 4000)))
    cfg = twin_config(f"measured.path={channels}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer")
    with pytest.raises(BearingTwinError, match=r"two.npy: holds channels 0, 1; choose one with measured.channel=<name>"):
        load_measurement(cfg.measured)
    clipped = tmp_path / "clipped.npy"  # read, and its clipping said: the library's `clipping` may explain it
    x = np.sin(2 * np.pi * 157.0 * np.arange(24000) / 12000.0) + 0.3 * np.random.default_rng(0).standard_normal(24000)
    np.save(clipped, np.clip(x, -0.8, 0.8))
    cfg = twin_config(f"measured.path={clipped}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                      "measured.check_fs=false")
    with caplog.at_level(logging.WARNING):
        load_measurement(cfg.measured)
    assert "the sensor or the converter clipped" in caplog.text
    flat = tmp_path / "flat.npy"
    np.save(flat, np.zeros(24000))
    cfg = twin_config(f"measured.path={flat}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer")
    with pytest.raises(BearingTwinError, match=r"flat.npy: every sample is 0: no vibration recorded"):
        load_measurement(cfg.measured)
    short = tmp_path / "short.npy"
    np.save(short, np.sin(np.arange(1000)))
    recording = Recording(np.load(short), 12000.0, 1797.0, "outer", source=str(short))
    with pytest.raises(BearingTwinError, match=rf"^{short}: a signal of 0.083 s is shorter than one comparison segment"):
        Comparator(recording, BearingGeometry.from_config(twin_config().bearing))
    # A dropout as long as a statistics window (0.1 s) would spoil the comparison, and is refused with its place;
    # a few samples held (a clipped peak, a coarse converter) are not.
    rng = np.random.default_rng(0)
    dropout = rng.normal(size=24000)
    dropout[6000:8400] = dropout[6000]
    recording = Recording(dropout, 12000.0, 1797.0, "outer", source="dropout.npy")
    geometry = BearingGeometry.from_config(twin_config().bearing)
    with pytest.raises(BearingTwinError, match=r"^dropout.npy: samples from 0.5 s to 0.7 s are all .*0.1 s statistics"):
        Comparator(recording, geometry)
    dropout[6000:8400] = rng.normal(size=2400)
    dropout[6000:6024] = 0.0
    Comparator(Recording(dropout, 12000.0, 1797.0, "outer", source="dropout.npy"), geometry)


def test_what_a_measurement_leaves_unsaid_is_asked_for_at_once_or_read_from_a_labels_table_beside_it(tmp_path):
    t = np.arange(4 * 12000) / 12000.0
    path = tmp_path / "outer_a.npy"
    np.save(path, sum(np.sin(2 * np.pi * k * 29.95 * t) / k for k in range(1, 8))
            + np.random.default_rng(0).standard_normal(t.size))
    with pytest.raises(BearingTwinError) as error:  # one message for all three, not one run per missing value
        load_measurement(twin_config(f"measured.path={path}").measured)
    assert str(error.value) == (f"{path}: the file does not state its sampling rate, speed, bearing state; give "
                                "measured.fs=<Hz> measured.rpm=<rev/min> measured.fault=<normal|inner|ball|outer> "
                                "(or a row for it in a labels.csv beside it: record,state,rpm,fs)")
    with pytest.raises(BearingTwinError, match=r"^measured.fault='outr' is not a bearing state; choose one of"):
        load_measurement(twin_config(f"measured.path={path}", "measured.fs=12000", "measured.rpm=1797",
                                     "measured.fault=outr").measured)
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.npy,outer,1797,12000\n")
    recording = load_measurement(twin_config(f"measured.path={path}").measured)
    assert (recording.fault, recording.rpm, recording.fs) == ("outer", 1797.0, 12000.0)
    given = load_measurement(twin_config(f"measured.path={path}", "measured.rpm=1800").measured)
    assert given.rpm == 1800.0  # a setting given wins over the table
    # A row is the file's by its name; by its stem only where the row gives no suffix (outer_a.mat is another file).
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.mat,inner,1750,48000\nouter_a,outer,1797,12000\n")
    assert load_measurement(twin_config(f"measured.path={path}").measured).fault == "outer"
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.mat,inner,1750,48000\n")
    with pytest.raises(BearingTwinError, match="does not state its sampling rate, speed, bearing state"):
        load_measurement(twin_config(f"measured.path={path}").measured)
    # Every fact given: the table is not read (two files of one stem in it are training's concern, not this one's).
    (tmp_path / "labels.csv").write_text("record,state\nouter_a.npy,outer\nouter_a.wav,outer\n")
    assert load_measurement(twin_config(f"measured.path={path}", "measured.fs=12000", "measured.rpm=1797",
                                        "measured.fault=outer").measured).fault == "outer"
    # Another file's bad row is that file's concern; this file's own is refused naming its line and field.
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.npy,outer,1797,12000\nb.npy,outter,1797,12000\n"
                                         "c.npy,normal,-1797,12000\n")
    assert load_measurement(twin_config(f"measured.path={path}").measured).rpm == 1797.0
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.npy,outer,1797,12k\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: fs='12k' must be a positive number of Hz"):
        load_measurement(twin_config(f"measured.path={path}").measured)
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.npy,outer,1797,12000\n")
    # A rate the shaft series contradicts is refused naming the ways out (the speed the row gave may be the wrong one).
    with pytest.raises(BearingTwinError, match=r"give the true rate with measured.fs=<Hz> \(or the true speed with "
                                               r"measured.rpm=<rev/min>\), or measured.check_fs=false "
                                               r"if both 24000 Hz and 1797 rpm are true$"):
        load_measurement(twin_config(f"measured.path={path}", "measured.fs=24000").measured)


def test_a_twin_of_no_duration(tmp_path):
    path = tmp_path / "x.npy"
    np.save(path, np.sin(np.arange(12000)))
    cfg = twin_config(f"measured.path={path}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                      "twin.duration=0")
    with pytest.raises(BearingTwinError, match="twin.duration must be a positive, finite number of seconds, got 0"):
        twin_for(load_measurement(cfg.measured), cfg)
    # Too short for a comparison: named as the twin's duration before the calibration's budget runs, not as a
    # comparison setting after every trial was refused.
    short = twin_config(f"measured.path={path}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                        "twin.duration=0.3")
    with pytest.raises(BearingTwinError, match=r"^twin.duration=0.3 s is shorter than one comparison segment "
                                               r"\(compare.envelope_segment_s=0.5 s\): give twin.duration of at least 0.5 s$"):
        twin_for(load_measurement(short.measured), short)


@pytest.mark.skipif(not RECORD_130.is_file(), reason=f"CWRU record 130 not found in {CWRU}")
@pytest.mark.parametrize("fs", [48000, 2000])
def test_the_twin_refuses_a_sampling_rate_the_record_contradicts(fs):
    cfg = twin_config(f"measured.path={RECORD_130}", f"measured.fs={fs}", "measured.channel=DE", "bearing=cwru_6205")
    # the file's name (12k_) and its shaft line, two witnesses against the rate typed
    with pytest.raises(BearingTwinError, match=f"OR007@6_0_130.mat: measured.fs={fs} Hz given, where its name states "
                                               f"12000 Hz, and the shaft line stands where it belongs at 12000 Hz, not "
                                               f"at {fs} Hz: give this file no rate"):
        load_measurement(cfg.measured, load_bearing("cwru_6205"))
    load_measurement(twin_config(f"measured.path={RECORD_130}", f"measured.fs={fs}", "measured.channel=DE",
                                 "measured.check_fs=false").measured)  # the user can overrule the check


@pytest.mark.skipif(not (CWRU / "12k_Drive_End_B007_0_118.mat").is_file(), reason=f"CWRU record 118 not found in {CWRU}")
def test_the_twin_reads_a_channel_at_its_files_rate_where_another_channel_shows_the_shaft():
    """Record 118's fan-end channel shows a stronger series than the shaft's, and faint ball lines: the drive
    end's channel in the same file witnesses the 12 kHz its name declares."""
    cfg = twin_config(f"measured.path={CWRU / '12k_Drive_End_B007_0_118.mat'}", "measured.channel=FE", "bearing=cwru_6205")
    recording = load_measurement(cfg.measured, load_bearing("cwru_6205"))
    assert (recording.channel, recording.fs) == ("FE", 12000)


def test_a_registry_alias_in_a_sweep_is_refused_before_any_job(tmp_path):
    """Each job would move the alias to its own model: it would end on whichever job finished last."""
    done = command("train", "-m", "seed=0,1", "register=diagnosis", "register_alias=champion",
                   f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"hydra.sweep.dir={tmp_path}/multirun", cwd=tmp_path)
    assert_one_line_exit_2(done, "register_alias=champion in a sweep of 2 jobs", "register_alias=null")
    assert not (tmp_path / "mlflow.db").exists()


def test_a_bad_model_name_in_a_sweep_is_refused_before_any_job(tmp_path):
    """As a single run refuses it: one line naming register=, exit 2, no parent run opened."""
    done = command("train", "-m", "seed=0,1", "register=bad/name", "register_alias=null",
                   f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"hydra.sweep.dir={tmp_path}/multirun", cwd=tmp_path)
    assert_one_line_exit_2(done, "register=bad/name")
    assert not (tmp_path / "mlflow.db").exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where no file can be made")
def test_an_output_folder_nothing_can_be_written_in_is_refused_before_any_work(tmp_path):
    from bearingtwin.config import output_folder

    with pytest.raises(BearingTwinError, match=r"^out=/proc/nope/deeper: nothing can be written in /proc \("):
        output_folder("/proc/nope/deeper")
    assert output_folder(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # checked, not made: a refused run leaves nothing behind
    done = run_module("bearingtwin.cli.simulate", "simulator.duration=0.2", "out=/proc/nope/x.npz", cwd=tmp_path)
    assert done.returncode == 2 and "out=/proc/nope: nothing can be written in /proc" in done.stderr, done.stderr


def test_an_empty_output_folder_is_refused_not_read_as_the_current_one(tmp_path):
    from bearingtwin.config import output_folder

    for empty in ("", "  "):
        with pytest.raises(BearingTwinError, match=rf"^out must name a folder, got {empty!r}$"):
            output_folder(empty)
    done = run_module("bearingtwin.cli.diagnose", "path=x.npz", "model=models:/any/1", "out=", cwd=tmp_path)
    assert done.returncode == 2 and "out must name a folder, got ''" in done.stderr, done.stderr
    assert not any(tmp_path.iterdir())


COMMANDS = sorted(target.split(":")[0].rpartition(".")[2] for target in
                  tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]["scripts"].values())
"""Every command the package installs (pyproject.toml's scripts), by module name under bearingtwin.cli."""


def test_the_commands_are_read_from_the_projects_scripts():
    assert {"train", "diagnose", "twin", "simulate", "inspect", "report", "cache"} <= set(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_installed_command_helps_with_its_usage(tmp_path, command):
    """A help text is a template Hydra fills in (``$APP_NAME``): a ``$`` of its own prose had made one a
    KeyError traceback."""
    helped = run_module(f"bearingtwin.cli.{command}", "--help", cwd=tmp_path)
    assert helped.returncode == 0, helped.stderr[-2000:]
    assert f"usage: bearingtwin-{command}" in helped.stdout.lower(), helped.stdout[-2000:]  # argparse's or Hydra's
    assert "Traceback" not in helped.stderr and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command, flag", [(command, "--help") for command in COMMANDS]
                         + [("train", "--cfg job"), ("simulate", "--info"),  # Hydra prints these through logging
                            ("train", "--cfg=job"), ("twin", "--info=config")])  # spelt as its parser reads them too
def test_help_into_a_pipe_its_reader_closed_ends_without_a_traceback(command, flag):
    """``bearingtwin-diagnose --help | head -3``: the reader leaves before the help is written (here, before it
    starts: a pipe whose reading end is closed), and the command ends quietly, with no BrokenPipeError traceback."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        done = subprocess.run([sys.executable, "-m", f"bearingtwin.cli.{command}", *flag.split()], stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write_end)
    assert "Traceback" not in done.stderr and "BrokenPipeError" not in done.stderr, done.stderr[-2000:]
    assert "Logging error" not in done.stderr, done.stderr[-2000:]


def test_a_sweeps_folder_that_cannot_be_made_is_refused_before_it_starts():
    """Hydra's own refusal came once the sweep had started: a traceback, exit 1, and a FAILED sweep run."""
    from bearingtwin.config import refuse_bad_overrides

    with pytest.raises(BearingTwinError, match=r"^hydra.sweep.dir=/dev/null/sweep: /dev/null is a file, not a folder$"):
        refuse_bad_overrides("train", ["-m", "seed=0,1", "hydra.sweep.dir=/dev/null/sweep"])
    # A folder named by what Hydra sets as the run starts is left for Hydra to make (it had been refused).
    refuse_bad_overrides("train", ["classifier=svm", "hydra.run.dir=outputs/${hydra:runtime.choices.classifier}", "--cfg",
                                   "job"])
    refuse_bad_overrides("train", ["classifier=svm", "hydra.run.dir=/tmp/${hydra:runtime.choices.classifier}/run"])



@pytest.mark.parametrize("call, said", [
    (lambda x: vmd(x, None, 2000.0), "k must be a positive integer, got None"),
    (lambda x: vmd(x, 3, "2000"), "alpha must be a finite number, got '2000'"),
    (lambda x: mutual_information(x, x, bins=None), "bins must be a positive integer"),
    (lambda x: cut_windows(x, 2048.5, 5), "window_length must be a positive integer, got 2048.5"),
    (lambda x: order_track(x, 12000.0, None), "profile must be a SpeedProfile"),
    (lambda x: peak_near(np.arange(10.0), np.ones(10), 5.0, "2"), "tolerance_hz must be a non-negative number, got '2'"),
])
def test_a_signal_function_given_a_wrong_type_names_the_argument(call, said):
    """From Python, a None, a text number or a fractional length had ended in a TypeError or IndexError deep inside."""
    with pytest.raises(BearingTwinError) as error:
        call(np.random.default_rng(0).standard_normal(12000))
    assert said in str(error.value)
