"""Bad simulator settings are refused before any heavy work, in one line naming the config field.

Each case was found by probing ``bearingtwin-simulate``: a NaN defect angle gave a near-silent record
still labelled faulty, a sampling rate below twice the fault's defect frequency was accepted, a huge
fs x duration grew memory without bound, and zero steps, a text seed, a record of no samples and
non-finite loads ended in tracebacks or in messages naming no field. (The command-line layer: exit
status 2 and the one line on stderr: tests/test_simulate_cli.py.)
"""

import tracemalloc

import numpy as np
import pytest
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics import simulator
from bearingtwin.physics.geometry import FAULTS, BearingGeometry
from bearingtwin.physics.simulator import simulate, simulate_many

BEARING = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
SIMULATOR = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")


def settings(**changes):
    return OmegaConf.to_container(OmegaConf.merge(SIMULATOR, changes))


def refused(fault, simulator_cfg, *named, bearing=BEARING, effects=None) -> str:
    """The one-line message ``simulate`` refuses with; it must name every field in ``named``."""
    with pytest.raises(BearingTwinError) as error:
        simulate(fault, bearing, simulator_cfg, effects)
    message = str(error.value)
    assert "\n" not in message and all(name in message for name in named), message
    return message


@pytest.mark.parametrize("name", ["outer_angle_deg", "inner_angle_deg", "ball_angle_deg"])
@pytest.mark.parametrize("fault", ["outer", "inner", "ball", "normal"])
@pytest.mark.parametrize("value", [float("nan"), "north"])
def test_a_defect_angle_must_be_a_finite_number_for_every_fault(name, fault, value):
    """Every state's angle, whichever state is simulated: the data set simulates all four from one config."""
    message = refused(fault, settings(duration=0.1, defect={name: value}), f"simulator.defect.{name}")
    assert message.startswith(f"simulator.defect.{name} must be ")


def test_any_finite_defect_angle_is_an_angle():
    """-450 deg is 270 deg: the same record, not a near-silent one, and not the record of a defect at 0 deg."""
    for fault, name in (("outer", "outer_angle_deg"), ("inner", "inner_angle_deg"), ("ball", "ball_angle_deg")):
        wound, _ = simulate(fault, BEARING, settings(duration=0.05, defect={name: -450.0}))
        plain, _ = simulate(fault, BEARING, settings(duration=0.05, defect={name: 270.0}))
        zero, _ = simulate(fault, BEARING, settings(duration=0.05, defect={name: 0.0}))
        assert wound.signal.size == 500
        np.testing.assert_allclose(wound.signal, plain.signal, rtol=1e-6, atol=1e-9 * np.abs(plain.signal).max())
        assert not np.allclose(wound.signal, zero.signal, rtol=1e-3), fault


@pytest.mark.parametrize("fault, rpm, frequency", [("inner", 200_000.0, "BPFI"), ("outer", 30_000.0, "BPFO"),
                                                   ("ball", 18_000.0, "2xBSF")])
def test_the_sampling_rate_must_clear_twice_the_faults_defect_frequency(fault, rpm, frequency):
    """A ball defect strikes both races, at twice BSF: at 18000 rpm its BSF (707 Hz) clears fs/2 = 1000 Hz, its
    strikes (1414 Hz) do not, and would fold to 586 Hz."""
    message = refused(fault, settings(rpm=rpm, fs=2000.0, duration=0.2), "simulator.fs=2000", frequency,
                      "fs/2 = 1000 Hz")
    assert message.startswith("simulator.fs=2000 Hz cannot show the ")


def test_the_defect_frequency_check_is_at_or_above_nyquist_and_a_healthy_bearing_has_none():
    geometry = BearingGeometry.from_config(BEARING)
    bpfi = geometry.bpfi_hz(1797.0)
    with pytest.raises(BearingTwinError, match="simulator.fs"):
        simulator._check_resolves_fault("inner", geometry, 1797.0, 2.0 * bpfi, 1.0)
    simulator._check_resolves_fault("inner", geometry, 1797.0, 2.0 * bpfi * 1.001, 1.0)
    simulator._check_resolves_fault("normal", geometry, 1797.0, 10.0, 1.0)


def test_a_fault_the_record_never_strikes_is_refused():
    """At 1 rpm an outer-race defect is struck once every 17 s: a 0.5 s record of it is a healthy bearing's
    labelled faulty, and so is a pit of no depth at any speed."""
    message = refused("outer", settings(rpm=1.0, duration=0.5), "simulator.rpm=1", "BPFO", "simulator.duration=0.5")
    assert message.endswith("raise the speed, or the duration to at least 16.7 s"), message
    geometry = BearingGeometry.from_config(BEARING)
    bpfo = geometry.fault_frequency_hz("outer", 1797.0)
    simulator._check_resolves_fault("outer", geometry, 1797.0, 10000.0, 1.01 / bpfo)  # struck once: a fault to see
    simulator._check_resolves_fault("normal", geometry, 1.0, 10000.0, 0.5)  # no defect, nothing to strike
    for fault in ("inner", "ball", "outer"):
        refused(fault, settings(duration=0.2, defect={"depth_mm": 0.0}), "simulator.defect.depth_mm must be positive")


