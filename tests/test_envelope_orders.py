"""Envelope-order features: physics (which band an impulse train lands in), invariances, config."""

import numpy as np
import pytest
import scipy.signal
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures, band_centres, defect_orders
from bearingtwin.features.extractor import build_feature_extractor
from bearingtwin.physics.geometry import BearingGeometry

FS_HZ = 12000.0
N = 4096


@pytest.fixture(scope="module")
def bearing():
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        cfg = compose("train", overrides=["bearing=cwru_6205", "features=envelope_orders"])
    return dict(cfg.bearing)


def ringing_impacts(rate_hz, rng, n=N, resonance_hz=3500.0, decay_s=1.5e-3, noise=0.05):
    """Impacts at ``rate_hz`` (with the 1 % jitter of real rolling), each ringing a resonance, plus white noise."""
    t = np.arange(n) / FS_HZ
    times = np.cumsum(1.0 / rate_hz * (1.0 + 0.01 * rng.standard_normal(int(n / FS_HZ * rate_hz) + 2)))
    x = np.zeros(n)
    for t0 in times[times < t[-1]]:
        after = t >= t0
        x[after] += np.exp(-(t[after] - t0) / decay_s) * np.sin(2 * np.pi * resonance_hz * (t[after] - t0))
    return x + noise * rng.standard_normal(n)


def features_of(bearing, windows, rpm):
    extractor = EnvelopeOrderFeatures(bearing=bearing)
    return extractor.fit_transform(windows, fs_hz=FS_HZ, rpm=rpm), extractor.feature_names_


@pytest.mark.parametrize("rate", ["bpfo", "bpfi", "bsf2"])
def test_an_impulse_train_at_a_defect_rate_puts_most_power_in_its_band(bearing, rate):
    rpm = 1750.0
    rate_hz = defect_orders(BearingGeometry.from_config(bearing))[rate] * rpm / 60.0
    rng = np.random.default_rng(1)
    features, names = features_of(bearing, np.stack([ringing_impacts(rate_hz, rng) for _ in range(3)]), rpm)
    fundamentals = [f"1x{r}" for r in ("bpfi", "bpfo", "bsf2", "ftf")]
    columns = [names.index(name) for name in fundamentals]
    assert [fundamentals[i] for i in features[:, columns].argmax(axis=1)] == [f"1x{rate}"] * 3
    shares = features[:, [i for i, name in enumerate(names) if name != "band_power_log10"]]
    assert np.all(shares >= 0) and np.all(shares.sum(axis=1) <= 1 + 1e-12)


def test_band_power_tells_impacts_ringing_in_the_band_from_power_below_it(bearing):
    """Impacts ringing at 3.5 kHz keep nearly all their power in the 1.5-5.4 kHz band-pass; shaft and
    ball-pass harmonics (30, 107, 214 Hz) with the same white noise keep about its in-band share."""
    rng = np.random.default_rng(4)
    t = np.arange(N) / FS_HZ
    low = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in (30.0, 107.0, 214.0))
    windows = np.stack([ringing_impacts(107.0, rng), low + 0.05 * rng.standard_normal(N)])
    features, names = features_of(bearing, windows, 1797.0)
    band_power = features[:, names.index("band_power_log10")]
    assert names[-1] == "band_power_log10"
    assert band_power[0] > np.log10(0.8)
    white_in_band = 0.05 ** 2 * 0.65 / np.var(windows[1])  # 1.5-5.4 kHz is 65 % of a white spectrum
    assert band_power[1] == pytest.approx(np.log10(white_in_band), abs=0.15) and band_power[1] < -2.5
    without = EnvelopeOrderFeatures(bearing=bearing, band_power=False).fit(windows, fs_hz=FS_HZ, rpm=1797.0)
    assert "band_power_log10" not in without.feature_names_
    assert np.array_equal(without.transform(windows, fs_hz=FS_HZ, rpm=1797.0), features[:, :-1])


def test_features_do_not_change_with_gain_and_are_seed_free(bearing):
    rng = np.random.default_rng(2)
    windows = np.stack([ringing_impacts(107.0, rng), rng.standard_normal(N)])
    features, _ = features_of(bearing, windows, 1797.0)
    scaled, _ = features_of(bearing, 37.5 * windows, 1797.0)
    assert np.allclose(features, scaled, rtol=1e-9)
    assert np.array_equal(features, features_of(bearing, windows, 1797.0)[0])


def test_features_follow_the_shaft_speed_window_by_window(bearing):
    """The same defect at two speeds gives the same order features when each window carries its rpm."""
    bpfo = defect_orders(BearingGeometry.from_config(bearing))["bpfo"]
    rng = np.random.default_rng(3)
    slow, fast = 1500.0, 1800.0
    windows = np.stack([ringing_impacts(bpfo * slow / 60.0, rng), ringing_impacts(bpfo * fast / 60.0, rng)])
    right, names = features_of(bearing, windows, np.array([slow, fast]))
    wrong, _ = features_of(bearing, windows, fast)  # the slow window read at the wrong speed
    column = names.index("1xbpfo")
    assert right[0, column] == pytest.approx(right[1, column], rel=0.5) and right[0, column] > 0.05
    assert wrong[0, column] < 0.2 * right[0, column]


