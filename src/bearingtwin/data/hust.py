"""The HUST bearing data set (Zhao, Zio, Shen, RESS 2024): the seed paper's second experiment.

The files are named ``.xls`` but are tab-separated text exported by the rig's software:
a header block (``Title:``, ``DAQ Settings:``, ``Total Data Rows``, ``Legend``, ``Units`` ...), a line
reading ``Data`` (or ``Data:``), then rows of time (s), speed (not meaningful), X, Y, Z acceleration, in the
order the ``Legend`` line names them (an export of fewer channels, ``Legend Speed Y Z``, holds those alone);
the ``Units`` line below it gives each channel's unit (``V g g g``).
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
from bearingtwin.data.formats import (FS_RELATIVE_TOLERANCE, RawRecord, coarse_stamps, fs_from_time_column, read_raw,
                                      recording_from_raw)
from bearingtwin.data.recording import Recording
from bearingtwin.data.units import acceleration_unit, quantity_of
from bearingtwin.errors import BearingTwinError

COLUMNS = ("time", "speed", "X", "Y", "Z")
CHANNELS = COLUMNS[2:]
STATES = {"H": "normal", "I": "inner", "B": "ball", "O": "outer", "C": None}
"""File-name state letter -> bearing state; C (inner + outer combined) has no single FAULTS label."""
BEARING = "er16k"
"""The rig's bearing (``conf/bearing/er16k.yaml``), which every HUST file records."""

HEADER_LINE_LIMIT = 200
"""The ``Data`` line must appear within this many lines; the reported header has about 21."""
DATA_MARKERS = ("data", "data:")
"""The line that ends the header, in lower case: ``Data`` as reported, ``Data:`` as the header's other keys are
written, ``DATA`` as another version of the software may write it."""
UTF8_BOM = "\ufeff".encode("utf-8").decode("latin-1")
"""A UTF-8 byte-order mark as the latin-1 reading sees it: a file saved again by an editor may start with one."""

_NUMBER = re.compile(r"[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?|[-+]?(nan|NaN|inf|Inf)")
"""A cell that is a number under either decimal mark; a first cell that is not one names the columns."""
_NAME = re.compile(r"^(?P<prefix>0\.5X_)?(?P<state>[HIOBC])_(?P<condition>\d+(?:\.\d+)?Hz|VS_[\d_]+Hz)$", re.IGNORECASE)
"""Letters in either case: a copy through another operating system or archive may change them (``h_65hz.xls``)."""
NAME_FORM = ("<state>_<speed>Hz.xls: <state> H, I, O, B or C, after 0.5X_ for medium damage; <speed> the shaft's "
             "in Hz, or VS_0_40_0 for the variable-speed run; e.g. 0.5X_O_65Hz.xls")
