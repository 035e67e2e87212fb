"""A folder of labelled recordings: the labels table that names each file's state (and its speed and rate where the
file does not state them), the file-name pattern that may name it instead, and which of a folder's files are
recordings at all (a table of notes or of results beside them is not).

Training (``data=files``, the twin-to-real source), ``bearingtwin-diagnose``, ``bearingtwin-twin`` and
``bearingtwin-inspect`` read a folder and its table through these functions alone.
"""

from __future__ import annotations

import csv
import logging
import re
from pathlib import Path, PurePath
from typing import NamedTuple

from bearingtwin.checks import positive_number
from bearingtwin.data.csv_file import holds_one_value, is_a_note, text_column
from bearingtwin.data.formats import FORMATS, TEXT_TABLES, known_unit, time_column_seconds
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS

log = logging.getLogger(__name__)

LABEL_COLUMNS = ("record", "state", "rpm", "fs", "unit", "scale")
"""Columns of a labels table: ``record`` (file name in ``data.root``) and ``state`` are required (a diagnosis may
leave the state out: :func:`labels_table_with_bad_rows`); ``rpm``, ``fs`` and ``unit`` give what a file does not
state (a logger's WAVs in g beside files in m/s^2: one folder), and ``scale`` multiplies its samples, ``unit`` then
naming the product's (an integer WAV whose full scale is 5 g: ``scale`` 5, ``unit`` g)."""


class LabelsRow(NamedTuple):
    """A row of a labels table that reads: ``where`` (its file and line, for messages), the ``record`` it names, its
    bearing ``state`` (None: unknown, where a diagnosis allows it), and the shaft speed ``rpm`` (rev/min), sampling
    rate ``fs`` (Hz) and ``unit`` of the samples it gives, and the ``scale`` they are multiplied by first, ``unit``
    then the product's (None: not given)."""

    where: str
    record: str
    state: str | None
    rpm: float | None
    fs: float | None
    unit: str | None
    scale: float | None = None


class LabelledFile(NamedTuple):
    """A recording of a labelled folder as training reads it: its file, its ``state``, and the ``rpm``, ``fs``,
    ``unit`` and ``scale`` its labels row gives (None: the file's own, or the setting's)."""

    path: Path
    state: str
    rpm: float | None = None
    fs: float | None = None
    unit: str | None = None
    scale: float | None = None

    def unit_settings(self) -> dict:
        """The row's ``unit`` and ``scale`` as :func:`~bearingtwin.data.formats.load_recording` takes them, each named
        as the row's in a message."""
        return {"unit": self.unit, "unit_key": "the labels row's unit", "scale": self.scale,
                "scale_key": "the labels row's scale"}

    def key_facts(self) -> tuple:
        """What a dataset's key holds of the row: its state, rpm and fs, and its unit and scale where it gives them (a
        table without them keeps the key it had before they could be given)."""
        return (self.state, self.rpm, self.fs, *filter(None, [self.unit, self.scale]))


DEFAULT_LABELS = "labels.csv"
"""The labels table ``data=files`` reads from ``data.root`` unless ``data.labels`` names another."""


def rows_from_labels(root: Path, cfg: dict, alternative: str = " or give data.pattern=<regex with a (?P<state>...) group>",
                     warn_unlisted: bool = True) -> list[LabelledFile]:
    """A :class:`LabelledFile` per row of the labels table ``data.labels`` (default ``<root>/labels.csv``);
    ``alternative`` ends the message when there is no such table; ``warn_unlisted``: say which recordings of
    ``root`` the table leaves out (where the data is built, not in the checks before it)."""
    table = labels_path(root, cfg)
    if not table.is_file():
        raise BearingTwinError(
            f"data.labels: no labels file {table}; write one with columns {','.join(LABEL_COLUMNS)} "
            f"(one row per file){alternative}"
        )
    rows, labelled_at = [], {}
    for row in labels_table(table):
        path = labelled_file(root, row.record, row.where)
        same = path.resolve()  # a stem and its file's name (or rig/../x and x): one record named twice
        if same in labelled_at:
            raise BearingTwinError(f"{row.where}: record {row.record!r} is labelled again ({labelled_at[same]} names "
                                   f"{path.name} too); one row per record")
        labelled_at[same] = row.where
        rows.append(LabelledFile(path, row.state, row.rpm, row.fs, row.unit, row.scale))
    if not rows:
        raise BearingTwinError(f"{table}: lists no recordings")
    recordings, others = recordings_and_others(root)
    unlisted = sorted(set(recordings) - {row.path for row in rows} - {table})
    if warn_unlisted:
        if unlisted:
            log.warning("%s: %s not labelled in %s, left out", root, ", ".join(path.name for path in unlisted), table.name)
        warn_left_out(root, {name: reason for name, reason in others.items()
                             if root / name not in {row.path for row in rows} and root / name != table})
    return rows


