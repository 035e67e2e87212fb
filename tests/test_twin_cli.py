"""``bearingtwin-twin`` end to end: the report contract, figures, MLflow, and clear failures."""

import json
import os

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from processes import run_module

from bearingtwin.config import CONF_DIR
from bearingtwin.twin.model import TwinModel

FAST = ["twin.duration=1.0", "compare.envelope_segment_s=0.25", "compare.lines_segment_s=0.25",
        "calibration.n_trials_base=8", "calibration.n_trials_effect=6", "calibration.n_trials_refine=6",
        "calibration.n_polish=10", "calibration.n_polish_effect=6", "ranking.max_effects=2",
        "operating_point.radial_load_n=0.0", "operating_point.clearance_um=5.0",
        "measured.check_fs=false"]  # a twin-made record shows no shaft line to check the rate by


# What the measurement's own reference record would have fixed: where the sensor sits, the defect's size.
KNOWN = ["operating_point.sensor=outer_y", "operating_point.defect_depth_mm=0.004", "operating_point.defect_width_mm=0.533"]


def run_cli(*overrides, env=None, cwd=None):
    return run_module("bearingtwin.cli.twin", *overrides, env={**os.environ, **(env or {})}, timeout=300, cwd=cwd)


@pytest.fixture(scope="module")
def measurement(tmp_path_factory):
    """2 s of an outer-race twin (sensor on the housing, vertical) seen through a 2.4 kHz mount
    resonance, in g, as a bare .npy."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.fs=12000", "simulator.rpm=1797", "simulator.duration=2.0",
                                             "simulator.sensor=outer_y"])
    twin = TwinModel("outer", cfg.bearing, cfg.simulator, seed=11)
    signal = twin.signal({"simulator.defect.depth_mm": 0.004},
                         {"resonance": {"natural_frequency_hz": 2400.0, "damping_ratio": 0.07}})
    path = tmp_path_factory.mktemp("measured") / "measured.npy"
    np.save(path, signal / 9.81)
    return path


def test_cli_writes_the_report_contract_and_logs_to_mlflow(measurement, tmp_path):
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    out = tmp_path / "report"
    result = run_cli(f"measured.path={measurement}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                     f"out={out}", "candidates=[resonance,slip,noise]", *FAST, *KNOWN, env={"MLFLOW_TRACKING_URI": uri})
    assert result.returncode == 0, result.stderr[-2000:]
    assert "Effects that were missing, in order: resonance" in result.stdout
    report = json.loads((out / "twin_report.json").read_text())
    assert isinstance(report["baseline_error"], float) and isinstance(report["final_error"], float)
    assert report["verdict"] == "effects missing" and report["added"][0] == "resonance"
    assert [entry["effect"] for entry in report["ranking"]][0] == "resonance"
    assert {"effect", "error", "params", "evidence", "intervals"} <= set(report["ranking"][0])
    evidence = [entry["evidence"] for entry in report["ranking"]]
    assert evidence == sorted(evidence, reverse=True) and evidence[0] > 0
    assert report["operating_point"]["radial_load_n"] == {"value": 0.0, "unit": "N", "held": True}
    assert report["operating_point"]["sensor"]["race"] == "outer"
    assert report["steps"][0]["effects"] == [] and report["steps"][1]["effects"] == ["resonance"]
    assert report["steps"][0]["error"] == report["baseline_error"]
    assert report["final_error"] == report["steps"][-1]["error"] < report["baseline_error"]
    assert 1000 < report["ranking"][0]["params"]["natural_frequency_hz"] < 4000
    assert "resonance" in report["summary"]
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert {"error_steps.png", "baseline_envelope.png", "final_psd.png", "final_lines.png"} <= set(pngs)

    client = MlflowClient(tracking_uri=uri)
    (run,) = client.search_runs([client.get_experiment_by_name("bearingtwin-twin").experiment_id])
    assert run.info.status == "FINISHED"
    history = client.get_metric_history(run.info.run_id, "discrepancy_db")
    assert [m.value for m in sorted(history, key=lambda m: m.step)] == [s["error"] for s in report["steps"]]
    artifacts = {a.path for a in client.list_artifacts(run.info.run_id)}
    assert "twin_report.json" in artifacts and "error_steps.png" in artifacts
    assert run.data.tags["verdict"] == "effects missing" and "op_sensor" not in run.data.metrics


def test_fixed_effects_stay_in_every_step(measurement, tmp_path):
    out = tmp_path / "report"
    result = run_cli(f"measured.path={measurement}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                     f"out={out}", "effects=[noise]", "effects.noise.snr_db=40", "candidates=[resonance]",
                     "tracking.enabled=false", "figures=false", *FAST, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # nothing else left in the working directory
    report = json.loads((out / "twin_report.json").read_text())
    assert all(step["effects"][0] == "noise" for step in report["steps"])
    assert list(out.glob("*.png")) == []


@pytest.mark.parametrize("overrides, message", [
    (["measured.path={missing}", "measured.fs=12000"], "missing.npy"),
    (["measured.path={measured}", "measured.fs=600"], "measured.fs=600 Hz is too low"),
    (["measured.path={measured}", "measured.fs=12000", "candidates=[resonance,wobble]"], "unknown effect 'wobble'"),
    (["measured.path={measured}", "measured.fs=12000", "measured.fault=cracked"], "fault='cracked'"),
])
def test_bad_input_exits_nonzero_naming_the_problem(measurement, tmp_path, overrides, message):
    overrides = [o.format(missing=tmp_path / "missing.npy", measured=measurement) for o in overrides]
    defaults = ["measured.rpm=1797", "measured.fault=outer"]
    given = {o.split("=")[0] for o in overrides}
    result = run_cli(*overrides, *[d for d in defaults if d.split("=")[0] not in given], f"out={tmp_path / 'r'}",
                     "tracking.enabled=false", *FAST)
    assert result.returncode != 0
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "r" / "twin_report.json").exists()


def test_no_measurement_given_is_named():
    from omegaconf import OmegaConf

    from bearingtwin.errors import BearingTwinError
    from bearingtwin.twin.report import load_measurement

    with pytest.raises(BearingTwinError, match=r"^measured.path is missing: give measured.path=<file>"):
        load_measurement(OmegaConf.create({"path": "???", "channel": None, "fs": None, "rpm": None, "fault": None}))
