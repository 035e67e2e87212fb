"""Datasets from real records: CWRU (real files) and HUST (fixtures), labels as FAULTS indices,
honest block splits versus the paper's leaky random split."""

import logging
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import COMPOSITION_ERRORS, CONF_DIR, data_root
from bearingtwin.data.real import build_cwru_dataset, build_hust_dataset
from bearingtwin.data.windows import split_indices
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS

CWRU = data_root() / "cwru"
HUST = Path(__file__).parent / "fixtures" / "hust"
needs_cwru = pytest.mark.skipif(not (CWRU / "normal_0_97.mat").is_file(), reason=f"CWRU files not found in {CWRU}")


def data_config(name, *overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(overrides=[f"+data={name}", "+paths=default", *overrides]).data


def shared_samples(dataset, train, test, window_length):
    """Number of (record, sample) positions covered by both a training and a test window."""
    covered = []
    for index in (train, test):
        mask = np.zeros((len(dataset.records), max(dataset.record_lengths)), dtype=bool)
        for record, start in zip(dataset.record_ids[index], dataset.starts[index]):
            mask[record, start : start + window_length] = True
        covered.append(mask)
    return int(np.count_nonzero(covered[0] & covered[1]))


@pytest.fixture(scope="module")
def cwru_0hp():
    return build_cwru_dataset(data_config("cwru", f"data.root={CWRU}"))


@needs_cwru
def test_cwru_0hp_has_four_classes_of_150_windows(cwru_0hp):
    assert cwru_0hp.windows.shape == (600, 2048) and cwru_0hp.fs == 12000
    assert cwru_0hp.class_names == FAULTS
    assert np.bincount(cwru_0hp.labels).tolist() == [150, 150, 150, 150]
    names = [Path(record).name for record in cwru_0hp.records]
    assert names == ["normal_0_97.mat", "12k_Drive_End_IR007_0_105.mat", "12k_Drive_End_B007_0_118.mat", "12k_Drive_End_OR007@6_0_130.mat"]


@needs_cwru
def test_block_split_shares_no_sample_and_random_split_leaks(cwru_0hp):
    common = dict(labels=cwru_0hp.labels, record_ids=cwru_0hp.record_ids, starts=cwru_0hp.starts,
                  record_lengths=cwru_0hp.record_lengths, window_length=2048, train_fraction=0.7, seed=0)
    train, test = split_indices(method="block", **common)
    assert shared_samples(cwru_0hp, train, test, 2048) == 0
    train, test = split_indices(method="random", **common)
    assert shared_samples(cwru_0hp, train, test, 2048) > 0


@needs_cwru
def test_cwru_at_2hp_three_fault_classes_keep_faults_labels():
    dataset = build_cwru_dataset(data_config("cwru", "data.load=2", "data.classes=[inner,ball,outer]", "data.samples_per_class=20"), CWRU)
    assert sorted(set(dataset.labels.tolist())) == [FAULTS.index("inner"), FAULTS.index("ball"), FAULTS.index("outer")]
    assert [Path(r).name.split("_")[-1] for r in dataset.records] == ["107.mat", "120.mat", "132.mat"]
    with pytest.raises(BearingTwinError, match="no healthy record at 2 hp.*data.classes=\\[inner,ball,outer\\]"):
        build_cwru_dataset(data_config("cwru", "data.load=2"), CWRU)


@needs_cwru
def test_cwru_contradicted_rate_and_bad_config_are_refused():
    with pytest.raises(BearingTwinError, match="normal_0_97.mat: fs = 48000 Hz contradicts"):
        build_cwru_dataset(data_config("cwru", "+data.fs_by_record={97: 48000}", "data.samples_per_class=5"), CWRU)
    with pytest.raises(BearingTwinError, match="data.load=5"):
        build_cwru_dataset(data_config("cwru", "data.load=5"), CWRU)
    with pytest.raises(BearingTwinError, match="data.split='shuffle'"):
        build_cwru_dataset(data_config("cwru", "data.split=shuffle"), CWRU)


def test_cwru_config_is_struct():
    with pytest.raises(COMPOSITION_ERRORS, match="unknown_key"):
        data_config("cwru", "data.unknown_key=1")


def test_hust_dataset_from_fixtures_is_deterministic():
    cfg = data_config("hust", f"data.root={HUST}", "data.window_length=256", "data.samples_per_class=12")
    dataset = build_hust_dataset(cfg)
    assert dataset.windows.shape == (48, 256) and dataset.fs == 25600
    assert np.bincount(dataset.labels).tolist() == [12, 12, 12, 12]
    assert [Path(r).name for r in dataset.records] == ["H_65Hz.xls", "0.5X_I_65Hz.xls", "0.5X_B_65Hz.xls", "0.5X_O_65Hz.xls"]
    again = build_hust_dataset(cfg)
    np.testing.assert_array_equal(again.windows, dataset.windows)
    assert again.key == dataset.key
    other_channel = build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=256", "data.samples_per_class=12", "data.channel=Y"))
    assert other_channel.key != dataset.key
    resplit = build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=256", "data.samples_per_class=12", "data.split=random"))
    assert resplit.key == dataset.key


def test_hust_missing_files_are_listed(tmp_path):
    (tmp_path / "H_60Hz.xls").write_bytes((HUST / "H_65Hz.xls").read_bytes())
    with pytest.raises(BearingTwinError) as error:
        build_hust_dataset(data_config("hust", f"data.root={tmp_path}", "data.condition=60"))
    message = str(error.value)
    assert "0.5X_I_60Hz.xls, 0.5X_B_60Hz.xls, 0.5X_O_60Hz.xls" in message
    assert "needs H_60Hz.xls, 0.5X_I_60Hz.xls" in message and "data.root=<dir>" in message


def test_hust_record_shorter_than_a_window_is_named_with_the_window_it_holds():
    with pytest.raises(BearingTwinError) as error:
        build_hust_dataset(data_config("hust", f"data.root={HUST}"))
    assert str(error.value).endswith("H_65Hz.xls: 1280 samples, shorter than one window of data.window_length=2048; "
                                     "data.window_length=1131 or less gives data.samples_per_class=150 distinct windows")
    with pytest.raises(BearingTwinError) as error:
        build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.samples_per_class=2000"))
    assert str(error.value).endswith("a data.window_length well below 1280 and fewer windows (data.samples_per_class)")


def test_more_windows_than_a_record_holds_distinct_are_warned_of(caplog):
    """1280 samples hold 1280 - 1024 + 1 = 257 windows of 1024 that differ in their start; asking 300 repeats some."""
    with caplog.at_level(logging.WARNING, logger="bearingtwin"):
        build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=1024",
                                       "data.samples_per_class=300"))
    assert ("(the shortest record): 1280 samples hold 257 distinct windows of data.window_length=1024, fewer than "
            "data.samples_per_class=300: some windows repeat (a shorter data.window_length or a lower "
            "data.samples_per_class avoids it)") in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="bearingtwin"):
        build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=1024",
                                       "data.samples_per_class=257"))
    assert "distinct windows" not in caplog.text


