"""Cutting records into windows, and train/test splits that can keep them honest.

The paper cuts each 30 s record into 150 windows of 2048 points and splits the
windows at random 70/30. When the windows of a record overlap (150 x 2048 points
from a 12 kHz, 10 s record do), a random split puts samples that appear in test
windows into training windows as well: the test set is not unseen data. The
``block`` split trains on windows from the first part of every record and tests
on windows from the last part, discarding any window that would straddle the
boundary, so no sample is shared. The ``record`` split holds whole records out for
testing, where a data set has several records of each state.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from bearingtwin.checks import finite_number, physical_memory_bytes, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS

SPLITS = ("random", "block", "record")

BYTES_PER_WINDOW_SAMPLE = 16
"""Peak memory per sample of a data set's windows while they are cut: the float64 windows of every
record, and their copy when they are joined into one array."""


def window_starts(n_samples: int, window_length: int, n_windows: int) -> np.ndarray:
    """First sample of ``n_windows`` windows spread evenly over ``n_samples``.

    The stride follows from the record length: ``(n_samples - window_length) / (n_windows - 1)``,
    rounded down per window, so windows overlap when the record is short and leave gaps
    when it is long. The first window starts at 0 and the last ends at the record's end.
    """
    if window_length < 1 or n_windows < 1:
        raise BearingTwinError(f"data.window_length and the windows per record (data.windows_per_record or "
                               f"data.samples_per_class) must be positive (got {window_length}, {n_windows})")
    if n_samples < window_length:
        raise BearingTwinError(
            f"the record has {n_samples} samples, shorter than one window of {window_length}"
        )
    if n_windows == 1:
        return np.zeros(1, dtype=np.int64)
    return np.floor(np.linspace(0, n_samples - window_length, n_windows)).astype(np.int64)


def cut_windows(signal: np.ndarray, window_length: int, n_windows: int) -> tuple[np.ndarray, np.ndarray]:
    """Cut ``n_windows`` windows of ``window_length`` samples from a 1-D signal.

    Returns:
        windows: (n_windows, window_length) copy of the signal's samples.
        starts: (n_windows,) first sample of each window.
    """
    signal = np.asarray(signal)
    if signal.ndim != 1:
        raise BearingTwinError(f"cut_windows takes a 1-D signal, got shape {signal.shape}")
    window_length = whole_number("window_length", window_length)  # 2048.0 is 2048; 2048.5 no length
    starts = window_starts(signal.size, window_length, whole_number("n_windows", n_windows))
    return signal[starts[:, None] + np.arange(window_length)], starts


def check_windows_fit(n_records: int, window_length: int, windows_per_record: int, count_key: str,
                      records: str = "records", remedy: str = "") -> None:
    """Refuse windows that would need over half the machine's memory, before any is cut (``count_key`` is
    the setting ``windows_per_record`` comes from, as the message names it; ``records`` says what the
    records are and ``remedy`` what else lowers their number)."""
    need = n_records * windows_per_record * window_length * BYTES_PER_WINDOW_SAMPLE
    memory = physical_memory_bytes()
    if memory is not None and need > memory / 2:
        raise BearingTwinError(
            f"{count_key}={windows_per_record} windows of data.window_length={window_length} samples from each of "
            f"{n_records} {records} need about {need / 1e9:.3g} GB of memory, more than half of this machine's "
            f"{memory / 1e9:.3g} GB: lower {count_key} or data.window_length{remedy}"
        )


WINDOW_NORMALIZATIONS = ("none", "zscore")


def normalize_windows(windows: np.ndarray, method: str = "zscore") -> np.ndarray:
    """Each window (row) to zero mean and unit standard deviation (``zscore``), or as is (``none``).

    Used where the training data and the data to diagnose differ in unit or gain (a twin in
    m/s^2, a CWRU record in g): what is left is the window's shape.
    """
    if method not in WINDOW_NORMALIZATIONS:
        raise BearingTwinError(f"window normalization {method!r}: choose one of {', '.join(WINDOW_NORMALIZATIONS)}")
    windows = np.asarray(windows, dtype=np.float64)
    if method == "none":
        return windows
    with np.errstate(over="ignore"):
        std = windows.std(axis=-1, keepdims=True)
    overflowed = ~np.isfinite(std)  # values near 1e154 and above overflow the sum of squares: scale those first
    if np.any(overflowed):
        peak = np.max(np.abs(windows), axis=-1, keepdims=True)
        windows = np.divide(windows, peak, out=windows.copy(), where=overflowed & (peak > 0))
        std = windows.std(axis=-1, keepdims=True)
    constant = np.flatnonzero(std.reshape(-1) == 0)
    if constant.size:
        raise BearingTwinError(f"window {constant[0] + 1} of {std.size} is constant (a dropout, or a stretch held at one "
                               "value), so it has no scale to normalize")
    return (windows - windows.mean(axis=-1, keepdims=True)) / std


def check_train_fraction(value) -> float:
    """``data.train_fraction`` as a float strictly between 0 and 1."""
    fraction = finite_number("data.train_fraction", value, "a number strictly between 0 and 1")
    if not 0.0 < fraction < 1.0:
        raise BearingTwinError(f"data.train_fraction must lie strictly between 0 and 1, got {value!r}")
    return fraction


def check_split(method, train_fraction) -> float:
    """``data.split`` (one of SPLITS) and ``data.train_fraction``, the latter returned as a float."""
    if method not in SPLITS:
        raise BearingTwinError(f"data.split={method!r} is not a split method; choose one of {', '.join(SPLITS)}")
    return check_train_fraction(train_fraction)


def check_stratified(class_counts: Sequence[int], train_fraction: float) -> None:
    """Raise where a stratified split of windows counted ``class_counts`` (per class) cannot give every class a
    training and a test window at ``train_fraction``; a data source that knows its counts from its config alone
    asks before any window is cut."""
    n_windows, n_classes, fewest = int(sum(class_counts)), len(class_counts), int(min(class_counts))
    n_train = int(np.floor(train_fraction * n_windows))  # as train_test_split rounds
    if fewest < 2 or min(n_train, n_windows - n_train) < n_classes:
        raise BearingTwinError(
            f"too few windows for a stratified split: {n_windows} windows ({fewest} in the smallest class) cannot "
            f"give every one of {n_classes} classes a training and a test window at data.train_fraction={train_fraction:g}; "
            "raise data.samples_per_class (data.windows_per_record under data=files)"
        )


def split_indices(
    labels: np.ndarray,
    record_ids: np.ndarray,
    starts: np.ndarray,
    record_lengths: np.ndarray,
    window_length: int,
    method: str = "block",
    train_fraction: float = 0.7,
    seed: int = 0,
    class_names: Sequence[str] = FAULTS,
    records: Sequence[str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the training and test windows; every class of ``labels`` has some of both.

    Args:
        labels: (n,) class of each window; ``random`` stratifies on it.
        record_ids: (n,) the record each window came from.
        starts: (n,) first sample of each window in its record.
        record_lengths: (n_records,) samples in each record.
        window_length: samples per window.
        method: ``random`` (the paper's: stratified shuffle of windows), ``block`` (train
            on windows lying wholly in the first ``train_fraction`` of their record, test on
            windows lying wholly in the rest; windows straddling the boundary are dropped) or
            ``record`` (whole records: of each class's records, a seeded ``train_fraction`` trains,
            the rest tests, so no recording, and no bearing recorded once, is on both sides).
        train_fraction: share of windows (random), of each record (block) or of each class's records
            (record, rounded, at least one on each side) used for training.
        seed: seeds the random split.
        class_names, records: the name of each label and the source of each record, for messages
            (default: FAULTS, and records by their index).

    Returns:
        (train_index, test_index), sorted int arrays.
    """
    train_fraction = check_split(method, train_fraction)
    labels = np.asarray(labels)
    if method == "random":
        from sklearn.model_selection import train_test_split

        index = np.arange(labels.size)
        check_stratified(np.unique(labels, return_counts=True)[1], train_fraction)
        train, test = train_test_split(index, train_size=train_fraction, stratify=labels, random_state=seed)
        return np.sort(train), np.sort(test)
    record_ids, record_lengths = np.asarray(record_ids), np.asarray(record_lengths)
    if method == "record":
        return _whole_records(labels, record_ids, train_fraction, seed, class_names, records)
    boundary = np.floor(record_lengths[record_ids] * train_fraction)
    ends = np.asarray(starts) + window_length
    train = np.flatnonzero(ends <= boundary)
    test = np.flatnonzero(np.asarray(starts) >= boundary)
    for label in np.unique(labels):
        missing = [part for part, index in (("training", train), ("test", test)) if not np.any(labels[index] == label)]
        if missing:  # scored without the class, a run would report the others' accuracy as the model's
            raise BearingTwinError(_block_split_shortfall(
                class_names[label], " and no ".join(missing), np.unique(record_ids[labels == label]), record_ids,
                record_lengths, window_length, train_fraction, records))
    return train, test


