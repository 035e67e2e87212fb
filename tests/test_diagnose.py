"""Diagnosing recordings: the saved pipeline, its MLflow model and registry entry, the physics
evidence, and ``bearingtwin-diagnose`` end to end on real CWRU records and generated files."""

import csv
import dataclasses
import json
import os
import re
import subprocess
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from mlflow import MlflowClient
from mlflow.exceptions import MlflowException
from omegaconf import OmegaConf
from processes import run_module

from bearingtwin.config import bearing_config, compose_config, data_root
from bearingtwin.data.formats import load_recording
from bearingtwin.data.recording import Recording, held_stretches
from bearingtwin.diagnosis.evidence import PhysicsFirst, check_segment, evidence_settings, physics_evidence
from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model, log_diagnosis_model, model_params, predictions_frame
from bearingtwin.diagnosis.pipeline import DiagnosisPipeline
from bearingtwin.diagnosis.record import (NOISE_FREE_SIMULATION, PreparedRecord, _in_samples, diagnose_recording,
                                         diagnosed_windows, dropouts, extrapolation_note, majority, one_line, plot_diagnosis, read_record,
                                         resample_to)
from bearingtwin.diagnosis.run import NOT_REACHED
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
from bearingtwin.features.extractor import SaboVmdFeatures
from bearingtwin.features.time_domain import FEATURE_NAMES
from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier
from bearingtwin.models.svm import SvmClassifier
from bearingtwin.physics.geometry import FAULTS, BearingGeometry
from bearingtwin.signal.sampling_rate import check_channels

CWRU = data_root() / "cwru"
needs_cwru = pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
BEARING = bearing_config("cwru_6205")
FS = 12000.0
RPM = 1797.0
SMOKE = ["data.samples_per_class=12", "data.duration=1.0", "search.population=3", "search.iterations=1",
         "search.windows=2", "features.progress=false", "classifier=svm"]


