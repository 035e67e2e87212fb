"""Markdown and CSV renderings of small tables, shared by run artifacts and reports."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence

from bearingtwin.errors import BearingTwinError


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub-flavoured markdown table; floats are printed as given (format them first)."""
    lines = ["| " + " | ".join(map(str, header)) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(map(str, row)) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def csv_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def generated_text(path: Path, marker: str) -> str | None:
    """The text between the two ``marker`` lines of ``path``, or None when it has no such block."""
    text = path.read_text() if path.exists() else ""
    if text.count(marker) < 2:
        return None
    return text.split(marker)[1].strip()


def check_generated_target(path: Path, marker: str) -> str:
    """The text of ``path`` (empty for a new file) if a generated block may be written into it
    (:func:`write_generated`); a folder, or a file without two ``marker`` lines, is refused, named."""
    if path.is_dir():
        raise BearingTwinError(f"out={path} is a folder; give the file to write (e.g. {path / 'report.md'})")
    text = path.read_text() if path.is_file() else ""
    if text.strip() and text.count(marker) < 2:
        raise BearingTwinError(f"out={path}: holds text that is not a generated report (no two lines {marker!r}); "
                               "give another out=<file>, or put those two lines where the report should go (a "
                               "report an earlier bearingtwin wrote has none: put them around it)")
    return text


def write_generated(path: Path, generated: str, marker: str, heading: str = "") -> None:
    """Write ``generated`` between two ``marker`` lines of ``path``, keeping hand-written text around it.

    The prose a person wrote above and below a table survives regenerating it. A new (or empty)
    file gets ``heading`` (if any), then the markers with the text; an existing file without two of
    them is refused, named: it holds something else, which writing over would lose.
    """
    text = check_generated_target(path, marker)
    if not text.strip() and heading:
        text = f"{heading.strip()}\n\n{marker}\n{marker}\n"
    before, _, rest = text.partition(marker)
    _, _, after = rest.partition(marker)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"{before}{marker}\n\n{generated.strip()}\n\n{marker}{after or chr(10)}")
    except OSError as error:
        raise BearingTwinError(f"out={path}: cannot be written ({error.strerror or error})") from None
