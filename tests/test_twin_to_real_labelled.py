"""Train on the twin, test on another rig's own records: ``data=twin_to_real`` with a labels table.

The records are the independent test rig's (``bearingtwin.testrig``: no code shared with the twin),
written as a user's logger would write them (``.npy`` arrays whose rate and speed only the labels
table states), so nothing here needs the CWRU files. The calibration reports are small
``twin_report.json`` files in the format ``bearingtwin-twin`` writes.
"""

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from processes import run_module

from bearingtwin.config import CONF_DIR, REPO_ROOT, data_root
from bearingtwin.data.build import build_dataset, input_digest
from bearingtwin.data.twin_to_real import TWIN_PREFIX, check_protocol, merged_calibration
from bearingtwin.errors import BearingTwinError
from bearingtwin.testrig import RigOperatingPoint, simulate_rig

FS = 12000.0
# Each record: file, state, speed (rev/min). The rig's healthy and outer-race records at the first
# speed calibrate the twin; every other record is a test record.
RECORDS = [("healthy_a.npy", "normal", 1797.0), ("outer_a.npy", "outer", 1797.0),
           ("inner_b.npy", "inner", 1750.0), ("ball_b.npy", "ball", 1750.0), ("outer_b.npy", "outer", 1750.0),
           ("healthy_b.npy", "normal", 1750.0)]
SMALL = ["data.window_length=1024", "data.twin.duration=0.5", "data.twin.windows_per_record=2",
         "data.test.windows_per_record=3", "data.calibration.validation_windows_per_record=2",
         "data.calibration.healthy.step=0"]


@pytest.fixture(scope="module")
def rig_folder(tmp_path_factory):
    """The rig's records as .npy arrays (in g) and a labels table giving each one's state, speed and rate."""
    folder = tmp_path_factory.mktemp("rig")
    rows = []
    for seed, (name, state, rpm) in enumerate(RECORDS):
        point = RigOperatingPoint(rpm=rpm, fs=FS, duration_s=1.0, unit="g")
        np.save(folder / name, simulate_rig(state, point, seed=seed))
        rows.append(f"{name},{state},{rpm:g},{FS:g}")
    (folder / "labels.csv").write_text("record,state,rpm,fs\n" + "\n".join(rows) + "\n")
    return folder


def labelled(folder: Path, report: Path, *extra: str) -> list[str]:
    return ["data=twin_to_real", "bearing=cwru_6205", f"data.root={folder}", f"data.labels={folder / 'labels.csv'}",
            "data.channel=null", "data.calibration.records=[healthy_a,outer_a.npy]", "data.calibration.record=outer_a.npy",
            "data.calibration.healthy.record=healthy_a", f"data.calibration.report={report}", "data.calibration.step=1",
            *SMALL, *extra]


def compose_train(overrides):
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        return compose("train", overrides=overrides)


def test_the_named_records_calibrate_and_every_other_labelled_record_is_tested(rig_folder, report_path, tmp_path):
    cfg = compose_train(labelled(rig_folder, report_path, f"paths.cache_dir={tmp_path}"))
    calibration, tests = check_protocol(cfg.data)
    assert [p.name for p in calibration] == ["healthy_a.npy", "outer_a.npy"]
    assert [p.name for p in tests] == ["inner_b.npy", "ball_b.npy", "outer_b.npy", "healthy_b.npy"]
    dataset = build_dataset(cfg)
    train, test = dataset.fixed_split
    # Training is all twin; the test and validation windows are the rig's own records, with their labels.
    assert all(dataset.records[i].startswith(TWIN_PREFIX) for i in set(dataset.record_ids[train]))
    assert [Path(dataset.records[i]).name for i in dict.fromkeys(dataset.record_ids[test])] == [p.name for p in tests]
    assert [dataset.class_names[label] for label in dict.fromkeys(dataset.labels[test])] == ["inner", "ball", "outer", "normal"]
    assert [Path(dataset.records[i]).name for i in dict.fromkeys(dataset.record_ids[dataset.validation])] == [
        "healthy_a.npy", "outer_a.npy"]
    # The twin runs at the labelled speeds of all six records, and each window keeps its record's speed.
    twin_rpms = {float(r.split("@")[1].split("rpm")[0]) for r in dataset.records if r.startswith(TWIN_PREFIX)}
    assert twin_rpms == {1797.0, 1750.0}
    assert set(dataset.window_rpms[test]) == {1750.0}
    # The labels table is one of the run's input files: a corrected state is another run.
    before = input_digest(cfg)
    table = rig_folder / "labels.csv"
    text = table.read_text()
    try:
        table.write_text(text.replace("ball_b.npy,ball", "ball_b.npy,inner"))
        assert input_digest(cfg) != before
    finally:
        table.write_text(text)


