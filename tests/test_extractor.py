"""SABO-VMD feature extractors end to end on synthetic bearing-like windows, configs and the cache.

The windows are impulse trains ringing at a structural resonance plus a shaft tone and noise,
one repetition rate per class (a stand-in for the simulated dataset, which keeps this file fast).
Searches use a small population and few iterations; the code path is the real one.
"""

import dataclasses
import json
import os

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from bearingtwin.config import COMPOSITION_ERRORS, CONF_DIR
from bearingtwin.data.recording import WindowedDataset
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.cache import cache_path, extract_features
from bearingtwin.features.extractor import RawFeatures, SaboVmdFeatures, build_feature_extractor, parameter_table
from bearingtwin.features.fitness import optimal_mode
from bearingtwin.features.time_domain import FEATURE_NAMES, time_domain_features
from bearingtwin.optim.search import search_vmd_params
from bearingtwin.signal import vmd

FS = 12000.0
LENGTH = 512
RATES_HZ = (0.0, 162.0, 141.0, 107.0)  # normal, inner, ball, outer repetition rates
SMALL = dict(population=4, iterations=2, search_windows=2, vmd_options={"max_iter": 80}, progress=False)


def bearing_windows(per_class=3, seed=0):
    """Windows of a shaft tone + noise, with impacts ringing at 3 kHz at each class's rate."""
    rng = np.random.default_rng(seed)
    time = np.arange(LENGTH) / FS
    windows, labels = [], []
    for label, rate in enumerate(RATES_HZ):
        for _ in range(per_class):
            x = 0.3 * np.sin(2 * np.pi * 29.95 * time + rng.uniform(0, 2 * np.pi)) + 0.05 * rng.normal(size=LENGTH)
            if rate:
                since = np.mod(time + rng.uniform(0, 1 / rate), 1 / rate)
                x += np.exp(-since * 900) * np.sin(2 * np.pi * 3000 * since)
            windows.append(x)
            labels.append(label)
    return np.array(windows), np.array(labels)


@pytest.fixture(scope="module")
def data():
    return bearing_windows()


@pytest.fixture(scope="module")
def dataset(data):
    windows, labels = data
    n = len(windows)
    return WindowedDataset(windows, labels, np.arange(n), np.zeros(n, int), [f"synthetic-{i}" for i in range(n)], FS, key="synthetic-v1")


def test_global_extractor_searches_once_and_features_are_those_of_the_selected_mode(data):
    windows, labels = data
    extractor = SaboVmdFeatures(fitness="min_envelope_entropy", seed=3, **SMALL).fit(windows[::2])
    (row,) = extractor.vmd_params_
    assert row["scope"] == "global"
    assert 3 <= row["k"] <= 10 and 100 <= row["alpha"] <= 3000
    assert 1 <= row["optimal_imf"] <= row["k"]
    features = extractor.transform(windows)
    assert features.shape == (len(windows), len(FEATURE_NAMES))
    # Recompute independently: decompose with the fitted parameters, pick the min-envelope-entropy mode.
    modes, _ = vmd(windows, row["k"], row["alpha"], max_iter=80, seed=3)
    chosen = modes[np.arange(len(windows)), optimal_mode(modes)]
    np.testing.assert_allclose(features, time_domain_features(chosen))
    # The search value is the mean fitness over its windows at the best parameters.
    search = search_vmd_params(
        extractor._draw(windows[::2], np.random.default_rng(3)), "min_envelope_entropy", population=4, iterations=2,
        seed=3, vmd_options={"max_iter": 80},
    )
    assert (search.k, search.alpha, search.value) == (row["k"], row["alpha"], row["fitness"])
    # Impacts make the selected mode impulsive: faulty windows have a higher kurtosis than normal ones.
    kurtosis = features[:, FEATURE_NAMES.index("kurtosis")]
    assert kurtosis[labels > 0].min() > kurtosis[labels == 0].max()


def test_search_value_is_the_best_trial_and_the_study_is_inspectable(data):
    windows, _ = data
    result = search_vmd_params(windows[3], "pe_mie", population=4, iterations=2, seed=0, vmd_options={"max_iter": 80})
    trials = result.study.trials
    assert len(trials) == 4 * 3
    assert result.value == min(t.value for t in trials)
    assert {"k", "alpha"} == set(trials[0].params)
    best = next(t for t in trials if t.value == result.value)
    assert (best.params["k"], best.params["alpha"]) == (result.k, result.alpha)


def test_same_seed_same_numbers_other_seed_other_search(data):
    windows, _ = data
    a = SaboVmdFeatures(seed=1, **SMALL).fit(windows)
    b = SaboVmdFeatures(seed=1, **SMALL).fit(windows)
    c = SaboVmdFeatures(seed=2, **SMALL).fit(windows)
    assert a.vmd_params_ == b.vmd_params_
    assert a.vmd_params_ != c.vmd_params_
    np.testing.assert_array_equal(a.transform(windows[:3]), b.transform(windows[:3]))


