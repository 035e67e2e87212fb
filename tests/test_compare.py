"""Comparison views: scale-free, zero for the same signal, and naming where two signals differ."""

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal as sps

from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.effect_library import base_excitation_filter
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.twin.compare import VIEWS, Comparator, CompareSettings, plot_comparison

FS = 12000.0
RPM = 1797.0
GEOMETRY = BearingGeometry(52.0, 25.0, 7.94, 39.0, 9)


def impacts(fault: str, seconds: float, seed: int, jitter: float = 0.0, noise: float = 1e-3) -> np.ndarray:
    """Defect impacts ringing a 3 kHz mode: a stand-in measurement that needs no simulator.

    ``jitter`` displaces every impact by that fraction of the impact spacing (random slip).
    """
    rng = np.random.default_rng(seed)
    rate = GEOMETRY.fault_frequency_hz(fault, RPM)
    n = int(seconds * FS)
    times = np.arange(0, seconds, 1 / rate)
    times = times + rng.normal(0, jitter / rate, times.size)
    x = np.zeros(n)
    index = np.round(times * FS).astype(int)
    weights = np.ones(index.size)
    if fault == "inner":  # load-zone modulation at the shaft rate
        weights = 1.0 + 0.8 * np.cos(2 * np.pi * RPM / 60.0 * times)
    keep = (index >= 0) & (index < n)
    np.add.at(x, index[keep], weights[keep])
    return base_excitation_filter(x, FS, 3000.0, 0.05) + noise * rng.standard_normal(n)


def measured(x: np.ndarray, fault: str = "outer") -> Recording:
    return Recording(x, FS, RPM, fault, source="test.npy")


def test_a_defect_line_too_low_for_the_envelope_segment_names_the_speed_that_put_it_there():
    """A speed given in Hz (29.9 for 1797 rev/min) puts BPFO near 1.8 Hz: the refusal had named only the envelope
    segment's resolution, not the file nor the speed behind it."""
    record = replace(measured(impacts("outer", 2.0, seed=0)), rpm=29.95, source="pump.npz")
    with pytest.raises(BearingTwinError, match=r"^pump.npz: compare.envelope_segment_s=.* too coarse for BPFO at 1.8 Hz, "
                                               r"where 29.95 rev/min puts it \(a speed given in Hz\? 29.95 Hz is 1797 "
                                               r"rev/min\)"):
        Comparator(record, GEOMETRY)


def test_identical_signals_compare_to_zero_at_any_gain():
    x = impacts("outer", 2.0, seed=0)
    comparator = Comparator(measured(x), GEOMETRY)
    same = comparator(x)
    assert same.discrepancy_db == pytest.approx(0.0, abs=1e-9)
    assert same.gain == pytest.approx(1.0)
    scaled = comparator(x * 9.81)  # twin in m/s^2, measurement in g
    assert scaled.discrepancy_db == pytest.approx(0.0, abs=1e-6)
    assert scaled.gain == pytest.approx(1 / 9.81, rel=1e-6)
    different = comparator(impacts("outer", 2.0, seed=0, jitter=0.05))
    assert different.discrepancy_db > 0.5
    assert sum(view.share for view in different.views.values()) == pytest.approx(1.0)


def test_psd_view_names_the_band_where_energy_is_added():
    twin = impacts("outer", 2.0, seed=0)
    rng = np.random.default_rng(1)
    band = sps.sosfiltfilt(sps.butter(6, [1300, 1700], "bandpass", fs=FS, output="sos"), rng.standard_normal(twin.size))
    meas = twin + 3 * twin.std() * band / band.std()
    result = Comparator(measured(meas), GEOMETRY)(twin)
    finding = result.views["psd"].finding
    assert "above the twin" in finding
    low, high = (float(part.split()[0]) * (1000 if "kHz" in part else 1)
                 for part in finding.removeprefix("energy between ").split(" is ")[0].split(" and "))
    assert low <= 1300 and 1700 <= high
    assert result.views["psd"].what_leaves_it is None  # energy added: the view's own words (a resonance, a source)