def labels_path(root: Path, cfg: dict) -> Path:
    """The labels table a folder of recordings is read with: ``data.labels``, else ``<root>/labels.csv``."""
    return Path(str(cfg.get("labels") or root / DEFAULT_LABELS)).expanduser()


def labels_table(table: Path) -> list[LabelsRow]:
    """A :class:`LabelsRow` per row of a labels table (columns ``record,state[,rpm,fs,unit,scale]``);
    ``where`` is the file and line, for messages. A bad header raises, and so does a bad row (naming its line and
    field; several, the first three and a count, so a table is mended in one pass): what reads every row, a training
    set, would otherwise be built without that record."""
    rows, bad_rows = labels_table_with_bad_rows(table)
    if len(bad_rows) == 1:
        raise BearingTwinError(bad_rows[0][1])
    if bad_rows:
        raise BearingTwinError(f"{len(bad_rows)} rows of {table} do not read: "
                               f"{first_messages([message for _, message in bad_rows])}")
    return rows


def labels_table_with_bad_rows(table: Path, state_required: bool = True) -> tuple[
        list[LabelsRow], list[tuple[str, str]]]:
    """The rows of a labels table that read, as :func:`labels_table` gives them, and ``(record, message)`` for
    each that does not (more values than the header has columns, a record labelled again, a state that is no
    bearing state, an rpm, fs or scale that is no positive number, a unit not known here, a scale without a unit), in
    the table's order: a bad row is its record's
    concern alone where a command reads one file's row, or each file of a folder its own. A table that cannot be
    read, or whose header is wrong, raises: none of its rows can be read.

    ``state_required=False`` (a diagnosis, where a fleet's states are what is asked): the ``state`` column may be
    left out and its cells left empty, such a row's state None (unknown) and its other cells read all the same; a
    state given must still be a bearing state. Training keeps it required: there the state is the label."""
    try:
        with open(table, newline="", encoding="utf-8-sig") as handle:  # -sig: a spreadsheet's byte-order mark
            header = handle.readline()
            handle.seek(0)
            # A spreadsheet set to a decimal comma separates its columns with semicolons (the table holds no decimals
            # beside rpm, fs and scale, which such a spreadsheet writes with commas too; a unit holds no comma).
            semicolons = ";" in header and "," not in header
            reader = csv.DictReader(handle, delimiter=";" if semicolons else ",")
            # Record,State,RPM,Fs,Unit,Scale as a spreadsheet capitalizes them: the same columns.
            columns = [name.strip().lower() if name.strip().lower() in LABEL_COLUMNS else name.strip()
                       for name in reader.fieldnames or []]
            twice = next((name for name in LABEL_COLUMNS if columns.count(name) > 1), None)
            if twice:  # rpm and RPM: one would be read, the other passed over
                raise BearingTwinError(f"{table}: the header names column {twice} more than once (in any case)")
            # Unnamed columns (a trailing separator) each keep a key of their own, so a value under any of them is seen.
            reader.fieldnames = [name or f"unnamed {index}" for index, name in enumerate(columns)]
            required = LABEL_COLUMNS[:2] if state_required else LABEL_COLUMNS[:1]
            missing = [name for name in required if name not in columns]
            if missing:
                raise BearingTwinError(f"{table}: no column {', '.join(missing)}; the header must read "
                                       f"{','.join(LABEL_COLUMNS)} ({', '.join(LABEL_COLUMNS[len(required):])} optional)")
            unknown = [name for name in columns if name and name not in LABEL_COLUMNS]  # (a trailing comma: no name)
            if unknown:  # a "speed" column would be passed over, and the files read at another speed
                raise BearingTwinError(f"{table}: column {unknown[0]!r} is not one of {', '.join(LABEL_COLUMNS)}")
            rows, bad_rows, seen = [], [], {}
            for row in reader:
                line = reader.line_num  # not a count of rows: the reader skips blank lines
                where = f"{table} line {line}"
                # Cells past the header's columns, or under a column it leaves unnamed: a speed written under a
                # header that names no rpm column would be passed over.
                beyond = [value for value in row.pop(None, None) or [] if value.strip()]
                beyond += [value for key, value in row.items() if key not in columns and (value or "").strip()]
                row = {key: (value or "").strip() for key, value in row.items() if key in columns}
                record = row["record"]
                try:
                    if Path(record) in seen:
                        raise BearingTwinError(f"{where}: record {record!r} is labelled again (line {seen[Path(record)]}); "
                                               "one row per record")
                    seen[Path(record)] = line  # a row that does not read still names its record
                    if beyond:
                        raise BearingTwinError(f"{where}: more values than the header has columns "
                                               f"({', '.join(name for name in columns if name)}); name every column in the header")
                    numbers = {key: _number_cell(row.get(key), key, semicolons, where) for key in ("rpm", "fs", "scale")}
                    state = row.get("state", "")  # no column, or an empty cell: unknown where that is allowed
                    unit = row.get("unit", "")
                    scale = _optional_number(numbers["scale"], "scale", "the unit given per unit of the file's samples",
                                             where)
                    if scale is not None and not unit:  # a product of no unit would be read in the file's
                        raise BearingTwinError(f"{where}: scale {scale:g} needs a unit in the row: the unit the "
                                               f"samples are in once multiplied by {scale:g} (g for a full scale in g)")
                    rows.append(LabelsRow(where, record, _state(state, where) if state or state_required else None,
                                          _optional_number(numbers["rpm"], "rpm", "rev/min", where),
                                          _optional_number(numbers["fs"], "fs", "Hz", where),
                                          known_unit(unit, f"{where}: unit", on_command_line=False) if unit else None,
                                          scale))
                except BearingTwinError as error:
                    bad_rows.append((record, str(error)))
    except (OSError, UnicodeDecodeError) as error:
        raise BearingTwinError(f"{table}: cannot read it ({error})") from None
    return rows, bad_rows


