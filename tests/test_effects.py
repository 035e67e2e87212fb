"""The effect library: each effect does the physics it documents, and is wired by name and YAML."""

import inspect
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from omegaconf import OmegaConf
from scipy import signal as sps

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics import effect_library as lib
from bearingtwin.physics.dynamics import DynamicParameters, contact_force, linear_modes, static_equilibrium
from bearingtwin.physics.effects import _REGISTRY, build_effects, effect_class, registered_effects
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.kinematics import rigid_kinematics

LIBRARY = ("resonance", "slip", "speed_fluctuation", "noise", "tones", "lubrication", "load_zone", "preload",
           "spin_slip", "unbalance", "misalignment", "looseness", "line_frequency", "clipping", "second_resonance",
           "structural_mode", "roughness")
SENSOR_ONLY = ("resonance", "noise", "tones", "unbalance", "misalignment", "looseness", "line_frequency", "clipping",
               "second_resonance", "structural_mode")
FS = 12000.0
SHAFT_HZ = 1797.0 / 60
GEOMETRY = BearingGeometry(52.0, 25.0, 7.94, 39.0, 9)


def _yaml(name):
    return OmegaConf.to_container(OmegaConf.load(Path(CONF_DIR) / "effects" / f"{name}.yaml"))


@pytest.mark.parametrize("name", LIBRARY)
def test_every_effect_has_a_yaml_a_search_space_and_a_signature(name):
    assert name in registered_effects()
    content = _yaml(name)
    assert list(content) == [name]
    (effect,) = build_effects(content)
    arguments = set(inspect.signature(type(effect).__init__).parameters) - {"self"}
    assert set(content[name]) == arguments
    assert effect.signature and set(effect.search_space) <= arguments
    for fs in (12000.0, 25600.0, 48000.0):
        for parameter, (low, high, log) in type(effect).search_space_at(fs).items():
            assert low < high < math.inf and (not log or low > 0)
            assert low <= content[name][parameter] <= high


@pytest.mark.parametrize("name", ["resonance", "second_resonance", "structural_mode"])
def test_a_mode_is_searched_as_high_as_the_rate_lets_a_record_show_it(name):
    """A stud-mounted accelerometer rings at 10-30 kHz: at 48 kHz the search reaches 21.6 kHz, at 12 kHz 5.4 kHz,
    below the Nyquist frequency where the mode's filter is refused."""
    cls = effect_class(name)
    for fs in (12000.0, 25600.0, 48000.0):
        low, high, log = cls.search_space_at(fs)["natural_frequency_hz"]
        assert (low, log) == (300.0, True) and high == pytest.approx(0.45 * fs)
        with pytest.raises(BearingTwinError, match="Nyquist"):
            build_effects({name: {**_yaml(name)[name], "natural_frequency_hz": fs / 2}})[0].check_rate(fs)
        build_effects({name: {**_yaml(name)[name], "natural_frequency_hz": high}})[0].check_rate(fs)


def test_composed_effects_keep_their_order():
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=["measured.path=x.npy", "effects=[tones,resonance]"])
    assert list(cfg.effects) == ["tones", "resonance"]
    assert [e.name for e in build_effects(cfg.effects)] == ["tones", "resonance"]


def test_clipping_acts_last_wherever_it_is_listed():
    """A saturation clips what reaches the recorder: a shaft line listed after it is clipped too."""
    listed = {"clipping": {"clip_level": 2.0}, "unbalance": {"level_db": 6.0}, "tones": {"frequencies_hz": [137.0],
                                                                                        "levels_db": [-6.0]}}
    assert [e.name for e in build_effects(listed)] == ["unbalance", "tones", "clipping"]
    rng = np.random.default_rng(0)
    impulsive = rng.standard_normal(24000) * 0.2
    impulsive[::400] += 8.0

    def recorded(effects):
        signal, stream = impulsive, np.random.default_rng(1)
        for effect in build_effects(effects):
            signal = effect.modify_signal(signal, FS, stream, SHAFT_HZ)
        return signal

    clipped = recorded(listed)
    np.testing.assert_array_equal(clipped, recorded({k: listed[k] for k in ("unbalance", "tones", "clipping")}))
    before = recorded({k: v for k, v in listed.items() if k != "clipping"})
    assert np.abs(clipped).max() == pytest.approx(2.0 * np.sqrt(np.mean(before**2)))


@pytest.mark.parametrize("natural_frequency_hz, damping_ratio", [(3000.0, 0.05), (1200.0, 0.1)])
def test_resonance_peaks_at_its_natural_frequency_with_gain_one_over_two_zeta(natural_frequency_hz, damping_ratio):
    impulse = np.zeros(2**16)
    impulse[0] = 1.0
    response = lib.base_excitation_filter(impulse, FS, natural_frequency_hz, damping_ratio)
    gain = np.abs(np.fft.rfft(response))
    freqs = np.fft.rfftfreq(impulse.size, 1 / FS)
    assert freqs[np.argmax(gain)] == pytest.approx(natural_frequency_hz, rel=0.02)
    assert gain.max() == pytest.approx(math.sqrt(1 + 4 * damping_ratio**2) / (2 * damping_ratio), rel=0.03)
    assert gain[np.searchsorted(freqs, 20.0)] == pytest.approx(1.0, abs=0.01)


def test_resonance_above_nyquist_is_named():
    with pytest.raises(BearingTwinError, match="resonance.natural_frequency_hz"):
        lib.Resonance(natural_frequency_hz=7000.0, damping_ratio=0.05).modify_signal(np.ones(100), FS, None, SHAFT_HZ)
    with pytest.raises(BearingTwinError, match="resonance.damping_ratio"):
        lib.Resonance(natural_frequency_hz=3000.0, damping_ratio=-1.0)


@pytest.mark.parametrize("snr_db, slope", [(10.0, 0.0), (0.0, 1.0)])
def test_noise_has_the_requested_snr_and_spectral_slope(snr_db, slope):
    rng = np.random.default_rng(0)
    clean = np.sin(2 * np.pi * 50 * np.arange(2**16) / FS)
    noisy = lib.Noise(snr_db=snr_db, spectral_slope=slope).modify_signal(clean, FS, rng, SHAFT_HZ)
    noise = noisy - clean
    assert 10 * np.log10(np.mean(clean**2) / np.mean(noise**2)) == pytest.approx(snr_db, abs=0.01)
    freqs, psd = sps.welch(noise, FS, nperseg=4096)
    band = (freqs > 100) & (freqs < 5000)
    fitted_slope = -np.polyfit(np.log10(freqs[band]), np.log10(psd[band]), 1)[0]
    assert fitted_slope == pytest.approx(slope, abs=0.1)