def fault_signal(rate_hz: float | None, seconds: float = 4.0, fs: float = FS, seed: int = 0) -> np.ndarray:
    """Impacts repeating at ``rate_hz`` ringing a 3 kHz resonance, in noise (``None``: noise alone)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    signal = 0.05 * rng.standard_normal(t.size)
    if rate_hz is not None:
        ring = np.exp(-800 * t[:200]) * np.sin(2 * np.pi * 3000 * t[:200])
        impacts = np.zeros(t.size)
        impacts[(np.arange(0, seconds, 1 / rate_hz) * fs).astype(int)] = 1.0
        signal += np.convolve(impacts, ring)[: t.size]
    return signal


def class_windows(n_per_class=16, length=2048):
    """Windows whose class is their defect rate: normal (noise), inner (BPFI), outer (BPFO)."""
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    windows, labels = [], []
    for label, rate in ((0, None), (1, rates["bpfi"]), (3, rates["bpfo"])):
        signal = fault_signal(rate, seconds=n_per_class * length / FS, seed=label)
        windows.append(signal[: n_per_class * length].reshape(n_per_class, length))
        labels += [label] * n_per_class
    return np.concatenate(windows), np.array(labels)


# ---------------------------------------------------------------- the pipeline


def test_saved_pipelines_predict_exactly_as_the_fitted_ones(tmp_path):
    X, y = class_windows()
    vmd = SaboVmdFeatures(population=3, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False)
    svm_pipeline = DiagnosisPipeline(vmd.fit(X, y), SvmClassifier().fit(vmd.transform(X), y), 2048, FS, bearing=BEARING)
    envelope = EnvelopeOrderFeatures(bearing=BEARING, line_measure="prominence").fit(X, fs_hz=FS, rpm=RPM)
    network = CnnBiLstmClassifier(max_epochs=3, random_state=0).fit(envelope.transform(X, fs_hz=FS, rpm=RPM), y)
    cnn_pipeline = DiagnosisPipeline(envelope, network, 2048, FS, window_normalization="zscore", bearing=BEARING)
    for index, pipeline in enumerate((svm_pipeline, cnn_pipeline)):
        loaded = DiagnosisPipeline.load(pipeline.save(tmp_path / str(index)))
        np.testing.assert_allclose(loaded.predict_proba(X, RPM), pipeline.predict_proba(X, RPM), atol=1e-7)
        assert loaded.class_names == ["normal", "inner", "outer"] and loaded.window_normalization == pipeline.window_normalization
    states, _ = svm_pipeline.predict(X)
    assert np.mean(states == np.array(["normal", "inner", "outer"])[np.searchsorted([0, 1, 3], y)]) > 0.5
    with pytest.raises(BearingTwinError, match="rpm"):  # shaft-order features need the speed
        cnn_pipeline.predict(X)
    with pytest.raises(BearingTwinError, match="windows of 1000 samples: the model reads windows of 2048 samples at"):
        svm_pipeline.predict(X[:, :1000])


def test_a_record_in_g_is_read_by_a_model_trained_in_m_s2_as_the_same_vibration_and_an_unseen_level_is_named(tmp_path):
    """Units (standard gravity between g and m/s^2) and levels travel with the saved pipeline: a record stated in
    g, mg or mm/s^2 is converted to the model's m/s^2 and then diagnosed exactly as the same vibration in m/s^2; one
    stated in a unit that is no acceleration's (a voltage, a velocity) is refused by a model that reads levels,
    naming the file, the unit and what it takes, and read as it is, said so, by one that normalizes its windows;
    windows a thousand times the training ones' level are named, as a unit or gain the model never saw, while the
    training windows themselves are not."""
    from bearingtwin.diagnosis.record import in_model_unit
    from bearingtwin.models.experiment import training_window_level

    X, y = class_windows()
    vmd = SaboVmdFeatures(population=3, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False)
    level = training_window_level(SimpleNamespace(windows=X, window_normalization="none"), np.arange(len(X)))
    fitted = DiagnosisPipeline(vmd.fit(X, y), SvmClassifier().fit(vmd.transform(X), y), 2048, FS, bearing=BEARING,
                               unit="m/s^2", window_level=level)
    pipeline = DiagnosisPipeline.load(fitted.save(tmp_path / "model"))
    assert pipeline.unit == "m/s^2" and pipeline.window_level == pytest.approx(level)
    signal = X[16:20].ravel()  # four inner-race windows, in m/s^2
    in_g = Recording(signal / 9.80665, FS, unit="G")  # a logger's spelling of g
    converted, notes, check = in_model_unit(in_g, pipeline)
    assert notes == ["converted from g to m/s^2, the unit the model was trained in (x 9.80665)"] and check == "converted"
    np.testing.assert_allclose(converted.signal, signal, rtol=1e-12)
    np.testing.assert_allclose(pipeline.predict_proba(converted.signal.reshape(4, 2048)),
                               pipeline.predict_proba(X[16:20]), atol=1e-9)
    for unit, factor in (("mg", 1000 / 9.80665), ("mm/s²", 1000.0), ("µg", 1e6 / 9.80665), ("m/s2", 1.0)):
        converted, _, check = in_model_unit(Recording(signal * factor, FS, unit=unit), pipeline)
        np.testing.assert_allclose(converted.signal, signal, rtol=1e-12, err_msg=unit)
        assert (converted.unit, check) == ((unit, "as stated") if factor == 1.0 else ("m/s^2", "converted"))
    with pytest.raises(BearingTwinError, match=r"^rig/a.npz: the record is in V, the model was trained on windows in "
                                               r"m/s\^2 and reads their level, and V \(a voltage\) is not converted "
                                               r"into m/s\^2 here: give scale=<1 / the sensor's sensitivity> "
                                               r"unit=<its acceleration unit> \(a 100 mV/g sensor's volts: scale=10 "
                                               r"unit=g"):
        in_model_unit(Recording(signal, FS, unit="V", source="rig/a.npz"), pipeline)
    with pytest.raises(BearingTwinError, match=r"^rig/v.csv: the record is in mm/s, .* mm/s \(a velocity\) is not "
                                               r"converted into m/s\^2 here: a velocity is an integrated acceleration"):
        in_model_unit(Recording(signal, FS, unit="mm/s", source="rig/v.csv"), pipeline)
    # Spellings of one unit are one unit; a label in brackets that is no unit known here is read as none stated.
    for spelling in ("m / s^2", "M/sec²", "m·s⁻²"):
        assert in_model_unit(Recording(signal, FS, unit=spelling), pipeline)[2] == "as stated", spelling
    assert in_model_unit(Recording(signal * 0.3048, FS, unit="ft/s^2"), pipeline)[0].signal == pytest.approx(signal * 0.3048**2)
    labelled, notes, check = in_model_unit(Recording(signal, FS, unit="A"), pipeline)  # "Sensor (A)"
    assert check == "assumed" and notes[0].startswith("the file states 'A', no unit known here: read as if in m/s^2")
    # A record that states no unit is read in the model's, and said so: g and m/s^2 differ by less than a decade.
    same, notes, check = in_model_unit(Recording(signal, FS), pipeline)
    assert same.signal is signal and check == "assumed" and notes == [
        "the file states no unit: read as if in m/s^2, the unit the model was trained in (where it is another, give "
        "unit=<unit>, or state it in the file: a CSV column header such as 'acc (m/s^2)', an .npz's 'unit' entry)"]
    assert pipeline.level_note(X) is None
    assert "lies more than 10 times above the 5-95 % range of the model's training windows" in pipeline.level_note(1000 * X)
    normalizing = dataclasses.replace(pipeline, window_normalization="zscore", window_level=None)
    assert normalizing.level_note(1000 * X) is None and in_model_unit(in_g, normalizing)[1:] == ([], "not needed")
    # Scaled to one level, a VMD mode's statistics still read the waveform's shape, which a velocity's differs in.
    with pytest.raises(BearingTwinError, match=r"^rig/v.csv: the record is in mm/s \(a velocity\): the model scales "
                                               r"every window to one level, but its features describe the waveform"):
        in_model_unit(Recording(signal, FS, unit="mm/s", source="rig/v.csv"), normalizing)


def test_windows_of_records_in_g_and_in_m_s2_are_brought_to_one_unit(caplog):
    from bearingtwin.data.real import windows_from_recordings

    caplog.set_level("INFO", logger="bearingtwin.data.real")

    signal = fault_signal(None, seconds=1.0)
    in_g = Recording(signal / 9.80665, FS, fault="normal", unit="g", source="a.npz")
    in_si = Recording(signal, FS, fault="inner", unit="m/s^2", source="b.npz")
    dataset = windows_from_recordings([in_g, in_si], 2048, 2, "data.windows_per_record", "key")
    assert dataset.unit == "m/s^2"
    np.testing.assert_allclose(dataset.windows[:2], dataset.windows[2:], rtol=1e-12)  # the same vibration
    both_g = windows_from_recordings([in_g, dataclasses.replace(in_si, signal=signal / 9.80665, unit="g")], 2048, 2,
                                     "data.windows_per_record", "key")
    assert both_g.unit == "g" and np.allclose(both_g.windows[0], signal[:2048] / 9.80665)
    # One record stating g, another none: 9.81 apart or not, nothing tells; the one stating none is named.
    with pytest.raises(BearingTwinError, match="b.npz states no unit, a.npz states g: state every record's unit"):
        windows_from_recordings([in_g, dataclasses.replace(in_si, unit="")], 2048, 2, "data.windows_per_record", "key")
    with pytest.raises(BearingTwinError, match="c.npz states no unit"):  # beside two units converted into one another
        windows_from_recordings([in_g, in_si, dataclasses.replace(in_si, unit="", source="c.npz")], 2048, 2,
                                "data.windows_per_record", "key")
    unstated = windows_from_recordings([dataclasses.replace(in_g, unit=""), dataclasses.replace(in_si, unit="")], 2048,
                                       2, "data.windows_per_record", "key")
    assert unstated.unit == ""
    in_mg = windows_from_recordings([in_g, dataclasses.replace(in_si, signal=signal / 9.80665 * 1000, unit="mg")], 2048,
                                    2, "data.windows_per_record", "key")
    assert in_mg.unit == "m/s^2" and np.allclose(in_mg.windows[:2], in_mg.windows[2:], rtol=1e-12)
    assert "the records state g, mg: each converted to m/s^2" in caplog.text  # said, not done in silence
    with pytest.raises(BearingTwinError, match=r"the records state units not converted into one another \(g: a.npz, V: "
                                               r"b.npz\); only acceleration units"):
        windows_from_recordings([in_g, dataclasses.replace(in_si, unit="V")], 2048, 2, "data.windows_per_record", "key")


def test_a_per_class_pipeline_refuses_to_diagnose(tmp_path):
    X, y = class_windows(n_per_class=6)
    vmd = SaboVmdFeatures(vmd_params="per_class", population=3, iterations=1, search_windows=2,
                          vmd_options={"max_iter": 60}, progress=False).fit(X, y)
    pipeline = DiagnosisPipeline(vmd, SvmClassifier().fit(vmd.transform(X, y), y), 2048, FS)
    loaded = DiagnosisPipeline.load(pipeline.save(tmp_path / "per_class"))  # saving it is fine
    with pytest.raises(BearingTwinError, match="vmd_params=per_class.*cannot diagnose an unlabeled window"):
        loaded.predict(X)


def test_the_svm_predicts_as_the_plain_svm_and_its_probabilities_sum_to_one():
    from bearingtwin.models.svm import make_svm

    X, y = class_windows(n_per_class=10)
    features = np.c_[X.std(axis=1), np.abs(X).max(axis=1), (X ** 4).mean(axis=1)]
    svm = SvmClassifier().fit(features, y)
    np.testing.assert_array_equal(svm.predict(features), make_svm().fit(features, y).predict(features))
    np.testing.assert_allclose(svm.predict_proba(features).sum(axis=1), 1.0)
    with pytest.raises(BearingTwinError, match="at least 2 training windows per class"):
        SvmClassifier().fit(features[:21], y[:21])  # one window of the last class


# ---------------------------------------------------------------- physics evidence


def test_evidence_names_the_fault_whose_harmonic_series_stands_out():
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    for state, rate in (("inner", rates["bpfi"]), ("outer", rates["bpfo"]), ("ball", 2 * rates["bsf"])):
        evidence = physics_evidence(fault_signal(rate), FS, RPM, BEARING)
        assert evidence.evidence_state == state, evidence.prominence_db
        others = [value for name, value in evidence.prominence_db.items() if name != state]
        assert evidence.prominence_db[state] > 10.0 and evidence.prominence_db[state] > max(others) + 6.0
        by_kurtogram = physics_evidence(fault_signal(rate), FS, RPM, BEARING, band="kurtogram")
        assert by_kurtogram.evidence_state == state, by_kurtogram.band_hz
    healthy = physics_evidence(fault_signal(None), FS, RPM, BEARING)
    assert healthy.evidence_state == "normal" and max(healthy.prominence_db.values()) < healthy.threshold_db


def test_the_physics_decides_a_window_only_where_one_series_leaves_no_doubt():
    """20 dB over the floor and 10 dB above every other series: a clear outer-race train is decided, noise,
    a faint train (counted by the baseline's 6 dB, short of 20) and two faults' trains at once are not."""
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    gate = PhysicsFirst(threshold_db=20.0, margin_db=10.0)
    clear = fault_signal(rates["bpfo"], seconds=1.0)
    faint = 0.04 * (fault_signal(rates["bpfo"], seconds=1.0) - fault_signal(None, seconds=1.0)) + fault_signal(None, 1.0, seed=3)
    both = fault_signal(rates["bpfo"], seconds=1.0) + fault_signal(rates["bpfi"], seconds=1.0, seed=1)
    evidence = {name: physics_evidence(window, FS, RPM, BEARING)
                for name, window in (("clear", clear), ("faint", faint), ("both", both))}
    assert evidence["faint"].evidence_state == "outer" and evidence["faint"].prominence_db["outer"] < 20.0
    assert min(evidence["both"].prominence_db["outer"], evidence["both"].prominence_db["inner"]) > 20.0
    windows = np.stack([clear, fault_signal(None, seconds=1.0), faint, both])
    assert gate.states(windows, FS, RPM, BEARING) == ["outer", None, None, None]
    # A speed per window, the windows read in one batch as physics_evidence reads each alone.
    speeds = [RPM, 1730.0, RPM, 1750.0]
    assert gate.states(windows, FS, speeds, BEARING) == [
        physics_evidence(window, FS, speed, BEARING).decisive_state(20.0, 10.0) for window, speed in zip(windows, speeds)]
    with pytest.raises(BearingTwinError, match="rpm must be a positive shaft speed, got 0 for window 2"):
        gate.states(windows, FS, [RPM, RPM, 0.0, RPM], BEARING)
    # The margin is measured to the runner-up: the same series beside a lower one is decided.
    lone = dataclasses.replace(evidence["both"], prominence_db={"inner": 31.0, "ball": 2.0, "outer": 20.5})
    assert lone.decisive_state(20.0, 10.0) == "inner" and lone.decisive_state(20.0, 11.0) is None
    assert lone.decisive_state(32.0, 0.0) is None
    with pytest.raises(BearingTwinError, match="physics_first.margin_db must be a non-negative number of dB"):
        PhysicsFirst(margin_db=-1.0)


def served_model(pipeline):
    """The pyfunc model a model server loads, around ``pipeline``, as ``load_context`` leaves it."""
    from bearingtwin.diagnosis.mlflow_model import DiagnosisModel

    model = DiagnosisModel()
    model.pipeline = pipeline
    return model


def integrated(windows: np.ndarray, times: int = 1) -> np.ndarray:
    """``windows`` integrated ``times`` over (per line: divided by j 2 pi f), as a velocity or displacement is."""
    frequencies = np.fft.rfftfreq(windows.shape[1], 1 / FS)
    per_line = np.where(frequencies > 0, 1 / (2j * np.pi * np.where(frequencies > 0, frequencies, 1.0)), 0.0)
    return np.fft.irfft(np.fft.rfft(windows, axis=1) * per_line**times, windows.shape[1], axis=1)


def test_a_unit_is_read_or_refused_by_what_the_models_features_compute_served_as_diagnosed():
    """A model free of scale (envelope-order features are ratios of one window's powers; or windows scaled to one
    level) had been refused a voltage "for it reads their level" (the envelope model), or read any text as a unit,
    a velocity too (the normalizing one). Now every model refuses a unit no reader knows, naming it; a model free of
    scale reads a voltage (an accelerometer's volts: a gain) as it reads windows of any gain, and refuses a velocity
    or a displacement for what its features compute: band_power, the share of the band-pass, which integration
    lowers; the same in bearingtwin-diagnose. Features free of the spectrum's shape too (lines of the cepstrally
    pre-whitened window, no band_power) read an integrated record as they read its acceleration."""
    from bearingtwin.diagnosis.mlflow_model import ModelInputError, in_model_terms
    from bearingtwin.diagnosis.record import in_model_unit

    X, y = class_windows(n_per_class=6)
    envelope = EnvelopeOrderFeatures(bearing=BEARING, line_measure="prominence").fit(X, fs_hz=FS, rpm=RPM)
    stds = np.std(X, axis=1)
    gain_free = DiagnosisPipeline(envelope, SvmClassifier().fit(envelope.transform(X, fs_hz=FS, rpm=RPM), y), 2048, FS,
                                  bearing=BEARING, unit="g", window_level=(float(stds.min()), float(stds.max())))
    normalizing = dataclasses.replace(gain_free, window_normalization="zscore", window_level=None, unit="")
    windows = X[::4]
    # What the refusal says is what the features compute: integration lowers band_power.
    assert (gain_free.features(integrated(windows), RPM)[:, -1] < gain_free.features(windows, RPM)[:, -1] - 0.5).all()
    for pipeline in (gain_free, normalizing):
        model = served_model(pipeline)
        with pytest.raises(ModelInputError, match=r"^params unit 'furlongs': no unit known here; give one of m/s\^2, "):
            model.predict(None, windows, {"rpm": RPM, "unit": "furlongs"})
        in_volts = model.predict(None, windows, {"rpm": RPM, "unit": "V"})
        pd.testing.assert_frame_equal(in_volts, model.predict(None, windows * 1000, {"rpm": RPM}))
        assert "level_unseen" not in in_volts and pipeline.level_note(windows * 1000) is None  # it reads no level
        _, notes, check = in_model_unit(Recording(windows.ravel(), FS, unit="V"), pipeline)
        assert check == "not needed" and notes[0].startswith("the record is in V (a voltage): read as it is, as an "
                                                             "accelerometer's")
        for unit, quantity in (("mm/s", "velocity"), ("µm", "displacement")):
            reason = (rf"the record is in {unit} \(a {quantity}\): .*, but its band_power feature is the share of a "
                      r"window's power in the band-pass \(1500-5400 Hz\), which integration lowers")
            with pytest.raises(ModelInputError, match=rf"^params unit '{unit}': {reason}"):
                model.predict(None, windows, {"rpm": RPM, "unit": unit})
            with pytest.raises(BearingTwinError, match=rf"^rig/v.csv: {reason}"):
                in_model_unit(Recording(windows.ravel(), FS, unit=unit, source="rig/v.csv"), pipeline)
    whitened = EnvelopeOrderFeatures(bearing=BEARING, band_power=False, prewhiten="cepstral").fit(X, fs_hz=FS, rpm=RPM)
    np.testing.assert_allclose(whitened.transform(integrated(windows), fs_hz=FS, rpm=RPM),
                               whitened.transform(windows, fs_hz=FS, rpm=RPM), atol=0.01)
    shape_free = dataclasses.replace(gain_free, extractor=whitened)
    assert in_model_terms(shape_free, windows, None, "mm/s") is windows


def test_a_shaft_speed_well_beyond_the_training_windows_speeds_is_named_and_kept_with_the_saved_model(tmp_path):
    """The training windows' slowest and fastest speed travel with the saved pipeline; a record more than a quarter
    below the slowest or above the fastest is named (a 600 rev/min record had been called normal with no word), one
    within that margin is not, and a model saved before the speeds were kept says nothing of any speed."""
    from bearingtwin.models.experiment import training_speeds

    dataset = SimpleNamespace(window_rpms=np.array([1730.0, 1797.0, 1750.0, np.nan]))
    assert training_speeds(dataset, np.arange(3)) == (1730.0, 1797.0)
    assert training_speeds(dataset, np.array([3])) is None  # no speed known among the windows trained on
    assert training_speeds(SimpleNamespace(window_rpms=None), np.arange(3)) is None
    X, y = class_windows()
    vmd = SaboVmdFeatures(population=3, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False)
    fitted = DiagnosisPipeline(vmd.fit(X, y), SvmClassifier().fit(vmd.transform(X), y), 2048, FS, bearing=BEARING,
                               speeds_rpm=(1730.0, 1797.0))
    pipeline = DiagnosisPipeline.load(fitted.save(tmp_path / "model"))
    assert pipeline.speeds_rpm == (1730.0, 1797.0)
    assert pipeline.speed_note(600.0) == (
        "the shaft speed (600 rev/min) lies more than 25% below the slowest (1730) of the model's training windows: the "
        "model reads a record at a speed it never learnt; hold its verdict against the physics evidence")
    assert "above the fastest (1797)" in pipeline.speed_note(1797.0 * 1.26)
    assert [pipeline.speed_note(rpm) for rpm in (1730.0 / 1.24, 1772.0, 1797.0 * 1.24, None)] == [None] * 4
    meta = json.loads((tmp_path / "model" / "pipeline.json").read_text())
    del meta["speeds_rpm"]  # as a model saved before the speeds were kept
    (tmp_path / "model" / "pipeline.json").write_text(json.dumps(meta))
    assert DiagnosisPipeline.load(tmp_path / "model").speed_note(60.0) is None


def test_a_window_whose_features_lie_well_beyond_every_training_windows_is_named_with_the_feature(tmp_path):
    """An SVM had given every window of a record unlike its training windows the same confident probabilities, and the
    diagnosis had reported them as a verdict: the training features' range now travels with the saved model, a window
    with a feature more than a quarter of that range beyond it is named with the feature, one within the margin is
    not, and the training windows themselves never are."""
    X, y = class_windows()
    vmd = SaboVmdFeatures(population=3, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False)
    features = vmd.fit(X, y).transform(X)
    low, high = features.min(axis=0), features.max(axis=0)
    fitted = DiagnosisPipeline(vmd, SvmClassifier().fit(features, y), 2048, FS, bearing=BEARING,
                               feature_range=(tuple(low), tuple(high)))
    pipeline = DiagnosisPipeline.load(fitted.save(tmp_path / "model"))
    np.testing.assert_array_equal(pipeline.feature_range, (low, high))
    assert list(pipeline.features_unseen(features)) == [""] * len(features)
    kurtosis = list(FEATURE_NAMES).index("kurtosis")
    probes = np.repeat(features[:1], 3, axis=0)
    probes[0, kurtosis] = high[kurtosis] + 0.3 * (high[kurtosis] - low[kurtosis])  # beyond the margin
    probes[1, kurtosis] = high[kurtosis] + 0.2 * (high[kurtosis] - low[kurtosis])  # within it
    probes[2, kurtosis] = low[kurtosis] - 0.3 * (high[kurtosis] - low[kurtosis])  # below, beyond it
    assert list(pipeline.features_unseen(probes)) == ["kurtosis", "", "kurtosis"]
    # A square wave at the training windows' level: no bearing's vibration; every window is named.
    square = 0.3 * np.sign(np.sin(2 * np.pi * 50 * np.arange(4 * 2048) / FS)).reshape(4, 2048)
    frame = served_model(pipeline).predict(None, np.concatenate([X[::8], square]), {})
    assert list(frame.columns)[-1] == "feature_unseen"
    assert (frame["feature_unseen"][: len(X[::8])] == "").all() and (frame["feature_unseen"][-4:] != "").all()
    assert DiagnosisPipeline(vmd, fitted.classifier, 2048, FS).features_unseen(probes).tolist() == [""] * 3  # unkept


def test_the_extrapolation_note_counts_the_classifiers_windows_and_names_the_features_most_often_beyond():
    unseen = np.array(["kurtosis", "crest_factor", "kurtosis", "kurtosis", "rms"])
    assert extrapolation_note(unseen, 5).startswith("all 5 windows the classifier decided hold a feature beyond")
    assert extrapolation_note(unseen, 8) == (
        "5 of the 8 windows the classifier decided hold a feature beyond its range over the training windows by more "
        "than 25% of that range (kurtosis in 3 windows, rms in 1 window, crest_factor in 1 window): the classifier "
        "extrapolates there, and its probabilities do not say so; hold its verdict against the physics evidence")
    assert extrapolation_note(np.array(["rms"]), 1).startswith("the one window the classifier decided holds a feature "
                                                                "beyond its range over the training windows by more "
                                                                "than 25% of that range (rms in 1 window)")


def test_a_served_model_that_reads_the_level_flags_each_window_of_a_level_it_never_saw():
    """Windows in an undeclared unit or gain had been answered 200 with a confident wrong state (an SVM read outer-race
    windows x1000 as ball): the frame of a model that reads the level now says, per window, where it lies a decade or
    more outside the training windows' levels, by the check bearingtwin-diagnose names a record by; the columns that
    were there are unchanged."""
    from bearingtwin.features.extractor import RawFeatures
    from bearingtwin.models.experiment import training_window_level

    X, y = class_windows(n_per_class=6)
    raw = RawFeatures().fit(X)
    level = training_window_level(SimpleNamespace(windows=X, window_normalization="none"), np.arange(len(X)))
    pipeline = DiagnosisPipeline(raw, SvmClassifier().fit(raw.transform(X), y), 2048, FS, unit="g", window_level=level)
    windows = X[::4]
    frame = served_model(pipeline).predict(None, np.concatenate([windows, windows[:2] * 1000, windows[:1] / 100]), {})
    assert list(frame.columns) == ["state", "normal", "inner", "outer", "level_unseen"]
    assert list(frame["level_unseen"]) == [False] * len(windows) + [True] * 3
    assert pipeline.level_note(windows * 1000) is not None and pipeline.level_note(windows) is None


def test_a_pipeline_that_puts_physics_first_overrules_its_classifier_only_where_the_physics_decides(tmp_path):
    """A classifier that learnt an outer-race train as inner (as one path's lines may teach it another's) is
    overruled on clear outer-race windows, not on noise; a state the classifier never learnt is never named;
    the rule is saved with the model, and a model's frame says who decided each window."""
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    X, y = class_windows(n_per_class=6)
    crossed = np.where(y == 3, 1, np.where(y == 1, 3, y))  # inner and outer learnt the wrong way round
    envelope = EnvelopeOrderFeatures(bearing=BEARING, line_measure="prominence").fit(X, fs_hz=FS, rpm=RPM)
    classifier = SvmClassifier().fit(envelope.transform(X, fs_hz=FS, rpm=RPM), crossed)
    plain = DiagnosisPipeline(envelope, classifier, 2048, FS, bearing=BEARING)
    gated = dataclasses.replace(plain, physics_first=PhysicsFirst())
    outer = fault_signal(rates["bpfo"], seconds=4 * 2048 / FS, seed=7).reshape(4, 2048)
    noise = fault_signal(None, seconds=2 * 2048 / FS, seed=8).reshape(2, 2048)
    ball = fault_signal(2 * rates["bsf"], seconds=2 * 2048 / FS, seed=9).reshape(2, 2048)
    windows = np.concatenate([outer, noise, ball])
    assert list(plain.predict(windows, RPM)[0][:4]) == ["inner"] * 4
    decision = gated.decide(windows, RPM)
    states, probabilities, by_physics = decision.states, decision.probabilities, decision.by_physics
    assert list(states[:4]) == ["outer"] * 4 and by_physics[:4].all()
    assert list(states[4:]) == list(plain.predict(windows, RPM)[0][4:]) and not by_physics[4:].any()  # ball: unknown
    np.testing.assert_array_equal(probabilities, plain.predict_proba(windows, RPM))  # the classifier's, throughout
    loaded = DiagnosisPipeline.load(gated.save(tmp_path / "gated"))
    assert loaded.physics_first == PhysicsFirst() and DiagnosisPipeline.load(plain.save(tmp_path / "plain")).physics_first is None
    # An earlier version refuses a model whose rule it would not apply; a plain model keeps the layout it reads.
    assert [json.loads((tmp_path / name / "pipeline.json").read_text())["format"] for name in ("gated", "plain")] == [2, 1]
    frame = predictions_frame(loaded, windows, RPM)
    assert list(frame["decided_by"]) == ["physics"] * 4 + ["classifier"] * 4
    assert "decided_by" not in predictions_frame(plain, windows, RPM)
    # Features that read no defect orders need no speed, but the physics does; it reads the windows raw.
    vmd = SaboVmdFeatures(population=3, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False)
    vmd_classifier = SvmClassifier().fit(vmd.fit(X, crossed).transform(X), crossed)
    vmd_plain = DiagnosisPipeline(vmd, vmd_classifier, 2048, FS, window_normalization="zscore", bearing=BEARING)
    vmd_gated = dataclasses.replace(vmd_plain, physics_first=PhysicsFirst())
    assert not vmd_plain.needs_rpm and vmd_gated.needs_rpm and not vmd_gated.reads_defect_orders
    assert list(vmd_gated.predict(outer, RPM)[0]) == ["outer"] * 4
    assert vmd_gated.bands_on_shaft_harmonics(bearing_config("cwru_6203")) == []
    with pytest.raises(BearingTwinError, match="rpm: this model's physics_first reads a window's defect lines at the "
                                               "shaft's speed; give the shaft speed"):
        vmd_gated.predict(windows)
    # Served, the refusal says where a request gives the speed (one beside "inputs" is read nowhere).
    from bearingtwin.diagnosis.mlflow_model import DiagnosisModel

    served = DiagnosisModel()
    served.pipeline = vmd_gated
    with pytest.raises(BearingTwinError, match=r'give the shaft speed \(a request gives it under "params", beside '
                                               r'"inputs": \{"params": \{"rpm": 1797\}\}\)$'):
        served.predict(None, windows, params={"rpm": 0.0})


def test_the_physics_first_note_says_what_the_classifier_decided_and_not_a_rest_where_none_was_left():
    from bearingtwin.diagnosis.record import physics_first_note

    pipeline = SimpleNamespace(physics_first=SimpleNamespace(threshold_db=20.0, margin_db=10.0))
    some = physics_first_note(pipeline, np.array(["physics", "classifier", "classifier"]))
    assert some.startswith("1 of 3 windows decided by the envelope spectrum, where one defect series stood 20 dB or "
                           "more over its floor and 10 dB above the others; the classifier decided the rest")
    every = physics_first_note(pipeline, np.array(["physics", "physics"]))
    assert every.startswith("2 of 2 windows") and "the classifier decided none (probabilities" in every
    assert "the rest" not in every


def test_a_defect_series_on_shaft_harmonics_is_not_read_as_evidence(tmp_path):
    """On the CWRU fan end's SKF 6203, 2 x BSF is 3.988 shaft orders: a machine's 4 x shaft line (impacts once
    a quarter turn, as a four-bladed fan or a twice-line-frequency electrical line at 1797 rpm gives) is not
    a ball fault's. The ball series is said to be unreadable there and never named; the races' series,
    whose lines lie outside their search bands' reach of the shaft's, are read as before."""
    fan_end = bearing_config("cwru_6203")
    shaft_hz = RPM / 60.0
    four_per_turn = physics_evidence(fault_signal(4 * shaft_hz), FS, RPM, fan_end)
    assert four_per_turn.evidence_state != "ball" and "ball" not in four_per_turn.prominence_db
    assert "2 x BSF fundamental, 3.988 shaft orders, has 4 x shaft within its search band" in four_per_turn.unreadable["ball"]
    rates = BearingGeometry.from_config(fan_end).defect_frequencies(RPM)
    assert physics_evidence(fault_signal(rates["bpfo"]), FS, RPM, fan_end).evidence_state == "outer"
    assert physics_evidence(fault_signal(rates["bpfi"]), FS, RPM, fan_end).evidence_state == "inner"
    assert physics_evidence(fault_signal(4 * shaft_hz), FS, RPM, BEARING).unreadable == {}  # the drive end's reads all
    # At 100 rpm every series of the 6205 lies within a 1 Hz bin of a shaft harmonic: no answer, and none scored.
    slow = physics_evidence(fault_signal(None, seconds=2), FS, 100.0, BEARING)
    assert slow.evidence_state is None and set(slow.unreadable) == {"inner", "ball", "outer"} and slow.lines_hz == {}
    assert "has 5 x shaft within its search band (+-1.0 Hz: 1 Hz bins)" in slow.unreadable["inner"]
    windows = [{"start_s": 0.0, "state": "outer", "probabilities": {"normal": 0.1, "outer": 0.9}}]
    result = {"record": "slow", "verdict": "outer", "share": 1.0, "mean_probability": 0.9, "windows": windows,
              "evidence_state": None, "evidence": slow.as_dict()}
    assert plot_diagnosis(result, slow, ["normal", "outer"], tmp_path / "slow.png").stat().st_size > 1000
    assert one_line(result) == "slow: outer (100% of 1 window, p 0.90)"


def test_a_record_whose_windows_split_between_states_says_what_the_others_said():
    """A long recording that turned from healthy to faulty half-way wins one state by a window: the line says the
    rest went to another (a state under a tenth of the windows is left unsaid)."""
    windows = [{"start_s": float(i), "state": "normal" if i < 175 else "outer", "probabilities": {}} for i in range(351)]
    windows[-1]["state"] = "ball"
    result = {"record": "changed", "verdict": "outer", "share": 175 / 351, "mean_probability": 0.61,
              "window_states": {"normal": 175, "inner": 0, "ball": 1, "outer": 175}, "windows": windows,
              "evidence_state": None}
    assert one_line(result) == "changed: outer (50% of 351 windows, p 0.61; the others: normal 50%)"
    states = np.array([window["state"] for window in windows])
    even = np.tile([[0.2, 0.1, 0.2, 0.5]], (351, 1))  # outer most probable: it wins the tie of windows
    assert majority(states, even, list(FAULTS)) == ("outer", {"normal": 175, "inner": 0, "ball": 1, "outer": 175})
    # A tie the envelope spectrum decided windows of goes to its state, however sure the classifier was of the other.
    two = np.array(["inner", "ball"])
    sure_of_ball = np.array([[0.0, 1e-6, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    assert majority(two, sure_of_ball, list(FAULTS))[0] == "ball"
    assert majority(two, sure_of_ball, list(FAULTS), np.array(["physics", "classifier"]))[0] == "inner"
    # Where the envelope spectrum decided windows, the classifier's own verdict is said beside the record's.
    for window in windows[175:]:
        window["decided_by"] = "physics"
    decided = {**result, "classifier_verdict": "ball", "physics_decided": 176 / 351}
    assert one_line(decided) == ("changed: outer (50% of 351 windows, 176 decided by the envelope spectrum; classifier "
                                 "p 0.61; the others: normal 50%; the windows left to the classifier: ball)")


def test_features_that_read_shaft_orders_on_the_recorded_bearing_but_not_the_models_are_named():
    pipeline = envelope_pipeline()
    on_shaft = pipeline.bands_on_shaft_harmonics(bearing_config("cwru_6203"))
    assert {"1xbsf2", "1xbpfo", "1xbpfi"} <= set(on_shaft) and "3xbsf2" not in on_shaft  # 14.14 orders on the 6205 too
    assert pipeline.bands_on_shaft_harmonics(BEARING) == []


def envelope_pipeline(bearing: dict = BEARING) -> DiagnosisPipeline:
    """A small envelope-order SVM pipeline on synthetic windows at ``FS``, for ``bearing`` (the drive end's)."""
    X, y = class_windows(n_per_class=6)
    envelope = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence").fit(X, fs_hz=FS, rpm=RPM)
    return DiagnosisPipeline(envelope, SvmClassifier().fit(envelope.transform(X, fs_hz=FS, rpm=RPM), y), 2048, FS,
                             bearing=bearing)


def test_a_unit_given_fills_in_for_a_file_that_states_none_and_is_refused_against_one_that_states_another(tmp_path):
    """A float WAV in g, read by a model of m/s^2 as if in m/s^2 (9.81 times too weak, within the level check's
    decade), had been called inner where it was outer, and only another file format could say its unit: unit=g
    converts it; a unit the file contradicts, or text no unit known here, is refused naming the setting."""
    import scipy.io.wavfile

    path = tmp_path / "pump.wav"
    scipy.io.wavfile.write(path, int(FS), (fault_signal(None, seconds=2) / 9.80665).astype(np.float32))
    from bearingtwin.features.extractor import RawFeatures

    X, y = class_windows(n_per_class=4)
    pipeline = DiagnosisPipeline(RawFeatures().fit(X), SvmClassifier().fit(X, y), 2048, FS, unit="m/s^2")  # reads levels
    assert read_record(path, pipeline, rpm=RPM).unit_check == "assumed"
    given = read_record(path, pipeline, rpm=RPM, unit="g")
    assert given.unit_check == "converted" and given.recording.unit == "m/s^2"
    np.savez(tmp_path / "stated.npz", signal=fault_signal(None, seconds=2), fs=FS, unit="m/s^2")
    with pytest.raises(BearingTwinError, match=r"stated.npz: unit=g contradicts the file's unit, m/s\^2$"):
        read_record(tmp_path / "stated.npz", pipeline, rpm=RPM, unit="g")
    assert read_record(tmp_path / "stated.npz", pipeline, rpm=RPM, unit="m/s2").unit_check == "as stated"
    with pytest.raises(BearingTwinError, match=r"^unit='furlongs' is no unit known here; give one such as g"):
        read_record(path, pipeline, rpm=RPM, unit="furlongs")
    # A folder's unit= is for its files that state none (unit_fills_in): one that states its own keeps it, said so
    # (a folder of a logger's WAVs in g beside files in m/s^2 had failed every file that stated m/s^2).
    in_folder = read_record(tmp_path / "stated.npz", pipeline, rpm=RPM, unit="g", unit_fills_in=True)
    assert in_folder.unit_check == "as stated" and in_folder.recording.unit == "m/s^2"
    assert "unit=g given for the files that state none; this one states m/s^2: read in it" in in_folder.notes
    filled = read_record(path, pipeline, rpm=RPM, unit="g", unit_fills_in=True)
    assert filled.unit_check == "converted" and not any("files that state none" in note for note in filled.notes)


def test_a_scale_reads_a_loggers_volts_or_full_scale_fractions_in_the_unit_given(tmp_path):
    """An int16 WAV of a 100 mV/g accelerometer on a +-5 V logger holds 1 g as 0.02 of full scale: read as if in the
    model's g, 50 times too weak (within the level check's decade), and volts were refused with no setting to read them
    by. scale= multiplies the samples, unit= naming the unit they are then in; the file's own unit is what it converts
    from, and a scale without a unit, or not a positive number, is refused naming the setting."""
    import scipy.io.wavfile

    from bearingtwin.features.extractor import RawFeatures

    X, y = class_windows(n_per_class=4)
    pipeline = DiagnosisPipeline(RawFeatures().fit(X), SvmClassifier().fit(X, y), 2048, FS, unit="g")  # reads levels
    in_g = fault_signal(None, seconds=2)
    path = tmp_path / "logger.wav"
    scipy.io.wavfile.write(path, int(FS), np.round(in_g * 0.02 * 32767).astype(np.int16))
    prepared = read_record(path, pipeline, rpm=RPM, unit="g", scale=50)
    assert prepared.unit_check == "as stated" and prepared.recording.unit == "g"
    np.testing.assert_allclose(prepared.recording.signal, in_g, atol=50 / 32767)
    assert "samples x 50 read in g (scale=50 unit=g)" in prepared.notes
    np.savez(tmp_path / "volts.npz", signal=in_g * 0.1, fs=FS, unit="V")  # 100 mV/g
    volts = read_record(tmp_path / "volts.npz", pipeline, rpm=RPM, unit="g", scale=10)
    np.testing.assert_allclose(volts.recording.signal, in_g, rtol=1e-12)
    assert "samples x 10 read in g (scale=10 unit=g; the file states V)" in volts.notes
    # A file in one acceleration unit is converted to another by the units themselves: a scale naming another (scale=1
    # unit=g on a file in m/s^2, read 9.81 times too strong) is refused; one in its own unit corrects a gain.
    np.savez(tmp_path / "si.npz", signal=in_g * 9.80665, fs=FS, unit="m/s^2")
    with pytest.raises(BearingTwinError, match=r"si.npz: unit=g with scale=1, but the file states its samples in m/s\^2, "
                                               r"which is converted to g by itself"):
        read_record(tmp_path / "si.npz", pipeline, rpm=RPM, unit="g", scale=1)
    gained = read_record(tmp_path / "si.npz", pipeline, rpm=RPM, unit="m/s^2", scale=2)
    np.testing.assert_allclose(gained.recording.signal, 2 * in_g, rtol=1e-9)  # in the model's g
    # A folder's scale= reads the files that state no unit or volts; one in g or m/s^2 keeps its own, said so (a file
    # in g beside volts had been multiplied by the volts' scale).
    kept = read_record(tmp_path / "si.npz", pipeline, rpm=RPM, unit="g", scale=10, unit_fills_in=True)
    np.testing.assert_allclose(kept.recording.signal, in_g, rtol=1e-9)
    assert "scale=10 unit=g given for the files that state none or volts; this one states m/s^2: read in it" in kept.notes
    folder_volts = read_record(tmp_path / "volts.npz", pipeline, rpm=RPM, unit="g", scale=10, unit_fills_in=True)
    np.testing.assert_allclose(folder_volts.recording.signal, in_g, rtol=1e-12)
    with pytest.raises(BearingTwinError, match=r"^scale=10 needs unit=<unit>: the unit the samples are in once "
                                               r"multiplied by 10"):
        read_record(tmp_path / "volts.npz", pipeline, rpm=RPM, scale=10)
    with pytest.raises(BearingTwinError, match=r"^scale=-1 must be a positive number of the unit given per unit of the file's "
                                               r"samples"):
        read_record(path, pipeline, rpm=RPM, unit="g", scale=-1)


def test_a_record_stamped_in_seconds_under_a_header_of_milliseconds_names_the_rate_its_stamps_gave(tmp_path):
    """Read a thousand times too fast, a 3 s record had been called shorter than one window, with no word of the
    stamps: the refusal names the rate they gave, and the rate given then reads the record."""
    path = tmp_path / "pump.csv"
    signal = fault_signal(None, seconds=3)
    np.savetxt(path, np.column_stack([np.arange(signal.size) / FS, signal]), delimiter=",", header="time [ms],acc",
               comments="", fmt="%.9f")
    pipeline = envelope_pipeline()
    with pytest.raises(BearingTwinError, match=r"pump.csv: 0.003 s, shorter than one window of the model's .*; read at "
                                               r"1.2e\+07 Hz, the rate its time stamps give: if their values are in "
                                               r"another unit than the column's name states, give fs=<Hz>$"):
        read_record(path, pipeline, rpm=RPM)
    prepared = read_record(path, pipeline, fs=FS, rpm=RPM)
    assert prepared.recording.fs == FS and prepared.recording.duration == pytest.approx(3.0)
    # A record stamped right that is just short (0.1 s at 12 kHz) is not sent after its stamps' unit.
    short = tmp_path / "short.csv"
    np.savetxt(short, np.column_stack([np.arange(1200) / FS, signal[:1200]]), delimiter=",", header="time [s],acc",
               comments="", fmt="%.9f")
    with pytest.raises(BearingTwinError, match=r"short.csv: 0.100 s, shorter than one window of the model's \(\d+ samples "
                                               r"at 12000 Hz, [\d.]+ s\)$"):
        read_record(short, pipeline, rpm=RPM)
    # At a rate no ratio of small integers brings to the model's (8 kHz stamped as ms: 8 MHz), the resampling's
    # refusal had said nothing of the stamps.
    slow = fault_signal(None, seconds=3)[::3]  # 4 kHz: 4 MHz read
    np.savetxt(tmp_path / "slow.csv", np.column_stack([np.arange(slow.size) / 4093.0, slow]), delimiter=",",
               header="time [ms],acc", comments="", fmt="%.9f")
    with pytest.raises(BearingTwinError, match=r"slow.csv: cannot resample 4.093e\+06 Hz to the model's 12000 Hz by a "
                                               r"ratio of small integers; 4.093e\+06 Hz is the rate its time stamps "
                                               r"give: if their values are in another unit"):
        read_record(tmp_path / "slow.csv", pipeline, rpm=RPM)


@needs_cwru
def test_a_cwru_record_is_read_at_the_bearing_it_was_made_on_whatever_the_models():
    """A drive-end fault record names the SKF 6205 by its name's end, as a fan-end one names the 6203: read at
    the model's bearing's orders (a 6203 model here) its outer-race lines had been taken for inner-race ones.
    A healthy record's bearing is the one under the accelerometer read."""
    pipeline = envelope_pipeline(bearing_config("cwru_6203"))
    prepared = read_record(CWRU / "12k_Drive_End_OR007@6_1_131.mat", pipeline)
    assert prepared.bearing == BEARING
    assert any("the record's bearing is cwru_6205, the model was trained on cwru_6203" in note
               for note in prepared.notes), prepared.notes
    rpm = prepared.recording.rpm
    assert physics_evidence(prepared.recording.signal, FS, rpm, prepared.bearing).evidence_state == "outer"
    assert read_record(CWRU / "normal_0_97.mat", pipeline).bearing == BEARING
    assert read_record(CWRU / "normal_0_97.mat", pipeline, channel="FE").bearing == bearing_config("cwru_6203")


@needs_cwru
def test_a_speed_given_at_half_that_the_cage_lines_witness_is_named_with_the_speed_the_shaft_series_stands_at(tmp_path):
    """An outer-race record's samples, its speed given at half: the cage's envelope lines, read at their second
    harmonic, had confirmed the rate and the speed, and the record was diagnosed at half its speed with no doubt. The
    shaft series stands where it belongs at twice the speed given: the note names that speed, the verdict in doubt."""
    from bearingtwin.data.cwru import load_cwru

    recording = load_cwru(CWRU / "12k_Drive_End_OR007@6_0_130.mat")
    np.save(tmp_path / "pump.npy", recording.signal)
    pipeline = envelope_pipeline()
    half = read_record(tmp_path / "pump.npy", pipeline, fs=12000, rpm=recording.rpm / 2, bearing="cwru_6205")
    assert half.rate_check == "contradicted"
    assert any(note.startswith(f"the speed contradicts the record: at {recording.rpm / 2:g} rpm") and
               f"stand where they belong at {recording.rpm:g} rpm (2 times the stated): check the speed given" in note
               for note in half.notes), half.notes
    true = read_record(tmp_path / "pump.npy", pipeline, fs=12000, rpm=recording.rpm, bearing="cwru_6205")
    assert true.rate_check == "consistent", true.notes


@needs_cwru
def test_a_rate_given_against_the_names_one_that_the_shaft_line_bears_out_is_refused(tmp_path):
    """``fs=48000`` for a ``12k_`` file had been read at it, its verdict wrong and only "in doubt"; the name and the
    shaft line are two witnesses against one typed number. A file whose name is the wrong one is read at the rate
    given where the shaft line bears that out, the name's rate noted."""
    import scipy.io

    pipeline = envelope_pipeline()
    path = CWRU / "12k_Drive_End_OR007@6_1_131.mat"
    with pytest.raises(BearingTwinError, match=(
            r"12k_Drive_End_OR007@6_1_131.mat: fs=48000 Hz given, where its name states 12000 Hz, and the shaft line "
            r"stands where it belongs at 12000 Hz, not at 48000 Hz: give this file no rate \(its name's is read\)$")):
        read_record(path, pipeline, fs=48000)
    assert read_record(path, pipeline, fs=12000).rate_check == "consistent"
    misnamed = tmp_path / "48k_Drive_End_OR007@6_1_136.mat"  # 12 kHz samples under a 48 kHz record's name
    stored = scipy.io.loadmat(path)
    scipy.io.savemat(misnamed, {key.replace("X131", "X136"): value for key, value in stored.items()
                                if not key.startswith("__")})
    prepared = read_record(misnamed, pipeline, fs=12000)
    assert prepared.original_fs == 12000 and prepared.rate_check == "consistent"
    assert any("fs=12000 Hz given, where its name states 48000 Hz" in note for note in prepared.notes), prepared.notes
    # Given no rate, the name's 48 kHz is contradicted and the Data Center's other rate bears the record out.
    found = read_record(misnamed, pipeline)
    assert found.original_fs == 12000 and found.rate_check == "consistent"
    assert ("the shaft line stands where it belongs at 12000 Hz, not at the declared 48000 Hz: read at 12000 Hz"
            in found.notes), found.notes


def test_a_fan_end_record_is_read_at_its_own_bearings_defect_lines(tmp_path, monkeypatch):
    """A CWRU fan-end fault sits in the SKF 6203 (BPFO 3.053 x shaft), a drive-end model's bearing is the 6205
    (3.585): the evidence and the model's defect-order features read the record's own bearing, which finds
    the fault; read at the model's bearing's orders, neither does."""
    import scipy.io

    rpm = 1772.0
    fan_end = bearing_config("cwru_6203")
    rate = BearingGeometry.from_config(fan_end).defect_frequencies(rpm)["bpfo"]
    t = np.arange(int(4 * FS)) / FS
    shaft = sum(0.1 / k * np.sin(2 * np.pi * k * rpm / 60 * t) for k in (1, 2, 3))  # what the rate is checked by
    fan = (fault_signal(rate) + shaft)[:, None]
    path = tmp_path / "12k_Fan_End_OR014@3_1_298.mat"
    scipy.io.savemat(path, {"X298_DE_time": (fault_signal(None, seed=1) + shaft)[:, None], "X298_FE_time": fan,
                            "X298RPM": rpm})
    pipeline = envelope_pipeline()
    prepared = read_record(path, pipeline)
    assert prepared.recording.channel == "FE" and prepared.bearing == fan_end and prepared.true_state == "outer"
    assert any("the record's bearing is cwru_6203, the model was trained on cwru_6205" in note
               and "BPFO 3.053" in note and "BPFO 3.585" in note for note in prepared.notes), prepared.notes
    signal = prepared.recording.signal
    assert physics_evidence(signal, FS, rpm, prepared.bearing).evidence_state == "outer"
    assert physics_evidence(signal, FS, rpm, BEARING).evidence_state != "outer"  # the drive end's lines miss it
    windows, *_ = diagnosed_windows(prepared, pipeline.window_length)
    outer_lines = [pipeline.extractor.feature_names_.index(f"{h}xbpfo") for h in (1, 2, 3)]
    at_its_own = pipeline.features(windows, rpm, prepared.bearing)[:, outer_lines]  # log10 line / floor
    at_the_models = pipeline.features(windows, rpm)[:, outer_lines]
    assert np.median(at_its_own) > 1.0 > np.median(np.abs(at_the_models)), (at_its_own, at_the_models)
    at_its_own, _ = pipeline.predict(windows, rpm, prepared.bearing)
    at_the_models, _ = pipeline.predict(windows, rpm)
    assert np.mean(at_its_own == "outer") > 0.9
    # The same through the logged MLflow model, whose signature takes the bearing as a parameter (the model's
    # own by default), as bearingtwin-diagnose and a model server ask it.
    import mlflow.tracking._model_registry.utils as registry_uri
    import mlflow.tracking._tracking_service.utils as tracking_uri

    # Logging and loading set MLflow's process-wide store URIs (and their environment variables): restored
    # after this test, for the others in this process.
    monkeypatch.setattr(tracking_uri, "_tracking_uri", tracking_uri._tracking_uri)
    monkeypatch.setattr(registry_uri, "_registry_uri", registry_uri._registry_uri)
    for variable in ("MLFLOW_TRACKING_URI", "MLFLOW_REGISTRY_URI"):
        monkeypatch.setitem(os.environ, variable, os.environ.get(variable, ""))
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(uri)
    # An artifact location of its own: MLflow's default is ./mlruns, the checkout when the suite runs there.
    run_id = client.create_run(client.create_experiment("fan_end", (tmp_path / "artifacts").as_uri())).info.run_id
    info = log_diagnosis_model(uri, client.get_run(run_id).info.experiment_id, run_id, pipeline, windows, rpm)
    model, loaded, _ = load_diagnosis_model(info.model_uri, uri)
    assert model_params(model) == {"rpm", "bearing", "fs", "unit", "scale"}
    served = model.predict(windows, params={"rpm": rpm, "bearing": "cwru_6203"})
    np.testing.assert_array_equal(served["state"].to_numpy(), at_its_own)
    np.testing.assert_array_equal(model.predict(windows, params={"rpm": rpm})["state"].to_numpy(), at_the_models)
    with pytest.raises(BearingTwinError, match="bearing=cwru_9999: no such bearing config"):
        model.predict(windows, params={"rpm": rpm, "bearing": "cwru_9999"})
    # No speed unless one is given: the signature's default is 0 (not the example's), and the model needs one.
    (rpm_spec,) = [spec for spec in model.metadata.get_params_schema().params if spec.name == "rpm"]
    assert rpm_spec.default == 0.0
    for params in ({}, {"rpm": 0.0}):
        with pytest.raises(MlflowException, match="rpm: this model's features are read on the shaft-order axis"):
            model.predict(windows, params=params)
    with pytest.raises(BearingTwinError, match=r"^rpm=-5.0 must be a positive number of rev/min"):
        model.predict(windows, params={"rpm": -5.0})
    broken = windows.copy()
    broken[1, 7] = np.nan
    with pytest.raises(BearingTwinError, match=r"^windows 1 \(of \d+, counted from 0\) hold NaN or infinite values"):
        model.predict(broken, params={"rpm": rpm})
    with warnings.catch_warnings():  # the one line alone, no numpy warnings of the overflow before it
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(BearingTwinError, match=r"^windows 0, 1, 2, 3, 4, \.\.\. \(counted from 0\): features not "
                                                    r"finite, values up to .*e\+1\d\d overflow them"):
            model.predict(windows * 1e160, params={"rpm": rpm})  # this model reads windows as they are (no z-score)
    result, _ = diagnose_recording(prepared, model, loaded, info.model_uri, {})
    assert result["verdict"] == "outer" and result["evidence_state"] == "outer"
    assert sum(result["window_states"].values()) == len(result["windows"])
    assert result["window_states"]["outer"] == round(result["share"] * len(result["windows"]))
    assert "the model's features read cwru_6203's defect lines too" in result["notes"], result["notes"]
    # A bearing given wins over the file's name, and says so.
    given = read_record(path, pipeline, bearing="cwru_6205")
    assert given.bearing == BEARING and any("bearing=cwru_6205 given, where the file names cwru_6203" in n for n in given.notes)
    drive_end = tmp_path / "12k_Drive_End_OR014@6_1_198.mat"
    scipy.io.savemat(drive_end, {"X198_DE_time": fan, "X198RPM": rpm})
    assert read_record(drive_end, pipeline).bearing == BEARING and not read_record(drive_end, pipeline).notes


@pytest.mark.parametrize("fs", [FS, 48000.0])  # read at the model's rate, and resampled to it
def test_samples_with_no_value_are_bridged_for_the_record_and_their_windows_left_out(tmp_path, fs):
    """A logger's lost packets, written as NaN, had refused the whole record. The gaps are bridged for the readings of
    the whole record (rate, physics evidence), and the windows touching them are left out, as a dropout's are: no value
    is made up for the model. A record every window of which touches one is refused, naming it."""
    rate = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)["bpfo"]
    x = fault_signal(rate, fs=fs)
    for start_s in (1.0, 2.5, 3.3):  # three 10 ms gaps
        x[int(start_s * fs):int((start_s + 0.01) * fs)] = np.nan
    path = tmp_path / "logger.npz"
    np.savez(path, signal=x, fs=fs, rpm=RPM, unit="g")
    pipeline = envelope_pipeline()
    prepared = read_record(path, pipeline)
    assert (f"{np.isnan(x).sum()} samples hold no value (NaN or infinite) in 3 stretches from 1 s to 3.31 s: bridged "
            "for the readings of the whole record (the sampling rate checked on the longest stretch without one), no "
            "window touching one diagnosed") in prepared.notes
    assert np.isfinite(prepared.recording.signal).all() and len(prepared.gaps_s) == 3
    model = SimpleNamespace(predict=lambda windows, params: predictions_frame(pipeline, windows, params["rpm"]))
    result, evidence = diagnose_recording(prepared, model, pipeline, "models:/unused", {})
    starts = np.array([window["start_s"] for window in result["windows"]])
    window_s = pipeline.window_length / FS
    for start_s in (1.0, 2.5, 3.3):  # no window read kept a sample of a gap
        assert not np.any((starts < start_s + 0.01) & (starts + window_s > start_s)), (start_s, starts)
    assert result["windows_left_out"] == int(4.0 * FS) // pipeline.window_length - len(starts) > 0
    said = re.search(rf"the {result['windows_left_out']} windows touching samples with no value, (.*), left out; the "
                     rf"verdict is the other {len(starts)} of ", " ".join(result["notes"]))
    spans = [(float(start), float(end)) for start, end in re.findall(r"from (\S+) s to (\S+) s", said[1])]
    assert len(spans) == 3 and all(start <= gap_s and gap_s + 0.01 <= end < gap_s + 0.01 + 2 * window_s
                                   for (start, end), gap_s in zip(spans, (1.0, 2.5, 3.3))), said[1]
    assert result["verdict"] == "outer" and evidence.evidence_state == "outer"
    # A logger that started late and stopped early: its end gaps are no stretch held at one value (a dropout).
    edges = x.copy()
    edges[:int(0.3 * fs)] = edges[-int(0.2 * fs):] = np.nan
    np.savez(path, signal=edges, fs=fs, rpm=RPM, unit="g")
    prepared = read_record(path, pipeline)
    assert not any("dropout" in note for note in prepared.notes), prepared.notes
    assert any(note.startswith(f"{np.isnan(edges).sum()} samples hold no value (NaN or infinite) in 5 stretches from "
                               "0 s to 4 s") for note in prepared.notes), prepared.notes
    x[::int(0.1 * fs)] = np.nan  # one every 0.1 s: every window touches one, and no stretch between two holds one
    np.savez(path, signal=x, fs=fs, rpm=RPM, unit="g")
    with pytest.raises(BearingTwinError, match=r"logger.npz: every window of the model's .* touches a stretch with no "
                                               r"value .*; no stretch between them holds one \(the longest: \d+ samples\)$"):
        diagnose_recording(read_record(path, pipeline), model, pipeline, "models:/unused", {})
    x[int(0.5 * fs)] = 0.0  # 0.2 s between two, a window's length and more, which no window of the grid falls in
    np.savez(path, signal=x, fs=fs, rpm=RPM, unit="g")
    with pytest.raises(BearingTwinError, match=r"; the longest stretch between them, \d+ samples from 0.4\d* s, holds "
                                               r"one: give each such stretch as a file of its own$"):
        diagnose_recording(read_record(path, pipeline), model, pipeline, "models:/unused", {})


@pytest.mark.skipif(not (CWRU / "12k_Drive_End_OR007@6_1_131.mat").exists(), reason="CWRU record 131 not present")
@pytest.mark.parametrize("gap", [(60000, 10), (60000, 500)])
def test_a_gap_in_a_real_record_leaves_its_sampling_rate_confirmed(tmp_path, gap):
    """Ten lost samples in the middle of CWRU record 131 (10 s): any value in their place is a click whose flat
    spectrum fills the quiet band where the shaft's lines stand, and the rate check, reading the whole bridged record,
    had called 12 kHz contradicted (fs = 3005 Hz; with 500 samples lost, 6687 Hz). The check reads the longest stretch
    without a gap, and confirms the rate as it does on the whole record; the note says which stretch it read and where
    the gap is, as one stretch."""
    import scipy.io

    variables = scipy.io.loadmat(CWRU / "12k_Drive_End_OR007@6_1_131.mat")
    x = variables["X131_DE_time"].ravel().copy()
    rpm = float(variables["X131RPM"].ravel()[0])
    start, length = gap
    x[start:start + length] = np.nan
    path = tmp_path / "logger.npz"
    np.savez(path, signal=x, fs=12000.0, rpm=rpm, unit="g")
    prepared = read_record(path, envelope_pipeline(), bearing="cwru_6205")
    assert prepared.rate_check == "consistent", prepared.notes
    assert not any("contradicts" in note or "disagree" in note for note in prepared.notes), prepared.notes
    assert any(note.startswith(f"{length} samples hold no value (NaN or infinite) in one stretch at "
                               f"{start / 12000:.4g} s:") for note in prepared.notes), prepared.notes
    # The check itself: a channel with no value somewhere is read on its longest stretch of values, not refused.
    bridged_line = x.copy()
    bridged_line[start:start + length] = np.linspace(x[start - 1], x[start + length], length + 2)[1:-1]
    assert check_channels({"DE": bridged_line}, 12000.0, rpm)["DE"].verdict == "contradicted"  # what the bridge did
    assert check_channels({"DE": x}, 12000.0, rpm)["DE"].verdict == "consistent"
    with pytest.raises(BearingTwinError, match="needs a channel with finite samples"):
        check_channels({"DE": np.full(1000, np.nan)}, 12000.0, rpm)


def test_a_clipped_record_and_a_dropout_are_named_in_the_diagnosis_notes(tmp_path):
    """Neither makes a record unreadable, both spoil what a diagnosis reads: the notes say so and where."""
    import scipy.io
    import scipy.signal

    rate = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)["bpfo"]
    x = fault_signal(rate)
    limit = 1.5 * np.sqrt(np.mean(x**2))
    x = np.clip(x, -limit, limit)
    x[int(2.0 * FS):int(2.25 * FS)] = 0.0
    path = tmp_path / "12k_Drive_End_OR007@6_0_130.mat"
    scipy.io.savemat(path, {"X130_DE_time": x[:, None], "X130RPM": RPM})
    notes = read_record(path, envelope_pipeline()).notes
    assert any("% of the samples pile up at its maximum" in note and "clipped" in note for note in notes), notes
    assert any(note.startswith("samples from 2 s to 2.25 s are all 0 (a dropout") for note in notes), notes
    # A dropout a window of the model's long or longer had failed the record: the windows it touches are left out
    # (windows 11 to 17 of 23), said where in seconds, and the others diagnosed.
    x[int(2.0 * FS):int(3.0 * FS)] = 0.0
    scipy.io.savemat(path, {"X130_DE_time": x[:, None], "X130RPM": RPM})
    pipeline = envelope_pipeline()
    model = SimpleNamespace(predict=lambda windows, params: predictions_frame(pipeline, windows, params["rpm"]))
    result, _ = diagnose_recording(read_record(path, pipeline), model, pipeline, "models:/unused", {})
    assert [window["start_s"] for window in result["windows"]] == [2048 * k / FS for k in (*range(11), *range(18, 23))]
    assert ("samples from 2 s to 3 s are all 0 (a dropout, or a stretch held at one value): the 7 windows touching it, "
            "from 1.877 s to 3.072 s, left out; the verdict is the other 16 of 23 windows'") in result["notes"], result["notes"]
    assert sum("samples from 2 s to 3 s are all 0" in note for note in result["notes"]) == 1  # said once, not twice
    # The clipping puts the verdict in doubt where it is read first, the record's own line.
    assert result["clipped"] and " - IN DOUBT: it clipped, which flattens the impacts; true outer" in one_line(result)
    assert result["windows_left_out"] == 7
    assert result["verdict"] == "outer" and result["share"] == pytest.approx(
        sum(window["state"] == "outer" for window in result["windows"]) / 16)
    # Recorded at 25.6 kHz, the same dropout is found before the record is resampled to the model's rate, whose
    # filter's phases leave no two samples of it equal: the same windows are left out.
    fast = scipy.signal.resample_poly(x, 32, 15)
    fast[int(2.0 * 25600):int(3.0 * 25600)] = 0.25  # a logger holding its last value
    np.savez(tmp_path / "fast.npz", signal=fast, fs=25600.0, rpm=RPM, unit="g")
    prepared = read_record(tmp_path / "fast.npz", pipeline)
    assert not held_stretches(prepared.recording.signal, 2)  # resampled, it holds no value twice
    result, _ = diagnose_recording(prepared, model, pipeline, "models:/unused", {})
    assert result["windows_left_out"] == 7 and [window["start_s"] for window in result["windows"]] == [
        2048 * k / FS for k in (*range(11), *range(18, 23))]
    # A record every window of which touches a dropout has nothing left to read.
    x[int(0.1 * FS):] = 0.0
    scipy.io.savemat(path, {"X130_DE_time": x[:, None], "X130RPM": RPM})
    with pytest.raises(BearingTwinError, match=r"130.mat: samples from 0.1 s to 4 s are all 0 \(a dropout, or a stretch "
                                               r"held at one value\), and every window of the model's \(2048 samples\) "
                                               r"touches one, so none reads a vibration"):
        diagnose_recording(read_record(path, pipeline), model, pipeline, "models:/unused", {})


def test_a_hust_export_of_combined_damage_or_variable_speed_is_said_so(tmp_path, monkeypatch):
    """A C export (inner and outer races damaged together) states no state a model answers: not scored, said so,
    and a label calling it one of the four is refused; a VS export states why it has no speed."""
    from bearingtwin.twin.report import read_measurement

    monkeypatch.syspath_prepend(str(Path(__file__).parent / "fixtures"))
    import make_hust_fixtures as hust

    monkeypatch.setattr(hust, "N_ROWS", int(0.5 * hust.FS_HZ))
    for name in ("0.5X_C_65Hz.xls", "H_VS_0_40_0Hz.xls"):
        hust.write(name, hust.header_lines(hust.N_ROWS) + ["Data"] + hust.rows(hust.synthetic_axes("inner", 1)), tmp_path)
    combined = read_record(tmp_path / "0.5X_C_65Hz.xls", envelope_pipeline(), channel="X")
    assert combined.true_state is None
    assert any("inner and outer races damaged together (C in its name), a state this model cannot answer" in note
               for note in combined.notes), combined.notes
    with pytest.raises(BearingTwinError, match=r"0.5X_C_65Hz.xls: the label=outer given, but the file states inner "
                                               r"and outer races damaged together"):
        read_record(tmp_path / "0.5X_C_65Hz.xls", envelope_pipeline(), channel="X", true_state="outer")
    with pytest.raises(BearingTwinError, match=r"H_VS_0_40_0Hz.xls: the file is a variable-speed run \(VS_0_40_0Hz in "
                                               r"its name\): its speed changes over the record, and this model reads a "
                                               r"record at one shaft speed"):
        read_record(tmp_path / "H_VS_0_40_0Hz.xls", envelope_pipeline(), channel="X")
    # A speed given does not make a run-up one speed's: refused (it had been read at the speed given, no doubt said).
    with pytest.raises(BearingTwinError, match=r"H_VS_0_40_0Hz.xls: rpm=1500 given, but the file is a variable-speed "
                                               r"run \(VS_0_40_0Hz in its name\): its speed changes over the record: no "
                                               r"one speed describes it"):
        read_record(tmp_path / "H_VS_0_40_0Hz.xls", envelope_pipeline(), channel="X", rpm=1500)
    # The twin refuses either file, whether it is told the state or speed, holds a state the envelope spectrum names
    # (a combined damage had been held as the inner race's) or is given a speed.
    for name, words, rpm in (("0.5X_C_65Hz.xls", "inner and outer races damaged together", None),
                             ("H_VS_0_40_0Hz.xls", "a variable-speed run", None),
                             ("H_VS_0_40_0Hz.xls", "a variable-speed run", 1500)):
        for state_required in (True, False):
            with pytest.raises(BearingTwinError, match=rf"{name}: (the file states {words}|measured.rpm=1500 given)"):
                read_measurement(OmegaConf.create({"path": str(tmp_path / name), "channel": "X", "fault": None,
                                                   "rpm": rpm, "fs": None, "check_fs": True}),
                                 state_required=state_required)


def test_a_variable_speed_export_diagnosed_by_a_model_reading_no_speed_is_in_doubt_on_its_own_line(tmp_path,
                                                                                                       monkeypatch):
    """A model that reads no speed diagnoses a VS export, but a run-up read as if at one speed is no verdict to trust:
    it had been scored with no doubt said. Its damage level (HUST's medium or severe) goes into the diagnosis."""
    from bearingtwin.features.extractor import RawFeatures

    monkeypatch.syspath_prepend(str(Path(__file__).parent / "fixtures"))
    import make_hust_fixtures as hust

    monkeypatch.setattr(hust, "N_ROWS", int(0.5 * hust.FS_HZ))
    hust.write("0.5X_O_VS_0_40_0Hz.xls", hust.header_lines(hust.N_ROWS) + ["Data"] +
               hust.rows(hust.synthetic_axes("outer", 1)), tmp_path)
    windows = np.random.default_rng(0).standard_normal((8, 256))
    pipeline = DiagnosisPipeline(RawFeatures().fit(windows), SvmClassifier().fit(windows, np.arange(8) % 4), 256,
                                 hust.FS_HZ, unit="g")
    model = SimpleNamespace(predict=lambda frame, params: predictions_frame(pipeline, frame, None))
    result, _ = diagnose_recording(read_record(tmp_path / "0.5X_O_VS_0_40_0Hz.xls", pipeline, channel="X"), model,
                                   pipeline, "models:/unused", {})
    assert result["speed_varies"] and result["severity"] == "medium" and result["true_state"] == "outer"
    assert " - IN DOUBT: the file is a variable-speed run, read as if at one speed" in one_line(result), one_line(result)


def test_a_hust_record_is_read_at_the_er16k_defect_lines(tmp_path, monkeypatch):
    """A HUST file records the rig's ER-16K bearing, whatever bearing the model was trained on: the evidence
    on an inner-race export (2 s in the fixtures' format) reads the ER-16K's lines and finds the fault there."""
    monkeypatch.syspath_prepend(str(Path(__file__).parent / "fixtures"))
    import make_hust_fixtures as hust

    monkeypatch.setattr(hust, "N_ROWS", int(2 * hust.FS_HZ))
    hust.write("0.5X_I_65Hz.xls", hust.header_lines(hust.N_ROWS) + ["Data"] + hust.rows(hust.synthetic_axes("inner", 1)),
               tmp_path)
    prepared = read_record(tmp_path / "0.5X_I_65Hz.xls", envelope_pipeline(), channel="X")
    recording = prepared.recording
    assert prepared.bearing == bearing_config("er16k") and recording.rpm == 3900.0
    assert any("the record's bearing is er16k" in note for note in prepared.notes), prepared.notes
    assert physics_evidence(recording.signal, recording.fs, recording.rpm, prepared.bearing).evidence_state == "inner"
    # No channel asked for: the file's speed, X, Y and Z columns leave it to the model, trained on data.channel=Y.
    trained_on_y = envelope_pipeline()
    trained_on_y.config = {"data": {"source": "hust", "channel": "Y"}}
    unasked = read_record(tmp_path / "0.5X_I_65Hz.xls", trained_on_y)
    assert unasked.recording.channel == "Y" and "channel Y, the one the model was trained on" in unasked.notes[0]
    with pytest.raises(BearingTwinError, match="holds channels X, Y, Z; choose one with channel=<name>"):
        read_record(tmp_path / "0.5X_I_65Hz.xls", envelope_pipeline())  # a model that names no channel
    # The export's speed column is no vibration (a tachometer's reading, not meaningful in these files).
    with pytest.raises(BearingTwinError, match=r"channel=speed reads the export's speed column, not meaningful .*; "
                                               r"choose one of X, Y, Z"):
        read_record(tmp_path / "0.5X_I_65Hz.xls", envelope_pipeline(), channel="speed")
    with pytest.raises(BearingTwinError, match=r"channel=0 reads the export's speed column"):  # its place, too
        read_record(tmp_path / "0.5X_I_65Hz.xls", envelope_pipeline(), channel=0)


def test_a_file_without_a_speed_is_refused_by_a_model_that_needs_one_naming_both_ways_to_give_it(tmp_path):
    """An envelope-order model reads shaft orders, so a plain array with no speed is refused, naming ``rpm=`` (one
    speed for every file) and the labels table's rpm column (each file its own)."""
    path = tmp_path / "no_speed.npy"
    np.save(path, np.random.default_rng(0).standard_normal(3 * 2048))
    with pytest.raises(BearingTwinError, match=r"no_speed\.npy: the file does not state the shaft speed and this model "
                                               r"needs it; give rpm=<rev/min>, or the file's speed in the rpm column "
                                               r"of a labels\.csv beside it"):
        read_record(path, envelope_pipeline(), fs=FS)


@needs_cwru
def test_a_channel_that_shows_the_shaft_weakly_is_read_at_its_files_rate(tmp_path):
    """The fan-end channel of drive-end records shows the shaft series too weakly beside a stronger series
    (53.7 Hz in ball record 118), so on its own the 12 kHz the file's name declares is contradicted. Every
    channel of a file is a witness of its one rate: with the drive end's channel beside it, record 118's FE
    channel is read. Alone, an inner-race record's FE channel is confirmed by its BPFI envelope line; the
    ball record's faint ball lines confirm nothing: it is read at its stated rate and speed, in doubt."""
    import scipy.io

    pipeline = envelope_pipeline()
    fan_end = read_record(CWRU / "12k_Drive_End_B007_0_118.mat", pipeline, channel="FE")
    assert fan_end.recording.channel == "FE" and fan_end.original_fs == 12000
    assert not any("sampling rate" in note for note in fan_end.notes), fan_end.notes
    for number, name, accepted in ((118, "12k_Drive_End_B007_0_118.mat", False), (105, "12k_Drive_End_IR007_0_105.mat", True)):
        stored = scipy.io.loadmat(CWRU / name)
        alone = tmp_path / name
        scipy.io.savemat(alone, {f"X{number:03d}_FE_time": stored[f"X{number:03d}_FE_time"],
                                 f"X{number:03d}RPM": stored[f"X{number:03d}RPM"]})
        read = read_record(alone, pipeline)
        assert read.recording.channel == "FE" and read.recording.fs == 12000.0
        assert read.rate_check == ("consistent" if accepted else "contradicted"), read.notes
        assert accepted or any(note.startswith("speed and rate disagree: fs = 12000 Hz contradicts the shaft speed")
                               for note in read.notes)


def test_evidence_does_not_depend_on_the_sensors_gain():
    signal = fault_signal(BearingGeometry.from_config(BEARING).defect_frequencies(RPM)["bpfo"])
    in_g = physics_evidence(signal, FS, RPM, BEARING).prominence_db
    in_ms2 = physics_evidence(9.81 * signal, FS, RPM, BEARING).prominence_db
    assert in_g == pytest.approx(in_ms2, abs=1e-9)


DEFAULT_EVIDENCE = {"band": "fixed", "band_nyquist": [0.25, 0.9], "harmonics": 3, "segment_s": 1.0, "tolerance": 0.01,
                    "threshold_db": 6.0}


def test_the_evidence_settings_of_the_config_are_accepted_as_written():
    written = OmegaConf.to_container(compose_config("diagnose", ["path=x.npz", "model=runs:/x/model"]).evidence)
    assert evidence_settings(written) == written == DEFAULT_EVIDENCE
    check_segment(1.0, FS)


@pytest.mark.parametrize("key, value, message", [
    ("threshold_db", "abc", "evidence.threshold_db must be a non-negative number of dB, got 'abc'"),
    ("threshold_db", -3, "evidence.threshold_db must be a non-negative number of dB"),
    ("tolerance", "abc", "evidence.tolerance must be a relative half width above 0 and below 0.5, got 'abc'"),
    ("tolerance", -1, "evidence.tolerance must be a relative half width above 0 and below 0.5, got -1"),
    ("tolerance", 0.5, "evidence.tolerance must be a relative half width above 0 and below 0.5"),
    ("band_nyquist", "abc", "evidence.band_nyquist must be [low, high], fractions of the Nyquist rate"),
    ("band_nyquist", [0.9, 0.25], "evidence.band_nyquist must be [low, high]"),
    ("band_nyquist", [0.25, 1.0], "evidence.band_nyquist must be [low, high]"),
    ("segment_s", 0, "evidence.segment_s=0 must be a positive number of seconds"),
    ("segment_s", "abc", "evidence.segment_s='abc' must be a positive number of seconds"),
    ("harmonics", 2.5, "evidence.harmonics must be a positive integer, got 2.5"),
    ("band", "widest", "evidence.band='widest': choose one of fixed, kurtogram"),
])
def test_a_bad_evidence_setting_is_named_with_what_it_must_be(key, value, message):
    with pytest.raises(BearingTwinError) as refused:
        evidence_settings({**DEFAULT_EVIDENCE, key: value})
    assert str(refused.value).startswith(message), refused.value


def test_a_welch_segment_too_short_for_the_models_rate_is_refused():
    """Below 16 samples the spectrum would silently take a longer segment than the one asked for."""
    check_segment(16 / FS, FS)
    with pytest.raises(BearingTwinError, match=r"^evidence.segment_s=0.001 holds 12 samples at the model's 12000 Hz; "
                                               r"give at least 0.00133 s \(16 samples\)"):
        check_segment(0.001, FS)


# ---------------------------------------------------------------- records


def test_resampling_keeps_the_frequencies_and_says_what_it_did():
    fs = 48000.0
    t = np.arange(int(2 * fs)) / fs
    recording = Recording(np.sin(2 * np.pi * 157.0 * t), fs, rpm=RPM, source="tone.npy")
    resampled, note = resample_to(recording, 12000.0)
    assert resampled.fs == 12000.0 and resampled.signal.size == t.size // 4 and "48000 Hz -> 12000 Hz" in note
    spectrum = np.abs(np.fft.rfft(resampled.signal * np.hanning(resampled.signal.size)))
    peak_hz = np.fft.rfftfreq(resampled.signal.size, 1 / 12000.0)[spectrum.argmax()]
    assert peak_hz == pytest.approx(157.0, abs=0.5)
    assert "nothing" not in note  # read at a lower rate, the record loses only what the model cannot see
    upsampled, note = resample_to(resampled, 24000.0)
    assert upsampled.fs == 24000.0 and note.endswith("; the record holds nothing between its Nyquist frequency, "
                                                     "6000 Hz, and the model's, 12000 Hz")
    spectrum = np.abs(np.fft.rfft(upsampled.signal))
    above = np.fft.rfftfreq(upsampled.signal.size, 1 / 24000.0) > 6100.0
    assert spectrum[above].max() < 1e-3 * spectrum.max()  # and indeed it holds nothing there


def test_windows_tile_the_record_without_overlap():
    def windows_of(signal, gaps_s=()):
        recording = Recording(signal, 1000.0, source="x.npy")
        prepared = PreparedRecord(recording, None, 1000.0, gaps_s=list(gaps_s), dropouts_s=dropouts(recording, 2.048))
        return diagnosed_windows(prepared, 2048)

    windows, starts, notes, left_out = windows_of(np.arange(10_000.0))
    assert windows.shape == (4, 2048) and list(starts) == [0, 2048, 4096, 6144] and (notes, left_out) == ([], 0)
    np.testing.assert_array_equal(windows.ravel(), np.arange(4 * 2048.0))
    # A stretch held at one value for a window's length or longer leaves out the windows it touches, no other.
    for length, kept in ((2100, [0, 6144]), (2047, [0, 2048, 4096, 6144])):
        signal = np.arange(10_000.0)
        signal[3000:3000 + length] = 0.0
        windows, starts, notes, left_out = windows_of(signal)
        assert list(starts) == kept and np.array_equal(windows, signal[np.add.outer(starts, np.arange(2048))])
        assert left_out == 4 - len(kept) and len(notes) == (left_out > 0)
    # A stretch on window boundaries, turned into seconds and back (3072 / 10000 * 10000 is 3071.9999...), touches its
    # own windows alone.
    assert _in_samples(3072 / 10000, 5120 / 10000, 10000.0) == (3072, 2048)
    assert _in_samples(12288 / 12000, 14336 / 12000, 12000.0) == (12288, 2048)
    # So does a stretch with no value (bridged when read), in seconds of the record: 4.1-4.2 s touches the third.
    windows, starts, notes, left_out = windows_of(np.arange(10_000.0), [(4.1, 4.2)])
    assert list(starts) == [0, 2048, 6144] and left_out == 1 and notes[0].startswith("the 1 window touching samples")
    with pytest.raises(BearingTwinError, match="x.npy: every window of the model's"):
        windows_of(np.arange(10_000.0), [(0.0, 9.0)])


# ---------------------------------------------------------------- end to end


def test_a_rate_too_low_to_hold_the_bearings_defect_lines_is_refused_naming_the_rate_in_khz_it_may_be(tmp_path):
    """Resampled to the model's 12 kHz, a record at 25.6 Hz (25.6 kHz written in Hz) was diagnosed on nothing and
    called normal. Whatever gave the rate (the file, fs=, a speed-less record read at the model's training speed),
    a rate whose Nyquist frequency lies below BPFI is refused; one just above it is read."""
    pipeline = envelope_pipeline()
    signal = fault_signal(None, seconds=3)
    np.savez(tmp_path / "stated.npz", signal=signal[:300], fs=25.6, rpm=RPM)
    with pytest.raises(BearingTwinError, match=(
            r"stated.npz: the rate the file states, 25.6 Hz, is too low to diagnose: the Nyquist frequency, 12.8 Hz, "
            r"lies below the inner-race defect line \(BPFI\) at 1797 rev/min \(162.2 Hz\): a record shows this "
            r"bearing's faults above fs = 324 Hz; if 25.6 kHz was meant, the file must state 25600 Hz$")):
        read_record(tmp_path / "stated.npz", pipeline)
    np.savez(tmp_path / "bare.npz", signal=signal[:300])
    with pytest.raises(BearingTwinError, match=r"bare.npz: fs=12 Hz is too low to diagnose: .* if 12 kHz was meant, "
                                               r"give 12000 Hz$"):
        read_record(tmp_path / "bare.npz", pipeline, fs=12, rpm=RPM)
    with pytest.raises(BearingTwinError, match=r"fs=12 Hz is too low .* at 3600 rev/min .*\(the slowest of the "
                                               r"model's training windows': the record states no speed\)"):
        read_record(tmp_path / "bare.npz", dataclasses.replace(pipeline, speeds_rpm=(3600.0, 3600.0)), fs=12)
    # A rate no kHz reading rescues is named without that guess; BPFI at 1797 rev/min is 162.2 Hz: 330 Hz holds it.
    with pytest.raises(BearingTwinError, match=r"fs=0.2 Hz is too low .*faults above fs = 324 Hz$"):
        read_record(tmp_path / "bare.npz", pipeline, fs=0.2, rpm=RPM)
    np.savez(tmp_path / "low.npz", signal=signal[:1000])
    assert read_record(tmp_path / "low.npz", pipeline, fs=330, rpm=RPM).original_fs == 330


def run(module: str, *args: str, cwd: Path, uri: str) -> subprocess.CompletedProcess:
    env = {**__import__("os").environ, "MLFLOW_TRACKING_URI": uri}
    return run_module(f"bearingtwin.cli.{module}", *args, cwd=cwd, env=env, timeout=600)


@pytest.fixture(scope="module")
def registered(tmp_path_factory):
    """A smoke-size model trained at CWRU's 12 kHz, registered as diag@champion; a per_class one as diag_per_class."""
    base = tmp_path_factory.mktemp("diagnose")
    uri = f"sqlite:///{base}/mlflow.db"
    for extra in (["register=diag", "register_alias=champion"], ["features.vmd_params=per_class", "register=diag_per_class"]):
        done = run("train", *SMOKE, "data.fs=12000", f"paths.cache_dir={base}/cache", *extra, cwd=base, uri=uri)
        assert done.returncode == 0, done.stderr[-3000:]
        (base / f"{extra[-1].partition('=')[2]}.stderr").write_text(done.stderr)
    return base, uri


def test_a_model_that_cannot_diagnose_is_logged_without_mlflows_warning_of_a_forgotten_example(registered):
    """A per_class model has no input example by design (it refuses recordings): MLflow's warning that one was not
    provided would read as an oversight."""
    base, _ = registered
    assert "An input example was not provided" not in (base / "diag_per_class.stderr").read_text()


def test_loading_a_registered_model_writes_nothing_into_its_store(registered):
    """MLflow loads a models:/ URI of a local store in place and writes its registered_model_meta beside the model:
    a diagnosis reads the store, and a team's may be read-only to it. The model is loaded from a copy instead."""
    base, uri = registered

    def files():
        return {path: path.stat().st_mtime_ns for path in base.rglob("*")
                if path.is_file() and path.name != "mlflow.db" and "cache" not in path.relative_to(base).parts}

    before = files()
    model, pipeline, pinned = load_diagnosis_model("models:/diag@champion", uri)
    assert pinned.startswith("models:/diag/") and pipeline is not None
    assert files() == before


def test_a_registry_apart_from_the_tracking_store_is_the_one_mlflow_serves_from(registered, tmp_path, monkeypatch):
    """MLFLOW_REGISTRY_URI names the Model Registry that MLflow's own tools read (mlflow.pyfunc.load_model, mlflow
    models serve): a model registered with it set is there, not in the tracking store, and a diagnosis loads it from
    there; a registry that is not there is named by that variable."""
    import mlflow

    from bearingtwin.diagnosis.mlflow_model import register_model

    _, uri = registered
    run_id = MlflowClient(tracking_uri=uri, registry_uri=uri).get_model_version_by_alias("diag", "champion").run_id
    registry = f"sqlite:///{tmp_path}/registry.db"
    MlflowClient(registry).search_registered_models()  # a new store's tables, as a team's registry has them

    def started_with(registry_uri):  # the variable as the user set it
        monkeypatch.setenv("MLFLOW_REGISTRY_URI", registry_uri)

    try:
        started_with(registry)
        version, _ = register_model(uri, f"runs:/{run_id}/model", "apart", "champion")
        found = MlflowClient(tracking_uri=uri, registry_uri=registry).get_model_version_by_alias("apart", "champion")
        assert str(found.version) == version
        assert "apart" not in {model.name for model in MlflowClient(tracking_uri=uri, registry_uri=uri).search_registered_models()}
        mlflow.set_tracking_uri(uri)
        mlflow.set_registry_uri(registry)
        assert mlflow.pyfunc.load_model("models:/apart@champion").metadata.run_id == run_id
        _, pipeline, pinned = load_diagnosis_model("models:/apart@champion", uri)
        assert pinned == f"models:/apart/{version}" and pipeline is not None
        assert os.environ["MLFLOW_REGISTRY_URI"] == registry  # as the user set it, whatever MLflow was pointed at
        monkeypatch.delenv("MLFLOW_REGISTRY_URI")
        load_diagnosis_model("models:/diag@champion", uri)  # the tracking store's registry: no variable left behind
        assert "MLFLOW_REGISTRY_URI" not in os.environ
        started_with(f"sqlite:///{tmp_path}/absent.db")
        with pytest.raises(BearingTwinError, match=rf"^MLFLOW_REGISTRY_URI=sqlite:///{tmp_path}/absent.db: no such store"):
            load_diagnosis_model("models:/apart@champion", uri)
    finally:
        mlflow.set_registry_uri(uri)  # MLflow's global, as the other tests of this store leave it


def test_a_models_own_folder_is_read_without_a_store(registered, tmp_path):
    """A model downloaded to a folder names everything it needs: reading it asks for no tracking store (with none
    set, the checkout's default store had been refused as missing before the folder was looked at)."""
    import mlflow

    _, uri = registered
    mlflow.set_tracking_uri(uri)
    folder = mlflow.artifacts.download_artifacts("models:/diag@champion", dst_path=str(tmp_path / "model"))
    _, pipeline, loaded = load_diagnosis_model(folder, f"sqlite:///{tmp_path}/absent.db")
    assert loaded == folder and pipeline is not None and not (tmp_path / "absent.db").exists()


def test_a_model_whose_run_was_deleted_is_said_to_be(registered):
    """A registered model whose run its owner deleted still loads (the version keeps its model); the diagnosis says
    the run is deleted, as it says every other doubt about what it read."""
    from bearingtwin.diagnosis.mlflow_model import deleted_run_words

    _, uri = registered
    client = MlflowClient(tracking_uri=uri, registry_uri=uri)
    model, _, _ = load_diagnosis_model("models:/diag@champion", uri)
    assert deleted_run_words(model, "models:/diag@champion", uri) == ""
    run_id = model.metadata.run_id
    client.delete_run(run_id)
    try:
        model, _, _ = load_diagnosis_model("models:/diag@champion", uri)
        assert deleted_run_words(model, "models:/diag@champion", uri) == (
            f"the run that logged it ({run_id}) is deleted in {uri}")
    finally:
        client.restore_run(run_id)


def test_training_registers_its_model_with_signature_and_alias(registered):
    import mlflow

    base, uri = registered
    client = MlflowClient(uri)
    version = client.get_model_version_by_alias("diag", "champion")
    run = client.get_run(version.run_id)
    assert run.data.tags["registered_model"] == f"diag/{version.version}"
    # What a later identical config, skipped, names as its model: this run's, as this run named it.
    from bearingtwin.tracking.mlflow_logging import earlier_model

    assert earlier_model(client, version.run_id) == f"runs:/{version.run_id}/model = models:/diag/{version.version}"
    mlflow.set_tracking_uri(uri)
    model = mlflow.pyfunc.load_model(f"runs:/{version.run_id}/model")
    signature = model.metadata.get_input_schema().inputs[0]
    params = {param["name"]: param["default"] for param in model.metadata.get_params_schema().to_dict()}
    # the recorded bearing: the model's; the windows' rate and unit: not stated
    # windows of any length pass MLflow's shape check, to meet the model's own refusal naming its length, recorded here
    assert signature.shape == (-1, -1) and model.metadata.metadata["window_length"] == 2048
    assert params == {"rpm": 0.0, "bearing": "paper", "fs": 0.0, "unit": "", "scale": 0.0}
    answer = model.predict(np.random.default_rng(0).standard_normal((3, 2048)))
    # Windows at another rate than the model's would be read without a word: stated, they are refused; stated in
    # another acceleration unit, they are converted to the model's.
    windows = np.random.default_rng(0).standard_normal((3, 2048))
    with pytest.raises(MlflowException, match=r"params fs 48000 Hz: the model reads windows sampled at 12000 Hz"):
        model.predict(windows, params={"fs": 48000.0})
    assert model.metadata.metadata["unit"] == "m/s^2"
    pd.testing.assert_frame_equal(model.predict(windows / 9.80665, params={"fs": 12000.0, "unit": "g"}), answer)
    with pytest.raises(MlflowException, match=r"^params unit 'V': the record is in V, the model was trained on windows "
                                              r"in m/s\^2 and reads their level"):
        model.predict(windows, params={"unit": "V"})
    with pytest.raises(MlflowException, match=r"^params unit 'furlongs': no unit known here; .*the model's is m/s\^2"):
        model.predict(windows, params={"unit": "furlongs"})
    # A sensor's volts at 100 mV/g read as the unit refusal advises: scale 10 makes them g, then converted (it had
    # been dropped by the served signature, the windows read as g unscaled).
    volts = windows / 9.80665 / 10.0
    pd.testing.assert_frame_equal(model.predict(volts, params={"unit": "g", "scale": 10.0}), answer)
    with pytest.raises(MlflowException, match=r"scale"):
        model.predict(volts, params={"unit": "g", "scale": -1.0})
    # level_unseen: the VMD features read the level; the columns before it are as they were.
    assert list(answer.columns) == ["state", "normal", "inner", "ball", "outer", "level_unseen", "feature_unseen"]
    assert len(answer) == 3
    np.testing.assert_allclose(answer[["normal", "inner", "ball", "outer"]].sum(axis=1), 1.0)


@needs_cwru
def test_diagnose_a_cwru_record_by_registry_alias(registered, tmp_path):
    base, uri = registered
    record = CWRU / "12k_Drive_End_OR007@6_1_131.mat"
    done = run("diagnose", f"path={record}", "model=models:/diag@champion", f"out={tmp_path}/out", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "out" / record.stem / "diagnosis.json").read_text())
    contract = {"record", "model_uri", "fs", "rpm", "verdict", "share", "mean_probability", "windows", "evidence",
                "evidence_state", "agree"}
    assert contract <= set(result) and result["model_uri"] == "models:/diag@champion"
    assert result["fs"] == 12000.0 and result["rpm"] == pytest.approx(1772, abs=5) and result["true_state"] == "outer"
    assert len(result["windows"]) == 122_426 // 2048  # non-overlapping windows over the whole record
    states = [w["state"] for w in result["windows"]]
    assert result["share"] == pytest.approx(states.count(result["verdict"]) / len(states))
    assert result["evidence_state"] == "outer" and result["evidence"]["prominence_db"]["outer"] > 20  # a clear BPFO series
    # The model learnt the twin's m/s^2; the record is in g: read as the same vibration in the model's unit.
    assert "converted from g to m/s^2, the unit the model was trained in (x 9.80665)" in result["notes"]
    assert result["agree"] == (result["verdict"] == "outer")
    assert (tmp_path / "out" / record.stem / "diagnosis.png").stat().st_size > 10_000
    # The summary is begun by the first file's run, so files diagnosed one by one build it up (it had been written
    # for one file only when it failed).
    (row,) = csv.DictReader(open(tmp_path / "out" / "summary.csv"))
    assert (row["record"], row["verdict"], row["true_state"]) == (record.stem, result["verdict"], "outer")
    assert record.stem in done.stdout and "mlflow ui --backend-store-uri" in done.stdout
    logged = MlflowClient(uri).search_runs([MlflowClient(uri).get_experiment_by_name("bearingtwin-diagnose").experiment_id])
    assert logged[0].info.status == "FINISHED" and logged[0].data.params["model"] == "models:/diag@champion"
    # The alias moves; the version it named is kept beside it, in the record's verdict and on the run.
    champion = MlflowClient(uri).get_model_version_by_alias("diag", "champion").version
    assert result["model_version_uri"] == logged[0].data.tags["model_version_uri"] == f"models:/diag/{champion}"


@needs_cwru
def test_a_model_that_puts_physics_first_is_scored_and_diagnoses_as_it_decides(tmp_path):
    """Trained on real CWRU records with physics_first, the run scores its windows as a diagnosis decides them
    (physics_decided: the share the physics took), the model carries the rule, and a diagnosis of an inner-race
    record says how many of its windows the envelope spectrum decided and marks each window."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    done = run("train", "data=cwru", "bearing=cwru_6205", "data.samples_per_class=8", "data.window_length=4096",
               "features=envelope_prominence",
               "classifier=svm", "physics_first={threshold_db:20,margin_db:10}", f"paths.cache_dir={tmp_path}/cache",
               f"hydra.run.dir={tmp_path}/run", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-3000:]
    client = MlflowClient(uri)
    (trained,) = client.search_runs([client.get_experiment_by_name("bearingtwin").experiment_id])
    # In 4096-point windows the 0 hp inner- and outer-race records' BPFI and BPFO series stand 20-36 dB over their
    # floors (results/sim2real_protocol.md, version 9), the ball and healthy records' series do not: of the four
    # states' test windows, at most half, the races', are the physics'.
    assert 0.35 <= trained.data.metrics["physics_decided"] <= 0.5, trained.data.metrics
    assert trained.data.params["physics_first.threshold_db"] == "20"
    # The classifier's own share of the accuracy: on the windows the physics left it, the test accuracy lies between
    # what those windows alone give and that plus every physics-decided window right.
    metrics = trained.data.metrics
    share_left = 1 - metrics["physics_decided"]
    assert (share_left * metrics["classifier_accuracy_left"] - 1e-9 <= metrics["accuracy"]
            <= metrics["physics_decided"] + share_left * metrics["classifier_accuracy_left"] + 1e-9), metrics
    assert 0 <= metrics["classifier_accuracy"] <= 1
    assert (f"the rest by the classifier, right in {100 * metrics['classifier_accuracy_left']:.2f} % of them; the "
            f"classifier alone, on every test window: {100 * metrics['classifier_accuracy']:.2f} %") in done.stdout
    assert (f"physics first: {100 * trained.data.metrics['physics_decided']:.2f} % of the test windows decided by the "
            "envelope spectrum") in done.stdout
    record = CWRU / "12k_Drive_End_IR007_1_106.mat"
    done = run("diagnose", f"path={record}", f"model=runs:/{trained.info.run_id}/model", f"out={tmp_path}/out",
               "figures=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "out" / record.stem / "diagnosis.json").read_text())
    deciders = [window["decided_by"] for window in result["windows"]]
    assert result["verdict"] == "inner" and deciders.count("physics") >= len(deciders) // 2, deciders
    assert (f"{deciders.count('physics')} of {len(deciders)} windows decided by the envelope spectrum, where one defect "
            "series stood 20 dB or more over its floor and 10 dB above the others") in " ".join(result["notes"])
    assert (f"inner (100% of {len(deciders)} windows, {deciders.count('physics')} decided by the envelope spectrum; "
            "classifier p ") in one_line(result)
    # The classifier's answer on the windows left to it, beside the verdict the physics helped make.
    assert result["physics_decided"] == pytest.approx(deciders.count("physics") / len(deciders))
    left = [window["state"] for window in result["windows"] if window["decided_by"] == "classifier"]
    assert result["classifier_verdict"] == (max(FAULTS, key=left.count) if left else None)
    # A record the model was trained on (0 hp), under its own name or another, is said to be no test of it, and
    # the score over the records it never saw stands beside the score over all.
    folder = tmp_path / "records"
    folder.mkdir()
    for source, name in ((CWRU / "12k_Drive_End_IR007_0_105.mat", "12k_Drive_End_IR007_0_105.mat"),
                         (CWRU / "12k_Drive_End_IR007_0_105.mat", "IR007_0.mat"), (record, record.name)):
        (folder / name).write_bytes(source.read_bytes())
    # The shaft's frequency in Hz typed for its speed: what reading the record noted is printed above its failure.
    np.savez(folder / "in_hz.npz", signal=load_recording(record).signal, fs=FS)
    (folder / "labels.csv").write_text("record,state,rpm\nin_hz,inner,29.95\n")
    done = run("diagnose", f"path={folder}", f"model=runs:/{trained.info.run_id}/model", f"out={tmp_path}/folder",
               "figures=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 2, done.stderr[-3000:]
    assert re.search(r"in_hz: .*rpm=29.95 is a shaft at 0.499 Hz; if 29.95 is the shaft's frequency in Hz, give .*"
                     r"rpm=1797\nin_hz: .*\nin_hz: FAILED - .*in_hz.npz: at 29.95 rpm a window resolves", done.stdout)
    seen = {path.parent.name: json.loads(path.read_text()) for path in (tmp_path / "folder").glob("*/diagnosis.json")}
    assert {name: result["training_record"] for name, result in seen.items()} == {
        "12k_Drive_End_IR007_0_105": True, "IR007_0": True, record.stem: False}
    assert ("the model was trained on windows of this record (the same contents): its verdict is no test of the model"
            in seen["IR007_0"]["notes"])
    assert " of 3 with a known state; 100.00 % of the 1 the model was not trained on" in done.stdout, done.stdout
    # Scored over windows, the share the envelope spectrum decided is said, and the classifier's own score beside it,
    # as summary.csv's counts give them.
    rows = [row for row in csv.DictReader(open(tmp_path / "folder" / "summary.csv")) if row["windows_right"]]
    windows, alone = (sum(int(row[key]) for row in rows) for key in ("windows", "classifier_windows_right"))
    assert f"the classifier alone: {100 * alone / windows:.2f} %)" in done.stdout, done.stdout
    # As the records, the windows of the one record the model never saw are scored apart.
    unseen = next(row for row in rows if row["record"] == record.stem)
    assert (f"; {100 * int(unseen['windows_right']) / int(unseen['windows']):.2f} % of the windows of the 1 the model "
            "was not trained on") in done.stdout, done.stdout


@needs_cwru
def test_a_folder_goes_on_past_bad_files_and_scores_against_labels(registered, tmp_path):
    base, uri = registered
    folder = tmp_path / "recordings"
    folder.mkdir()
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    np.savez(folder / "pump_a.npz", signal=fault_signal(rates["bpfo"], seconds=3), fs=FS, rpm=RPM)
    # It names a bearing no config here describes (a user's own, simulated with hydra.searchpath): its defect lines
    # are unknown, and no other bearing's stand in for them.
    np.savez(folder / "own.npz", signal=fault_signal(rates["bpfo"], seconds=3), fs=FS, rpm=RPM, bearing="rig_b_6206")
    np.savez(folder / "pump_b.npz", signal=fault_signal(None, seconds=3, seed=5), fs=48000.0, rpm=RPM)  # resampled
    np.savez(folder / "short.npz", signal=fault_signal(None, seconds=100 / FS), fs=FS)
    np.savez(folder / "nan.npz", signal=np.full(30000, np.nan), fs=FS)
    (folder / "cut.wav").write_bytes(b"RIFF\x24\x00\x00\x00WAVEjunk" * 3)  # a reader's own exception, not ours
    np.savez(folder / "told.npz", signal=fault_signal(None, seconds=3), fs=FS, fault="inner")
    # Excel's byte-order mark; a row for a file the folder does not hold
    np.savez(folder / "other.npz", signal=fault_signal(None, seconds=3), fs=FS)
    # A row for other.npy is not other.npz's: it names a file the folder does not hold.
    (folder / "labels.csv").write_text("record,state\npump_a,outer\npump_b.npz,normal\ntold,outer\ngone.npz,ball\n"
                                       "other.npy,ball\n", encoding="utf-8-sig")
    done = run("diagnose", f"path={folder}", "model=models:/diag/1", f"labels={folder}/labels.csv",
               f"out={tmp_path}/out", "rpm=1797", cwd=tmp_path, uri=uri)
    assert done.returncode == 2  # some records failed, the others were diagnosed
    rows = {row["record"]: row for row in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert set(rows) == {"pump_a", "pump_b", "short", "nan", "cut", "told", "other", "own"}
    header = open(tmp_path / "out" / "summary.csv").readline().strip().split(",")
    # The same columns in every run, whatever its records hold (the conditional ones had moved those after them).
    from bearingtwin.diagnosis.run import SUMMARY_FIELDS

    assert header == list(SUMMARY_FIELDS) and header[-13:] == [
        "original_fs", "unit_check", "level_unseen", "classifier_verdict", "physics_decided", "speed_spread",
        "order_tracked", "speed_unseen", "features_unseen", "scale", "windows", "windows_right", "classifier_windows_right"]
    assert 0.0 <= float(rows["pump_a"]["features_unseen"]) <= 1.0 and not rows["short"]["features_unseen"]
    assert rows["pump_a"]["classifier_verdict"] == rows["pump_a"]["verdict"]  # no physics_first: the model's own
    assert float(rows["pump_a"]["physics_decided"]) == 0.0 and not rows["short"]["physics_decided"]
    assert rows["pump_a"]["bearing"] and not rows["short"]["bearing"] and rows["pump_a"]["unit_check"]
    assert float(rows["pump_a"]["original_fs"]) > 0 and not rows["short"]["original_fs"]
    assert "true_state" not in rows["other"] or not rows["other"]["true_state"]
    assert "shorter than one window" in rows["short"]["error"] and "NaN" in rows["nan"]["error"]
    assert "cut.wav: not a readable .wav file" in rows["cut"]["error"] and "Traceback" not in done.stderr
    assert "told.npz: labelled outer, but the file states fault=inner" in rows["told"]["error"]
    # A failed record's row says which state went unanswered, where its labels row gives one.
    assert rows["told"]["true_state"] == "outer" and not rows["told"]["correct"] and not rows["short"]["true_state"]
    assert "rows for gone.npz, other.npy, which" in done.stdout
    assert rows["pump_a"]["true_state"] == "outer" and rows["pump_a"]["evidence_state"] == "outer"
    assert rows["own"]["error"] == (f"{folder / 'own.npz'}: the file names bearing rig_b_6206, which no conf/bearing "
                                    "config here describes: its defect frequencies are unknown here (give bearing=<name>, "
                                    "with hydra.searchpath for one of your own)")
    assert rows["pump_b"]["true_state"] == "normal"
    for row in (rows["pump_a"], rows["pump_b"]):  # right means the verdict is the row's state
        assert row["correct"] == str(row["verdict"] == row["true_state"]), row
    assert "resampled 48000 Hz -> 12000 Hz" in done.stdout
    assert "records right: " in done.stdout and "of 2 with a known state" in done.stdout
    # No bearing= and no file naming one known here: the model's stood in, which the closing summary says.
    assert re.search(r"\n  bearing: \w+ \(the model's, for every record: no bearing= given and the files name none; "
                     r"where they are of another bearing, give bearing=<name>", done.stdout), done.stdout
    assert f"error: {folder / 'short.npz'}: 0.008 s, shorter than one window of the model's (" in done.stderr


def test_records_a_folder_cannot_tell_apart_and_a_file_for_out_are_refused_before_any_work(registered, tmp_path):
    """A record is named by its stem (its output folder, its summary row, its labels row): two files of one
    stem would overwrite each other. ``out=`` naming a file is refused too, in one line, with nothing written; a
    labels table naming a record twice labels neither row's file, which fails naming both lines while the folder's
    other files are diagnosed."""
    base, uri = registered
    folder = tmp_path / "twice"
    folder.mkdir()
    np.savez(folder / "rec.npz", signal=fault_signal(None, seconds=1), fs=FS, rpm=RPM)
    np.save(folder / "rec.npy", fault_signal(None, seconds=1))
    clash = run("diagnose", f"path={folder}", "model=models:/diag/1", cwd=tmp_path, uri=uri)
    assert clash.returncode == 2 and "rec.npy, rec.npz share the record name rec" in clash.stderr
    (folder / "rec.npy").unlink()
    (folder / "labels.csv").write_text("record,state\nrec.npz,outer\nrec,inner\n")
    np.save(folder / "other.npy", fault_signal(None, seconds=1))
    twice = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/twice_out", f"rpm={RPM}", f"fs={FS}",
                cwd=tmp_path, uri=uri)
    assert twice.returncode == 2 and f"error: {folder / 'rec.npz'}: {folder / 'labels.csv'} line 3: record 'rec' is " \
        "labelled again (" in twice.stderr, twice.stderr[-2000:]
    assert "labels.csv line 2 names rec too)" in twice.stderr
    assert (tmp_path / "twice_out" / "other" / "diagnosis.json").is_file()  # the other file is diagnosed
    (folder / "labels.csv").unlink()
    (folder / "other.npy").unlink()
    into_file = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={folder / 'rec.npz'}", cwd=tmp_path,
                    uri=uri)
    assert into_file.returncode == 2 and "rec.npz is a file, not a folder" in into_file.stderr
    maybe = run("diagnose", f"path={folder}", "model=models:/diag/1", "figures=maybe", cwd=tmp_path, uri=uri)
    assert maybe.returncode == 2 and "figures=maybe: give figures=true or figures=false" in maybe.stderr
    spread = run("diagnose", f"path={folder}", "model=models:/diag/1", "order_tracking.unsteady=2", cwd=tmp_path,
                 uri=uri)
    assert spread.returncode == 2 and "order_tracking.unsteady must be a relative spread below 1" in spread.stderr
    # An out= another diagnosis is writing into (a job started again before the last ended): the two had each removed
    # the other's outputs as an earlier run's, and left a folder of both.
    import fcntl
    import os

    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "theirs.txt").write_text("another run's")
    held = os.open(tmp_path / "busy", os.O_RDONLY)
    try:
        fcntl.flock(held, fcntl.LOCK_EX)
        busy = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path / 'busy'}", cwd=tmp_path,
                   uri=uri)
    finally:
        os.close(held)
    assert busy.returncode == 2 and f"out={tmp_path / 'busy'}: another bearingtwin-diagnose is writing there" in busy.stderr
    assert [path.name for path in (tmp_path / "busy").iterdir()] == ["theirs.txt"]
    # Files diagnosed one by one as they arrive, each its own record's outputs: side by side, into a new folder.
    held = os.open(tmp_path / "busy", os.O_RDONLY)
    try:
        fcntl.flock(held, fcntl.LOCK_SH)  # as another one-file diagnosis holds it
        beside = run("diagnose", f"path={folder / 'rec.npz'}", "model=models:/diag/1", f"out={tmp_path / 'busy'}",
                     "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    finally:
        os.close(held)
    assert beside.returncode == 0 and (tmp_path / "busy" / "rec" / "diagnosis.json").is_file(), beside.stderr[-2000:]
    for done in (clash, twice, into_file, maybe, spread, busy):
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert not (tmp_path / "diagnosis").exists()


def test_a_dead_sensor_fails_its_file_alone_and_each_failure_names_its_file_once(registered, tmp_path):
    """A record whose every sample is the same has no vibration to diagnose (as bearingtwin-twin refuses it);
    the other records are still diagnosed. A reader's message names its file already: the error line names it once."""
    base, uri = registered
    folder = tmp_path / "f"
    folder.mkdir()
    np.savez(folder / "dead.npz", signal=np.full(30000, 0.5), fs=FS, rpm=RPM)
    np.savez(folder / "live.npz", signal=fault_signal(None, seconds=3), fs=FS, rpm=RPM)
    np.savez(folder / "slow.npz", signal=fault_signal(None, seconds=3)[:300], fs=25.6, rpm=RPM)  # 25.6 kHz meant
    (folder / "two.csv").write_text("time,a,b\n" + "".join(f"{i / FS},{i % 3},{i % 5}\n" for i in range(3000)))
    done = run("diagnose", "path=f/*", "model=models:/diag/1", "out=out", "figures=false", "tracking.enabled=false",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert [line for line in done.stderr.splitlines() if line.startswith("error: ")] == [
        "error: f/dead.npz: every sample is 0.5: no vibration recorded",
        "error: f/slow.npz: the rate the file states, 25.6 Hz, is too low to diagnose: the Nyquist frequency, 12.8 Hz, "
        "lies below the inner-race defect line (BPFI) at 1797 rev/min (162.2 Hz): a record shows this bearing's "
        "faults above fs = 324 Hz; if 25.6 kHz was meant, the file must state 25600 Hz",
        "error: f/two.csv: holds channels a, b; choose one with channel=<name>",
    ]
    assert (tmp_path / "out" / "live" / "diagnosis.json").is_file() and "records diagnosed: 1 of 4" in done.stdout
    assert f"output: {(tmp_path / 'out').resolve()}\n" in done.stdout  # out=out, named where it is from anywhere


@pytest.mark.parametrize("overrides, message", [
    (["evidence.tolerance=abc"], "error: evidence.tolerance must be a relative half width above 0 and below 0.5, got 'abc'"),
    (["evidence.segment_s=0"], "error: evidence.segment_s=0 must be a positive number of seconds"),
    (["path="], "error: path is empty: give path=<file | folder | glob>"),
    (["path=recordings/*.npz"], "error: path=recordings/*.npz: the pattern matches no file"),
    (["tracking.enabled=maybe"], "error: tracking.enabled=maybe: give tracking.enabled=true or tracking.enabled=false"),
    (["rpm=abc"], "error: rpm='abc' must be a positive number of rev/min"),  # once, not file by file
    (["fs=0"], "error: fs=0 must be a positive number of Hz"),
])
def test_bad_settings_and_paths_are_refused_in_one_line_before_any_file_is_read(tmp_path, overrides, message):
    """Checked before the model is loaded and before any file is read (so the model here is bogus): a bad evidence
    setting would otherwise fail every record alike, and path= would diagnose the working directory."""
    np.savez(tmp_path / "r.npz", signal=fault_signal(None, seconds=1), fs=FS, rpm=RPM)
    given = [] if any(override.startswith("path=") for override in overrides) else ["path=r.npz"]
    done = run("diagnose", *given, "model=runs:/x/model", *overrides, cwd=tmp_path, uri=f"sqlite:///{tmp_path}/mlflow.db")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith(message), done.stderr
    assert sorted(path.name for path in tmp_path.iterdir()) == ["r.npz"]  # no store, no output


def test_the_recorded_bearing_is_given_on_the_command_line(registered, tmp_path):
    """A recording of a fan-end (SKF 6203) outer race, in a file that names no bearing: with bearing=cwru_6203
    the evidence reads that bearing's lines and the model is asked with it (a parameter its signature declares)."""
    base, uri = registered
    rate = BearingGeometry.from_config(bearing_config("cwru_6203")).defect_frequencies(RPM)["bpfo"]
    np.savez(tmp_path / "fan.npz", signal=fault_signal(rate, seconds=3), fs=FS, rpm=RPM)
    done = run("diagnose", f"path={tmp_path / 'fan.npz'}", "model=models:/diag/1", "bearing=cwru_6203",
               f"out={tmp_path}/out", "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads((tmp_path / "out" / "fan" / "diagnosis.json").read_text())
    assert result["evidence_state"] == "outer" and result["evidence"]["prominence_db"]["outer"] > 10
    assert any("the record's bearing is cwru_6203, the model was trained on paper" in note for note in result["notes"])
    assert "the model's features do not depend on the bearing" in result["notes"], result["notes"]
    assert "Unrecognized params" not in done.stderr + done.stdout


def two_speed_folder(folder):
    """A folder of two outer-race .npy recordings that state neither speed nor rate, and their (rpm, fs) by name."""
    folder.mkdir()
    rows = {"slow": (1500.0, 12000.0), "fast": (1797.0, 24000.0)}
    for name, (rpm, fs) in rows.items():
        bpfo = BearingGeometry.from_config(bearing_config("paper")).defect_frequencies(rpm)["bpfo"]
        np.save(folder / f"{name}.npy", fault_signal(bpfo, seconds=3, fs=fs))
    return folder, rows


def test_a_files_scale_and_unit_come_whole_from_its_row_or_from_the_command():
    """A scale's unit is the product's, a unit without one the file's own: the two come from one place. A folder's
    row that gives a unit is its file's, even beside a command's scale (a WAV already in g had been multiplied by the
    volts' scale); for the one file given, the command's unit holds, never paired with the row's scale."""
    from bearingtwin.data.labels import LabelsRow, scale_and_unit_given

    def _scale_and_unit(command, row, single):  # the command's (scale, unit), as diagnose passes them
        return scale_and_unit_given(command["scale"], command["unit"], row, command_first=single)

    def cfg(unit=None, scale=None):
        return {"unit": unit, "scale": scale}

    in_g, volts, bare = (LabelsRow("t", "a.wav", None, None, None, "g"), LabelsRow("t", "b.npz", None, None, None, "g", 10.0),
                         LabelsRow("t", "c.npy", None, None, None, None))
    assert _scale_and_unit(cfg("g", 10), in_g, single=False) == (None, "g", True)
    assert _scale_and_unit(cfg("g", 10), volts, single=False) == (10.0, "g", True)
    assert _scale_and_unit(cfg("g", 10), bare, single=False) == (10, "g", False)
    assert _scale_and_unit(cfg("m/s^2"), volts, single=True) == (None, "m/s^2", False)
    assert _scale_and_unit(cfg(), volts, single=True) == (10.0, "g", True)
    assert _scale_and_unit(cfg(), bare, single=True) == (None, None, False)


def test_a_folders_labels_give_each_file_its_unit_which_a_file_stating_another_refuses(registered, tmp_path):
    """A logger's .npy in g beside a file in m/s^2, in one folder: each row's unit is its file's (the command's
    unit= would be every file's), read and converted to the model's; a row's unit the file contradicts fails that
    file alone, naming its row."""
    base, uri = registered
    folder = tmp_path / "plant"
    folder.mkdir()
    np.save(folder / "logger.npy", fault_signal(None, seconds=3) / 9.80665)
    np.savez(folder / "stated.npz", signal=fault_signal(None, seconds=3), fs=FS, unit="m/s^2")
    np.savez(folder / "other.npz", signal=fault_signal(None, seconds=3), fs=FS, unit="m/s^2")
    (folder / "labels.csv").write_text(f"record,state,rpm,fs,unit\nlogger.npy,outer,{RPM},{FS:g},g\n"
                                       f"stated.npz,outer,{RPM},,m/s^2\nother.npz,outer,{RPM},,g\n")
    done = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/out", "figures=false",
               "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 2, done.stderr[-2000:]
    logger = json.loads((tmp_path / "out" / "logger" / "diagnosis.json").read_text())
    assert logger["unit_check"] == "converted", logger["notes"]
    assert json.loads((tmp_path / "out" / "stated" / "diagnosis.json").read_text())["unit_check"] == "as stated"
    assert (f"other.npz: {folder / 'labels.csv'} (its row for other.npz): unit=g contradicts the file's unit, m/s^2"
            in done.stderr), done.stderr[-2000:]
    # A logger's volts beside: its row's scale (g per V) and unit read it, the others as before.
    np.savez(folder / "volts.npz", signal=fault_signal(None, seconds=3) / 9.80665 / 10, fs=FS, unit="V")
    (folder / "labels.csv").write_text(f"record,state,rpm,fs,unit,scale\nlogger.npy,outer,{RPM},{FS:g},g,\n"
                                       f"stated.npz,outer,{RPM},,m/s^2,\nother.npz,outer,{RPM},,,\n"
                                       f"volts.npz,outer,{RPM},,g,10\n")
    done = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/out2", "figures=false",
               "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    volts = json.loads((tmp_path / "out2" / "volts" / "diagnosis.json").read_text())
    summary = {row["record"]: row for row in csv.DictReader(open(tmp_path / "out2" / "summary.csv"))}
    assert volts["scale"] == 10.0 and (summary["volts"]["scale"], summary["logger"]["scale"]) == ("10.0", "")
    assert volts["unit_check"] == "converted" and any(
        "samples x 10 read in g" in note and "(its row for volts.npz): scale=10" in note for note in volts["notes"]), volts
    # The one file given with unit=: the command's unit holds, and the row's scale is said not applied.
    (tmp_path / "one").mkdir()
    np.save(tmp_path / "one" / "counts.npy", fault_signal(None, seconds=3) / 9.80665 / 5)  # full scale 5 g
    (tmp_path / "one" / "labels.csv").write_text(f"record,state,rpm,fs,unit,scale\ncounts.npy,outer,{RPM},{FS:g},g,5\n")
    one = run("diagnose", f"path={tmp_path / 'one' / 'counts.npy'}", "model=models:/diag/1", "unit=g",
              f"out={tmp_path}/out3", "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert one.returncode == 0, one.stderr[-2000:]
    notes = json.loads((tmp_path / "out3" / "counts" / "diagnosis.json").read_text())["notes"]
    assert any("labels.csv line 2 gives scale 5 (unit g), not applied: the unit= and scale= given hold" in note
               for note in notes), notes


def test_a_folders_own_labels_give_each_file_its_truth_speed_and_rate(registered, tmp_path):
    """Recordings that state neither speed nor rate (.npy), at two speeds, and the folder's labels.csv giving them,
    as training reads such a folder: each file is read at its row's rate and speed (the physics evidence finds its
    outer-race lines there) and scored against its row's state, with no labels= or rpm= on the command line."""
    base, uri = registered
    folder, rows = two_speed_folder(tmp_path / "pumps")
    (folder / "labels.csv").write_text("record,state,rpm,fs\n" + "".join(f"{n}.npy,outer,{r},{f}\n" for n, (r, f) in rows.items()))
    np.save(folder / "unlabelled.npy", fault_signal(None, seconds=3))
    unlabelled = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/first", "figures=false",
                     "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert unlabelled.returncode == 2 and (f"unlabelled.npy: the file does not state its sampling rate; give fs=<Hz> "
                                           f"(or a row in {folder / 'labels.csv'}, which has none for it)") in unlabelled.stderr
    (folder / "unlabelled.npy").unlink()
    bare = tmp_path / "elsewhere" / "bare"  # without a table, the message names the one a user may write
    bare.mkdir(parents=True)
    for name in ("a", "b"):
        np.save(bare / f"{name}.npy", fault_signal(None, seconds=3))
    unlabelled = run("diagnose", f"path={bare}", "model=models:/diag/1", f"out={tmp_path}/out", "figures=false",
                     "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert unlabelled.returncode == 2
    assert ("a.npy: the file does not state its sampling rate; give fs=<Hz> (every file's), or this file's "
            "in a labels.csv beside it (columns record,state,rpm,fs)") in unlabelled.stderr, unlabelled.stderr[-2000:]
    (tmp_path / "out" / "earlier").mkdir(parents=True)
    (tmp_path / "out" / "earlier" / "diagnosis.json").write_text('{"record": "earlier", "model_uri": "models:/diag/1"}')
    done = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/out", "figures=false",
               "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "an earlier run's record outputs in out: 0 replaced by this run's, 1 removed (earlier)" in done.stdout
    assert not (tmp_path / "out" / "earlier").exists()
    for name, (rpm, fs) in rows.items():
        result = json.loads((tmp_path / "out" / name / "diagnosis.json").read_text())
        assert (result["rpm"], result["original_fs"], result["true_state"]) == (rpm, fs, "outer")
        assert result["evidence_state"] == "outer", result["evidence"]
    assert "of 2 with a known state" in done.stdout
    # A glob's files read the table of the folder they share, as the folder's own files do; a glob across folders
    # with tables of their own is refused, naming them.
    globbed = run("diagnose", f'path="{folder}/*.npy"', "model=models:/diag/1", f"out={tmp_path}/globbed",
                  "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert globbed.returncode == 0, globbed.stderr[-2000:]
    assert json.loads((tmp_path / "globbed" / "fast" / "diagnosis.json").read_text())["original_fs"] == 24000.0
    (tmp_path / "more").mkdir()
    np.save(tmp_path / "more" / "x.npy", fault_signal(None, seconds=3))
    (tmp_path / "more" / "labels.csv").write_text("record,state,rpm,fs\nx.npy,outer,1500,12000\n")
    across = run("diagnose", f'path="{tmp_path}/*/*.npy"', "model=models:/diag/1", f"out={tmp_path}/across",
                 "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert across.returncode == 2 and "matches files in 2 folders" in across.stderr, across.stderr[-2000:]
    assert str(folder / "labels.csv") in across.stderr and "give labels=<csv>" in across.stderr
    # A row's rate that the file contradicts is named as the row's, not as an fs= the command never got.
    np.savez(folder / "stated.npz", signal=fault_signal(None, seconds=3), fs=12000.0, rpm=1500.0)
    with open(folder / "labels.csv", "a") as table:
        table.write("stated.npz,outer,1500,48000\n")
    contradicted = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/stated",
                       "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert contradicted.returncode != 0 and "could not be diagnosed: stated.npz" in contradicted.stdout
    assert ("labels.csv (its row for stated.npz): fs=48000 Hz contradicts the file's 12000 Hz"
            in contradicted.stdout + contradicted.stderr), contradicted.stderr
    alone = run("diagnose", f"path={folder / 'stated.npz'}", "model=models:/diag/1", f"out={tmp_path}/alone",
                "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)  # its row beside one file is read
    assert alone.returncode == 2 and "labels.csv (its row for stated.npz): fs=48000 Hz" in alone.stderr, alone.stderr
    # For one file the command's own value comes first (the row fills in only what it leaves out), and another
    # file's rows, even two of one stem in subfolders (a data=files table may hold them), are not its concern.
    with open(folder / "labels.csv", "a") as table:
        table.write("rig_a/x.npz,outer,1500,12000\nrig_b/x.npz,inner,1500,12000\n")
    told = run("diagnose", f"path={folder / 'stated.npz'}", "model=models:/diag/1", "fs=12000", f"out={tmp_path}/told",
               "figures=false", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert told.returncode == 0, told.stderr[-2000:]
    assert json.loads((tmp_path / "told" / "stated" / "diagnosis.json").read_text())["true_state"] == "outer"


def test_a_fleets_labels_table_may_leave_the_state_out_and_give_speeds_and_rates_alone(registered, tmp_path):
    """For a fleet the states are what is asked: a labels table without a state column (record,rpm,fs), or with its
    state cells empty, gives each file its speed and rate, and its verdict is of unknown truth (neither true_state nor
    correct, nothing scored); a file whose row leaves out the rate it needs is refused naming the row's fs column."""
    _, uri = registered
    folder, rows = two_speed_folder(tmp_path / "fleet")
    np.save(folder / "norate.npy", fault_signal(None, seconds=3))
    for table in ("record,rpm,fs\nslow.npy,1500,12000\nfast.npy,1797,24000\nnorate.npy,1500,\n",
                  "record,state,rpm,fs\nslow.npy,,1500,12000\nfast.npy,,1797,24000\nnorate.npy,,1500,\n"):
        (folder / "labels.csv").write_text(table)
        done = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={tmp_path}/out", "figures=false",
                   "tracking.enabled=false", cwd=tmp_path, uri=uri)
        assert done.returncode == 2 and "records diagnosed: 2 of 3" in done.stdout, done.stderr[-2000:]
        for name, (rpm, fs) in rows.items():
            result = json.loads((tmp_path / "out" / name / "diagnosis.json").read_text())
            assert (result["rpm"], result["original_fs"]) == (rpm, fs) and "true_state" not in result
            assert "correct" not in result
        assert "records right" not in done.stdout
        assert (f"error: {folder / 'norate.npy'}: the file does not state its sampling rate; give fs=<Hz> (or this "
                f"file's in the fs column of its row in {folder / 'labels.csv'})") in done.stderr, done.stderr[-2000:]


def test_a_reused_out_folder_holds_this_runs_record_outputs_alone(registered, tmp_path):
    """Diagnosed again into the same out=, a record deleted since and one that fails now had kept the earlier run's
    verdict and figure, which anything reading out/*/diagnosis.json took for this run's: the command's own files of
    the earlier run are removed before the first record (a file of the user's own stays), the closing summary counts
    the records' outputs replaced and names those removed, and each diagnosis.json names its MLflow run and when
    it was made."""
    from datetime import datetime, timezone

    _, uri = registered
    folder = outer_race_folder(tmp_path, 3)
    out = tmp_path / "out"
    first = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert first.returncode == 0, first.stderr[-2000:]
    assert {path.parent.name for path in out.glob("*/diagnosis.png")} == {"r00", "r01", "r02"}
    (out / "r01" / "notes.txt").write_text("bearing replaced on Monday")  # the user's own, beside the outputs
    (folder / "r00.npz").unlink()
    np.savez(folder / "r01.npz", signal=np.zeros(3 * int(FS)), fs=FS, rpm=RPM)  # a dead sensor now
    started = datetime.now(timezone.utc).replace(microsecond=0)
    again = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert again.returncode == 2, again.stderr[-2000:]
    assert sorted(path.relative_to(out).as_posix() for path in out.rglob("*") if path.is_file()) == [
        "r01/notes.txt", "r02/diagnosis.json", "r02/diagnosis.png", "summary.csv"]
    assert "an earlier run's record outputs in out: 1 replaced by this run's, 2 removed (r00, r01)" in again.stdout
    result = json.loads((out / "r02" / "diagnosis.json").read_text())
    client = MlflowClient(uri)
    experiment = client.get_experiment(client.get_run(result["run_id"]).info.experiment_id).name
    assert f"MLflow run: {result['run_id']} in experiment {experiment}  (" in again.stdout  # the one it is in
    assert client.get_run(result["run_id"]).data.params["path"] == str(folder)
    assert result["diagnosed_at"].endswith("+00:00")
    assert started <= datetime.fromisoformat(result["diagnosed_at"]) <= datetime.now(timezone.utc)
    # One file at a time, as they arrive: each run replaces its own record's outputs and leaves the others'. A
    # diagnosis.json of someone else's (another record named, no model) is never removed, by any run.
    (folder / "r03.npz").write_bytes((folder / "r02.npz").read_bytes())
    (out / "notes").mkdir()
    (out / "notes" / "diagnosis.json").write_text('{"record": "mine"}')
    single = run("diagnose", f"path={folder / 'r03.npz'}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert single.returncode == 0, single.stderr[-2000:]
    assert {path.parent.name for path in out.glob("*/diagnosis.json")} == {"r02", "r03", "notes"}
    # A logger's next day gives a file of the same name in another folder: it would have replaced r03's verdict,
    # another file's, with one line of the summary to say so. Refused before any run is opened; r03 itself again is not.
    (tmp_path / "next_day").mkdir()
    (tmp_path / "next_day" / "r03.npz").write_bytes((folder / "r02.npz").read_bytes())
    runs_before = len(MlflowClient(uri).search_runs([e.experiment_id for e in MlflowClient(uri).search_experiments()]))
    other_day = run("diagnose", f"path={tmp_path / 'next_day' / 'r03.npz'}", "model=models:/diag/1", f"out={out}",
                    cwd=tmp_path, uri=uri)
    assert other_day.returncode == 2 and other_day.stderr.strip() == (
        f"error: out={out} holds r03's diagnosis of {folder / 'r03.npz'}, which {tmp_path / 'next_day' / 'r03.npz'} would "
        f"replace: give another out= (one per folder or day), or remove {out / 'r03'} to replace it"), other_day.stderr
    assert json.loads((out / "r03" / "diagnosis.json").read_text())["source"] == str(folder / "r03.npz")
    assert len(MlflowClient(uri).search_runs([e.experiment_id for e in MlflowClient(uri).search_experiments()])) \
        == runs_before
    single = run("diagnose", f"path={folder / 'r03.npz'}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert single.returncode == 0, single.stderr[-2000:]
    assert "another model" not in single.stdout
    # Rows of records another model diagnosed stay beside a one-file run's: the closing summary names them.
    r02 = json.loads((out / "r02" / "diagnosis.json").read_text())
    (out / "r02" / "diagnosis.json").write_text(json.dumps({**r02, "model_version_uri": "models:/other/3"}))
    single = run("diagnose", f"path={folder / 'r03.npz'}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert single.returncode == 0, single.stderr[-2000:]
    assert re.search(r"summary.csv also holds records another model diagnosed: +models:/other/3: r02\n", single.stdout), \
        single.stdout
    # ... and their rows of summary.csv: each one-file run's row beside the rows of the files before it. A failing
    # file's run had written a summary.csv of its own row alone over the folder's.
    rows = {row["record"]: row for row in csv.DictReader(open(out / "summary.csv"))}
    assert list(rows) == ["r01", "r02", "r03"] and rows["r03"]["verdict"] == rows["r02"]["verdict"] != ""
    assert rows["r01"]["error"].endswith("r01.npz: every sample is 0: no vibration recorded")
    (folder / "r05.npz").write_bytes(b"not an npz")
    failing = run("diagnose", f"path={folder / 'r05.npz'}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert failing.returncode == 2 and failing.stderr.startswith(f"error: {folder / 'r05.npz'}: "), failing.stderr[-2000:]
    rows = {row["record"]: row for row in csv.DictReader(open(out / "summary.csv"))}
    assert list(rows) == ["r01", "r02", "r03", "r05"] and rows["r05"]["error"] and rows["r03"]["verdict"]
    (folder / "r05.npz").unlink()
    folder_run = run("diagnose", f"path={folder}", "model=models:/diag/1", f"out={out}", cwd=tmp_path, uri=uri)
    assert folder_run.returncode == 2 and (out / "notes" / "diagnosis.json").is_file(), folder_run.stderr[-2000:]
    # A record named as that folder is refused rather than written over it, nor written through a linked folder.
    (folder / "notes.npz").write_bytes((folder / "r02.npz").read_bytes())
    (tmp_path / "elsewhere").mkdir()
    (out / "r04").symlink_to(tmp_path / "elsewhere")
    (folder / "r04.npz").write_bytes((folder / "r02.npz").read_bytes())
    for name in ("notes", "r04"):
        refused = run("diagnose", f"path={folder / (name + '.npz')}", "model=models:/diag/1", f"out={out}",
                      cwd=tmp_path, uri=uri)
        assert refused.returncode == 2 and "it is kept: move it or choose another out=" in refused.stderr, \
            refused.stderr[-2000:]
    assert json.loads((out / "notes" / "diagnosis.json").read_text()) == {"record": "mine"}
    assert not any((tmp_path / "elsewhere").iterdir())


def test_a_record_far_slower_than_the_models_training_speed_or_of_a_window_or_two_is_named_so(registered, tmp_path):
    """The smoke model learnt the bearing at 1797 rev/min: a record at 600 rev/min is read as the model never learnt
    (its note, summary.csv's speed_unseen, a line of the closing summary), as is a verdict resting on one window;
    a record at the model's own speed and long enough gets neither note. A user's summary.csv in out= is kept and
    the folder refused before any record is read."""
    _, uri = registered
    folder = tmp_path / "f"
    folder.mkdir()
    np.savez(folder / "slow.npz", signal=fault_signal(None, seconds=3), fs=FS, rpm=600.0)
    np.savez(folder / "usual.npz", signal=fault_signal(None, seconds=3, seed=1), fs=FS, rpm=RPM)
    np.savez(folder / "short.npz", signal=fault_signal(None, seconds=0.3, seed=2), fs=FS, rpm=RPM)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "summary.csv").write_text("machine,owner\npump 3,me\n")
    refused = run("diagnose", "path=f", "model=models:/diag/1", "out=mine", "figures=false", "tracking.enabled=false",
                  cwd=tmp_path, uri=uri)
    assert refused.returncode == 2 and refused.stderr == (
        f"error: {tmp_path / 'mine' / 'summary.csv'} is not one this command wrote; it is kept: move it or choose "
        "another out=\n")
    assert (tmp_path / "mine" / "summary.csv").read_text() == "machine,owner\npump 3,me\n"
    done = run("diagnose", "path=f", "model=models:/diag/1", "out=out", "figures=false", "tracking.enabled=false",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    notes = {name: json.loads((tmp_path / "out" / name / "diagnosis.json").read_text())["notes"]
             for name in ("slow", "usual", "short")}
    assert any(note.startswith("the shaft speed (600 rev/min) lies more than 25% below the slowest (1797) of the "
                               "model's training windows") for note in notes["slow"])
    assert "the verdict rests on 1 window of the model's 2048 samples (0.171 s): a longer record gives a surer one" \
        in notes["short"]
    assert not any("shaft speed (" in note or "rests on" in note for note in notes["usual"] + notes["short"][:-1])
    rows = {row["record"]: row for row in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert {name: row["speed_unseen"] for name, row in rows.items()} == {"short": "False", "slow": "True",
                                                                         "usual": "False"}
    assert "shaft speed well beyond the model's training windows' (see their notes): slow\n" in done.stdout
    # The one-window verdict is a line of the closing summary too, as every other doubt is (it had been its note's alone).
    assert "verdict on one or two windows (a longer record gives a surer one): short\n" in done.stdout
    # 0.3 s at 1797 rev/min, or 3 s at 600, cannot place the shaft line finely enough to check the rate: said of them,
    # in the closing summary too.
    assert [rows[name]["rate_check"] == "not checked" for name in ("short", "slow", "usual")] == [True, True, False]
    assert ("sampling rate not checked (too short for the shaft line to confirm it: see their notes): short, slow\n"
            in done.stdout)


def test_an_interrupt_while_a_record_is_written_leaves_no_part_of_it(registered, tmp_path, monkeypatch):
    """Interrupted while drawing a record's figure, the command had left that record's folder without its
    diagnosis.json (and an earlier run's record beside it): out holds the records finished, and nothing else."""
    from bearingtwin.diagnosis import run as diagnosis_run

    _, uri = registered
    folder = outer_race_folder(tmp_path, 2)
    out = tmp_path / "out"
    (out / "r01").mkdir(parents=True)
    (out / "r01" / "diagnosis.json").write_text('{"record": "r01", "model_uri": "models:/diag/1", "verdict": "normal"}')  # an earlier run's

    def plot_then_interrupt(result, evidence, class_names, path):
        if result["record"] == "r01":
            path.write_bytes(b"\x89PNG")  # a figure cut short
            raise KeyboardInterrupt
        return plot_diagnosis(result, evidence, class_names, path)

    monkeypatch.setattr(diagnosis_run, "plot_diagnosis", plot_then_interrupt)
    cfg = compose_config("diagnose", [f"path={folder}", "model=models:/diag/1", f"out={out}", "tracking.enabled=false",
                                      f"tracking.uri={uri}"])
    with pytest.raises(KeyboardInterrupt):
        diagnosis_run.diagnose_paths(cfg)
    assert sorted(path.relative_to(out).as_posix() for path in out.rglob("*")) == [
        "r00", "r00/diagnosis.json", "r00/diagnosis.png", "summary.csv"]


def test_files_of_one_record_name_in_several_folders_are_named_with_their_folders_every_clash_at_once(tmp_path):
    """A glob over weekly folders matches m01.csv in each: a record is named by its stem, so they are refused, and
    the refusal names each file with its folder (not m01.csv four times) and every record name that clashes."""
    from bearingtwin.diagnosis.run import find_records

    for week in ("week01", "week02"):
        (tmp_path / week).mkdir()
        for name in ("m01", "m02", week):
            np.save(tmp_path / week / f"{name}.npy", np.zeros(8))
    with pytest.raises(BearingTwinError) as refused:
        find_records(f"{tmp_path}/week*/*.npy", None)
    assert str(refused.value) == (f"path={tmp_path}/week*/*.npy: week01/m01.npy, week02/m01.npy share the record name "
                                  "m01; week01/m02.npy, week02/m02.npy share the record name m02; rename them, or point "
                                  "at one folder or file")


def test_a_bad_labels_row_fails_its_file_alone_and_tables_of_notes_are_left_out(registered, tmp_path):
    """A folder's labels.csv with a state typo, a speed that is no number and a negative rate: those three files
    fail, each naming the table, its line and the field, the good one is diagnosed and scored, and the command exits
    2. Diagnosed alone, the good file reads its own row. Notes, a results table and a copy of the labels table beside
    the recordings are left out, each named with why: neither diagnosed nor failures, while an unlabelled recording
    (a CSV of numbers) is diagnosed."""
    base, uri = registered
    folder = tmp_path / "rig"
    folder.mkdir()
    bpfo = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)["bpfo"]
    for seed, name in enumerate(("good", "typo", "speed", "rate")):
        np.save(folder / f"{name}.npy", fault_signal(bpfo, seconds=3, seed=seed))
    table = folder / "labels.csv"
    table.write_text("record,state,rpm,fs\ngood.npy,outer,1797,12000\ntypo.npy,outter,1797,12000\n"
                     "speed.npy,outer,fast,12000\nrate.npy,outer,1797,-12000\nlogged.csv,outer,1797,12000\n")
    (folder / "logged.csv").write_text("acc,status\n0.1,ok\n0.2,ok\n")  # labelled: a recording, its reader says why not
    (folder / "notes.csv").write_text("date,operator,comment\n2024-01-02,ann,new sensor\n")
    (folder / "results.csv").write_text("record,verdict,share\ngood,outer,0.9\n")
    (folder / "states.csv").write_text("record,state\ngood.npy,outer\n")
    common = ("model=models:/diag/1", "figures=false", "tracking.enabled=false", "rpm=1797", "fs=12000")
    done = run("diagnose", f"path={folder}", f"out={tmp_path}/out", *common, cwd=tmp_path, uri=uri)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-2000:]
    rows = {row["record"]: row for row in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert set(rows) == {"good", "typo", "speed", "rate", "logged"} and not rows["good"]["error"]
    assert rows["good"]["true_state"] == "outer" and "records diagnosed: 1 of 5" in done.stdout
    errors = [line for line in done.stderr.splitlines() if line.startswith("error: ")]
    assert errors[0].startswith(f"error: {folder / 'logged.csv'}: ") and rows["logged"]["error"]
    assert errors[1:] == [
        f"error: {folder / 'rate.npy'}: {table} line 5: fs='-12000' must be a positive number of Hz (a plain number, "
        "no unit)",
        f"error: {folder / 'speed.npy'}: {table} line 4: rpm='fast' must be a positive number of rev/min (a plain "
        "number, no unit)",
        f"error: {folder / 'typo.npy'}: {table} line 3: state 'outter' is not a bearing state; choose one of normal, "
        "inner, ball, outer",
    ]
    said = done.stdout + done.stderr
    assert f"{folder}: left out notes.csv (its column 'date' holds text ('2024-01-02'), not samples)" in said
    assert f"{folder}: left out results.csv (its column 'record' holds text ('good'), not samples)" in said
    assert f"{folder}: left out states.csv (a labels table, columns record,state, not a recording)" in said
    alone = run("diagnose", f"path={folder / 'good.npy'}", f"out={tmp_path}/alone", *common, cwd=tmp_path, uri=uri)
    assert alone.returncode == 0, alone.stderr[-2000:]
    assert json.loads((tmp_path / "alone" / "good" / "diagnosis.json").read_text())["true_state"] == "outer"
    assert "good.npy: read its row of" in alone.stdout + alone.stderr  # and the bad rows named, in one line
    given = run("diagnose", f"path={folder / 'good.npy'}", f"labels={table}", f"out={tmp_path}/given", *common,
                cwd=tmp_path, uri=uri)
    assert given.returncode == 0, given.stderr[-2000:]
    assert f"{table}: passed over rows of other files that do not read: {table} line 3: state 'outter'" in given.stdout
    table.write_text("record,state\ngood.npy,outer\ntypo.npy,outer\nspeed.npy,outer\nrate.npy,outer\n")
    (folder / "logged.csv").unlink()
    np.savetxt(folder / "unknown.csv", fault_signal(None, seconds=3))  # a recording no row labels
    mended = run("diagnose", f'path="{folder}/*.csv"', f"out={tmp_path}/mended", *common, cwd=tmp_path, uri=uri)
    assert mended.returncode == 0, mended.stderr[-2000:]
    assert json.loads((tmp_path / "mended" / "unknown" / "diagnosis.json").read_text())["verdict"]
    assert f"left out {folder / 'notes.csv'} (its column 'date' holds text" in mended.stdout + mended.stderr
    assert not (tmp_path / "mended" / "notes").exists()


def test_bad_models_fail_in_one_line(registered, tmp_path):
    base, uri = registered
    record = tmp_path / "r.npz"
    np.savez(record, signal=fault_signal(None, seconds=1), fs=FS, rpm=RPM)
    unknown = run("diagnose", f"path={record}", "model=models:/no_such_model@champion", cwd=tmp_path, uri=uri)
    assert unknown.returncode == 2 and "model=models:/no_such_model@champion" in unknown.stderr
    assert "Traceback" not in unknown.stderr
    per_class = run("diagnose", f"path={record}", "model=models:/diag_per_class/1", cwd=tmp_path, uri=uri)
    assert per_class.returncode == 2 and "vmd_params=per_class" in per_class.stderr and "Traceback" not in per_class.stderr
    missing = run("diagnose", f"path={tmp_path}/absent.mat", "model=models:/diag/1", cwd=tmp_path, uri=uri)
    assert missing.returncode == 2 and "absent.mat" in missing.stderr
    bearing = run("diagnose", f"path={record}", "model=models:/diag/1", "bearing=skf_0000", cwd=tmp_path, uri=uri)
    assert bearing.returncode == 2 and "bearing=skf_0000: no such bearing config; choose one of cwru_6203" in bearing.stderr
    assert len(bearing.stderr.strip().splitlines()) == 1 and not (tmp_path / "diagnosis").exists()


def test_the_model_of_a_run_that_did_not_finish_is_refused_saying_so(tmp_path):
    """A training stopped while it logged its model leaves the run KILLED and the model part-written: MLflow's
    reason alone (no MLmodel file in a temporary folder) did not say why."""
    from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(uri)
    run_id = client.create_run(client.create_experiment("bearingtwin")).info.run_id
    client.set_terminated(run_id, "KILLED")
    with pytest.raises(BearingTwinError, match=(rf"^model=runs:/{run_id}/model: cannot load it from .*; its run "
                                                rf"{run_id} ended KILLED, so its model may not have been logged whole$")):
        load_diagnosis_model(f"runs:/{run_id}/model", uri)
    # A run whose process died unseen is still RUNNING: it has not "ended".
    running = client.create_run(client.get_experiment_by_name("bearingtwin").experiment_id).info.run_id
    with pytest.raises(BearingTwinError, match=rf"; its run {running} is still marked RUNNING: its process may have "):
        load_diagnosis_model(f"runs:/{running}/model", uri)


def test_a_model_that_cannot_be_loaded_is_refused_naming_what_the_store_holds(tmp_path):
    """MLflow's reasons alone ("Registered Model with name=nosuch not found", "Logged model with ID 'diag' not found"
    for a name without a version, 18 artifact schemes listed for a typo) did not say what to give instead: the
    refusal names the registered models, a model's versions and aliases, what a run of the project's that holds no
    model is, and the forms a model URI takes."""
    from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client = MlflowClient(uri, registry_uri=uri)
    experiment = client.create_experiment("bearingtwin")
    with pytest.raises(BearingTwinError, match=r"^model=models:/nosuch/1: cannot load it from .*; no model is "
                                               r"registered there$"):
        load_diagnosis_model("models:/nosuch/1", uri)
    for name in ("diag", "other"):
        client.create_registered_model(name)
    for _ in range(2):
        run_id = client.create_run(experiment).info.run_id
        client.create_model_version("diag", f"runs:/{run_id}/model", run_id)
    client.set_registered_model_alias("diag", "champion", "2")
    with pytest.raises(BearingTwinError, match=r"^model=models:/nosuch/1: cannot load it .*; registered there: diag, "
                                               r"other$"):
        load_diagnosis_model("models:/nosuch/1", uri)
    with pytest.raises(BearingTwinError, match=r"^model=models:/diag@prod: cannot load it .*\(Registered model alias "
                                               r"prod not found\); diag's versions: 1, 2, its aliases: @champion "
                                               r"\(version 2\)$"):
        load_diagnosis_model("models:/diag@prod", uri)
    # models:/<name> alone is read as a logged model's id (models:/m-...), which MLflow says it cannot find.
    with pytest.raises(BearingTwinError, match=r"^model=models:/diag: cannot load it .*; diag's versions: 1, 2, its "
                                               r"aliases: @champion \(version 2\) \(give one: models:/diag/<version> "
                                               r"or models:/diag@<alias>\)$"):
        load_diagnosis_model("models:/diag", uri)
    for typo in ("modles:/diag/1", "run:/abc/model"):
        with pytest.raises(BearingTwinError, match=rf"^model={typo}: {typo.split(':')[0]}:/ is no model URI here; give "
                                                   r"runs:/<run id>/model, models:/<name>/<version> or "
                                                   r"models:/<name>@<alias>, or a model's folder$"):
            load_diagnosis_model(typo, uri)
    # A bare name or a folder on disk had been answered with MLflow's words of a download.
    forms = r"give runs:/<run id>/model, models:/<name>/<version> or models:/<name>@<alias>, or a model's folder"
    with pytest.raises(BearingTwinError, match=rf"^model=diag: no such folder, nor a model URI; {forms} \(one holding "
                                               r"MLmodel\); diag's versions: 1, 2, its aliases: @champion \(version 2\)"):
        load_diagnosis_model("diag", uri)
    (tmp_path / "empty").mkdir()
    with pytest.raises(BearingTwinError, match=rf"^model={tmp_path / 'empty'}: a folder without an MLmodel file; {forms} "
                                               r"\(one holding MLmodel\)$"):
        load_diagnosis_model(str(tmp_path / "empty"), uri)
    sweep = client.create_run(experiment, tags={"bt.kind": "sweep"}).info.run_id
    client.set_terminated(sweep, "FAILED")  # a sweep one of whose jobs failed: no model was ever meant to be there
    with pytest.raises(BearingTwinError, match=rf"; run {sweep} is a sweep's parent run, which holds no model: its "
                                               r"jobs' runs do$"):
        load_diagnosis_model(f"runs:/{sweep}/model", uri)


def test_a_bearing_of_the_users_own_outside_the_checkout_is_found_through_hydras_search_path(registered, tmp_path):
    base, uri = registered
    (tmp_path / "conf" / "bearing").mkdir(parents=True)
    (tmp_path / "conf" / "bearing" / "my6005.yaml").write_text(
        "defaults:\n  - paper\n  - _self_\nname: my6005\nn_balls: 11\nball_diameter_mm: 6.35\n"
        "pitch_diameter_mm: 36.0\nouter_diameter_mm: 47.0\ninner_diameter_mm: 25.0\n")
    record = tmp_path / "r.npz"
    np.savez(record, signal=fault_signal(None, seconds=1), fs=FS, rpm=RPM)
    done = run("diagnose", f"path={record}", "model=models:/diag/1", "bearing=my6005", f"out={tmp_path}/out",
               f"hydra.searchpath=[file://{tmp_path / 'conf'}]", "figures=false", "tracking.enabled=false",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads((tmp_path / "out" / "r" / "diagnosis.json").read_text())
    assert result["bearing"] == "my6005" and "  bearing: my6005" in done.stdout  # whose lines were read, said
    evidence = result["evidence"]
    # The physics evidence reads the user's bearing's outer-race line, BPFO = Nb / 2 (1 - d / D) x shaft.
    assert evidence["lines_hz"]["outer"][0] == pytest.approx(11 / 2 * (1 - 6.35 / 36.0) * RPM / 60, rel=1e-6), evidence
    unknown = run("diagnose", f"path={record}", "model=models:/diag/1", "bearing=my6005", cwd=tmp_path, uri=uri)
    assert unknown.returncode == 2 and ("bearing=my6005: no such bearing config; choose one of cwru_6203, cwru_6205, "
                                        "er16k, paper, or describe yours in <folder>/bearing/my6005.yaml and add "
                                        "hydra.searchpath=[file://<folder>]") in unknown.stderr, unknown.stderr


@pytest.mark.parametrize("scheme", ["file://", ""])
def test_the_bearings_a_name_may_choose_are_those_hydra_finds_on_the_search_path(tmp_path, scheme):
    from hydra import initialize_config_dir

    from bearingtwin.config import CONF_DIR, bearing_choices

    (tmp_path / "bearing").mkdir()
    (tmp_path / "bearing" / "my6005.yaml").write_text("defaults:\n  - paper\n  - _self_\nn_balls: 11\n")
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        assert "my6005" in bearing_choices([f"hydra.searchpath=['{scheme}{tmp_path}']"])
        assert "my6005" not in bearing_choices()


@needs_cwru
def test_cwru_records_at_48_khz_or_packaged_without_a_speed_are_read_as_the_data_center_wrote_them(registered, tmp_path):
    import scipy.io
    import scipy.signal

    base, uri = registered
    stored = scipy.io.loadmat(CWRU / "normal_0_97.mat")
    at_48k = scipy.signal.resample_poly(stored["X097_DE_time"][:, 0], 4, 1)  # 97 as if recorded at 48 kHz
    folder = tmp_path / "records"
    folder.mkdir()
    record = folder / "normal_1_98.mat"  # a healthy baseline name: it states no rate, 12 kHz is declared
    scipy.io.savemat(record, {"X098_DE_time": at_48k[:, None], "X098_FE_time": at_48k[:, None], "X098RPM": stored["X097RPM"]})
    # Record 105 (0 hp) packaged as the Data Center packages its 0.028 in records: another number, no speed.
    inner = scipy.io.loadmat(CWRU / "12k_Drive_End_IR007_0_105.mat")
    scipy.io.savemat(folder / "12k_Drive_End_IR028_0_3001.mat", {"X056_DE_time": inner["X105_DE_time"]})
    # The Data Center's own file name (a number its catalogue lists) and a mirror's (its label of the condition).
    scipy.io.savemat(folder / "3003.mat", {"X058_DE_time": scipy.io.loadmat(CWRU / "12k_Drive_End_IR007_2_107.mat")["X107_DE_time"]})
    outer = scipy.io.loadmat(CWRU / "12k_Drive_End_OR007@6_2_132.mat")
    scipy.io.savemat(folder / "OR021@3_2.mat", {"X248_DE_time": outer["X132_DE_time"], "X248RPM": outer["X132RPM"]})
    done = run("diagnose", f"path={folder}", "model=models:/diag@champion", f"out={tmp_path}/out", "tracking.enabled=false",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "stands where it belongs at 48000 Hz" in done.stdout and "read at 48000 Hz" in done.stdout
    assert "48000 Hz -> 12000 Hz" in done.stdout
    result = json.loads((tmp_path / "out" / "normal_1_98" / "diagnosis.json").read_text())
    assert result["original_fs"] == 48000.0 and len(result["windows"]) == stored["X097_DE_time"].size // 2048
    repackaged = json.loads((tmp_path / "out" / "12k_Drive_End_IR028_0_3001" / "diagnosis.json").read_text())
    assert repackaged["rpm"] == 1797.0 and repackaged["true_state"] == "inner" and repackaged["original_fs"] == 12000.0
    assert any("nominal speed at 0 hp" in note for note in repackaged["notes"]) and "nominal speed at 0 hp" in done.stdout
    # Scored against the names, beside the envelope analysis alone on the same records, by defect size.
    assert repackaged["fault_size_in"] == 0.028 and repackaged["physics_correct"]  # record 105's clear BPFI series
    rows = {row["record"]: row for row in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert rows["12k_Drive_End_IR028_0_3001"]["fault_size_in"] == "0.028" and rows["normal_1_98"]["fault_size_in"] == ""
    condition = ("true_state", "fault_size_in", "position", "load_hp", "original_fs")
    assert tuple(rows["3003"][key] for key in condition) == ("inner", "0.028", "", "2", "12000.0")
    assert tuple(rows["OR021@3_2"][key] for key in condition) == ("outer", "0.021", "3", "2", "12000.0")
    assert json.loads((tmp_path / "out" / "3003" / "diagnosis.json").read_text())["rpm"] == 1750.0  # 2 hp's nominal
    # The label's record is the catalogue's (X248: OR021@3_2 at 12 kHz, drive end), which gives its rate and bearing.
    assert "which the Data Center's catalogue lists as OR021@3_2 at 12 kHz, drive end: read so" in done.stdout
    for row in rows.values():  # the physics is right where its evidence names the record's state
        assert row["physics_correct"] == str(row["evidence_state"] == row["true_state"]), row
    assert re.search(r"physics alone right: [\d.]+ % of the 4 with a known state and physics evidence", done.stdout), done.stdout
    # Every record is of the 6205; read at two rates, the groups name theirs, and the outer race its position.
    by_size = re.search(r"records right by state and fault size \(model, physics\): normal at 48 kHz [01]/1, [01]/1; "
                        r"inner 0.028 in at 12 kHz [012]/2, [12]/2; outer 0.021 in @3 at 12 kHz [01]/1, [01]/1",
                        done.stdout)
    assert by_size is not None, done.stdout
    assert "read at another rate than declared (the shaft line refused it: see their notes): normal_1_98 (12000 -> " \
           "48000 Hz)" in done.stdout


@needs_cwru
def test_a_cwru_record_whose_speed_variable_the_shaft_line_contradicts_is_diagnosed_in_doubt(registered, tmp_path):
    """Record 106 (1772 rpm) packaged with a speed variable of 1500 rpm: no rate the Data Center records at puts the
    shaft line where 1500 rpm does, and the line cannot tell a wrong speed from a wrong rate, so the record is
    diagnosed at its stated values, in doubt (a note with the speed the line implies, rate_check contradicted, a
    line of the summary), not refused."""
    import scipy.io

    base, uri = registered
    folder = tmp_path / "records"
    folder.mkdir()
    stored = scipy.io.loadmat(CWRU / "12k_Drive_End_IR007_1_106.mat")
    scipy.io.savemat(folder / "12k_Drive_End_IR014_1_170.mat", {"X170_DE_time": stored["X106_DE_time"],
                                                               "X170RPM": np.array([[1500.0]])})
    done = run("diagnose", f"path={folder}", "model=models:/diag@champion", f"out={tmp_path}/out", "tracking.enabled=false",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads((tmp_path / "out" / "12k_Drive_End_IR014_1_170" / "diagnosis.json").read_text())
    assert result["rate_check"] == "contradicted" and result["rpm"] == 1500.0 and result["fs"] == 12000.0
    note = next(note for note in result["notes"] if note.startswith("speed and rate disagree"))
    assert float(re.search(r"the shaft line says (\d+) rpm", note).group(1)) == pytest.approx(1772, rel=0.02)
    assert "speed or rate in doubt (the shaft line contradicts them: check them): 12k_Drive_End_IR014_1_170" in done.stdout


@pytest.mark.parametrize("overrides, message", [
    (["register_alias=champion"], "register_alias=champion needs register=<model name>"),
    (["register=a/b"], "register=a/b: Invalid model name 'a/b'. Names cannot contain '/' or ':'."),
    (["register=ok", "register_alias=latest"], "register_alias=latest: 'latest' alias name (case insensitive) is reserved."),
    (["register=ok", "register_alias=v3"], "register_alias=v3: Version alias name 'v3' is reserved."),
])
def test_a_registration_mlflow_would_refuse_fails_before_any_work(tmp_path, overrides, message):
    """MLflow's registry checks the names only when the model is registered, after the training."""
    done = run("train", *SMOKE, *overrides, f"paths.cache_dir={tmp_path}/cache", cwd=tmp_path,
               uri=f"sqlite:///{tmp_path}/mlflow.db")
    assert done.returncode == 2 and message in done.stderr and "Traceback" not in done.stderr, done.stderr
    assert not (tmp_path / "cache").exists()  # nothing was simulated


def test_unknown_keys_are_refused(tmp_path):
    done = run("diagnose", "path=x.npz", "model=runs:/x/model", "+evidence.threshold=3", cwd=tmp_path,
               uri=f"sqlite:///{tmp_path}/mlflow.db")
    assert done.returncode == 2 and "evidence.threshold" in done.stderr and "Traceback" not in done.stderr
    # A bearing is asked for by its conf/bearing name, so a value changed on top of the file is refused, not dropped.
    changed = run("diagnose", "path=x.npz", "model=runs:/x/model", "bearing=cwru_6203", "bearing.n_balls=7", cwd=tmp_path,
                  uri=f"sqlite:///{tmp_path}/mlflow.db")
    assert changed.returncode == 2 and changed.stderr.startswith("error: bearing.*: bearingtwin-diagnose reads "
                                                                 "conf/bearing/cwru_6203.yaml as written"), changed.stderr
    assert len(changed.stderr.strip().splitlines()) == 1


def outer_race_folder(tmp_path, count: int):
    """A folder of ``count`` 3 s outer-race records, ``r00.npz`` ..., at the drive end's speed and rate."""
    folder = tmp_path / "recordings"
    folder.mkdir()
    rates = BearingGeometry.from_config(BEARING).defect_frequencies(RPM)
    for index in range(count):
        np.savez(folder / f"r{index:02d}.npz", signal=fault_signal(rates["bpfo"], seconds=3, seed=index), fs=FS, rpm=RPM)
    return folder


def test_an_interrupted_folder_is_killed_in_mlflow_and_summarised_as_far_as_it_went(registered, tmp_path):
    """The run is open while the records are diagnosed, so a Ctrl-C marks it KILLED; summary.csv lists the
    records this run diagnosed, not an earlier run's beside them, and those it did not reach as not diagnosed."""
    import signal
    import sys
    import time

    from bearingtwin.diagnosis.run import SUMMARY_COLUMNS

    base, uri = registered
    folder = outer_race_folder(tmp_path, 60)
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.csv").write_text(",".join(SUMMARY_COLUMNS) + "\nan_earlier_run,normal\n")  # the command's own
    process = subprocess.Popen([sys.executable, "-m", "bearingtwin.cli.diagnose", f"path={folder}", "model=models:/diag/1",
                                f"out={out}", "figures=false"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env={**os.environ, "MLFLOW_TRACKING_URI": uri})
    deadline = time.monotonic() + 180
    while len(list(out.glob("r*/diagnosis.json"))) < 2:
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()[1][-2000:]
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err[-2000:]
    assert "marked KILLED: run" in err.strip().splitlines()[-1] and "Traceback" not in err, err[-2000:]
    client = MlflowClient(uri)
    (run,) = client.search_runs([client.get_experiment_by_name("bearingtwin-diagnose").experiment_id],
                                "tags.`bt.kind` = 'diagnose'", order_by=["attributes.start_time DESC"], max_results=1)
    assert run.info.status == "KILLED" and run.data.params["path"] == str(folder)
    rows = list(csv.DictReader(open(out / "summary.csv")))
    diagnosed = [row["record"] for row in rows if not row.get("error")]
    assert diagnosed and "an_earlier_run" not in diagnosed and len(diagnosed) < 60
    assert set(diagnosed) <= {path.parent.name for path in out.glob("r*/diagnosis.json")}
    # The records the interrupt left are listed as left: the summary does not read as the whole folder's.
    left = {row["record"] for row in rows if row.get("error") == NOT_REACHED}
    assert len(rows) == 60 and left == {f"r{index:02d}" for index in range(60)} - set(diagnosed)


def test_a_record_of_a_state_the_model_never_learned_says_so(tmp_path):
    """A model trained without ball faults calls a ball record something else, always wrongly: the note says why."""
    import scipy.io

    rpm = 1772.0
    t = np.arange(int(4 * FS)) / FS
    shaft = sum(0.1 / k * np.sin(2 * np.pi * k * rpm / 60 * t) for k in (1, 2, 3))
    path = tmp_path / "12k_Drive_End_B007_1_119.mat"
    scipy.io.savemat(path, {"X119_DE_time": (fault_signal(None) + shaft)[:, None], "X119RPM": rpm})
    prepared = read_record(path, envelope_pipeline())
    assert prepared.true_state == "ball"
    assert "true state ball, which this model cannot answer: it was trained on normal, inner, outer only" in prepared.notes


@needs_cwru
def test_a_speed_the_shaft_line_contradicts_is_named_with_what_it_would_be_and_the_verdict_put_in_doubt(registered,
                                                                                                     tmp_path):
    """An export of record 106 (1772 rpm) given rpm=900: the shaft line fixes only the ratio of speed and rate, so the
    note names the speed it implies at the given rate; the record is still diagnosed, listed in the summary as one
    whose speed or rate is wrong, and ``rate_check`` says so. Given its true speed, the check is consistent."""
    from bearingtwin.data.cwru import load_cwru

    base, uri = registered
    (tmp_path / "recordings").mkdir()
    np.save(tmp_path / "recordings" / "r106.npy", load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat", channel="DE",
                                                            fs=12000.0).signal)
    (tmp_path / "recordings" / "notes.txt").write_text("taken on the test stand")
    done = run("diagnose", "path=recordings", "model=models:/diag@champion", "fs=12000", "rpm=900", f"out={tmp_path}/out",
               "tracking.enabled=false", cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "out" / "r106" / "diagnosis.json").read_text())
    note = next(note for note in result["notes"] if note.startswith("speed and rate disagree"))
    assert result["rate_check"] == "contradicted" and "the verdict is in doubt" in note
    assert float(re.search(r"at fs = 12000 Hz the shaft line says (\d+) rpm", note).group(1)) == pytest.approx(
        1772, rel=0.02)
    assert "speed or rate in doubt (the shaft line contradicts them: check them): r106" in done.stdout
    # ...and on the record's own line, which is read first: the verdict's confidence says nothing of it.
    (line,) = [line for line in done.stdout.splitlines() if re.match(r"r106: \w+ \(\d+% of \d+ windows", line)]
    # The .npy states no unit either, and this model reads levels.
    assert line.endswith(" - IN DOUBT: the shaft line contradicts the speed or rate; its unit is assumed to be the "
                         "model's, which reads levels: give unit="), line
    assert "left out notes.txt" in done.stdout + done.stderr  # a file of another format is named, not dropped silently
    done = run("diagnose", "path=recordings/r106.npy", "model=models:/diag@champion", "fs=12000", "rpm=1772",
               f"out={tmp_path}/right", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    result = json.loads((tmp_path / "right" / "r106" / "diagnosis.json").read_text())
    assert done.returncode == 0 and result["rate_check"] == "consistent" and "speed or rate in doubt" not in done.stdout
    assert "the shaft line contradicts" not in done.stdout
    # Resampled to 25.6 kHz and declared at 12: the rate note's chain ends near 25.6 kHz (840 rpm at 12 kHz); the speed
    # the shaft series read at the refused rate is no speed, and its "give rpm=..." had stood beside it.
    import scipy.signal

    np.save(tmp_path / "r106_25k6.npy", scipy.signal.resample_poly(np.load(tmp_path / "recordings" / "r106.npy"), 32, 15))
    done = run("diagnose", "path=r106_25k6.npy", "model=models:/diag@champion", "fs=12000", "rpm=1772",
               f"out={tmp_path}/fast", "tracking.enabled=false", cwd=tmp_path, uri=uri)
    result = json.loads((tmp_path / "fast" / "r106_25k6" / "diagnosis.json").read_text())
    assert done.returncode == 0 and result["rate_check"] == "contradicted", result["notes"]
    note = next(note for note in result["notes"] if note.startswith("speed and rate disagree"))
    assert re.search(r"implying fs = 25[3-9]\d\d Hz; at fs = 12000 Hz the shaft line says", note), note
    assert not any("if the sampling rate is right" in note for note in result["notes"]), result["notes"]


@needs_cwru
@pytest.mark.parametrize("rpm, nearest_rpm", [(900.0, 1772.0), (17720.0, None)])
def test_a_speed_that_contradicts_a_rate_the_file_states_is_named_as_the_suspect(tmp_path, rpm, nearest_rpm):
    """Record 106 (1772 rpm) written with its time stamps: the rate is the file's own, so a contradicting speed is
    what the note names, and no rate is suggested. The nearest series' reading is offered as the speed "if it is
    the shaft's": right for a speed a little off, no reading of the speed for one ten times too high (the series
    near the line that speed expects is not the shaft's)."""
    from bearingtwin.data.cwru import load_cwru

    signal = load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat", channel="DE", fs=12000.0).signal[:60000]
    t = np.arange(signal.size) / 12000.0
    (tmp_path / "r106.csv").write_text("time_s,acc_g\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, signal)))
    prepared = read_record(tmp_path / "r106.csv", envelope_pipeline(), rpm=rpm)
    assert prepared.rate_check == "contradicted"
    (note,) = [note for note in prepared.notes if note.startswith("the speed contradicts the record")]
    assert (f"at {rpm:g} rpm the shaft line belongs at {rpm / 60:.2f} Hz, and the shaft's series does not stand "
            "where that puts it at the rate the file's time stamps give (12000 Hz): check the speed given") in note
    assert "fs may be" not in note and "the verdict is in doubt" in note
    said = float(re.search(r"would put it at (\d+) rpm if it is the shaft's", note).group(1))
    if nearest_rpm:
        assert said == pytest.approx(nearest_rpm, rel=0.02)
    else:
        assert said > 5 * 1772  # the 10th harmonic's neighbourhood, which the note offers only conditionally


@needs_cwru
def test_a_typed_rate_the_shaft_line_contradicts_is_named_beside_the_speed(tmp_path):
    """A rate a logger's note states was typed, not measured: record 106 (12 kHz, 1772 rpm) under a note of 48 kHz
    with its true speed given. The note names the speed as the first suspect and the rate the series implies at
    that speed, the true one."""
    from bearingtwin.data.cwru import load_cwru

    signal = load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat", channel="DE", fs=12000.0).signal[:120000]
    (tmp_path / "r106.csv").write_text("Sample rate: 48000 Hz\n\nacc (g)\n" + "".join(f"{a:.6f}\n" for a in signal))
    prepared = read_record(tmp_path / "r106.csv", envelope_pipeline(), rpm=1772.0)
    assert prepared.rate_check == "contradicted"
    (note,) = [note for note in prepared.notes if note.startswith("the speed contradicts the record")]
    said = float(re.search(r"or the rate the file states is wrong: at 1772 rpm that series puts it at (\d+) Hz",
                           note).group(1))
    assert said == pytest.approx(12000.0, rel=0.01), note


@needs_cwru
def test_a_speed_a_whole_factor_too_high_for_a_rate_the_file_states_is_named_without_a_misplaced_series(tmp_path):
    """Given twice its speed, record 106's shaft series still stands where that speed puts it (its even harmonics),
    and the lines between them with the defect lines refuse the speed: the note says the series stands where it
    belongs and why the speed is refused, not that it stands elsewhere (it offered the stated speed as its reading)."""
    from bearingtwin.data.cwru import load_cwru

    signal = load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat", channel="DE", fs=12000.0).signal[:60000]
    t = np.arange(signal.size) / 12000.0
    (tmp_path / "r106.csv").write_text("time_s,acc_g\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, signal)))
    prepared = read_record(tmp_path / "r106.csv", envelope_pipeline(), rpm=2 * 1772.0)
    assert prepared.rate_check == "contradicted"
    (note,) = [note for note in prepared.notes if note.startswith("the speed contradicts the record")]
    assert "at 3544 rpm the shaft series stands where it belongs (59.07 Hz)" in note, note
    assert "between its harmonics" in note and "check the speed given" in note and "would put it at" not in note


@pytest.mark.parametrize("stated_rpm, order_step, seconds, verdict, words", [
    (1800.0, 1.0, 10.0, "consistent", None),
    (900.0, 1.0, 10.0, "contradicted", "at fs = 12000 Hz the shaft line says 1794 rpm"),
    (1800.0, 0.5, 10.0, "ambiguous", "sampling rate unconfirmed"),  # half orders too: the rate may be twice
    (1800.0, 1.0, 0.05, "not checked", "sampling rate not checked"),
])
def test_the_rate_check_of_a_stated_speed_and_rate_reports_its_verdict(stated_rpm, order_step, seconds, verdict, words):
    """A shaft series at 1800 rpm (harmonics 1/k, 12 kHz) read at a stated speed: the line where it belongs, at half
    the speed (a wrong rpm), with half orders between (a rate it cannot confirm), or in too short a record."""
    from bearingtwin.diagnosis.record import _checked_rate

    t = np.arange(int(seconds * 12000.0)) / 12000.0
    x = sum(np.sin(2 * np.pi * k * order_step * 30.0 * t + k) / k for k in range(1, 14))
    x = x + 0.3 * np.random.default_rng(0).standard_normal(t.size)
    recording = Recording(x, 12000.0, stated_rpm, "normal", source="synthetic.npy")
    kept, notes, found = _checked_rate(recording, bearing_config("cwru_6205"), channels={"a": x})
    assert found == verdict and kept.fs == 12000.0  # a stated rate is kept whatever the check says
    assert (notes == []) if words is None else any(words in note for note in notes), notes


def test_a_record_in_a_subfolder_is_known_by_the_path_a_training_table_names_it_by(tmp_path):
    """data.calibration.records may name a record in a subfolder by its path from the table (rig_a/healthy_a):
    diagnose must know it as a calibration record, not score it as a test of the model."""
    from bearingtwin.diagnosis.run import _names_of

    (tmp_path / "rig_a").mkdir()
    record = tmp_path / "rig_a" / "healthy_a.npy"
    table = tmp_path / "labels.csv"
    assert _names_of(record, table) == {"healthy_a", "healthy_a.npy", "rig_a/healthy_a", "rig_a/healthy_a.npy"}
    assert _names_of(record, None) == {"healthy_a", "healthy_a.npy"}
    assert _names_of(tmp_path / "elsewhere.npy", tmp_path / "rig_a" / "labels.csv") == {"elsewhere", "elsewhere.npy"}


def test_the_closing_summary_names_records_read_below_the_models_rate():
    """An upsampled record has nothing where the model reads above its own Nyquist frequency: its verdict is in
    doubt, and the summary says which records those are, as it names a contradicted rate."""
    from bearingtwin.cli.diagnose import diagnosis_lines
    from bearingtwin.diagnosis.run import DiagnosisRun

    rows = [{"record": "logger_5k", "verdict": "ball", "fs": 12000.0, "original_fs": 5000.0},
            {"record": "cwru_48k", "verdict": "inner", "fs": 12000.0, "original_fs": 48000.0},
            {"record": "cwru_12k", "verdict": "inner", "fs": 12000.0, "original_fs": 12000.0}]
    lines = diagnosis_lines(DiagnosisRun(rows=rows))
    assert lines["recorded below the model's rate (no content above their Nyquist)"] == "logger_5k"
    assert "recorded below the model's rate (no content above their Nyquist)" not in diagnosis_lines(
        DiagnosisRun(rows=rows[1:]))


def test_the_closing_summary_names_what_else_puts_a_verdict_in_doubt():
    """A rate the shaft line left unconfirmed, windows left out over dropouts, no physics evidence, a speed steadied
    or left unsteady: each per-record note's caveat is named in the summary too, where a fleet's reader looks."""
    from bearingtwin.cli.diagnose import diagnosis_lines
    from bearingtwin.diagnosis.run import DiagnosisRun

    rows = [{"record": "clean", "verdict": "outer", "rate_check": "consistent", "windows_left_out": 0},
            {"record": "lone_line", "verdict": "outer", "rate_check": "ambiguous"},
            {"record": "gaps", "verdict": "inner", "windows_left_out": 3},
            {"record": "no_speed", "verdict": "ball", "no_evidence": True},
            {"record": "H_VS_0_40_0Hz", "verdict": "normal", "no_evidence": True, "speed_varies": True},
            {"record": "fan", "verdict": "inner", "order_tracked": True},
            {"record": "run_up", "verdict": "normal", "order_tracked": True, "speed_in_doubt": True},
            {"record": "belt", "verdict": "outer", "speed_in_doubt": True, "steadying_refused": True}]
    lines = diagnosis_lines(DiagnosisRun(rows=rows))
    assert lines["sampling rate unconfirmed by the shaft line (see their notes)"] == "lone_line"
    assert lines["windows left out over dropouts or samples with no value"] == "gaps (3)"
    assert lines["no physics evidence (no shaft speed or bearing known)"] == "no_speed"
    assert lines["no physics evidence (variable-speed runs: no one speed to read their lines at)"] == "H_VS_0_40_0Hz"
    assert lines["shaft speed varied: resampled to a steady speed (order tracking)"] == "fan, run_up"
    assert lines["shaft speed varies, left unsteady (its lines smeared: in doubt)"] == "run_up"
    assert lines["speed read in doubt (steadied, the shaft's series stood no sharper: read as recorded)"] == "belt"
    assert not any("clean" in value for value in lines.values() if value != "records diagnosed")


def test_the_closing_summary_names_records_read_in_an_assumed_unit_or_at_an_unseen_level_and_scores_by_state_and_size():
    """Beside a wrong rate and a disagreement with the physics, what else puts a verdict in doubt is named: a unit
    assumed (the file states none) and a level a decade from the training windows'. Records are scored by state, then
    by the defect size their names give: sized and unsized records of one state are apart, never mixed with
    another state's."""
    from bearingtwin.cli.diagnose import diagnosis_lines
    from bearingtwin.diagnosis.run import DiagnosisRun

    def row(record, state, unit_check="as stated", level_unseen=False, **size):
        return {"record": record, "verdict": state, "true_state": state, "correct": True, "physics_correct": True,
                "unit_check": unit_check, "level_unseen": level_unseen, "bearing": "cwru_6205", "windows": 10,
                "windows_right": 9, "classifier_windows_right": 4, **size}

    rows = [row("wav", "inner", unit_check="assumed"), row("mg_gain", "inner", level_unseen=True),
            row("or_a", "outer"), row("or_b", "outer"), row("ir007", "inner", fault_size_in=0.007),
            row("healthy", "normal", unit_check="converted")]
    lines = diagnosis_lines(DiagnosisRun(rows=rows))
    assert lines["unit assumed (the file states none known here: read in the model's)"] == "wav"
    assert lines["level a decade or more outside the model's training windows"] == "mg_gain"
    assert lines["records right by state and fault size (model, physics)"] == (
        "normal 1/1, 1/1; inner 0.007 in 1/1, 1/1; inner, size unknown 2/2, 2/2; outer 2/2, 2/2")
    # Windows too, over the same groups; where the envelope spectrum decided some, the classifier's own beside them.
    assert lines["windows right by state and fault size (model)"] == (
        "normal 90.00 % of 10; inner 0.007 in 90.00 % of 10; inner, size unknown 90.00 % of 20; outer 90.00 % of 20")
    scores = {"accuracy_records": 1.0, "n_scored": 6, "accuracy_windows": 0.9, "share_windows_physics_decided": 0.5,
              "accuracy_windows_classifier": 0.4}
    lines = diagnosis_lines(DiagnosisRun(rows=rows, scores=scores))
    assert lines["windows right"] == "90.00 % (the envelope spectrum decided 50.00 % of them; the classifier alone: 40.00 %)"
    assert lines["windows right by state and fault size (model, classifier alone)"].startswith(
        "normal 90.00 % of 10, classifier alone 40.00 %; inner 0.007 in 90.00 % of 10, classifier alone 40.00 %;")
    # A HUST name's damage groups as a size does; an outer race's position apart; a record of no known state named.
    rows = [row("h", "normal", severity="none"), row("o_m", "outer", severity="medium"),
            row("o_s", "outer", severity="severe"), row("or6", "outer", fault_size_in=0.021, position="6"),
            row("or12", "outer", fault_size_in=0.021, position="12"), row("or3", "outer", fault_size_in=0.021, position="3"),
            {"record": "c", "verdict": "inner"}]
    lines = diagnosis_lines(DiagnosisRun(rows=rows, scores={"accuracy_records": 1.0, "n_scored": 5,
                                                            "accuracy_windows": 1.0}))
    assert lines["records right by state and fault size (model, physics)"] == (
        "normal 1/1, 1/1; outer 0.021 in @3 1/1, 1/1; outer 0.021 in @6 1/1, 1/1; outer 0.021 in @12 1/1, 1/1; "
        "outer medium 1/1, 1/1; outer severe 1/1, 1/1")
    assert lines["not scored (no state known, or one the model cannot answer: see their notes)"] == "c"
    rows[1]["named_state"] = "inner"
    assert diagnosis_lines(DiagnosisRun(rows=rows))[
        "labelled otherwise than their names say (scored by the label: check it)"] == "o_m (outer, named inner)"
    # Every record scored one the model was trained on: said to be no test of it (the score had stood alone).
    trained = [{**row("a", "outer"), "seen": {"trained": True}}, {**row("b", "normal"), "seen": {"trained": True}}]
    scores = {"accuracy_records": 1.0, "n_scored": 2, "accuracy_windows": 1.0}
    assert diagnosis_lines(DiagnosisRun(rows=trained, scores=scores))["records right"] == (
        "100.00 % of 2 with a known state; none the model was not trained on: no test of the model")
    assert diagnosis_lines(DiagnosisRun(rows=rows, scores=scores))["records right"] == "100.00 % of 2 with a known state"


def test_a_simulated_record_without_noise_is_said_to_have_no_floor(tmp_path):
    """A healthy twin record without a noise effect has lines at the ball-pass rate (the balls through the load
    zone) over a floor of rounding errors: read as a measurement, they stand out as an outer-race fault would. The
    record's own list of effects says no noise was added, and the diagnosis says what that does; with noise, not."""
    notes, evidence = {}, {}
    for effects in ("[]", "[noise]"):
        path = tmp_path / f"healthy_{effects.strip('[]') or 'clean'}.npz"
        done = run_module("bearingtwin.cli.simulate", "fault=normal", "bearing=cwru_6205", f"simulator.rpm={RPM:g}",
                          f"simulator.fs={FS:g}", "simulator.duration=3", f"effects={effects}", f"out={path}",
                          cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        prepared = read_record(path, envelope_pipeline())
        notes[effects] = prepared.notes
        evidence[effects] = physics_evidence(prepared.recording.signal, FS, RPM, BEARING).evidence_state
    assert NOISE_FREE_SIMULATION in notes["[]"] and NOISE_FREE_SIMULATION not in notes["[noise]"]
    assert evidence == {"[]": "outer", "[noise]": "normal"}  # what the note warns of
    # A simulation's own note travels with its record into the diagnosis (a fault it says no loaded ball met).
    slow = tmp_path / "slow.npz"
    done = run_module("bearingtwin.cli.simulate", "fault=inner", "bearing=cwru_6205", "simulator.rpm=60",
                      f"simulator.fs={FS:g}", "simulator.duration=0.4", "effects=[noise]", f"out={slow}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert any(note.startswith("the simulation noted: no ball passes the inner-race defect")
               for note in read_record(slow, envelope_pipeline()).notes)


def test_a_signal_a_library_swallowed_stops_the_folder_before_its_next_record(registered, tmp_path, monkeypatch):
    """An interrupt whose exception a library dropped (one came while the model loaded: the whole folder had been
    diagnosed and the run FINISHED before the command stopped) is acted on before the next record: none is
    diagnosed, and summary.csv lists each as not reached."""
    import signal

    from bearingtwin.diagnosis.run import diagnose_paths
    from bearingtwin.tracking import lifecycle

    _, uri = registered
    folder = outer_race_folder(tmp_path, 3)
    cfg = compose_config("diagnose", [f"path={folder}", "model=models:/diag/1", f"out={tmp_path / 'out'}",
                                      "figures=false", "tracking.enabled=false", f"tracking.uri={uri}"])
    monkeypatch.setattr(lifecycle, "_received", [signal.SIGINT])  # as the handler leaves it when the raise was lost
    with pytest.raises(lifecycle.Interrupted):
        diagnose_paths(cfg)
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    assert [row["error"] for row in rows] == [NOT_REACHED] * 3
    assert not list((tmp_path / "out").glob("*/diagnosis.json"))


def test_a_requests_unit_is_held_against_the_models_as_a_records_is():
    """A model trained in a unit that is no acceleration (V: a rig's records in volts) reads a request in V as it is
    and refuses one in g naming its own unit (a request's unit had been checked as an acceleration's alone: a V model
    refused its own unit, and blamed the user's g for a unit the user never sent); a model normalizing its windows
    reads any acceleration unit as it is."""
    from bearingtwin.diagnosis.mlflow_model import in_model_terms

    windows = np.ones((2, 8))
    in_volts = DiagnosisPipeline(None, None, 8, 12000.0, unit="V")  # an extractor that reads the level (not envelope)
    assert in_model_terms(in_volts, windows, 12000.0, "V") is windows
    with pytest.raises(BearingTwinError, match=r"^params unit 'g': the record is in g, the model was trained on windows "
                                               r"in V .*give the record in V"):
        in_model_terms(in_volts, windows, None, "g")
    in_g = dataclasses.replace(in_volts, unit="g")
    np.testing.assert_allclose(in_model_terms(in_g, windows, None, "m/s^2"), windows / 9.80665)
    normalized = dataclasses.replace(in_g, window_normalization="zscore")
    assert in_model_terms(normalized, windows, None, "mg") is windows
    # A unit no reader knows is refused, unless it is the model's own: its records all stated it.
    in_counts = dataclasses.replace(in_volts, unit="counts")
    assert in_model_terms(in_counts, windows, None, "counts") is windows
    with pytest.raises(BearingTwinError, match=r"^params unit 'furlongs': the record is in furlongs, .*give the record "
                                               r"in counts"):
        in_model_terms(in_counts, windows, None, "furlongs")


@needs_cwru
def test_a_record_whose_speed_drifts_is_order_tracked_before_it_is_read(registered, tmp_path):
    """A CWRU outer-race record re-timed so that its shaft swings by +-4 % once over it (a fan under a changing load):
    its defect lines smear into their floor. The diagnosis reads the drift from the shaft series, resamples the record
    to a steady speed and the physics evidence finds the outer race again; with order_tracking.enabled=false the
    record is read as recorded and said to be in doubt. The steady record beside it is left as it was."""
    from scipy.interpolate import CubicSpline


    base, uri = registered
    recording = load_recording(CWRU / "12k_Drive_End_OR007@6_1_131.mat")
    folder = tmp_path / "fan"
    folder.mkdir()
    t = np.arange(recording.signal.size - 2000) / recording.fs  # the re-timed record reads ahead by up to 0.04 s
    ratio = 1 + 0.04 * np.sin(2 * np.pi * t / t[-1])
    recorded_at = np.concatenate([[0.0], np.cumsum((ratio[1:] + ratio[:-1]) / 2) / recording.fs])
    drifting = CubicSpline(np.arange(recording.signal.size) / recording.fs, recording.signal)(recorded_at)
    for name, signal in (("drifting", drifting), ("steady", recording.signal)):
        np.savez(folder / f"{name}.npz", signal=signal, fs=recording.fs, rpm=recording.rpm, unit="g", fault="outer")
    results = {}
    for option in ("true", "false"):
        done = run("diagnose", f"path={folder}", "model=models:/diag@champion", f"out={tmp_path}/{option}",
                   f"order_tracking.enabled={option}", "figures=false", cwd=tmp_path, uri=uri)
        assert done.returncode == 0, done.stderr[-3000:]
        results[option] = ({name: json.loads((tmp_path / option / name / "diagnosis.json").read_text())
                            for name in ("drifting", "steady")}, done.stdout)
    (tracked, steady), stdout = (results["true"][0]["drifting"], results["true"][0]["steady"]), results["true"][1]
    assert tracked["speed"]["tracked"] and tracked["speed"]["spread"] == pytest.approx(0.08, abs=0.02)
    assert not tracked["speed"]["in_doubt"] and tracked["speed"]["steady_rpm"] == pytest.approx(recording.rpm, rel=0.01)
    assert any("resampled at equal steps of shaft angle to a steady" in note for note in tracked["notes"])
    assert tracked["evidence_state"] == "outer"
    assert "shaft speed varied: resampled to a steady speed (order tracking): drifting" in stdout
    assert not steady["speed"]["tracked"] and steady["speed"]["spread"] < 0.01
    as_recorded, stdout = results["false"][0]["drifting"], results["false"][1]
    assert not as_recorded["speed"]["tracked"] and as_recorded["speed"]["in_doubt"]
    smeared = as_recorded["evidence"]["prominence_db"]["outer"]
    assert smeared < tracked["evidence"]["prominence_db"]["outer"] - 10, (smeared, tracked["evidence"])
    assert "shaft speed varies, left unsteady (its lines smeared: in doubt): drifting" in stdout
    rows = {row["record"]: row for row in csv.DictReader(open(tmp_path / "true" / "summary.csv"))}
    assert rows["drifting"]["order_tracked"] == "True" and rows["steady"]["order_tracked"] == "False"
    assert float(rows["drifting"]["speed_spread"]) == pytest.approx(tracked["speed"]["spread"])


def test_a_gap_is_followed_to_where_order_tracking_moves_it(monkeypatch):
    """A record both unsteady and gapped: the gap's samples, re-timed by the tracking, are the ones left out."""
    from test_speed import FS as SPEED_FS
    from test_speed import RPM as SPEED_RPM
    from test_speed import machine

    import bearingtwin.diagnosis.record as record
    from bearingtwin.diagnosis.record import steadied

    # The marker's block of 100s outweighs the shaft's lines in the whole record's spectrum, which the tracking's
    # sharpness check reads: the check is another test's, the gap's place this one's.
    monkeypatch.setattr(record, "sharpening", lambda before, after: 10.0)

    signal, _ = machine(drift=0.04)
    start, length = int(5.0 * SPEED_FS), int(0.02 * SPEED_FS)
    signal[start:start + length] = 100.0  # marks the gap's samples (bridged ones are never read)
    recording = Recording(signal, SPEED_FS, rpm=SPEED_RPM, source="gapped")
    tracked, notes, speed, ((first, count),) = steadied(recording, True, 0.02, gaps=[(start, length)])
    assert speed["tracked"] and first != start  # moved: the shaft ran fast before 5 s
    marked = np.flatnonzero(tracked.signal > 50)
    assert marked.min() >= first - 2 and marked.max() <= first + count + 2 and marked.size >= 0.9 * length


def test_a_dropout_is_followed_to_where_order_tracking_moves_it(tmp_path, monkeypatch):
    """A record both unsteady and holding a dropout: tracked, the stretch holds one value no longer, so it is found
    as the file holds it and its windows left out where the tracking moved it."""
    from test_speed import FS as SPEED_FS
    from test_speed import RPM as SPEED_RPM
    from test_speed import machine

    import bearingtwin.diagnosis.record as record

    monkeypatch.setattr(record, "sharpening", lambda before, after: 10.0)  # as for a gap, above: this test's is the place
    signal, _ = machine(drift=0.04)
    start, length = int(5.0 * SPEED_FS), int(0.5 * SPEED_FS)
    signal[start:start + length] = signal[start]  # a logger holding its last value for half a second
    np.savez(tmp_path / "unsteady.npz", signal=signal, fs=SPEED_FS, rpm=SPEED_RPM, unit="g")
    pipeline = envelope_pipeline()
    prepared = read_record(tmp_path / "unsteady.npz", pipeline)
    assert prepared.speed["tracked"] and not held_stretches(prepared.recording.signal, pipeline.window_length)
    ((first_s, last_s, words),) = prepared.dropouts_s
    assert words.startswith("samples from 5 s to 5.5 s are all ") and first_s != pytest.approx(5.0, abs=0.01)  # moved
    windows, starts, notes, left_out = diagnosed_windows(prepared, pipeline.window_length)
    assert left_out >= 3 and any(note.startswith(words) for note in notes), notes
    assert not np.any((starts < last_s * FS) & (starts + pipeline.window_length > first_s * FS))


@needs_cwru
def test_a_stated_speed_a_few_percent_off_is_named_with_the_speed_the_shaft_series_reads(tmp_path):
    """A nameplate's speed given for a measured one puts every defect line beside where it stands: the shaft's own
    harmonic series names the speed it turns at. The true speed draws no such note."""

    recording = load_recording(CWRU / "12k_Drive_End_OR007@6_1_131.mat")  # 1772 rpm
    pipeline = envelope_pipeline()
    notes = {}
    for factor in (1.0, 1.03):
        path = tmp_path / f"pump_{factor}.npz"
        np.savez(path, signal=recording.signal, fs=recording.fs, rpm=recording.rpm * factor, unit="g")
        prepared = read_record(path, pipeline)
        notes[factor] = [note for note in prepared.notes if "harmonic series reads" in note]
        assert prepared.speed.get("off", False) == (factor != 1.0)
    assert notes[1.0] == []
    (note,) = notes[1.03]
    read = float(re.search(r"reads (\d+) rpm", note).group(1))
    assert read == pytest.approx(recording.rpm, rel=0.003)
    assert note.endswith(f"give rpm={read:.0f}")
    assert f"from the stated {recording.rpm * 1.03:g} rpm" in note and re.search(r", -[23]\.\d % from", note)
    # The remedy works although the file states its own speed: the shaft's series bears the given speed out, and the
    # record is read at it, said so; a speed the series does not bear out stays refused, naming what it reads.
    followed = read_record(tmp_path / "pump_1.03.npz", pipeline, rpm=read)
    assert followed.recording.rpm == read and not followed.speed.get("off", False)
    assert (f"rpm={read:g} given against the file's {recording.rpm * 1.03:g} rpm: the shaft's harmonic series reads "
            f"{read:.0f} rpm, so the given speed is read") in followed.notes
    with pytest.raises(BearingTwinError, match=rf"rpm=1700.0 contradicts the file's rpm={recording.rpm * 1.03!r} \(more "
                                               rf"than 1% apart\); the shaft's harmonic series reads {read:.0f} rpm$"):
        read_record(tmp_path / "pump_1.03.npz", pipeline, rpm=1700)
    for factor in (0.5, 3.0):  # half or three times the true speed: some harmonics stand where it puts them, refused
        with pytest.raises(BearingTwinError, match=rf"the shaft's harmonic series reads {read:.0f} rpm$"):
            read_record(tmp_path / "pump_1.03.npz", pipeline, rpm=read * factor)
    # Twice or half a file's right speed: every other harmonic stands where the given speed's would, but the file's
    # own speed is borne out as well: refused.
    np.savez(tmp_path / "right.npz", signal=recording.signal, fs=recording.fs, rpm=recording.rpm, unit="g")
    for factor in (2.0, 0.5):
        with pytest.raises(BearingTwinError, match=rf"contradicts the file's rpm={recording.rpm!r}"):
            read_record(tmp_path / "right.npz", pipeline, rpm=recording.rpm * factor)
    np.savez(tmp_path / "pump.npz", signal=recording.signal, fs=recording.fs, unit="g")
    given = read_record(tmp_path / "pump.npz", pipeline, rpm=round(recording.rpm * 1.03))
    assert any(note.endswith(f"give rpm={read:.0f}") for note in given.notes), given.notes


@needs_cwru
def test_a_stated_speed_a_tachometer_contradicts_is_named_with_the_speed_it_reads_near_the_supplys_lines_too(tmp_path):
    """Record 130 turns at 1797 rpm, within 0.2 % of 1800 rpm, whose shaft rate is half the 60 Hz supply's: a shaft
    series read there may be the supply's, and no speed is offered from it. A tachometer's pulses measure the shaft
    itself: stated at 1750 rpm, the record had been read there without a word, its verdict ball."""

    recording = load_recording(CWRU / "12k_Drive_End_OR007@6_0_130.mat")
    t = np.arange(recording.signal.size) / recording.fs
    pulses = 5.0 * ((t * 1797.0 / 60.0) % 1 < 0.1)
    np.savez(tmp_path / "pump.npz", vib=recording.signal, tach=pulses, fs=recording.fs, rpm=1750.0, unit="g")
    prepared = read_record(tmp_path / "pump.npz", envelope_pipeline(), channel="vib")
    assert prepared.speed["source"] == "the tachometer channel tach" and prepared.speed["off"]
    assert ("the tachometer channel tach reads 1797 rpm, +2.7 % from the stated 1750 rpm: every defect line is read "
            "where the stated speed puts it; if the sampling rate is right, give rpm=1797") in prepared.notes
    # The file states its speed; the way out the note names works, the tachometer bearing the given speed out.
    followed = read_record(tmp_path / "pump.npz", envelope_pipeline(), channel="vib", rpm=1797)
    assert followed.recording.rpm == 1797 and not followed.speed.get("off", False)
    assert ("rpm=1797 given against the file's 1750 rpm: the tachometer channel tach reads 1797 rpm, so the given "
            "speed is read") in followed.notes


@needs_cwru
def test_a_record_that_states_no_speed_is_read_at_the_one_its_tachometer_gives_or_refused_naming_the_choices(tmp_path):
    """A file of an accelerometer and a tachometer's pulses, no speed stated: a model that reads shaft orders had
    refused it, asking for the speed the pulses hold. One mark a turn, which the shaft series confirms, is read and
    said; two marks a turn leave two speeds the series cannot tell apart, named in the refusal."""
    recording = load_recording(CWRU / "12k_Drive_End_IR007_1_106.mat")
    t = np.arange(recording.signal.size) / recording.fs
    for marks in (1, 2):
        np.savez(tmp_path / f"marks{marks}.npz", vib=recording.signal, fs=recording.fs, unit="g",
                 tach=5.0 * ((t * marks * recording.rpm / 60.0) % 1 < 0.1))
    prepared = read_record(tmp_path / "marks1.npz", envelope_pipeline())
    assert prepared.recording.rpm == pytest.approx(recording.rpm, rel=1e-3)
    assert prepared.notes[0] == ("shaft speed 1772 rpm from the tachometer channel tach: 1 pulse per revolution, the "
                                 "one count at which the record's shaft series stands clearly highest (8 of its first 8 "
                                 "harmonics standing)")
    assert prepared.rate_check == "consistent" and prepared.speed["source"] == "the tachometer channel tach"
    with pytest.raises(BearingTwinError, match=r"marks2.npz: the file does not state the shaft speed \(its tachometer "
                                               r"channel tach pulses 59.07 times a second: 3544 rpm at 1 pulse per "
                                               r"revolution or 1772 rpm at 2 pulses per revolution, which the record's "
                                               r"shaft series does not tell apart\) and this model needs it; give rpm="):
        read_record(tmp_path / "marks2.npz", envelope_pipeline())
    assert read_record(tmp_path / "marks2.npz", envelope_pipeline(), rpm=1772).recording.rpm == 1772


def test_a_steady_record_is_not_warped_by_a_misread_profile(monkeypatch):
    """Two shafts' series (a belt drive), segments reading the supply, a swing faster than the segments resolve: each
    can make the speed read flip between values on a steady record. Steadied to such a profile, the shaft's own series
    stands no sharper, and the record is read as recorded, its verdict in doubt, no speed offered in the stated one's
    place."""
    import bearingtwin.diagnosis.record as record
    from bearingtwin.signal.speed import SpeedProfile
    from test_speed import FS as SPEED_FS
    from test_speed import RPM as SPEED_RPM
    from test_speed import machine

    signal, _ = machine(drift=0.0)
    recording = Recording(signal, SPEED_FS, rpm=SPEED_RPM, source="belt")
    times = np.arange(0.5, 8.0, 0.5)
    flipping = SpeedProfile(times, SPEED_RPM * np.where(np.arange(times.size) % 4 < 2, 1.0, 0.97), 1.0, SPEED_RPM)
    monkeypatch.setattr(record, "speed_profile", lambda *args, **kwargs: flipping)
    steady, notes, speed, _ = record.steadied(recording, True, 0.02)
    assert steady is recording and not speed["tracked"] and speed["in_doubt"] and speed["sharpening"] < 1
    assert "shows the shaft's series no sharper" in notes[0] and "read as recorded" in notes[0]
    assert record.speed_off_note(speed, SPEED_RPM) is None


def test_a_tachometer_in_the_file_steadies_a_record_whose_shaft_series_does_not_show(tmp_path):
    """A record of a defect's impacts alone (no shaft series to read the speed from) drifting by +-4 %, with a
    tachometer channel beside it: the diagnosis reads the speed from the pulses, tracks the record, and its
    outer-race lines stand again; without the tachometer the record is read as recorded, nothing said."""
    from test_speed import FS as SPEED_FS
    from test_speed import RPM as SPEED_RPM
    from test_speed import machine, tachometer

    signal, _ = machine(drift=0.04, shaft_lines=False)
    pipeline = envelope_pipeline()
    evidence = {}
    for name, channels in (("with", {"vib": signal, "tach": tachometer(0.04)}), ("without", {"vib": signal})):
        path = tmp_path / f"{name}.npz"
        np.savez(path, **channels, fs=SPEED_FS, rpm=SPEED_RPM, unit="g")
        prepared = read_record(path, pipeline, channel="vib")
        evidence[name] = physics_evidence(prepared.recording.signal, prepared.recording.fs, prepared.recording.rpm,
                                          BEARING).prominence_db["outer"]
        if name == "with":
            assert prepared.speed["tracked"] and prepared.speed["source"] == "the tachometer channel tach"
            assert any("1-s segments of the tachometer channel tach: resampled" in note for note in prepared.notes)
        else:
            assert not prepared.speed["tracked"] and prepared.speed["spread"] is None
    assert evidence["with"] > evidence["without"] + 6, evidence


def test_a_gap_at_the_very_end_survives_two_tracking_passes():
    """A gap widened past the tracked record's last sample had been indexed beyond it on the second pass."""
    from test_speed import FS as SPEED_FS
    from test_speed import RPM as SPEED_RPM
    from test_speed import machine

    from bearingtwin.diagnosis.record import steadied

    signal, _ = machine(drift=0.08)
    recording = Recording(signal, SPEED_FS, rpm=SPEED_RPM, source="end")
    tracked, _, speed, ((start, length),) = steadied(recording, True, 0.001, gaps=[(signal.size - 5, 5)])
    assert speed["tracked"] and start + length <= tracked.signal.size and length >= 5


def test_a_diagnosis_the_disk_cannot_take_fails_its_record_in_one_line_and_leaves_no_part(tmp_path, monkeypatch):
    """A full disk under out=: each record's failure had been a page of traceback (600 lines over a folder)."""
    import errno

    from bearingtwin.diagnosis import run as diagnosis_run

    def disk_full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(diagnosis_run, "plot_diagnosis", disk_full)
    with pytest.raises(BearingTwinError) as refused:
        diagnosis_run.write_outputs({"record": "r"}, None, list(FAULTS), tmp_path / "out" / "r", figures=True)
    assert str(refused.value) == (f"out={tmp_path / 'out'}: r's diagnosis cannot be written there (No space left on "
                                  "device)")
    assert not (tmp_path / "out" / "r").exists()
    monkeypatch.setattr("builtins.open", disk_full)
    with pytest.raises(BearingTwinError, match=r"summary.csv cannot be written there \(No space left on device\)$"):
        diagnosis_run.write_summary([{"record": "r"}], tmp_path / "out" / "summary.csv")
    with pytest.raises(BearingTwinError, match=r"summary.csv cannot be written there \(No space left on device\)$"):
        diagnosis_run.update_summary([{"record": "r"}], tmp_path / "out" / "summary.csv")


def test_a_one_file_row_takes_its_records_place_in_the_summary_and_a_failed_write_puts_the_earlier_back(
        tmp_path, monkeypatch):
    """update_summary: a record's row replaces its earlier row where it stood, a new record's is added last, the
    columns are the same whatever the rows hold (an error column with none in it), a cell of two lines is read back whole;
    a write the disk refuses leaves the earlier summary as it was."""
    import errno
    import io

    from bearingtwin.diagnosis import run as diagnosis_run

    path = tmp_path / "summary.csv"
    diagnosis_run.write_summary([{"record": "a", "verdict": "inner", "share": 1.0},
                                 {"record": "b", "error": "b.npz: not an npz"}], path)
    diagnosis_run.update_summary([{"record": "b", "verdict": "outer", "share": 0.75}], path)
    assert [(row["record"], row["verdict"], row["share"]) for row in csv.DictReader(open(path))] == [
        ("a", "inner", "1.0"), ("b", "outer", "0.75")]
    assert open(path).readline().rstrip("\n").split(",") == list(diagnosis_run.SUMMARY_FIELDS)  # every run's header
    diagnosis_run.update_summary([{"record": "c", "error": "c.csv: holds channels a, b\nchoose one"}], path)
    diagnosis_run.update_summary([{"record": "a", "verdict": "ball"}], path)  # a cell of two lines read back whole
    rows = list(csv.DictReader(open(path, newline="")))
    assert [(row["record"], row["verdict"], row["error"]) for row in rows] == [
        ("a", "ball", ""), ("b", "outer", ""), ("c", "", "c.csv: holds channels a, b\nchoose one")]
    before = path.read_bytes()
    real_open = open

    class FullDisk(io.TextIOWrapper):
        def write(self, text):
            if text != before.decode():  # the merged summary is refused; putting the earlier back is not
                raise OSError(errno.ENOSPC, "No space left on device")
            return super().write(text)

    def opened(file, mode="r", **kwargs):
        handle = real_open(file, mode, **kwargs)
        return FullDisk(handle.detach(), newline="") if "a" in mode else handle

    monkeypatch.setattr(diagnosis_run, "open", opened, raising=False)
    with pytest.raises(BearingTwinError, match=r"summary.csv cannot be written there \(No space left on device\)$"):
        diagnosis_run.update_summary([{"record": "d", "verdict": "normal"}], path)
    monkeypatch.undo()
    assert path.read_bytes() == before


def test_under_hydra_job_chdir_the_records_are_read_from_where_the_command_started(registered, tmp_path):
    """hydra.job.chdir=true starts the task in its run's folder: a relative path= had been looked for there and
    refused as no such file. Inputs are read from where the command started (as hydra.utils.to_absolute_path
    reads them); out= is what the run writes, in its run's folder."""
    _, uri = registered
    outer_race_folder(tmp_path, 2)
    done = run("diagnose", "path=recordings", "model=models:/diag/1", "hydra.job.chdir=true", "hydra.run.dir=runs/one",
               cwd=tmp_path, uri=uri)
    assert done.returncode == 0, done.stderr[-2000:]
    assert {path.parent.name for path in (tmp_path / "runs" / "one" / "diagnosis").glob("*/diagnosis.json")} == {
        "r00", "r01"}
    result = json.loads((tmp_path / "runs" / "one" / "diagnosis" / "r00" / "diagnosis.json").read_text())
    assert MlflowClient(uri).get_run(result["run_id"]).data.params["path"] == str(tmp_path / "recordings")


@needs_cwru
def test_a_cwru_record_saved_as_npy_or_csv_under_its_long_name_is_read_as_its_mat_is(tmp_path):
    """A CWRU record converted to .npy (or a headerless CSV) keeps its long name and loses what the .mat held beside
    its samples: the name's state, rate, load (its nominal speed) and bearing are read, as from a .mat of that name,
    where the file itself states none; the state is scored, a label may name another (as for a .mat); a number or a
    label alone says too little of an unknown file, and what the file states itself wins."""
    from scipy.io import loadmat

    samples = loadmat(CWRU / "12k_Drive_End_IR007_1_106.mat")["X106_DE_time"].ravel()
    pipeline = envelope_pipeline()
    as_mat = read_record(CWRU / "12k_Drive_End_IR007_1_106.mat", pipeline)
    np.save(tmp_path / "12k_Drive_End_IR007_1_106.npy", samples)
    np.savetxt(tmp_path / "12k_Drive_End_IR007_1_106.csv", samples[:, None])
    for suffix in (".npy", ".csv"):
        prepared = read_record(tmp_path / f"12k_Drive_End_IR007_1_106{suffix}", pipeline)
        assert (prepared.recording.fs, prepared.true_state, prepared.rate_check) == (12000.0, "inner", as_mat.rate_check)
        assert prepared.recording.rpm == 1772.0 and prepared.recording.meta["rpm_origin"] == "nominal"  # the .mat's: 1772
        assert prepared.recording.meta["bearing"] == "cwru_6205" and prepared.recording.meta["fault_size_in"] == 0.007
        assert ("read by its CWRU name: state inner, rate 12 kHz (declared, checked), unit g, the drive-end bearing "
                "(cwru_6205)" in prepared.notes), prepared.notes
    relabelled = read_record(tmp_path / "12k_Drive_End_IR007_1_106.npy", pipeline, true_state="outer")
    assert relabelled.true_state == "outer" and relabelled.named_state == "inner"
    assert "labelled outer where the file name says inner: scored as outer" in relabelled.notes
    # 48k_ names its rate; the fan end its bearing.
    np.save(tmp_path / "12k_Fan_End_B014_2_288.npy", samples)
    fan = load_recording(tmp_path / "12k_Fan_End_B014_2_288.npy")
    assert (fan.fault, fan.rpm, fan.meta["bearing"]) == ("ball", 1750.0, "cwru_6203")
    # What the file states wins over the name; a bare number or label names nothing of a file not the Data Center's.
    np.savez(tmp_path / "48k_Drive_End_OR007@6_0_135.npz", signal=samples, fs=12000.0, rpm=1772.0, fault="outer")
    stated = load_recording(tmp_path / "48k_Drive_End_OR007@6_0_135.npz")
    assert (stated.fs, stated.rpm, stated.fault) == (12000.0, 1772.0, "outer")
    for bare in ("106.npy", "IR007_1.npy"):
        np.save(tmp_path / bare, samples)
        with pytest.raises(BearingTwinError, match="does not state its sampling rate"):
            load_recording(tmp_path / bare)


def test_a_healthy_cwru_record_without_the_drive_end_channel_is_read_on_the_models_channel(tmp_path):
    """A healthy record records both bearings, so the model's channel stands in for a missing DE, said so; a fault
    record's own accelerometer has no stand-in (tests/test_cwru.py)."""
    import scipy.io

    from bearingtwin.diagnosis.record import _channel

    x = np.random.default_rng(1).standard_normal((12000, 1))
    scipy.io.savemat(tmp_path / "normal_0_97.mat", {"X097_FE_time": x, "X097_BA_time": x, "X097RPM": np.array([[1797.0]])})
    on_fe = dataclasses.replace(envelope_pipeline(), config={"data": {"channel": "FE"}})
    from bearingtwin.data.formats import read_raw

    assert _channel(read_raw(tmp_path / "normal_0_97.mat"), None, on_fe) == (
        "FE", ["channel FE, the one the model was trained on (channel=<name> reads another)"])


def test_a_folder_or_a_glob_passes_over_excels_lock_files(tmp_path):
    """Excel leaves ~$<name>.xls beside a workbook open in it: found by a folder or by *.xls, it had been read and
    refused as a binary workbook, as ._<name> files, which macOS leaves, never were."""
    from bearingtwin.diagnosis.run import find_records

    (tmp_path / "H_65Hz.xls").write_bytes((Path(__file__).parent / "fixtures" / "hust" / "H_65Hz.xls").read_bytes())
    (tmp_path / "~$H_65Hz.xls").write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(154))
    for path in (tmp_path, tmp_path / "*.xls"):
        assert [found.name for found in find_records(str(path), None)] == ["H_65Hz.xls"], path


def test_a_glob_with_two_stars_reaches_the_folder_itself_and_every_folder_below(tmp_path):
    """``records/**/*.npy`` had matched one folder down only, leaving the records beside it out without a word."""
    from bearingtwin.diagnosis.run import find_records

    for folder in (tmp_path, tmp_path / "sub", tmp_path / "sub" / "deeper"):
        folder.mkdir(exist_ok=True)
        np.save(folder / f"{folder.name}_record.npy", np.zeros(8))
    found = find_records(str(tmp_path / "**" / "*.npy"), None)
    assert sorted(path.relative_to(tmp_path).as_posix() for path in found) == sorted([
        f"{tmp_path.name}_record.npy", "sub/deeper/deeper_record.npy", "sub/sub_record.npy"])
