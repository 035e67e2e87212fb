"""Train on the twin, test on real CWRU bearings: protocol, operating points, end to end, report.

Reads the CWRU records in place (skipped when they are absent). The calibration report is
a small ``twin_report.json`` in the format ``bearingtwin-twin`` writes (bare step + one
``noise`` step), so the test does not depend on the committed study.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from omegaconf import OmegaConf, open_dict
from processes import run_module

from bearingtwin.config import CONF_DIR, data_root
from bearingtwin.data.build import build_dataset
from bearingtwin.data.cwru import load_cwru
from bearingtwin.data.twin_to_real import (TWIN_PREFIX, check_protocol, healthy_twin_rms, merged_calibration,
                                          with_base_params)
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.tracking.reports import run_report

DATA = data_root() / "cwru"
pytestmark = pytest.mark.skipif(not (DATA / "normal_0_97.mat").is_file(), reason="CWRU records not present")

CALIBRATION = {"normal_0_97", "12k_Drive_End_OR007@6_0_130"}
SMALL = [
    "data.twin.duration=0.5",
    "data.twin.windows_per_record=2",
    "data.test.windows_per_record=3",
    "data.test.loads=[1]",
    "features.progress=false",
    "search.population=3",
    "search.iterations=1",
    "search.windows=2",
    "data.calibration.healthy.step=0",
    "data.calibration.validation_windows_per_record=2",
]


def compose_train(overrides):
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        return compose("train", overrides=["data=twin_to_real", "bearing=cwru_6205", *overrides])


def test_twin_at_the_records_speeds_and_no_measured_window_in_training(report_path, tmp_path):
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=1",
                                 f"paths.cache_dir={tmp_path}"])
    dataset = build_dataset(cfg)
    train, test = dataset.fixed_split
    tests = [p for p in dataset.records if not p.startswith(TWIN_PREFIX) and Path(p).stem not in CALIBRATION]
    assert sorted(Path(p).name for p in tests) == ["12k_Drive_End_B007_1_119.mat", "12k_Drive_End_IR007_1_106.mat",
                                                  "12k_Drive_End_OR007@6_1_131.mat"]
    # Speeds: each file's measured rpm (test and calibration records), every state at each.
    files = [DATA / Path(p).name for p in tests] + [DATA / f"{stem}.mat" for stem in CALIBRATION]
    rpms = sorted({round(load_cwru(f).rpm, 1) for f in files})
    twin_records = [p for p in dataset.records if p.startswith(TWIN_PREFIX)]
    assert twin_records == [f"{TWIN_PREFIX}{fault}@{rpm:g}rpm" for fault in FAULTS for rpm in rpms]
    assert 1797 not in rpms and len(rpms) >= 3  # 1796 (0 hp) and the 1 hp speeds, not the nominal one
    # Training windows come only from twin records, test windows only from the 1 hp files.
    assert all(dataset.records[i].startswith(TWIN_PREFIX) for i in dataset.record_ids[train])
    assert {Path(dataset.records[i]).name for i in dataset.record_ids[test]} == {Path(p).name for p in tests}
    assert set(dataset.labels[test]) == {1, 2, 3} and set(dataset.labels[train]) == {0, 1, 2, 3}
    assert len(train) == 4 * len(rpms) * 2 and len(test) == 3 * 3
    # Validation: windows of the two 0 hp calibration records only, apart from both training and test.
    validation = dataset.validation
    assert {Path(dataset.records[i]).stem for i in dataset.record_ids[validation]} == CALIBRATION
    assert len(validation) == 2 * 2 and not set(validation) & (set(train) | set(test))
    assert sorted(dataset.labels[validation]) == [0, 0, 3, 3]
    # Per-window normalization makes twin (m/s^2) and CWRU (g) windows scale-free alike.
    assert np.allclose(dataset.windows.std(axis=1), 1.0) and np.allclose(dataset.windows.mean(axis=1), 0.0, atol=1e-9)


@pytest.mark.parametrize("stem", ["12k_Drive_End_IR007_0_105", "12k_Drive_End_OR007@6_1_131"])
def test_calibration_on_a_record_outside_the_protocol_is_refused(stem):
    cfg = compose_train([f"data.calibration.records=[normal_0_97,'{stem}']"])
    with pytest.raises(BearingTwinError, match=rf"data\.calibration\.records: {stem} is not a calibration record"):
        check_protocol(dict(cfg.data))


def test_testing_at_the_calibration_load_is_refused():
    cfg = compose_train(["data.test.loads=[0,1]"])
    with pytest.raises(BearingTwinError, match=r"data\.test\.loads: 0 hp is the calibration load"):
        check_protocol(dict(cfg.data))


def test_a_reports_sensor_direction_is_a_base_parameter_even_where_the_config_leaves_it_null():
    """bearingtwin-twin reports the sensor it fitted (simulator.sensor, simulator.sensor_angle_deg),
    and the simulator config holds sensor_angle_deg as null: set, not refused; a key no config has is."""
    simulator = {"sensor": "outer_y", "sensor_angle_deg": None, "defect": {"width_mm": 0.5}}
    fitted = {"simulator.sensor": "outer_x", "simulator.sensor_angle_deg": 90.0, "simulator.defect.width_mm": 0.2}
    bearing, twin = with_base_params({"name": "cwru_6205"}, simulator, fitted, "twin_report.json")
    assert twin == {"sensor": "outer_x", "sensor_angle_deg": 90.0, "defect": {"width_mm": 0.2}}
    assert simulator["sensor_angle_deg"] is None and bearing == {"name": "cwru_6205"}  # copies
    with pytest.raises(BearingTwinError, match="twin_report.json: base parameter simulator.sensor_gain is no bearing"):
        with_base_params({}, simulator, {"simulator.sensor_gain": 2.0}, "twin_report.json")


def test_step_beyond_the_report_names_the_field(report_path, tmp_path):
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=2",
                                 f"paths.cache_dir={tmp_path}"])
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.step=2: \S+/twin_report\.json has steps 0\.\.1"):
        build_dataset(cfg)


def test_train_end_to_end_and_the_sim2real_report(report_path, tmp_path):
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    # The calibrated steps 0 and 1, then step 1 with an effect set by hand (outside the protocol).
    for name, extra in (("step0", ["data.calibration.step=0"]), ("step1", ["data.calibration.step=1", "band_power_by_calibration=true"]),
                        ("hand", ["data.calibration.step=1", "effects=[preload]"]),
                        ("variants", ["data.calibration.step=1", "+data.twin.variants.spin_slip.jitter=[0.01,0.4]"])):
        done = run_module(
            "bearingtwin.cli.train", "classifier=svm", "features=envelope_orders",
            *(o for o in SMALL if not o.startswith("features.")), *extra,
            f"data.calibration.report={report_path}", "data=twin_to_real",
            "bearing=cwru_6205", f"tracking.uri={uri}", f"paths.cache_dir={tmp_path}/cache",
            f"hydra.run.dir={tmp_path}/{name}", cwd=tmp_path, timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
        assert ("band power: " in done.stdout) == ("band_power_by_calibration=true" in extra)
    client = MlflowClient(uri)
    runs = client.search_runs([client.get_experiment_by_name("bearingtwin").experiment_id])
    assert {r.info.status for r in runs} == {"FINISHED"} and {r.data.metrics["n_test"] for r in runs} == {9.0}
    import csv
    for run in runs:  # which record fails: one row per test file, averaging to the run's accuracy
        with open(client.download_artifacts(run.info.run_id, "per_record.csv", str(tmp_path))) as handle:
            per_record = list(csv.DictReader(handle))
        assert [(row["record"], row["class"], row["windows"]) for row in per_record] == [
            ("12k_Drive_End_IR007_1_106.mat", "inner", "3"), ("12k_Drive_End_B007_1_119.mat", "ball", "3"),
            ("12k_Drive_End_OR007@6_1_131.mat", "outer", "3")]
        assert np.mean([float(row["accuracy"]) for row in per_record]) == pytest.approx(run.data.metrics["accuracy"], abs=1e-4)
        # No healthy test window: no recall or F1 for it (a 0 would read as a class the model fails).
        assert "recall_normal" not in run.data.metrics and "f1_normal" not in run.data.metrics
        with open(client.download_artifacts(run.info.run_id, "per_class.csv", str(tmp_path))) as handle:
            (normal,) = [row for row in csv.DictReader(handle) if row["class"] == "normal"]
        assert normal["recall"] == normal["f1"] == "—"
    (chosen,) = [r.data.metrics for r in runs if r.data.params.get("band_power_by_calibration") == "True"]
    assert chosen["band_power_kept"] == float(chosen["band_power_calibration_accuracy"] >= chosen["lines_only_calibration_accuracy"])
    assert chosen["calibration_accuracy"] == chosen["band_power_calibration_accuracy" if chosen["band_power_kept"]
                                                   else "lines_only_calibration_accuracy"]
    for run in runs:  # the calibration records, scored apart: 2 healthy + 2 outer-race windows
        val = {k: v for k, v in run.data.metrics.items() if k.startswith("calibration_")}
        assert set(val) == {"calibration_accuracy", "calibration_recall_normal", "calibration_recall_outer"}
        assert val["calibration_accuracy"] == pytest.approx((val["calibration_recall_normal"] + val["calibration_recall_outer"]) / 2)

    out = tmp_path / "sim2real.md"
    marker = "<!-- generated by bearingtwin-report: text between these lines is rewritten -->"
    out.write_text(f"# Hand-written title\n\n{marker}\nold table\n{marker}\n\nHand-written prose.\n")
    # Without force the smoke-sized runs are refused against a file of full-size results, and nothing the
    # report would write (its JSON and figures beside the markdown) replaces what is there.
    out.with_suffix(".json").write_text("[]")
    with pytest.raises(BearingTwinError, match="holds results of larger runs than these"):
        run_report("sim2real", {"uri": uri, "out": str(out)})
    assert "old table" in out.read_text() and out.with_suffix(".json").read_text() == "[]"
    assert not out.with_suffix(".png").exists()
    # force: a generated section of unknown runs counts as full size, and these runs are smoke-sized
    report = run_report("sim2real", {"uri": uri, "out": str(out), "force": "true"})
    written = out.read_text()  # the prose around the generated section survives, the old table does not
    assert written.startswith("# Hand-written title\n") and written.endswith("Hand-written prose.\n")
    assert "old table" not in written and report.markdown.strip() in written
    rows = json.loads(out.with_suffix(".json").read_text())
    assert [row["effects"] for row in rows] == [[], ["noise"], ["noise"], ["noise", "preload"]]
    assert [row["hand_set_effects"] for row in rows] == [[], [], [], ["preload"]]
    assert [row["variants"] for row in rows] == [{}, {}, {"spin_slip.jitter": [0.01, 0.4]}, {}]
    assert rows[3]["effect_params"]["preload"] == {"interference_um": 20.0}  # conf/effects/preload.yaml
    assert "twin + noise + preload (hand-set)" in report.markdown
    assert "twin + noise + spin_slip.jitter ∈ {0.01, 0.4} (variants)" in report.markdown
    assert {row["method"] for row in rows} == {"envelope_orders+band_power+svm"}
    for row in rows:  # one seed each: 2 healthy windows of record 97
        assert 0.0 <= row["calibration_accuracy_mean"] <= 1.0 and row["calibration_recall_normal_mean"] in (0.0, 0.5, 1.0)
    runs = [r for r in runs if "effects.preload.interference_um" not in r.data.params
            and not any(k.startswith("data.twin.variants.") for k in r.data.params)]
    for row, run_step in zip(rows, (0, 1)):
        assert {"effects", "accuracy_mean", "accuracy_std", "n_test_windows", "test_records"} <= set(row)
        assert row["n_test_windows"] == 9 and 0.0 <= row["accuracy_mean"] <= 1.0 and row["accuracy_std"] == 0.0
        assert "12k_Drive_End_OR007@6_1_131.mat" in row["test_records"] and len(row["test_records"]) == 3
        assert np.sum(row["confusion"]) == 9
        (run,) = [r for r in runs if r.data.params["data.calibration.step"] == str(run_step)]
        assert row["accuracy_mean"] == pytest.approx(run.data.metrics["accuracy"])
        assert row["calibration_accuracy_mean"] == pytest.approx(run.data.metrics["calibration_accuracy"])
    assert "twin + noise" in report.markdown


def test_a_hand_set_effect_the_calibration_already_found_is_refused(report_path, tmp_path):
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=1",
                                 "effects=[noise]", f"paths.cache_dir={tmp_path}"])
    with pytest.raises(BearingTwinError, match="effects: noise is already in the calibrated twin"):
        build_dataset(cfg)


@pytest.fixture(scope="module")
def healthy_report_path(tmp_path_factory):
    """A healthy record's report in bearingtwin-twin's format: bare step + one noise step."""
    path = tmp_path_factory.mktemp("healthy") / "twin_report.json"
    steps = [{"effects": [], "params": {}, "base_params": {"simulator.defect.depth_mm": 0.02}},
             {"effects": ["noise"], "params": {"noise": {"snr_db": -3.0, "spectral_slope": 1.0}},
              "base_params": {"simulator.defect.depth_mm": 0.03}}]
    path.write_text(json.dumps({"steps": steps}))
    return path


@pytest.fixture(scope="module")
def slip_report_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("outer") / "twin_report.json"
    steps = [{"effects": [], "params": {}, "base_params": {"simulator.defect.depth_mm": 0.01}},
             {"effects": ["slip"], "params": {"slip": {"jitter": 0.01}}, "base_params": {"simulator.defect.depth_mm": 0.004}}]
    path.write_text(json.dumps({"steps": steps}))
    return path


def test_the_healthy_records_noise_joins_every_twin_after_the_fault_records_effects(healthy_report_path,
                                                                                    slip_report_path, tmp_path):
    calibration = {"report": str(slip_report_path), "step": 1, "records": ["normal_0_97"],
                   "healthy": {"record": "normal_0_97", "report": str(healthy_report_path), "step": 1}}
    base, effects = merged_calibration(calibration)
    # Base parameters are the fault record's (a defect depth fitted on a healthy record means nothing).
    assert base == {"simulator.defect.depth_mm": 0.004}
    assert list(effects) == ["slip", "noise"] and effects["noise"] == {"snr_db": -3.0, "spectral_slope": 1.0}
    assert merged_calibration({**calibration, "healthy": {**calibration["healthy"], "step": 0}})[1] == {"slip": {"jitter": 0.01}}
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.healthy: effect noise was found on both"):
        merged_calibration({**calibration, "report": str(healthy_report_path)})
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.healthy\.record=12k_Drive_End_OR007@6_0_130: its name says outer, not healthy"):
        merged_calibration({**calibration, "records": ["12k_Drive_End_OR007@6_0_130"],
                            "healthy": {**calibration["healthy"], "record": "12k_Drive_End_OR007@6_0_130"}})

    # In the dataset: windows carry their record's speed, and the -3 dB noise is in every twin state.
    def dataset(healthy_step):
        cfg = compose_train(SMALL + [f"data.calibration.report={slip_report_path}", "data.calibration.step=1",
                                     f"data.calibration.healthy.report={healthy_report_path}",
                                     f"data.calibration.healthy.step={healthy_step}", "data.normalize_windows=false",
                                     # each state's own SNR (absolute: test_absolute_noise_level_gives_...)
                                     "data.calibration.healthy.noise_level=relative", f"paths.cache_dir={tmp_path}"])
        return build_dataset(cfg)

    quiet, noisy = dataset(0), dataset(1)
    for part in (quiet, noisy):
        expected = [float(r.split("@")[1].removesuffix("rpm")) if r.startswith(TWIN_PREFIX) else load_cwru(r).rpm
                    for r in part.records]
        assert np.allclose(part.window_rpms, np.asarray(expected)[part.record_ids])
    train = quiet.fixed_split[0]
    for label in range(len(FAULTS)):
        rows = train[quiet.labels[train] == label]
        # Noise 3 dB above the bearing signal: each twin window's power grows about threefold.
        ratio = np.mean(noisy.windows[rows] ** 2) / np.mean(quiet.windows[rows] ** 2)
        assert 2.0 < ratio < 4.5, (FAULTS[label], ratio)


def test_an_unknown_noise_level_is_refused_before_any_simulation(report_path, healthy_report_path, tmp_path, monkeypatch):
    import bearingtwin.data.twin_to_real as twin_to_real

    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated before the configuration was checked")

    monkeypatch.setattr(twin_to_real, "simulate", no_simulation)
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0",
                                 f"data.calibration.healthy.report={healthy_report_path}", "data.calibration.healthy.step=1",
                                 "data.calibration.healthy.noise_level=loud", f"paths.cache_dir={tmp_path}"])
    with pytest.raises(BearingTwinError, match=r"data\.calibration\.healthy\.noise_level='loud': choose absolute or relative"):
        build_dataset(cfg)


def test_a_healthy_report_whose_noise_a_reference_held_keeps_its_level(report_path, healthy_report_path, tmp_path,
                                                                        monkeypatch):
    """A healthy record's report made with reference= gives its noise at the reference's absolute level, which its
    snr_db refers to: noise_level=absolute keeps that level (the healthy twin's would change the floor), and
    noise_level=relative, which has no ratio to keep, is refused before any simulation."""
    import bearingtwin.data.twin_to_real as twin_to_real

    held = tmp_path / "held" / "twin_report.json"
    held.parent.mkdir()
    steps = json.loads(healthy_report_path.read_text())["steps"]
    steps[1]["params"]["noise"]["reference_rms"] = 0.25
    held.write_text(json.dumps({"steps": steps}))

    class Simulated(Exception):
        pass

    def simulated(*args, **kwargs):
        raise Simulated(args)

    def overwritten(*args, **kwargs):
        raise AssertionError("the held level was replaced by the healthy twin's")

    monkeypatch.setattr(twin_to_real, "simulate", simulated)
    monkeypatch.setattr(twin_to_real, "simulate_variants", simulated)
    monkeypatch.setattr(twin_to_real, "healthy_twin_rms", overwritten)

    def dataset(noise_level):
        return build_dataset(compose_train(SMALL + [
            f"data.calibration.report={report_path}", "data.calibration.step=0",
            f"data.calibration.healthy.report={held}", "data.calibration.healthy.step=1",
            f"data.calibration.healthy.noise_level={noise_level}", f"paths.cache_dir={tmp_path}"]))

    with pytest.raises(BearingTwinError, match=r"^data\.calibration\.healthy\.noise_level=relative: the calibration's "
                                               r"noise is held at an absolute level \(reference_rms=0\.25 m/s\^2"):
        dataset("relative")
    with pytest.raises(Simulated) as reached:
        dataset("absolute")
    variants = reached.value.args[0][3]
    assert all(effects["noise"]["reference_rms"] == 0.25 for _, effects in variants)


@pytest.fixture(scope="module")
def white_noise_report_path(tmp_path_factory):
    """A healthy record's report whose noise is white (its level in a short window is then tight), fitted on a
    healthy twin with some unbalance (a base parameter that changes the healthy signal, unlike a defect depth)."""
    path = tmp_path_factory.mktemp("white") / "twin_report.json"
    steps = [{"effects": [], "params": {}, "base_params": {"simulator.defect.depth_mm": 0.02}},
             {"effects": ["noise"], "params": {"noise": {"snr_db": -3.0, "spectral_slope": 0.0}},
              "base_params": {"simulator.defect.depth_mm": 0.03, "simulator.eccentricity_mm": 0.02}}]
    path.write_text(json.dumps({"steps": steps}))
    return path


def test_absolute_noise_level_gives_every_twin_state_the_healthy_twins_noise_floor(report_path, white_noise_report_path,
                                                                                  tmp_path):
    """noise_level=absolute: record 97's noise, fitted as a ratio to its healthy twin's power, is one absolute floor
    for every state; relative: each state's own power sets it, so a loud fault gets a loud floor."""
    from bearingtwin.physics.simulator import simulate

    def dataset(healthy_step, noise_level):
        cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0",
                                     f"data.calibration.healthy.report={white_noise_report_path}",
                                     f"data.calibration.healthy.step={healthy_step}",
                                     f"data.calibration.healthy.noise_level={noise_level}",
                                     "data.normalize_windows=false", f"paths.cache_dir={tmp_path}"])
        return cfg, build_dataset(cfg)

    cfg, quiet = dataset(0, "absolute")
    _, absolute = dataset(1, "absolute")
    _, relative = dataset(1, "relative")
    assert absolute.records == quiet.records == relative.records
    train, test = quiet.fixed_split
    np.testing.assert_array_equal(absolute.windows[test], quiet.windows[test])  # the real windows get no noise

    # The reference: the noise-free healthy twin with the healthy report's base parameters, at record 97's speed.
    healthy = load_cwru(DATA / "normal_0_97.mat")
    bearing = OmegaConf.to_container(cfg.bearing)
    simulator = {**OmegaConf.to_container(cfg.simulator), "fs": 12000.0, "duration": 0.5, "sensor": "outer_y"}
    fitted = {**simulator, "rpm": healthy.rpm, "eccentricity_mm": 0.02,
              "defect": {**simulator["defect"], "depth_mm": 0.03}}
    reference_rms = float(simulate("normal", bearing, fitted)[0].signal.std())
    assert healthy_twin_rms(white_noise_report_path, 1, healthy, bearing, simulator) == pytest.approx(reference_rms, rel=1e-9)
    # A sensor-path effect found after the noise (a resonance filtering the floor) is not part of the power the noise
    # refers to; one found before it is, and so is an effect acting before the sensor path wherever it was found.
    found = {"resonance": {"natural_frequency_hz": 2200.0, "damping_ratio": 0.04},
             "lubrication": {"stiffness_ratio": 0.5, "damping_ns_per_m": 3000.0}}
    with_resonance = float(simulate("normal", bearing, fitted, {"resonance": found["resonance"]})[0].signal.std())
    lubricated = float(simulate("normal", bearing, fitted, {"lubrication": found["lubrication"]})[0].signal.std())
    assert with_resonance > 1.02 * reference_rms and abs(lubricated / reference_rms - 1) > 0.01  # each moves the power
    for order, expected in ((["noise", "resonance"], reference_rms), (["resonance", "noise"], with_resonance),
                            (["noise", "lubrication"], lubricated)):
        steps = json.loads(white_noise_report_path.read_text())["steps"]
        params = {**steps[1]["params"], **found}
        steps.append({"effects": order, "params": {name: params[name] for name in order},
                      "base_params": steps[1]["base_params"]})
        ordered = tmp_path / f"{'_'.join(order)}.json"
        ordered.write_text(json.dumps({"steps": steps}))
        assert healthy_twin_rms(ordered, "all", healthy, bearing, simulator) == pytest.approx(expected, rel=1e-9), order
    # The unbalance matters: the healthy twin of the fault record's base parameters is quieter.
    assert float(simulate("normal", bearing, {**simulator, "rpm": healthy.rpm})[0].signal.std()) < 0.9 * reference_rms
    noise_rms = reference_rms * 10 ** (3.0 / 20)

    twin_ids = [i for i, r in enumerate(quiet.records) if r.startswith(TWIN_PREFIX)]
    assert len(twin_ids) >= 4 * 3
    for record_id in twin_ids:
        rows = train[quiet.record_ids[train] == record_id]
        signal_rms = np.sqrt(np.mean(quiet.windows[rows] ** 2))
        absolute_rms = np.sqrt(np.mean((absolute.windows[rows] - quiet.windows[rows]) ** 2))
        relative_rms = np.sqrt(np.mean((relative.windows[rows] - quiet.windows[rows]) ** 2))
        state = quiet.records[record_id]
        # Absolute: one floor, the healthy twin's RMS 3 dB up, in every state at every speed.
        assert absolute_rms == pytest.approx(noise_rms, rel=0.03), state
        # Relative: each state's own SNR of -3 dB.
        # (rel 0.1: the SNR refers to the whole 0.5 s record, these are two windows of it.)
        assert relative_rms == pytest.approx(signal_rms * 10 ** (3.0 / 20), rel=0.1), state
        if not state.startswith(f"{TWIN_PREFIX}normal@"):
            # A fault signal is an order of magnitude above the healthy one: relative noise would bury it.
            assert signal_rms > 5 * reference_rms and relative_rms > 5 * absolute_rms, state


