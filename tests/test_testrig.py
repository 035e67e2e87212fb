"""The independent test rig: its kinematics, load zone, sensor direction and every effect's signature."""

import ast
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import signal as sps
from scipy.stats import kurtosis

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.testrig import OUT_OF_LIBRARY, RIG_EFFECTS, RigBearing, RigOperatingPoint, simulate_rig
from bearingtwin.testrig.loadzone import load_zone
from bearingtwin.testrig.path import RigPath, strike_spectrum

FS = 12000.0
RPM = 1797.0
OP = RigOperatingPoint(rpm=RPM, fs=FS, duration_s=2.0)
FREQS = RigBearing().frequencies_hz(RPM)
SHAFT = FREQS["shaft"]
TWIN_LIBRARY = ("resonance", "slip", "speed_fluctuation", "noise", "tones", "lubrication", "unbalance",
                "misalignment", "looseness", "line_frequency", "clipping", "second_resonance")


def rig(fault="outer", effects=None, seed=0, **op_fields):
    op = RigOperatingPoint(**{**OP.__dict__, **op_fields})
    return simulate_rig(fault=fault, operating_point=op, effects=effects, seed=seed)


def envelope_spectrum(x, fs=FS):
    """Hann-windowed amplitude spectrum of the Hilbert envelope (mean removed)."""
    env = np.abs(sps.hilbert(x))
    window = np.hanning(x.size)
    return np.fft.rfftfreq(x.size, 1.0 / fs), 2.0 * np.abs(np.fft.rfft((env - env.mean()) * window)) / window.sum()


def peak(freqs, amplitude, target_hz, tolerance_hz=1.0):
    return amplitude[np.abs(freqs - target_hz) <= tolerance_hz].max()


def line(x, frequency_hz, fs=FS):
    """Amplitude of the sinusoid at ``frequency_hz`` in ``x`` (Hann-windowed single-frequency DFT)."""
    window = np.hanning(x.size)
    phasor = np.exp(-2j * np.pi * frequency_hz * np.arange(x.size) / fs)
    return 2.0 * abs(np.sum(window * x * phasor)) / window.sum()


def band_power(x, low_hz, high_hz, fs=FS):
    freqs, psd = sps.welch(x, fs, nperseg=2048)
    return psd[(freqs >= low_hz) & (freqs <= high_hz)].sum()


def rms(x):
    return float(np.sqrt(np.mean(x**2)))


# ---------------------------------------------------------------- kinematics


def test_defect_frequencies_are_the_textbook_formulas():
    bearing = RigBearing(contact_angle_deg=15.0)
    fn, ratio = RPM / 60.0, 7.94 / 39.04 * math.cos(math.radians(15.0))
    got = bearing.frequencies_hz(RPM)
    assert got["shaft"] == pytest.approx(fn, rel=1e-12)
    assert got["ftf"] == pytest.approx(fn / 2 * (1 - ratio), rel=1e-12)
    assert got["bpfo"] == pytest.approx(9 / 2 * fn * (1 - ratio), rel=1e-12)
    assert got["bpfi"] == pytest.approx(9 / 2 * fn * (1 + ratio), rel=1e-12)
    assert got["bsf"] == pytest.approx(39.04 / (2 * 7.94) * fn * (1 - ratio**2), rel=1e-12)
    # Rolling without slip: the contact point sweeps the outer race at the cage rate times its radius.
    outer_contact_radius_m = (39.04 + 7.94 * math.cos(math.radians(15.0))) / 2000
    assert bearing.rolling_speed_m_s(fn) == pytest.approx(2 * math.pi * got["ftf"] * outer_contact_radius_m)


