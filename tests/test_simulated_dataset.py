"""The simulated dataset: windows and labels from the twin, cached once per configuration."""

import numpy as np
import pytest
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.data import simulated
from bearingtwin.data.simulated import build_simulated_dataset, simulation_config
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.physics.simulator import simulate

BEARING = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
SIMULATOR = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")
DATA = OmegaConf.merge(OmegaConf.load(f"{CONF_DIR}/data/simulated.yaml"),
                       {"duration": 0.4, "samples_per_class": 6, "window_length": 512, "n_jobs": 1})


def test_paper_defaults():
    paper = OmegaConf.load(f"{CONF_DIR}/data/simulated.yaml")
    assert (paper.rpm, paper.fs, paper.duration, paper.samples_per_class, paper.window_length) == (
        1797, 10000, 30.0, 150, 2048)
    assert paper.split == "random" and paper.train_fraction == 0.7


def test_windows_labels_and_provenance(tmp_path):
    dataset = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)
    assert dataset.windows.shape == (4 * 6, 512)
    np.testing.assert_array_equal(dataset.labels, np.repeat(np.arange(4), 6))
    assert dataset.class_names == FAULTS and dataset.fs == 10000.0
    assert dataset.record_lengths == [4000] * 4
    # the ball-fault windows are slices of the simulator's ball record at the data config's operating point
    ball, _ = simulate("ball", BEARING, simulation_config(DATA, SIMULATOR))
    for window, start in zip(dataset.windows[dataset.labels == 2], dataset.starts[dataset.labels == 2]):
        np.testing.assert_array_equal(window, ball.signal[start:start + 512])
    assert dataset.starts[-1] + 512 == 4000  # windows reach the record's end


def test_second_build_reads_the_cache_and_configs_key_it(tmp_path, monkeypatch):
    first = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)
    files = list((tmp_path / "simulated").iterdir())
    assert len(files) == 1 and files[0].suffix == ".npz"  # no temporary file left behind

    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated although the cache holds these records")

    monkeypatch.setattr(simulated, "simulate_many", no_simulation)
    again = build_simulated_dataset(OmegaConf.merge(DATA, {"samples_per_class": 3, "n_jobs": 2}), BEARING,
                                    SIMULATOR, {}, tmp_path)
    np.testing.assert_array_equal(again.windows[again.labels == 3][0], first.windows[first.labels == 3][0])
    assert again.key != first.key  # same records, other windows
    with pytest.raises(AssertionError, match="simulated although"):
        build_simulated_dataset(DATA, OmegaConf.merge(BEARING, {"clearance_mm": 0.01}), SIMULATOR, {}, tmp_path)


def test_bad_data_config_names_the_field(tmp_path):
    with pytest.raises(BearingTwinError, match="data.window_length"):
        build_simulated_dataset(OmegaConf.merge(DATA, {"window_length": 0}), BEARING, SIMULATOR, {}, tmp_path)
    for name in ("window_length", "samples_per_class"):  # a YAML true is no count
        with pytest.raises(BearingTwinError, match=rf"^data\.{name} must be a positive integer, got True$"):
            build_simulated_dataset(OmegaConf.merge(DATA, {name: True}), BEARING, SIMULATOR, {}, tmp_path)
    with pytest.raises(BearingTwinError, match="data.source"):
        build_simulated_dataset(OmegaConf.merge(DATA, {"source": "cwru"}), BEARING, SIMULATOR, {}, tmp_path)
    # The operating point is named as the user set it (data.*), not as the simulator key it replaces.
    for name, value in (("duration", -1.0), ("fs", "abc"), ("rpm", True)):
        with pytest.raises(BearingTwinError, match=rf"^data\.{name}=.* must be a positive number"):
            build_simulated_dataset(OmegaConf.merge(DATA, {name: value}), BEARING, SIMULATOR, {}, tmp_path)
    assert not any(tmp_path.iterdir())  # refused before any simulation was cached