def test_variants_simulate_every_state_at_every_value_and_the_value_reaches_the_physics(report_path, tmp_path):
    """data.twin.variants: one twin record per state, speed and value; a ball whose spin wanders more
    (spin_slip.jitter 0.4 against 0.01) strikes less regularly, so less envelope power at 2 x BSF."""
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures

    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0", "data.twin.duration=1.0",
                         "data.twin.windows_per_record=5", "data.normalize_windows=false", f"paths.cache_dir={tmp_path}"]
    plain = build_dataset(compose_train(overrides))
    varied = build_dataset(compose_train(overrides + ["+data.twin.variants.spin_slip.jitter=[0.01,0.4]"]))
    plain_twin = [r for r in plain.records if r.startswith(TWIN_PREFIX)]
    varied_twin = [r for r in varied.records if r.startswith(TWIN_PREFIX)]
    assert varied_twin == [f"{r}[spin_slip.jitter={j}]" for j in ("0.01", "0.4") for r in plain_twin]
    assert len(varied.fixed_split[0]) == 2 * len(plain.fixed_split[0])
    np.testing.assert_array_equal(varied.windows[varied.fixed_split[1]], plain.windows[plain.fixed_split[1]])

    bsf2 = {}
    for jitter in ("0.01", "0.4"):
        ids = [i for i, r in enumerate(varied.records) if r.startswith(f"{TWIN_PREFIX}ball@") and f"jitter={jitter}]" in r]
        rows = np.isin(varied.record_ids, ids)
        extractor = EnvelopeOrderFeatures(bearing=dict(compose_train(overrides).bearing))
        features = extractor.fit_transform(varied.windows[rows], fs_hz=varied.fs, rpm=varied.window_rpms[rows])
        bsf2[jitter] = features[:, extractor.feature_names_.index("1xbsf2")].mean()
    assert bsf2["0.4"] < 0.8 * bsf2["0.01"], bsf2  # measured 0.033 against 0.053