def test_the_config_builds_the_extractor_and_bad_settings_name_their_field(bearing):
    with initialize_config_dir(version_base="1.3", config_dir=CONF_DIR):
        cfg = compose("train", overrides=["bearing=cwru_6205", "features=envelope_orders"])
    extractor = build_feature_extractor(cfg.features)
    assert isinstance(extractor, EnvelopeOrderFeatures) and extractor.bearing["n_balls"] == 9
    with pytest.raises(BearingTwinError, match=r"features\.band_nyquist"):
        build_feature_extractor({**dict(cfg.features), "band_nyquist": [0.5, 0.2]})
    for band in ([0.25], 0.5, ["a", 0.5]):  # one value, a bare number, a word: named, not unpacked in a traceback
        with pytest.raises(BearingTwinError, match=r"^features\.band_nyquist=.*need two numbers"):
            build_feature_extractor({**dict(cfg.features), "band_nyquist": band})
    with pytest.raises(BearingTwinError, match=r"^features\.half_width_orders must be positive, got 'wide'$"):
        build_feature_extractor({**dict(cfg.features), "half_width_orders": "wide"})
    with pytest.raises(BearingTwinError, match=r"features\.line_measure='height': choose one of share, prominence"):
        build_feature_extractor({**dict(cfg.features), "line_measure": "height"})
    with pytest.raises(BearingTwinError, match=r"features\.floor_width_orders must be positive"):
        build_feature_extractor({**dict(cfg.features), "floor_width_orders": 0})
    with pytest.raises(BearingTwinError, match=r"features\.band_power must be true or false"):
        build_feature_extractor({**dict(cfg.features), "band_power": "yes"})
    for rates in ([], ["bpfo", "cage"], ["bpfo", "bpfo"], 3):
        with pytest.raises(BearingTwinError, match=r"^features\.rates=.*: give one or more of bpfi, bpfo, bsf2, ftf, each once"):
            build_feature_extractor({**dict(cfg.features), "rates": rates})
    with pytest.raises(BearingTwinError, match=r"features: unknown key\(s\) \['bandwidth'\]"):
        build_feature_extractor({**dict(cfg.features), "bandwidth": 3})
    with pytest.raises(BearingTwinError, match=r"rpm: .*shaft speed"):
        EnvelopeOrderFeatures(bearing=bearing).fit(np.ones((2, 64)), fs_hz=FS_HZ, rpm=None)
    with pytest.raises(BearingTwinError, match=r"rpm must be positive"):
        EnvelopeOrderFeatures(bearing=bearing).fit(np.ones((2, 64)), fs_hz=FS_HZ, rpm=[1797.0, -1.0])


def test_prominence_sees_a_line_above_the_floor_and_none_in_noise_whatever_the_floor(bearing):
    """An impulse train at BPFO stands 10x and more above its flanks at 1xBPFO; white noise has no line
    anywhere (prominences about 0 = log10 1). Narrowing the ringing band raises every share of the
    envelope's power below the narrow band's width (400 Hz) but not the noise's prominences."""
    geometry = BearingGeometry.from_config(bearing)
    rpm = 1797.0
    rng = np.random.default_rng(5)
    impacts = np.stack([ringing_impacts(defect_orders(geometry)["bpfo"] * rpm / 60.0, rng) for _ in range(3)])
    noise = rng.standard_normal((20, N))
    narrow = scipy.signal.sosfiltfilt(scipy.signal.butter(4, [3300, 3700], "bandpass", fs=FS_HZ, output="sos"), noise)
    prominence = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence", band_power=False)
    names = prominence.fit(impacts, fs_hz=FS_HZ, rpm=rpm).feature_names_
    lines = prominence.transform(impacts, fs_hz=FS_HZ, rpm=rpm)
    assert np.all(lines[:, names.index("1xbpfo")] > 1.0) and np.all(lines[:, names.index("1xbpfi")] < 0.5)
    broad, narrowed = (prominence.transform(x, fs_hz=FS_HZ, rpm=rpm).mean(axis=0) for x in (noise, narrow))
    assert np.all(np.abs(broad) < 0.35) and np.all(np.abs(narrowed) < 0.35), (broad, narrowed)
    share = EnvelopeOrderFeatures(bearing=bearing, band_power=False)
    broad_share, narrow_share = (share.fit_transform(x, fs_hz=FS_HZ, rpm=rpm).mean(axis=0) for x in (noise, narrow))
    below = [order * rpm / 60.0 < 300.0 for order in band_centres(geometry, 3).values()]
    assert narrow_share[below].mean() > 3 * broad_share[below].mean()  # measured 5.8x
    assert np.allclose(prominence.transform(40.0 * impacts, fs_hz=FS_HZ, rpm=rpm), lines)


