"""Fast (numba RK4) against reference (scipy RK45) solver, and the paper's Figure 9 check."""

import numpy as np
import pytest
import scipy.signal
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR, bearing_config
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS, BearingGeometry
from bearingtwin.physics.simulator import simulate, simulate_many
from bearingtwin.physics.defects import build_defect
from bearingtwin.physics.dynamics import DynamicParameters, static_equilibrium
from bearingtwin.physics.effect_library import Roughness
from bearingtwin.physics.kinematics import rigid_kinematics
from bearingtwin.physics.solvers.fast import (_geometry, derivative, integrate, samples_per_step,
                                              substeps_per_sample)
from bearingtwin.signal.envelope import envelope_spectrum, peak_near

BEARING = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
SIMULATOR = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")
GEOMETRY = BearingGeometry.from_config(BEARING)
FREQUENCIES = GEOMETRY.defect_frequencies(1797)
# A ball defect strikes both races once per spin, so its envelope line sits at 2 x BSF (geometry.py).
DEFECT_LINE_HZ = {"inner": FREQUENCIES["bpfi"], "ball": 2 * FREQUENCIES["bsf"], "outer": FREQUENCIES["bpfo"]}


def settings(**changes):
    return OmegaConf.merge(SIMULATOR, changes)


def test_substeps_resolve_both_the_contact_mode_and_the_defect_crossing():
    assert substeps_per_sample(10_000, 500.0, 0.3e-3, 20, 6) == 2  # crossing: 0.3 ms / 6 = 50 us per step
    assert substeps_per_sample(10_000, 5000.0, 0.3e-3, 20, 6) == 10  # a stiff contact: 1 / (5 kHz x 20)
    assert substeps_per_sample(100_000, 500.0, 0.3e-3, 20, 6) == 1


def test_a_step_spans_several_samples_only_where_the_sampling_is_finer_than_the_step():
    assert samples_per_step(10_000, 500.0, 0.3e-3, 20, 6) == 1  # 50 us steps, 100 us samples
    assert samples_per_step(48_000, 500.0, 0.3e-3, 20, 6) == 2  # 50 us steps hold 2.4 samples
    assert samples_per_step(100_000, 500.0, 0.3e-3, 20, 6) == 5
    assert samples_per_step(100_000, 5000.0, 0.3e-3, 20, 6) == 1  # a stiff contact: 10 us steps


@pytest.mark.parametrize("fault, per_step", [("outer", 2), ("inner", 3), ("ball", 3)])
def test_a_step_over_several_samples_matches_a_step_per_sample(fault, per_step):
    """At 60 kHz a step of 1/20 000 s still resolves the paper bearing's contact and defect
    (10 kHz needs two steps per sample). Stepping over 2 or 3 samples, each sample inside a step
    read off its Hermite interpolant, must give what a step per sample gives: 63 002 samples
    (1.05 s: past the integrator's one-second chunks, every defect through the load zone many
    times; at 3 samples per step the last step spans 2) within 2 % of the peak."""
    params = DynamicParameters.from_config(BEARING, settings(eccentricity_mm=0.05))
    rest = 2.0 * np.pi * np.arange(GEOMETRY.n_balls) / GEOMETRY.n_balls
    state = static_equilibrium(params, rest)
    n_samples = 63_002
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, 60_000.0, n_samples + 1, 0.0)
    defect = build_defect(fault, GEOMETRY, SIMULATOR.defect, -np.pi / 2).as_array()
    fine = integrate(params, kinematics, defect, state, 0, n_samples, 1)
    coarse = integrate(params, kinematics, defect, state, 0, n_samples, 1, per_step=per_step)
    assert not np.array_equal(coarse, fine)  # the samples inside a step are interpolated, not stepped
    assert np.abs(coarse - fine).max() <= 0.02 * np.abs(fine).max()
    for row_coarse, row_fine in zip(coarse, fine):
        assert np.corrcoef(row_coarse, row_fine)[0, 1] >= 0.9999