def read_labels(path: Path | None, state_required: bool = True) -> tuple[
        dict[str, LabelsRow], dict[str, list[tuple[str, str]]]]:
    """``stem -> row`` (:class:`LabelsRow`) from a labels table (``record,state[,rpm,fs,unit,scale]``; record: file name or
    stem; :func:`names_file` says which file a row is for), and ``stem -> [(record, message), ...]``, the rows of
    that stem that do not read (:func:`labels_table_with_bad_rows`, which ``state_required`` goes to): their
    records' errors, not the others'.

    Records are named by their stem here (an output folder, a summary row), so two rows of one stem (``rec.npz`` and
    ``rec``) label neither: both are that stem's bad rows."""
    rows, bad_rows = labels_table_with_bad_rows(path, state_required) if path is not None else ([], [])
    labels, lines = {}, {}
    for row in rows:
        stem = _record_stem(row.record)
        if stem in lines:
            message = (f"{row.where}: record {row.record!r} is labelled again ({lines[stem]} names {stem} too); one row "
                       "per record")
            bad_rows += [(labels.pop(stem).record, message)] if stem in labels else []
            bad_rows.append((row.record, message))
            continue
        labels[stem], lines[stem] = row, row.where
    refused: dict[str, list[tuple[str, str]]] = {}
    for record, message in bad_rows:  # a.npz's and a.npy's rows share the stem a: each kept, for its own file
        refused.setdefault(_record_stem(record), []).append((record, message))
    return labels, refused


def _record_stem(record: str) -> str:
    """The record name a labels row's ``record`` gives: its file name's stem (``a.npz``: ``a``), or the name itself
    where it has no recording's suffix (``run.2024``: ``run.2024``)."""
    name = PurePath(record).name
    return PurePath(name).stem if PurePath(name).suffix.lower() in FORMATS else name


def scale_and_unit_given(scale, unit, row: LabelsRow | None, command_first: bool) -> tuple:
    """A file's scale and unit, and whether its labels ``row`` gave them, beside the command's ``scale`` and ``unit``.
    The two come whole from one place, as a scale's unit is the product's and a unit without one the file's own: from
    the row where it gives a unit, unless the command gives either and comes first (``command_first``: it names the one
    file); else from the command (a row's unit alone is never multiplied by the command's scale, nor a row's scale
    paired with the command's unit)."""
    command_gives = scale is not None or unit is not None
    if row is not None and row.unit is not None and not (command_first and command_gives):
        return row.scale, row.unit, True
    return scale, unit, False


def labelled_file(root: Path, record: str, where: str) -> Path:
    """The file in ``root`` a labels row's ``record`` names: its file name, or its stem where it gives no recording's
    suffix and one recording has that stem (:func:`names_file`, as a diagnosis reads a row); ``where`` names the row."""
    path = root / record
    if record and path.is_file():
        return path
    named = sorted(candidate for candidate in path.parent.iterdir() if candidate.is_file()
                   and names_file(path.name, candidate) and candidate.suffix.lower() in FORMATS
                   ) if record and PurePath(record).name not in ("", ".", "..") and path.parent.is_dir() else []
    if len(named) > 1:
        raise BearingTwinError(f"{where}: record {record!r} names {', '.join(p.name for p in named)}; give the file name")
    if not named:
        raise BearingTwinError(f"{where}: record {record!r} is not a file in {root}")
    return named[0]


