"""The pre-registered protocol's headline: its runs read back from a real MLflow store, beside the
physics baseline computed on the real test records and on the record scored for false alarms."""

import re
from pathlib import Path

import pytest
from mlflow import MlflowClient

from bearingtwin.config import REPO_ROOT, data_root
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.sim2real_protocol import (headline_markdown, per_record_markdown, plot_headline,
                                                    protocol_headline, protocol_runs,
                                                    protocol_version, protocol_versions,
                                                    version_in_force)

CWRU = data_root() / "cwru"
TEST_RECORDS = {"12k_Drive_End_IR007_1_106": 0.75, "12k_Drive_End_OR007@6_1_131": 1.0}
PROTOCOL_WINDOWS = {"sim2real_v1": {"data.window_length": 2048, "data.test.windows_per_record": 50},
                    "sim2real_v2": {"data.window_length": 4096, "data.test.windows_per_record": 25}}


def log_protocol_run(client, experiment_id, seed, accuracy, false_alarm_record, protocol="sim2real_v1"):
    run = client.create_run(experiment_id, tags={"bt.kind": "train", "experiment": protocol})
    run_id = run.info.run_id
    for key, value in {"seed": seed, "data.bearing": "cwru_6205", "data.calibration.healthy.record": false_alarm_record,
                       **PROTOCOL_WINDOWS[protocol], "data.calibration.validation_windows_per_record": 50}.items():
        client.log_param(run_id, key, value)
    metrics = {"accuracy": accuracy, "recall_inner": 0.75, "recall_ball": 0.5, "recall_outer": 1.0,
               "calibration_recall_normal": 0.9 + seed / 100}
    for key, value in metrics.items():
        client.log_metric(run_id, key, value)
    client.log_text(run_id, "record,class,windows,accuracy\n" + "".join(
        f"{record}.mat,x,50,{value}\n" for record, value in TEST_RECORDS.items()), "per_record.csv")
    client.set_terminated(run_id, "FINISHED")


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
def test_the_headline_reads_every_seed_of_every_version_and_computes_the_physics_of_the_false_alarm_record(tmp_path):
    client = MlflowClient(f"sqlite:///{tmp_path}/mlflow.db")
    experiment_id = client.create_experiment("protocol", artifact_location=(tmp_path / "artifacts").as_uri())
    for seed, accuracy in ((0, 0.8), (1, 0.9)):
        log_protocol_run(client, experiment_id, seed, accuracy, "normal_0_97")
    log_protocol_run(client, experiment_id, 0, 0.95, "normal_0_97", protocol="sim2real_v2")
    result = protocol_headline(client, experiment_id, "sim2real_v1", CWRU)
    assert result.seeds == [0, 1] and result.accuracy == [0.8, 0.9]  # the other version's run is not among them
    assert result.physics["12k_Drive_End_IR007_1_106"] == "inner" and result.physics["12k_Drive_End_OR007@6_1_131"] == "outer"
    assert result.physics["normal_0_97"] == "normal" and result.physics_calls_healthy_record_healthy
    newer = protocol_headline(client, experiment_id, "sim2real_v2", CWRU)
    assert newer.seeds == [0] and newer.accuracy == [0.95]
    both = {"v1 (day 1)": result, "v2 (day 2)": newer}
    table = headline_markdown(both, in_force="sim2real_v1") + per_record_markdown(both)
    assert "| **v1 (day 1), in force** (`+experiment=sim2real_v1`, seeds 0, 1) | 85.0 ± 5.0 |" in table  # mean ± std over seeds
    assert "| v2 (day 2) (`+experiment=sim2real_v2`, seeds 0) | 95.0 ± 0.0 |" in table  # newer, but not adopted
    assert "(record normal_0_97: healthy)" in table
    # The physics read on the very windows the classifier was scored on: every inner- and outer-race
    # window of these records shows its defect's lines (measured 25 of 25 each); record 97's windows
    # are mostly called healthy.
    assert result.physics_windows["12k_Drive_End_IR007_1_106"] == 1.0 and result.physics_window_recall("outer") == 1.0
    assert 0.5 < result.physics_windows["normal_0_97"] < 1.0
    assert "| physics baseline on the windows of v2 (4096 points; envelope analysis, no learning) | 100.0 |" in table
    assert "| record | true state | v1 windows right % | v2 windows right % | physics windows right % | physics says |" in table
    assert "| 12k_Drive_End_IR007_1_106 | inner | 75.0 ± 0.0 | 75.0 ± 0.0 | 100 | inner |" in table
    assert plot_headline({"v1": result, "v2": newer}, tmp_path / "headline.png").stat().st_size > 10_000
    assert "physics decided" not in table  # no version lets the physics decide: no column for it
    # A version that lets the physics decide windows (physics_first) says how many, in a column of its own.
    newer.physics_decided = [0.6, 0.7]
    decided = headline_markdown(both, in_force="sim2real_v1")
    assert decided.splitlines()[0].endswith("| normal_0_97 windows called healthy % | test windows the physics decided % |")
    assert "| 95.0 ± 0.0 | 75.0 ± 0.0 | 50.0 ± 0.0 | 100.0 ± 0.0 | 90.0 ± 0.0 | 65.0 ± 5.0 |" in decided
    assert "| 100.0 ± 0.0 | 90.5 ± 0.5 | — |" in decided