@pytest.mark.parametrize(("override", "message"), [
    ("data.calibration.records=[healthy_a,inner_b]", r"data\.calibration\.records: inner_b is labelled inner; the twin "
                                                     r"may be fitted only to normal or outer records"),
    ("data.calibration.records=[healthy_a,outer_z]", r"data\.calibration\.records: outer_z is no record of the labels "
                                                     r"table \(healthy_a\.npy, outer_a\.npy"),
    ("data.twin.classes=[normal,inner,outer]", r"ball_b\.npy: labelled ball, a state the twin does not simulate"),
    ("data.fs=25600", r"inner_b\.npy: recorded at 12000 Hz, where the twin simulates at data\.fs=25600 Hz; set data\.fs=12000"),
    ("data.calibration.records=null", r"data\.calibration\.records=None: give a list of record names"),
    ("data.calibration.records=[healthy_a,outer_a,healthy_a]", r"data\.calibration\.records=\[.*\]: a record named twice"),
    ("data.calibration.step=5", r"data\.calibration\.step=5: \S+twin_report\.json has steps 0\.\.1 \(or all\)"),
    ("data.calibration.healthy.step=3", r"data\.calibration\.healthy\.step=3: \S+twin_report\.json has steps 0\.\.1"),
    ("data.calibration.records=healthy_a", r"data\.calibration\.records='healthy_a': give a list of record names"),
])
def test_a_labelled_protocol_that_cannot_hold_is_refused_naming_the_field(rig_folder, report_path, tmp_path, override,
                                                                          message):
    with pytest.raises(BearingTwinError, match=message):
        build_dataset(compose_train(labelled(rig_folder, report_path, f"paths.cache_dir={tmp_path}",
                                             f"data.calibration.healthy.report={report_path}", override)))


def test_step_all_keeps_every_effect_a_report_added(report_path, tmp_path):
    calibration = {"report": str(report_path), "step": "all", "records": ["healthy_a", "outer_a"],
                   "healthy": {"record": "healthy_a", "report": str(report_path), "step": 0}}
    assert merged_calibration(calibration) == merged_calibration({**calibration, "step": 1})
    assert list(merged_calibration(calibration)[1]) == ["noise"]
    # Noise on both records: with step all it is the healthy record's (the sensor's floor); a number must choose.
    healthy = tmp_path / "healthy.json"
    healthy.write_text(json.dumps({"steps": [{"effects": [], "params": {}},
                                             {"effects": ["noise"], "params": {"noise": {"snr_db": -3.0}}}]}))
    both = {**calibration, "healthy": {"record": "normal_0_97", "report": str(healthy), "step": "all"},
            "records": ["normal_0_97"]}
    assert merged_calibration(both)[1] == {"noise": {"snr_db": -3.0}}
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.healthy: effect noise was found on both calibration records"):
        merged_calibration({**both, "step": 1})