def _whole_records(labels: np.ndarray, record_ids: np.ndarray, train_fraction: float, seed: int,
                   class_names: Sequence[str], records: Sequence[str] | None) -> tuple[np.ndarray, np.ndarray]:
    """The ``record`` split: each class's records shuffled (seeded) and cut at ``train_fraction``, rounded, with
    at least one record on each side. Written here because scikit-learn's grouped splitters either ignore the classes
    (GroupShuffleSplit) or fix the fraction by a fold count (StratifiedGroupKFold)."""
    rng = np.random.default_rng(seed)
    training_records = []
    for label in np.unique(labels):
        own = np.unique(record_ids[labels == label])
        if own.size < 2:
            named = ", ".join(Path(records[i]).name if records is not None else f"record {i}" for i in own)
            raise BearingTwinError(f"data.split=record needs two records or more of each class; {class_names[label]} "
                                   f"has one ({named}): give more recordings of it, or use data.split=block")
        n_train = min(max(int(round(train_fraction * own.size)), 1), own.size - 1)
        training_records += rng.permutation(own)[:n_train].tolist()
    in_training = np.isin(record_ids, training_records)
    return np.flatnonzero(in_training), np.flatnonzero(~in_training)


def _block_split_shortfall(name: str, missing: str, class_records: np.ndarray, record_ids: np.ndarray,
                           record_lengths: np.ndarray, window_length: int, train_fraction: float,
                           records: Sequence[str] | None) -> str:
    """Why the block split leaves class ``name`` no ``missing`` windows, naming its records, and what would help."""
    listing = ", ".join(f"{Path(records[i]).name if records is not None else f'record {i}'} "
                        f"({record_lengths[i]} samples, {np.count_nonzero(record_ids == i)} windows)"
                        for i in class_records)
    # A record holds a window on each side of its split point from this length on (with two windows or more:
    # the first starts at 0, the last ends at the record's end).
    needed = math.ceil(window_length / min(train_fraction, 1.0 - train_fraction))
    if np.all(record_lengths[class_records] >= needed):
        advice = "Cut more than one window from each record (data.windows_per_record or data.samples_per_class)"
    else:
        advice = (f"Give records of at least {needed} samples, a data.train_fraction nearer 0.5 or a shorter "
                  "data.window_length")
    return (f"the block split leaves class {name} no {missing} windows at data.train_fraction={train_fraction:g} "
            f"with windows of {window_length} samples; its records: {listing}. {advice}")