def _line_amplitudes(lines, frequencies_hz):
    """Amplitude of the spectrum of ``lines`` (an integer number of cycles of each line) at each frequency."""
    spectrum = np.abs(np.fft.rfft(lines)) * 2 / lines.size
    freqs = np.fft.rfftfreq(lines.size, 1 / FS)
    return np.array([spectrum[np.abs(freqs - f) < 0.1].max() for f in frequencies_hz])


def test_tones_put_independent_lines_at_their_levels():
    x = np.random.default_rng(1).standard_normal(60000)  # 5 s: the lines fall on bins
    tones = lib.Tones(frequencies_hz=[60.0, 157.4, 333.2], levels_db=[6.0, -3.0, -10.0], level_offset_db=-2.0)
    lines = tones.modify_signal(x, FS, np.random.default_rng(2), SHAFT_HZ) - x
    rms_db = np.array([6.0, -3.0, -10.0]) - 2.0
    np.testing.assert_allclose(_line_amplitudes(lines, [60.0, 157.4, 333.2]),
                               math.sqrt(2) * x.std() * 10 ** (rms_db / 20), rtol=0.02)
    assert _line_amplitudes(lines, [120.0, 180.0]).max() < 1e-3  # no harmonics: the lines are independent
    assert np.array_equal(lib.Tones([], []).modify_signal(x, FS, np.random.default_rng(2), SHAFT_HZ), x)


def test_slip_jitters_the_balls_by_the_requested_fraction_of_their_spacing():
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, FS, 120000)
    slipped = lib.Slip(jitter=0.02).modify_kinematics(kinematics, np.random.default_rng(0))
    offsets = slipped.ball_offset_rad
    spacing = 2 * np.pi / GEOMETRY.n_balls
    # Knots hold std = jitter x spacing; linear interpolation between them averages to 2/3 of the variance.
    assert offsets.std() / spacing == pytest.approx(0.02 * math.sqrt(2 / 3), rel=0.1)
    np.testing.assert_array_equal(slipped.cage_angle_rad, kinematics.cage_angle_rad)
    # Independent from ball to ball: slip breaks the spacing, not just the phase of the whole set.
    assert abs(np.corrcoef(offsets[:, 0], offsets[:, 1])[0, 1]) < 0.1


def test_speed_fluctuation_modulates_speed_and_keeps_rolling_ratios():
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, FS, 60000)
    effect = lib.SpeedFluctuation(depth=0.03, frequency_hz=4.0)
    varied = effect.modify_kinematics(kinematics, np.random.default_rng(0))
    speed_ratio = varied.shaft_speed_rad_s / kinematics.shaft_speed_rad_s
    assert speed_ratio.max() - 1 == pytest.approx(0.03, rel=0.01)
    assert 1 - speed_ratio.min() == pytest.approx(0.03, rel=0.01)
    freqs = np.fft.rfftfreq(speed_ratio.size, 1 / FS)
    assert freqs[np.argmax(np.abs(np.fft.rfft(speed_ratio - 1)))] == pytest.approx(4.0, abs=0.25)
    cage_per_shaft = np.diff(varied.cage_angle_rad) / np.diff(varied.shaft_angle_rad)
    np.testing.assert_allclose(cage_per_shaft, GEOMETRY.ftf_hz(1797.0) / (1797.0 / 60), rtol=1e-9)
    # The mean speed is kept: after whole modulation periods the shaft is where it would have been.
    period = int(FS / 4.0)
    drift = varied.shaft_angle_rad[10 * period] - kinematics.shaft_angle_rad[10 * period]
    excursion = np.max(np.abs(varied.shaft_angle_rad - kinematics.shaft_angle_rad))
    assert excursion > 0.1 and abs(drift) < 1e-6 * excursion  # it swings ahead and behind, and comes back


def _params():
    return DynamicParameters(inner_mass_kg=5.5, outer_mass_kg=12.64, inner_damping_ns_per_m=3376.84,
                             outer_damping_ns_per_m=2310.68, inner_stiffness_n_per_m=5.24e4,
                             outer_stiffness_n_per_m=1.51e7, contact_stiffness_n_per_m1_5=9.26e9,
                             clearance_m=5e-6, n_balls=9)


def test_load_zone_narrows_with_clearance_and_widens_with_load():
    angles = 2 * np.pi * np.arange(9) / 9 - np.pi / 2

    def load_zone(load_n, clearance_um):
        """The balls in contact, and the load zone's half angle (rad): where the races' approach exceeds the
        clearance, arccos(clearance / largest approach)."""
        params = lib.LoadZone(radial_load_n=load_n, clearance_um=clearance_um).modify_parameters(_params())
        state = static_equilibrium(params, angles)
        deflection = (state[0] - state[2]) * np.cos(angles) + (state[1] - state[3]) * np.sin(angles)
        return int(np.sum(deflection > params.clearance_m)), float(np.arccos(params.clearance_m / deflection.max()))

    assert load_zone(2000.0, 1.0)[0] > load_zone(2000.0, 30.0)[0]
    assert load_zone(2000.0, 1.0)[1] > load_zone(2000.0, 30.0)[1]
    assert load_zone(5000.0, 10.0)[0] >= load_zone(100.0, 10.0)[0]
    assert load_zone(5000.0, 10.0)[1] > load_zone(100.0, 10.0)[1]  # the same clearance, a deeper approach
    with pytest.raises(BearingTwinError, match="load_zone.clearance_um"):
        lib.LoadZone(radial_load_n=100.0, clearance_um=-1.0)


def test_lubrication_softens_and_damps_the_contacts():
    params = _params()
    lubricated = lib.Lubrication(stiffness_ratio=0.5, damping_ns_per_m=2000.0).modify_parameters(params)
    assert lubricated.contact_stiffness_n_per_m1_5 == pytest.approx(0.5 * params.contact_stiffness_n_per_m1_5)
    angles = 2 * np.pi * np.arange(9) / 9 - np.pi / 2
    dry_state = static_equilibrium(params, angles)
    _, dry_decay = linear_modes(params, dry_state, angles)
    assert lubricated.contact_damping_ns_per_m == pytest.approx(params.contact_damping_ns_per_m + 2000.0)
    only_damped = lib.Lubrication(stiffness_ratio=1.0, damping_ns_per_m=2000.0).modify_parameters(params)
    _, wet_decay = linear_modes(only_damped, dry_state, angles)
    assert wet_decay > dry_decay  # the film damps the slowest mode faster
    with pytest.raises(BearingTwinError, match="lubrication.stiffness_ratio"):
        lib.Lubrication(stiffness_ratio=1.5, damping_ns_per_m=10.0)


def test_unknown_effect_and_bad_parameters_are_named():
    with pytest.raises(BearingTwinError, match="effects.wobble: unknown effect"):
        build_effects({"wobble": {}})
    with pytest.raises(BearingTwinError, match="effects.slip: bad parameters"):
        build_effects({"slip": {"jitter": 0.01, "colour": 3}})
    assert all(_REGISTRY[name].__module__ == lib.__name__ for name in LIBRARY)


