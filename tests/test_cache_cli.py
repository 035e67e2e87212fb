"""bearingtwin-cache: what the cache holds per kind, entries marked used when read, and the removal of those no
command has used for a while, which touches nothing but the project's entries; bad settings refused in one line."""

import os
import time

import numpy as np
import pytest

from bearingtwin.cli.cache import main
from bearingtwin.data.simulated import build_simulated_dataset
from bearingtwin.storage import cache_entries, load_npz_or_heal, remove_unused, save_npz_atomic

from processes import run_here
from test_cache_healing import BEARING, DATA, SIMULATOR, only_file

DAY_S = 86400


def run(capsys, monkeypatch, *overrides):
    """``bearingtwin-cache <overrides>`` in this process: exit status, stdout, stderr."""
    return run_here(main, "bearingtwin-cache", capsys, monkeypatch, *overrides)


def age(path, days: float, read_days: float | None = None) -> None:
    """Make ``path`` look written ``days`` ago and last read ``read_days`` ago (as long ago, if not given)."""
    now = time.time()
    os.utime(path, (now - (days if read_days is None else read_days) * DAY_S, now - days * DAY_S),
             follow_symlinks=False)


def entry(folder, name: str, size: int, days: float):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(b"x" * size)
    age(path, days)
    return path


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A cache of every kind: two entries unused for 40 days (one a temporary file a killed write left), two used
    yesterday, and numba's kernels (where NUMBA_CACHE_DIR points), as old."""
    root = tmp_path / "cache"
    files = {
        "old simulated": entry(root / "simulated", "records-a.npz", 1500, 40),
        "new simulated": entry(root / "simulated", "records-b.npz", 500, 1),
        "old twin": entry(root / "twin_to_real", "records-cabc123.tmp", 2000, 40),
        "new features": entry(root / "features", "features-d.npz", 3000, 1),
        "numba": entry(root / "numba" / "bearingtwin", "kernel.nbi", 700, 40),
    }
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(root / "numba"))
    return root, files


def line_of(out: str, first_word: str) -> str:
    return next(line for line in out.splitlines() if line.split() and line.split()[0] == first_word)


def test_the_report_counts_each_kind_and_removes_nothing(cache, capsys, monkeypatch):
    root, files = cache
    code, out, err = run(capsys, monkeypatch, f"paths.cache_dir={root}")
    assert code == 0 and err == ""
    assert out.splitlines()[0] == f"cache: {root}"
    assert "2 entries" in line_of(out, "simulated") and "2.0 kB" in line_of(out, "simulated")  # 1500 + 500 bytes
    assert "1 entry " in line_of(out, "twin_to_real") and "2.0 kB" in line_of(out, "twin_to_real")
    assert "4 entries" in line_of(out, "total") and "7.0 kB" in line_of(out, "total")  # numba's kernels are not entries
    assert out.splitlines()[-1].startswith(f"numba's compiled kernels: {root / 'numba'}, 700 B (numba's own")
    assert all(path.exists() for path in files.values())


def test_unused_days_counts_what_remove_removes_and_numba_stays(cache, capsys, monkeypatch):
    root, files = cache
    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=30")
    assert code == 0 and out.splitlines()[-1] == "unused for 30 days: 2 entries, 3.5 kB; remove=true removes them"
    assert all(path.exists() for path in files.values())

    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=30", "remove=true")
    assert code == 0 and out.splitlines()[-1] == "removed (unused for 30 days): 2 entries, 3.5 kB freed"
    assert {name for name, path in files.items() if path.exists()} == {"new simulated", "new features", "numba"}

    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=0", "remove=true")
    assert code == 0 and out.splitlines()[-1] == "removed (every entry): 2 entries, 3.5 kB freed"
    assert {name for name, path in files.items() if path.exists()} == {"numba"}


def test_nothing_but_the_projects_entries_is_touched_nor_anything_through_a_link(cache, tmp_path, capsys,
                                                                                 monkeypatch):
    """A folder given as the cache by mistake (a home, ~/.cache), a file of the user's own beside the entries, and a
    kind's folder or an entry that is a link to somewhere else: none is counted, and none removed."""
    root, files = cache
    outside = tmp_path / "outside"
    foreign = [entry(root / "src" / "pkg", "module.py", 100, 60), entry(root / "simulated", "notes.txt", 100, 60),
               entry(root / "simulated" / "sub", "records-x.npz", 100, 60), entry(outside, "precious.npz", 100, 60),
               entry(outside / "deep", "precious.npz", 100, 60)]
    (root / "features" / "linked.npz").symlink_to(outside / "precious.npz")
    age(root / "features" / "linked.npz", 60)
    files["old twin"].unlink()
    (root / "twin_to_real").rmdir()
    (root / "twin_to_real").symlink_to(outside)
    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}")
    assert code == 0 and "3 entries" in line_of(out, "total")
    assert line_of(out, "twin_to_real").endswith(f"a link to {outside}: not followed")
    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=30", "remove=true")
    assert code == 0 and out.splitlines()[-1] == "removed (unused for 30 days): 1 entry, 1.5 kB freed"
    assert all(path.exists() for path in foreign) and (root / "features" / "linked.npz").is_symlink()
    assert not files["old simulated"].exists()