@pytest.mark.parametrize("changes, message", [
    ({"n_balls": 2}, "bearing.n_balls must be an integer of at least 3, got 2"),
    ({"n_balls": 40}, "bearing.n_balls=40 balls of bearing.ball_diameter_mm=7.94 overlap on bearing.pitch_diameter_mm=39.04"),
])
def test_the_rig_refuses_balls_that_cannot_be_as_the_twin_does(changes, message):
    """One check for both: the rig's bearing and the twin's refuse the same balls in the same words."""
    with pytest.raises(BearingTwinError) as rig:
        RigBearing(**changes)
    with pytest.raises(BearingTwinError) as twin:
        BearingGeometry(**{"outer_diameter_mm": 100.0, "inner_diameter_mm": 1.0, "ball_diameter_mm": 7.94,
                           "pitch_diameter_mm": 39.04, "n_balls": 9, **changes})
    assert str(rig.value).startswith(message) and str(twin.value) == str(rig.value)


@pytest.mark.parametrize("contact_angle_deg", [0.0, 15.0])
def test_defect_frequencies_agree_with_the_twins_geometry(contact_angle_deg):
    twin = BearingGeometry(52.0, 25.0, 7.94, 39.04, 9, contact_angle_deg=contact_angle_deg).defect_frequencies(RPM)
    ours = RigBearing(contact_angle_deg=contact_angle_deg).frequencies_hz(RPM)
    for name in ("shaft", "ftf", "bpfo", "bpfi", "bsf"):
        assert ours[name] == pytest.approx(twin[name], rel=1e-9)


# ---------------------------------------------------------------- defect signatures


def test_outer_race_envelope_peaks_at_bpfo():
    freqs, amp = envelope_spectrum(rig("outer"))
    band = (freqs > 5) & (freqs < 500)
    assert freqs[band][np.argmax(amp[band])] == pytest.approx(FREQS["bpfo"], abs=0.5)


def test_inner_race_envelope_has_bpfi_with_shaft_rate_sidebands():
    freqs, amp = envelope_spectrum(rig("inner"))
    floor = np.median(amp[(freqs > 5) & (freqs < 600)])
    assert peak(freqs, amp, FREQS["bpfi"]) > 20 * floor
    for side in (-1, 1):
        assert peak(freqs, amp, FREQS["bpfi"] + side * SHAFT) > 10 * floor
    # The load zone turns with the defect: the envelope carries the shaft rate itself.
    assert peak(freqs, amp, SHAFT) > 20 * floor


def test_ball_envelope_has_two_bsf_with_cage_rate_sidebands():
    freqs, amp = envelope_spectrum(rig("ball"))
    floor = np.median(amp[(freqs > 5) & (freqs < 600)])
    two_bsf = 2 * FREQS["bsf"]
    assert peak(freqs, amp, two_bsf) > 20 * floor
    for side in (-1, 1):
        assert peak(freqs, amp, two_bsf + side * FREQS["ftf"]) > 10 * floor
    # Outer- and inner-race strikes alternate with unequal strength: BSF itself shows.
    assert peak(freqs, amp, FREQS["bsf"]) > 10 * floor


def test_healthy_bearing_has_no_defect_lines():
    freqs, amp = envelope_spectrum(rig("normal"))
    floor = np.median(amp[(freqs > 5) & (freqs < 600)])
    for name in ("bpfo", "bpfi"):
        assert peak(freqs, amp, FREQS[name]) < 6 * floor
    assert rms(rig("normal")) < rms(rig("outer")) / 5


# ---------------------------------------------------------------- load zone and sensor direction


def test_zero_clearance_gives_stribecks_constant_and_a_half_circle():
    zone = load_zone(RigBearing(), 1000.0, 0.0)
    assert zone.epsilon == pytest.approx(0.5)
    assert math.degrees(zone.half_angle_rad) == pytest.approx(90.0)
    assert zone.max_ball_load_n == pytest.approx(4.37 * 1000.0 / 9, rel=2e-3)  # Stribeck: Q_max = 4.37 Fr / Z