def test_psd_view_takes_an_empty_top_band_for_the_measurement_chains_low_pass():
    """A record whose chain cuts it off below the Nyquist frequency (a converter's anti-aliasing, a sensor's
    bandwidth, a record resampled from a lower rate) is quieter in the top band than a twin that is not: the
    view says what takes energy away there, not what adds it."""
    twin = impacts("outer", 2.0, seed=0, noise=0.05)
    meas = sps.sosfiltfilt(sps.butter(10, 3500, fs=FS, output="sos"), twin)
    psd = Comparator(measured(meas), GEOMETRY)(twin).views["psd"]
    assert psd.finding.endswith("below the twin's") and "6 kHz" in psd.finding, psd.finding
    assert "a low-pass in the measurement chain" in psd.what_leaves_it


def test_a_healthy_records_shaft_harmonics_are_put_down_to_the_shaft_not_to_a_defect():
    """A healthy record's harmonics view reads the shaft's lines in the envelope: what leaves them there is a once-per-
    revolution modulation (unbalance, misalignment), not "a different defect geometry" of a bearing that has none."""
    rng = np.random.default_rng(0)
    t = np.arange(int(2.0 * FS)) / FS
    carrier = rng.standard_normal(t.size)
    twin = 0.1 * carrier
    meas = twin * (1 + 0.8 * np.sin(2 * np.pi * RPM / 60 * t))
    harmonics = Comparator(measured(meas, "normal"), GEOMETRY)(twin).views["harmonics"]
    assert harmonics.what_leaves_it.startswith("a modulation once per revolution") and "unbalance" in harmonics.what_leaves_it
    assert Comparator(measured(impacts("outer", 2.0, seed=0)), GEOMETRY)(twin).views["harmonics"].what_leaves_it is None


def test_harmonics_view_sees_smeared_lines_as_wider():
    sharp = impacts("outer", 2.0, seed=0)
    rate = GEOMETRY.bpfo_hz(RPM)
    # A slowly wandering rate (+-3 %) smears the harmonics without changing the band energies.
    t = np.arange(sharp.size) / FS
    phase = np.cumsum(rate * (1 + 0.03 * np.sin(2 * np.pi * 1.3 * t))) / FS
    pulses = np.diff(np.floor(phase), prepend=0.0)
    smeared = base_excitation_filter(pulses, FS, 3000.0, 0.05) + 1e-3 * np.random.default_rng(0).standard_normal(t.size)
    result = Comparator(measured(smeared), GEOMETRY)(sharp)
    assert np.all(result.measured.widths_hz[2:] > 1.5 * result.twin.widths_hz[2:])
    assert "BPFO harmonics are" in result.views["harmonics"].finding
    assert "times as wide as the twin's" in result.views["harmonics"].finding


def test_harmonics_view_names_its_largest_difference_where_the_means_cancel():
    """The finding's widths and prominence are means over the harmonics, where differences of opposite sign cancel,
    while the view's error is their RMS: the largest single difference is named beside them."""
    x = impacts("outer", 2.0, seed=0)
    comparator = Comparator(measured(x), GEOMETRY)
    twin = comparator.profile(x)
    assert "most apart" not in comparator.compare_profiles(twin).views["harmonics"].finding
    assert "on average" not in comparator.compare_profiles(twin).views["harmonics"].finding
    k = comparator.settings.n_harmonics
    comparator.measured = replace(twin, line_db=twin.line_db + np.array([6.0, -6.0] + [0.0] * (k - 2)))
    view = comparator.compare_profiles(twin).views["harmonics"]
    assert view.error_db == pytest.approx(np.sqrt(2 * 6.0**2 / (2 * k)))  # the RMS over heights and widths
    assert "harmonics are on average as wide as" in view.finding and "equally prominent" in view.finding  # +6, -6 dB
    assert view.finding.endswith("most apart, harmonic 1 is 6.0 dB more prominent"), view.finding
    comparator.measured = replace(twin, widths_hz=twin.widths_hz * np.array([1.0, 1.0, 3.0] + [1.0] * (k - 3)))
    finding = comparator.compare_profiles(twin).views["harmonics"].finding
    assert finding.endswith("harmonic 3 is 3 times as wide as the twin's"), finding
    # An inner race's lines: its harmonics, then the sidebands below them, then those above.
    inner = Comparator(measured(impacts("inner", 2.0, seed=0), "inner"), GEOMETRY)
    twin = inner.measured
    for index, words in ((k + 1, "the sideband below harmonic 2 is 4.0 dB weaker"),
                         (2 * k + 3, "the sideband above harmonic 4 is 4.0 dB stronger")):
        shift = np.zeros(3 * k)
        shift[index] = 4.0 if index >= 2 * k else -4.0
        inner.measured = replace(twin, line_db=twin.line_db + shift)
        assert inner.compare_profiles(twin).views["harmonics"].finding.endswith(words)


