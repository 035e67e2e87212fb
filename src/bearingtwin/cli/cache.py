"""``bearingtwin-cache [unused_days=<days> [remove=true]]``: what the cache holds, and what no command has used lately.

The cache (``paths.cache_dir``: ``BEARINGTWIN_CACHE``, else ``~/.cache/bearingtwin``) keeps every simulated dataset,
twin record and feature table a command computed, keyed by its configuration and its code, and nothing removes them:
a team's shared cache grows with every configuration and every upgrade of the code. Every read of an entry marks it
used (:func:`~bearingtwin.storage.mark_used`), so ``unused_days=<days>`` lists the entries no command has written or
read for that long, and ``remove=true`` removes them; what a later run needs again is computed again. Entries are
removed one by one, so this may run while other commands do. Numba's compiled kernels are reported, not removed.
Exit status: 0, 1 when an entry could not be removed (named), 2 for bad input.
"""

from __future__ import annotations

import datetime
import sys
import time
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.checks import non_negative_number
from bearingtwin.config import exit_on_user_error, hydra_command, refuse_unknown_keys
from bearingtwin.errors import BearingTwinError
from bearingtwin.storage import NUMBA_FOLDER, CacheEntry, cache_entries, folder_bytes, remove_entries
from bearingtwin.tracking.lifecycle import stop_cleanly

SECONDS_PER_DAY = 86400.0


@hydra_command("cache")
@exit_on_user_error
def cache_command(cfg: DictConfig) -> None:
    refuse_unknown_keys(HydraConfig.get())
    unused_days = (None if cfg.unused_days is None
                   else non_negative_number("unused_days", cfg.unused_days, "a number of days, 0 or more"))
    if not isinstance(cfg.remove, bool):
        raise BearingTwinError(f"remove must be true or false, got {cfg.remove!r}")
    if cfg.remove and unused_days is None:
        raise BearingTwinError("remove=true removes the entries unused for unused_days=<days>: give it "
                               "(unused_days=0 removes every entry)")
    root = Path(cfg.paths.cache_dir).expanduser()
    if root.exists() and not root.is_dir():
        raise BearingTwinError(f"paths.cache_dir={root} is a file, not the cache's folder")
    kinds = cache_entries(root)
    print(usage_table(root, kinds))
    if unused_days is None:
        return
    cutoff_s = time.time() - unused_days * SECONDS_PER_DAY
    unused = [entry for entries in kinds.values() for entry in entries if entry.last_used_s <= cutoff_s]
    since = f"unused for {unused_days:g} days" if unused_days else "every entry"
    if not cfg.remove:
        print(f"{since}: {_count(unused)}, {_size(unused)}"
              + ("; remove=true removes them" if unused else ""))
        return
    failed = remove_entries(unused)
    kept = {entry for entry, _ in failed}
    removed = [entry for entry in unused if entry not in kept]
    print(f"removed ({since}): {_count(removed)}, {_size(removed)} freed")
    if failed:
        first, error = failed[0]
        print(f"{_count(list(kept))} could not be removed ({error.strerror or error}), {first.path} among them",
              file=sys.stderr)
        sys.exit(1)


def usage_table(root: Path, kinds: dict[str, list[CacheEntry]]) -> str:
    """One line per kind of entry (how many, their size, when the least and the most recently used was last used),
    numba's kernels and the total."""
    if not kinds and not (root / NUMBA_FOLDER).is_dir():
        return f"cache: {root} (empty: nothing cached yet)"
    rows = [(kind, _count(entries), _size(entries), _used_span(entries)) for kind, entries in kinds.items()]
    if (root / NUMBA_FOLDER).is_dir():
        rows.append((NUMBA_FOLDER, "compiled kernels", _bytes(folder_bytes(root / NUMBA_FOLDER)),
                     "numba's own; deleting the folder recompiles them"))
    everything = [entry for entries in kinds.values() for entry in entries]
    rows.append(("total", _count(everything), _size(everything), ""))
    widths = [max(len(row[column]) for row in rows) for column in range(3)]
    lines = [f"  {kind:<{widths[0]}}  {count:>{widths[1]}}  {size:>{widths[2]}}  {note}".rstrip()
             for kind, count, size, note in rows]
    return "\n".join([f"cache: {root}", *lines])


def _count(entries: list[CacheEntry]) -> str:
    return f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}"


def _size(entries: list[CacheEntry]) -> str:
    return _bytes(sum(entry.size_bytes for entry in entries))


def _bytes(size: float) -> str:
    """A size as people read it: 512 B, 3.4 kB, 120.0 MB, 1.6 GB (powers of 1000, as ``du --si`` counts)."""
    if size < 1000:
        return f"{size:.0f} B"
    for unit in ("kB", "MB", "GB"):
        size /= 1000
        if size < 1000:
            break
    return f"{size:.1f} {unit}"


def _used_span(entries: list[CacheEntry]) -> str:
    if not entries:
        return ""
    day = [datetime.date.fromtimestamp(entry.last_used_s).isoformat() for entry in (
        min(entries, key=lambda e: e.last_used_s), max(entries, key=lambda e: e.last_used_s))]
    return f"last used {day[0]}" if day[0] == day[1] else f"last used {day[0]} to {day[1]}"


main = stop_cleanly(cache_command)


if __name__ == "__main__":
    main()