def test_a_speed_that_puts_a_line_past_the_envelope_spectrum_is_named(bearing):
    """At 60000 rpm (a mistyped speed) the third BPFI lies past half the sampling rate: the refusal names the speed,
    the first thing to check, not the windows."""
    windows = np.random.default_rng(0).standard_normal((2, N))
    prominence = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence").fit(windows, fs_hz=FS_HZ, rpm=1797.0)
    with pytest.raises(BearingTwinError, match=r"the shaft speed \(60000 rpm\) puts its order \d+\.\d\d line beyond the "
                                               r"envelope spectrum of a window \(6000 Hz\): check the speed"):
        prominence.transform(windows, fs_hz=FS_HZ, rpm=60000.0)


def test_a_speed_too_slow_for_the_windows_resolution_is_named_as_such(bearing):
    """At 60 rpm a bin of a window spans several shaft orders: the line has no flanks to stand out of. The refusal
    says the resolution is too coarse, not that the line lies beyond the spectrum (it lies at 4 Hz)."""
    windows = np.random.default_rng(0).standard_normal((2, N))
    prominence = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence").fit(windows, fs_hz=FS_HZ, rpm=1797.0)
    with pytest.raises(BearingTwinError, match=r"at 60 rpm a window resolves \d+\.\d\d shaft orders, too coarse for the "
                                               r"order \d+\.\d\d line and its flanks: check the speed"):
        prominence.transform(windows, fs_hz=FS_HZ, rpm=60.0)


def test_a_subset_of_rates_reads_those_columns_alone_and_the_same_values(bearing):
    """``rates`` leaves out whole repetition rates (their harmonics and sidebands); the columns kept are the full
    set's, to the bit, in the full set's order whatever order the rates are given in. An extractor pickled before
    ``rates`` existed (a registered model) reads every rate."""
    rng = np.random.default_rng(3)
    windows = np.stack([ringing_impacts(defect_orders(BearingGeometry.from_config(bearing))["bpfo"] * 1797.0 / 60.0, rng)
                        for _ in range(2)])
    full = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence")
    every = full.fit_transform(windows, fs_hz=FS_HZ, rpm=1797.0)
    some = EnvelopeOrderFeatures(bearing=bearing, line_measure="prominence", rates=["bsf2", "bpfo"])
    part = some.fit_transform(windows, fs_hz=FS_HZ, rpm=1797.0)
    assert some.feature_names_ == ["1xbpfo", "2xbpfo", "3xbpfo", "1xbsf2", "2xbsf2", "3xbsf2", "band_power_log10"]
    assert np.array_equal(part, every[:, [full.feature_names_.index(name) for name in some.feature_names_]])
    old = full.__getstate__()
    del old["rates"]
    loaded = EnvelopeOrderFeatures.__new__(EnvelopeOrderFeatures)
    loaded.__setstate__(old)
    assert np.array_equal(loaded.transform(windows, fs_hz=FS_HZ, rpm=1797.0), every)


def test_in_a_pipeline_the_operating_point_travels_as_metadata_and_the_columns_are_named(bearing):
    """scikit-learn's own composition: the windows' rate and speeds routed to fit and transform, the
    classifier told inner-race from outer-race impacts by the envelope orders alone."""
    import sklearn
    from sklearn.model_selection import cross_val_score
    from sklearn.pipeline import Pipeline

    from bearingtwin.models.svm import SvmClassifier

    rng = np.random.default_rng(3)
    rpm = 1797.0
    geometry = BearingGeometry.from_config(bearing)
    rates = geometry.defect_frequencies(rpm)
    X = np.stack([ringing_impacts(rates[name], rng) for name in ["bpfi", "bpfo"] * 10])
    y = np.array(["inner", "outer"] * 10)
    with sklearn.config_context(enable_metadata_routing=True):
        features = EnvelopeOrderFeatures(bearing=geometry)  # the geometry itself does, as its config does
        features.set_fit_request(fs_hz=True, rpm=True).set_transform_request(fs_hz=True, rpm=True)
        pipeline = Pipeline([("features", features), ("svm", SvmClassifier())])
        scores = cross_val_score(pipeline, X, y, cv=2, params={"fs_hz": FS_HZ, "rpm": rpm}, error_score="raise")
        assert scores.min() == 1.0
        pipeline.fit(X, y, fs_hz=FS_HZ, rpm=rpm)
        assert list(pipeline.predict(X[:2], fs_hz=FS_HZ, rpm=rpm)) == ["inner", "outer"]
    names = pipeline[0].get_feature_names_out()
    assert list(names) == pipeline[0].feature_names_ and names[-1] == "band_power_log10"