def test_a_background_hears_every_twin_record_again_and_weakens_its_series(report_path, tmp_path):
    """data.twin.background_snr_db: each twin record again with white background at each level, labelled as the
    record, seeded (the same twin twice gives the same windows); the test windows and, for null, the dataset's
    key stay what they were; the inner race's BPFI series stands lower over the floor, most at 0 dB."""
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures

    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0", "data.twin.duration=1.0",
                         "data.twin.windows_per_record=5", f"paths.cache_dir={tmp_path}"]
    plain = build_dataset(compose_train(overrides))
    assert plain.key == build_dataset(compose_train(overrides + ["data.twin.background_snr_db=null"])).key
    heard = build_dataset(compose_train(overrides + ["data.twin.background_snr_db=[10.0,0.0]"]))
    again = build_dataset(compose_train(overrides + ["data.twin.background_snr_db=[10.0,0.0]"]))
    np.testing.assert_array_equal(heard.windows, again.windows)
    assert heard.key != plain.key
    plain_twin = [r for r in plain.records if r.startswith(TWIN_PREFIX)]
    assert [r for r in heard.records if r.startswith(TWIN_PREFIX)] == plain_twin + [
        f"{r}[background {level} dB]" for level in ("10", "0") for r in plain_twin]
    train, test = heard.fixed_split
    assert len(train) == 3 * len(plain.fixed_split[0])
    np.testing.assert_array_equal(heard.windows[test], plain.windows[plain.fixed_split[1]])
    for index, record in enumerate(heard.records[:len(plain_twin) * 3]):
        assert set(heard.labels[heard.record_ids == index]) == {FAULTS.index(record[len(TWIN_PREFIX):].split("@")[0])}
    extractor = EnvelopeOrderFeatures(bearing=dict(compose_train(overrides).bearing))
    bpfi = {}
    for suffix in ("rpm", "[background 10 dB]", "[background 0 dB]"):
        ids = [i for i, r in enumerate(heard.records) if r.startswith(f"{TWIN_PREFIX}inner@") and r.endswith(suffix)]
        rows = np.isin(heard.record_ids, ids)
        features = extractor.fit_transform(heard.windows[rows], fs_hz=heard.fs, rpm=heard.window_rpms[rows])
        bpfi[suffix] = features[:, extractor.feature_names_.index("1xbpfi")].mean()
    assert bpfi["rpm"] > bpfi["[background 10 dB]"] > bpfi["[background 0 dB]"], bpfi
    with pytest.raises(BearingTwinError, match=r"data\.twin\.background_snr_db must be null or a non-empty list"):
        build_dataset(compose_train(overrides + ["data.twin.background_snr_db=[]"]))
    with pytest.raises(BearingTwinError, match=r"data\.twin\.background_snr_db must be null or a non-empty list"):
        build_dataset(compose_train(overrides + ["data.twin.background_snr_db=10"]))


