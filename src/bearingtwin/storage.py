"""Writing cache files that parallel sweep jobs share."""

from __future__ import annotations

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