def names_file(record: str, path: Path) -> bool:
    """Whether a labels row's ``record`` is ``path``, a file beside the table: its file name, or its stem where
    the row gives no recording's suffix (a row for ``a.mat`` is not ``a.npy``'s; ``run.2024`` is ``run.2024.npy``'s).
    A row with a folder (``rig_a/x.npy``) names a file in that folder, not one beside the table."""
    row = PurePath(record)
    if row.parent != PurePath("."):
        return False
    return row.name == path.name or (row.suffix.lower() not in FORMATS and row.name == path.stem)


def labels_row(path: Path, state_required: bool = True) -> LabelsRow | None:
    """The row (:class:`LabelsRow`) of the ``labels.csv`` beside ``path`` that names it
    (:func:`names_file`); None when there is no such table or row. Its row alone is read: a bad row of
    another file is that file's concern, named in a warning, while a bad row of this one raises.
    ``state_required``: as :func:`labels_table_with_bad_rows` takes it."""
    table = path.parent / DEFAULT_LABELS
    if not table.is_file():
        return None
    rows, bad_rows = labels_table_with_bad_rows(table, state_required)
    its_own = [message for record, message in bad_rows if names_file(record, path)]
    if its_own:
        raise BearingTwinError(its_own[0])
    naming = [row for row in rows if names_file(row.record, path)]
    if len(naming) > 1:  # rec.npy and rec both name rec.npy
        raise BearingTwinError(f"{naming[1].where}: names {path.name} again ({naming[0].where} names it too); one row "
                               "per record")
    own = naming[0] if naming else None
    if bad_rows:
        log.warning("%s: %s; passed over rows of other files that do not read: %s", path.name,
                    f"read its row of {table}" if own else f"{table} has no row for it",
                    first_messages([message for _, message in bad_rows]))
    return own


def first_messages(messages: list[str], shown: int = 3) -> str:
    """The first ``shown`` of ``messages`` joined in one line, and how many more there are: a table of many bad
    rows is named, not printed whole."""
    more = len(messages) - shown
    return "; ".join(messages[:shown]) + (f"; and {more} more" if more > 0 else "")


NOT_LISTED = (".", "~$")
"""How the names of a folder's files that are no one's data begin: hidden files (macOS leaves ._<name> beside every
file it copies) and Excel's lock files (~$<name> beside a workbook open in Excel, a few bytes of its own format)."""


def recordings_in(folder: Path) -> list[Path]:
    """The files of a folder bearingtwin reads as recordings, sorted (:func:`recordings_and_others`)."""
    return recordings_and_others(folder)[0]


def recordings_and_others(folder: Path) -> tuple[list[Path], dict[str, str]]:
    """A folder's recordings, sorted by name, and why each of its other files is none (``name -> reason``): a format
    bearingtwin does not read, or a text table of something else or a note (:func:`why_not_a_recording`). The labels table and
    hidden and lock files (:data:`NOT_LISTED`) are neither."""
    recordings, others = [], {}
    for path in sorted(folder.iterdir()):
        if path.name.startswith(NOT_LISTED):
            continue
        if path.is_symlink() and not path.exists():
            others[path.name] = "a link to nothing (its target is gone, or it links back to itself)"
            continue
        if not path.is_file() or path.name == DEFAULT_LABELS:
            continue
        if path.suffix.lower() not in FORMATS:
            others[path.name] = f"not {', '.join(FORMATS)}"
            continue
        reason = why_not_a_recording(path)
        if reason is None:
            recordings.append(path)
        else:
            others[path.name] = reason
    return recordings, others


NOTE = "no row of numbers (notes, or a table of text), not samples"
"""Why a .txt or .tsv beside the recordings that holds no row of numbers is none: passed over even where a pattern
names it (``inner_notes.txt``)."""
ONE_VALUE = "one number (a setting or a stamp), not samples"
"""Why a text file beside the recordings that holds a single number is none (``seed.txt``, ``rate.txt``): passed
over even where a pattern names it (``inner_rate.csv``)."""


