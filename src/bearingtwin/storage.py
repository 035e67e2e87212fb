"""Cache files that parallel sweep jobs share: their keys, atomic writes, and reads that heal.

A cache entry is never the only copy of anything: it can always be recomputed from its
configuration. So an entry that cannot be read (a truncated, empty or bit-flipped file
left by a full disk, a crash or bad storage) is not an error but a miss:
:func:`load_npz_or_heal` logs one line naming the file, removes it and lets the caller
recompute and rewrite it. Nor is an entry that cannot be written (a read-only shared cache,
a full disk) an error: one line says so, and the numbers just computed go on to be used.
Every read marks its entry used, so what no command has used for a while can be told apart and
removed (:func:`cache_entries`, ``bearingtwin-cache``).
"""

from __future__ import annotations

import ast
import contextlib
import errno
import functools
import hashlib
import json
import logging
import os
import stat
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)


def save_npz_atomic(path: str | Path, **arrays: np.ndarray) -> None:
    """Write ``arrays`` to ``path`` as .npz so that no reader ever sees a partial file (:func:`_write_atomic`)."""
    _write_atomic(path, lambda stream: np.savez(stream, **arrays))


def save_npy_atomic(path: str | Path, array: np.ndarray) -> None:
    """Write ``array`` to ``path`` as .npy so that no reader ever sees a partial file (:func:`_write_atomic`)."""
    _write_atomic(path, lambda stream: np.save(stream, array))


def _write_atomic(path: str | Path, write) -> None:
    """``write(stream)`` into the cache entry ``path`` (:func:`write_atomic`). A cache folder that cannot take the
    entry (read-only, full) is said in one line and the entry left unwritten: the numbers it would keep are in the
    caller's hands, and computing them again next time costs less than the run a refusal here would throw away."""
    try:
        write_atomic(path, write)
    except OSError as error:
        log.warning("cache entry %s not written (%s); the run goes on, and computes it again next time",
                    path, error.strerror or error)


def write_atomic(path: str | Path, write) -> None:
    """``write(stream)`` into a temporary file in ``path``'s folder, then moved into place.

    ``os.replace`` is atomic on one file system: a parallel job finds either nothing or the
    whole file, and two jobs writing the same entry leave one complete copy. A write that fails (a full disk, a
    file-size limit) raises ``OSError`` and leaves no partial file, and whatever ``path`` held before as it was.
    """
    path = Path(path)
    temporary = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        with os.fdopen(handle, "wb") as stream:
            write(stream)
        # mkstemp makes the file private (0600); the entry gets the mode any new file would (the umask's), so a
        # team's shared cache is readable by the team.
        os.chmod(temporary, 0o666 & ~_UMASK)
        os.replace(temporary, path)
    except BaseException:
        _remove(temporary)
        raise


def takes_entries(folder: str | Path) -> bool:
    """Whether new cache entries can be written into ``folder`` (made if missing): a read-only shared cache or a
    full disk cannot take them."""
    try:
        Path(folder).mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def _remove(temporary: str | None) -> None:
    """A temporary file left by a write that did not finish, removed where it was made."""
    if temporary is not None:
        with contextlib.suppress(OSError):
            Path(temporary).unlink(missing_ok=True)


def _read_umask() -> int:
    """The process's file-mode creation mask (reading it means setting it: set back at once; done once, at
    import, before any thread of the process writes a file)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()


def load_npz_or_heal(path: str | Path, *names: str) -> dict[str, np.ndarray] | None:
    """The arrays ``names`` of the cache entry at ``path``; None when there is no usable entry.

    Every array is read in full, which makes ``zipfile`` check its CRC, so a flipped bit is
    caught here and not in a computation later. An unreadable entry is logged (file and
    reason), removed and reported as a miss. (Should another job replace the entry in the
    instant between the failed read and the removal, its good copy goes too: one more
    recomputation, never a wrong number.) An entry read is marked used (:func:`mark_used`).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: np.array(stored[name]) for name in names}
        mark_used(path)
        return arrays
    except (FileNotFoundError, NotADirectoryError):  # never written (or removed by ``bearingtwin-cache remove=true``)
        return None
    except Exception as error:  # any failure to read means the entry is unusable; it is recomputed
        if isinstance(error, OSError) and error.errno == errno.ESTALE:  # removed by another machine (NFS) while read
            return None
        try:
            path.unlink(missing_ok=True)
            done = "removed"
        except OSError as removal:  # a read-only shared cache: read past, as a miss, every time until someone fixes it
            done = f"left in place ({removal.strerror or removal})"
        log.warning("cache entry %s is unreadable (%s: %s); %s, recomputing it", path, type(error).__name__, error, done)
        return None