def test_records_in_subfolders_are_named_by_their_path_in_the_table(tmp_path, report_path):
    """Two rigs' runs of one name in two subfolders: the name alone is ambiguous, the table's path is not."""
    for sub in ("rig_a", "rig_b"):
        (tmp_path / sub).mkdir()
        for seed, (name, state, rpm) in enumerate(RECORDS[:3]):
            np.save(tmp_path / sub / name, simulate_rig(state, RigOperatingPoint(rpm=rpm, fs=FS, duration_s=1.0), seed=seed))
    table = tmp_path / "labels.csv"
    table.write_text("record,state,rpm,fs\n" + "".join(f"{sub}/{name},{state},{rpm:g},{FS:g}\n" for sub in ("rig_a", "rig_b")
                                                       for name, state, rpm in RECORDS[:3]))
    overrides = [*labelled(tmp_path, report_path), f"data.labels={table}"]
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.records: healthy_a is more than one record of the "
                                               r"labels table \(rig_a/healthy_a\.npy, rig_b/healthy_a\.npy\); name it by its path"):
        check_protocol(compose_train(overrides).data)
    cfg = compose_train([*overrides, "data.calibration.records=[rig_a/healthy_a,rig_a/outer_a.npy]",
                         "data.calibration.record=rig_a/outer_a", "data.calibration.healthy.record=rig_a/healthy_a.npy"])
    calibration, tests = check_protocol(cfg.data)
    assert [p.relative_to(tmp_path).as_posix() for p in calibration] == ["rig_a/healthy_a.npy", "rig_a/outer_a.npy"]
    assert [p.relative_to(tmp_path).as_posix() for p in tests] == ["rig_a/inner_b.npy", "rig_b/healthy_a.npy",
                                                                    "rig_b/outer_a.npy", "rig_b/inner_b.npy"]


def test_the_data_key_follows_what_a_labelled_record_holds(rig_folder, report_path, tmp_path):
    """Cached features are keyed by the data: a calibration record written over, or labelled otherwise, is other data
    (two rigs' files of one name and length are not one dataset)."""
    import shutil

    folder = tmp_path / "rig"
    shutil.copytree(rig_folder, folder)
    cfg = compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}"))
    before = build_dataset(cfg).key
    original = np.load(folder / "healthy_a.npy")
    np.save(folder / "healthy_a.npy", original[::-1].copy())  # the same length, other samples
    assert build_dataset(cfg).key != before
    np.save(folder / "healthy_a.npy", original)
    assert build_dataset(cfg).key == before


def test_another_rigs_model_is_not_registered_as_the_cwru_protocols(rig_folder, report_path):
    from bearingtwin.tracking.mlflow_logging import check_registration

    cfg = compose_train(["+experiment=sim2real", *labelled(rig_folder, report_path)])
    with pytest.raises(BearingTwinError, match=r"register=sim2real is the CWRU protocol's model; a model of another rig's "
                                               r"records \(data\.labels\) is registered under a name of its own"):
        check_registration(cfg)
    assert check_registration(compose_train(["+experiment=sim2real", *labelled(rig_folder, report_path),
                                             "register=my_rig"])) == ("my_rig", "champion")



def test_only_a_protocol_run_registers_the_protocols_model():
    """models:/sim2real@champion is what the README diagnoses real recordings with: a smoke run of another config
    registered under it would take it over without a word."""
    from bearingtwin.tracking.mlflow_logging import check_registration

    with pytest.raises(BearingTwinError, match=r"register=sim2real is the pre-registered protocol's model "
                                               r"\(bearingtwin-train \+experiment=sim2real\)"):
        check_registration(compose_train(["classifier=svm", "register=sim2real", "register_alias=champion"]))
    assert check_registration(compose_train(["+experiment=sim2real"])) == ("sim2real", "champion")
    for version in ("sim2real_v8", "sim2real_v1"):  # any version, the first (no protocol key of its own) included
        with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):  # as the running command sees its choices
            cfg = compose("train", overrides=[f"+experiment={version}"], return_hydra_config=True)
        assert check_registration(cfg) == ("sim2real", "champion")


