"""Windowing and splits: the stride follows the record, and the block split shares no sample."""

import numpy as np
import pytest

from bearingtwin.data.recording import Recording
from bearingtwin.data.windows import cut_windows, split_indices, window_starts
from bearingtwin.errors import BearingTwinError


def test_windows_span_the_record_and_copy_its_samples():
    signal = np.arange(10_000.0)
    windows, starts = cut_windows(signal, window_length=2048, n_windows=5)
    assert windows.shape == (5, 2048)
    assert starts[0] == 0 and starts[-1] + 2048 == signal.size
    np.testing.assert_array_equal(windows[:, 0], starts)
    np.testing.assert_array_equal(windows[3], signal[starts[3] : starts[3] + 2048])


def test_windows_overlap_when_the_record_is_short():
    # The paper's 150 windows of 2048 points from a 10 s, 12 kHz record must overlap.
    starts = window_starts(120_000, 2048, 150)
    assert np.all(np.diff(starts) < 2048)


def test_a_record_shorter_than_one_window_is_an_error_not_padding():
    with pytest.raises(BearingTwinError, match="shorter than one window"):
        cut_windows(np.zeros(1000), window_length=2048, n_windows=1)


def _two_records(n_per_record=150, length=60_000, window=2048):
    starts = window_starts(length, window, n_per_record)
    return (
        np.repeat([0, 1], n_per_record),  # labels
        np.repeat([0, 1], n_per_record),  # record ids
        np.tile(starts, 2),
        np.array([length, length]),
    )


def test_block_split_shares_no_sample_between_train_and_test():
    labels, record_ids, starts, lengths = _two_records()
    train, test = split_indices(labels, record_ids, starts, lengths, 2048, method="block")
    for record in (0, 1):
        train_samples = {
            s for i in train[record_ids[train] == record] for s in range(starts[i], starts[i] + 2048)
        }
        test_samples = {s for i in test[record_ids[test] == record] for s in range(starts[i], starts[i] + 2048)}
        assert train_samples and test_samples
        assert not train_samples & test_samples


def test_random_split_of_overlapping_windows_leaks_samples():
    labels, record_ids, starts, lengths = _two_records()
    train, test = split_indices(labels, record_ids, starts, lengths, 2048, method="random", seed=0)
    assert abs(len(test) / len(labels) - 0.3) < 0.01
    train_samples = {s for i in train[record_ids[train] == 0] for s in range(starts[i], starts[i] + 2048)}
    test_samples = {s for i in test[record_ids[test] == 0] for s in range(starts[i], starts[i] + 2048)}
    assert len(train_samples & test_samples) > 0.5 * len(test_samples)


def test_random_split_is_stratified_and_seeded():
    labels, record_ids, starts, lengths = _two_records()
    a = split_indices(labels, record_ids, starts, lengths, 2048, method="random", seed=1)
    b = split_indices(labels, record_ids, starts, lengths, 2048, method="random", seed=1)
    c = split_indices(labels, record_ids, starts, lengths, 2048, method="random", seed=2)
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])
    assert np.bincount(labels[a[1]]).tolist() == [45, 45]


def test_record_split_keeps_every_recording_on_one_side_and_every_class_on_both():
    """Several recordings of each state (a user's rig, three bearings a state): the block split puts every recording
    on both sides (its start trains, its end tests), so the test is of the same bearings; the record split keeps
    each recording whole on one side, every class on both, seeded; a class recorded once is refused by name."""
    n_records, per_record = 12, 10
    record_ids = np.repeat(np.arange(n_records), per_record)
    labels = record_ids % 4  # four states, three recordings each
    starts = np.tile(np.arange(per_record) * 1000, n_records)
    lengths = np.full(n_records, per_record * 1000)
    block_train, block_test = split_indices(labels, record_ids, starts, lengths, 1000, method="block")
    assert set(record_ids[block_train]) == set(record_ids[block_test]) == set(range(n_records))
    train, test = split_indices(labels, record_ids, starts, lengths, 1000, method="record", seed=3)
    assert not set(record_ids[train]) & set(record_ids[test]) and train.size + test.size == labels.size
    assert set(labels[train]) == set(labels[test]) == {0, 1, 2, 3}
    assert all(np.unique(record_ids[train][labels[train] == label]).size == 2 for label in range(4))  # 0.7 of 3
    again = split_indices(labels, record_ids, starts, lengths, 1000, method="record", seed=3)
    np.testing.assert_array_equal(again[0], train)
    assert any(not np.array_equal(split_indices(labels, record_ids, starts, lengths, 1000, method="record", seed=seed)[0],
                                  train) for seed in range(4, 10))
    once = record_ids < 9  # the last three recordings left out: state 0 keeps records 0, 4, 8; state 3 keeps 3, 7
    lonely = labels[once].copy()
    lonely[record_ids[once] == 7] = 0  # record 7 relabelled: state 3 is recorded once, by record 3
    with pytest.raises(BearingTwinError, match=r"^data.split=record needs two records or more of each class; outer "
                                               r"has one \(a.wav\): give more recordings of it, or use data.split=block$"):
        split_indices(lonely, record_ids[once], starts[once], lengths[:9], 1000, method="record",
                      records=[f"{name}.wav" for name in "bcdaefghi"])