@pytest.mark.parametrize("effect", [{"resonance": {"natural_frequency_hz": 3000.0, "damping_ratio": 0.05}},
                                    {"structural_mode": {"natural_frequency_hz": 3000.0, "damping_ratio": 0.05,
                                                         "level_db": 10.0}}])
def test_a_mode_above_nyquist_is_refused_before_the_solver_runs(effect, monkeypatch):
    """At fs = 2 kHz a 3 kHz mode cannot ring: refused before the solver's minutes, not after them."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.physics import simulator

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.fs=2000", "simulator.duration=0.2"])
    monkeypatch.setattr(simulator, "static_equilibrium", lambda *args: pytest.fail("the solver's set-up ran"))
    name = next(iter(effect))
    with pytest.raises(BearingTwinError, match=rf"^{name}.natural_frequency_hz=3000.0 must lie below the Nyquist "
                                               r"frequency 1000.0 Hz$"):
        simulator.simulate("outer", cfg.bearing, cfg.simulator, effect)


def test_lubricated_contacts_damp_the_impacts_in_both_solvers():
    """The contact-damping extension of the hook: both solvers agree, and the film drains the contact modes."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.physics.simulator import simulate

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.fs=12000", "simulator.duration=0.2"])
    film = {"lubrication": {"stiffness_ratio": 1.0, "damping_ns_per_m": 3000.0}}
    dry, _ = simulate("inner", cfg.bearing, cfg.simulator)
    fast, _ = simulate("inner", cfg.bearing, cfg.simulator, film)
    cfg.simulator.solver = "reference"
    reference, _ = simulate("inner", cfg.bearing, cfg.simulator, film)
    assert np.corrcoef(fast.signal, reference.signal)[0, 1] > 0.99
    # The contact modes of the linearized bearing hold less energy once the film damps them.
    params = DynamicParameters.from_config(cfg.bearing, cfg.simulator)
    angles = 2 * np.pi * np.arange(params.n_balls) / params.n_balls
    highest_mode_hz, _ = linear_modes(params, static_equilibrium(params, angles), angles)
    freqs, psd = sps.welch(np.stack([dry.signal, fast.signal]), 12000, nperseg=600)
    modes = (freqs > 0.4 * highest_mode_hz) & (freqs < 1.2 * highest_mode_hz)
    dry_energy, film_energy = psd[:, modes].sum(axis=1)
    assert film_energy < 0.7 * dry_energy


def _healthy_twin(effects, fs=12000, seed=0):
    from hydra import compose, initialize_config_dir

    from bearingtwin.physics.simulator import simulate

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=[f"simulator.fs={fs}", "simulator.duration=1.0", "simulator.sensor=outer_y",
                                             "simulator.load_y_n=-500", f"simulator.seed={seed}"])
    return simulate("normal", cfg.bearing, cfg.simulator, effects)[0].signal


def _band_level_db(x, fs, low_hz, high_hz):
    """Median PSD level (dB re 1 (m/s^2)^2/Hz) over a band: lines between the bins do not move it."""
    freqs, psd = sps.welch(x, fs, nperseg=int(fs / 10))
    return 10 * np.log10(np.median(psd[(freqs >= low_hz) & (freqs <= high_hz)]))


def test_roughness_makes_a_floor_shaped_by_the_bearings_dynamics_growing_with_its_height():
    """A random height at the contacts drives the races through the Hertz springs: the floor it makes rises with
    frequency towards the contact modes (acceleration from a force grows as f^2 below the support's resonance),
    where a sensor's white floor lies flat, and its power grows as the height's square (small heights: linear)."""
    smooth = _healthy_twin({})
    rough, rougher = (_healthy_twin({"roughness": {"rms_um": rms}}) for rms in (0.05, 0.1))
    for band in ((1500, 2500), (3000, 5000)):  # between the bare twin's ball-pass harmonics, high up
        assert _band_level_db(rough, FS, *band) > _band_level_db(smooth, FS, *band) + 30
        assert _band_level_db(rougher, FS, *band) - _band_level_db(rough, FS, *band) == pytest.approx(6.0, abs=1.0)
    assert _band_level_db(rough, FS, 800, 1200) > _band_level_db(rough, FS, 40, 90) + 45  # below the first ball pass
    white = lib.add_noise(smooth, FS, -10.0, 0.0, np.random.default_rng(0))
    assert abs(_band_level_db(white, FS, 800, 1200) - _band_level_db(white, FS, 40, 90)) < 1.5


def test_roughness_keeps_its_spectral_level_whatever_the_rate_and_follows_the_seed():
    """The height's level is set per hertz of its band, so a finer grid adds higher frequencies, not power in
    the bands both rates see; independent draws per ball and seed."""
    effects = {"roughness": {"rms_um": 0.05}}
    at_12k, at_24k = _healthy_twin(effects, fs=12000), _healthy_twin(effects, fs=24000)
    assert _band_level_db(at_24k, 24000, 1500, 4000) == pytest.approx(_band_level_db(at_12k, FS, 1500, 4000), abs=1.5)
    (effect,) = build_effects(effects)
    for grid_hz in (48000.0, FS):  # one that carries the whole 10 kHz band, one that cuts it at 5.4 kHz
        height = effect.modify_kinematics(rigid_kinematics(GEOMETRY, 1797.0, grid_hz, int(grid_hz)),
                                          np.random.default_rng(3)).contact_roughness_m
        freqs, psd = sps.welch(height, grid_hz, nperseg=2048, axis=0)
        in_band = psd[(freqs > 100) & (freqs < 4000)].mean()
        assert in_band * 10000 == pytest.approx((0.05e-6) ** 2, rel=0.1), grid_hz  # the level rms^2 / bandwidth
    kinematics = rigid_kinematics(GEOMETRY, 1797.0, FS, 24000)
    first, again, other = (effect.modify_kinematics(kinematics, np.random.default_rng(seed)).contact_roughness_m
                           for seed in (3, 3, 4))
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)
    assert abs(np.corrcoef(first[:, 0], first[:, 1])[0, 1]) < 0.05  # ball by ball independent
    with pytest.raises(BearingTwinError, match="roughness.rms_um"):
        lib.Roughness(rms_um=0.0)


def test_rough_contacts_agree_in_both_solvers():
    from hydra import compose, initialize_config_dir

    from bearingtwin.physics.simulator import simulate

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.fs=12000", "simulator.duration=0.1"])
    rough = {"roughness": {"rms_um": 0.1}}
    fast, _ = simulate("outer", cfg.bearing, cfg.simulator, rough)
    cfg.simulator.solver = "reference"
    reference, _ = simulate("outer", cfg.bearing, cfg.simulator, rough)
    smooth, _ = simulate("outer", cfg.bearing, cfg.simulator)
    assert np.corrcoef(fast.signal, reference.signal)[0, 1] > 0.99
    assert np.corrcoef(smooth.signal, reference.signal)[0, 1] < 0.95  # the roughness is in both, not lost