"""The file names :func:`parse_hust_name` reads (``_NAME``), in words, as messages give them."""


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
    state, condition = match["state"].upper(), match["condition"].upper().replace("HZ", "Hz")  # as the data set writes them
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
    """Every column of a HUST export (speed included, NaN cells kept) by the names its ``Legend`` gives, each
    channel's unit from the ``Units`` row below it, with the header as meta."""
    path = Path(path)
    header, header_rows, data_line = _read_header(path)
    layout = _data_layout(path, data_line)
    # A row of names below the 'Data' line names the columns (its first, the time column's) over the Legend, which
    # then gives the units' places alone, and cannot refuse the file.
    try:
        legend = _column_order(header_rows.get("Legend"), "the header's Legend")
    except BearingTwinError as error:
        if layout.names is None:
            raise BearingTwinError(f"{path}: {error}") from None
        legend = None
    try:
        columns = legend if layout.names is None else _column_order(layout.names[1:],
                                                                    "the row of names below the 'Data' line")
    except BearingTwinError as error:
        raise BearingTwinError(f"{path}: {error}") from None
    legend = legend or columns
    table = _read_table(path, layout, columns)
    declared_rows = _declared_rows(header)
    if declared_rows is not None and declared_rows != table.shape[0]:
        raise BearingTwinError(
            f"{path}: the header declares {declared_rows} data rows (Total Data Rows) but the file holds "
            f"{table.shape[0]}; the file is truncated or not a single export"
        )
    name = parse_hust_name(path)
    notes = list(columns.notes)
    if layout.decimal == ",":
        notes.append("numbers written with decimal commas")
    channels = dict(zip(columns.names, table[:, 1:].T))
    units, unit_notes = _channel_units(legend, header_rows.get("Units"))
    if layout.names is not None:  # "X (g)" in the row of names states X's unit
        units.update({channel: unit for cell, channel in zip(layout.names[1:], columns.names)
                      if (unit := _unit(re.sub(r"^[^(\[]*", "", cell))[0])})
    notes += [note for channel, note in unit_notes.items() if channel in (*CHANNELS, "") and channel in (*channels, "")]
    meta = {"header": header, "data_line": data_line + 1, "bearing": BEARING, "notes": notes,
            "columns_named_by": columns.named_by}
    if "speed" in channels:
        meta["not_vibration"] = {"speed": "the export's speed column, not meaningful (the shaft speed is in the file's "
                                          "name)"}
    if name is None:  # a user's own name: the reader knows no other place for the speed and the state
        notes.append(f"the name {path.name!r} is not a HUST file name ({NAME_FORM}): its shaft speed and bearing "
                     "state are not read from it")
        meta["unread_name"] = "its name is not a HUST file name"
    else:
        meta.update(state=name.state, severity=name.severity, condition=name.condition)
        if name.fault is None:  # C: no single state of the four a model or the twin knows
            meta["unlabelled_state"] = f"inner and outer races damaged together ({name.state} in its name)"
        if name.shaft_hz is None:
            meta["no_speed"] = f"a variable-speed run ({name.condition} in its name): its speed changes over the record"
    fs, fs_origin, rate_note = _sampling_rate(path, header, table[:, 0], layout.decimal)
    notes += [rate_note] if rate_note else []
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
        channel_units={channel: unit for channel, unit in units.items() if channel in channels},
    )


def load_hust(path: str | Path, channel: str = "X", fs: float | None = None, channel_key: str = "channel",
              fs_key: str = "fs") -> Recording:
    """One accelerometer axis (X, Y or Z) of a HUST file, fs checked against the time column; ``channel_key``
    and ``fs_key`` are the settings ``channel`` and ``fs`` come from, as messages name them. An export whose
    Legend names no such axis is refused, naming the columns it names."""
    if channel not in CHANNELS:
        raise BearingTwinError(f"{channel_key}={channel!r} is not a HUST accelerometer axis; choose one of {', '.join(CHANNELS)}")
    raw = read_raw(path)
    if raw.format == "hust-xls" and channel not in raw.channels:
        axes = [axis for axis in CHANNELS if axis in raw.channels]
        raise BearingTwinError(f"{raw.path}: {channel_key}={channel}, but {raw.meta['columns_named_by']} names no "
                               f"{channel} column; choose one of {', '.join(axes)}" if axes else
                               f"{raw.path}: {channel_key}={channel}, but {raw.meta['columns_named_by']} names no "
                               "accelerometer axis (X, Y or Z)")
    return recording_from_raw(raw, channel=channel, fs=fs, channel_key=channel_key, fs_key=fs_key)


class _Columns(NamedTuple):
    """The columns after time, as a Legend (or a row of names) gives them."""

    names: list[str]  # in the file's order, as COLUMNS spells them
    cells: list[int]  # each one's cell in the legend, where the Units row's cell beside it gives its unit
    notes: list[str]
    named_by: str  # the legend and what it reads, as messages name it
    width: int  # the legend's cells, time's among them, up to its last named one


