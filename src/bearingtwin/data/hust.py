"""The HUST bearing data set (Zhao, Zio, Shen, RESS 2024): the seed paper's second experiment.

The files are named ``.xls`` but are tab-separated text exported by the rig's software:
a header block (``Title:``, ``DAQ Settings:``, ``Total Data Rows``, ``Legend`` ...), a line
reading ``Data`` (or ``Data:``), then rows of time (s), speed (not meaningful), X, Y, Z acceleration, in the
order the ``Legend`` line names them.
This layout was reported by users of the data and not checked against a real file here,
so the reader finds the ``Data`` line instead of counting header lines, checks the row
count against the header when it states one, and names the file and line on any
deviation. The shaft speed and bearing state come from the file name,
``<prefix><state>_<condition>.xls``: prefix ``0.5X_`` = medium damage, none = severe;
states H, I, O, B, C; conditions ``<f>Hz`` (shaft Hz) or ``VS_0_40_0Hz`` (variable speed).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from bearingtwin.checks import is_finite_number
from bearingtwin.data.files import FS_RELATIVE_TOLERANCE, RawRecord, fs_from_time_column, load_recording
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError

COLUMNS = ("time", "speed", "X", "Y", "Z")
CHANNELS = COLUMNS[2:]
STATES = {"H": "normal", "I": "inner", "B": "ball", "O": "outer", "C": None}
"""File-name state letter -> bearing state; C (inner + outer combined) has no single FAULTS label."""
BEARING = "er16k"
"""The rig's bearing (``conf/bearing/er16k.yaml``), which every HUST file records."""

HEADER_LINE_LIMIT = 200
"""The ``Data`` line must appear within this many lines; the reported header has about 21."""
DATA_MARKERS = ("Data", "Data:")
"""The line that ends the header: ``Data`` as reported, ``Data:`` as the header's other keys are written."""
UTF8_BOM = "\ufeff".encode("utf-8").decode("latin-1")
"""A UTF-8 byte-order mark as the latin-1 reading sees it: a file saved again by an editor may start with one."""

_NUMBER = re.compile(r"[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?|[-+]?(nan|NaN|inf|Inf)")
"""A cell that is a number under either decimal mark; a first cell that is not one names the columns."""
_NAME = re.compile(r"^(?P<prefix>0\.5X_)?(?P<state>[HIOBC])_(?P<condition>\d+(?:\.\d+)?Hz|VS_[\d_]+Hz)$")


@dataclass(frozen=True)
class HustName:
    """What a HUST file name says: state letter, damage level and operating condition."""

    state: str
    severity: str  # "none", "medium" or "severe"
    condition: str  # as written, e.g. "65Hz" or "VS_0_40_0Hz"
    shaft_hz: float | None  # None for the variable-speed condition

    @property
    def fault(self) -> str | None:
        return STATES[self.state]

    @property
    def rpm(self) -> float | None:
        return None if self.shaft_hz is None else self.shaft_hz * 60.0


def parse_hust_name(path: str | Path) -> HustName | None:
    """The state and condition encoded in a HUST file name (None if the name has another form)."""
    match = _NAME.match(Path(path).stem)
    if match is None:
        return None
    state, condition = match["state"], match["condition"]
    severity = "none" if state == "H" else ("medium" if match["prefix"] else "severe")
    shaft_hz = None if condition.startswith("VS_") else float(condition[:-2])
    return HustName(state=state, severity=severity, condition=condition, shaft_hz=shaft_hz)


def hust_file_name(class_stem: str, condition) -> str:
    """The file name of a class (``H``, ``0.5X_I``, ...) at a condition (``65`` or ``VS_0_40_0``,
    :func:`hust_condition`)."""
    return f"{class_stem}_{hust_condition(condition)}Hz.xls"