def test_a_calibration_report_of_another_record_is_refused(rig_folder, tmp_path):
    """bearingtwin-twin writes what it held the twin against into its report: the healthy record's report given as
    the outer-race record's (two reports swapped), one made at another rate or on another bearing, is refused
    before any simulation; a report of a copy of the record (another file name) is the record's."""
    def report(fault, fs=FS, bearing="cwru_6205", **geometry):
        path = tmp_path / f"{fault}-{fs:g}-{bearing}-{len(geometry)}.json"
        measured = {"path": "elsewhere/copy_of_outer_a.npy", "fault": fault, "fs": fs, "bearing": bearing,
                    **({"geometry": geometry} if geometry else {})}
        path.write_text(json.dumps({"measured": measured, "steps": [{"effects": [], "params": {}, "base_params": {}}]}))
        return path

    def build(outer_report):
        return build_dataset(compose_train([*labelled(rig_folder, outer_report, f"paths.cache_dir={tmp_path}"),
                                            "data.calibration.step=0"]))

    with pytest.raises(BearingTwinError, match=r"data\.calibration\.report=\S+: a report of a normal record, where "
                                               r"data\.calibration\.record is outer; give the report bearingtwin-twin wrote"):
        build(report("normal"))
    with pytest.raises(BearingTwinError, match=r"a report of a record at 25600 Hz, where the twin simulates at data\.fs=12000 Hz"):
        build(report("outer", fs=25600))
    with pytest.raises(BearingTwinError, match=r"its record is of bearing paper, this one of cwru_6205; a calibration "
                                               r"report must come from the same rig"):
        build(report("outer", bearing="paper"))
    with pytest.raises(BearingTwinError, match=r"its record's bearing has n_balls=12, this one bearing\.n_balls=9"):
        build(report("outer", n_balls=12))
    assert build(report("outer")).fixed_split[1].size == 12
    # bearingtwin-twin's out= folder stands for the report it wrote there; an unset report is named as such.
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "twin_report.json").write_text(report("outer").read_text())
    assert build(tmp_path / "out").fixed_split[1].size == 12
    # ... and its contents are the run's, as the file's are: a report fitted again into that folder is another run.
    by_folder = compose_train([*labelled(rig_folder, tmp_path / "out", f"paths.cache_dir={tmp_path}")])
    before = input_digest(by_folder)
    (tmp_path / "out" / "twin_report.json").write_text(report("outer", fs=FS).read_text().replace("[]", "[ ]", 1))
    assert input_digest(by_folder) != before
    with pytest.raises(BearingTwinError, match=r"^data\.calibration\.report is not set; give the twin_report\.json"):
        build_dataset(compose_train([*labelled(rig_folder, "null", f"paths.cache_dir={tmp_path}"),
                                     "data.calibration.step=0"]))
    with pytest.raises(BearingTwinError, match=r"a report of an inner record, where data\.calibration\.record is outer"):
        build(report("inner"))
    # A report written for another file (its contents' digest), and the project's CWRU study's report, the
    # default, left in place for a rig's own records, are refused too.
    other = report("outer")
    written = json.loads(other.read_text())
    written["measured"]["file"] = {"path": "/rig/outer_b.npy", "sha256": "0" * 64}
    other.write_text(json.dumps(written))
    with pytest.raises(BearingTwinError, match=r"a report of outer_b.npy, not of outer_a.npy \(data\.calibration\.record; "
                                               r"their contents differ\)"):
        build(other)
    study = REPO_ROOT / "results" / "cwru_twin_study" / "calibration_130_min_explained_0.1" / "twin_report.json"
    with pytest.raises(BearingTwinError, match=r"the project's CWRU study's report \(the default\), not one of "
                                               r"outer_a.npy; run bearingtwin-twin on outer_a.npy"):
        build(study)


def test_a_copy_of_a_calibration_record_is_no_test_record(rig_folder, report_path, tmp_path):
    """Scored as a test record, a copy (another name, the same contents) would count the twin's own fit as a test."""
    import shutil

    folder = tmp_path / "rig"
    shutil.copytree(rig_folder, folder)
    shutil.copy(folder / "healthy_a.npy", folder / "healthy_copy.npy")
    with open(folder / "labels.csv", "a") as table:
        table.write(f"healthy_copy.npy,normal,1797,{FS:g}\n")
    with pytest.raises(BearingTwinError, match=r"healthy_copy.npy: the same contents as the calibration record "
                                               r"healthy_a.npy, which the twin was fitted to"):
        build_dataset(compose_train([*labelled(folder, report_path, f"paths.cache_dir={tmp_path}")]))