PATHS = "{hearings:2,modes:6,natural_frequency_hz:[500.0,5500.0],damping_ratio:[0.005,0.05]}"


def test_other_paths_hear_every_twin_record_again_with_its_harmonics_spread(report_path, tmp_path):
    """data.twin.other_paths: each twin record again through each of `hearings` random structural paths, labelled
    as the record, seeded; the test windows and, for null, the dataset's key stay what they were; through another
    path the inner race's impacts spread in time, so its third BPFI harmonic stands lower over the floor even
    after pre-whitening (measured 1.6 -> 1.2-1.3 on the full-size twin)."""
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures

    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0", "data.twin.duration=1.0",
                         "data.twin.windows_per_record=5", f"paths.cache_dir={tmp_path}"]
    plain = build_dataset(compose_train(overrides))

    def without_paths(cfg):  # a config written before the option existed
        with open_dict(cfg):
            del cfg.data.twin["other_paths"]
        return cfg

    # ... builds the very dataset the option's null default builds, with a background too.
    assert plain.key == build_dataset(without_paths(compose_train(overrides))).key
    background = overrides + ["data.twin.background_snr_db=[10.0]"]
    assert build_dataset(compose_train(background)).key == build_dataset(without_paths(compose_train(background))).key
    heard = build_dataset(compose_train(overrides + [f"data.twin.other_paths={PATHS}"]))
    again = build_dataset(compose_train(overrides + [f"data.twin.other_paths={PATHS}"]))
    np.testing.assert_array_equal(heard.windows, again.windows)
    assert heard.key != plain.key
    plain_twin = [r for r in plain.records if r.startswith(TWIN_PREFIX)]
    assert [r for r in heard.records if r.startswith(TWIN_PREFIX)] == plain_twin + [
        f"{r}[path {number}]" for number in (1, 2) for r in plain_twin]
    train, test = heard.fixed_split
    assert len(train) == 3 * len(plain.fixed_split[0])
    np.testing.assert_array_equal(heard.windows[test], plain.windows[plain.fixed_split[1]])
    for index, record in enumerate(heard.records[:len(plain_twin) * 3]):
        assert set(heard.labels[heard.record_ids == index]) == {FAULTS.index(record[len(TWIN_PREFIX):].split("@")[0])}
    first, second = (heard.windows[heard.record_ids == heard.records.index(f"{plain_twin[0]}[path {n}]")] for n in (1, 2))
    assert not np.allclose(first, second)  # each path its own draw
    extractor = EnvelopeOrderFeatures(bearing=dict(compose_train(overrides).bearing), line_measure="prominence",
                                      prewhiten="cepstral")
    third = {}
    for heard_as in ("rpm", "path"):
        ids = [i for i, r in enumerate(heard.records) if r.startswith(f"{TWIN_PREFIX}inner@")
               and (r.endswith("rpm") if heard_as == "rpm" else "[path" in r)]
        rows = np.isin(heard.record_ids, ids)
        features = extractor.fit_transform(heard.windows[rows], fs_hz=heard.fs, rpm=heard.window_rpms[rows])
        third[heard_as] = features[:, extractor.feature_names_.index("3xbpfi")].mean()
    assert third["path"] < third["rpm"] - 0.1, third
    for bad, field in (("{hearings:2,modes:6}", r"must be null or give exactly hearings, modes"),
                       (PATHS.replace("hearings:2", "hearings:0"), r"other_paths\.hearings must be a positive integer"),
                       (PATHS.replace("[0.005,0.05]", "[0.05,1.5]"), r"other_paths\.damping_ratio must be \[low, high\]"),
                       (PATHS.replace("[500.0,5500.0]", "[7000.0,9000.0]"),
                        r"other_paths\.natural_frequency_hz: low 7000 Hz is at or above the twin's Nyquist frequency")):
        with pytest.raises(BearingTwinError, match=field):
            build_dataset(compose_train(overrides + [f"data.twin.other_paths={bad}"]))