def hust_condition(value, key: str = "data.condition") -> str:
    """A condition as the file names write it before ``Hz``: a shaft speed in Hz (``65``; ``65.0`` is ``65``) or
    the variable-speed run ``VS_0_40_0``; anything else is refused naming ``key``."""
    if isinstance(value, str) and re.fullmatch(r"VS_[\d_]+", value):
        return value
    if is_finite_number(value) and not isinstance(value, bool) and value > 0:
        return f"{value:g}"
    hint = " (without Hz: the file name adds it)" if isinstance(value, str) and value.endswith("Hz") else ""
    raise BearingTwinError(f"{key}={value!r} is not a HUST condition{hint}: give the shaft speed in Hz as the file "
                           "names write it (20, 25, ..., 80) or VS_0_40_0, the variable-speed run")


def read_hust_raw(path: str | Path) -> RawRecord:
    """All five columns of a HUST export (speed included, NaN cells kept), with the header as meta."""
    path = Path(path)
    header, data_line = _read_header(path)
    layout = _data_layout(path, data_line)
    table = _read_table(path, layout)
    declared_rows = _declared_rows(header)
    if declared_rows is not None and declared_rows != table.shape[0]:
        raise BearingTwinError(
            f"{path}: the header declares {declared_rows} data rows (Total Data Rows) but the file holds "
            f"{table.shape[0]}; the file is truncated or not a single export"
        )
    name = parse_hust_name(path)
    if layout.names is None:
        names, notes = _column_order(header.get("Legend"), "the header's Legend")
    else:  # its first name is the time column's
        names, notes = _column_order("\t".join(layout.names[1:]), "the row of names below the 'Data' line")
    if layout.decimal == ",":
        notes.append("numbers written with decimal commas")
    channels = dict(zip(names, table[:, 1:].T))
    meta = {"header": header, "data_line": data_line + 1, "bearing": BEARING, "notes": notes,
            "not_vibration": {"speed": "the export's speed column, not meaningful (the shaft speed is in the file's name)"}}
    if name is not None:
        meta.update(state=name.state, severity=name.severity, condition=name.condition)
        if name.fault is None:  # C: no single state of the four a model or the twin knows
            meta["unlabelled_state"] = f"inner and outer races damaged together ({name.state} in its name)"
        if name.shaft_hz is None:
            meta["no_speed"] = f"a variable-speed run ({name.condition} in its name): its speed changes over the record"
    fs, fs_origin = _sampling_rate(path, header, table[:, 0], layout.decimal)
    return RawRecord(
        str(path),
        "hust-xls",
        channels,
        fs=fs,
        fs_origin=fs_origin,
        fs_tolerance=FS_RELATIVE_TOLERANCE,  # the time column measures it; the header is checked against that
        rpm=None if name is None else name.rpm,
        fault=None if name is None else name.fault,
        meta=meta,
    )


def load_hust(path: str | Path, channel: str = "X", fs: float | None = None, channel_key: str = "channel",
              fs_key: str = "fs") -> Recording:
    """One accelerometer axis (X, Y or Z) of a HUST file, fs checked against the time column; ``channel_key``
    and ``fs_key`` are the settings ``channel`` and ``fs`` come from, as messages name them."""
    if channel not in CHANNELS:
        raise BearingTwinError(f"{channel_key}={channel!r} is not a HUST accelerometer axis; choose one of {', '.join(CHANNELS)}")
    return load_recording(path, channel=channel, fs=fs, channel_key=channel_key, fs_key=fs_key)


def _column_order(legend: str | None, where: str) -> tuple[list[str], list[str]]:
    """The names of the columns after time, in the order ``legend`` (tab-separated, said to be ``where``) gives,
    and a note when it gives none that names them: an export with its channels in another order is read by
    name; one whose legend names other channels (the layout was reported, not checked) by position, and said so."""
    if legend is None:
        return list(COLUMNS[1:]), []
    by_lower = {column.lower(): column for column in COLUMNS[1:]}
    cells = [cell.strip() for cell in legend.split("\t") if cell.strip()]
    bare = [re.sub(r"\s*[(\[].*$", "", cell).lower() for cell in cells]  # "X (g)", "Speed [rpm]": the name alone
    names = [by_lower.get(cell) for cell in bare if cell not in ("time", "t")]
    if sorted(filter(None, names)) == sorted(COLUMNS[1:]) and len(names) == len(COLUMNS) - 1:
        return names, []
    return list(COLUMNS[1:]), [f"{where} reads {' '.join(cells)!r}, not Speed, X, Y and Z: the columns "
                               f"after time are read by position as {', '.join(COLUMNS[1:])}"]