def test_a_record_read_at_a_rate_its_shaft_line_contradicts_is_refused(tmp_path, report_path):
    """A file that states no rate, labelled without one, is read at data.fs; at 25.6 kHz read as 12 kHz, its shaft
    series stands at less than half the shaft's rate, and the record is refused rather than read wrong."""
    folder = tmp_path / "rig"
    folder.mkdir()
    rows = []
    for seed, (name, state, rpm) in enumerate(RECORDS):
        fs = 25600.0 if name == "inner_b.npy" else FS
        np.save(folder / name, simulate_rig(state, RigOperatingPoint(rpm=rpm, fs=fs, duration_s=2.0), seed=seed))
        rows.append(f"{name},{state},{rpm:g}," + ("" if name == "inner_b.npy" else f"{FS:g}"))
    (folder / "labels.csv").write_text("record,state,rpm,fs\n" + "\n".join(rows) + "\n")
    with pytest.raises(BearingTwinError, match=r"inner_b\.npy: read at data\.fs=12000 Hz, a rate neither the file nor its "
                                               r"labels row states, but .*; give its rate in the labels table's fs column"):
        build_dataset(compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}")))
    # A wrong rate its row gives is refused alike, named as the row's.
    (folder / "labels.csv").write_text((folder / "labels.csv").read_text().replace("inner_b.npy,inner,1750,",
                                                                                 "inner_b.npy,inner,1750,12000"))
    with pytest.raises(BearingTwinError, match=r"inner_b\.npy: read at its labels row's fs=12000 Hz, but fs = 12000 Hz "
                                               r"contradicts the shaft speed"):
        build_dataset(compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}")))
    (folder / "labels.csv").write_text((folder / "labels.csv").read_text().replace("inner_b.npy,inner,1750,12000",
                                                                                 "inner_b.npy,inner,1750,"))
    # Its rate given, the record is at another rate than the rest: named, with what can be done.
    (folder / "labels.csv").write_text((folder / "labels.csv").read_text().replace("inner_b.npy,inner,1750,",
                                                                                 "inner_b.npy,inner,1750,25600"))
    with pytest.raises(BearingTwinError, match=r"data\.labels: the records are at 25600 Hz \(inner_b\.npy, \.\.\.\), "
                                               r"12000 Hz \(ball_b\.npy, \.\.\.\); the twin simulates at one rate"):
        build_dataset(compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}")))
    # The same from a file that states its rate itself, its row stating none.
    np.savez(folder / "inner_b.npz", signal=np.load(folder / "inner_b.npy"), fs=25600.0)
    (folder / "labels.csv").write_text((folder / "labels.csv").read_text().replace("inner_b.npy,inner,1750,25600",
                                                                                 "inner_b.npz,inner,1750,"))
    (folder / "inner_b.npy").unlink()
    with pytest.raises(BearingTwinError, match=r"data\.labels: the records are at 25600 Hz \(inner_b\.npz, \.\.\.\)"):
        build_dataset(compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}")))


def test_a_record_shorter_than_a_window_is_named(rig_folder, report_path, tmp_path):
    with pytest.raises(BearingTwinError, match=r"inner_b\.npy: the record has 12000 samples, shorter than one window "
                                               r"of 16384 \(data\.window_length\)"):
        build_dataset(compose_train(labelled(rig_folder, report_path, f"paths.cache_dir={tmp_path}",
                                             "data.window_length=16384", "data.twin.duration=2.0")))