def test_a_step_spans_several_samples_or_a_sample_several_steps_not_both():
    params = DynamicParameters.from_config(BEARING, SIMULATOR)
    state = static_equilibrium(params, 2.0 * np.pi * np.arange(GEOMETRY.n_balls) / GEOMETRY.n_balls)
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, 60_000.0, 11, 0.0)
    defect = build_defect("outer", GEOMETRY, SIMULATOR.defect, -np.pi / 2).as_array()
    with pytest.raises(ValueError, match="not both"):
        integrate(params, kinematics, defect, state, 0, 10, 2, per_step=2)


def _textbook_rk4(state, kinematics, defect, p, n_samples, substeps):
    """Classical RK4 with every stage's geometry (kinematics, defect depths, trigonometry) evaluated afresh."""
    fs = kinematics.fs_hz
    arrays = kinematics.solver_arrays()
    angles, depths, cosines, sines = (np.empty(kinematics.n_balls) for _ in range(4))

    def rate(t, y):
        shaft_angle, shaft_speed = _geometry(t, fs, *arrays, defect, angles, depths, cosines, sines)
        out = np.empty(8)
        derivative(y, cosines, sines, depths, shaft_angle, shaft_speed, p, out)
        return out

    dt, accelerations = 1.0 / (fs * substeps), np.empty((4, n_samples))
    for sample in range(n_samples):
        for step in range(substeps):
            t = sample / fs + step * dt
            k1 = rate(t, state)
            if step == 0:
                accelerations[:, sample] = k1[4:]
            k2 = rate(t + 0.5 * dt, state + 0.5 * dt * k1)
            k3 = rate(t + 0.5 * dt, state + 0.5 * dt * k2)
            k4 = rate(t + dt, state + dt * k3)
            state = state + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return accelerations


@pytest.mark.parametrize("fault, substeps, rough", [("outer", 3, False), ("inner", 1, True), ("ball", 2, False)])
def test_fast_solver_sharing_stage_geometry_is_textbook_rk4_to_the_bit(fault, substeps, rough):
    """The compiled stepper evaluates the geometry three times a step, not four; nothing else may change.

    1500 samples at 20 kHz (75 ms) carry each defect through the load zone at least once (the
    ball's pit first meets a race near sample 1130), and an unbalance makes the shaft's angle
    and speed count in every stage; rough contacts add a height read at every stage too."""
    params = DynamicParameters.from_config(BEARING, settings(eccentricity_mm=0.05))
    rest = 2.0 * np.pi * np.arange(GEOMETRY.n_balls) / GEOMETRY.n_balls
    state = static_equilibrium(params, rest)
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, 20_000.0, 1501, 0.0)
    if rough:
        smooth = integrate(params, kinematics, build_defect(fault, GEOMETRY, SIMULATOR.defect, -np.pi / 2).as_array(),
                           state, 0, 1500, substeps)
        kinematics = Roughness(rms_um=0.1).modify_kinematics(kinematics, np.random.default_rng(0))
    defect = build_defect(fault, GEOMETRY, SIMULATOR.defect, -np.pi / 2).as_array()
    fast = integrate(params, kinematics, defect, state, 0, 1500, substeps)
    unpitted = defect.copy()
    unpitted[[2, 5]] = 0.0  # the pit's depth (and a ball's on the other race)
    bare = integrate(params, kinematics, unpitted, state, 0, 1500, substeps)
    assert np.abs(fast - bare).max() > 0.1 * np.abs(bare).max()  # the defect's impacts are in the stretch
    textbook = _textbook_rk4(np.array(state, dtype=float), kinematics, defect, params.as_array(), 1500, substeps)
    np.testing.assert_array_equal(fast, textbook)
    if rough:
        assert np.abs(fast - smooth).max() > 0.01 * np.abs(smooth).max()  # the height is read, not dropped