def test_per_class_gives_one_row_per_label_and_uses_each_windows_label(data):
    windows, labels = data
    extractor = SaboVmdFeatures(vmd_params="per_class", fitness="min_envelope_entropy", seed=0, **SMALL)
    features = extractor.fit_transform(windows, labels)
    assert [row["scope"] for row in extractor.vmd_params_] == [0, 1, 2, 3]
    for row in extractor.vmd_params_:
        mine = labels == row["scope"]
        modes, _ = vmd(windows[mine], row["k"], row["alpha"], max_iter=80, seed=0)
        chosen = modes[np.arange(mine.sum()), optimal_mode(modes)]
        np.testing.assert_allclose(features[mine], time_domain_features(chosen))
    with pytest.raises(BearingTwinError, match="y \\(the labels\\) is required"):
        extractor.transform(windows)
    with pytest.raises(BearingTwinError, match=r"label\(s\) \[7\]"):
        extractor.transform(windows[:1], [7])


def test_parameter_table_reports_labels_one_based_like_table_2(data):
    windows, labels = data
    rows = parameter_table(windows, labels, ("normal", "inner", "ball", "outer"), seed=0, **SMALL)
    assert [(r["label"], r["class"]) for r in rows] == [(1, "normal"), (2, "inner"), (3, "ball"), (4, "outer")]
    assert all(set(r) == {"label", "class", "k", "alpha", "fitness", "optimal_imf"} for r in rows)


def test_per_sample_searches_each_window_the_same_in_parallel_or_not(data):
    windows, _ = data
    subset = windows[[0, 4]]
    serial = SaboVmdFeatures(vmd_params="per_sample", n_jobs=1, seed=0, **SMALL).fit(subset)
    features, rows = serial.extract(subset)
    parallel_features, parallel_rows = SaboVmdFeatures(vmd_params="per_sample", n_jobs=2, seed=0, **SMALL).fit(
        subset
    ).extract(subset)
    assert [r["scope"] for r in rows] == [0, 1]
    assert rows == parallel_rows
    np.testing.assert_array_equal(features, parallel_features)
    alone = search_vmd_params(subset[1], "pe_mie", population=4, iterations=2, seed=_seed(0, 1), vmd_options={"max_iter": 80})
    assert (rows[1]["k"], rows[1]["alpha"]) == (alone.k, alone.alpha)


def _seed(seed, index):
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


def test_raw_features_are_the_windows(data):
    windows, _ = data
    np.testing.assert_array_equal(RawFeatures().fit(windows).transform(windows), windows)


def compose_features(name, *overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name="train", overrides=[f"features={name}", *overrides]).features


def test_configs_build_the_paper_settings_and_unknown_values_fail():
    pemie = build_feature_extractor(compose_features("sabo_vmd_pemie"))
    assert (pemie.fitness, pemie.population, pemie.iterations, tuple(pemie.k_range), tuple(pemie.alpha_range)) == (
        "pe_mie", 15, 20, (3, 10), (100, 3000))
    assert pemie.vmd_params == "global" and pemie.fitness_params["pe_of"] == "selected"
    # The optimizer and its budget are top-level, so one override reaches every SABO-VMD config.
    tpe = build_feature_extractor(compose_features("sabo_vmd_minen", "optimizer=tpe", "search.population=5", "search.windows=3"))
    assert (tpe.optimizer, tpe.population, tpe.search_windows) == ("tpe", 5, 3)
    minen = build_feature_extractor(compose_features("sabo_vmd_minen", "features.vmd_params=per_class"))
    assert (minen.fitness, minen.vmd_params, minen.fitness_params) == ("min_envelope_entropy", "per_class", None)
    assert isinstance(build_feature_extractor(compose_features("raw")), RawFeatures)
    with pytest.raises(BearingTwinError, match="optimizer='annealing'"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "optimizer=annealing"))
    with pytest.raises(BearingTwinError, match="^features.vmd_params='per_window'"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "features.vmd_params=per_window"))
    with pytest.raises(BearingTwinError, match="features.kind='wavelet'"):
        build_feature_extractor({"name": "x", "kind": "wavelet"})
    with pytest.raises(BearingTwinError, match=r"unknown key\(s\) \['popsize'\]"):
        build_feature_extractor({"name": "x", "kind": "sabo_vmd", "popsize": 3})
    with pytest.raises(COMPOSITION_ERRORS, match="popsize"):  # struct mode: a typo on the command line fails
        compose_features("sabo_vmd_pemie", "features.popsize=3")
    with pytest.raises(BearingTwinError, match="^features.seed must be a non-negative integer, got 'abc'$"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "features.seed=abc"))  # was numpy's TypeError
    with pytest.raises(BearingTwinError, match="^search.windows must be a positive integer, got 0$"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "search.windows=0"))
    # Settings the search would trip over minutes later, after the data is built, are named when the extractor is.
    with pytest.raises(BearingTwinError, match=r"^features.k_range must be two whole numbers 2 <= low < high, got \[1, 3\]$"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "features.k_range=[1,3]"))
    with pytest.raises(BearingTwinError, match=r"^features.alpha_range must be two numbers"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "features.alpha_range=[3000,100]"))
    with pytest.raises(BearingTwinError, match="^search.population must be an integer of at least 2, got 'abc'$"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "search.population=abc"))
    with pytest.raises(BearingTwinError, match="^search.population must be an integer of at least 2, got 1$"):
        build_feature_extractor(compose_features("sabo_vmd_pemie", "search.population=1"))  # SABO's agents need another
    assert build_feature_extractor(compose_features("sabo_vmd_pemie", "optimizer=tpe", "search.population=1")).population == 1
    with pytest.raises(BearingTwinError, match="^features.vmd_options.tolerance is not an option of VMD; known: dc, init"):
        build_feature_extractor({**OmegaConf.to_container(compose_features("sabo_vmd_pemie"), resolve=True),
                                 "vmd_options": {"tolerance": 1e-7}})


