"""Cache files that parallel sweep jobs share: their keys and their atomic writes."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np


def save_npz_atomic(path: str | Path, **arrays: np.ndarray) -> None:
    """Write ``arrays`` to ``path`` as .npz so that no reader ever sees a partial file.

    The data go to a temporary file in the same folder, moved into place with
    ``os.replace`` (atomic on one file system): a parallel job finds either nothing or the
    whole file, and two jobs writing the same entry leave one complete copy.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **arrays)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def content_key(content, length: int = 16) -> str:
    """A stable hex key for JSON-able ``content`` (dict order ignored; non-JSON values by ``str``).

    Equal configurations give equal keys in every process and session, which is what lets a
    sweep's jobs find one another's cached simulations and features.
    """
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()[:length]