def test_a_path_of_one_mode_is_its_resonator_and_modes_above_nyquist_are_refused():
    """An impulse through one mode: the impulse-invariant resonator r^n sin(n theta), r = exp(-zeta omega),
    theta = omega sqrt(1 - zeta^2), up to the modal weight (the RMS of what went in is kept); ranges drawn
    log-uniform within their bounds; a path with no mode below the Nyquist frequency is refused."""
    from bearingtwin.data.twin_to_real import through_other_path

    fs, f_n, zeta = 12000.0, 1000.0, 0.02
    impulse = np.zeros(6000)
    impulse[0] = 1.0
    heard = through_other_path(impulse, fs, 1, (f_n, f_n), (zeta, zeta), (0, 1))
    omega = 2 * np.pi * f_n / fs
    n = np.arange(impulse.size)
    resonator = np.exp(-zeta * omega * n) * np.sin(n * omega * np.sqrt(1 - zeta ** 2))
    scale = heard @ resonator / (resonator @ resonator)
    np.testing.assert_allclose(heard, scale * resonator, atol=1e-12)
    assert np.sqrt(np.mean(heard ** 2)) == pytest.approx(np.sqrt(np.mean(impulse ** 2)))
    # Three modes drawn between 500 and 5000 Hz: the spectrum's peaks lie inside, and another seed draws others.
    heard = through_other_path(impulse, fs, 3, (500.0, 5000.0), (0.005, 0.005), (0, 2))
    spectrum = np.abs(np.fft.rfft(heard))
    freqs = np.fft.rfftfreq(heard.size, 1 / fs)
    assert 450 < freqs[np.argmax(spectrum)] < 5050
    assert not np.allclose(heard, through_other_path(impulse, fs, 3, (500.0, 5000.0), (0.005, 0.005), (0, 3)))
    with pytest.raises(BearingTwinError, match="no mode of this path rings below the Nyquist frequency"):
        through_other_path(impulse, fs, 1, (7000.0, 7000.0), (zeta, zeta), (0, 1))


