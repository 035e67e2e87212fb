"""``bearingtwin-cache [unused_days=<days> [remove=true]]``: what the cache holds, and what no command has used lately.

The cache (``paths.cache_dir``: ``BEARINGTWIN_CACHE``, else ``$XDG_CACHE_HOME/bearingtwin`` or ``~/.cache/bearingtwin``) keeps every simulated dataset,
twin record and feature table a command computed, keyed by its configuration and its code, and nothing removes them:
a team's shared cache grows with every configuration and every upgrade of the code. Every read of an entry marks it
used (:func:`~bearingtwin.storage.mark_used`), so ``unused_days=<days>`` counts the entries no command has written or
read for that long, and ``remove=true`` removes them, one by one, each looked at again first, so this may run while
other commands do; what a later run needs is computed again. Only the project's entries are listed or removed
(:data:`~bearingtwin.storage.CACHE_KINDS`), never through a link. Numba's compiled kernels are reported, not removed.
Exit status: 0, 1 when an entry could not be removed (named), 2 for bad input.
"""

from __future__ import annotations

import datetime
import os
import stat
import sys
import time
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.checks import non_negative_number
from bearingtwin.config import exit_on_user_error, hydra_command, refuse_unknown_keys
from bearingtwin.errors import BearingTwinError
from bearingtwin.storage import CACHE_KINDS, CacheEntry, cache_entries, remove_unused, unused_entries
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
    if not isinstance(cfg.paths.cache_dir, str) or not cfg.paths.cache_dir.strip():  # '' would read the current folder
        raise BearingTwinError(f"paths.cache_dir must name the cache's folder, got {cfg.paths.cache_dir!r}")
    root = Path(cfg.paths.cache_dir).expanduser()
    if root.exists() and not root.is_dir():
        raise BearingTwinError(f"paths.cache_dir={root} is a file, not the cache's folder")
    try:
        kinds = cache_entries(root)
    except OSError as error:
        raise BearingTwinError(f"paths.cache_dir={root}: cannot be read ({error.strerror or error})") from None
    print(usage_table(root, kinds))
    if unused_days is None:
        return
    now_s, unused_s = time.time(), unused_days * SECONDS_PER_DAY
    since = f"unused for {unused_days:g} day{'' if unused_days == 1 else 's'}" if unused_days else "every entry"
    if not cfg.remove:
        unused = unused_entries(kinds, unused_s, now_s)
        print(f"{since}: {_count(unused)}, {_size(unused)}" + ("; remove=true removes them" if unused else ""))
        return
    removed, failed = remove_unused(kinds, unused_s, now_s)
    print(f"removed ({since}): {_count(removed)}, {_size(removed)} freed")
    if failed:
        first, error = failed[0]
        print(f"error: {_count([entry for entry, _ in failed])} could not be removed ({error.strerror or error}), "
              f"{first.path} among them", file=sys.stderr)
        sys.exit(1)


def usage_table(root: Path, kinds: dict[str, list[CacheEntry]]) -> str:
    """One line per kind of entry (how many, their size, when the least and the most recently used were last used),
    a kind's folder that is a link (not followed), the total, and numba's compiled kernels."""
    linked = [kind for kind in CACHE_KINDS if (root / kind).is_symlink()]
    if not kinds and not linked:
        # A folder not there is a fresh machine's cache, or a misspelt path: said as such, not only "empty".
        lines = [f"cache: {root} ({'empty' if root.is_dir() else 'no such folder'}: nothing cached yet)"]
    else:
        rows = [(kind, _count(entries), _size(entries), _used_span(entries)) for kind, entries in kinds.items()]
        rows += [(kind, "", "", f"a link to {os.readlink(root / kind)}: not followed") for kind in linked]
        everything = [entry for entries in kinds.values() for entry in entries]
        rows.append(("total", _count(everything), _size(everything), ""))
        widths = [max(len(row[column]) for row in rows) for column in range(3)]
        lines = [f"cache: {root}"] + [f"  {kind:<{widths[0]}}  {count:>{widths[1]}}  {size:>{widths[2]}}  {note}".rstrip()
                                      for kind, count, size, note in rows]
    kernels = os.environ.get("NUMBA_CACHE_DIR")  # bearingtwin sets it when imported, unless the environment did
    if kernels and Path(kernels).is_dir():
        lines.append(f"numba's compiled kernels: {kernels}, {_bytes(_folder_bytes(Path(kernels)))} (numba's own: "
                     "not removed here; deleting the folder recompiles them)")
    return "\n".join(lines)


def _folder_bytes(folder: Path) -> int:
    """The size of the regular files under ``folder``, links not followed."""
    total = 0
    for parent, _, names in os.walk(folder):
        for name in names:
            try:
                status = os.lstat(os.path.join(parent, name))
            except OSError:
                continue
            total += status.st_size if stat.S_ISREG(status.st_mode) else 0
    return total


def _count(entries: list[CacheEntry]) -> str:
    return f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}"


def _size(entries: list[CacheEntry]) -> str:
    return _bytes(sum(entry.size_bytes for entry in entries))


def _bytes(size: float) -> str:
    """A size as people read it: 512 B, 3.4 kB, 120.0 MB, 1.6 GB, 2.1 TB (powers of 1000, as ``du --si`` counts)."""
    if size < 1000:
        return f"{size:.0f} B"
    for unit in ("kB", "MB", "GB", "TB"):
        size /= 1000
        if size < 1000:
            break
    return f"{size:.1f} {unit}"


def _used_span(entries: list[CacheEntry]) -> str:
    if not entries:
        return ""
    first, last = (datetime.date.fromtimestamp(time_s).isoformat() for time_s in (
        min(entry.last_used_s for entry in entries), max(entry.last_used_s for entry in entries)))
    return f"last used {first}" if first == last else f"last used {first} to {last}"


main = stop_cleanly(cache_command)


if __name__ == "__main__":
    main()