@pytest.fixture(scope="module")
def both_solvers_for_0_3_s():
    """0.3 s of every state from each solver (the reference runs two states at a time).

    The reference takes ~12 s of CPU per simulated second and state: 0.3 s of each (over 30 defect
    impacts) holds the solvers within a correlation of 0.99998 and the defect lines within 0.007 Hz
    of each other, against the 0.99 and 0.05 Hz asserted."""
    fast = simulate_many(FAULTS, BEARING, settings(duration=0.3, solver="fast"), n_jobs=2)
    reference = simulate_many(FAULTS, BEARING, settings(duration=0.3, solver="reference"), n_jobs=2)
    return dict(zip(FAULTS, zip(fast, reference)))


@pytest.mark.parametrize("fault", FAULTS)
def test_fast_solver_matches_the_reference_over_30_impacts(both_solvers_for_0_3_s, fault):
    (fast, fast_channels), (reference, reference_channels) = both_solvers_for_0_3_s[fault]
    for row_fast, row_reference in zip(fast_channels, reference_channels):
        assert np.corrcoef(row_fast, row_reference)[0, 1] >= 0.99
    if fault != "normal":
        freqs, amplitude = envelope_spectrum(np.stack([fast.signal, reference.signal]), fast.fs)
        peaks, _ = peak_near(freqs, amplitude, DEFECT_LINE_HZ[fault], 2.0)
        assert peaks[0] == pytest.approx(peaks[1], abs=0.05)


def test_paper_tolerances_agree_with_a_tightened_reference():
    # With max_step bounded by the defect crossing, ode45's loose rtol 1e-3 / atol 1e-6 (atol is
    # larger than the micrometre displacements!) still reproduces a 1e-8 / 1e-12 solution.
    loose, _ = simulate("outer", BEARING, settings(duration=0.2, solver="reference"))
    tight, _ = simulate("outer", BEARING, settings(duration=0.2, solver="reference",
                                                   reference={"rtol": 1e-8, "atol": 1e-12}))
    assert np.corrcoef(loose.signal, tight.signal)[0, 1] >= 0.999


@pytest.fixture(scope="module")
def thirty_seconds():
    """30 s of every state, vertical inner-race channel (the load line, where the race defects strike)."""
    results = simulate_many(FAULTS, BEARING, settings(duration=30.0, sensor="inner_y"), n_jobs=2)
    return dict(zip(FAULTS, results))


@pytest.mark.parametrize("fault", ["inner", "ball", "outer"])
def test_envelope_peak_at_the_defect_frequency_figure_9(thirty_seconds, fault):
    signals = np.stack([thirty_seconds[fault][0].signal, thirty_seconds["normal"][0].signal])
    freqs, amplitude = envelope_spectrum(signals, thirty_seconds[fault][0].fs)
    (peak, healthy_peak), (line, healthy_line) = peak_near(freqs, amplitude, DEFECT_LINE_HZ[fault], 1.0)
    assert peak == pytest.approx(DEFECT_LINE_HZ[fault], abs=0.1)
    # the healthy bearing has no such line: at BPFO only its varying-compliance ripple, far weaker
    assert healthy_line < 0.1 * line
    search = (freqs > 5) & (freqs < 400)
    assert line > 20 * np.median(amplitude[0, search])  # a line standing well clear of the spectrum's floor


def test_inner_race_defect_shows_in_the_papers_horizontal_channel(thirty_seconds):
    recording, channels = thirty_seconds["inner"]
    freqs, amplitude = envelope_spectrum(channels[0], recording.fs)  # inner_x, the channel of Figure 9
    peak, _ = peak_near(freqs, amplitude, FREQUENCIES["bpfi"], 1.0)
    assert peak == pytest.approx(FREQUENCIES["bpfi"], abs=0.1)