@pytest.mark.parametrize("variants, message", [
    ("+data.twin.variants.spin_slip.jitter=[]", r"data\.twin\.variants\.spin_slip\.jitter: need a non-empty list"),
    ("+data.twin.variants.spin_slip=0.2", r"data\.twin\.variants\.spin_slip: give parameter: \[values"),
    ("data.calibration.validation_windows_per_record=-1", r"data\.calibration\.validation_windows_per_record"),
    ("+data.twin.variants.spinslip.jitter=[0.1]", r"data\.twin\.variants \(spinslip\.jitter=0\.1\): .*unknown effect"),
    ("+data.twin.variants.spin_slip.jitter=[0.1,-0.1]", r"data\.twin\.variants \(spin_slip\.jitter=-0\.1\): .*positive"),
    ("+data.twin.variants.noise.snr_db=[null,10.0]", r"data\.twin\.variants\.noise: a null leaves the effect out, so it can be "
                                                      r"the only varied parameter of noise \(got snr_db, spectral_slope\)"),
])
def test_bad_variants_and_validation_settings_name_their_field(report_path, tmp_path, variants, message):
    extra = ["+data.twin.variants.noise.spectral_slope=[0.0]"] if "noise" in variants else []
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", f"paths.cache_dir={tmp_path}", variants, *extra])
    with pytest.raises(BearingTwinError, match=message):
        build_dataset(cfg)