def test_a_defect_of_the_callers_own_without_every_setting_or_with_text_for_a_size_is_refused_naming_it():
    """The Python API takes a defect dict of the caller's own: one with a width alone had failed on a bare
    KeyError ('depth_mm'), a size given as text on a TypeError."""
    defect = settings()["defect"]
    partial = {"width_mm": 0.5}
    with pytest.raises(BearingTwinError, match=r"^simulator.defect has no depth_mm, outer_angle_deg, inner_angle_deg, "
                                               r"ball_index, ball_angle_deg; give every one of width_mm, depth_mm"):
        simulate("outer", BEARING, {**settings(duration=0.2), "defect": partial}, None)
    refused("inner", {**settings(duration=0.2), "defect": {**defect, "width_mm": "wide"}},
            "simulator.defect.width_mm must be a width in mm, got 'wide'")


def test_the_data_set_path_is_refused_before_any_state_is_simulated(monkeypatch):
    """simulate_many (the simulated data set's path) checks every state first: the healthy one, first in
    FAULTS, is not simulated only for the inner race's to be refused after it."""
    started = []
    monkeypatch.setattr(simulator, "simulate", lambda fault, *args, **kwargs: started.append(fault))
    with pytest.raises(BearingTwinError, match=r"^simulator\.fs=2000 Hz cannot show the inner fault"):
        simulate_many(FAULTS, BEARING, settings(rpm=200_000.0, fs=2000.0, duration=0.2))
    assert started == []


def test_a_simulation_larger_than_half_the_memory_is_refused_naming_fs_and_duration(monkeypatch):
    monkeypatch.setattr(simulator, "physical_memory_bytes", lambda: 2_000_000)  # 1 s at 10 kHz needs ~3.9 MB
    message = refused("outer", settings(duration=1.0), "simulator.fs=10000 Hz", "simulator.duration=1 s",
                      "10,000 samples", "GB of memory", "this machine's 0.002 GB")
    assert message.startswith("simulator.fs=")


def test_a_duration_beyond_any_memory_is_refused_not_an_allocation_error():
    refused("outer", settings(duration=1e9), "simulator.fs", "simulator.duration", "10,000,000,000,000 samples")
    refused("outer", settings(duration=1e200, fs=1e200), "simulator.fs", "simulator.duration")


def test_parallel_states_count_together_in_the_memory_check(monkeypatch):
    cfg = settings(duration=0.5)
    plan = simulator._plan("normal", BEARING, cfg, None)
    one = simulator._memory_bytes("fast", plan.n_transient, plan.n_samples, 9)
    monkeypatch.setattr(simulator, "physical_memory_bytes", lambda: 3 * one)  # half the memory: 1.5 simulations
    monkeypatch.setattr(simulator, "simulate", lambda *args, **kwargs: None)  # no processes, whatever happens
    simulate_many(["normal", "inner"], BEARING, cfg, n_jobs=1)
    with pytest.raises(BearingTwinError, match="for 2 simulations at once"):
        simulate_many(["normal", "inner"], BEARING, cfg, n_jobs=2)


@pytest.mark.parametrize("solver, duration, effects", [
    ("fast", 0.5, None),
    ("fast", 0.5, {"slip": {"jitter": 0.015}, "spin_slip": {"jitter": 0.05},  # they rewrite the kinematics
                   "speed_fluctuation": {"depth": 0.01, "frequency_hz": 2.0}}),
    ("reference", 0.02, None),
])
def test_the_memory_estimate_bounds_the_traced_peak(solver, duration, effects):
    """The factors were measured with tracemalloc; a new array in the solvers must not outgrow them."""
    cfg = settings(solver=solver, duration=duration)
    simulate("outer", BEARING, settings(solver=solver, duration=0.01), effects)  # numba compiled before tracing
    tracemalloc.start()
    try:
        recording, _ = simulate("outer", BEARING, cfg, effects)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    n_transient = round(recording.meta["transient_s"] * recording.fs)
    estimate = simulator._memory_bytes(solver, n_transient, recording.signal.size, 9)
    assert 0.25 * estimate < peak <= estimate  # without slip's copies of the ball offsets, 0.4 of it


@pytest.mark.parametrize("changes, field", [
    ({"fast": {"steps_per_period": 0}}, "simulator.fast.steps_per_period"),
    ({"fast": {"steps_per_period": 2.5}}, "simulator.fast.steps_per_period"),
    ({"fast": {"steps_per_defect": 0}}, "simulator.fast.steps_per_defect"),
    ({"solver": "reference", "reference": {"steps_per_defect": 0}}, "simulator.reference.steps_per_defect"),
])
def test_steps_must_be_a_positive_integer(changes, field):
    message = refused("outer", settings(duration=0.1, **changes), field)
    assert message.startswith(f"{field} must be a positive integer")


