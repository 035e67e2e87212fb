"""Caches heal: a damaged entry of each of the three caches is named, removed and recomputed.

Each cache is filled for real, its file damaged as storage damages files (cut short,
emptied, one bit flipped), and the next read must give the original numbers with one
warning naming the file.
"""

import logging

import numpy as np
import pytest
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.data.simulated import build_simulated_dataset
from bearingtwin.data.twin_to_real import twin_signals
from bearingtwin.features.cache import cache_path, extract_features

from test_extractor import dataset, data, small_cfg  # noqa: F401  (fixtures)

BEARING = OmegaConf.load(f"{CONF_DIR}/bearing/paper.yaml")
SIMULATOR = OmegaConf.load(f"{CONF_DIR}/simulator/default.yaml")
DATA = OmegaConf.merge(OmegaConf.load(f"{CONF_DIR}/data/simulated.yaml"),
                       {"duration": 0.3, "samples_per_class": 4, "window_length": 512, "n_jobs": 1})


def damage(path, how: str) -> None:
    content = path.read_bytes()
    if how == "truncated":
        path.write_bytes(content[: len(content) // 2])
    elif how == "empty":
        path.write_bytes(b"")
    else:  # one bit flipped in the middle of the stored arrays: only the CRC can tell
        middle = len(content) // 2
        path.write_bytes(content[:middle] + bytes([content[middle] ^ 0x01]) + content[middle + 1:])


def only_file(folder):
    (path,) = list(folder.iterdir())
    return path


def assert_healed(caplog, path, rebuild, expected):
    """One warning naming the damaged entry, no temporary file left, and the entry rewritten whole: read back by
    ``rebuild`` with no warning, it gives ``expected``."""
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and str(path) in warnings[0] and "unreadable" in warnings[0]
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary file left
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        np.testing.assert_array_equal(rebuild(), expected)
    assert not [r for r in caplog.records if r.levelno == logging.WARNING]


HOW = ["truncated", "empty", "bit-flipped"]


@pytest.mark.parametrize("how", HOW)
def test_simulated_dataset_cache(tmp_path, caplog, how):
    first = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)
    path = only_file(tmp_path / "simulated")
    damage(path, how)
    with caplog.at_level(logging.WARNING):
        again = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)
    np.testing.assert_array_equal(again.windows, first.windows)
    assert_healed(caplog, path, lambda: build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path).windows,
                  first.windows)


@pytest.mark.parametrize("how", HOW)
def test_twin_to_real_cache(tmp_path, caplog, how):
    simulator = {**OmegaConf.to_container(SIMULATOR, resolve=True), "duration": 0.3}
    bearing = OmegaConf.to_container(BEARING, resolve=True)
    first, key = twin_signals(["outer"], [1797.0], bearing, simulator, {}, tmp_path)
    path = only_file(tmp_path / "twin_to_real")
    damage(path, how)
    with caplog.at_level(logging.WARNING):
        again, same_key = twin_signals(["outer"], [1797.0], bearing, simulator, {}, tmp_path)
    np.testing.assert_array_equal(again, first)
    assert same_key == key
    assert_healed(caplog, path, lambda: twin_signals(["outer"], [1797.0], bearing, simulator, {}, tmp_path)[0], first)


@pytest.mark.parametrize("how", HOW)
def test_features_cache(dataset, tmp_path, caplog, how):  # noqa: F811
    cfg = small_cfg()
    train = np.arange(0, len(dataset), 2)
    first, table, _ = extract_features(cfg, dataset, train, tmp_path)
    path = cache_path(cfg, dataset, train, tmp_path)
    damage(path, how)
    with caplog.at_level(logging.WARNING):
        again, again_table, _ = extract_features(cfg, dataset, train, tmp_path)
    np.testing.assert_array_equal(again, first)
    assert again_table == table
    assert_healed(caplog, path, lambda: extract_features(cfg, dataset, train, tmp_path)[0], first)


def test_atomic_writes_leave_the_whole_file_or_the_old_one(tmp_path):
    """save_npz_atomic and save_npy_atomic: the file holds what was written and nothing else is left in its folder; a
    write that fails part-way leaves the earlier file as it was and no temporary file."""
    from bearingtwin.storage import save_npy_atomic, save_npz_atomic

    array = np.arange(12.0).reshape(3, 4)
    save_npy_atomic(tmp_path / "a.npy", array)
    save_npz_atomic(tmp_path / "b.npz", signals=array)
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), array)
    np.testing.assert_array_equal(np.load(tmp_path / "b.npz")["signals"], array)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npz"]
    # A team's shared cache: an entry gets the mode any new file gets under the umask, not a temporary file's 0600.
    import os
    import stat

    mask = os.umask(0o022)
    try:
        save_npz_atomic(tmp_path / "shared.npz", signals=array)
    finally:
        os.umask(mask)
    assert stat.S_IMODE((tmp_path / "shared.npz").stat().st_mode) == 0o644
    (tmp_path / "shared.npz").unlink()

    class Unsaveable:  # np.save pickles objects it cannot store as arrays; this one refuses part-way
        def __reduce__(self):
            raise RuntimeError("disk gone")

    with pytest.raises(RuntimeError, match="disk gone"):
        save_npy_atomic(tmp_path / "a.npy", np.array([Unsaveable()], dtype=object))
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), array)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npz"]