_SPEED_NAMES = ("speed", "tacho", "tach", "tachometer", "rpm", "shaft speed", "rotating speed", "rotational speed")
"""Names a rig's software may give the speed column (the column is never read: the file's name gives the speed)."""
_AXIS_NAME = re.compile(r"^(?:(?:acc(?:el(?:eration)?)?|vib(?:ration)?|ch(?:annel)?)[\s_.-]*)?(?P<axis>[xyz])"
                        r"(?:[\s_.-]*(?:axis|acc(?:el(?:eration)?)?|dir(?:ection)?))?$", re.IGNORECASE)
"""An accelerometer axis as a Legend may name it: ``X``, ``x axis``, ``Z-axis``, ``Acc X``, ``Acceleration Y``."""


def _bare_name(cell: str) -> str:
    """A Legend cell's name, its unit in brackets aside (``X (g)``, ``Speed [rpm]``)."""
    return re.sub(r"\s*[(\[].*$", "", cell).strip()


def _time_name(cell: str) -> bool:
    """Whether a Legend cell names the time column (``Time``, ``t``, ``Time (s)``, ``Time_s``, ``Timestamp``)."""
    bare = _bare_name(cell).lower()
    return bare in ("t", "t_s") or bare.startswith("time")


def _column_name(cell: str) -> str | None:
    """The column (``speed``, ``X``, ``Y``, ``Z``) a Legend cell names, its unit in brackets aside; None for another."""
    bare = _bare_name(cell)
    if bare.lower() in _SPEED_NAMES:
        return "speed"
    axis = _AXIS_NAME.match(bare)
    return axis["axis"].upper() if axis else None


def _column_order(legend: list[str] | None, where: str) -> _Columns:
    """The names of the columns after time, in the order ``legend`` (its cells after the key, said to be ``where``)
    gives, and a note when it gives none that names them: an export with its channels in another order, or with
    some of them alone (``Speed Y Z``), is read by name; one that names X, Y and Z and one other cell (``Drehzahl Z Y
    X``) reads the axes by name and that cell as the speed column; one whose legend names no column known here (the
    layout was reported, not checked) by position, and said so. A legend that names an axis where the position would
    read another, beside cells it does not name, is refused: neither reading can be trusted."""
    if legend is None:
        return _Columns(list(COLUMNS[1:]), list(range(len(COLUMNS) - 1)), [], "the default order (no Legend)",
                        len(COLUMNS) - 1)
    written = [(index, cell.strip()) for index, cell in enumerate(legend) if cell.strip()]
    cells = [cell for _, cell in written]
    # "X (g)", "Speed [rpm]": the name alone; a time column's name is not one of the channels'
    named = [(index, cell, _column_name(cell)) for index, cell in written if not _time_name(cell)]
    # A first cell no name reads before the four columns named in full is the time column's, however it is called.
    if len(named) == len(COLUMNS) and named[0][2] is None and {name for _, _, name in named[1:]} == set(COLUMNS[1:]):
        named = named[1:]
    names = [name for _, _, name in named]
    width = written[-1][0] + 1 if written else 0
    known = [name for name in names if name]
    unknown = [cell for _, cell, name in named if name is None]
    if known and len(set(known)) == len(known):
        if not unknown:
            return _Columns(names, [index for index, _, _ in named], [], f"{where} ({', '.join(cells)})", width)
        if set(CHANNELS) <= set(known) and len(unknown) == 1 and "speed" not in known:
            return _Columns(["speed" if name is None else name for name in names], [index for index, _, _ in named],
                            [f"{where} reads {' '.join(cells)!r}: X, Y and Z are read by their names, and "
                             f"{unknown[0]!r}, no name known here, as the speed column (which is not read)"],
                            f"{where} ({', '.join(cells)}; {unknown[0]} read as the speed column)", width)
    by_position = COLUMNS[1:]
    twice = sorted({name for name in known if known.count(name) > 1})
    if twice:
        raise BearingTwinError(f"{where} reads {' '.join(cells)!r}: it names {' and '.join(twice)} twice, so its "
                               "columns cannot be told apart; name them Speed, X, Y and Z")
    misplaced = [(name, by_position[place]) for place, name in enumerate(names[:len(by_position)])
                 if name and name != by_position[place]]
    if misplaced:
        raise BearingTwinError(f"{where} reads {' '.join(cells)!r}: it names {misplaced[0][0]} where the reported "
                               f"layout (speed, X, Y, Z) has {misplaced[0][1]}, beside cells no name known here reads "
                               f"({', '.join(repr(cell) for cell in unknown)}), so its columns can be read neither by "
                               "name nor by position; name them Speed, X, Y and Z")
    positions = [index for index, _, _ in named] if len(named) == len(COLUMNS) - 1 else list(range(len(COLUMNS) - 1))
    return _Columns(list(COLUMNS[1:]), positions,
                    [f"{where} reads {' '.join(cells)!r}, not Speed, X, Y and Z: the columns after time are read by "
                     f"position as {', '.join(COLUMNS[1:])}"], f"{where} ({', '.join(cells)}, read by position)",
                    max(width, len(COLUMNS) - 1))