def test_twin_windows_beyond_half_the_memory_are_refused_before_any_simulation(rig_folder, report_path, tmp_path,
                                                                              monkeypatch):
    """Each distinct speed of the records is a twin record per state and variant: at 25.6 kHz, 36 records a few
    rpm apart and 72 variants were killed for memory after half an hour of simulation."""
    monkeypatch.setattr("bearingtwin.data.windows.physical_memory_bytes", lambda: 200_000)
    with pytest.raises(BearingTwinError, match=r"data\.twin\.windows_per_record=2 windows of data\.window_length=1024 "
                                               r"samples from each of 8 twin records \(4 states x 2 distinct speeds of the "
                                               r"records, to 0\.1 rpm, x 1 variant\) need about 0\.000262 GB.*labels "
                                               r"table's rpm column\)"):
        build_dataset(compose_train(labelled(rig_folder, report_path, f"paths.cache_dir={tmp_path}")))
    assert not (tmp_path / "twin_to_real").exists()  # nothing simulated


def test_a_file_the_table_leaves_out_is_named_once_by_a_command_that_reads_it_thrice(rig_folder, report_path,
                                                                                   tmp_path, caplog):
    """bearingtwin-train reads the table to check its input, for its closing summary and to build the data: the
    checks say nothing of a stray file, the build names it, once."""
    import shutil

    folder = tmp_path / "rig"
    shutil.copytree(rig_folder, folder)
    np.save(folder / "stray.npy", np.zeros(100))
    cfg = compose_train(labelled(folder, report_path, f"paths.cache_dir={tmp_path}"))
    with caplog.at_level("WARNING"):
        check_protocol(cfg.data)  # the input check
        check_protocol(cfg.data)  # the closing summary's records
        build_dataset(cfg)
    left_out = [r.getMessage() for r in caplog.records if "not labelled" in r.getMessage()]
    assert [message.split(": ", 1)[1] for message in left_out] == ["stray.npy not labelled in labels.csv, left out"]


def test_a_record_whose_speed_nobody_states_is_refused(rig_folder, report_path, tmp_path):
    table = tmp_path / "labels.csv"
    table.write_text((rig_folder / "labels.csv").read_text().replace("inner_b.npy,inner,1750", "inner_b.npy,inner,"))
    with pytest.raises(BearingTwinError, match=r"inner_b\.npy: states no shaft speed; give it in the labels table's rpm"):
        build_dataset(compose_train(labelled(rig_folder, report_path, f"paths.cache_dir={tmp_path}", f"data.labels={table}")))