def test_every_protocol_version_is_a_dated_file_and_sim2real_selects_the_version_in_force(tmp_path):
    """sim2real.yaml names one version (the newest its own rule adopted) and is that version to the key; a newer
    version not adopted says in its section of results/sim2real_protocol.md by which rule it would have been."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR, REPO_ROOT

    versions = protocol_versions()
    assert list(versions)[:2] == ["sim2real_v1", "sim2real_v2"] and versions["sim2real_v1"] == "v1 (2026-11-23)"
    (in_force,) = re.findall(r"^  - (sim2real_v\d+)$", (Path(CONF_DIR) / "experiment" / "sim2real.yaml").read_text(), re.M)
    assert in_force in versions and version_in_force() == in_force  # the report's reading of the same file
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        current = compose("train", overrides=["+experiment=sim2real"])
        named = compose("train", overrides=[f"+experiment={in_force}"])
    assert current == named and current.protocol == in_force  # the runs' tag, whichever name selected it
    protocol_text = (REPO_ROOT / "results" / "sim2real_protocol.md").read_text()
    in_force_number = in_force.rpartition("v")[2]
    for later in list(versions)[list(versions).index(in_force) + 1:]:
        section = protocol_text[protocol_text.index(f"# Sim2real protocol, version {later.rpartition('v')[2]} "):]
        section = section.split("\n# Sim2real protocol, version ")[0]  # that version's own section only
        assert f"replaces version {in_force_number} as `+experiment=sim2real`" in section and "only if" in section
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "sim2real_v1.yaml").write_text("# a protocol without its version and date\n")
    with pytest.raises(BearingTwinError, match="sim2real_v1.yaml: a protocol version opens with"):
        protocol_versions(tmp_path)


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
def test_the_report_writes_the_protocols_block_and_keeps_the_exploratory_tables_without_exploratory_runs(tmp_path):
    from bearingtwin.tracking.reports import GENERATED, PROTOCOL_MARKER, run_report

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(uri)
    experiment_id = client.create_experiment("bearingtwin", artifact_location=(tmp_path / "artifacts").as_uri())
    log_protocol_run(client, experiment_id, 0, 0.8, "normal_0_97")
    out = tmp_path / "sim2real.md"
    out.write_text(f"# title\n\n{PROTOCOL_MARKER}\nold result\n{PROTOCOL_MARKER}\n\nprose\n\n{GENERATED}\n"
                   f"exploratory tables of earlier sweeps\n{GENERATED}\n")
    run_report("sim2real", {"uri": uri, "experiment": "bearingtwin", "out": str(out), "data_root": str(CWRU)})
    text = out.read_text()
    assert "old result" not in text and "| v1 (2026-11-23) (`+experiment=sim2real_v1`, seeds 0) | 80.0 ± 0.0 |" in text
    assert "exploratory tables of earlier sweeps" in text and "prose" in text


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
def test_the_report_into_a_new_file_holds_the_protocols_result_without_exploratory_runs(tmp_path, capsys):
    """A user's own out= (no file there yet) and a store with the protocol's run alone: the report is its result."""
    from bearingtwin.tracking.reports import GENERATED, run_report

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(uri)
    experiment_id = client.create_experiment("bearingtwin", artifact_location=(tmp_path / "artifacts").as_uri())
    log_protocol_run(client, experiment_id, 0, 0.8, "normal_0_97")
    out = tmp_path / "reports" / "sim2real.md"
    run_report("sim2real", {"uri": uri, "experiment": "bearingtwin", "out": str(out), "data_root": str(CWRU)})
    text = out.read_text()
    assert text.count(GENERATED) == 2 and "| v1 (2026-11-23) (`+experiment=sim2real_v1`, seeds 0) | 80.0 ± 0.0 |" in text
    assert "the report holds the pre-registered protocol's result alone" in capsys.readouterr().err


def test_a_run_that_departs_from_its_protocol_is_left_out_with_a_warning(tmp_path, caplog):
    from bearingtwin.config import compose_config
    from bearingtwin.tracking.mlflow_logging import flatten, loggable_config

    client = MlflowClient(f"sqlite:///{tmp_path}/mlflow.db")
    experiment_id = client.create_experiment("protocol", artifact_location=(tmp_path / "artifacts").as_uri())

    def log_run(tag, seed, **changed):
        params = flatten(loggable_config(compose_config("train", ["+experiment=sim2real_v2", f"seed={seed}", *(
            f"{k}={v}" for k, v in changed.items())])))
        run = client.create_run(experiment_id, tags={"bt.kind": "train", "experiment": tag})
        for key, value in params.items():
            client.log_param(run.info.run_id, key, value)
        client.set_terminated(run.info.run_id, "FINISHED")
        return run.info.run_id

    log_run("sim2real_v2", 0, **{"data.window_length": 2048})  # v2's name on v1's window: not v2
    log_run("sim2real_v2", 1, **{"data.twin.windows_per_record": 2, "trainer.progress_bar": False})  # a smoke run
    kept = log_run("sim2real_v2", 2, **{"trainer.progress_bar": False})  # a display setting does not count
    with caplog.at_level("WARNING"):
        runs = protocol_runs(client, experiment_id, "sim2real_v2")
    assert [run.info.run_id for run in runs] == [kept]
    assert "data.window_length=2048 (the protocol: 4096)" in caplog.text
    assert "data.twin.windows_per_record=2 (the protocol: 10)" in caplog.text
    assert protocol_runs(client, experiment_id, "sim2real_v1") == []
    assert protocol_version("sim2real") == "sim2real_v1" and protocol_version("sim2real_variants") is None


def test_a_run_with_another_physics_first_rule_than_its_versions_is_left_out(tmp_path, caplog):
    """physics_first is logged as one key when unset and as its settings when set: a v8-tagged run that applied the
    rule, a v9-tagged one that did not, or one with another threshold is not the version's; the same rule written as
    20 or 20.0 is, and so is a run from before the key was logged."""
    from bearingtwin.config import compose_config
    from bearingtwin.tracking.mlflow_logging import flatten, loggable_config

    client = MlflowClient(f"sqlite:///{tmp_path}/mlflow.db")
    experiment_id = client.create_experiment("protocol", artifact_location=(tmp_path / "artifacts").as_uri())

    def log_run(tag, seed, rule, drop_rule=False):
        params = flatten(loggable_config(compose_config("train", [f"+experiment={tag}", f"seed={seed}",
                                                                  f"physics_first={rule}"])))
        run = client.create_run(experiment_id, tags={"bt.kind": "train", "experiment": tag})
        for key, value in params.items():
            if not (drop_rule and key.startswith("physics_first")):
                client.log_param(run.info.run_id, key, value)
        client.set_terminated(run.info.run_id, "FINISHED")
        return run.info.run_id

    log_run("sim2real_v8", 0, "{threshold_db:20,margin_db:10}")
    old = log_run("sim2real_v8", 1, "null", drop_rule=True)
    v8 = log_run("sim2real_v8", 2, "null")
    log_run("sim2real_v9", 0, "null")
    log_run("sim2real_v9", 1, "{threshold_db:15,margin_db:10}")
    v9 = log_run("sim2real_v9", 2, "{threshold_db:20,margin_db:10}")
    with caplog.at_level("WARNING"):
        assert [run.info.run_id for run in protocol_runs(client, experiment_id, "sim2real_v8")] == [old, v8]
        assert [run.info.run_id for run in protocol_runs(client, experiment_id, "sim2real_v9")] == [v9]
    assert "physics_first={'threshold_db': 20.0, 'margin_db': 10.0} (the protocol: None)" in caplog.text
    assert "physics_first=None (the protocol: {'threshold_db': 20.0, 'margin_db': 10.0})" in caplog.text
    assert "physics_first={'threshold_db': 15.0, 'margin_db': 10.0} (the protocol:" in caplog.text


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
def test_the_rule_beside_a_classifier_that_knows_nothing_is_scored_on_the_protocols_own_windows(capsys):
    """scripts/sim2real_constant_class.py: the physics-first rule of the protocol in force with every window it
    leaves called one state. No test record is healthy, so a constant 'normal' scores only the windows the physics
    decides right, and every other constant at least those; the healthy record is called healthy only by it."""
    from script_modules import load_script

    load_script(REPO_ROOT / "scripts" / "sim2real_constant_class.py").main([])
    printed = capsys.readouterr().out
    decided, total = map(int, re.search(r"the physics decides (\d+) of (\d+) test windows", printed).groups())
    rows = {state: (int(right), int(healthy) if healthy != "-" else None) for state, right, healthy in re.findall(
        r"\| every window left to it called (\w+) \| [\d.]+ \((\d+)/\d+\) \| \d+/\d+ \| (\S+) \|", printed)}
    assert set(rows) == {"normal", "inner", "ball", "outer"} and 0 < decided < total
    assert rows["normal"][0] <= decided and rows["normal"][1] == 100
    assert all(right >= rows["normal"][0] for right, _ in rows.values())
    assert all(rows[state][1] == 0 for state in ("inner", "ball", "outer"))