def _channel_units(legend: _Columns, units: list[str] | None) -> tuple[dict[str, str], dict[str, str]]:
    """Each channel's unit from the header's ``Units`` row (its cells after the key, beside the Legend's), and notes
    (by channel, "" for the row) on a cell that is no unit known here; none where the row is absent or holds more
    units than the Legend names columns (a time column's unit before them, ``s``, is passed over)."""
    units = list(units or [])
    while units and not units[-1]:  # a tab closing the row
        units.pop()
    if not units:
        return {}, {}
    if len(units) == legend.width + 1 and quantity_of(units[0]) == "a time":  # "Units  s  V  g  g  g"
        units = units[1:]
    if len(units) > legend.width:
        return {}, {"": f"the header's Units row gives {len(units)} units ({', '.join(units)}) for the {legend.width} "
                        f"columns {legend.named_by} names: no unit read from it"}
    # One unit per channel beside a Legend of more cells (a "Time" cell among them): the units are the channels', in
    # their order, not the Legend's cells'.
    cells = (range(len(units)) if len(units) == len(legend.names) < legend.width and quantity_of(units[0]) != "a time"
             else legend.cells)
    read, notes = {}, {}
    for channel, index in zip(legend.names, cells):
        unit, unknown = _unit(units[index] if index < len(units) else "")
        if unit:
            read[channel] = unit
        elif unknown:
            notes[channel] = (f"the header's Units row gives {channel} the unit {unknown!r}, none known here: read as "
                              "stating no unit")
    return read, notes


def _unit(cell: str) -> tuple[str, str]:
    """A unit as a Units cell (or brackets after a column's name) writes it: an acceleration unit in its canonical
    spelling (``g``, ``m/s^2``), a unit of another quantity as written (``V``); "" and the text for text that is no
    unit known here, "" and "" for none. A UTF-8 ``m/s²`` or ``µg`` read as latin-1 is read as written."""
    text = cell.strip().strip("()[]").strip()
    try:
        text = text.encode("latin-1").decode("utf-8")
    except UnicodeError:  # written in latin-1 (or another 8-bit code page) itself
        pass
    if not text or text == "-":
        return "", ""
    unit = acceleration_unit(text) or (text if quantity_of(text) else "")
    return unit, "" if unit else text


