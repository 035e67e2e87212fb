"""A table of numbers from a text file, as spreadsheets and data loggers write it.

numpy's ``loadtxt`` reads the numbers, streaming; what it cannot decide alone is decided here,
once per file, from its first rows: the encoding, the column separator (comma, semicolon, tab
or spaces), the decimal mark, whether the first row (or the comment line ``numpy.savetxt``
writes above the data) names the columns, whether a row of units follows the names (``Time,Acc`` above ``s,g``),
which columns hold a logger's clock time (``2024-03-01 10:00:00.000083``; a ``Date`` column beside a ``Time``
one) and whether every row ends with a separator. pandas'
``read_csv`` sniffs too, but guesses where this module refuses: a number whose decimal mark the
file contradicts (``1,234`` beside ``0.5``: a thousands separator) is refused naming its line,
never read a thousand times too small.
"""

from __future__ import annotations

import codecs
import csv
import itertools
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, NamedTuple

import numpy as np

from bearingtwin.data.units import quantity_of
from bearingtwin.errors import BearingTwinError

SAMPLE_LINES = 200
"""Lines read to decide the layout: enough for a header, comment lines and a sample of the numbers."""
DECIMAL_COMMA_REMEDY = "save the file with decimal points, or separate the columns with semicolons"
"""What to do about numbers written with decimal commas in a comma-separated file."""
_NUMBER_LIKE = re.compile(r"[+-]?(?:\d[\d.,]*|[.,]\d+)(?:[eE][+-]?\d+)?")
"""A cell that is a number under some decimal mark and grouping: the cells that tell the mark."""
_CLOCK = re.compile(r"(?P<date>\d{4}-\d{1,2}-\d{1,2}|\d{4}/\d{1,2}/\d{1,2}|\d{1,2}[./-]\d{1,2}[./-]\d{2,4})?"
                    r"(?:(?(date)(?:[ T]+))(?P<hour>\d{1,2}):(?P<minute>\d{2})(?::(?P<second>\d{2}(?:[.,]\d*)?))?Z?)?")
"""A logger's clock time (``10:00:00.000083``, ``2024-03-01 10:00:00.000083333``, ``2024-03-01T10:00:00Z``) or a
date alone (``01.03.2024``, ``2024-03-01``)."""


@dataclass
class CsvTable:
    """The numbers of a file (rows x columns), the names its header gives (None without one), and notes."""

    values: np.ndarray
    names: list[str] | None
    notes: list[str] = field(default_factory=list)
    preamble: list[str] = field(default_factory=list)  # a logger's lines above the header, stripped
    clock: list[str] = field(default_factory=list)  # columns of clock times, as seconds of their day in values
    dates: list[str] = field(default_factory=list)  # columns of dates alone beside them (0 in values)
    decimal: str = "."  # the decimal mark its numbers are written with


@dataclass(frozen=True)
class _Layout:
    encoding: str
    delimiter: str | None  # None: columns apart by spaces
    decimal: str
    body_start: int  # index of the first line after the header (of the first line, without one)
    trailing: bool  # every row ends with the separator
    preamble: tuple[str, ...] = ()  # a logger's lines above the header (:func:`_preamble`) and comments, stripped
    clock: tuple[int, ...] = ()  # columns of clock times (:data:`_CLOCK`)
    dates: tuple[int, ...] = ()  # columns of dates alone, beside a column of clock times
    text: tuple[int, ...] = ()  # named columns whose every cell in the first rows is text (:func:`_text_throughout`)


class _BadLine(Exception):
    def __init__(self, number: int, message: str):
        super().__init__(f"line {number}: {message}")