def test_inner_race_sidebands_sit_at_the_shaft_rate():
    comparator = Comparator(measured(impacts("inner", 2.0, seed=0), "inner"), GEOMETRY)
    shaft = RPM / 60.0
    np.testing.assert_allclose(comparator.sidebands_hz[: comparator.settings.n_harmonics],
                               comparator.harmonics_hz - shaft)
    # The load-zone modulation puts real lines there: well above the envelope floor.
    assert np.all(comparator.measured.line_db[comparator.settings.n_harmonics:] > 6.0)


def test_statistics_view_sees_lost_impulsiveness():
    twin = impacts("outer", 2.0, seed=0)
    noisy = twin + 2 * twin.std() * np.random.default_rng(3).standard_normal(twin.size)
    result = Comparator(measured(noisy), GEOMETRY)(twin)
    assert result.views["statistics"].error_db > 1.0
    assert result.summary.startswith(f"discrepancy {result.discrepancy_db:.2f} dB")


def test_statistics_view_is_blind_to_the_level_that_the_psd_view_judges():
    """Hum in a band where the twin is nearly silent moves the band-level gain by dB while the RMS
    ratio barely moves; the statistics view must not count that level misfit a second time."""
    twin = impacts("outer", 2.0, seed=0)
    hum = sps.sosfiltfilt(sps.butter(4, [55, 70], "bandpass", fs=FS, output="sos"),
                          np.random.default_rng(4).standard_normal(twin.size))
    meas = twin + 0.01 * twin.std() * hum / hum.std()  # -40 dB of power: the RMS moves by 0.0004 dB
    comparator = Comparator(measured(meas), GEOMETRY)
    result = comparator(twin)
    assert abs(20 * np.log10(result.gain)) > 1.5
    assert result.views["psd"].error_db > 3.0
    assert result.views["statistics"].error_db < 0.5
    assert comparator(7.0 * twin).views["statistics"].error_db == pytest.approx(result.views["statistics"].error_db)


def test_lines_view_leaves_the_defects_own_lines_to_the_envelope_views():
    """Sharp defect-rate lines in the twin and smeared ones in the measurement are the harmonics
    view's finding; a shaft-order line the measurement adds is the lines view's."""
    rate = GEOMETRY.bpfo_hz(RPM)
    t = np.arange(int(2 * FS)) / FS
    train = np.cos(2 * np.pi * rate * np.outer(t, np.arange(1, int(FS / 2 / rate)))).sum(axis=1)
    sharp = base_excitation_filter(train, FS, 3000.0, 0.05)  # a perfectly periodic twin
    sharp = sharp + 1e-3 * sharp.std() * np.random.default_rng(2).standard_normal(t.size)
    smeared = impacts("outer", 2.0, seed=1, jitter=0.05)
    result = Comparator(measured(smeared), GEOMETRY)(sharp)
    # No defect-rate line is compared. Below 80 Hz this noiseless train's spectrum rises 20 dB, and over the low
    # percentile of a neighbourhood that steep its upper bins stand a few dB over the threshold (compare.py).
    assert result.views["lines"].error_db < 4.0
    assert not any(f"at {k * rate:.0f} Hz" in result.views["lines"].finding for k in range(1, 10))
    assert "times as wide as the twin's" in result.views["harmonics"].finding
    one_x = 0.5 * smeared.std() * np.sqrt(2) * np.sin(2 * np.pi * RPM / 60.0 * t)
    with_unbalance = Comparator(measured(smeared + one_x), GEOMETRY)(sharp)
    assert with_unbalance.views["lines"].error_db > 10.0
    assert "shaft order 1.00" in with_unbalance.views["lines"].finding