def test_records_simulated_before_oversample_existed_keep_their_cache_key():
    from omegaconf import OmegaConf

    from bearingtwin.config import CONF_DIR
    from bearingtwin.data.simulated import records_key

    data = {"rpm": 1797.0, "fs": 10000.0, "duration": 1.0}
    bearing = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml"))
    simulator = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml"))
    before = {name: value for name, value in simulator.items() if name != "oversample"}
    assert records_key(data, bearing, {**simulator, "oversample": None}, None) == records_key(data, bearing, before, None)
    assert records_key(data, bearing, {**simulator, "oversample": 1}, None) == records_key(data, bearing, before, None)
    assert records_key(data, bearing, {**simulator, "oversample": 4}, None) != records_key(data, bearing, before, None)


def test_a_whole_number_typed_with_a_decimal_point_is_the_same_record():
    """``data.duration=1`` and ``data.duration=1.0`` simulate the same samples: one cache entry, one key."""
    from bearingtwin.data.simulated import records_key

    bearing = OmegaConf.to_container(BEARING)
    simulator = OmegaConf.to_container(SIMULATOR)
    as_int, as_float = ({"rpm": 1797, "fs": 10000, "duration": whole} for whole in (1, 1.0))
    assert records_key(as_int, bearing, simulator, None) == records_key(as_float, bearing, simulator, None)
    assert records_key({**as_int, "duration": 1.5}, bearing, simulator, None) != records_key(as_int, bearing, simulator, None)
    assert records_key({**as_int, "rpm": 1797.5}, bearing, simulator, None) != records_key(as_int, bearing, simulator, None)


def test_effects_that_act_in_another_order_are_other_records():
    """A resonance filters a noise floor added before it, not one added after: the cache tells the two apart.
    Clipping acts last wherever it is listed, so its place in the list does not."""
    from omegaconf import OmegaConf

    from bearingtwin.config import CONF_DIR
    from bearingtwin.data.simulated import records_key

    data = {"rpm": 1797.0, "fs": 10000.0, "duration": 1.0}
    bearing = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml"))
    simulator = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml"))
    noise, resonance = {"snr_db": 10.0, "spectral_slope": 0.0}, {"natural_frequency_hz": 3000.0, "damping_ratio": 0.05}
    unbalance, clipping = {"level_db": 0.0}, {"clip_level": 3.0}

    def key(effects):
        return records_key(data, bearing, simulator, effects)

    assert key({"noise": noise, "resonance": resonance}) != key({"resonance": resonance, "noise": noise})
    assert key({"clipping": clipping, "unbalance": unbalance}) == key({"unbalance": unbalance, "clipping": clipping})


def test_records_at_several_speeds_each_have_their_own_noise_and_are_drawn_alike_every_time():
    """The twin's records for a real data set: one per state and speed, fault-major, each with a seed of its own
    (the configured seed, the variant, the state, the speed's place), so no two share a noise realization, and the
    same settings give the same numbers."""
    from bearingtwin.physics.simulator import simulate_at_speeds

    simulator = {**OmegaConf.to_container(SIMULATOR), "fs": 12000, "duration": 0.2}
    effects = OmegaConf.to_container(OmegaConf.load(f"{CONF_DIR}/effects/noise.yaml"))
    signals = simulate_at_speeds(["outer", "inner"], [1797.0, 1750.0], BEARING, simulator, effects)
    assert signals.shape == (4, 2400)
    np.testing.assert_array_equal(signals, simulate_at_speeds(["outer", "inner"], [1797.0, 1750.0], BEARING,
                                                              simulator, effects))
    same_speed = simulate_at_speeds(["outer"], [1797.0, 1797.0], BEARING, simulator, effects)
    assert not np.allclose(same_speed[0], same_speed[1])  # the speed's place alone parts their noise
    variant = simulate_at_speeds(["outer"], [1797.0], BEARING, simulator, effects, variant=1)
    assert not np.allclose(variant[0], signals[0])
    np.testing.assert_array_equal(signals[1], simulate_at_speeds(["outer"], [1797.0, 1750.0], BEARING, simulator,
                                                                 effects)[1])  # fault-major: outer at 1750 rpm