def read_csv_table(path: Path) -> CsvTable:
    """The table in ``path``; a file that is no such table is refused naming the file and, where one is
    to blame, its line."""
    _, layout, names, notes = _head_and_layout(path)
    every_name = names  # the layout's column indices count them all
    # A logger's status or comment column beside the numbers is passed over; a table of text alone is left to
    # loadtxt, which names its first cell.
    passed_over = layout.text if names is not None and len(layout.text) < len(names) else ()
    if passed_over:
        shown = ", ".join(repr(names[column]) for column in passed_over)
        notes = [*notes, f"column{'s' * (len(passed_over) > 1)} {shown} hold{'s' * (len(passed_over) == 1)} text, not "
                         "numbers: passed over"]
        names = [name for column, name in enumerate(names) if column not in passed_over]
    try:
        with open(path, encoding=layout.encoding) as handle, warnings.catch_warnings():
            warnings.filterwarnings("ignore", "loadtxt: input contained no data")  # refused below, naming the file
            values = np.loadtxt(_body_lines(handle, layout), delimiter=layout.delimiter, ndmin=2, dtype=np.float64,
                                quotechar='"' if layout.delimiter else None,
                                usecols=[column for column in range(len(every_name))
                                         if column not in passed_over] if passed_over else None,
                                converters={column: clock_seconds for column in layout.clock + layout.dates} or None)
    except _BadLine as error:
        raise BearingTwinError(f"{path}: {error}") from None
    except UnicodeDecodeError:
        raise _not_text(path) from None
    except ValueError as error:
        raise BearingTwinError(f"{path}: {_on_its_line(path, str(error), layout)}") from None
    if values.shape[0] == 0:
        raise BearingTwinError(f"{path}: the file holds a header but no data rows")
    if names is not None and values.shape[1] != len(names):
        # Twice the columns in a comma-separated file: "0,0324" is one number with a decimal comma, split in two.
        split = (f" (numbers written with decimal commas? {DECIMAL_COMMA_REMEDY})"
                 if layout.delimiter == "," and values.shape[1] == 2 * len(names) else "")
        raise BearingTwinError(f"{path}: the header names {len(names)} columns but the rows have {values.shape[1]}{split}")
    return CsvTable(values, names, notes, list(layout.preamble), [every_name[column] for column in layout.clock],
                    [every_name[column] for column in layout.dates], layout.decimal)


class TextColumn(NamedTuple):
    """A column of a table that holds text, not numbers, among the names its header gives."""

    names: list[str]
    name: str
    cell: str  # its first cell, to show


def text_column(path: Path) -> TextColumn | None:
    """The first column whose every cell in the file's first rows is text (a table of names or notes: a list of
    records, a log, a results table), else None: every column holds numbers, or the file is no table whose layout
    can be told (:func:`read_csv_table` then says why). A stray word among numbers is no text column: it is a
    damaged record, which the reader names by its line."""
    try:
        head, layout, names, _ = _head_and_layout(path)
    except BearingTwinError:
        return None
    if not layout.text:  # every column holds numbers (or the first row does: no header, no column text throughout)
        return None
    rows = [_cells(head[index], layout.delimiter) for index in _content(head) if index >= layout.body_start]
    column = layout.text[0]
    return TextColumn(names, names[column], next(row[column] for row in rows if column < len(row) and row[column]))


def is_a_note(path: Path) -> bool:
    """Whether the file is text whose first lines hold no row of numbers (a ``.txt`` beside the recordings:
    ``rig B, sensor on the housing``; an empty one). A file that is no text is no note: :func:`read_csv_table`
    names what is wrong with it."""
    try:
        head, _ = _head(path)
    except BearingTwinError:
        return False
    return not any(_numbers_row(line) for line in head if _holds_data(line))


def holds_one_value(path: Path) -> bool:
    """Whether the text file holds a single number (``seed.txt``, ``rate.txt``: a setting or a stamp beside the
    recordings, never samples), under at most one name (``fs`` above ``12000``), blank and ``#`` comment lines
    aside. A file that is no text holds none, nor one longer than the lines read to tell."""
    try:
        head, _ = _head(path)
    except BearingTwinError:
        return False
    if len(head) >= SAMPLE_LINES:  # more lines than were read: what follows may be samples
        return False
    lines = [line for line in head if _holds_data(line)]
    if len(lines) == 2 and len(_row_cells(lines[0], _delimiter(lines[0]))) == 1 and not _numbers_row(lines[0]):
        lines = lines[1:]  # a name above the number
    return len(lines) == 1 and _numbers_row(lines[0]) and len(_row_cells(lines[0], _delimiter(lines[0]))) == 1