def test_the_twins_clearance_is_the_gap_per_ball_half_the_rigs_catalogue_play():
    """The twin's contact law subtracts its clearance from every ball's deflection (the paper's c_d, Harris's Pd/2);
    the rig takes the catalogue's radial internal clearance (the total play) and subtracts half of it. The two
    formulations' static load zones agree when the twin is given half the rig's clearance, and differ when it is
    given the same number."""
    from dataclasses import replace

    from bearingtwin.config import compose_config
    from bearingtwin.physics.dynamics import DynamicParameters, static_equilibrium

    cfg = compose_config("simulate", ["bearing=cwru_6205", "simulator.gravity_m_per_s2=0"])
    twin = DynamicParameters.from_config(cfg.bearing, cfg.simulator)
    rig = RigBearing(contact_stiffness_n_per_m1_5=twin.contact_stiffness_n_per_m1_5)
    balls = math.radians(270.0) + 2.0 * math.pi * np.arange(9) / 9  # one ball under the load

    def twin_half_angle_deg(load_n: float, clearance_um: float) -> float:
        params = replace(twin, load_y_n=-load_n, clearance_m=clearance_um * 1e-6, inner_stiffness_n_per_m=0.0)
        state = static_equilibrium(params, balls)
        return math.degrees(math.acos(params.clearance_m / math.hypot(state[0] - state[2], state[1] - state[3])))

    for load_n, play_um in ((500.0, 6.0), (2000.0, 20.0)):
        rig_deg = math.degrees(load_zone(rig, load_n, play_um).half_angle_rad)
        assert twin_half_angle_deg(load_n, play_um / 2.0) == pytest.approx(rig_deg, abs=0.5)
        assert twin_half_angle_deg(load_n, play_um) < rig_deg - 4.0


def test_load_widens_and_clearance_narrows_the_load_zone():
    bearing = RigBearing()
    half_angles_by_load = [load_zone(bearing, load, 20.0).half_angle_rad for load in (200.0, 1000.0, 5000.0)]
    half_angles_by_clearance = [load_zone(bearing, 500.0, c).half_angle_rad for c in (5.0, 20.0, 60.0)]
    assert half_angles_by_load == sorted(half_angles_by_load) and half_angles_by_load[0] < half_angles_by_load[-1]
    assert half_angles_by_clearance == sorted(half_angles_by_clearance, reverse=True)
    assert half_angles_by_clearance[0] > half_angles_by_clearance[-1]
    zone = load_zone(bearing, 500.0, 20.0)
    assert zone.ball_load_n(zone.half_angle_rad + 0.01) == 0.0 and zone.ball_load_n(0.0) == zone.max_ball_load_n


def sideband_ratio(**op_fields):
    """Shaft-rate sidebands (orders 1-3, both sides) over the BPFI line in an inner-race envelope."""
    freqs, amp = envelope_spectrum(rig("inner", **op_fields))
    sidebands = sum(peak(freqs, amp, FREQS["bpfi"] + k * SHAFT) for k in (-3, -2, -1, 1, 2, 3))
    return sidebands / peak(freqs, amp, FREQS["bpfi"])


def test_more_load_means_more_balls_loaded_and_weaker_inner_race_sidebands():
    ratios = [sideband_ratio(radial_load_n=load, clearance_um=20.0) for load in (200.0, 1000.0, 5000.0)]
    assert ratios[0] > ratios[1] > ratios[2]
    assert ratios[2] < 0.8 * ratios[0]


def test_more_clearance_narrows_the_zone_and_strengthens_inner_race_sidebands():
    ratios = [sideband_ratio(clearance_um=clearance) for clearance in (2.0, 20.0, 80.0)]
    assert ratios[0] < ratios[1] < ratios[2]
    assert ratios[2] > 1.2 * ratios[0]


def test_sensor_sees_the_projection_of_load_zone_impacts_on_its_axis():
    levels = [rms(rig("outer", sensor_angle_deg=angle)) for angle in (0.0, 30.0, 60.0, 90.0)]
    assert levels == sorted(levels)
    assert levels[-1] > 3 * levels[0]
    # A defect 30 deg off the zone's centre is struck along 120 deg: a sensor on that line
    # reads more than one across it.
    aligned = rms(rig("outer", defect_angle_deg=30.0, sensor_angle_deg=120.0))
    across = rms(rig("outer", defect_angle_deg=30.0, sensor_angle_deg=30.0))
    assert aligned > 1.5 * across  # not zero across: the housing is stiffer vertically than horizontally