def test_noise_with_a_reference_rms_has_the_same_absolute_level_whatever_the_signal():
    """A sensor's noise floor: with ``reference_rms`` the SNR refers to it, not to each signal's own power."""
    t = np.arange(2**15) / FS
    quiet = np.sin(2 * np.pi * 50 * t) + 0.3 * np.random.default_rng(3).standard_normal(t.size)
    expected_rms = 0.8 * 10 ** (-6.0 / 20)
    for slope in (0.0, 1.0):
        effect = lib.Noise(snr_db=6.0, spectral_slope=slope, reference_rms=0.8)
        noise = [effect.modify_signal(x, FS, np.random.default_rng(4), SHAFT_HZ) - x for x in (quiet, 10 * quiet)]
        for n in noise:
            assert np.sqrt(np.mean(n**2)) == pytest.approx(expected_rms, rel=0.02)
        assert np.sqrt(np.mean(noise[1] ** 2)) == pytest.approx(np.sqrt(np.mean(noise[0] ** 2)), rel=1e-9)
    # Several signals at once (last axis = time): one absolute level for all rows ...
    both = np.stack([quiet, 10 * quiet])
    rows = lib.add_noise(both, FS, 6.0, 0.0, np.random.default_rng(5), reference_rms=0.8) - both
    np.testing.assert_allclose(np.sqrt(np.mean(rows**2, axis=1)), expected_rms, rtol=0.02)
    # ... while without it each row keeps its own SNR, so the louder signal gets ten times the noise.
    relative = lib.add_noise(both, FS, 6.0, 0.0, np.random.default_rng(5)) - both
    rms = np.sqrt(np.mean(relative**2, axis=1))
    assert rms[1] / rms[0] == pytest.approx(10.0, rel=0.02)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(BearingTwinError, match="noise.reference_rms"):
            lib.Noise(snr_db=6.0, spectral_slope=0.0, reference_rms=bad)
        with pytest.raises(BearingTwinError, match="noise.reference_rms"):
            lib.add_noise(quiet, FS, 6.0, 0.0, np.random.default_rng(0), reference_rms=bad)


def _cwru_config(duration_s, depth_mm=None):
    """The cwru_6205 twin at the CWRU rig's operating point: 12 kHz, 1772 rev/min, housing sensor."""
    from hydra import compose, initialize_config_dir

    overrides = ["bearing=cwru_6205", "simulator.fs=12000", "simulator.rpm=1772", "simulator.sensor=outer_y",
                 f"simulator.duration={duration_s}"]
    if depth_mm is not None:
        overrides.append(f"simulator.defect.depth_mm={depth_mm}")
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("simulate", overrides=overrides)