def why_not_a_recording(path: Path) -> str | None:
    """Why a file is a table of something other than samples (a labels table under another name, or a column of
    text: a log's notes, a results table's verdicts), so is passed over as no recording; None for a file that
    may be one (any other format, a table of numbers, one the reader will refuse naming why). A table with a
    time column is a recording whatever else it holds: its text column is then an error the reader names. A
    ``.txt`` or ``.tsv`` with no row of numbers (notes in words, a table of text, an empty file) is :data:`NOTE`;
    any text table holding a single number is :data:`ONE_VALUE`;
    a ``.csv`` is meant as a table, so one without numbers is left to its reader to say why."""
    suffix = path.suffix.lower()
    if suffix not in TEXT_TABLES:
        return None
    if holds_one_value(path):
        return ONE_VALUE
    note = suffix != ".csv" and is_a_note(path)
    text = text_column(path)
    if text is None:
        return NOTE if note else None
    if set(LABEL_COLUMNS[:2]) <= {name.strip().lower() for name in text.names}:  # in any case, as read
        return f"a labels table, columns {','.join(LABEL_COLUMNS[:2])}, not a recording"
    if any(time_column_seconds(name) is not None for name in text.names):
        return None
    if re.search(r"time|stamp", text.name, re.IGNORECASE):  # a logger's clock: a recording, its reader names the column
        return None
    return NOTE if note else f"its column {text.name!r} holds text ({text.cell!r}), not samples"


def warn_left_out(where: str | Path, others: dict[str, str]) -> None:
    """Name the files :func:`recordings_and_others` passes over, one line per reason: a user's export in a format not read
    here, or a table of notes beside the recordings, must not vanish without a word."""
    by_reason: dict[str, list[str]] = {}
    for name, reason in others.items():
        by_reason.setdefault(reason, []).append(name)
    for reason, names in by_reason.items():
        log.warning("%s: left out %s (%s)", where, ", ".join(names), reason)


def rows_from_pattern(root: Path, cfg: dict) -> list[LabelledFile]:
    """A :class:`LabelledFile` for every readable file in ``root``, the state from its name (its rpm, fs and unit
    the file's own, or the settings')."""
    if cfg.get("labels"):
        raise BearingTwinError("data.labels and data.pattern both set; label the files one way")
    try:
        pattern = re.compile(cfg["pattern"])
    except re.error as error:
        raise BearingTwinError(f"data.pattern={cfg['pattern']!r} is not a regular expression ({error})") from None
    if "state" not in pattern.groupindex:
        raise BearingTwinError(f"data.pattern={cfg['pattern']!r} has no (?P<state>...) group naming the bearing state")
    paths, others = recordings_and_others(root)
    for name, reason in others.items():  # a training set silently short of a record would be a wrong result
        # A table of notes, not a picture or a note in words (rig_notes.txt).
        if pattern.search(name) and Path(name).suffix.lower() in FORMATS and reason not in (NOTE, ONE_VALUE):
            raise BearingTwinError(f"{root / name}: data.pattern={cfg['pattern']!r} names it a recording, but it is "
                                   f"none ({reason}); mend it or move it out of data.root")
    warn_left_out(root, others)
    if not paths:
        raise BearingTwinError(f"data.root={root} holds no file bearingtwin reads ({', '.join(FORMATS)})")
    rows = []
    for path in paths:
        match = pattern.search(path.name)
        if match is None:
            raise BearingTwinError(f"{path}: data.pattern={cfg['pattern']!r} does not match its name; rename it or move it out of data.root")
        rows.append(LabelledFile(path, _state(match["state"], f"{path} (data.pattern)")))
    return rows


def _state(value: str, where: str) -> str:
    if value not in FAULTS:
        raise BearingTwinError(f"{where}: state {value!r} is not a bearing state; choose one of {', '.join(FAULTS)}")
    return value


def _number_cell(value: str | None, name: str, semicolons: bool, where: str) -> str | None:
    """A labels row's rpm, fs or scale cell as a number with a decimal point. A table of semicolons is a spreadsheet's
    with decimal commas, whose point groups thousands: ``12.000`` there is refused as reading two ways (12 Hz read
    for 12 kHz had been resampled and diagnosed), ``1797,5`` read as 1797.5."""
    if not (value and semicolons):
        return value
    if re.fullmatch(r"\d{1,3}(?:\.\d{3})+", value):
        raise BearingTwinError(f"{where}: {name} {value!r} reads two ways in a table of semicolons (a spreadsheet's with "
                               f"decimal commas): {float(value):g} or {int(value.replace('.', ''))}; write it without "
                               "the point")
    return value.replace(",", ".")


def _optional_number(value: str | None, name: str, unit: str, where: str) -> float | None:
    """A labels row's rpm, fs or scale: None where the cell is empty, else a positive number (:func:`positive_number`)."""
    return positive_number(value, name, unit, f"{where}: ") if value else None
