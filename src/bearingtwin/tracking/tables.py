"""Markdown and CSV renderings of small tables, shared by run artifacts and reports."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence


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


def write_generated(path: Path, generated: str, marker: str) -> None:
    """Write ``generated`` to ``path``, keeping hand-written text around it.

    If the file holds two ``marker`` lines, only the text between them is replaced, so the
    prose a person wrote above and below a table survives regenerating it; otherwise the
    whole file becomes ``generated``.
    """
    text = path.read_text() if path.exists() else ""
    if text.count(marker) >= 2:
        before, _, rest = text.partition(marker)
        _, _, after = rest.partition(marker)
        text = f"{before}{marker}\n\n{generated.strip()}\n\n{marker}{after}"
    else:
        text = generated
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