def test_same_seed_same_numbers_and_bad_settings_name_the_field():
    first, _ = simulate("ball", BEARING, settings(duration=0.2))
    second, _ = simulate("ball", BEARING, settings(duration=0.2))
    np.testing.assert_array_equal(first.signal, second.signal)
    with pytest.raises(BearingTwinError, match="simulator.solver"):
        simulate("ball", BEARING, settings(solver="euler"))
    with pytest.raises(BearingTwinError, match="simulator.fs"):
        simulate("ball", BEARING, settings(fs=800.0))
    with pytest.raises(BearingTwinError, match="simulator.sensor"):
        simulate("ball", BEARING, settings(sensor="housing"))


def _band_powers(signal, fs, edges_hz):
    freqs, psd = scipy.signal.welch(signal, fs=fs, nperseg=1024)
    return np.array([psd[(freqs >= low) & (freqs < high)].sum() for low, high in zip(edges_hz[:-1], edges_hz[1:])])


@pytest.fixture(scope="module")
def outer_race_at_12_khz_three_ways():
    """An outer-race record of the CWRU bearing at 12 kHz: solved at 96 kHz and cut to 12 kHz by an ideal
    low-pass (the truth an acquisition with a perfect anti-aliasing filter records), sampled at 12 kHz
    (``oversample`` 1), and solved 4 x finer and filtered down (``oversample`` 4)."""
    bearing = bearing_config("cwru_6205")
    base = dict(rpm=1797.0, duration=1.0, sensor="outer_y")
    fine, _ = simulate("outer", bearing, settings(fs=96000.0, **base))
    spectrum = np.fft.rfft(fine.signal)
    n = fine.signal.size // 8
    truth = np.fft.irfft(spectrum[: n // 2 + 1], n) / 8
    sampled, _ = simulate("outer", bearing, settings(fs=12000.0, **base))
    filtered, _ = simulate("outer", bearing, settings(fs=12000.0, oversample=4, **base))
    return truth, sampled.signal, filtered.signal


def test_oversampling_removes_the_pit_edges_aliases_and_keeps_the_band_below(outer_race_at_12_khz_three_ways):
    truth, sampled, filtered = outer_race_at_12_khz_three_ways
    edges = [0.0, 1000.0, 2000.0, 3000.0, 4000.0, 5000.0]
    truth_bands = _band_powers(truth, 12000.0, edges)
    sampled_ratio = _band_powers(sampled, 12000.0, edges) / truth_bands
    filtered_ratio = _band_powers(filtered, 12000.0, edges) / truth_bands
    # The pit edges' transients above 6 kHz fold into the top band of the point samples ...
    assert sampled_ratio[-1] > 2.0, sampled_ratio
    # ... and the filtered record holds what the truth holds there, and everywhere below.
    np.testing.assert_allclose(filtered_ratio, 1.0, atol=0.05)
    assert filtered.size == sampled.size == truth.size


def test_the_oversampled_record_keeps_the_sampled_records_instants(outer_race_at_12_khz_three_ways):
    """The record starts where the transient at fs ends, whatever the oversampling: 4 and 8 times finer
    give the same samples but for what the filter leaves above 5 kHz, with no lag between them."""
    _, sampled, filtered = outer_race_at_12_khz_three_ways
    bearing = bearing_config("cwru_6205")
    finer, _ = simulate("outer", bearing, settings(fs=12000.0, oversample=8, rpm=1797.0, duration=1.0,
                                                   sensor="outer_y"))
    lags = np.arange(-5, 6)
    assert lags[int(np.argmax([np.dot(np.roll(filtered, lag), finer.signal) for lag in lags]))] == 0
    assert np.corrcoef(filtered, finer.signal)[0, 1] > 0.9999
    assert np.corrcoef(sampled, finer.signal)[0, 1] > 0.99  # the samples at fs are the same instants, aliased


def test_oversample_1_is_the_config_written_before_it_existed():
    bearing = bearing_config("cwru_6205")
    with_key = OmegaConf.to_container(settings(fs=12000.0, duration=0.1, oversample=1))
    without_key = {name: value for name, value in with_key.items() if name != "oversample"}
    np.testing.assert_array_equal(simulate("inner", bearing, with_key)[0].signal,
                                  simulate("inner", bearing, without_key)[0].signal)
