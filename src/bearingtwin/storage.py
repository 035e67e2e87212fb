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
import functools
import hashlib
import json
import logging
import os
import tempfile
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
    """``write(stream)`` into a temporary file in ``path``'s folder, then moved into place.

    ``os.replace`` is atomic on one file system: a parallel job finds either nothing or the
    whole file, and two jobs writing the same entry leave one complete copy. A cache folder
    that cannot take the entry (read-only, full) is said in one line and the entry left unwritten:
    the numbers it would keep are in the caller's hands, and computing them again next time costs
    less than the run a refusal here would throw away.
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
    except OSError as error:
        _remove(temporary)
        log.warning("cache entry %s not written (%s); the run goes on, and computes it again next time",
                    path, error.strerror or error)
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
    sweep's jobs find one another's cached simulations and features.
    """
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()[:length]


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
        tree = ast.parse(source.read_text(encoding="utf-8"))
        for node in ast.walk(tree):  # every string standing as a statement: docstrings, a constant's words below it
            for field in ("body", "orelse", "finalbody"):
                body = getattr(node, field, None)
                if isinstance(body, list) and body:
                    kept = [statement for statement in body if not (isinstance(statement, ast.Expr) and isinstance(
                        statement.value, ast.Constant) and isinstance(statement.value.value, str))]
                    setattr(node, field, kept or [ast.Pass()])
        digest.update(f"{source.relative_to(PACKAGE).as_posix()}\0{ast.dump(tree)}\0".encode())
    return digest.hexdigest()[:12]


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
    stat = Path(path).stat()
    return _cached_digest(Path(path).resolve(), stat.st_size, stat.st_mtime_ns)


NUMBA_FOLDER = "numba"
"""Numba's compiled kernels, in the cache's folder by default (``bearingtwin/__init__.py``): numba's own files, which
it reads without marking them used, so they are reported but never removed one by one."""


@dataclass(frozen=True)
class CacheEntry:
    """One cached file: where it is, its size in bytes, and when a command last wrote or read it (POSIX seconds)."""

    path: Path
    size_bytes: int
    last_used_s: float


def mark_used(path: Path) -> None:
    """Set ``path``'s modification time to now: an entry's time is when a command last used it, which is what
    :func:`cache_entries` reports and ``bearingtwin-cache unused_days=`` removes by."""
    with contextlib.suppress(OSError):  # a read-only shared cache, or another user's entry: its time stays as written
        os.utime(path)


def cache_entries(root: str | Path) -> dict[str, list[CacheEntry]]:
    """Every cache entry under ``root`` by kind, the subfolder it lies in (``simulated``, ``twin_to_real``,
    ``features``; a temporary file a killed write left behind is one too, last used when it was written), sorted by
    path. :data:`NUMBA_FOLDER` is left out; a missing ``root`` holds nothing."""
    root = Path(root)
    kinds: dict[str, list[CacheEntry]] = {}
    for folder in sorted(root.iterdir()) if root.is_dir() else ():
        if not folder.is_dir() or folder.name == NUMBA_FOLDER:
            continue
        entries = kinds.setdefault(folder.name, [])
        for path in sorted(folder.rglob("*")):
            with contextlib.suppress(FileNotFoundError):  # removed by another command while listed
                stat = path.stat()
                if path.is_file():
                    entries.append(CacheEntry(path, stat.st_size, stat.st_mtime))
    return kinds


def folder_bytes(folder: str | Path) -> int:
    """The size of every file under ``folder`` in bytes (0 if it does not exist)."""
    total = 0
    for path in Path(folder).rglob("*"):
        with contextlib.suppress(FileNotFoundError):
            if path.is_file():
                total += path.stat().st_size
    return total


def remove_entries(entries: list[CacheEntry]) -> list[tuple[CacheEntry, OSError]]:
    """Remove each of ``entries``, one by one (a command that needs one later computes it again); those that could
    not be removed (a read-only shared cache, another user's entry), each with its error. One gone already counts as
    removed."""
    failed = []
    for entry in entries:
        try:
            entry.path.unlink(missing_ok=True)
        except OSError as error:
            failed.append((entry, error))
    return failed