def _head_and_layout(path: Path) -> tuple[list[str], _Layout, list[str] | None, list[str]]:
    """The file's first lines, the layout they show, the names its header gives and notes (:func:`_layout`);
    a file that is no text is refused."""
    head, encoding = _head(path)
    lines = [line.strip() for line in head[:2]]
    if len(lines) == 2 and lines[0] == "-1" and lines[1].isdigit():  # a Universal File's first data set opens so
        raise BearingTwinError(f"{path}: a Universal File Format export (data set {lines[1]}), not a table of numbers: "
                               "not read here; export the time records as a table (time, acceleration columns) or "
                               "save them as .npz")
    return (head, *_layout(path, head, encoding))


def _head(path: Path) -> tuple[list[str], str]:
    """The file's first :data:`SAMPLE_LINES` lines and its encoding; a file that is no text is refused."""
    encoding = _encoding(path)
    try:
        with open(path, encoding=encoding) as handle:
            return list(itertools.islice(handle, SAMPLE_LINES)), encoding
    except UnicodeDecodeError:
        raise _not_text(path) from None


def _not_text(path: Path) -> BearingTwinError:
    return BearingTwinError(f"{path}: not a text file, so no table of numbers (.csv, .txt, .tsv)")


def _encoding(path: Path) -> str:
    """UTF-8 (a byte-order mark allowed), else Windows' western code page (a German Excel's ``m/s²``)."""
    with open(path, "rb") as handle:
        start = handle.read(65536)
    if b"\x00" in start:
        raise _not_text(path)
    try:
        codecs.getincrementaldecoder("utf-8")().decode(start, final=False)  # a character cut at the end is no error
    except UnicodeDecodeError:
        return "cp1252"
    return "utf-8-sig"


def _holds_data(line: str) -> bool:
    """Whether a line holds something: it is neither blank nor a ``#`` comment (loadtxt skips both)."""
    return bool(line.strip()) and not line.lstrip().startswith("#")


def _content(lines: list[str]) -> list[int]:
    """Indices of the lines that hold something (:func:`_holds_data`)."""
    return [i for i, line in enumerate(lines) if _holds_data(line)]


def _delimiter(line: str) -> str | None:
    """The separator of a data row: a tab, a semicolon or a comma if it has one, else spaces between several
    numbers (None), else it is the only column (a comma, which it lacks)."""
    return next((d for d in ("\t", ";", ",") if d in line), None if len(line.split()) > 1 else ",")


