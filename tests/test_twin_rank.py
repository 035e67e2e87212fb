"""Hidden-effect identification: a 'measurement' is the twin with one effect switched on at
parameter values the ranking is not told (and another random realization, another defect depth,
a sensor in g); the ranking must put that effect first and adding it must halve the discrepancy."""

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.twin.calibrate import minimize, parse_space
from bearingtwin.twin.compare import Comparator, CompareSettings
from bearingtwin.twin.model import TwinModel, effect_defaults
from bearingtwin.twin.rank import EffectRanker

LIBRARY = ["resonance", "slip", "speed_fluctuation", "noise", "tones", "lubrication", "load_zone"]
HIDDEN = {  # none of these is the YAML default the calibration starts from
    "resonance": {"natural_frequency_hz": 2200.0, "damping_ratio": 0.08},
    "slip": {"jitter": 0.03},
    "speed_fluctuation": {"depth": 0.02, "frequency_hz": 5.0},
    "noise": {"snr_db": 5.0, "spectral_slope": 1.0},
    # The YAML's lines 6 dB up: calibration fits the levels; the frequencies are Tones.initial_guess's to find.
    "tones": {"frequencies_hz": [718.6, 838.6, 958.6], "levels_db": [-4.0, 0.0, -4.0], "level_offset_db": 0.0},
    "lubrication": {"stiffness_ratio": 0.5, "damping_ns_per_m": 3000.0},
    "load_zone": {"radial_load_n": 1500.0, "clearance_um": 15.0},
}
DEPTH = "simulator.defect.depth_mm"
FS, RPM, SECONDS = 12000.0, 1797.0, 1.0


def comparator_for(measured, cfg):
    return Comparator(measured, BearingGeometry.from_config(cfg.bearing), CompareSettings(envelope_segment_s=0.25))


@pytest.fixture(scope="module")
def cfg():
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("simulate", overrides=[f"simulator.fs={FS}", f"simulator.rpm={RPM}",
                                              f"simulator.duration={SECONDS}"])


def hidden_measurement(cfg, fault, effect):
    truth = TwinModel(fault, cfg.bearing, cfg.simulator, seed=7)
    signal_g = truth.signal({DEPTH: 0.004}, {effect: HIDDEN[effect]}) / 9.81
    return Recording(signal_g, FS, RPM, fault, source=f"hidden {effect}", unit="g")


def test_hidden_parameters_differ_from_the_calibration_start():
    for name, params in HIDDEN.items():
        defaults = effect_defaults(name)
        assert any(params[k] != defaults[k] for k in params), name


@pytest.mark.parametrize("effect", LIBRARY)
def test_ranking_names_the_hidden_effect_and_halves_the_discrepancy(cfg, effect):
    measured = hidden_measurement(cfg, "inner", effect)
    comparator = comparator_for(measured, cfg)
    twin = TwinModel("inner", cfg.bearing, cfg.simulator, seed=0)
    ranker = EffectRanker(LIBRARY, base_space={DEPTH: (0.0005, 0.02, True)}, n_trials_base=8, n_trials_effect=12,
                          n_trials_refine=12, max_effects=1, seed=0).fit(twin, comparator)
    fit = ranker.fit_
    assert [f.effect for f in fit.ranking][0] == effect, [(f.effect, round(f.error, 2)) for f in fit.ranking]
    assert list(fit.steps[1].effects) == [effect]
    assert fit.steps[1].error <= 0.5 * fit.steps[0].error
    assert f"`{effect}`" in fit.summary and "explains" in fit.summary
    assert sorted(f.effect for f in fit.ranking) == sorted(LIBRARY)


def test_nothing_is_added_when_the_twin_already_matches(cfg):
    measured = Recording(TwinModel("outer", cfg.bearing, cfg.simulator, seed=3).signal({DEPTH: 0.004}) * 0.5,
                         FS, RPM, "outer")
    comparator = comparator_for(measured, cfg)
    twin = TwinModel("outer", cfg.bearing, cfg.simulator, seed=0)
    fit = EffectRanker(["resonance", "noise"], base_space={DEPTH: (0.0005, 0.02, True)}, n_trials_base=10,
                       n_trials_effect=4, min_explained=0.3, seed=0).fit(twin, comparator).fit_
    assert fit.added == [] and len(fit.steps) == 1
    assert fit.baseline_error < 0.3  # the depth is recovered, and with it the measurement
    assert fit.summary.startswith("no candidate effect explains enough")


def test_calibration_is_deterministic_and_never_worse_than_its_start():
    def bowl(p):
        return (np.log10(p["a"]) - 0.3) ** 2 + (p["b"] - 2.0) ** 2

    space = parse_space({"a": [0.1, 100.0, "log"], "b": [0.0, 5.0]}, "calibration.test")
    first = minimize(bowl, space, n_trials=20, seed=4, start={"a": 1.0, "b": 1.0})
    again = minimize(bowl, space, n_trials=20, seed=4, start={"a": 1.0, "b": 1.0})
    assert first.params == again.params and first.trial_errors == again.trial_errors
    assert first.trial_errors[0] == pytest.approx(bowl({"a": 1.0, "b": 1.0}))
    assert first.error <= min(first.trial_errors) and first.error < 0.2


def test_bad_search_spaces_and_candidates_are_named(cfg):
    with pytest.raises(BearingTwinError, match="calibration.base.depth"):
        parse_space({"depth": [1.0, 0.5]}, "calibration.base")
    with pytest.raises(BearingTwinError, match="calibration.base.depth"):
        parse_space({"depth": [0.0, 1.0, "log"]}, "calibration.base")
    measured = hidden_measurement(cfg, "outer", "noise")
    comparator = comparator_for(measured, cfg)
    twin = TwinModel("outer", cfg.bearing, cfg.simulator, seed=0)
    with pytest.raises(BearingTwinError, match="unknown effect 'wobble'"):
        EffectRanker(["noise", "wobble"]).fit(twin, comparator)
    with pytest.raises(BearingTwinError, match="calibration.base.simulator.defect.deep"):
        EffectRanker(["noise"], base_space={"simulator.defect.deep": (0.1, 1.0, False)}, n_trials_base=1).fit(
            twin, comparator)


def test_same_seed_same_ranking(cfg):
    measured = hidden_measurement(cfg, "outer", "resonance")
    runs = []
    for _ in range(2):
        twin = TwinModel("outer", cfg.bearing, cfg.simulator, seed=0)
        ranker = EffectRanker(["resonance", "noise"], base_space={DEPTH: (0.0005, 0.02, True)}, n_trials_base=3,
                              n_trials_effect=4, n_trials_refine=3, seed=5)
        runs.append(ranker.fit(twin, comparator_for(measured, cfg)).fit_.as_dict())
    assert runs[0] == runs[1]