def small_cfg(**changes):
    cfg = OmegaConf.to_container(compose_features("sabo_vmd_minen"), resolve=True)
    cfg.update(population=4, iterations=1, search_windows=2, vmd_options={"max_iter": 60}, progress=False, **changes)
    return cfg


def test_cache_reuses_an_extraction_and_keys_on_config_dataset_and_split(dataset, tmp_path):
    cfg = small_cfg()
    train = np.arange(0, len(dataset), 2)
    features, table, _ = extract_features(cfg, dataset, train, tmp_path)
    path = cache_path(cfg, dataset, train, tmp_path)
    assert path.exists() and [p.name for p in path.parent.iterdir()] == [path.name]  # no temp file left
    assert features.shape == (len(dataset), 9) and table[0]["scope"] == "global"
    # A hit returns the stored numbers without extracting: prove it by planting a marker.
    marker = np.full_like(features, 7.0)
    np.savez(path, features=marker, table=np.array(json.dumps(table)))
    np.testing.assert_array_equal(extract_features({**cfg, "n_jobs": 2}, dataset, train, tmp_path)[0], marker)
    assert cache_path({**cfg, "seed": 1}, dataset, train, tmp_path) != path
    assert cache_path(cfg, dataset, train[1:], tmp_path) != path
    other = dataclasses.replace(dataset, key="synthetic-v2")
    assert cache_path(cfg, other, train, tmp_path) != path
    per_sample = {**cfg, "vmd_params": "per_sample"}
    assert cache_path(per_sample, dataset, train, tmp_path) == cache_path(per_sample, dataset, train[1:], tmp_path)


def test_training_seeds_share_an_extraction_exactly_when_their_training_windows_are_the_same(dataset, tmp_path):
    """What the README promises: under a block split every seed trains on the same windows, so
    one extraction serves all seeds; a random split draws other windows per seed, so it cannot."""
    from bearingtwin.data.windows import split_indices

    n = len(dataset)
    per_record = n // 4  # one record per class, its windows side by side
    records, starts, lengths = np.repeat(np.arange(4), per_record), np.tile(np.arange(per_record) * LENGTH, 4), [per_record * LENGTH] * 4

    def path(method, seed, vmd_params="global"):
        train, _ = split_indices(dataset.labels, records, starts, lengths, LENGTH, method=method, train_fraction=0.5, seed=seed)
        return cache_path({**small_cfg(), "vmd_params": vmd_params}, dataset, train, tmp_path)

    assert len({path("block", seed) for seed in range(5)}) == 1
    assert len({path("random", seed) for seed in range(5)}) == 5
    assert len({path("random", seed, "per_sample") for seed in range(5)}) == 1


def test_cache_refuses_bad_training_indices(dataset, tmp_path):
    with pytest.raises(BearingTwinError, match="train_index"):
        extract_features(small_cfg(), dataset, [0, len(dataset)], tmp_path)


def test_raw_extraction_returns_the_windows_uncached(dataset, tmp_path):
    features, table, _ = extract_features({"name": "raw", "kind": "raw"}, dataset, [0, 1], tmp_path)
    np.testing.assert_array_equal(features, dataset.windows)
    assert table == [] and not os.path.exists(tmp_path / "features")


@pytest.mark.parametrize("vmd_params", ["global", "per_sample"])
def test_windows_too_short_for_the_modes_searched_are_refused_naming_the_window_length(vmd_params):
    """data.window_length=7 had reached VMD and failed there ("k must be an integer between 1 and the signal length 7
    (got [7, 7, ...])"), naming no setting: a window must give each of the most modes searched two spectral bins."""
    extractor = SaboVmdFeatures(population=2, iterations=1, search_windows=2, vmd_params=vmd_params, progress=False)
    X, y = np.random.default_rng(0).standard_normal((4, 39)), np.array([0, 0, 1, 1])
    with pytest.raises(BearingTwinError, match=r"^windows of 39 samples are too short for VMD into up to 10 modes "
                                               r"\(features.k_range\): give data.window_length=40 or more"):
        extractor.fit_transform(X, y)
    assert extractor.set_params(k_range=(3, 9)).fit_transform(X[:, :36], y).shape == (4, 9)