@pytest.mark.parametrize("fault", ["inner", "normal"])
def test_lines_view_leaves_a_faulty_bearings_ball_passing_to_the_envelope_views_and_sees_a_healthy_ones(fault):
    """The balls passing through the load zone (varying compliance) leave lines at BPFO's harmonics in any
    bearing. Beside an inner-race defect how high they stand hangs on the contact model, so a twin that rings
    there and a measurement that does not differ in no machine element's line, and a line off those harmonics
    still counts. On a healthy bearing they are the bare twin's largest lines, which a real bearing's roughness
    and noise bury: a twin keeping them over a measurement without them differs in the lines view, by them."""
    t = np.arange(int(2 * FS)) / FS
    rng = np.random.default_rng(4)
    measurement = impacts(fault, 2.0, seed=5, noise=0.05) if fault != "normal" else 0.05 * rng.standard_normal(t.size)
    level = 0.3 * measurement.std()  # lines far above the floor, but little of the power (the gain stays)
    ball_pass = level * sum(np.cos(2 * np.pi * k * GEOMETRY.bpfo_hz(RPM) * t) / k for k in (1, 2, 3))
    comparator = Comparator(Recording(measurement, FS, RPM, fault, source="test.npy"), GEOMETRY)
    lines = comparator(measurement + ball_pass).views["lines"]
    named = [k for k in (1, 2, 3) if f"at {k * GEOMETRY.bpfo_hz(RPM):.0f} Hz" in lines.finding]
    if fault == "normal":
        assert lines.error_db > 10.0 and named, lines.finding
    else:
        # Only what the lines' power moves with them: the fitted gain, by which the inner race's shaft-rate
        # lines (its load zone's) then compare a little off.
        assert lines.error_db < 3.0 and not named, lines.finding
    tone = level * np.cos(2 * np.pi * 247.0 * t)  # no bearing frequency
    assert comparator(measurement + tone).views["lines"].error_db > 10.0


def test_a_line_of_a_dense_comb_stands_as_high_as_a_lone_one():
    """Looseness rattles at every half order of the shaft: a comb whose lines' skirts fill more than half of each
    neighbourhood the local level is taken over. The level is a low percentile of that neighbourhood, so the
    comb's 1x line stands within a few dB of where the same line alone would; the neighbourhood's median sat on
    the skirts and read it 10 dB or more lower."""
    t = np.arange(int(4 * FS)) / FS
    floor = np.random.default_rng(5).standard_normal(t.size)
    shaft_hz = RPM / 60.0
    lone = floor + 0.5 * np.sin(2 * np.pi * shaft_hz * t)
    comb = lone + sum(0.5 * np.sin(2 * np.pi * k / 2 * shaft_hz * t + k) for k in range(1, 30) if k != 2)

    def height_at_1x(x: np.ndarray, settings: CompareSettings) -> float:
        comparator = Comparator(measured(x, "normal"), GEOMETRY, settings)
        profile = comparator.measured
        at = np.argmin(np.abs(profile.lines_freqs_hz - shaft_hz))
        return float(np.max(comparator.line_heights_db(profile, profile, 1.0)[0][at - 2:at + 3]))

    default, median = CompareSettings(), CompareSettings(line_level_percentile=50.0, line_level_bins=21)
    assert height_at_1x(lone, default) > 10.0
    assert abs(height_at_1x(comb, default) - height_at_1x(lone, default)) < 4.0
    assert height_at_1x(comb, median) < height_at_1x(lone, median) - 10.0


def test_the_lowest_lines_are_measured_over_the_noise_not_over_the_dip_at_0_hz():
    """Below the lines view's lowest bin (a quarter of the shaft rate) the removed mean and the window's leakage leave
    a dip towards 0 Hz; the level the lowest lines stand over is taken above it, so noise there is no line."""
    for seed in range(4):
        noise = np.random.default_rng(seed).standard_normal(int(2 * FS))
        comparator = Comparator(measured(noise, "normal"), GEOMETRY)
        heights, _ = comparator.line_heights_db(comparator.measured, comparator.measured, 1.0)
        assert not heights[comparator.measured.lines_freqs_hz < 40.0].any(), seed


def test_a_line_between_the_lines_views_bins_is_named_at_its_frequency():
    """At 1500 rpm the shaft line, 25 Hz, falls midway between the lines view's 2 Hz bins; it is named
    where it stands, not at the bin beside it."""
    t = np.arange(int(4 * FS)) / FS
    floor = np.random.default_rng(3).standard_normal(t.size)
    line = 0.3 * np.sin(2 * np.pi * 25.0 * t)
    result = Comparator(Recording(floor + line, FS, 1500.0, "outer", source="test.npy"), GEOMETRY)(floor)
    assert "a line at 25 Hz (shaft order 1.00) stands" in result.views["lines"].finding


def test_sampling_rate_too_low_for_the_harmonics_is_named():
    x = impacts("inner", 2.0, seed=0)
    with pytest.raises(BearingTwinError, match="measured.fs=1000 Hz is too low"):
        Comparator(Recording(x[::12], 1000.0, RPM, "inner"), GEOMETRY)