def test_a_teammates_read_keeps_an_entry_a_fresh_temporary_file_stays_and_so_does_one_read_since_it_was_listed(
        cache, capsys, monkeypatch):
    """Another user's read cannot set an entry's modification time, but sets its access time (Linux's relatime); a
    temporary file an hour old may be a write still running; and an entry read between the listing and the removal
    is used, whatever the listing said."""
    root, files = cache
    age(files["old simulated"], 40, read_days=2)  # written 40 days ago, read by a teammate two days ago
    writing = entry(root / "features", "features-e.tmp", 100, 0.01)  # a quarter of an hour old
    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=0")
    assert code == 0 and out.splitlines()[-1] == "every entry: 4 entries, 7.0 kB; remove=true removes them"
    listed = cache_entries(root)
    os.utime(files["new features"])  # read now, after the listing
    removed, failed = remove_unused(listed, 30 * DAY_S - 1, time.time())
    assert [entry.path for entry in removed] == [files["old twin"]] and not failed
    removed, failed = remove_unused(listed, 0.0, time.time() - 60)
    assert {entry.path for entry in removed} == {files["old simulated"], files["new simulated"]} and not failed
    assert files["new features"].exists() and writing.exists()


def test_an_entry_that_cannot_be_removed_is_named_the_others_go_and_the_exit_status_says_so(cache, capsys,
                                                                                            monkeypatch):
    root, files = cache
    unlink = type(files["old twin"]).unlink

    def refuse_one(path, missing_ok=False):
        if path == files["old twin"]:
            raise PermissionError(13, "Permission denied", str(path))
        unlink(path, missing_ok=missing_ok)

    monkeypatch.setattr(type(files["old twin"]), "unlink", refuse_one)
    code, out, err = run(capsys, monkeypatch, f"paths.cache_dir={root}", "unused_days=30", "remove=true")
    assert code == 1
    assert out.splitlines()[-1] == "removed (unused for 30 days): 1 entry, 1.5 kB freed"
    assert err.strip() == f"error: 1 entry could not be removed (Permission denied), {files['old twin']} among them"
    assert files["old twin"].exists() and not files["old simulated"].exists()


def test_a_missing_cache_is_empty_and_not_made(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    code, out, _ = run(capsys, monkeypatch, f"paths.cache_dir={tmp_path / 'none'}", "unused_days=1", "remove=true")
    assert code == 0 and out.splitlines() == [f"cache: {tmp_path / 'none'} (no such folder: nothing cached yet)",
                                              "removed (unused for 1 day): 0 entries, 0 B freed"]
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize("overrides, named", [
    (["unused_days=-1"], "unused_days must be a number of days, 0 or more, got -1"),
    (["unused_days=soon"], "unused_days must be a number of days, 0 or more, got 'soon'"),
    (["remove=true"], "remove=true removes the entries unused for unused_days=<days>"),
    (["unused_days=3", "remove=maybe"], "remove must be true or false, got 'maybe'"),
    (["paths.cache_dir=", "unused_days=0", "remove=true"], "paths.cache_dir must name the cache's folder, got ''"),
])
def test_bad_settings_are_refused_in_one_line(cache, capsys, monkeypatch, overrides, named):
    root, files = cache
    code, out, err = run(capsys, monkeypatch, f"paths.cache_dir={root}", *overrides)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and err.startswith(f"error: {named}"), err
    assert all(path.exists() for path in files.values())


def test_a_file_for_the_cache_is_refused(tmp_path, capsys, monkeypatch):
    (tmp_path / "cache").write_text("not a folder")
    code, _, err = run(capsys, monkeypatch, f"paths.cache_dir={tmp_path / 'cache'}")
    assert code == 2 and err.strip() == f"error: paths.cache_dir={tmp_path / 'cache'} is a file, not the cache's folder"


def test_a_simulated_dataset_read_from_the_cache_is_marked_used(tmp_path):
    first = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)
    path = only_file(tmp_path / "simulated")
    age(path, 40)
    again = build_simulated_dataset(DATA, BEARING, SIMULATOR, {}, tmp_path)  # a hit: read, not simulated
    np.testing.assert_array_equal(again.windows, first.windows)
    assert time.time() - path.stat().st_mtime < DAY_S


def test_a_hit_in_a_cache_that_cannot_be_marked_is_still_read(tmp_path, monkeypatch, caplog):
    path = tmp_path / "entry.npz"
    save_npz_atomic(path, signals=np.arange(3.0))
    age(path, 40)

    def read_only(*args, **kwargs):
        raise PermissionError(30, "Read-only file system")

    monkeypatch.setattr(os, "utime", read_only)
    np.testing.assert_array_equal(load_npz_or_heal(path, "signals")["signals"], np.arange(3.0))
    assert not caplog.records and time.time() - path.stat().st_mtime > 30 * DAY_S


def test_an_entry_removed_before_it_is_read_is_a_miss_without_a_warning(tmp_path, caplog):
    assert load_npz_or_heal(tmp_path / "gone.npz", "signals") is None and not caplog.records


def test_a_read_marks_an_entry_at_most_hourly(tmp_path):
    """A mark writes the file's metadata, which on a network file system makes every other machine read the entry
    afresh: a read within the hour leaves the times as they were, one after it marks."""
    path = tmp_path / "entry.npz"
    save_npz_atomic(path, signals=np.arange(3.0))
    age(path, 0.01)  # used a quarter of an hour ago
    before = path.stat().st_mtime
    load_npz_or_heal(path, "signals")
    assert path.stat().st_mtime == before
    age(path, 0.1)  # two and a half hours ago
    load_npz_or_heal(path, "signals")
    assert time.time() - path.stat().st_mtime < 60


def test_an_entry_removed_by_another_machine_while_read_is_a_plain_miss(tmp_path, monkeypatch, caplog):
    """On a network file system a file removed elsewhere while read gives ESTALE: a miss, not an unreadable entry."""
    import errno

    path = tmp_path / "entry.npz"
    save_npz_atomic(path, signals=np.arange(3.0))

    def stale(*args, **kwargs):
        raise OSError(errno.ESTALE, "Stale file handle")

    monkeypatch.setattr(np, "load", stale)
    assert load_npz_or_heal(path, "signals") is None and not caplog.records and path.exists()