def _read_header(path: Path) -> tuple[dict[str, str], int]:
    """Header key/value pairs and the 0-based index of the ``Data`` line."""
    with open(path, "rb") as handle:
        magic = handle.read(8)
    if magic.startswith(b"\xd0\xcf\x11\xe0") or magic.startswith(b"PK\x03\x04"):
        raise BearingTwinError(
            f"{path}: is a binary Excel workbook, not the tab-separated text export the HUST files are; "
            "export it as text or point data.root at the original files"
        )
    header: dict[str, str] = {}
    with open(path, encoding="latin-1") as handle:
        for index, line in enumerate(handle):
            text = line.removeprefix(UTF8_BOM).strip()
            if text in DATA_MARKERS:
                return header, index
            if index >= HEADER_LINE_LIMIT:
                break
            key, _, value = re.split(r"(\t|:)", text, maxsplit=1) if re.search(r"\t|:", text) else (text, "", "")
            if key:
                header[key.strip()] = value.strip(" \t:")
    raise BearingTwinError(
        f"{path}: no line reading 'Data' (or 'Data:') within the first {HEADER_LINE_LIMIT} lines; expected a HUST "
        "text export (header block, a 'Data' line, then rows of time, speed, X, Y, Z)"
    )


def _sampling_rate(path: Path, header: dict[str, str], time_s: np.ndarray, decimal: str = ".") -> tuple[float, str]:
    """The rate the header's ``Sampling Rate`` line states, checked against the time column;
    the time column's alone when the header states none. ``decimal``: the mark the data rows use (a file
    written with decimal commas writes 25600,0, and may group thousands with points).

    The header is exact (25600), while the time column, printed to a microsecond, only
    approximates it (25599.9997 Hz over a whole file).
    """
    from_time = fs_from_time_column(time_s, str(path))
    written = header.get("Sampling Rate", "").split("\t")[0].strip()
    # The other mark groups thousands: 25,600 (or 25.600,0 beside decimal commas).
    text = written.replace(".", "").replace(",", ".") if decimal == "," else written.replace(",", "")
    if not text:
        return from_time, "time column"
    try:
        stated = float(text)
    except ValueError:
        raise BearingTwinError(f"{path}: the header's Sampling Rate {written!r} is not a number") from None
    if not (np.isfinite(stated) and stated > 0) or abs(from_time / stated - 1.0) > FS_RELATIVE_TOLERANCE:
        raise BearingTwinError(f"{path}: the header's Sampling Rate {written!r} (read as {stated:g} Hz, a comma "
                               f"taken for a thousands separator) contradicts the time column's {from_time:.6g} Hz"
                               if "," in written and decimal == "." else
                               f"{path}: the header's Sampling Rate {written} Hz contradicts the time column's {from_time:.6g} Hz")
    return stated, "header"


def _declared_rows(header: dict[str, str]) -> int | None:
    text = header.get("Total Data Rows", "").replace(",", "").split("\t")[0].strip()
    return int(text) if text.isdigit() else None


class _DataLayout(NamedTuple):
    """How the rows after the ``Data`` line are written: an export saved again by a spreadsheet or a regional
    setting may name its columns in a row of their own, close every row with a tab, or write decimal commas."""

    first_row: int  # 0-based index of the first line of numbers
    names: list[str] | None  # the names a row below the Data line gives the columns, time included
    decimal: str
    trailing: bool  # every row ends with a tab