def test_train_on_the_twin_and_score_the_rigs_records_end_to_end(rig_folder, report_path, tmp_path):
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    done = run_module("bearingtwin.cli.train", "classifier=svm", "features=envelope_prominence",
                      *labelled(rig_folder, report_path), f"tracking.uri={uri}", f"paths.cache_dir={tmp_path}/cache",
                      f"hydra.run.dir={tmp_path}/run", cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "calibration accuracy: " in done.stdout
    assert "data: twin calibrated on healthy_a.npy, outer_a.npy; tested on 4 other records (per_record.csv among the artifacts)" in done.stdout
    artifacts = next(line.split(": ", 1)[1] for line in done.stdout.splitlines() if line.strip().startswith("artifacts:"))
    assert (Path(artifacts.removeprefix("file://")) / "per_record.csv").is_file(), artifacts
    client = MlflowClient(uri)
    (run,) = client.search_runs([client.get_experiment_by_name("bearingtwin").experiment_id])
    assert run.info.status == "FINISHED" and run.data.metrics["n_test"] == 12.0
    assert set(run.data.metrics) >= {"calibration_recall_normal", "calibration_recall_outer", "recall_normal"}
    with open(client.download_artifacts(run.info.run_id, "per_record.csv", str(tmp_path))) as handle:
        rows = list(csv.DictReader(handle))
    assert [(Path(row["record"]).name, row["class"], row["windows"]) for row in rows] == [
        ("inner_b.npy", "inner", "3"), ("ball_b.npy", "ball", "3"), ("outer_b.npy", "outer", "3"),
        ("healthy_b.npy", "normal", "3")]
    # Diagnosing the whole folder: the two records the twin was calibrated on are scored, and said to be no test.
    diagnosed = run_module("bearingtwin.cli.diagnose", f"path={rig_folder}", f"model=runs:/{run.info.run_id}/model",
                           f"out={tmp_path}/diagnosis", "figures=false", f"tracking.uri={uri}", cwd=tmp_path, timeout=300)
    assert diagnosed.returncode == 0, diagnosed.stderr[-3000:]
    assert "of 6 with a known state; " in diagnosed.stdout and " of the 4 the model's twin was not calibrated on" in diagnosed.stdout
    for record in ("healthy_a", "outer_a"):
        diagnosis = json.loads((tmp_path / "diagnosis" / record / "diagnosis.json").read_text())
        assert "the model's twin was calibrated on this record (data.calibration.records): its verdict is no test" \
               " of the model" in diagnosis["notes"] and diagnosis["calibration_record"] is True
    inner = json.loads((tmp_path / "diagnosis" / "inner_b" / "diagnosis.json").read_text())
    assert not any("calibrated on this record" in note for note in inner["notes"]) and inner["calibration_record"] is False
    # A copy of a calibration record under a name of its own is known by its contents (the Data Center's 97.mat had
    # been scored as a record the twin never saw).
    (tmp_path / "copies").mkdir()
    shutil.copy(rig_folder / "healthy_a.npy", tmp_path / "copies" / "97.npy")
    healthy_rpm, healthy_fs = next(row.split(",")[2:] for row in (rig_folder / "labels.csv").read_text().splitlines()
                                   if row.startswith("healthy_a"))
    copied = run_module("bearingtwin.cli.diagnose", f"path={tmp_path / 'copies' / '97.npy'}", f"rpm={healthy_rpm}",
                        f"fs={healthy_fs}", f"model=runs:/{run.info.run_id}/model", f"out={tmp_path}/copies_diagnosis",
                        "figures=false", f"tracking.uri={uri}", cwd=tmp_path, timeout=300)
    assert copied.returncode == 0, copied.stderr[-3000:]
    assert json.loads((tmp_path / "copies_diagnosis" / "97" / "diagnosis.json").read_text())["calibration_record"] is True
    # Another rig's run is no row of the CWRU report: with no CWRU run in the store, the report has nothing to show.
    report = run_module("bearingtwin.cli.report", "sim2real", f"uri={uri}", f"out={tmp_path}/sim2real.md",
                        cwd=tmp_path, timeout=300)
    assert report.returncode == 2 and "no FINISHED training runs of data.source=twin_to_real on CWRU records" in report.stderr, \
        report.stderr[-2000:]


CWRU = data_root() / "cwru"


@pytest.mark.skipif(not (CWRU / "normal_0_97.mat").is_file(), reason="CWRU records not present")
def test_cwru_records_read_through_a_labels_table_give_the_cwru_protocols_very_windows(report_path, tmp_path):
    """The labels table is a second way to name the same records: listing the CWRU files with their states
    (calibration records 97 and 130, every fault record at 1 hp a test record) builds the dataset the CWRU
    names build, window for window."""
    tests = ["12k_Drive_End_IR007_1_106", "12k_Drive_End_B007_1_119", "12k_Drive_End_OR007@6_1_131"]
    states = {"normal_0_97": "normal", "12k_Drive_End_OR007@6_0_130": "outer", **dict(zip(tests, ("inner", "ball", "outer")))}
    table = tmp_path / "labels.csv"
    table.write_text("record,state\n" + "".join(f"{stem}.mat,{state}\n" for stem, state in states.items()))
    common = ["data=twin_to_real", "bearing=cwru_6205", f"data.calibration.report={report_path}", "data.calibration.step=1",
              *SMALL, "data.window_length=2048", f"paths.cache_dir={tmp_path}"]
    by_name = build_dataset(compose_train([*common, "data.test.loads=[1]"]))
    by_table = build_dataset(compose_train([*common, f"data.root={CWRU}", f"data.labels={table}"]))
    assert [Path(r).name for r in by_table.records] == [Path(r).name for r in by_name.records]
    for field in ("windows", "labels", "record_ids", "starts", "validation", "window_rpms"):
        assert np.array_equal(getattr(by_table, field), getattr(by_name, field)), field
    assert all(np.array_equal(a, b) for a, b in zip(by_table.fixed_split, by_name.fixed_split))