def test_a_null_variant_leaves_the_effect_out_and_a_preload_removes_the_inner_race_sidebands(report_path, tmp_path):
    """data.twin.variants {preload: {interference_um: [null, 20]}} (protocol v3): the twin as it is, and preloaded. A
    preloaded bearing loads every ball all the way round, so an inner-race spall strikes as hard at
    every shaft angle: its shaft-order sidebands around BPFI sink while the BPFI series stays."""
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures

    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0", "data.twin.duration=1.0",
                         "data.twin.windows_per_record=4", "data.window_length=4096", f"paths.cache_dir={tmp_path}",
                         "+data.twin.variants.preload.interference_um=[null,20.0]"]
    varied = build_dataset(compose_train(overrides))
    twin = [r for r in varied.records if r.startswith(f"{TWIN_PREFIX}inner@")]
    labels = [r[r.index("[") + 1:-1] for r in twin]
    assert labels == ["preload=absent"] * (len(twin) // 2) + ["preload.interference_um=20"] * (len(twin) // 2)
    extractor = EnvelopeOrderFeatures(bearing=dict(compose_train(overrides).bearing), line_measure="prominence",
                                      prewhiten="cepstral")
    lines = {}
    for label in ("preload=absent", "preload.interference_um=20"):
        ids = [i for i, r in enumerate(varied.records) if r.startswith(f"{TWIN_PREFIX}inner@") and r.endswith(f"[{label}]")]
        rows = np.isin(varied.record_ids, ids)
        features = extractor.fit_transform(varied.windows[rows], fs_hz=varied.fs, rpm=varied.window_rpms[rows])
        mean = dict(zip(extractor.feature_names_, features.mean(axis=0)))
        lines[label] = {"bpfi": np.mean([mean[f"{h}xbpfi"] for h in (1, 3)]),
                        "sidebands": np.mean([mean[f"{h}xbpfi{side}"] for h in (1, 3) for side in ("-1x", "+1x")])}
    free, preloaded = lines["preload=absent"], lines["preload.interference_um=20"]
    assert preloaded["sidebands"] < free["sidebands"] - 0.3, lines  # measured 0.92 -> -0.01 (log10)
    assert preloaded["bpfi"] > 0.5 and free["bpfi"] > 0.5, lines


def test_the_datasets_key_follows_what_the_calibration_and_test_records_hold(report_path, tmp_path):
    """The key names the feature cache and groups seeds in reports: a calibration record written over (its
    windows are scored, its healthy level sets the twin's noise) is other data, wherever the folder lies."""
    import shutil

    import scipy.io

    root = tmp_path / "cwru"
    root.mkdir()
    for path in DATA.glob("*.mat"):
        shutil.copy(path, root / path.name)
    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0",
                         f"paths.cache_dir={tmp_path / 'cache'}"]
    before = build_dataset(compose_train(overrides + [f"data.root={root}"])).key
    assert build_dataset(compose_train(overrides + [f"data.root={DATA}"])).key == before
    record = scipy.io.loadmat(root / "normal_0_97.mat")
    record["X097_DE_time"] = record["X097_DE_time"] * 1.001
    scipy.io.savemat(root / "normal_0_97.mat", {k: v for k, v in record.items() if not k.startswith("__")})
    assert build_dataset(compose_train(overrides + [f"data.root={root}"])).key != before