LAYOUT_SAMPLE_ROWS = 20
"""Rows after the ``Data`` line read to tell the layout of the rest."""


def _data_layout(path: Path, data_line: int) -> _DataLayout:
    with open(path, encoding="latin-1") as handle:
        sample = [(index, line.rstrip("\r\n")) for index, line in itertools.islice(enumerate(handle), data_line + 1,
                                                                                   data_line + 1 + LAYOUT_SAMPLE_ROWS)
                  if line.strip()]
    if not sample:
        raise BearingTwinError(f"{path}: no data rows after the 'Data' line (line {data_line + 1})")
    names = None
    first_cells = [cell.strip() for cell in sample[0][1].split("\t")]
    if not any(_NUMBER.fullmatch(cell) for cell in first_cells if cell):  # names ("Time (s)", "Speed", "X", ...)
        names = list(first_cells)  # by position: a blank cell names its column too (an unnamed time column)
        while names and not names[-1]:  # a tab closing the row
            names.pop()
        sample = sample[1:]
    rows = [line for _, line in sample]
    trailing = bool(rows) and all(line.endswith("\t") for line in rows)
    cells = [cell for line in rows for cell in line.split("\t") if cell.strip()]
    decimal = "," if any("," in cell for cell in cells) and not any("." in cell for cell in cells) else "."
    first_row = sample[0][0] if sample else data_line + 2
    return _DataLayout(first_row, names, decimal, trailing)


def _read_table(path: Path, layout: _DataLayout) -> np.ndarray:
    """The rows of numbers as (n, 5) float64.

    pandas' C parser reads a 262,144-row file several times faster than numpy.loadtxt
    (benchmarks/hust_read.md) but pads short rows and empty cells with NaN and names no
    line on a bad cell; so whenever it fails or returns a NaN, the rows are re-checked one
    by one to tell a NaN written in the file from a damaged row and to name the line.
    """
    import pandas as pd

    try:
        table = pd.read_csv(path, sep="\t", header=None, skiprows=layout.first_row, dtype=np.float64, engine="c",
                            decimal=layout.decimal).to_numpy()
    except pd.errors.EmptyDataError:
        raise BearingTwinError(f"{path}: no data rows after the 'Data' line") from None
    except (ValueError, pd.errors.ParserError) as error:
        _diagnose_rows(path, layout)
        raise BearingTwinError(f"{path}: unreadable data rows ({error})") from None
    if layout.trailing and table.shape[1] == len(COLUMNS) + 1 and np.isnan(table[:, -1]).all():
        table = table[:, :-1]
    if table.shape[1] != len(COLUMNS):
        raise BearingTwinError(
            f"{path}: data rows have {table.shape[1]} columns, expected {len(COLUMNS)} ({', '.join(COLUMNS)})"
        )
    if np.isnan(table).any():
        _diagnose_rows(path, layout)
    return table


def _diagnose_rows(path: Path, layout: _DataLayout) -> None:
    """Raise naming the first row that is not five numbers; NaN written as such is allowed."""
    with open(path, encoding="latin-1") as handle:
        lines = handle.read().splitlines()
    numbered = [(number, line) for number, line in enumerate(lines, 1) if number > layout.first_row and line.strip()]
    last = numbered[-1][0] if numbered else 0
    for number, line in numbered:
        cells = (line.removesuffix("\t") if layout.trailing else line).split("\t")
        if len(cells) != len(COLUMNS):
            hint = " (truncated last row?)" if number == last else ""
            raise BearingTwinError(
                f"{path}: line {number} has {len(cells)} columns, expected {len(COLUMNS)} ({', '.join(COLUMNS)}){hint}"
            )
        for column, cell in zip(COLUMNS, cells):
            if not cell.strip():
                raise BearingTwinError(f"{path}: line {number} column {column} is empty")
            try:
                float(cell.replace(",", ".") if layout.decimal == "," else cell)
            except ValueError:
                raise BearingTwinError(f"{path}: line {number} column {column}: {cell!r} is not a number") from None