@pytest.mark.parametrize("oversample", [0, 2.5, "four", True])
def test_oversample_must_be_a_positive_integer(oversample):
    assert refused("outer", settings(duration=0.1, oversample=oversample), "simulator.oversample").startswith(
        "simulator.oversample must be a positive integer")


def test_a_whole_oversample_written_as_a_float_is_that_whole_number():
    recording, _ = simulate("outer", BEARING, settings(duration=0.05, oversample=2.0))
    assert recording.meta["oversample"] == 2 and recording.signal.size == 500


def test_an_oversampled_simulation_counts_its_finer_grid_in_the_memory_check(monkeypatch):
    monkeypatch.setattr(simulator, "physical_memory_bytes", lambda: 2_000_000_000)
    simulator._plan("outer", BEARING, settings(duration=60.0, oversample=1), None)  # within the memory at fs
    message = refused("outer", settings(duration=60.0, oversample=8), "simulator.fs", "simulator.oversample",
                      "simulator.duration")
    assert "8 times finer" in message


@pytest.mark.parametrize("seed", ["abc", -1, 1.5, True])
def test_the_seed_must_be_a_non_negative_integer(seed):
    assert refused("outer", settings(duration=0.1, seed=seed), "simulator.seed").startswith(
        "simulator.seed must be a non-negative integer")


@pytest.mark.parametrize("duration, samples", [(1e-5, 0), (1e-4, 1)])
def test_a_record_of_fewer_than_two_samples_is_refused_up_front(duration, samples):
    message = refused("outer", settings(duration=duration), "simulator.duration", "simulator.fs=10000",
                      f"gives {samples} sample", "at least 0.0002 s")
    assert message.startswith("simulator.duration=")
    recording, _ = simulate("normal", BEARING, settings(duration=2e-4))
    assert recording.signal.size == 2


@pytest.mark.parametrize("name, value", [
    ("initial_cage_angle_deg", float("nan")), ("load_x_n", float("nan")), ("gravity_m_per_s2", float("nan")),
    ("load_y_n", float("inf")), ("load_y_n", "heavy"), ("eccentricity_mm", float("inf")),
    ("settle_decades", float("inf")),
])
def test_non_finite_loads_and_angles_are_refused_before_the_static_equilibrium(name, value):
    message = refused("outer", settings(duration=0.1, **{name: value}), f"simulator.{name}")
    assert message.startswith(f"simulator.{name} must be ") and "equilibrium" not in message


@pytest.mark.parametrize("name, value, said", [
    ("inner_mass_kg", 0.0, "bearing.inner_mass_kg must be positive, got 0.0"),
    ("outer_damping_ns_per_m", -1.0, "bearing.outer_damping_ns_per_m must not be negative, got -1.0"),
])
def test_a_bearing_setting_out_of_range_is_named_as_the_config_sets_it(name, value, said):
    """The masses, dampings and support stiffnesses come from the bearing config: named bearing.<field>, as the
    user gives them (the message had named the bare field)."""
    assert refused("normal", settings(duration=0.2), bearing=OmegaConf.merge(BEARING, {name: value})) == said


def test_a_missing_state_is_named_as_the_command_line_writes_it():
    assert refused(None, settings()) == "fault=null is not a bearing state; choose one of normal, inner, ball, outer"


@pytest.mark.parametrize("changes, named, meant", [
    ({"durration": 2.0}, "simulator.durration", "simulator.duration"),
    ({"defect": {"width_mmm": 2.0}}, "simulator.defect.width_mmm", "simulator.defect.width_mm"),
    ({"fast": {"steps_per_perod": 40}}, "simulator.fast.steps_per_perod", "simulator.fast.steps_per_period")])
def test_a_misspelt_setting_is_refused_naming_the_one_meant(changes, named, meant):
    """From Python a mapping takes any key: a misspelt duration had simulated the default 2 s, unsaid."""
    simulator_cfg = settings()
    for key, value in changes.items():
        simulator_cfg[key] = {**simulator_cfg[key], **value} if isinstance(value, dict) else value
    assert f"did you mean {meant}?" in refused("outer", simulator_cfg, named)


def test_a_hand_written_mapping_names_the_settings_it_lacks_and_may_leave_out_null_ones():
    message = refused("outer", {"fs": 12000.0, "duration": 0.1, "rpm": 1797.0}, "simulator has no solver, sensor, seed")
    assert "compose_config" in message
    lean = {key: value for key, value in settings(duration=0.05).items() if value is not None}
    assert simulate("outer", BEARING, lean)[0].signal.size == 500  # sensor_angle_deg, oversample: null by default


@pytest.mark.parametrize("bearing", [BearingGeometry.from_config(OmegaConf.to_container(BEARING)), "paper"])
def test_a_bearing_given_as_its_geometry_or_name_is_refused_saying_what_to_give(bearing):
    message = refused("outer", settings(duration=0.05), "bearing", "bearing_config", bearing=bearing)
    assert type(bearing).__name__ in message