def test_an_entry_computed_by_other_code_is_a_miss_while_an_edit_of_words_alone_keeps_it(tmp_path, monkeypatch):
    """Cache entries were keyed by their configuration alone: a changed computation got the numbers of the code before
    it. The code's key changes with the code and stays with its docstrings and comments."""
    import bearingtwin.storage as storage

    package = tmp_path / "bearingtwin"
    (package / "physics").mkdir(parents=True)
    module = package / "physics" / "impacts.py"
    monkeypatch.setattr(storage, "PACKAGE", package)

    def key(text: str) -> str:
        module.write_text(text)
        storage.code_fingerprint.cache_clear()
        return storage.code_fingerprint("physics")

    base = key('"""Impacts."""\n\ndef force(x):\n    """Hertz."""\n    return x ** 1.5\n')
    assert key('"""Impacts, reworded."""\n\ndef force(x):\n    """Hertz, 1896."""\n    return x ** 1.5  # why\n') == base
    assert key('"""Impacts."""\n\ndef force(x):\n    """Hertz."""\n    return x ** 1.4\n') != base
    # A constant's words below it, as physics/ and signal/ document their constants, are words too.
    constant = key('EXPONENT = 1.5\n"""Hertz."""\n')
    assert key('EXPONENT = 1.5\n"""Hertz, for a point contact."""\n') == constant != key('EXPONENT = 1.4\n"""Hertz."""\n')
    # A module named beside a subpackage (the Recording a simulation returns, in data/): its edits change the key,
    # the other modules of its package do not.
    (package / "data").mkdir()
    container = package / "data" / "recording.py"
    container.write_text("def signal(x):\n    return x\n")
    storage.code_fingerprint.cache_clear()
    with_container = storage.code_fingerprint("physics", "data/recording.py")
    assert with_container != storage.code_fingerprint("physics")
    container.write_text("def signal(x):\n    return -x\n")
    storage.code_fingerprint.cache_clear()
    changed = storage.code_fingerprint("physics", "data/recording.py")
    assert changed != with_container
    (package / "data" / "other.py").write_text("X = 1\n")  # a module beside it, not named, is not read
    storage.code_fingerprint.cache_clear()
    assert storage.code_fingerprint("physics", "data/recording.py") == changed
    storage.code_fingerprint.cache_clear()
    monkeypatch.undo()
    from bearingtwin.storage import SIMULATION_CODE
    assert all((storage.PACKAGE / part).exists() for part in SIMULATION_CODE)


def test_a_cache_that_cannot_take_an_entry_is_said_and_the_numbers_computed_are_used(dataset, tmp_path,  # noqa: F811
                                                                                   caplog):
    """A read-only shared cache or a full disk: the features had been computed in full, then lost to a PermissionError
    or 'No space left on device' traceback, the run FAILED. Now one warning names the entry, and the run goes on with
    the numbers it computed."""
    import errno

    from bearingtwin.storage import save_npy_atomic

    cfg = small_cfg()
    train = np.arange(0, len(dataset), 2)
    expected, _, _ = extract_features(cfg, dataset, train, tmp_path / "good")
    blocked = tmp_path / "not_a_folder"
    blocked.write_text("a file where the cache's folder would be")  # no folder can be made under it, even by root
    with caplog.at_level(logging.WARNING):
        features, _, _ = extract_features(cfg, dataset, train, blocked)
    np.testing.assert_array_equal(features, expected)
    (said,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert said.startswith(f"cache entry {blocked}/features/") and "the run goes on" in said
    caplog.clear()

    class DiskFull:  # np.save pickles objects it cannot store as arrays; this one meets a full disk part-way
        def __reduce__(self):
            raise OSError(errno.ENOSPC, "No space left on device")

    with caplog.at_level(logging.WARNING):
        save_npy_atomic(tmp_path / "full" / "a.npy", np.array([DiskFull()], dtype=object))
    assert list((tmp_path / "full").iterdir()) == []  # no partial entry, no temporary file
    assert "not written (No space left on device)" in caplog.records[0].getMessage()


def test_a_cache_that_takes_no_entries_simulates_the_twins_variants_once_each(tmp_path, monkeypatch, caplog):
    """The parallel workers hand their records back through the cache: into one that takes no entries, every variant
    had been simulated by a worker, lost, and simulated again where it was read. Now they are simulated where read,
    once, and the warning says why."""
    import joblib

    from bearingtwin.data import twin_to_real

    def no_workers(*args, **kwargs):
        raise AssertionError("workers started for a cache that takes no entries")

    monkeypatch.setattr(joblib, "Parallel", no_workers)
    blocked = tmp_path / "not_a_folder"
    blocked.write_text("a file where the cache's folder would be")
    simulator = {**OmegaConf.to_container(SIMULATOR, resolve=True), "duration": 0.3}
    variants = [(simulator, {}), ({**simulator, "seed": 1}, {})]
    with caplog.at_level(logging.WARNING):
        twin_to_real.simulate_variants(["outer"], [1797.0], OmegaConf.to_container(BEARING, resolve=True), variants,
                                       blocked, n_jobs=2)
    (said,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert said == f"{blocked / 'twin_to_real'} takes no new entries: the twin's 2 variants are simulated one by one, as they are read"