def _read_header(path: Path) -> tuple[dict[str, str], dict[str, list[str]], int]:
    """Header key/value pairs, the cells after the key of each tab-separated header line (the ``Legend`` and
    ``Units`` rows: a cell may be empty), and the 0-based index of the ``Data`` line."""
    with open(path, "rb") as handle:
        magic = handle.read(8)
    if magic.startswith(b"\xd0\xcf\x11\xe0") or magic.startswith(b"PK\x03\x04"):
        raise BearingTwinError(
            f"{path}: is a binary Excel workbook, not the tab-separated text export the HUST files are; "
            "save it as tab-separated text, or give the original exports instead"
        )
    header: dict[str, str] = {}
    rows: dict[str, list[str]] = {}
    with open(path, encoding="latin-1") as handle:
        for index, line in enumerate(handle):
            text = line.removeprefix(UTF8_BOM).strip()
            if text.lower() in DATA_MARKERS:
                return header, rows, index
            if index >= HEADER_LINE_LIMIT:
                break
            key, _, value = re.split(r"(\t|:)", text, maxsplit=1) if re.search(r"\t|:", text) else (text, "", "")
            if key:
                header[key.strip()] = value.strip(" \t:")
            first, *cells = line.removeprefix(UTF8_BOM).rstrip("\r\n").split("\t")
            if cells and first.strip().rstrip(":").strip():
                rows[first.strip().rstrip(":").strip()] = [cell.strip() for cell in cells]
    raise BearingTwinError(
        f"{path}: no line reading 'Data' (or 'Data:') within the first {HEADER_LINE_LIMIT} lines; expected a HUST "
        "text export (header block, a 'Data' line, then rows of time, speed, X, Y, Z)"
    )


def _sampling_rate(path: Path, header: dict[str, str], time_s: np.ndarray,
                   decimal: str = ".") -> tuple[float, str, str | None]:
    """The rate the header's ``Sampling Rate`` line states (``25600``, ``25600 Hz``, ``25.6 kHz``), checked against the
    time column; the time column's alone when the header states none; and a note where the time column could not
    check it. ``decimal``: the mark the data rows use (a file written with decimal commas writes 25600,0, and may
    group thousands with points).

    The header is exact (25600), while the time column, printed to a microsecond, only approximates it (25599.9997
    Hz over a whole file). A time column printed coarser than a sample period (to 0.0001 s at 25.6 kHz) repeats its
    stamps and states no rate, and one counting milliseconds gives a thousandth of the header's: the header's rate
    is taken, said so.
    """
    written = header.get("Sampling Rate", "").split("\t")[0].strip()
    if not written:
        return fs_from_time_column(time_s, str(path)), "time column", None
    number, unit = re.fullmatch(r"(.*?)\s*((?:k|K)?(?:Hz|HZ|hz|S/s|SPS|sps|Sa/s))?", written).groups()
    # The other mark groups thousands: 25,600 (or 25.600,0 beside decimal commas).
    text = number.replace(".", "").replace(",", ".") if decimal == "," else number.replace(",", "")
    try:
        stated = float(text) * (1000.0 if unit and unit[0] in "kK" else 1.0)
    except ValueError:
        raise BearingTwinError(f"{path}: the header's Sampling Rate {written!r} is not a number") from None
    if not (np.isfinite(stated) and stated > 0):
        raise BearingTwinError(f"{path}: the header's Sampling Rate {written!r} is not a positive number")
    if coarse_stamps(time_s):
        return stated, "header", (f"the time column repeats its stamps, printed coarser than a sample period: the "
                                  f"header's Sampling Rate ({stated:g} Hz) is taken unchecked")
    try:
        from_time = fs_from_time_column(time_s, str(path))
    except BearingTwinError:
        span_s = float(time_s[-1] - time_s[0]) if time_s.size > 1 else 0.0
        in_ms = span_s > 0 and abs((time_s.size - 1) / span_s * 1000.0 / stated - 1.0) <= FS_RELATIVE_TOLERANCE
        if not in_ms:
            raise
        return stated, "header", (f"the time column counts milliseconds (it spans {span_s:g} for "
                                  f"{time_s.size} rows): the header's Sampling Rate ({stated:g} Hz) agrees with it so")
    if abs(from_time / stated - 1.0) > FS_RELATIVE_TOLERANCE:
        raise BearingTwinError(f"{path}: the header's Sampling Rate {written!r} (read as {stated:g} Hz, a comma "
                               f"taken for a thousands separator) contradicts the time column's {from_time:.6g} Hz"
                               if "," in written and decimal == "." else
                               f"{path}: the header's Sampling Rate {written}{'' if unit else ' Hz'} contradicts the time column's "
                               f"{from_time:.6g} Hz")
    return stated, "header", None


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


