"""What no calibration record determines is spanned: the twin's defect size and position, and the
cepstral pre-whitening that lets the twin's envelope lines be compared with another path's."""

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR, bearing_config
from bearingtwin.data.twin_to_real import simulator_settings
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import simulate
from bearingtwin.signal import cepstral_prewhiten, envelope_spectrum, peak_near

FS = 12000.0


def simulator_cfg(**changes):
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        cfg = compose("simulate", overrides=["bearing=cwru_6205"])
    simulator = dict(cfg.simulator)
    simulator.update(fs=FS, duration=1.0, rpm=1797.0, sensor="outer_y", **changes)
    return bearing_config("cwru_6205"), simulator


def test_the_grid_spans_every_combination_and_refuses_unknown_keys():
    _, simulator = simulator_cfg()
    settings = simulator_settings(simulator, {"defect.width_mm": [0.178, 0.533], "defect.outer_angle_deg": [None, 0.0, 90.0]})
    assert len(settings) == 6 and len({label for label, _ in settings}) == 6
    assert sorted({(s["defect"]["width_mm"], s["defect"]["outer_angle_deg"]) for _, s in settings}, key=str) == sorted(
        {(w, a) for w in (0.178, 0.533) for a in (None, 0.0, 90.0)}, key=str)
    assert simulator_settings(simulator, {}) == [("", simulator)]
    with pytest.raises(BearingTwinError, match="simulator.defect.size_mm is no simulator setting"):
        simulator_settings(simulator, {"defect.size_mm": [1.0]})
    with pytest.raises(BearingTwinError, match="non-empty list"):
        simulator_settings(simulator, {"defect.width_mm": []})


def outer_race_response(width_mm: float) -> tuple[float, float]:
    """RMS (m/s^2) and BPFO envelope line (m/s^2) of the twin's outer-race fault with a spall this wide."""
    bearing, simulator = simulator_cfg(load_y_n=-500.0)
    simulator["defect"] = {**simulator["defect"], "width_mm": width_mm}
    recording, _ = simulate("outer", bearing, simulator, {})
    freqs, amplitude = envelope_spectrum(recording.signal, FS)
    bpfo = BearingGeometry.from_config(bearing).bpfo_hz(1797.0)
    return float(recording.signal.std()), float(peak_near(freqs, amplitude, bpfo, 3.0)[1])


def test_a_0021_in_spall_strikes_harder_than_a_0007_in_one():
    """A ball cannot reach the bottom of a pit narrower than itself: it drops by its sagitta over the
    chord, ~0.5 um over 0.178 mm and ~9 um over 0.533 mm (6205 balls), so the wider spall's impacts,
    the vibration and the BPFO line of its envelope grow with the width (measured: ~20x)."""
    (rms_7, line_7), (rms_14, line_14), (rms_21, line_21) = (outer_race_response(w) for w in (0.178, 0.356, 0.533))
    assert rms_7 < rms_14 < rms_21 and rms_21 > 5 * rms_7
    assert line_7 < line_14 < line_21 and line_21 > 5 * line_7


def test_prewhitening_flattens_the_spectrum_and_keeps_the_impact_rate():
    rng = np.random.default_rng(0)
    t = np.arange(int(2 * FS)) / FS
    ring = np.exp(-600 * t[:300]) * np.sin(2 * np.pi * 3200 * t[:300])  # a resonance: the path's shape
    impacts = np.zeros(t.size)
    impacts[(np.arange(0, 2, 1 / 107.3) * FS).astype(int)] = 1.0
    signal = np.convolve(impacts, ring)[: t.size] + 0.01 * rng.standard_normal(t.size)
    whitened = cepstral_prewhiten(np.stack([signal, 1e3 * signal]))
    magnitude = np.abs(np.fft.rfft(whitened[0]))[1:-1]  # DC removed; Nyquist real
    assert np.allclose(magnitude, magnitude[0], rtol=1e-6)  # white: one magnitude everywhere
    np.testing.assert_allclose(whitened[0], whitened[1], atol=1e-9)  # whatever the gain or unit
    freqs, amplitude = envelope_spectrum(whitened[0], FS)
    peak_hz, _ = peak_near(freqs, amplitude, 107.3, 5.0)
    assert peak_hz == pytest.approx(107.3, abs=0.5)
    assert amplitude[np.argmin(np.abs(freqs - 107.3))] > 5 * np.median(amplitude[(freqs > 20) & (freqs < 1000)])


def test_the_sim2real_experiments_compose_their_protocols():
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        cfg = compose("train", overrides=["+experiment=sim2real_v1", "seed=3"])
        v2 = compose("train", overrides=["+experiment=sim2real_v2", "seed=3"])
    assert (cfg.data.source, cfg.bearing.name, cfg.features.name, cfg.classifier.name) == (
        "twin_to_real", "cwru_6205", "envelope_prominence", "svm")
    assert (cfg.classifier.kernel, cfg.features.prewhiten, cfg.data.calibration.step) == ("linear", "cepstral", 3)
    assert list(cfg.data.twin.randomize["defect.width_mm"]) == [0.178, 0.356, 0.533]
    assert list(cfg.data.twin.variants.spin_slip.jitter) == [0.01, 0.1, 0.4]
    assert list(cfg.data.test.loads) == [1, 2, 3] and (cfg.register, cfg.register_alias) == ("sim2real", "champion")
    assert cfg.simulator.seed == 3  # the seed is also the twin's
    # Version 2 is version 1 with longer windows, none overlapping, and the 0.028 in size added.
    assert (v2.data.window_length, v2.data.twin.windows_per_record, v2.data.test.windows_per_record) == (4096, 10, 25)
    assert v2.data.twin.windows_per_record * v2.data.window_length <= v2.data.twin.duration * v2.data.fs
    assert list(v2.data.twin.randomize["defect.width_mm"]) == [0.178, 0.356, 0.533, 0.711]
    changed = {"window_length", "twin", "test"}
    assert {k: v for k, v in v2.data.items() if k not in changed} == {k: v for k, v in cfg.data.items() if k not in changed}
    assert (v2.features, v2.classifier, v2.register) == (cfg.features, cfg.classifier, cfg.register)