def content_key(content, length: int = 16) -> str:
    """A stable hex key for JSON-able ``content`` (dict order ignored; non-JSON values by ``str``).

    Equal configurations give equal keys in every process and session, which is what lets a
    sweep's jobs find one another's cached simulations and features. A whole number is one key however it is
    typed (``data.duration=1`` and ``data.duration=1.0`` simulate the same record).
    """
    return hashlib.sha256(json.dumps(_whole_numbers_as_int(content), sort_keys=True, default=str).encode()).hexdigest()[:length]


def _whole_numbers_as_int(content):
    """``content`` with every float that holds a whole number as that int, in its dicts, lists and tuples."""
    if isinstance(content, float) and content.is_integer():
        return int(content)
    if isinstance(content, dict):
        return {key: _whole_numbers_as_int(value) for key, value in content.items()}
    if isinstance(content, (list, tuple)):
        return [_whole_numbers_as_int(value) for value in content]
    return content


PACKAGE = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=None)
def code_fingerprint(*parts: str) -> str:
    """A key of the code in ``parts`` of bearingtwin (subpackages, ``"physics"``, ``"signal"``, ..., or modules,
    ``"data/recording.py"``) that computes a cached entry: its syntax trees without docstrings (comments never enter
    one), so that an entry computed by other code is a miss, while an edit of the words alone keeps every entry. A
    cache keyed by its configuration alone would hand a changed computation the numbers of the code before it.
    (Another Python version dumps its trees otherwise: every entry is then a miss, once.)"""
    digest = hashlib.sha256()
    modules = {path for name in parts
               for path in ([PACKAGE / name] if name.endswith(".py") else (PACKAGE / name).rglob("*.py"))}
    for source in sorted(modules):
        tree = _tree_without_words(source.read_text(encoding="utf-8"))
        digest.update(f"{source.relative_to(PACKAGE).as_posix()}\0{tree}\0".encode())
    return digest.hexdigest()[:12]