def _read_table(path: Path, layout: _DataLayout, columns: _Columns, tabs_only: frozenset[int] = frozenset()
                ) -> np.ndarray:
    """The rows of numbers as (n, 1 + the ``columns``' count) float64: time and the columns the Legend names.

    pandas' C parser reads a 262,144-row file several times faster than numpy.loadtxt
    (benchmarks/hust_read.md) but pads short rows and empty cells with NaN and names no
    line on a bad cell; so whenever it fails or returns a NaN, the rows are re-checked one
    by one to tell a NaN written in the file from a damaged row and to name the line.
    It skips blank lines but reads a line of tabs alone (a spreadsheet saving the file again leaves them after the
    data) as a row of NaN, or as too many cells: the re-check finds those lines (``tabs_only``, 0-based), and the
    rows are read again without them, as blank lines.
    """
    import pandas as pd

    skipped = sorted({*range(layout.first_row), *tabs_only}) if tabs_only else layout.first_row
    try:
        table = pd.read_csv(path, sep="\t", header=None, skiprows=skipped, dtype=np.float64, engine="c",
                            decimal=layout.decimal).to_numpy()
    except pd.errors.EmptyDataError:
        raise BearingTwinError(f"{path}: no data rows after the 'Data' line") from None
    except (ValueError, pd.errors.ParserError) as error:
        if (found := _diagnose_rows(path, layout, columns)) and not tabs_only:
            return _read_table(path, layout, columns, found)
        raise BearingTwinError(f"{path}: unreadable data rows ({error})") from None
    expected = ("time", *columns.names)
    if layout.trailing and table.shape[1] == len(expected) + 1 and np.isnan(table[:, -1]).all():
        table = table[:, :-1]
    if table.shape[1] != len(expected):
        named = f" as {columns.named_by} names them" if len(expected) != len(COLUMNS) else ""
        raise BearingTwinError(
            f"{path}: data rows have {table.shape[1]} columns, expected {len(expected)} ({', '.join(expected)}){named}"
        )
    # Read again without its lines of tabs, the table's NaN are written in the file (the re-check allowed them).
    if not tabs_only and np.isnan(table).any() and (found := _diagnose_rows(path, layout, columns)):
        return _read_table(path, layout, columns, found)
    return table


def _diagnose_rows(path: Path, layout: _DataLayout, columns: _Columns) -> frozenset[int]:
    """Raise naming the first row that is not time and the ``columns``' numbers; NaN written as such is allowed.
    Blank lines are passed over; those holding a tab (which pandas reads as a row) are returned, 0-based."""
    expected = ("time", *columns.names)
    with open(path, encoding="latin-1") as handle:  # lines as _data_layout counts them, and pandas
        lines = [line.rstrip("\r\n") for line in handle]
    numbered = [(number, line) for number, line in enumerate(lines, 1) if number > layout.first_row and line.strip()]
    last = numbered[-1][0] if numbered else 0
    for number, line in numbered:
        cells = (line.removesuffix("\t") if layout.trailing else line).split("\t")
        # A copy cut short ends in too few cells, an empty one (cut after a tab) or part of a number ('-', '1e').
        hint = " (truncated last row?)" if number == last else ""
        if len(cells) != len(expected):
            raise BearingTwinError(
                f"{path}: line {number} has {len(cells)} columns, expected {len(expected)} ({', '.join(expected)}){hint}"
            )
        for column, cell in zip(expected, cells):
            if not cell.strip() and column == "speed":  # a column never read (the name gives the speed) may be blank
                continue
            if not cell.strip():
                raise BearingTwinError(f"{path}: line {number} column {column} is empty{hint}")
            try:
                float(cell.replace(",", ".") if layout.decimal == "," else cell)
            except ValueError:
                raise BearingTwinError(f"{path}: line {number} column {column}: {cell!r} is not a number"
                                       f"{hint}") from None
    return frozenset(index for index, line in enumerate(lines) if index >= layout.first_row and not line.strip()
                     and "\t" in line)