@pytest.mark.parametrize("setting, message", [
    ("data.samples_per_class=abc", "data.samples_per_class must be a positive integer, got 'abc'"),
    ("data.samples_per_class=2.7", "data.samples_per_class must be a positive integer, got 2.7"),
    ("data.window_length=256.5", "data.window_length must be a positive integer, got 256.5"),
    ("data.train_fraction=abc", "data.train_fraction must be a number strictly between 0 and 1, got 'abc'"),
    ("data.channel=W", "data.channel='W' is not a HUST accelerometer axis"),
])
def test_hust_settings_of_the_wrong_kind_are_named(setting, message):
    with pytest.raises(BearingTwinError) as error:
        build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=256", setting))
    assert str(error.value).startswith(message)


def test_hust_records_too_short_for_a_test_window_after_the_split_point_are_named():
    """1280 samples, windows of 512: the last starts at 768, before the 70 % mark (896), so no class has a test
    window; the split names the first class and its file."""
    dataset = build_hust_dataset(data_config("hust", f"data.root={HUST}", "data.window_length=512"))
    with pytest.raises(BearingTwinError, match=r"class normal no test windows .*H_65Hz.xls \(1280 samples, 150 windows\)"):
        split_indices(dataset.labels, dataset.record_ids, dataset.starts, dataset.record_lengths, 512,
                      method="block", class_names=dataset.class_names, records=dataset.records)