def _envelope_orders(cfg, signal):
    """Mean envelope-order features of 2048-sample windows, each normalised to zero mean and unit std."""
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures

    windows = signal[: signal.size // 2048 * 2048].reshape(-1, 2048)
    windows = (windows - windows.mean(axis=1, keepdims=True)) / windows.std(axis=1, keepdims=True)
    extractor = EnvelopeOrderFeatures(bearing=dict(cfg.bearing))
    features = extractor.fit_transform(windows, fs_hz=12000.0, rpm=1772.0)
    return dict(zip(extractor.feature_names_, features.mean(axis=0)))


CWRU_LOAD_ZONE = {"load_zone": {"radial_load_n": 1842.6, "clearance_um": 2.3}}


@pytest.mark.parametrize("radial_load_n, clearance_um", [(0.0, 20.0), (100.0, 0.0), (100.0, 20.0), (1842.6, 5.0)])
@pytest.mark.parametrize("interference_um", [1.0, 30.0, 100.0])
def test_static_equilibrium_is_found_under_any_preload(radial_load_n, clearance_um, interference_um):
    """A heavy preload under a light load once stalled the solver ("no static equilibrium found")."""
    cfg = _cwru_config(1.0)
    params = DynamicParameters.from_config(cfg.bearing, cfg.simulator)
    if radial_load_n:
        params = lib.LoadZone(radial_load_n=radial_load_n, clearance_um=clearance_um).modify_parameters(params)
    params = lib.Preload(interference_um=interference_um).modify_parameters(params)
    angles = 2 * np.pi * np.arange(params.n_balls) / params.n_balls
    state = static_equilibrium(params, angles)
    carried = contact_force(state, angles, np.zeros(params.n_balls), params)
    weight = params.inner_mass_kg * params.gravity_m_per_s2
    # The balls carry the load and the inner race's weight, less what its support takes.
    support = params.inner_stiffness_n_per_m * state[:2]
    np.testing.assert_allclose(carried + support, [params.load_x_n, params.load_y_n - weight], atol=1e-3)


def test_preload_keeps_every_ball_loaded_under_a_radial_load():
    cfg = _cwru_config(1.0)
    params = lib.LoadZone(radial_load_n=1842.6, clearance_um=5.0).modify_parameters(
        DynamicParameters.from_config(cfg.bearing, cfg.simulator))
    preloaded = lib.Preload(interference_um=30.0).modify_parameters(params)
    assert preloaded.clearance_m == pytest.approx(-30e-6) and preloaded.load_y_n == params.load_y_n
    angles = 2 * np.pi * np.arange(params.n_balls) / params.n_balls

    def ball_loads(p):
        state = static_equilibrium(p, angles)
        compression = (state[0] - state[2]) * np.cos(angles) + (state[1] - state[3]) * np.sin(angles) - p.clearance_m
        carried = contact_force(state, angles, np.zeros(p.n_balls), p)
        return compression, p.contact_stiffness_n_per_m1_5 * np.clip(compression, 0.0, None) ** 1.5, carried

    compression, _, carried = ball_loads(params)
    assert np.sum(compression <= 0) >= 3  # with clearance the upper balls carry nothing
    preloaded_compression, preloaded_loads, preloaded_carried = ball_loads(preloaded)
    assert np.all(preloaded_compression > 0)  # with preload every ball is compressed: a full-circle load zone
    assert preloaded_loads.min() > 0.3 * preloaded_loads.max()
    # The balls still carry the same radial load (plus the inner race's weight), shared out around the circle.
    np.testing.assert_allclose(preloaded_carried, carried, rtol=0.01, atol=1.0)
    assert -carried[1] == pytest.approx(1842.6 + params.inner_mass_kg * params.gravity_m_per_s2, rel=0.01)
    with pytest.raises(BearingTwinError, match="preload.interference_um"):
        lib.Preload(interference_um=0.0)
    with pytest.raises(BearingTwinError, match="preload.interference_um"):
        lib.Preload(interference_um=-5.0)


def test_preload_removes_the_shaft_rate_modulation_of_an_inner_race_fault():
    """An inner-race defect struck at every angle, not only in the load zone, has no shaft-rate sidebands."""
    from bearingtwin.physics.simulator import simulate

    cfg = _cwru_config(1.5, depth_mm=0.0007)
    preloaded_effects = {**CWRU_LOAD_ZONE, "preload": {"interference_um": 25.0}}  # after load_zone: replaces its clearance
    ratios = []
    for effects in (CWRU_LOAD_ZONE, preloaded_effects):
        recording, _ = simulate("inner", cfg.bearing, cfg.simulator, effects)
        f = _envelope_orders(cfg, recording.signal)
        ratios.append((f["1xbpfi-1x"] + f["1xbpfi+1x"]) / f["1xbpfi"])
    clearance_ratio, preload_ratio = ratios
    # Measured: 1.39 with clearance (deep modulation), 0.023 with 25 um preload.
    assert clearance_ratio > 0.7
    assert preload_ratio < 0.3


def test_spin_slip_random_walks_the_ball_spin_only():
    kinematics = rigid_kinematics(GEOMETRY, 1772.0, FS, 120000)
    slipped = lib.SpinSlip(jitter=0.2).modify_kinematics(kinematics, np.random.default_rng(0))
    for name in ("shaft_angle_rad", "shaft_speed_rad_s", "cage_angle_rad", "ball_offset_rad"):
        np.testing.assert_array_equal(getattr(slipped, name), getattr(kinematics, name))
    walk = slipped.ball_spin_angle_rad - kinematics.ball_spin_angle_rad
    assert walk[0] == 0.0 and np.abs(walk).max() > 2 * np.pi
    # Read at whole spin revolutions (the knots), the walk steps by jitter x 2 pi per revolution ...
    samples_per_revolution = FS / GEOMETRY.bsf_hz(1772.0)
    knots = walk[np.round(np.arange(int((walk.size - 1) / samples_per_revolution)) * samples_per_revolution).astype(int)]
    steps = np.diff(knots)
    assert steps.std() == pytest.approx(0.2 * 2 * np.pi, rel=0.1)
    # ... and wanders like a random walk (spread ~ sqrt(lag)), not a bounded jitter (spread independent of lag).
    assert 2.5 < (knots[16:] - knots[:-16]).std() / steps.std() < 6.0
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(BearingTwinError, match="spin_slip.jitter"):
            lib.SpinSlip(jitter=bad)


def test_spin_slip_smears_the_ball_fault_lines_and_keeps_the_cage_modulation():
    """A ball defect whose spin wanders loses its 2 x BSF rhythm; its trips through the load zone (FTF) stay."""
    from bearingtwin.physics.simulator import simulate

    cfg = _cwru_config(2.0, depth_mm=0.0007)
    rolling = _envelope_orders(cfg, simulate("ball", cfg.bearing, cfg.simulator, CWRU_LOAD_ZONE)[0].signal)
    family = ("1xbsf2", "2xbsf2", "3xbsf2")
    slipping = []
    for seed in (0, 1, 2):
        cfg.simulator.seed = seed
        recording, _ = simulate("ball", cfg.bearing, cfg.simulator, {**CWRU_LOAD_ZONE, "spin_slip": {"jitter": 0.2}})
        slipping.append(_envelope_orders(cfg, recording.signal))
    # Measured: 1xbsf2 0.081 rolling, 0.036 / 0.046 / 0.035 slipping (seeds 0-2); the 2 x BSF harmonics
    # together keep 0.30 / 0.37 / 0.30 of their share; 1xftf 0.069 rolling, 0.068-0.071 slipping.
    assert np.mean([f["1xbsf2"] for f in slipping]) < 0.6 * rolling["1xbsf2"]
    for f in slipping:
        assert f["1xbsf2"] < 0.75 * rolling["1xbsf2"]
        assert sum(f[name] for name in family) < 0.5 * sum(rolling[name] for name in family)
        assert f["1xftf"] == pytest.approx(rolling["1xftf"], rel=0.1)


# ---- the machine's lines, clipping and the second mode: sensor-path effects -------------------------------

SHAFT_ORDERS = np.arange(1, 21) / 2  # 0.5x ... 10x
ROUND_SHAFT_HZ = 30.0  # over 10 s every half order of it falls on a bin of the FFT


def _added_lines(effect, seed=2):
    """The lines ``effect`` adds to 10 s of unit white noise at ROUND_SHAFT_HZ, and their amplitudes at SHAFT_ORDERS."""
    x = np.random.default_rng(1).standard_normal(int(10 * FS))
    lines = effect.modify_signal(x, FS, np.random.default_rng(seed), ROUND_SHAFT_HZ) - x
    return lines, _line_amplitudes(lines, ROUND_SHAFT_HZ * SHAFT_ORDERS)


@pytest.mark.parametrize("name", SENSOR_ONLY)
def test_sensor_path_effects_cost_a_filter_not_a_simulation(name):
    """Effects that only override modify_signal are re-run on the twin's cached simulation."""
    from bearingtwin.physics.effects import Effect

    cls = _REGISTRY[name]
    assert cls.modify_parameters is Effect.modify_parameters and cls.modify_kinematics is Effect.modify_kinematics
    assert cls.modify_signal is not Effect.modify_signal


def test_unbalance_is_one_line_at_the_shaft_rate():
    lines, amplitudes = _added_lines(lib.Unbalance(level_db=-6.0))
    assert amplitudes[SHAFT_ORDERS == 1.0][0] == pytest.approx(math.sqrt(2) * 10 ** (-6 / 20), rel=0.02)
    assert amplitudes[SHAFT_ORDERS != 1.0].max() < 1e-3 * amplitudes.max()  # nothing at 2x, nor anywhere else
    assert np.sqrt(np.mean(lines**2)) == pytest.approx(10 ** (-6 / 20), rel=0.02)


def test_misalignment_puts_its_largest_line_at_twice_the_shaft_rate():
    _, amplitudes = _added_lines(lib.Misalignment(level_db=0.0, one_x_db=-6.0, three_x_db=-10.0))
    one, two, three = (amplitudes[SHAFT_ORDERS == k][0] for k in (1.0, 2.0, 3.0))
    assert two > one > three > 0.1 * two
    assert 20 * np.log10([one / two, three / two]) == pytest.approx([-6.0, -10.0], abs=0.2)
    assert amplitudes[SHAFT_ORDERS > 3].max() < 1e-3 * two


def test_looseness_is_a_comb_of_shaft_harmonics_with_half_orders():
    _, amplitudes = _added_lines(lib.Looseness(level_db=0.0, half_order_db=-6.0, n_harmonics=10, decay_db_per_order=1.0))
    level_db = 20 * np.log10(amplitudes / (math.sqrt(2)))
    integer, half = SHAFT_ORDERS % 1 == 0, SHAFT_ORDERS % 1 != 0
    np.testing.assert_allclose(level_db[integer], -(SHAFT_ORDERS[integer] - 1), atol=0.2)  # 1 dB per order
    assert level_db[SHAFT_ORDERS == 0.5][0] == pytest.approx(-6.0, abs=0.2)
    assert level_db[SHAFT_ORDERS == 1.5][0] == pytest.approx(-6.0 - 0.5, abs=0.2)
    np.testing.assert_allclose(level_db[half], -6.0 - np.maximum(SHAFT_ORDERS[half] - 1, 0), atol=0.2)


def test_line_frequency_puts_its_largest_line_at_twice_the_supply():
    effect = lib.LineFrequency(supply_hz=50.0, level_db=0.0, fundamental_db=-12.0, n_harmonics=3)
    x = np.random.default_rng(1).standard_normal(int(10 * FS))
    lines = effect.modify_signal(x, FS, np.random.default_rng(2), SHAFT_HZ) - x
    spectrum = np.abs(np.fft.rfft(lines)) * 2 / lines.size
    freqs = np.fft.rfftfreq(lines.size, 1 / FS)
    assert freqs[np.argmax(spectrum)] == pytest.approx(100.0, abs=0.1)
    amplitudes = _line_amplitudes(lines, [50.0, 100.0, 200.0, 300.0])
    np.testing.assert_allclose(amplitudes / amplitudes[1], [10 ** (-12 / 20), 1.0, 1 / 2, 1 / 3], rtol=0.02)


def test_clipping_caps_the_signal_and_flattens_its_impacts():
    rng = np.random.default_rng(0)
    impulsive = rng.standard_normal(24000) * 0.2
    impulsive[::400] += 8.0  # impacts: kurtosis far above 3
    clipped = lib.Clipping(clip_level=3.0).modify_signal(impulsive, FS, rng, SHAFT_HZ)
    rms = np.sqrt(np.mean(impulsive**2))
    assert np.abs(clipped).max() == pytest.approx(3.0 * rms)
    untouched = np.abs(impulsive) < 3.0 * rms
    np.testing.assert_array_equal(clipped[untouched], impulsive[untouched])

    def kurtosis(x):
        return np.mean((x - x.mean()) ** 4) / np.var(x) ** 2

    def crest(x):
        return np.abs(x).max() / np.sqrt(np.mean(x**2))

    assert kurtosis(clipped) < 0.5 * kurtosis(impulsive) and crest(clipped) < 0.5 * crest(impulsive)
    batch = lib.clip_at_rms(np.stack([impulsive, 10 * impulsive]), 3.0)  # per signal: scale-free
    np.testing.assert_allclose(batch[1], 10 * batch[0])


def test_second_resonance_adds_a_band_around_its_frequency_and_needs_the_first():
    assert lib.SecondResonance.requires == ("resonance",) and lib.Resonance.requires == ()
    assert all(_REGISTRY[name].requires == () for name in LIBRARY if name != "second_resonance")
    x = np.random.default_rng(0).standard_normal(24000)
    one = lib.Resonance(natural_frequency_hz=3000.0, damping_ratio=0.05).modify_signal(x, FS, None, SHAFT_HZ)
    two = lib.SecondResonance(natural_frequency_hz=1200.0, damping_ratio=0.05).modify_signal(one, FS, None, SHAFT_HZ)
    freqs, psd = sps.welch(np.stack([one, two]), FS, nperseg=1024)
    band = np.abs(freqs - 1200.0) < 100.0
    gain_db = 10 * np.log10(psd[1, band].sum() / psd[0, band].sum())
    assert gain_db > 10.0  # ~ 1 / (2 zeta) = 10 in amplitude at the peak
    np.testing.assert_allclose(two, lib.base_excitation_filter(one, FS, 1200.0, 0.05))  # the same filter


def test_a_structural_mode_raises_its_band_and_leaves_the_rest_of_the_spectrum():
    """Beside the direct path (unlike ``resonance``, a mount in series): the power ratio is
    (1 + g)^2 at the natural frequency, 1 an octave and more away; the guess reads f_n, zeta, g."""
    x = np.random.default_rng(0).standard_normal(48000)
    mode = lib.StructuralMode(natural_frequency_hz=2000.0, damping_ratio=0.03, level_db=20.0)
    y = mode.modify_signal(x, FS, None, SHAFT_HZ)
    freqs, psd = sps.welch(np.stack([x, y]), FS, nperseg=1200)
    ratio_db = 10 * np.log10(psd[1] / psd[0])
    at = np.argmin(np.abs(freqs - 2000.0))
    assert ratio_db[at] == pytest.approx(20 * np.log10(11.0), abs=1.5)
    far = (freqs < 1000.0) | ((freqs > 4000.0) & (freqs < 0.45 * FS))
    assert np.all(np.abs(ratio_db[far]) < 1.0)
    series = lib.Resonance(natural_frequency_hz=2000.0, damping_ratio=0.03).modify_signal(x, FS, None, SHAFT_HZ)
    _, series_psd = sps.welch(series, FS, nperseg=1200)
    assert 10 * np.log10(series_psd[freqs > 4000.0] / psd[0, freqs > 4000.0]).mean() < -6.0  # the mount rolls off
    guess = lib.StructuralMode.initial_guess(y, x, FS, SHAFT_HZ)
    assert guess["natural_frequency_hz"] == pytest.approx(2000.0, rel=0.05)
    assert 0.015 <= guess["damping_ratio"] <= 0.06  # within a factor 2: the ratio is smoothed over 250 Hz
    assert guess["level_db"] == pytest.approx(20.0, abs=6.0)  # a start for the search: smoothing lowers the peak
    assert lib.StructuralMode.initial_guess(x, x, FS, SHAFT_HZ) is None  # nothing raised: no mode to read


@pytest.mark.parametrize("mode", [lib.Resonance(natural_frequency_hz=12000.0, damping_ratio=0.03),
                                  lib.StructuralMode(natural_frequency_hz=12000.0, damping_ratio=0.03, level_db=20.0)])
def test_a_mode_above_a_few_khz_is_read_where_it_rings_on_a_fast_record(mode):
    """A mount ringing at 12 kHz on a 48 kHz record: the first guess reads it there, not at the top of a box a
    slower rate would need (the search reaches 0.45 fs)."""
    fs = 48000.0
    x = np.random.default_rng(2).standard_normal(int(fs))
    guess = type(mode).initial_guess(mode.modify_signal(x, fs, None, SHAFT_HZ), x, fs, SHAFT_HZ)
    assert guess["natural_frequency_hz"] == pytest.approx(12000.0, rel=0.02)
    assert 0.015 <= guess["damping_ratio"] <= 0.06


def test_line_effects_are_deterministic_under_a_seeded_rng():
    x = np.random.default_rng(1).standard_normal(12000)
    for name in ("tones", "unbalance", "misalignment", "looseness", "line_frequency", "noise"):
        (effect,) = build_effects({name: _yaml(name)[name]})
        first, again, other = (effect.modify_signal(x, FS, np.random.default_rng(seed), SHAFT_HZ) for seed in (5, 5, 6))
        np.testing.assert_array_equal(first, again)
        assert not np.array_equal(first, other), name  # random phases (or noise) follow the seed


def test_new_effects_name_the_bad_field():
    bad = [
        (lambda: lib.Tones([100.0], [0.0, -3.0]), "tones.levels_db"),
        (lambda: lib.Tones([-5.0], [0.0]), "tones.frequencies_hz"),
        (lambda: lib.Tones([100.0], [float("nan")]), "tones.levels_db"),
        (lambda: lib.Tones([100.0], [0.0], level_offset_db=float("inf")), "tones.level_offset_db"),
        (lambda: lib.Unbalance(level_db=float("nan")), "unbalance.level_db"),
        (lambda: lib.Misalignment(level_db=0.0, one_x_db=3.0), "misalignment.one_x_db"),
        (lambda: lib.Misalignment(level_db=0.0, three_x_db=1.0), "misalignment.three_x_db"),
        (lambda: lib.Looseness(level_db=0.0, n_harmonics=0), "looseness.n_harmonics"),
        (lambda: lib.Looseness(level_db=0.0, decay_db_per_order=-1.0), "looseness.decay_db_per_order"),
        (lambda: lib.LineFrequency(supply_hz=0.0, level_db=0.0), "line_frequency.supply_hz"),
        (lambda: lib.LineFrequency(supply_hz=50.0, level_db=0.0, fundamental_db=3.0), "line_frequency.fundamental_db"),
        (lambda: lib.LineFrequency(supply_hz=50.0, level_db=0.0, n_harmonics=1.5), "line_frequency.n_harmonics"),
        (lambda: lib.Clipping(clip_level=0.0), "clipping.clip_level"),
        (lambda: lib.SecondResonance(natural_frequency_hz=1000.0, damping_ratio=-0.1), "second_resonance.damping_ratio"),
        (lambda: lib.SecondResonance(natural_frequency_hz=7000.0, damping_ratio=0.05).modify_signal(
            np.ones(100), FS, None, SHAFT_HZ), "second_resonance.natural_frequency_hz"),
        (lambda: lib.Unbalance(level_db=0.0).modify_signal(np.ones(100), FS, None, 0.0), "shaft_hz"),
    ]
    for make, field in bad:
        with pytest.raises(BearingTwinError, match=field.replace(".", r"\.")):
            make()
    with pytest.raises(BearingTwinError, match="effects.tones: bad parameters"):  # the old single-family form
        build_effects({"tones": {"frequency_hz": 60.0, "level_db": 0.0, "n_harmonics": 3}})


# ---- starting points read off a measurement ------------------------------------------------------------------


def _bearing_like(seed, seconds=2.0):
    """A stand-in for a twin's signal: a resonance ringing under noise, with impacts at 107 Hz."""
    rng = np.random.default_rng(seed)
    x = 0.3 * rng.standard_normal(int(seconds * FS))
    x[:: int(FS / 107.0)] += 4.0
    return lib.base_excitation_filter(x, FS, 3000.0, 0.05)


def test_tones_guess_finds_three_hidden_lines_and_leaves_the_other_effects_lines():
    twin, base = _bearing_like(0), _bearing_like(1)  # two realizations: the twin is not the measurement
    frequencies_hz, levels_db = [137.3, 263.7, 611.1], [-6.0, -10.0, -14.0]
    hidden = lib.Tones(frequencies_hz, levels_db).modify_signal(base, FS, np.random.default_rng(3), SHAFT_HZ)
    # Lines the other effects explain: unbalance (1x), looseness (a series of half orders), the 2 x 60 Hz pull.
    hidden = lib.add_lines(hidden, FS, [SHAFT_HZ, 120.0], [-6.0, -6.0], np.random.default_rng(4))
    hidden = lib.Looseness(-10.0, half_order_db=-3.0).modify_signal(hidden, FS, np.random.default_rng(6), SHAFT_HZ)
    guess = lib.Tones.initial_guess(hidden, twin, FS, SHAFT_HZ)
    assert json.loads(json.dumps(guess)) == guess  # a plain dict: it goes into a report as it is
    bin_hz = lib.LINE_RESOLUTION_HZ
    assert len(guess["frequencies_hz"]) == 3
    np.testing.assert_allclose(guess["frequencies_hz"], frequencies_hz, atol=bin_hz)
    np.testing.assert_allclose(guess["levels_db"], levels_db, atol=2.0)
    assert guess["level_offset_db"] == 0.0
    assert lib.Tones.initial_guess(base, twin, FS, SHAFT_HZ)["frequencies_hz"] == []  # nothing hidden: no lines
    (effect,) = build_effects({"tones": guess})
    assert effect.frequencies_hz == guess["frequencies_hz"]


def test_a_lone_shaft_order_is_a_tone_but_an_order_in_a_rattles_series_is_not():
    """A fan's blade pass stands at a whole shaft order (here 7x) with no comb around it: no machine effect
    makes such a line, so ``tones`` takes it; the same order inside looseness's series is looseness's."""
    twin, base = _bearing_like(0), _bearing_like(1)
    blade_pass = lib.add_lines(base, FS, [7 * SHAFT_HZ], [-6.0], np.random.default_rng(4))
    guess = lib.Tones.initial_guess(blade_pass, twin, FS, SHAFT_HZ)
    np.testing.assert_allclose(guess["frequencies_hz"], [7 * SHAFT_HZ], atol=lib.LINE_RESOLUTION_HZ)
    rattle = lib.Looseness(-10.0, half_order_db=-3.0).modify_signal(base, FS, np.random.default_rng(4), SHAFT_HZ)
    assert lib.Tones.initial_guess(rattle, twin, FS, SHAFT_HZ)["frequencies_hz"] == []
    # A lone 1x, 2x or 3x line is unbalance's or misalignment's, series or not.
    for order in (1, 2, 3):
        lone = lib.add_lines(base, FS, [order * SHAFT_HZ], [-6.0], np.random.default_rng(4))
        assert lib.Tones.initial_guess(lone, twin, FS, SHAFT_HZ)["frequencies_hz"] == []


def test_tones_guess_closes_the_gap_the_lines_open():
    """The motivating failure: with the guessed lines the twin matches a measurement with extra tones."""
    from bearingtwin.data.recording import Recording
    from bearingtwin.twin.compare import Comparator

    twin, base = _bearing_like(0), _bearing_like(1)
    hidden = lib.Tones([137.3, 263.7, 611.1], [0.0, -4.0, -8.0]).modify_signal(base, FS, np.random.default_rng(3),
                                                                                SHAFT_HZ)
    comparator = Comparator(Recording(hidden, FS, 60 * SHAFT_HZ, "normal"), GEOMETRY)
    guess = lib.Tones.initial_guess(hidden, twin, FS, SHAFT_HZ)
    with_lines = lib.Tones(**guess).modify_signal(twin, FS, np.random.default_rng(5), SHAFT_HZ)
    before, after = comparator(twin).views["psd"].error_db, comparator(with_lines).views["psd"].error_db
    assert after < 0.5 * before


@pytest.mark.parametrize("level_db", [-12.0, 0.0])
def test_unbalance_guess_reads_the_shaft_line_level(level_db):
    twin, base = _bearing_like(0), _bearing_like(1)
    measured = lib.Unbalance(level_db).modify_signal(base, FS, np.random.default_rng(3), SHAFT_HZ)
    assert lib.Unbalance.initial_guess(measured, twin, FS, SHAFT_HZ)["level_db"] == pytest.approx(level_db, abs=2.0)
    # Without the line, the guess is the search space's floor: the unbalance the data leave room for.
    assert lib.Unbalance.initial_guess(base, twin, FS, SHAFT_HZ)["level_db"] < -25.0


def test_misalignment_and_looseness_guesses_read_their_lines():
    twin, base = _bearing_like(0), _bearing_like(1)
    misaligned = lib.Misalignment(-4.0, one_x_db=-8.0, three_x_db=-12.0).modify_signal(
        base, FS, np.random.default_rng(3), SHAFT_HZ)
    guess = lib.Misalignment.initial_guess(misaligned, twin, FS, SHAFT_HZ)
    assert [guess[k] for k in ("level_db", "one_x_db", "three_x_db")] == pytest.approx([-4.0, -8.0, -12.0], abs=2.0)
    loose = lib.Looseness(-8.0, half_order_db=-6.0).modify_signal(base, FS, np.random.default_rng(3), SHAFT_HZ)
    guess = lib.Looseness.initial_guess(loose, twin, FS, SHAFT_HZ)
    assert [guess["level_db"], guess["half_order_db"]] == pytest.approx([-8.0, -6.0], abs=2.0)
    assert guess["decay_db_per_order"] == pytest.approx(1.0, abs=0.5)
    # A rattle of longer impacts: a comb falling 4 dB per order, read off the lines as such.
    steep = lib.Looseness(0.0, half_order_db=-3.0, decay_db_per_order=4.0).modify_signal(
        base, FS, np.random.default_rng(4), SHAFT_HZ)
    guess = lib.Looseness.initial_guess(steep, twin, FS, SHAFT_HZ)
    assert guess["decay_db_per_order"] == pytest.approx(4.0, abs=1.0)
    assert [guess["level_db"], guess["half_order_db"]] == pytest.approx([0.0, -3.0], abs=2.0)
    # Misalignment's lines stand at whole orders only: no half order, so the comb keeps its default fall.
    assert lib.Looseness.initial_guess(misaligned, twin, FS, SHAFT_HZ)["decay_db_per_order"] == 1.0


@pytest.mark.parametrize("supply_hz", [50.0, 59.7])
def test_line_frequency_guess_finds_the_supply(supply_hz):
    twin, base = _bearing_like(0), _bearing_like(1)
    measured = lib.LineFrequency(supply_hz, -3.0, fundamental_db=-10.0).modify_signal(
        base, FS, np.random.default_rng(3), SHAFT_HZ)
    guess = lib.LineFrequency.initial_guess(measured, twin, FS, SHAFT_HZ)
    assert guess["supply_hz"] == pytest.approx(supply_hz, abs=0.5)
    assert guess["level_db"] == pytest.approx(-3.0, abs=2.0) and guess["fundamental_db"] == pytest.approx(-10.0, abs=2.0)


def test_line_frequency_guess_of_an_absent_supply_line_makes_it_weakest():
    """No supply line to read: the 2 f_s level sits at the search range's floor and the f_s line
    is as weak as its ratio goes (two floors read as equal lines would say 0 dB)."""
    twin = _bearing_like(0)
    guess = lib.LineFrequency.initial_guess(twin, twin, FS, SHAFT_HZ)  # the measurement adds nothing
    assert guess["level_db"] == lib.LineFrequency.search_space["level_db"][0]
    assert guess["fundamental_db"] == lib.FUNDAMENTAL_FLOOR_DB


def test_guesses_are_gain_free_and_build_their_effect():
    """A guess reads levels relative to the twin, so a sensor gain on both leaves it unchanged."""
    from bearingtwin.physics.effects import Effect

    twin, base = _bearing_like(0), _bearing_like(1)
    measured = lib.Misalignment(-4.0).modify_signal(base, FS, np.random.default_rng(3), SHAFT_HZ)
    for name in ("tones", "unbalance", "misalignment", "looseness", "line_frequency"):
        cls = _REGISTRY[name]
        guess = cls.initial_guess(measured, twin, FS, SHAFT_HZ)
        scaled = cls.initial_guess(measured / 9.81, twin / 9.81, FS, SHAFT_HZ)
        assert scaled == pytest.approx(guess), name
        assert set(guess) <= set(_yaml(name)[name])
        build_effects({name: {**_yaml(name)[name], **guess}})
    assert Effect.initial_guess(measured, twin, FS, SHAFT_HZ) is None
    assert lib.Resonance.initial_guess(measured, twin, FS, SHAFT_HZ) is None


def test_resonance_guess_finds_a_hidden_mode_and_its_width():
    rng = np.random.default_rng(3)
    twin = rng.standard_normal(int(2 * FS))
    measured = lib.base_excitation_filter(twin, FS, 2400.0, 0.05)
    guess = lib.Resonance.initial_guess(3.0 * measured, twin, FS, 29.95)  # any gain
    assert abs(guess["natural_frequency_hz"] - 2400.0) <= 50.0  # one 50 Hz bin
    assert 0.03 <= guess["damping_ratio"] <= 0.08
    assert lib.Resonance.initial_guess(2.0 * twin, twin, FS, 29.95) is None  # a gain is no mode
    assert lib.SecondResonance.initial_guess.__func__ is lib.Resonance.initial_guess.__func__


@pytest.mark.parametrize("effects, message", [
    ({"noise": {"snr_db": -1e6, "spectral_slope": 0.0}}, "effects.noise.snr_db must lie within +-300 dB, got -1000000.0"),
    ({"structural_mode": {"natural_frequency_hz": 2000.0, "damping_ratio": 0.05, "level_db": 1e6}},
     "effects.structural_mode.level_db must lie within +-300 dB"),
    ({"tones": {"frequencies_hz": [100.0], "levels_db": [1e6]}}, "effects.tones.levels_db must lie within +-300 dB"),
])
def test_a_level_no_float_can_hold_is_refused_when_the_effect_is_built(effects, message):
    """1e6 dB overflowed (an OverflowError or a record of NaNs) only after the whole simulation."""
    with pytest.raises(BearingTwinError, match=re.escape(message)):
        build_effects(effects)