def test_a_deeper_spall_strikes_harder():
    assert rms(rig("outer", defect_depth_mm=0.002)) < 0.5 * rms(rig("outer", defect_depth_mm=0.1))


def test_a_strike_sheds_load_at_the_leading_edge_and_impacts_at_the_trailing_edge():
    fs, n, crossing_s, impact_s = 192000.0, 19200, 1.2e-3, 40e-6
    force = np.fft.irfft(fs * strike_spectrum(np.fft.rfftfreq(n, 1 / fs), crossing_s, 0.4e-3, impact_s, 2.0), n)
    t = np.arange(n) / fs
    t = np.where(t > n / fs / 2, t - n / fs, t)  # circular: negative times at the end
    assert t[np.argmax(force)] == pytest.approx(crossing_s, abs=1 / fs)
    assert force[(t > 0.4e-3) & (t < 0.9e-3)].mean() == pytest.approx(-1.0, abs=1e-3)  # the whole load shed
    assert np.abs(force[t < -0.25e-3]).max() < 1e-3  # nothing before the ball reaches the spall
    assert force.sum() / fs == pytest.approx(-crossing_s + 2.0 * 2 * impact_s / math.pi, rel=1e-6)


def test_the_path_rings_at_the_housing_and_mount_modes_and_the_contact_stiffens_with_load():
    path = RigPath()
    freqs = np.arange(100.0, 6000.0, 1.0)
    _, from_y = path.sensor_frf(freqs, math.pi / 2)  # vertical sensor, vertical force
    gain = np.abs(from_y)
    maxima = freqs[1:-1][(gain[1:-1] > gain[:-2]) & (gain[1:-1] > gain[2:])]
    assert len(maxima) == 2
    assert maxima[0] == pytest.approx(path.housing_y_hz, rel=0.1)
    assert maxima[1] == pytest.approx(path.mount_hz, rel=0.1)
    stiffness = [load_zone(RigBearing(), load, 10.0).radial_stiffness_n_per_m for load in (200.0, 2000.0)]
    assert path.contact_ringing_hz(stiffness[1]) > path.contact_ringing_hz(stiffness[0])


# ---------------------------------------------------------------- effects


def test_effect_catalogue():
    assert set(TWIN_LIBRARY) | set(OUT_OF_LIBRARY) == set(RIG_EFFECTS)
    assert not set(TWIN_LIBRARY) & set(OUT_OF_LIBRARY) and len(OUT_OF_LIBRARY) >= 3


@pytest.mark.parametrize("name", list(RIG_EFFECTS))
def test_every_effect_changes_the_record_with_its_defaults_and_is_deterministic(name):
    base = rig("inner")
    first, second = rig("inner", effects={name: {}}), rig("inner", effects={name: RIG_EFFECTS[name]})
    assert first.shape == base.shape and np.all(np.isfinite(first))
    np.testing.assert_array_equal(first, second)
    assert rms(first - base) > 0.01 * rms(base)


def test_unbalance_adds_a_line_at_exactly_the_shaft_rate():
    base, unbalanced = rig("outer"), rig("outer", effects={"unbalance": {"level_db": 0.0}})
    added = unbalanced - base
    assert line(added, SHAFT) == pytest.approx(math.sqrt(2) * rms(base), rel=0.02)
    assert line(added, 2 * SHAFT) < 0.01 * line(added, SHAFT)
    assert line(unbalanced, SHAFT) > 5 * line(base, SHAFT)  # the residual 1x line sits 20 dB lower


def test_misalignment_2x_exceeds_1x_and_3x():
    x = rig("outer", effects={"misalignment": {}})
    one, two, three = (line(x, k * SHAFT) for k in (1, 2, 3))
    assert two > one > three and two > 1.5 * one