def test_unknown_split_names_the_choices():
    labels, record_ids, starts, lengths = _two_records()
    with pytest.raises(BearingTwinError, match="^data.split=.kfold. is not a split method; choose one of random, block, record"):
        split_indices(labels, record_ids, starts, lengths, 2048, method="kfold")


def test_recording_rejects_nan_and_names_the_source():
    signal = np.ones(100)
    signal[7] = np.nan
    with pytest.raises(BearingTwinError, match=r"rec\.npy: 1 NaN"):
        Recording(signal, fs=1000, source="rec.npy")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"signal": np.ones((2, 10))}, "one channel"),
        ({"signal": np.array([])}, "empty"),
        ({"signal": np.array(["a", "b"])}, "not numeric"),
        ({"fs": 0}, "sampling rate"),
        ({"rpm": -1}, "rpm"),
        ({"fault": "cage"}, "fault='cage'"),
    ],
)
def test_recording_validates_its_fields(kwargs, message):
    args = {"signal": np.ones(10), "fs": 1000.0, **kwargs}
    with pytest.raises(BearingTwinError, match=message):
        Recording(**args)


def test_zscore_of_values_that_overflow_their_squares_is_the_same_shape():
    """A window near 1e160 (a record in a unit far too small) overflows the sum of squares; it is
    normalised to the shape of the same window at a sane scale, and the other rows are untouched."""
    from bearingtwin.data.windows import normalize_windows

    windows = np.random.default_rng(0).normal(size=(3, 256))
    scaled = windows.copy()
    scaled[1] *= 1e160
    with np.errstate(all="raise"):  # no overflow reaches the caller either
        normalized = normalize_windows(scaled)
    np.testing.assert_array_equal(normalized[[0, 2]], normalize_windows(windows)[[0, 2]])
    np.testing.assert_allclose(normalized[1], normalize_windows(windows)[1], atol=1e-12)


def _one_short_record(short_length: int, windows_per_record: int = 10):
    """Record 0 (normal, 60000 samples) and record 1 (inner, ``short_length``), windows of 2048."""
    starts = [window_starts(60_000, 2048, windows_per_record), window_starts(short_length, 2048, windows_per_record)]
    labels = np.repeat([0, 1], windows_per_record)
    return labels, labels.copy(), np.concatenate(starts), np.array([60_000, short_length])


def test_block_split_refuses_a_class_its_records_cannot_give_both_training_and_test_windows():
    """A short record's windows all fall before (or across) the split point: scored without the class, the
    accuracy would be the other classes'."""
    with pytest.raises(BearingTwinError, match=r"^the block split leaves class inner no test windows at "
                       r"data.train_fraction=0.7 .*its records: b.npy \(4000 samples, 10 windows\)\. "
                       r"Give records of at least 6827 samples, a data.train_fraction nearer 0.5"):
        split_indices(*_one_short_record(4000), 2048, method="block", records=["/x/a.npy", "/x/b.npy"])
    with pytest.raises(BearingTwinError, match=r"class inner no training and no test windows.*record 1 \(2100 samples"):
        split_indices(*_one_short_record(2100), 2048, method="block")
    with pytest.raises(BearingTwinError, match=r"class normal no test windows.*Cut more than one window"):
        split_indices(*_one_short_record(60_000, windows_per_record=1), 2048, method="block")
    train, test = split_indices(*_one_short_record(6827), 2048, method="block")  # the length the message asks for
    labels = _one_short_record(6827)[0]
    assert set(labels[train]) == set(labels[test]) == {0, 1}


@pytest.mark.parametrize("fraction, message", [
    ("abc", "data.train_fraction must be a number strictly between 0 and 1, got 'abc'"),
    (True, "data.train_fraction must be a number strictly between 0 and 1, got True"),
    (1.5, "data.train_fraction must lie strictly between 0 and 1, got 1.5"),
])
def test_a_train_fraction_that_is_no_fraction_is_named(fraction, message):
    labels, record_ids, starts, lengths = _two_records()
    with pytest.raises(BearingTwinError) as error:
        split_indices(labels, record_ids, starts, lengths, 2048, train_fraction=fraction)
    assert str(error.value) == message


def test_a_constant_window_is_named_by_its_place():
    from bearingtwin.data.windows import normalize_windows

    windows = np.random.default_rng(0).standard_normal((5, 64))
    windows[3] = 0.25  # a dropout held at one value
    with pytest.raises(BearingTwinError, match=r"^window 4 of 5 is constant \(a dropout"):
        normalize_windows(windows)