def test_a_records_rate_the_shaft_line_contradicts_names_this_data_sources_remedies(report_path, tmp_path):
    """data=twin_to_real has no data.fs_by_record (data=cwru's remedy): it names a labels table's fs column."""
    cfg = compose_train(SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=0", "data.fs=48000",
                                 f"paths.cache_dir={tmp_path}"])
    with pytest.raises(BearingTwinError, match=r"contradicts the shaft speed.*; give its rate in a labels table "
                                               r"\(data.labels=<csv> with an fs column\) or set data.check_fs=false$"):
        build_dataset(cfg)


@pytest.mark.parametrize("setting", ["data.window_length=true", "data.twin.windows_per_record=true",
                                     "data.test.windows_per_record=2.5"])
def test_counts_of_the_wrong_kind_are_named(setting, report_path, tmp_path):
    key = setting.split("=")[0]
    with pytest.raises(BearingTwinError, match=rf"^{key} must be a positive integer, got"):
        build_dataset(compose_train(SMALL + [f"data.calibration.report={report_path}", setting,
                                             f"paths.cache_dir={tmp_path}"]))


def test_variants_simulated_in_parallel_give_the_windows_one_process_gives(report_path, tmp_path, monkeypatch):
    """data.twin.n_jobs: the variants' records simulated by two processes are the records one process simulates
    (each record's seed is its own), and the dataset's key does not depend on it; a bad value is named."""
    import joblib

    overrides = SMALL + [f"data.calibration.report={report_path}", "data.calibration.step=1",
                         "+data.twin.variants.spin_slip.jitter=[0.01,0.2,0.4]"]
    one = build_dataset(compose_train(overrides + ["data.twin.n_jobs=1", f"paths.cache_dir={tmp_path / 'one'}"]))
    pools, parallel = [], joblib.Parallel
    monkeypatch.setattr(joblib, "Parallel", lambda *args, **kwargs: pools.append(kwargs) or parallel(*args, **kwargs))
    two = build_dataset(compose_train(overrides + ["data.twin.n_jobs=2", f"paths.cache_dir={tmp_path / 'two'}"]))
    assert [pool["n_jobs"] for pool in pools] == [2]  # the three variants were simulated by a pool of two
    np.testing.assert_array_equal(one.windows, two.windows)
    assert one.key == two.key and one.records == two.records
    assert len(list((tmp_path / "two" / "twin_to_real").glob("records-*.npz"))) == 3
    with pytest.raises(BearingTwinError, match=r"^data.twin.n_jobs must be a positive integer, got 0"):
        build_dataset(compose_train(overrides + ["data.twin.n_jobs=0", f"paths.cache_dir={tmp_path / 'bad'}"]))


@pytest.mark.parametrize("mode, launcher, jobs", [
    (None, None, -1),  # a single run, or a library call outside Hydra: every core
    ("MULTIRUN", "hydra._internal.core_plugins.basic_launcher.BasicLauncher", -1),  # jobs one after another
    ("MULTIRUN", "hydra_plugins.bearingtwin_launcher.joblib_launcher.SurvivingJoblibLauncher", 1),  # side by side
])
def test_auto_simulation_jobs_take_every_core_unless_sweep_jobs_run_side_by_side(monkeypatch, mode, launcher, jobs):
    from types import SimpleNamespace

    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    from bearingtwin.data.twin_to_real import simulation_jobs

    monkeypatch.setattr(HydraConfig, "initialized", staticmethod(lambda: mode is not None))
    monkeypatch.setattr(HydraConfig, "get", staticmethod(
        lambda: SimpleNamespace(mode=getattr(RunMode, mode or "RUN"), launcher={"_target_": launcher})))
    assert simulation_jobs("auto") == jobs and simulation_jobs(3) == 3 and simulation_jobs(-1) == -1


def test_a_test_state_the_twin_does_not_simulate_is_named_before_anything_is_read(report_path, tmp_path):
    with pytest.raises(BearingTwinError, match=r"^data.test.classes: ball is a state the twin does not simulate "
                                               r"\(data.twin.classes: normal, inner, outer\)$"):
        build_dataset(compose_train(SMALL + [f"data.calibration.report={report_path}", "data.twin.classes=[normal,inner,outer]",
                                             f"paths.cache_dir={tmp_path}"]))


def test_a_calibration_report_fitted_again_is_another_run(report_path, tmp_path):
    """The run's hash holds the reports that make its twin: a finished run is not taken for one whose twin was
    calibrated otherwise."""
    import shutil

    from bearingtwin.tracking.mlflow_logging import config_hash

    report = tmp_path / "twin_report.json"
    shutil.copy(report_path, report)
    cfg = compose_train(SMALL + [f"data.calibration.report={report}", "data.calibration.step=1"])
    before = config_hash(cfg)
    fitted = json.loads(report.read_text())
    fitted["steps"][-1]["base_params"]["simulator.defect.depth_mm"] = 0.02  # the defect fitted deeper
    report.write_text(json.dumps(fitted))
    assert config_hash(cfg) != before