def test_looseness_has_half_order_and_many_integer_harmonics():
    base, loose = rig("normal"), rig("normal", effects={"looseness": {}})
    for order in (0.5, 1.5, 2.5):
        assert line(loose, order * SHAFT) > 3 * line(base, order * SHAFT)
    raised = [line(loose, k * SHAFT) > 3 * line(base, k * SHAFT) for k in range(1, 11)]
    assert sum(raised) >= 8


@pytest.mark.parametrize("supply_hz", [50.0, 60.0])
def test_line_frequency_puts_lines_at_twice_the_supply_whatever_the_speed(supply_hz):
    for rpm in (1500.0, 1797.0):
        base = rig("outer", rpm=rpm)
        x = rig("outer", rpm=rpm, effects={"line_frequency": {"supply_hz": supply_hz}})
        assert line(x, 2 * supply_hz) == pytest.approx(math.sqrt(2) * rms(base), rel=0.05)
        assert line(x, 4 * supply_hz) == pytest.approx(math.sqrt(2) * rms(base) / 2, rel=0.05)
        assert line(x, supply_hz) < 0.05 * line(x, 2 * supply_hz)


def test_tones_put_lines_at_their_frequencies_and_levels():
    base = rig("outer")
    added = rig("outer", effects={"tones": {"frequencies_hz": [47.0, 311.0], "levels_db": [0.0, -6.0]}}) - base
    assert line(added, 47.0) == pytest.approx(math.sqrt(2) * rms(base), rel=0.02)
    assert line(added, 311.0) == pytest.approx(math.sqrt(2) * rms(base) * 10 ** (-6 / 20), rel=0.02)


@pytest.mark.parametrize("effect, bands", [
    ("resonance", [(2400.0, 2600.0)]),
    ("second_resonance", [(1750.0, 1850.0), (3500.0, 3700.0)]),
])
def test_resonances_raise_band_energy_at_their_natural_frequencies(effect, bands):
    base, x = rig("outer"), rig("outer", effects={effect: {}})
    for low, high in bands:
        assert band_power(x, low, high) > 4 * band_power(base, low, high)
    assert band_power(x, 5000.0, 5500.0) < 2 * band_power(base, 5000.0, 5500.0)


def test_lubrication_lowers_and_flattens_the_contact_ringing():
    def ringing(x):
        freqs, psd = sps.welch(x, FS, nperseg=1024)
        band = (freqs > 300) & (freqs < 800)
        return freqs[band][np.argmax(psd[band])], psd[band].max()

    dry_hz, dry_peak = ringing(rig("normal"))
    wet_hz, wet_peak = ringing(rig("normal", effects={"lubrication": {}}))
    # The ringing sits at sqrt(k_r / m_rotor) / (2 pi): the film's stiffness ratio 0.7 moves it by sqrt(0.7).
    assert wet_hz == pytest.approx(math.sqrt(0.7) * dry_hz, rel=0.08)
    assert wet_peak < dry_peak / 3


def harmonic_share(x, fundamental_hz, orders):
    freqs, amp = envelope_spectrum(x)
    return [peak(freqs, amp, k * fundamental_hz, 0.5) / peak(freqs, amp, fundamental_hz, 0.5) for k in orders]


def test_slip_weakens_the_envelope_harmonics_with_order():
    clean = harmonic_share(rig("outer"), FREQS["bpfo"], (2, 10))
    slipping = harmonic_share(rig("outer", effects={"slip": {"jitter": 0.02}}), FREQS["bpfo"], (2, 10))
    # Gaussian jitter of the impact times keeps a share exp(-(2 pi k jitter)^2 / 2) of harmonic k
    # (0.97 at k = 2, 0.45 at k = 10).
    assert slipping[0] > 0.85 * clean[0]
    assert slipping[1] < 0.6 * clean[1]