def test_bad_settings_name_the_field():
    with pytest.raises(BearingTwinError, match="compare.bands"):
        CompareSettings.from_config({"bands": 3})
    with pytest.raises(BearingTwinError, match="compare.weights.spectrum"):
        CompareSettings.from_config({"weights": {"spectrum": 1.0}})
    with pytest.raises(BearingTwinError, match="compare.band_min_hz"):
        Comparator(measured(impacts("outer", 2.0, 0)), GEOMETRY, CompareSettings(band_min_hz=1.0))
    with pytest.raises(BearingTwinError, match="shorter than one comparison segment"):
        Comparator(measured(impacts("outer", 2.0, 0)), GEOMETRY)(np.zeros(100))
    with pytest.raises(BearingTwinError, match=r"compare.n_bands must be a positive integer, got 'abc'"):
        CompareSettings.from_config({"n_bands": "abc"})
    with pytest.raises(BearingTwinError, match=r"compare.n_bands=3 leaves no band level beyond the polynomial of order "
                                               r"compare.psd_detrend_order=2: give n_bands of at least 4"):
        CompareSettings.from_config({"n_bands": 3, "psd_detrend_order": 2})
    with pytest.raises(BearingTwinError, match=r"compare.psd_detrend_order must be a non-negative integer, got -1"):
        CompareSettings(psd_detrend_order=-1)
    settings = CompareSettings.from_config({"n_bands": 12.0})  # a whole number as YAML or a shell may write it
    assert settings.n_bands == 12 and isinstance(settings.n_bands, int)
    # Every setting is named where it is read, not met later as a division by zero or a NaN.
    for name, value in [("stats_window_s", 0), ("welch_segment_s", -0.1), ("envelope_segment_s", "abc"),
                        ("lines_segment_s", 0), ("band_min_hz", True), ("line_threshold_db", float("inf"))]:
        with pytest.raises(BearingTwinError, match=rf"^compare\.{name}={value!r} must be a positive number of"):
            CompareSettings.from_config({name: value})
    with pytest.raises(BearingTwinError, match=r"^compare.n_harmonics must be a positive integer, got 0$"):
        CompareSettings.from_config({"n_harmonics": 0})
    with pytest.raises(BearingTwinError, match=r"^compare.weights.psd must be a non-negative number, got 'abc'$"):
        CompareSettings.from_config({"weights": {"psd": "abc"}})
    with pytest.raises(BearingTwinError, match=r"^compare.weights must not all be zero$"):
        CompareSettings.from_config({"weights": {view: 0 for view in VIEWS}})


def test_view_weights_are_relative():
    """Weights say how the views weigh against each other: scaled alike, they compare and rank alike."""
    small = CompareSettings.from_config({"weights": {view: 0.2 for view in VIEWS}})
    assert small.weights == CompareSettings().weights == {view: 1.0 for view in VIEWS}
    only_two = CompareSettings.from_config({"weights": {"psd": 3.0, "lines": 1.0}})  # the views left out weigh nothing
    assert only_two.weights == {"psd": 3.75, "lines": 1.25, "envelope": 0.0, "harmonics": 0.0, "statistics": 0.0}


def test_figures_and_numbers_are_written(tmp_path):
    x = impacts("outer", 1.0, seed=0)
    result = Comparator(measured(x), GEOMETRY)(impacts("outer", 1.0, seed=0, jitter=0.02))
    paths = plot_comparison(result, tmp_path)
    assert sorted(p.name for p in paths) == sorted(f"compare_{view}.png" for view in VIEWS)
    assert all(p.read_bytes()[:4] == b"\x89PNG" for p in paths)
    numbers = json.loads(json.dumps(result.as_dict()))
    assert set(numbers["views"]) == set(VIEWS)


def test_a_line_is_named_at_its_peak_not_at_the_skirt_where_the_twin_differs_most():
    """The twin's 1x line 23 dB below the measurement's: the largest difference lies on the strong line's window
    skirt, 4 Hz off; the finding names the line where it stands, at shaft order 1."""
    t = np.arange(int(2 * FS)) / FS
    one_x = np.sin(2 * np.pi * RPM / 60.0 * t)
    measurement, twin = impacts("outer", 2.0, seed=1, jitter=0.05), impacts("outer", 2.0, seed=3, jitter=0.05)
    amplitude = 2.0 * measurement.std()
    result = Comparator(measured(measurement + amplitude * one_x), GEOMETRY)(twin + amplitude / 14 * one_x)
    assert "a line at 30 Hz (shaft order 1.00) stands" in result.views["lines"].finding


