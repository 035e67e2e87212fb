"""``bearingtwin-twin`` end to end: the report contract, figures, MLflow, and clear failures."""

import json
import os
import re

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from joblib import cpu_count
from mlflow import MlflowClient
from processes import run_module

from bearingtwin.config import CONF_DIR, data_root, load_bearing
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.twin.compare import VIEWS
from bearingtwin.twin.model import TwinModel
from bearingtwin.twin.report import build_ranker, ranker_settings

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
    # what the twin was held against, wherever each value came from (here settings; an .npy states no unit)
    assert "\n  record: outer, 1797 rpm, 12000 Hz, its unit not stated\n" in result.stdout, result.stdout[-1500:]
    # whose defect lines were read, though no file named it: the default, said to be one
    assert ("\n  bearing: paper, the default: the record names no bearing; give bearing=<name> (a conf/bearing config, "
            "or one's own) for the defect frequencies of the bearing it was made on\n") in result.stdout
    # What was said of the rig is repeated where the summary ends, held, not fitted.
    assert ("  operating point held: radial load 0 N, clearance 5 um, defect depth 0.004 mm, defect width 0.533 mm, "
            "sensor outer race, vertical") in result.stdout, result.stdout[-1500:]
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
    out.mkdir()
    for name in ("final_psd.png", "baseline_lines.png", "error_steps.png", "final_notes.png"):  # an earlier run's
        (out / name).write_bytes(b"png")
    result = run_cli(f"measured.path={measurement}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                     f"out={out}", "effects=[noise]", "effects.noise.snr_db=40", "candidates=[resonance]",
                     "tracking.enabled=false", "figures=false", *FAST, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # nothing else left in the working directory
    report = json.loads((out / "twin_report.json").read_text())
    assert all(step["effects"][0] == "noise" for step in report["steps"])
    # With figures=false no figure of the earlier run stays beside the report, and only this command's are removed.
    assert sorted(p.name for p in out.iterdir()) == ["final_notes.png", "twin_report.json"]
    assert result.stderr == ""  # no progress bar where no one watches
    assert "held in the twin: noise (effects=)\n" in result.stdout  # not a candidate here: not tried as changed


def test_a_speed_the_file_contradicts_is_named_as_the_twins_setting(measurement, tmp_path):
    np.savez(tmp_path / "stated.npz", signal=np.load(measurement), fs=12000.0, rpm=1797.0, fault="outer")
    result = run_cli(f"measured.path={tmp_path / 'stated.npz'}", "measured.rpm=1750", f"out={tmp_path / 'r'}",
                     "tracking.enabled=false", *FAST, cwd=tmp_path)
    assert result.returncode == 2 and result.stderr.strip().splitlines() == [
        f"error: {tmp_path / 'stated.npz'}: measured.rpm=1750.0 contradicts the file's rpm=1797.0 (more than 1% apart); "
        "no speed could be read off the record itself to decide between them (a tachometer channel's, or the shaft's "
        "harmonic series' away from the supply's lines)"], result.stderr


def cwru_record(folder, name, samples):
    """``samples`` as a CWRU Data Center file of that ``name`` (its record number in the variables' names too)."""
    import scipy.io

    record = folder / name
    number, end = name.removesuffix(".mat").split("_")[-1], "FE" if "_Fan_End_" in name else "DE"
    scipy.io.savemat(record, {f"X{number}_{end}_time": samples[:, None], f"X{number}RPM": np.array([[1797.0]])})
    return record


@pytest.mark.parametrize("name, bearing, bpfo", [
    ("12k_Drive_End_OR007@6_0_130.mat", "cwru_6205", 3.5848),  # the drive end's SKF 6205, known by the record's name
    ("12k_Fan_End_OR007@6_0_294.mat", "cwru_6203", 3.0530),  # the fan end's SKF 6203, which the file names
    ("normal_0_97.mat", "cwru_6205", 3.5848),  # no faulty end: the bearing under the accelerometer read (DE)
])
def test_a_record_that_names_its_bearing_is_read_with_it_when_no_bearing_is_given(measurement, tmp_path, name,
                                                                                   bearing, bpfo):
    """Without bearing= the twin's default (the paper's bearing) gave a CWRU record another bearing's defect
    frequencies, with a warning only: the record's own is read, and the log, the report and the closing summary
    say which."""
    record = cwru_record(tmp_path, name, np.load(measurement))
    result = run_cli(f"measured.path={record}", f"out={tmp_path / 'r'}", "candidates=[]", "tracking.enabled=false",
                     "figures=false", *FAST, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    geometry = load_bearing(bearing)
    orders = f"BPFO {geometry.bpfo_hz(60.0):.3f}, BPFI {geometry.bpfi_hz(60.0):.3f} x shaft"
    assert (f"{record}: the record's bearing is {bearing} and no bearing= was given: the twin reads it ({orders}), "
            "not paper's") in result.stderr, result.stderr[-3000:]  # a log line: stdout keeps the summary
    assert f"  bearing: {bearing}, the record's own (no bearing= given; {orders})\n" in result.stdout
    assert "give bearing=" not in result.stdout  # no doubt left of a bearing it did not use
    report = json.loads((tmp_path / "r" / "twin_report.json").read_text())
    assert report["measured"]["bearing"] == bearing
    used = BearingGeometry(**report["measured"]["geometry"])  # the geometry the comparison read the lines of
    assert used.bpfo_hz(60.0) == pytest.approx(bpfo, abs=5e-4) and used.bpfi_hz(60.0) == geometry.bpfi_hz(60.0)
    assert "effects found: no effect tried: the candidate list is empty (candidates=[])" in result.stdout
    # The library was not asked: no "unexplained discrepancy" verdict, whatever views the twin leaves unexplained.
    assert "Not explained by the twin: " in result.stdout and "verdict: no effect tried" in result.stdout
    assert re.search(r"discrepancy: \d+\.\d\d dB, no effect added, the measurement's own", result.stdout), result.stdout


def test_a_record_of_unknown_state_is_held_at_the_state_its_envelope_spectrum_names(measurement, tmp_path):
    """A plant's record states no bearing state, which is what its user wants to know: the twin had refused it, asking
    for measured.fault. The record's envelope spectrum names it (this one's outer-race lines), said in the log and the
    closing summary, and the twin is held at it."""
    result = run_cli(f"measured.path={measurement}", "measured.fs=12000", "measured.rpm=1797", f"out={tmp_path / 'r'}",
                     "candidates=[]", "tracking.enabled=false", "figures=false", *FAST, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert re.search(r"\n  state: outer, as the record's envelope spectrum names it \(outer lines \+\d+\.\d dB over "
                     r"their floor; no state was given\): give measured.fault= where it is known\n", result.stdout), (
        result.stdout)
    assert "\n  record: outer (by its envelope spectrum: see state), 1797 rpm, 12000 Hz" in result.stdout, result.stdout
    assert json.loads((tmp_path / "r" / "twin_report.json").read_text())["measured"]["fault"] == "outer"


def test_a_record_naming_a_bearing_no_config_describes_is_refused_unless_one_is_given(measurement, tmp_path):
    """A simulation of one's own bearing held against the twin without its search path had been calibrated to the
    paper's defect lines, a warning aside (a 0.28 mm defect fitted as 0.002 mm): refused in one line before a store
    is opened; with a bearing given, it is read with that one, said."""
    np.savez(tmp_path / "own.npz", signal=np.load(measurement), fs=12000.0, rpm=1797.0, fault="outer", bearing="skf_6206")
    result = run_cli(f"measured.path={tmp_path / 'own.npz'}", f"out={tmp_path / 'r'}", "candidates=[]", *FAST,
                     env={"MLFLOW_TRACKING_URI": f"sqlite:///{tmp_path / 'mlflow.db'}"}, cwd=tmp_path)
    assert result.returncode == 2 and result.stderr.strip().splitlines() == [
        f"error: {tmp_path / 'own.npz'}: the file names bearing skf_6206, which no conf/bearing config here describes: "
        "its defect frequencies are unknown here (give bearing=<name>, with hydra.searchpath for one of your own)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["own.npz"]  # no store, no report folder
    given = run_cli(f"measured.path={tmp_path / 'own.npz'}", "bearing=paper", f"out={tmp_path / 'r'}", "candidates=[]",
                    "tracking.enabled=false", "figures=false", *FAST, cwd=tmp_path)
    assert given.returncode == 0 and "the file names bearing skf_6206" in given.stderr, given.stderr[-2000:]


@pytest.mark.parametrize("given", ["cwru_6203", "paper"])  # paper: the default's name, but given
def test_a_bearing_given_that_is_not_the_records_is_refused_before_a_run_opens(measurement, tmp_path, given):
    """A drive-end record run with another bearing= was calibrated to that bearing's defect frequencies, a warning
    aside: it is refused in one line naming the file, both bearings and the fix, before the MLflow store is opened
    (no run left RUNNING or FAILED) or the out= folder is made."""
    record = cwru_record(tmp_path, "12k_Drive_End_OR007@6_0_130.mat", np.load(measurement))
    result = run_cli(f"measured.path={record}", f"bearing={given}", f"out={tmp_path / 'r'}", "candidates=[]", *FAST,
                     env={"MLFLOW_TRACKING_URI": f"sqlite:///{tmp_path / 'mlflow.db'}"}, cwd=tmp_path)
    assert result.returncode == 2, result.stderr[-2000:]
    orders = {name: f"BPFO {load_bearing(name).bpfo_hz(60.0):.3f}, BPFI {load_bearing(name).bpfi_hz(60.0):.3f} x shaft"
              for name in ("cwru_6205", given)}
    assert result.stderr.strip().splitlines() == [
        f"error: {record}: the record's bearing is cwru_6205 ({orders['cwru_6205']}), the one given is {given} "
        f"({orders[given]}): give bearing=cwru_6205 for the record's defect frequencies"], result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [record.name]  # no store, no report folder


def test_which_bearing_counts_as_given_and_which_the_record_replaces(measurement, tmp_path):
    """Outside a Hydra run no override can be read: the default's name alone counts as no bearing given. A bearing
    given under another name but of the record's geometry (one of your own) is kept."""
    from omegaconf import open_dict

    from bearingtwin.data.formats import read_raw, recording_from_raw
    from bearingtwin.twin.report import bearing_chosen, record_bearing

    assert not bearing_chosen(twin_config()) and not bearing_chosen(twin_config("bearing=paper"))
    assert bearing_chosen(twin_config("bearing=cwru_6203"))
    record = cwru_record(tmp_path, "12k_Drive_End_OR007@6_0_130.mat", np.load(measurement))
    measured = recording_from_raw(read_raw(record))
    adopted, line = record_bearing(twin_config(f"measured.path={record}"), measured)
    assert adopted.bearing.name == "cwru_6205" and BearingGeometry.from_config(adopted.bearing) == load_bearing("cwru_6205")
    assert line.startswith("cwru_6205, the record's own (no bearing= given; BPFO 3.585")
    own = twin_config(f"measured.path={record}", "bearing=cwru_6205")
    with open_dict(own):
        own.bearing.name = "my6205"
    assert record_bearing(own, measured) == (own, None)
    with pytest.raises(BearingTwinError, match=r"the one given is cwru_6203 \(BPFO 3\.053.*give bearing=cwru_6205"):
        record_bearing(twin_config(f"measured.path={record}", "bearing=cwru_6203"), measured)
    # A fault record named by the Data Center's label, its variables of no catalogued record, names no end: which
    # bearing is faulty is the user's to say, on either channel; a healthy one's bearing is the one under the
    # accelerometer read. (Variables of a catalogued record, X105_*, name its end: tests/test_cwru.py.)
    import scipy.io

    samples = np.load(measurement)[:, None]
    label = tmp_path / "IR007_0.mat"
    scipy.io.savemat(label, {"X999_DE_time": samples, "X999_FE_time": samples, "X999RPM": np.array([[1797.0]])})
    for channel in ("DE", "FE"):
        for given in ("cwru_6205", "cwru_6203"):
            cfg = twin_config(f"measured.path={label}", f"bearing={given}")
            assert record_bearing(cfg, recording_from_raw(read_raw(label), channel=channel)) == (cfg, None)
    # A record that names no bearing is held against the default one, said so; against one chosen, without a word.
    bare = recording_from_raw(read_raw(measurement), fs=12000)
    kept, line = record_bearing(twin_config(f"measured.path={measurement}"), bare)
    assert kept.bearing.name == "paper" and line.startswith("paper, the default: the record names no bearing; give bearing=")
    assert record_bearing(twin_config(f"measured.path={measurement}", "bearing=cwru_6205"), bare)[1] is None
    healthy = recording_from_raw(read_raw(cwru_record(tmp_path, "normal_0_97.mat", np.load(measurement))), channel="DE")
    assert record_bearing(twin_config(f"measured.path={tmp_path / 'normal_0_97.mat'}"), healthy)[0].bearing.name == "cwru_6205"


def test_a_record_that_names_no_bearing_is_read_with_its_references_unless_one_is_given(measurement):
    """Held against a baseline of another bearing than the default, a later record that names none had been refused
    until the baseline's bearing was given again: the reference's bearing is read where no bearing= is given, said
    so, while one given, or one the record names, stays; a reference whose geometry its bearing's name no longer
    gives (a bearing.* override) gives none."""
    from bearingtwin.data.formats import read_raw, recording_from_raw
    from bearingtwin.twin.reference import reference_bearing, rig_geometry
    from bearingtwin.twin.report import record_bearing

    report = {"measured": {"bearing": "cwru_6205", "geometry": rig_geometry(load_bearing("cwru_6205"))}}
    assert reference_bearing(report) == "cwru_6205"
    changed = {"measured": {"bearing": "cwru_6205", "geometry": {**report["measured"]["geometry"], "n_balls": 12}}}
    assert reference_bearing(changed) is None and reference_bearing({"measured": {"bearing": "mine"}}) is None
    assert reference_bearing(None) is None
    bare = recording_from_raw(read_raw(measurement), fs=12000)
    adopted, line = record_bearing(twin_config(f"measured.path={measurement}"), bare, "cwru_6205")
    assert adopted.bearing.name == "cwru_6205" and line == "cwru_6205, the reference's (no bearing= given)"
    given = twin_config(f"measured.path={measurement}", "bearing=cwru_6203")
    assert record_bearing(given, bare, "cwru_6205") == (given, None)  # refused later, against the reference's geometry


@pytest.mark.parametrize("overrides, message", [
    (["measured.path={missing}", "measured.fs=12000"], "missing.npy"),
    (["measured.path={measured}", "measured.fs=600"], "measured.fs=600 Hz is too low"),
    (["measured.path={measured}", "measured.fs=12000", "candidates=[resonance,wobble]"], "unknown effect 'wobble'"),
    (["measured.path={measured}", "measured.fs=12000", "measured.fault=cracked"], "fault='cracked'"),
    (["measured.path={measured}"], "measured.npy: the file does not state its sampling rate; give measured.fs=<Hz>"),
    (["measured.path={measured}", "measured.fs=12000", "measured.rpm=abc"],
     "measured.rpm='abc' must be a positive number of rev/min"),
    (["measured.path={measured}", "measured.fs=12000", "operating_point.defect_width_mm=50"],
     "operating_point.defect_width_mm=50 cannot be simulated: simulator.defect.width_mm must be positive and below "
     "the ball diameter"),
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


def test_a_velocity_or_displacement_record_is_refused_and_a_voltage_held_as_an_accelerometers(measurement, tmp_path):
    """Integrated, a record's spectrum is tilted: the twin had fitted a gain to a velocity and explained the tilt as
    a quieter path. A voltage is an accelerometer's record times its sensitivity, which the fitted gain takes."""
    from bearingtwin.twin.report import load_measurement

    signal = np.load(measurement)[:6000]
    for header, refused in (("velocity (mm/s)", "a velocity"), ("x (um)", "a displacement"), ("acc (V)", None)):
        (tmp_path / "r.csv").write_text(f"{header}\n" + "".join(f"{value:.6g}\n" for value in signal))
        cfg = twin_config(f"measured.path={tmp_path / 'r.csv'}", "measured.fs=12000", "measured.rpm=1797",
                          "measured.fault=outer").measured
        if refused is None:
            assert load_measurement(cfg).unit == "V"
            continue
        with pytest.raises(BearingTwinError, match=rf"r.csv: the record is in .* \({refused}\); the twin simulates an "
                                                   r"accelerometer's record, whose spectrum integration tilts"):
            load_measurement(cfg)


@pytest.mark.parametrize("switch", ["measured.check_fs", "tracking.enabled"])
def test_a_switch_that_is_neither_true_nor_false_is_refused_before_the_file_is_read(tmp_path, switch):
    result = run_cli(f"measured.path={tmp_path / 'absent.npy'}", f"{switch}=maybe", f"out={tmp_path / 'r'}", cwd=tmp_path)
    assert result.returncode == 2 and "absent.npy" not in result.stderr  # refused before the file is looked for
    assert result.stderr.strip() == f"error: {switch}=maybe: give {switch}=true or {switch}=false"
    assert list(tmp_path.iterdir()) == []


def twin_config(*overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("twin", overrides=["measured.path=unused", *overrides])


@pytest.mark.parametrize("overrides, message", [
    (["calibration.n_trials_base=abc"], "calibration.n_trials_base must be a positive integer, got 'abc'"),
    (["calibration.n_trials_base=2.7"], "calibration.n_trials_base must be a positive integer, got 2.7"),
    (["calibration.n_trials_effect=0"], "calibration.n_trials_effect must be a positive integer, got 0"),
    (["calibration.n_trials_refine=-1"], "calibration.n_trials_refine must be a positive integer, got -1"),
    (["calibration.n_polish=-3"], "calibration.n_polish must be a non-negative integer, got -3"),
    (["calibration.n_polish_effect=abc"], "calibration.n_polish_effect must be a non-negative integer, got 'abc'"),
    (["ranking.max_effects=abc"], "ranking.max_effects must be a non-negative integer, got 'abc'"),
    (["ranking.points_per_view=0"], "ranking.points_per_view=0 must be a positive number"),
    (["ranking.points_per_view=-1"], "ranking.points_per_view=-1 must be a positive number"),
    (["ranking.points_per_view=abc"], "ranking.points_per_view='abc' must be a positive number"),
    (["ranking.view_floor_db=0"], "ranking.view_floor_db=0 must be a positive number of dB"),
    (["ranking.min_signature_gain=-1"], "ranking.min_signature_gain must be a non-negative number, got -1"),
    (["ranking.later_points_per_view=0"], "ranking.later_points_per_view=0 must be a positive number"),
    (["ranking.pair_candidates=-1"], "ranking.pair_candidates must be a non-negative integer, got -1"),
    (["ranking.points_per_view=0.1"], "ranking.points_per_view=0.1: the 5 views would count as 0.5 values in all, "
                                       "and a parameter would cost nothing; give more than 0.2"),
    (["ranking.later_points_per_view=0.2"], "ranking.later_points_per_view=0.2: the 5 views would count as 1 value in all"),
    (["ranking.n_jobs=0"], "ranking.n_jobs must be a positive integer, got 0 (or -1: one thread per core)"),
    (["ranking.n_jobs=abc"], "ranking.n_jobs must be a positive integer, got 'abc'"),
    (["seed=abc"], "seed must be a non-negative integer, got 'abc'"),
    (["seed=-1"], "seed must be a non-negative integer, got -1"),
    (["seed=4294967296"], "seed must be at most 2147483647, got 4294967296"),
    (["candidates=noise"], "candidates=noise: give a list of effect names, candidates=[noise]"),
    (["candidates=[resonanse]"], "candidates: unknown effect 'resonanse'"),
    (["candidates=[unbalance,unbalance]"], "candidates: unbalance is named twice"),
    (["effects=[noise]", "effects.noise.snr_db=nan"], "effects.noise.snr_db must be finite, got nan"),
    (["effects=[noise]", "effects.noise.snr_db=[1,2]"], "effects.noise.snr_db must be finite, got [1, 2]"),
    (["effects=[slip]", "effects.slip.jitter=true"], "effects.slip.jitter must be a positive number, got True"),
])
def test_every_setting_of_the_ranking_is_checked_by_kind_naming_it(overrides, message):
    with pytest.raises(BearingTwinError) as error:
        ranker_settings(twin_config(*overrides))
    assert str(error.value).startswith(message)


def test_an_effect_known_to_be_present_stays_a_candidate_to_be_tried_as_changed():
    """``effects=[noise]`` with the default candidates: noise is in the twin at its given values and among the
    candidates (it was refused as 'already among the fixed effects', so a known effect meant editing the list)."""
    settings = ranker_settings(twin_config("effects=[noise]"))
    assert "noise" in settings["fixed_effects"] and "noise" in settings["candidates"]


@pytest.mark.parametrize("overrides, message", [
    (["calibration.ranges=abc"], "calibration.ranges must map each parameter to [low, high] or [low, high, log]"),
    (["calibration.ranges.radial_load_n=5"], "calibration.ranges.radial_load_n must be [low, high] or [low, high, log] "
                                             "of finite numbers, got 5"),
    (["calibration.ranges.radial_load_n=[abc,5]"], "calibration.ranges.radial_load_n must be [low, high]"),
    (["calibration.ranges.radial_load_n=[1,inf]"], "calibration.ranges.radial_load_n must be [low, high]"),
    (["calibration.base=abc"], "calibration.base must map each parameter"),
    (["calibration.base_held=abc"], "calibration.base_held must map names to values, got 'abc'"),
    (["calibration.sensor_angle_step_deg=abc"], "calibration.sensor_angle_step_deg must be a finite number"),
    (["operating_point=abc"], "operating_point must map names to values, got 'abc'"),
])
def test_every_setting_of_the_operating_point_is_checked_when_the_ranker_is_built(overrides, message):
    with pytest.raises(BearingTwinError) as error:
        build_ranker(twin_config(*overrides), "outer")
    assert str(error.value).startswith(message)


def test_the_shipped_settings_pass_and_n_jobs_minus_one_is_a_thread_per_core():
    ranker = build_ranker(twin_config("ranking.n_jobs=-1"), "outer")
    assert ranker.n_jobs == cpu_count() and ranker.n_trials_base == 30 and ranker.later_points_per_view == 6.0


def test_a_bad_setting_ends_the_command_before_the_file_is_read_or_a_run_is_opened(tmp_path):
    """ranking.points_per_view=0 divided by zero after the calibration, its MLflow run left FAILED."""
    result = run_cli(f"measured.path={tmp_path / 'absent.npy'}", "ranking.points_per_view=0", f"out={tmp_path / 'r'}",
                     env={"MLFLOW_TRACKING_URI": f"sqlite:///{tmp_path / 'mlflow.db'}"}, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "error: ranking.points_per_view=0 must be a positive number of values per view (a plain number, no unit)"]
    assert list(tmp_path.iterdir()) == []  # no store opened, no report written


@pytest.mark.parametrize("case", ["a comparison setting", "a record shorter than one segment"])
def test_views_the_record_cannot_fill_are_named_before_a_run_opens(measurement, tmp_path, case):
    """A comparison setting or a record too short for one comparison segment is refused before the MLflow run opens,
    so no FAILED run is left behind for a typo."""
    if case == "a comparison setting":
        given = [f"measured.path={measurement}", "compare.n_bands=1"]
        message = ("compare.n_bands=1 leaves no band level beyond the polynomial of order compare.psd_detrend_order=1: "
                   "give n_bands of at least 3, or a lower order")
    else:
        short = tmp_path / "short.npy"
        np.save(short, np.load(measurement)[:2400])  # 0.2 s, where a lines segment is 0.5 s
        given, message = [f"measured.path={short}"], "short.npy: a signal of 0.200 s is shorter than one comparison"
    result = run_cli(*given, "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer", f"out={tmp_path / 'r'}",
                     env={"MLFLOW_TRACKING_URI": f"sqlite:///{tmp_path / 'mlflow.db'}"}, cwd=tmp_path)
    lines = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert result.returncode == 2 and len(lines) == 1 and message in lines[0], result.stderr[-2000:]
    assert not (tmp_path / "mlflow.db").exists() and not (tmp_path / "r").exists()  # no store opened, no report


def test_an_out_folder_that_holds_the_reference_is_refused_and_the_reference_kept(tmp_path):
    baseline = tmp_path / "baseline"
    baseline.mkdir()
    (baseline / "twin_report.json").write_text("the baseline")
    result = run_cli(f"measured.path={tmp_path / 'absent.npy'}", f"reference={baseline / 'twin_report.json'}",
                     f"out={baseline}", "tracking.enabled=false", cwd=tmp_path)
    assert result.returncode == 2
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith(f"error: out={baseline} is the folder of reference={baseline / 'twin_report.json'}")
    assert (baseline / "twin_report.json").read_text() == "the baseline"


def test_no_measurement_given_is_named():
    from omegaconf import OmegaConf

    from bearingtwin.errors import BearingTwinError
    from bearingtwin.twin.report import load_measurement

    with pytest.raises(BearingTwinError, match=r"^measured.path is missing: give measured.path=<file>"):
        load_measurement(OmegaConf.create({"path": "???", "channel": None, "fs": None, "rpm": None, "fault": None}))
    # A path to nothing is named by its setting, as diagnose's path= is (it had read "/x.mat: no such file").
    with pytest.raises(BearingTwinError, match=r"^measured.path=/nonexistent/x.mat: no such file$"):
        load_measurement(OmegaConf.create({"path": "/nonexistent/x.mat", "channel": None, "fs": None, "rpm": None,
                                           "fault": None, "check_fs": True}))


def test_a_reference_record_holds_its_operating_point_and_effects_so_the_new_one_names_what_changed(
        measurement, tmp_path):
    """A baseline of the rig (its 2.4 kHz mount resonance, the defect's depth fitted), then a record of
    the same rig in which an unbalance line appeared: with ``reference=`` the defect depth and the sensor
    direction are the baseline's, held, the resonance stays in the twin at the baseline's values (tried as
    changed, it is not: the mount is the same), and the unbalance is what is added."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.fs=12000", "simulator.rpm=1797", "simulator.duration=2.0",
                                             "simulator.sensor=outer_y"])
    changed = TwinModel("outer", cfg.bearing, cfg.simulator, seed=12).signal(
        {"simulator.defect.depth_mm": 0.004}, {"resonance": {"natural_frequency_hz": 2400.0, "damping_ratio": 0.07},
                                               "unbalance": {"level_db": 0.0}})
    np.save(tmp_path / "changed.npy", changed / 9.81)
    common = ["measured.fs=12000", "measured.rpm=1797", "measured.fault=outer", "tracking.enabled=false",
              "figures=false", *FAST, "operating_point.sensor=outer", "operating_point.defect_width_mm=0.533"]
    baseline = run_cli(f"measured.path={measurement}", f"out={tmp_path / 'baseline'}", "candidates=[resonance]", *common)
    assert baseline.returncode == 0, baseline.stderr[-2000:]
    first = json.loads((tmp_path / "baseline" / "twin_report.json").read_text())
    assert first["added"] == ["resonance"] and first["measured"]["fault"] == "outer"
    assert first["measured"]["geometry"]["n_balls"] == 9  # what a later run's bearing is compared with
    assert first["operating_point"]["defect_depth_mm"]["held"] is False

    result = run_cli(f"measured.path={tmp_path / 'changed.npy'}", f"out={tmp_path / 'changed'}",
                     "candidates=[resonance,unbalance]", f"reference={tmp_path / 'baseline' / 'twin_report.json'}", *common)
    assert result.returncode == 0, result.stderr[-2000:]
    report = json.loads((tmp_path / "changed" / "twin_report.json").read_text())
    held = report["operating_point"]
    assert held["defect_depth_mm"] == {"value": first["operating_point"]["defect_depth_mm"]["value"], "unit": "mm",
                                       "held": True}
    assert held["sensor"]["angle_deg"] == first["operating_point"]["sensor"]["angle_deg"] and held["sensor"]["held"]
    # The direction was left to fit and the reference filled it in: marked where the reference's record fitted any.
    unmarked = not first["operating_point"]["sensor"].get("every_direction_fits")
    assert held["sensor"].get("identified_by_reference", True) is unmarked
    assert f"sensor {held['sensor']['value']}{'' if unmarked else ' (the reference record hardly identified it)'}" in result.stdout
    # The held resonance, tried as changed, is found as held: nothing to fit, not ranked.
    assert [entry["effect"] for entry in report["ranking"]] == ["unbalance"] and report["found_nothing"] == ["resonance"]
    assert report["added"] == ["unbalance"]
    assert all(step["params"]["resonance"] == first["steps"][-1]["params"]["resonance"] for step in report["steps"])
    assert report["measured"]["reference"] == str(tmp_path / "baseline" / "twin_report.json")
    assert (f"reference: {tmp_path / 'baseline' / 'twin_report.json'} (its operating point held where this run gives "
            "none; its effects kept: resonance)") in result.stdout
    # The two records compared directly, no twin between them: the new line is what changed most (the line's power
    # moves the band levels and the statistics too).
    assert report["since_reference"][0]["view"] == "lines", report["since_reference"]
    line = re.search(r"a line at (\d+) Hz \(shaft order [\d.]+\) stands \d+ dB higher in the measurement",
                     report["since_reference"][0]["where"])
    assert line and abs(float(line.group(1)) - 1797 / 60) <= 4.0  # the shaft's line, at the 4 Hz lines resolution here
    assert f"since the reference record: lines: {line.group(0)}" in result.stdout

    # Another record of the unchanged rig, through a sensor four times as sensitive: nothing changed since the
    # reference in the shapes the views compare, so whatever the twin still misses is the rig's own, and no effect is
    # needed; the level, which a gain between the two records takes up there, is compared apart and named.
    again = TwinModel("outer", cfg.bearing, cfg.simulator, seed=13).signal(
        {"simulator.defect.depth_mm": 0.004}, {"resonance": {"natural_frequency_hz": 2400.0, "damping_ratio": 0.07}})
    np.save(tmp_path / "again.npy", 4 * again / 9.81)
    null = run_cli(f"measured.path={tmp_path / 'again.npy'}", f"out={tmp_path / 'again'}",
                   "candidates=[resonance,unbalance]", f"reference={tmp_path / 'baseline' / 'twin_report.json'}", *common)
    assert null.returncode == 0, null.stderr[-2000:]
    unchanged = json.loads((tmp_path / "again" / "twin_report.json").read_text())
    assert unchanged["since_reference"] == [] and unchanged["added"] == []
    assert unchanged["level_since_reference_db"] == pytest.approx(20 * np.log10(4), abs=1.0)
    assert re.search(r"since the reference record: the overall level is 1\d\.\d dB above the reference record's "
                     r"\(x [\d.]+\): a louder machine, or a sensor, mount or gain that changed; nothing else changed",
                     null.stdout), null.stdout
    assert unchanged["verdict"] == "no effect needed" and "verdict: no effect needed\n" in null.stdout
    assert "nothing changed beyond the measurement's own part-to-part scatter" in unchanged["summary"]
    # What the twin still misses there is said to be the rig's own, view by view.
    assert unchanged["summary"].count("Not explained by the library, unchanged since the reference record") == len(
        unchanged["unexplained"])


def test_a_reference_record_that_cannot_be_compared_says_why(measurement, tmp_path):
    """The reference's record is read again from the path its report names: gone, or taken at another rate or
    speed, it is not compared, and the report says why."""
    from types import SimpleNamespace

    from bearingtwin.config import load_bearing
    from bearingtwin.data.recording import Recording
    from bearingtwin.storage import file_digest
    from bearingtwin.twin.compare import Comparator, CompareSettings
    from bearingtwin.twin.report import compare_with_reference

    measured = Recording(np.load(measurement), 12000.0, 1797.0, "outer", source=str(measurement), channel="0")
    comparator = Comparator(measured, load_bearing("paper"), CompareSettings())
    earlier = tmp_path / "earlier.npy"  # the same samples in another file: a record of the unchanged rig
    np.save(earlier, np.load(measurement))
    np.savez(tmp_path / "two.npz", **{"0": np.load(measurement), "b": np.load(measurement)})
    about = {"path": str(earlier), "fs": 12000.0, "rpm": 1797.0, "channel": "0"}
    for change, words in [({"path": str(tmp_path / "gone.npy")}, f"its record {tmp_path / 'gone.npy'} is not there"),
                          ({"path": str(measurement)}, "it is this record itself"),
                          ({"file": {"path": str(earlier), "sha256": "0" * 64}}, "has changed since the reference was made"),
                          ({"path": str(tmp_path / "two.npz"), "channel": None}, "does not say which of its record's channels"),
                          ({"path": str(tmp_path / "two.npz"), "channel": "b"},
                           "read on channel b, this one on 0, which its file holds too: another sensor"),
                          ({"fs": 25600.0}, "taken at 25600 Hz, this one at 12000 Hz"),
                          ({"rpm": 1750.0}, "taken at 1750 rpm, this one at 1797 rpm")]:
        fit = SimpleNamespace(repeatability_db={v: 0.5 for v in VIEWS}, since_reference=None, reference_note="")
        given = {key: value for key, value in {**about, **change}.items() if value is not None}
        compare_with_reference(fit, comparator, measured, {"measured": given}, 0.5)
        assert fit.since_reference is None and words in fit.reference_note, fit.reference_note
    fit = SimpleNamespace(repeatability_db={v: 0.5 for v in VIEWS}, since_reference=None, reference_note="")
    stored = {"file": {"path": str(earlier), "sha256": file_digest(earlier)}}  # as a report written now records it
    compare_with_reference(fit, comparator, measured, {"measured": {**about, "path": "earlier.npy", **stored}}, 0.5)
    assert fit.since_reference == [] and fit.reference_note == ""  # found by its resolved path, and unchanged
    # Another format names its channel otherwise (a .mat's DE, an export's signal): still this rig's sensor.
    np.savez(tmp_path / "export.npz", DE=np.load(measurement))
    fit = SimpleNamespace(repeatability_db={v: 0.5 for v in VIEWS}, since_reference=None, reference_note="")
    compare_with_reference(fit, comparator, measured, {"measured": {**about, "path": str(tmp_path / "export.npz"),
                                                                    "channel": "DE"}}, 0.5)
    assert fit.since_reference == [] and fit.reference_note == ""


def test_a_value_held_from_a_reference_that_did_not_identify_it_is_marked():
    """Only values the reference filled in (left to fit here) and that its own record did not identify."""
    from bearingtwin.twin.report import mark_unidentified_by_reference

    operating = {"radial_load_n": {"value": 1163.0, "unit": "N", "held": True},
                 "clearance_um": {"value": 5.0, "unit": "um", "held": True},
                 "defect_depth_mm": {"value": 0.2, "unit": "mm", "held": True},
                 "defect_width_mm": {"value": 0.3, "unit": "mm", "held": False, "interval": [0.2, 0.4]}}
    earlier = {name: {"value": entry["value"], "interval": [20.0, 5000.0], "range": [20.0, 5000.0]}
               for name, entry in operating.items()}
    earlier["defect_depth_mm"]["interval"] = [0.1, 0.3]  # identified there
    operating["bearing.pitch_diameter_mm"] = {"value": 39.0, "unit": "mm", "held": True}  # held there from its own reference
    earlier["bearing.pitch_diameter_mm"] = {"value": 39.0, "held": True, "identified_by_reference": False}
    mark_unidentified_by_reference(operating, earlier, taken={"radial_load_n", "defect_depth_mm", "defect_width_mm",
                                                              "bearing.pitch_diameter_mm"})
    assert operating["radial_load_n"]["identified_by_reference"] is False
    assert operating["bearing.pitch_diameter_mm"]["identified_by_reference"] is False  # along a chain of references
    assert "identified_by_reference" not in operating["clearance_um"]  # the user gave it
    assert "identified_by_reference" not in operating["defect_depth_mm"]  # the reference identified it
    assert "identified_by_reference" not in operating["defect_width_mm"]  # fitted here, not held
    # Nearly any value fitting is as good as none (the summary's "hardly identified"); a sensor direction every
    # direction fitted for is one, held when only its race was given.
    hardly = {"value": 0.5, "interval": [0.1, 1.6], "range": [0.1, 2.0], "scale": "log"}
    sensor = {"value": "outer race, vertical", "race": "outer", "angle_deg": 90.0, "interval": [0.0, 180.0],
              "every_direction_fits": True}
    held = {"defect_width_mm": {"value": 0.5, "unit": "mm", "held": True},
            "sensor": {"value": "outer race, vertical", "held": True}}
    mark_unidentified_by_reference(held, {"defect_width_mm": hardly, "sensor": sensor},
                                   taken={"defect_width_mm", "sensor_angle_deg"})
    assert held["defect_width_mm"]["identified_by_reference"] is False and held["sensor"]["identified_by_reference"] is False
    given = {"sensor": {"value": "outer race, vertical", "held": True}}  # operating_point.sensor_angle_deg=90 given
    mark_unidentified_by_reference(given, {"sensor": sensor}, taken=set())
    assert "identified_by_reference" not in given["sensor"]


@pytest.mark.parametrize("content, message", [
    (None, "no such file"), ("not json", "not a JSON file"), ('{"verdict": "no effect needed"}', "not a twin_report.json")])
def test_a_bad_reference_is_one_line_and_exit_2(measurement, tmp_path, content, message):
    reference = tmp_path / "twin_report.json"
    if content is not None:
        reference.write_text(content)
    result = run_cli(f"measured.path={measurement}", "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer",
                     f"reference={reference}", f"out={tmp_path / 'r'}", "tracking.enabled=false", *FAST)
    assert result.returncode == 2
    (line,) = result.stderr.strip().splitlines()
    assert f"reference={reference}" in line and message in line
    assert not (tmp_path / "r").exists()


def test_a_speed_given_twice_the_true_one_is_refused_where_the_file_records_its_rate(tmp_path):
    """Given twice its speed, an outer race's record puts BPFO's comb on the given speed's BPFO, its second harmonic:
    a record without a shaft series of its own (the twin's) had it confirm the speed. The lines between that comb's
    harmonics are BPFO's own at the true speed: the speed is refused in one line naming it and the true one, though
    the rate the file records would have only been logged; the true speed is read."""
    from omegaconf import OmegaConf

    from bearingtwin.physics.simulator import simulate
    from bearingtwin.twin.report import load_measurement

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["bearing=er16k", "simulator.rpm=1500", "simulator.fs=25600",
                                             "simulator.duration=2", "simulator.sensor=outer_y",
                                             "simulator.load_y_n=-200", "effects=[noise]"])
    recording, _ = simulate("outer", cfg.bearing, cfg.simulator, cfg.effects)
    path = tmp_path / "record.npz"
    np.savez(path, signal=recording.signal, fs=25600.0)  # a rate the file records, no speed
    bearing = load_bearing("er16k")

    def measured(rpm):
        return OmegaConf.create({"path": str(path), "channel": None, "fs": None, "rpm": rpm, "fault": "outer",
                                 "check_fs": True})

    assert load_measurement(measured(1500), bearing).rpm == 1500
    with pytest.raises(BearingTwinError, match=r"^\S*record.npz: fs = 25600 Hz contradicts the shaft speed: .*BPFO's own "
                                               r"at a speed of 1500 rpm.*give the true speed with measured.rpm=<rev/min>"):
        load_measurement(measured(3000), bearing)


CWRU_RECORDS = data_root() / "cwru"


def test_a_unit_given_for_a_measurement_that_states_none_is_read_and_a_velocity_refused(measurement, tmp_path, caplog):
    """A WAV or a bare .npy cannot state its unit, and the twin had no setting for it: a velocity record passed for an
    acceleration, its tilt fitted as physics. measured.unit fills it in; a velocity is refused as a stated one is, and
    a unit a file contradicts is refused naming the setting."""
    from omegaconf import OmegaConf

    from bearingtwin.twin.report import read_measurement

    def measured(path, unit):
        return OmegaConf.create({"path": str(path), "channel": None, "fs": 12000, "rpm": 1797, "fault": "outer",
                                 "check_fs": False, "unit": unit})

    assert read_measurement(measured(measurement, "g"))[0].unit == "g"
    with pytest.raises(BearingTwinError, match=r"measured.npy: the record is in mm/s \(a velocity\); the twin simulates"):
        read_measurement(measured(measurement, "mm/s"))
    np.savez(tmp_path / "stated.npz", signal=np.load(measurement), fs=12000.0, unit="m/s^2")
    with pytest.raises(BearingTwinError, match=r"stated.npz: measured.unit=g contradicts the file's unit, m/s\^2$"):
        read_measurement(measured(tmp_path / "stated.npz", "g"))
    # A logger's volts, read through the sensor's sensitivity (scale: g per V).
    np.savez(tmp_path / "volts.npz", signal=0.1 * np.load(measurement), fs=12000.0, unit="V")
    volts = OmegaConf.merge(measured(tmp_path / "volts.npz", "g"), {"scale": 10})
    recording = read_measurement(volts)[0]
    assert recording.unit == "g" and "samples x 10 read in g (measured.scale=10 measured.unit=g; the file states V)" in \
        recording.meta["notes"]
    np.testing.assert_allclose(recording.signal, np.load(measurement), rtol=1e-12)
    # A labels row beside the file gives its unit where the settings do not, as a diagnosis reads it; against the
    # file's own it is refused naming the row, and a unit given on the command line holds, the row's said.
    (tmp_path / "labels.csv").write_text("record,state,unit\nplain.npy,outer,g\nstated.npz,outer,g\n")
    np.save(tmp_path / "plain.npy", np.load(measurement))
    assert read_measurement(measured(tmp_path / "plain.npy", None))[0].unit == "g"
    with pytest.raises(BearingTwinError, match=r"stated.npz: \S*labels.csv line 3: unit=g contradicts the file's unit, "
                                               r"m/s\^2$"):
        read_measurement(measured(tmp_path / "stated.npz", None))
    assert read_measurement(measured(tmp_path / "plain.npy", "m/s^2"))[0].unit == "m/s^2"
    # A row's scale reads a logger's volts through the sensor's sensitivity, its unit the product's.
    (tmp_path / "labels.csv").write_text("record,state,unit,scale\nvolts.npz,outer,g,10\n")
    from_row = read_measurement(measured(tmp_path / "volts.npz", None))[0]
    assert from_row.unit == "g" and from_row.meta["scale"] == 10.0
    np.testing.assert_allclose(from_row.signal, np.load(measurement), rtol=1e-12)
    with caplog.at_level("WARNING"):  # a unit given holds for the one file, the row's scale said not applied
        assert read_measurement(measured(tmp_path / "volts.npz", "V"))[0].unit == "V"
    assert "labels.csv line 2 gives scale 10, not applied: the measured.unit and measured.scale given hold" in caplog.text


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
def test_a_speed_given_a_few_percent_off_is_named_with_the_one_the_shaft_series_reads(tmp_path):
    """A nameplate's 1800 rpm for record 131's 1772 passes the rate check's 2 %, and the twin had then sought every
    defect line beside where it stands without a word (diagnose says so): the speed the shaft series reads is named,
    with the setting that gives it; at the right speed nothing is said."""
    from omegaconf import OmegaConf

    from bearingtwin.data.formats import load_recording
    from bearingtwin.twin.report import read_measurement, speed_read_off

    np.savez(tmp_path / "pump.npz", signal=load_recording(CWRU_RECORDS / "12k_Drive_End_OR007@6_1_131.mat").signal,
             fs=12000.0, unit="g")

    def measured(rpm):
        return read_measurement(OmegaConf.create({"path": str(tmp_path / "pump.npz"), "channel": None, "fs": None,
                                                  "rpm": rpm, "fault": "outer", "check_fs": False}))[0]

    assert speed_read_off(measured(1800)) == (
        "the shaft's harmonic series reads 1772 rpm, -1.5 % from the stated 1800 rpm: every defect line is read where "
        "the stated speed puts it; if the sampling rate is right, give measured.rpm=1772")
    assert speed_read_off(measured(1772)) is None


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
def test_a_measurement_that_states_no_speed_is_held_at_the_one_its_tachometer_gives(tmp_path):
    """A file of an accelerometer and a tachometer, no speed stated: the twin had refused it, asking for the speed
    the pulses hold. Read at one mark a turn (the record's shaft series confirms it), it is held at that speed, said
    so; at two marks a turn the series cannot tell 1772 rpm from 3544 rpm, and the refusal names both; a stated speed
    the pulses contradict is said to be."""
    from omegaconf import OmegaConf

    from bearingtwin.data.formats import load_recording
    from bearingtwin.twin.report import read_measurement

    recording = load_recording(CWRU_RECORDS / "12k_Drive_End_IR007_1_106.mat")
    t = np.arange(recording.signal.size) / recording.fs
    for marks in (1, 2):
        np.savez(tmp_path / f"marks{marks}.npz", acc=recording.signal, fs=recording.fs,
                 tach=5.0 * ((t * marks * 1772.0 / 60.0) % 1 < 0.1))
    np.savez(tmp_path / "stated.npz", acc=recording.signal, fs=recording.fs, rpm=1300.0,
             tach=5.0 * ((t * 1772.0 / 60.0) % 1 < 0.1))

    def measured(name):
        return OmegaConf.create({"path": str(tmp_path / name), "channel": None, "fs": None, "rpm": None,
                                 "fault": "inner", "check_fs": True})

    held, _ = read_measurement(measured("marks1.npz"))
    assert held.rpm == pytest.approx(1772.0, rel=1e-3) and held.meta["rpm_origin"] == "tachometer"
    with pytest.raises(BearingTwinError, match=r"marks2.npz: the file does not state its speed \(its tachometer channel "
                                               r"tach pulses 59.07 times a second: 3544 rpm at 1 pulse per revolution or "
                                               r"1772 rpm at 2 pulses per revolution, which the record's shaft series "
                                               r"does not tell apart\); give measured.rpm=<rev/min>"):
        read_measurement(measured("marks2.npz"))
    stated, _ = read_measurement(measured("stated.npz"))
    assert stated.rpm == 1300.0 and ("the tachometer channel tach pulses 29.53 times a second, 1772 rpm at 1 pulse per "
                                     "revolution, not near the stated 1300 rpm") in " ".join(stated.meta["notes"])


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
@pytest.mark.parametrize("name", ["12k_Drive_End_OR007@6_1_131.mat", "12k_Drive_End_IR007_1_106.mat"])
def test_a_real_records_speed_typed_a_whole_factor_too_high_is_refused_beside_its_files_rate(tmp_path, name):
    """A real race fault's drive-end channel in an .npz stating its rate alone: read at its true speed, refused at twice
    and three times it (its shaft series and defect comb stand where the true speed puts them)."""
    from omegaconf import OmegaConf

    from bearingtwin.data.cwru import load_cwru
    from bearingtwin.twin.report import load_measurement

    recording = load_cwru(CWRU_RECORDS / name)
    np.savez(tmp_path / "record.npz", signal=recording.signal, fs=recording.fs)

    def measured(rpm):
        return OmegaConf.create({"path": str(tmp_path / "record.npz"), "channel": None, "fs": None, "rpm": rpm,
                                 "fault": recording.fault, "check_fs": True})

    assert load_measurement(measured(recording.rpm), load_bearing("cwru_6205")).rpm == recording.rpm
    # Both given by settings (a bare array): the refusal names the rate, and the speeds the lines stand at too.
    np.save(tmp_path / "bare.npy", recording.signal)
    bare = OmegaConf.create({"path": str(tmp_path / "bare.npy"), "channel": None, "fs": recording.fs,
                             "rpm": 2 * recording.rpm, "fault": recording.fault, "check_fs": True})
    with pytest.raises(BearingTwinError, match=rf"give the true rate with measured.fs=<Hz> \(or the true speed with "
                                               rf"measured.rpm=<rev/min>: its lines stand where they belong at "
                                               rf"{recording.rpm:g} rpm \(2 times lower\)"):
        load_measurement(bare, load_bearing("cwru_6205"))
    for factor in (2, 3):
        with pytest.raises(BearingTwinError, match=rf"the record's lines stand where they belong at {recording.rpm:g} rpm "
                                                   rf"\({factor} times lower\).*give the true speed with measured.rpm"):
            load_measurement(measured(recording.rpm * factor), load_bearing("cwru_6205"))


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
def test_a_rate_given_against_the_names_one_that_the_shaft_line_bears_out_is_refused_in_a_line():
    """``measured.fs=48000`` for a ``12k_`` file had been refused on the shaft series alone, in a paragraph naming
    three candidate rates; the name and the shaft line are two witnesses against one typed number, as a diagnosis
    says. The name's own rate given is read."""
    from omegaconf import OmegaConf

    from bearingtwin.twin.report import load_measurement

    path = CWRU_RECORDS / "12k_Drive_End_OR007@6_1_131.mat"

    def measured(fs):
        return OmegaConf.create({"path": str(path), "channel": None, "fs": fs, "rpm": None, "fault": None,
                                 "check_fs": True})

    with pytest.raises(BearingTwinError, match=(
            r"12k_Drive_End_OR007@6_1_131.mat: measured.fs=48000 Hz given, where its name states 12000 Hz, and the "
            r"shaft line stands where it belongs at 12000 Hz, not at 48000 Hz: give this file no rate \(its name's is "
            r"read\)$")):
        load_measurement(measured(48000), load_bearing("cwru_6205"))
    assert load_measurement(measured(12000), load_bearing("cwru_6205")).fs == 12000


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
def test_a_real_records_speed_typed_at_half_is_refused_though_its_cage_lines_witness_it(tmp_path):
    """An outer-race record's drive-end channel as a bare array, its speed typed at half: the shaft series stands at
    twice the speed's place, but the cage's envelope lines, read at their second harmonic, had witnessed the rate, and
    the twin was fitted at half the speed, its summary blaming a gear mesh for the record's own lines. Refused naming
    the speed, twice the one typed, at which the shaft series stands at its place; the true speed is read."""
    from omegaconf import OmegaConf

    from bearingtwin.data.cwru import load_cwru
    from bearingtwin.twin.report import load_measurement

    recording = load_cwru(CWRU_RECORDS / "12k_Drive_End_OR007@6_0_130.mat")
    np.save(tmp_path / "bare.npy", recording.signal)

    def measured(rpm):
        return OmegaConf.create({"path": str(tmp_path / "bare.npy"), "channel": None, "fs": recording.fs, "rpm": rpm,
                                 "fault": recording.fault, "check_fs": True})

    half = recording.rpm / 2
    with pytest.raises(BearingTwinError, match=rf"bare.npy: measured.rpm={half:g} puts the shaft line at "
                                               rf"{half / 60:.2f} Hz, but .*; the shaft series and the record's lines "
                                               rf"stand where they belong at {recording.rpm:g} rpm \(2 times higher\): "
                                               rf"give the true speed with measured.rpm=<rev/min>, or "
                                               rf"measured.check_fs=false if {half:g} rpm is true$"):
        load_measurement(measured(half), load_bearing("cwru_6205"))
    assert load_measurement(measured(recording.rpm), load_bearing("cwru_6205")).rpm == recording.rpm
    # Typed at two thirds: its BPFO comb and its shaft line stand 1.5 times their places, where one rate puts both.
    # Which of the two settings is wrong no line tells: both readings lead, the evidence after them (the line had
    # opened with the rate and a series' reading it then overturned).
    with pytest.raises(BearingTwinError) as refused:
        load_measurement(measured(1200.0), load_bearing("cwru_6205"))
    assert re.match(r"^\S*bare.npy: measured.fs=12000 and measured.rpm=1200 do not fit the record: its lines stand where "
                    r"about 1800 rpm puts them at 12000 Hz \(1.5 times the speed given\), or about 8000 Hz at 1200 rpm; "
                    r"give the true speed with measured.rpm=<rev/min> or the true rate with measured.fs=<Hz>, or "
                    r"measured.check_fs=false if both 12000 Hz and 1200 rpm are true \(fs = 12000 Hz contradicts .*BPFO "
                    r"comb stands at 1.5 times its frequency", str(refused.value)), str(refused.value)


@pytest.mark.skipif(not CWRU_RECORDS.is_dir(), reason=f"CWRU records not present in {CWRU_RECORDS}")
def test_a_doubt_over_a_typed_speed_names_the_speed_the_lines_imply(tmp_path, caplog):
    """A ball record's envelope lines do not decide: typed at twice its speed beside its file's rate, it is read with
    a doubt, which names the speed its shaft series implies (it had named only a rate the file does not have)."""
    from omegaconf import OmegaConf

    from bearingtwin.data.cwru import load_cwru
    from bearingtwin.twin.report import load_measurement

    recording = load_cwru(CWRU_RECORDS / "12k_Drive_End_B007_1_119.mat")
    np.savez(tmp_path / "record.npz", signal=recording.signal, fs=recording.fs)
    measured = OmegaConf.create({"path": str(tmp_path / "record.npz"), "channel": None, "fs": None,
                                 "rpm": 2 * recording.rpm, "fault": "ball", "check_fs": True})
    load_measurement(measured, load_bearing("cwru_6205"))
    assert f"or, at 12000 Hz, a speed of {recording.rpm:.0f} rpm (measured.rpm)" in caplog.text


def test_a_state_given_against_the_labels_row_beside_the_file_is_held_and_said(tmp_path, caplog):
    """measured.fault=inner on a file whose labels.csv row says normal: the given state holds for the one file the
    command names (as diagnose's rpm= and fs= do), but it had been held without a word."""
    import logging

    from omegaconf import OmegaConf

    from bearingtwin.testrig import RigOperatingPoint, simulate_rig
    from bearingtwin.twin.report import read_measurement

    np.save(tmp_path / "healthy.npy", simulate_rig("normal", RigOperatingPoint(rpm=1797, fs=12000, duration_s=1.0,
                                                                                 unit="g"), seed=0))
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nhealthy.npy,normal,1797,12000\n")

    def measured(fault):
        return OmegaConf.create({"path": str(tmp_path / "healthy.npy"), "channel": None, "fs": None, "rpm": None,
                                 "fault": fault, "check_fs": False, "unit": "g"})

    with caplog.at_level(logging.WARNING, logger="bearingtwin.twin.report"):
        recording, _ = read_measurement(measured("inner"))
    assert recording.fault == "inner" and recording.rpm == 1797.0
    said = [record.getMessage() for record in caplog.records if "given where" in record.getMessage()]
    assert len(said) == 1 and "measured.fault=inner given where" in said[0] and "says state=normal" in said[0], said
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="bearingtwin.twin.report"):
        assert read_measurement(measured("normal"))[0].fault == "normal"
        # Every value given: the row is still read to say where it disagrees; a speed within 1 % agrees.
        every = OmegaConf.merge(measured("inner"), {"rpm": 1797.5, "fs": 12000.0})
        assert read_measurement(every)[0].fault == "inner"
    said = [record.getMessage() for record in caplog.records if "given where" in record.getMessage()]
    assert len(said) == 1 and "measured.fault=inner given where" in said[0] and "rpm=" not in said[0], said


def test_a_rate_the_file_records_that_the_shaft_line_contradicts_is_kept_and_marked_for_the_summary(tmp_path):
    """A logger's note types 1743 rpm for a shaft at 1797 (its time stamps give the rate): the rate is kept, the
    contradiction had been logged only, and the closing summary read as if nothing were in doubt."""
    from omegaconf import OmegaConf

    from bearingtwin.testrig import RigOperatingPoint, simulate_rig
    from bearingtwin.twin.report import check_measurement, read_measurement

    point = RigOperatingPoint(rpm=1797, fs=12000, duration_s=2.0, radial_load_n=500.0, unit="g")
    x = simulate_rig("outer", point, {"unbalance": {"level_db": 6.0}}, seed=3)
    t = np.arange(x.size) / 12000.0
    for name, speed in (("typed_off.csv", 1743), ("typed_right.csv", 1797)):
        with open(tmp_path / name, "w") as handle:
            handle.write(f"Speed: {speed} rpm\ntime_s,acc (g)\n")
            handle.writelines(f"{a:.6f},{b:.6e}\n" for a, b in zip(t, x))
    bearing = load_bearing("cwru_6205")
    marked = {}
    for name in ("typed_off.csv", "typed_right.csv"):
        cfg = OmegaConf.create({"path": str(tmp_path / name), "channel": None, "fs": None, "rpm": None,
                                "fault": "outer", "check_fs": True})
        recording, channels = read_measurement(cfg)
        marked[name] = check_measurement(cfg, recording, channels, bearing).meta.get("rate_contradicted")
    assert marked["typed_off.csv"].startswith("fs = 12000 Hz contradicts the shaft speed: at 1743 rpm"), marked
    assert marked["typed_right.csv"] is None