def test_speed_fluctuation_smears_harmonics_more_with_order():
    clean = harmonic_share(rig("outer"), FREQS["bpfo"], (5,))
    fluctuating = harmonic_share(rig("outer", effects={"speed_fluctuation": {}}), FREQS["bpfo"], (5,))
    assert fluctuating[0] < 0.5 * clean[0]
    freqs, amp = envelope_spectrum(rig("outer", effects={"speed_fluctuation": {"frequency_hz": 4.0}}))
    assert peak(freqs, amp, FREQS["bpfo"] + 4.0, 0.5) > 0.1 * peak(freqs, amp, FREQS["bpfo"], 0.5)


def test_noise_has_its_snr_and_lowers_kurtosis():
    base = rig("outer")
    noisy = rig("outer", effects={"noise": {"snr_db": 10.0, "spectral_slope": 1.0}})
    assert 20 * math.log10(rms(base) / rms(noisy - base)) == pytest.approx(10.0, abs=0.05)
    # Independent Gaussian noise scales the excess kurtosis by (P_signal / P_total)^2 = (1 / 1.1)^2.
    assert kurtosis(noisy) == pytest.approx(kurtosis(base) / 1.1**2, rel=0.05)
    # Pink: more power per hertz low than high.
    assert band_power(noisy - base, 100, 200) > 10 * band_power(noisy - base, 4000, 4100)


def test_clipping_caps_the_record_and_lowers_kurtosis():
    base = rig("outer")
    clipped = rig("outer", effects={"clipping": {"level_rms": 2.0}})
    assert np.abs(clipped).max() == pytest.approx(2.0 * rms(base), rel=0.01)
    assert np.mean(np.abs(clipped) >= np.abs(clipped).max()) > 0.001  # flat tops
    assert kurtosis(clipped) < 0.5 * kurtosis(base)


def test_gear_mesh_has_a_mesh_line_with_shaft_rate_sidebands():
    base, x = rig("normal"), rig("normal", effects={"gear_mesh": {"n_teeth": 29}})
    for order in (28, 29, 30, 58):
        assert line(x, order * SHAFT) > 10 * line(base, order * SHAFT)
    assert line(x, 29 * SHAFT) > 2 * line(x, 30 * SHAFT)


def test_rub_bursts_once_per_revolution():
    x = rig("normal", effects={"rub": {}})
    freqs, amp = envelope_spectrum(x)
    band = (freqs > 5) & (freqs < 500)
    assert freqs[band][np.argmax(amp[band])] == pytest.approx(SHAFT, abs=0.5)
    assert kurtosis(x) > kurtosis(rig("normal")) + 1.0


def test_am_interference_is_a_carrier_with_sidebands_and_an_envelope_line():
    x = rig("normal", effects={"am_interference": {"carrier_hz": 3300.0, "modulation_hz": 37.0}})
    base = rig("normal")
    for frequency in (3300.0, 3263.0, 3337.0):
        assert line(x, frequency) > 10 * line(base, frequency)
    freqs, amp = envelope_spectrum(x)
    band = (freqs > 5) & (freqs < 500)
    assert freqs[band][np.argmax(amp[band])] == pytest.approx(37.0, abs=0.5)


def test_cable_crackle_drops_out_and_spikes_at_random():
    base = rig("normal")
    x = rig("normal", effects={"cable_crackle": {"rate_per_s": 5.0, "dropout_ms": 2.0, "spike_level_rms": 8.0}})
    assert np.sum(x == 0.0) > 0.2 * 2.0e-3 * FS  # at least one dropout of a few tenths of its longest
    assert np.abs(x).max() > 0.9 * 8.0 * rms(base) > 1.5 * np.abs(base).max()
    assert kurtosis(x) > kurtosis(base) + 1.0


# ---------------------------------------------------------------- operating point, determinism, isolation


def test_same_seed_same_record_other_seed_other_record():
    effects = {"noise": {}, "slip": {}, "cable_crackle": {}}
    np.testing.assert_array_equal(rig("inner", effects, seed=3), rig("inner", effects, seed=3))
    assert not np.allclose(rig("inner", effects, seed=3), rig("inner", effects, seed=4))