@functools.lru_cache(maxsize=None)
def _tree_without_words(source: str) -> str:
    """The dump of a module's syntax tree without the strings standing as statements (docstrings, a constant's words
    below it), parsed once per process for one text: the simulation's and the features' fingerprints share the
    physics modules."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        for field in ("body", "orelse", "finalbody"):
            body = getattr(node, field, None)
            if isinstance(body, list) and body:
                kept = [statement for statement in body if not (isinstance(statement, ast.Expr) and isinstance(
                    statement.value, ast.Constant) and isinstance(statement.value.value, str))]
                setattr(node, field, kept or [ast.Pass()])
    return ast.dump(tree)


SIMULATION_CODE = ("physics", "data/recording.py")
"""The code that makes a simulated record (:func:`code_fingerprint`)."""
FEATURE_CODE = ("features", "signal", "optim", "physics", "data")
"""The subpackages whose code makes a window's features, and the windows themselves (a simulated record's, a real
one's as read and cut): a dataset's key names its configuration, not the code that made it."""


@functools.lru_cache(maxsize=4096)
def _cached_digest(path: Path, size: int, modified_ns: int) -> str:
    with open(path, "rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


def file_digest(path: Path) -> str:
    """SHA-256 of a file's contents, computed once per process for a file unchanged since (a sweep's jobs share
    their files)."""
    status = Path(path).stat()
    return _cached_digest(Path(path).resolve(), status.st_size, status.st_mtime_ns)


CACHE_KINDS = ("simulated", "twin_to_real", "features")
"""The cache's subfolders, one per kind of entry (:mod:`bearingtwin.data.simulated`, :mod:`bearingtwin.data.twin_to_real`,
:mod:`bearingtwin.features.cache`): an entry is a ``.npz`` file in one of them, or the ``.tmp`` file a write that did not
finish left there. Nothing else in the cache's folder is the project's to list or remove."""
TEMPORARY_GRACE_S = 3600.0
"""How long a temporary file is left alone whatever ``unused_days`` says: a running write may still be filling it."""


@dataclass(frozen=True)
class CacheEntry:
    """One cached file: where it is, its size in bytes, and when a command last wrote or read it (POSIX seconds)."""

    path: Path
    size_bytes: int
    last_used_s: float


MARK_INTERVAL_S = 3600.0
"""How often a read marks an entry used: days are what ``unused_days`` counts, and a mark is a write of the file's
metadata, which on a network file system makes every other machine read the entry afresh."""


def mark_used(path: Path) -> None:
    """Set ``path``'s times to now, unless they were set less than :data:`MARK_INTERVAL_S` ago: an entry's modification
    time is when a command last wrote or read it, which ``bearingtwin-cache unused_days=`` removes by."""
    with contextlib.suppress(OSError):  # another user's entry, a read-only cache: its access time (_last_used) tells
        if time.time() - os.stat(path).st_mtime > MARK_INTERVAL_S:
            os.utime(path)


def mark_used_if_present(path: Path) -> bool:
    """Whether the cache entry at ``path`` exists, marked used if it does: a command that will read it later keeps a
    pruning by ``unused_days`` from removing it meanwhile."""
    if not path.is_file():
        return False
    mark_used(path)
    return True


def _last_used(status: os.stat_result) -> float:
    """When a command last used the entry: its modification time (set by every write, and by the reads of those who
    may write the file), or its access time where that is later. Linux sets the access time on a read by any user at
    least once a day (``relatime``, its default), so a teammate's reads keep a shared entry too; under ``noatime``
    only the first of the two counts, and a backup that reads every file keeps every entry."""
    return max(status.st_mtime, status.st_atime)


def cache_entries(root: str | Path) -> dict[str, list[CacheEntry]]:
    """The entries of each of :data:`CACHE_KINDS` under ``root`` whose folder exists, sorted by path. A kind's folder
    that is a symbolic link is not followed, nor is a linked entry, so nothing outside ``root`` is listed (and
    removed by :func:`remove_unused`); a file that vanishes while it is listed is left out."""
    kinds: dict[str, list[CacheEntry]] = {}
    for kind in CACHE_KINDS:
        folder = Path(root) / kind
        if folder.is_symlink() or not folder.is_dir():
            continue
        entries = kinds.setdefault(kind, [])
        for path in sorted(folder.iterdir()):
            if path.suffix not in (".npz", ".tmp"):
                continue
            with contextlib.suppress(OSError):
                status = path.lstat()
                if stat.S_ISREG(status.st_mode):
                    entries.append(CacheEntry(path, status.st_size, _last_used(status)))
    return kinds


def unused_entries(kinds: dict[str, list[CacheEntry]], unused_s: float, now_s: float) -> list[CacheEntry]:
    """The entries of ``kinds`` no command has used for ``unused_s`` seconds before ``now_s`` (a temporary file for
    :data:`TEMPORARY_GRACE_S` at least)."""
    return [entry for entries in kinds.values() for entry in entries
            if now_s - entry.last_used_s >= _unused_for(entry.path, unused_s)]


def _unused_for(path: Path, unused_s: float) -> float:
    return max(unused_s, TEMPORARY_GRACE_S) if path.suffix == ".tmp" else unused_s


def remove_unused(kinds: dict[str, list[CacheEntry]], unused_s: float,
                  now_s: float) -> tuple[list[CacheEntry], list[tuple[CacheEntry, OSError]]]:
    """Remove the :func:`unused_entries`, one by one, each looked at again first: one a command has read or rewritten
    since it was listed stays. Returns those removed, and those that could not be (a read-only shared cache, a folder
    of another user's), each with its error; a command that needs one later computes it again."""
    removed, failed = [], []
    for entry in unused_entries(kinds, unused_s, now_s):
        try:
            if now_s - _last_used(entry.path.lstat()) < _unused_for(entry.path, unused_s):
                continue
            entry.path.unlink()
            removed.append(entry)
        except FileNotFoundError:  # removed by another command meanwhile
            continue
        except OSError as error:
            failed.append((entry, error))
    return removed, failed