def _cells(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [cell.strip() for cell in next(csv.reader([line.strip("\r\n")], delimiter=delimiter))]


def _is_number(text: str, decimal: str = ".") -> bool:
    try:
        float(text.replace(",", ".") if decimal == "," else text)
    except ValueError:
        return False
    return True


def _row_cells(line: str, delimiter: str | None) -> list[str]:
    """A row's cells without the empty one a closing separator leaves."""
    cells = _cells(line, delimiter)
    return cells[:-1] if len(cells) > 1 and cells[-1] == "" else cells


def _numbers_row(line: str) -> bool:
    """Whether a line is a row of numbers under some decimal mark (a closing separator allowed), clock times
    counted as numbers beside one at least (a logger's date line above its header, ``2024-03-01 10:00``, is none)."""
    cells = _row_cells(line, _delimiter(line))
    return (bool(cells) and all(_number_or_clock(cell) for cell in cells)
            and any(_NUMBER_LIKE.fullmatch(cell) and not _is_clock(cell) for cell in cells))


def _number_or_clock(cell: str) -> bool:
    """Whether a cell is a number under some decimal mark or a clock time (:func:`_is_clock`)."""
    return bool(_NUMBER_LIKE.fullmatch(cell)) or _is_clock(cell)


def _data_rows(head: list[str], content: list[int]) -> list[bool]:
    """Per line of ``content``, whether it is a row of the table's data: a row of numbers (:func:`_numbers_row`), or,
    where the last row holds text beside its numbers (a logger's ``status`` column), a row of as many cells whose cells
    are numbers wherever the last row's are (a header's names and a logger's notes are not)."""
    last = _row_cells(head[content[-1]], _delimiter(head[content[-1]]))
    numeric = [_number_or_clock(cell) for cell in last]
    if all(numeric) or not any(numeric):
        return [_numbers_row(head[i]) for i in content]

    def like_last(line: str) -> bool:
        cells = _row_cells(line, _delimiter(line))
        return len(cells) == len(last) and all(_number_or_clock(cell) for cell, number in zip(cells, numeric) if number)

    return [_numbers_row(head[i]) or like_last(head[i]) for i in content]


def _is_clock(cell: str) -> bool:
    """Whether a cell is a clock time or a date (:data:`_CLOCK`)."""
    match = _CLOCK.fullmatch(cell)
    return match is not None and bool(match["date"] or match["hour"])


def clock_seconds(cell: str) -> float:
    """The seconds since midnight a clock time gives (0 for a date alone): its date is passed over, a record
    spanning minutes, not days (a record running over midnight is unwrapped by its reader). Parsed here rather
    than by ``datetime``, which keeps microseconds only: a logger's stamps may print nanoseconds."""
    match = _CLOCK.fullmatch(cell.strip())
    if match is None or not (match["date"] or match["hour"]):
        raise ValueError(f"{cell!r} is no clock time")
    if match["hour"] is None:
        return 0.0
    return 3600.0 * int(match["hour"]) + 60.0 * int(match["minute"]) + float((match["second"] or "0").replace(",", "."))


def _units_row(cells: list[str]) -> bool:
    """Whether a row's cells are units (``s,g``, ``[s];[m/s^2]``), a cell without one left empty or ``-``."""
    cells = [cell.strip("()[] ") for cell in cells]
    return any(cells) and all(cell in ("", "-") or quantity_of(cell) for cell in cells)


_NOTE_LINE = re.compile(r"\s*[^\d\s:=][^:=]*[:=]\s*\S|\s*[^\W\d][^;\t]*[;\t]\s*[-+]?\d[^;\t]*$")
"""A logger's note: a label, then ``:`` or ``=``, then its value (``Sample rate: 12000 Hz``, ``Serial = A1234``); or a
label and a number in two cells, as a spreadsheet exports them (``Sample rate;25600``, ``Date<tab>2026-11-29``), which
a header's names (``ch1;ch2``) never are."""


def _preamble(head: list[str], content: list[int]) -> list[int]:
    """The lines a data logger writes above the header (``Device: ...``, ``Sample rate: 12000 Hz``): every line
    above a header whose names are as many as the numbers of the rows below it, when the header is not the first
    line, no line above it is a row of numbers (a damaged row among the numbers is refused by its line), and none
    has as many cells as the numbers unless every line above reads as a note, ``label: value``. A line of as many
    cells above the header is otherwise a second header row, refused by its line as without a preamble; in a table
    of one column every line has one cell, so there only the notes' form tells them apart. A row of units under the
    header (:func:`_units_row`) is the header's. Where no row of numbers follows (an export cut after its header), the
    lines above the header are notes when every one reads as one, so the file is said to hold no data rows."""
    numbers_rows = _data_rows(head, content)
    start = max((k + 1 for k, numbers in enumerate(numbers_rows) if not numbers), default=0)  # after the last text
    if start == len(content):  # no row of numbers: notes above a header (and its units) and no row under it, where
        # the header, read as the first row, would be named as a cell that is not a number
        last = head[content[-1]]
        if _NOTE_LINE.match(last):  # a file of notes alone, no header: no recording (a folder leaves it out)
            return []
        notes = content[:-1 - _units_row(_row_cells(last, _delimiter(last)))]
        return notes if all(_NOTE_LINE.match(head[i]) or _is_clock(head[i].strip()) for i in notes) else []
    if start < 2 or start == len(content) or any(numbers_rows[:start]):
        return []
    delimiter = _delimiter(head[content[start]])
    header_at = start - 1 - _units_row(_row_cells(head[content[start - 1]], delimiter))  # names above a row of units
    if header_at < 1:
        return []
    *above, header = [len(_row_cells(head[i], delimiter)) for i in content[:header_at + 1]]
    numbers = len(_row_cells(head[content[start]], delimiter))
    notes = content[:header_at]
    if header != numbers and not (delimiter == "," and numbers == 2 * header):  # decimal commas split each number
        return []  # in two: the notes are read, and the table refused with the remedy (read_csv_table)
    if numbers == 1 and header_at == start - 1 and all(_NOTE_LINE.match(head[i]) for i in content[:start]):
        return content[:start]  # a single column under notes alone ("Units: m/s^2" last): no header, no name
    # A logger's date line ("2024-03-01 10:00:00") is a note as "Device: X" is.
    return notes if numbers not in above or all(_NOTE_LINE.match(head[i]) or _is_clock(head[i].strip())
                                                for i in notes) else []


def _layout(path: Path, head: list[str], encoding: str) -> tuple[_Layout, list[str] | None, list[str]]:
    content = _content(head)
    if not content:
        raise BearingTwinError(f"{path}: the file holds no rows")
    preamble = _preamble(head, content)
    content = content[len(preamble):]
    first = content[0]
    # The separator as a data row shows it: a header's names may hold spaces ("Acc (g)").
    delimiter = _delimiter(head[content[1]] if len(content) > 1 else head[first])
    cells = _cells(head[first], delimiter)
    trailing = delimiter is not None and len(cells) > 1 and cells[-1] == ""
    cells = cells[:-1] if trailing else cells
    decimal = _decimal_mark(path, [cell for i in content for cell in _cells(head[i], delimiter)], delimiter)
    names, notes, body_start = None, [], first
    if preamble:
        shown = "; ".join(head[i].strip() for i in preamble[:3]) + ("; ..." if len(preamble) > 3 else "")
        notes.append(f"the {len(preamble)} line{'s' * (len(preamble) > 1)} above the header read as notes, not data "
                     f"({shown})")
    if not all(_is_number(cell, decimal) or _is_clock(cell) for cell in cells):  # a first row of stamps is data
        names, body_start = cells, first + 1
    elif first > 0 and head[first - 1].lstrip().startswith("#"):  # numpy.savetxt writes its header so: "# time,acc"
        above = _cells(head[first - 1].lstrip()[1:], delimiter)
        above = above[:-1] if trailing and above and above[-1] == "" else above
        # Names, not a note ("# Sample rate: 25600 Hz" above a column of numbers): no name holds a "key: value".
        if len(above) == len(cells) and not all(_is_number(cell, decimal) for cell in above) \
                and not any(re.search(r"[:=]\s*\S", cell) for cell in above):
            names = above
            notes.append("column names read from the comment line above the numbers, as numpy.savetxt writes them")
    if names is None and delimiter == ",":
        split = _split_by_decimal_comma([_cells(head[i], delimiter) for i in content])
        if split is not None:
            raise BearingTwinError(f"{path}: its row {split!r} reads as numbers written with decimal commas; "
                                   f"{DECIMAL_COMMA_REMEDY}")
    clock = dates = text = ()
    if names is not None:
        units = _row_cells(head[content[1]], delimiter) if len(content) > 1 else []
        if _units_row(units) and len(units) <= len(names):  # each name then states its unit
            units = ["" if unit == "-" else unit.strip("()[] ") for unit in units]  # "-": a column of no unit
            names = [f"{name} ({unit})" if unit else name
                     for name, unit in itertools.zip_longest(names, units, fillvalue="")]
            body_start = content[1] + 1
            notes.append(f"the row under the header read as the columns' units: {', '.join(names)}")
        rows = [_row_cells(head[i], delimiter) for i in content if i >= body_start]
        clock, dates = _clock_columns(rows, len(names))
        text = tuple(column for column in range(len(names)) if column not in clock + dates and
                     _text_throughout([row[column] for row in rows if column < len(row) and row[column]], decimal))
        names, repeated = _distinct(names)
        notes += repeated
    if names is not None and len(names) == 1 and delimiter == "," and _one_column_of_decimal_commas(
            [_row_cells(head[i], delimiter) for i in content if i >= body_start]):
        delimiter, decimal = ";", ","  # no line holds a semicolon: each is one cell, its comma the decimal mark
        notes.append("one column under its header, each number written with a decimal comma ('0,1'): read so")
    # A logger's notes above the header, and its '#' comment lines there ("# Sample rate: 25600 Hz"), in their order.
    notes_above = tuple(line.lstrip().removeprefix("#").strip() for i, line in enumerate(head[:first])
                        if i in preamble or line.lstrip().startswith("#"))
    layout = _Layout(encoding, delimiter, decimal, body_start, trailing, notes_above, clock, dates, text)
    return layout, names, notes


def _text_throughout(cells: list[str], decimal: str) -> bool:
    """Whether a column's non-empty ``cells`` in the first rows are all text (``OK``, a status, a comment): a stray
    word among numbers is no text column but a damaged record, which the reader names by its line."""
    return bool(cells) and not any(_is_number(cell, decimal) for cell in cells)


def _clock_columns(rows: list[list[str]], n_columns: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The columns whose every cell in ``rows`` is a clock time (``10:00:00.000083``, with a date or not), and,
    where there is one, those whose every cell is a date alone (a ``Date`` column beside a ``Time`` one)."""
    clock, dates = [], []
    for column in range(n_columns):
        cells = [row[column] for row in rows if column < len(row) and row[column]]
        matches = [_CLOCK.fullmatch(cell) for cell in cells]
        if not cells or not all(match and (match["date"] or match["hour"]) for match in matches):
            continue
        (clock if any(match["hour"] for match in matches) else dates).append(column)
    return (tuple(clock), tuple(dates)) if clock else ((), ())


def _split_by_decimal_comma(rows: list[list[str]]) -> str | None:
    """The first row that shows whole numbers to be halves of decimal-comma numbers, else None.

    Written with decimal commas and read as comma-separated, one column of numbers becomes two of
    integers: "0,3456" -> 0 and 3456. No integer column is written "0324" (a fraction's leading zero)
    or "-0" (the sign of a number between -1 and 0), and some row of the sample shows one of them.
    """
    for row in rows:
        row = row[:-1] if row and row[-1] == "" else row  # a separator closing the row
        if len(row) > 1 and all(re.fullmatch(r"-?\d+", cell) for cell in row) and (
                any(re.fullmatch(r"0\d+", cell) for cell in row[1:]) or row[0] == "-0"):
            return ",".join(row)
    return None


def _one_column_of_decimal_commas(rows: list[list[str]]) -> bool:
    """Whether the rows under a header of one name are that one column's numbers written with decimal commas: every
    row two cells, a whole number and a fraction's digits (``-0,1``); a second column's numbers would carry their own
    signs, points or exponents somewhere."""
    return bool(rows) and all(len(row) == 2 and re.fullmatch(r"[-+]?\d+", row[0].strip())
                              and re.fullmatch(r"\d+", row[1].strip()) for row in rows)


def _decimal_mark(path: Path, cells: list[str], delimiter: str | None) -> str:
    """``,`` when the file's numbers are written with decimal commas, else ``.``; a file whose numbers use both
    marks (one of them a thousands separator) is refused: which is which cannot be told."""
    if delimiter == ",":
        return "."
    numbers = [cell for cell in cells if _NUMBER_LIKE.fullmatch(cell) and not _is_clock(cell)]  # not 01.03.2024
    with_point = next((cell for cell in numbers if "." in cell), None)
    with_comma = next((cell for cell in numbers if "," in cell), None)
    grouped = next((cell for cell in numbers if cell.count(",") > 1 or cell.count(".") > 1), None)
    if grouped is not None or (with_point is not None and with_comma is not None):
        shown = grouped if grouped is not None else f"{with_point}' and '{with_comma}"
        raise BearingTwinError(f"{path}: its numbers ('{shown}') use more than one decimal mark, or a thousands "
                               "separator; save it with one decimal mark and no thousands separators")
    return "," if with_comma is not None else "."


def _body_lines(handle, layout: _Layout) -> Iterator[str]:
    """The lines after the header, each as loadtxt reads it: a closing separator dropped, a decimal comma made
    a point. A line whose numbers contradict the decimal mark the first rows showed is refused."""
    foreign = "." if layout.decimal == "," else ","
    for number, line in enumerate(itertools.islice(handle, layout.body_start, None), start=layout.body_start + 1):
        if layout.trailing:
            line = line.rstrip().removesuffix(layout.delimiter)
        if layout.delimiter != "," and foreign in line and _holds_data(line):  # rare: then cell by cell
            cell = next((c for c in _cells(line, layout.delimiter)
                         if foreign in c and _NUMBER_LIKE.fullmatch(c) and not _is_clock(c)), None)
            if cell is not None:
                raise _BadLine(number, f"{cell!r} is written with '{foreign}' where the rows above use "
                                       f"'{layout.decimal}' as the decimal mark (a thousands separator?)")
        yield line.replace(",", ".") if layout.decimal == "," else line


def _on_its_line(path: Path, message: str, layout: _Layout) -> str:
    """numpy's message with the file's own line number and cell for its data row (counted without blank and
    comment lines; from 0 in a conversion error, from 1 where the column count changes)."""
    converting = re.search(r"could not convert string .* at row (\d+), column (\d+)", message)
    changing = re.search(r"the number of columns changed from (\d+) to (\d+) at row (\d+)", message)
    if converting is None and changing is None:
        return message
    row = int(converting[1]) if converting else int(changing[3]) - 1
    with open(path, encoding=layout.encoding) as handle:
        data_lines = ((number, line) for number, line in enumerate(handle, start=1)
                      if number > layout.body_start and _holds_data(line))
        found = next(itertools.islice(data_lines, row, None), None)
    if found is None:
        return message
    number, line = found
    if changing:
        return f"line {number} has {changing[2]} columns where the rows above have {changing[1]}"
    column = int(converting[2])
    cells = _cells(line, layout.delimiter)
    cell = cells[column - 1] if column <= len(cells) else ""
    comma = (f" (a number written with a decimal comma? {DECIMAL_COMMA_REMEDY})"
             if layout.delimiter == "," and re.fullmatch(r"[+-]?\d*,\d+", cell) else "")
    if _is_clock(cell.strip()) and not layout.clock:  # stamps are read as such under a header that names the columns
        comma = " (a clock time: give the file a header row naming its columns, and its stamps are read as time stamps)"
    return f"line {number}, column {column}: {cell!r} is not a number{comma}"


def _distinct(names: list[str]) -> tuple[list[str], list[str]]:
    """Column names made distinct as pandas makes them (``acc``, ``acc.1``, skipping a name another column
    has), and a note for each repeated one."""
    used: set[str] = set()
    distinct = []
    for name in names:
        candidate, count = name, 0
        while candidate in used or (count and candidate in names):
            count += 1
            candidate = f"{name}.{count}"
        used.add(candidate)
        distinct.append(candidate)
    notes = [f"more than one column is headed {name!r}: read as "
             f"{', '.join(repr(d) for d, n in zip(distinct, names) if n == name)}, from left to right"
             for name in dict.fromkeys(names) if names.count(name) > 1]
    return distinct, notes