@pytest.mark.parametrize("fs", [12000.0, 25600.0, 48000.0])
def test_sampling_rates(fs):
    x = rig("outer", fs=fs, duration_s=1.0)
    assert x.shape == (int(fs),) and x.dtype == np.float64
    freqs, amp = envelope_spectrum(x, fs)
    band = (freqs > 5) & (freqs < 500)
    assert freqs[band][np.argmax(amp[band])] == pytest.approx(FREQS["bpfo"], abs=1.0)


def test_unit_g_divides_by_standard_gravity_and_gain_multiplies():
    metres = rig("ball")
    np.testing.assert_allclose(rig("ball", unit="g") * 9.80665, metres, rtol=1e-12)
    np.testing.assert_allclose(rig("ball", unit="g", gain=0.1), metres / 9.80665 * 0.1, rtol=1e-12)


def test_two_seconds_at_48_khz_simulate_in_well_under_a_second():
    effects = {name: {} for name in RIG_EFFECTS}
    rig("inner", effects, fs=48000.0)  # warm-up
    start = time.perf_counter()
    rig("inner", effects, fs=48000.0)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize("field, value", [
    ("rpm", 0.0), ("fs", -1.0), ("duration_s", 0.001), ("radial_load_n", 0.0), ("clearance_um", -1.0),
    ("sensor_angle_deg", float("nan")), ("defect_width_mm", 0.0), ("defect_depth_mm", -0.1), ("gain", 0.0),
    ("unit", "mm/s"),
])
def test_bad_operating_point_fields_are_named(field, value):
    with pytest.raises(BearingTwinError, match=f"operating_point.{field}"):
        RigOperatingPoint(**{field: value})


@pytest.mark.parametrize("effects, named", [
    ({"resonance": {"damping_ratio": -0.1}}, "effects.resonance.damping_ratio"),
    ({"resonance": {"natural_frequency_hz": 7000.0}}, "natural_frequency_hz=7000.0"),
    ({"slip": {"width": 1.0}}, "effects.slip.width"),
    ({"wobble": {}}, "'wobble'"),
    ({"tones": {"frequencies_hz": [50.0], "levels_db": [0.0, 1.0]}}, "effects.tones.levels_db"),
    ({"am_interference": {"carrier_hz": 6000.0}}, "effects.am_interference.carrier_hz"),
    ({"slip": {"jitter": 0.6}}, "effects.slip.jitter"),
    ({"second_resonance": {"frequencies_hz": "1800"}}, "effects.second_resonance.frequencies_hz"),
    ({"line_frequency": {"n_harmonics": 2.5}}, "effects.line_frequency.n_harmonics"),
    ({"noise": {"snr_db": None}}, "effects.noise.snr_db"),
])
def test_bad_effects_are_named(effects, named):
    with pytest.raises(BearingTwinError, match=named.replace(".", r"\.")):
        rig("outer", effects)


def test_bad_fault_and_seed_are_named():
    with pytest.raises(BearingTwinError, match="fault='cage'"):
        rig("cage")
    with pytest.raises(BearingTwinError, match="seed"):
        rig("outer", seed=-1)


def test_the_rig_shares_no_code_with_the_twin():
    forbidden = ("bearingtwin.physics", "bearingtwin.twin", "bearingtwin.signal", "bearingtwin.features")
    package = Path(__file__).resolve().parents[1] / "src" / "bearingtwin" / "testrig"
    for source in package.glob("*.py"):
        for node in ast.walk(ast.parse(source.read_text())):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            assert not [name for name in names if name.startswith(forbidden)], f"{source.name} imports {names}"
    loaded = subprocess.run([sys.executable, "-c", "import sys, bearingtwin.testrig; print(*sys.modules)"],
                            capture_output=True, text=True, check=True).stdout.split()
    assert not [name for name in loaded if name.startswith(forbidden)]