@pytest.mark.parametrize("order,words", [(1.0, "unbalance"), (2.0, "misalignment"), (0.5, "half orders"),
                                         (5.3, None)])
def test_a_line_the_measurement_adds_is_traced_to_what_its_place_tells(order, words):
    """A line the measurement adds on the shaft's first orders is put to the sources that make lines there (1x:
    unbalance; 2x: misalignment; a half order: looseness or a rub); elsewhere the lines view's general answer
    stands (what_leaves_it None)."""
    twin = impacts("outer", 2.0, seed=1)
    t = np.arange(twin.size) / FS
    line = 0.2 * np.std(twin) * np.sqrt(2) * np.sin(2 * np.pi * order * RPM / 60.0 * t)
    lines = Comparator(measured(twin + line), GEOMETRY)(twin).views["lines"]
    assert f"shaft order {order:.2f}" in lines.finding, lines.finding
    if words is None:
        assert lines.what_leaves_it is None
    else:
        assert words in lines.what_leaves_it, lines.what_leaves_it
    lacking = Comparator(measured(twin), GEOMETRY)(twin + line).views["lines"]  # the twin's line, the machine without
    assert "higher in the twin" in lacking.finding and "the twin makes and the machine does not" in lacking.what_leaves_it


def test_a_line_on_a_supply_multiple_names_the_supply_and_a_coarse_spectrum_names_nothing():
    """120 Hz at a 30 Hz shaft: the 4th order, and twice a 60 Hz supply (a motor's pull); 60 Hz there is both the
    2nd order and the supply, too close to tell apart; with bins a quarter of the shaft rate wide, nothing."""
    from bearingtwin.twin.compare import line_source

    assert line_source(120.0, 30.0, 0.5) == "an electrical line at 2 x a 60 Hz supply (a motor's magnetic pull)"
    both = line_source(60.0, 29.95, 0.5)
    assert both.startswith("a force twice per revolution") and "too close here to tell apart" in both
    assert line_source(150.0, 30.0, 0.5).startswith("an electrical line at 3 x a 50 Hz supply (pickup")
    assert line_source(8.0, 10.0, 2.0) is None and line_source(10.0, 10.0, 2.5) is None
    # On a defect frequency of the bearing: named as such (an outer-race record's line at 5.41 shaft orders is its
    # BPFI, not a gear's or a blade's), the stated defect's own told apart from another's.
    rates = {"BPFO": 107.4, "BPFI": 162.2, "BSF": 70.6}
    assert line_source(162.0, 29.95, 0.5, rates, own="BPFO") == (
        "this bearing's BPFI (the inner race's defect frequency): a defect on the inner race as well, or a record of "
        "another state than the one stated")
    assert line_source(214.8, 29.95, 0.5, rates, own="BPFO").startswith("this bearing's 2 x BPFO (the outer race's "
                                                                         "defect frequency): the stated defect rings")
    assert line_source(162.0, 29.95, 0.5, rates, own="shaft").endswith("a defect on the inner race, though the record "
                                                                       "is stated healthy")
    assert line_source(60.0, 29.95, 0.5, rates).startswith("a force twice per revolution")  # the shaft's first
    assert line_source(130.0, 29.95, 0.5, rates) is None


def test_a_line_whose_peak_lies_in_a_band_the_lines_view_leaves_out_is_named_at_its_peak():
    """Twice a 50 Hz supply (100 Hz) lies within the band left to the envelope views around BPFO (107 Hz at 1797 rpm):
    the lines view sees its skirt alone, and had named "a line at 98 Hz (shaft order 3.27)"."""
    from bearingtwin.config import load_bearing
    from bearingtwin.testrig import RigOperatingPoint, simulate_rig

    point = RigOperatingPoint(rpm=1797, fs=12000, duration_s=2.0, radial_load_n=500.0, unit="g")
    supplied = simulate_rig("outer", point, {"line_frequency": {"supply_hz": 50.0, "level_db": -3.0}}, seed=5)
    comparator = Comparator(Recording(supplied, 12000.0, 1797.0, "outer"), load_bearing("cwru_6205"))
    finding = comparator(simulate_rig("outer", point, {}, seed=6)).views["lines"].finding
    assert finding.startswith("a line at 100 Hz (shaft order 3.34) stands"), finding
