"""Labelled windows from real measurements: the CWRU and HUST data sets, and a folder of your
own recordings, as WindowedDatasets.

CWRU and HUST: each class is one record (one file); ``samples_per_class`` windows of
``window_length`` samples are spread evenly over it (``data.windows.cut_windows``), so the
stride follows the record length. Your own folder (``data=files``): any number of files per
state, ``windows_per_record`` windows from each, the state of each file from a labels table
or a file-name pattern (:func:`build_files_dataset`). Labels are indices into ``FAULTS`` whatever subset of classes is built, so a
three-class CWRU set at 1-3 hp (no healthy record there) still labels an inner-race window 1.
The split is not made here: ``data.windows.split_indices`` takes the dataset's ``labels``,
``record_ids``, ``starts`` and ``record_lengths`` with ``data.split`` and ``data.train_fraction``.
"""

from __future__ import annotations

from pathlib import Path, PurePath

import csv
import dataclasses
import logging
import re

import numpy as np

from bearingtwin.checks import positive_number, whole_number
from bearingtwin.config import load_bearing, plain_config
from bearingtwin.storage import content_key, file_digest
from bearingtwin.data.cwru import declared_fs_hz, load_cwru, parse_cwru_name
from bearingtwin.data.csv_file import holds_one_value, is_a_note, text_column
from bearingtwin.data.files import (FORMATS, SIMULATED_RATE, TEXT_TABLES, load_recording, speed_setting,
                                    time_column_seconds)
from bearingtwin.data.hust import CHANNELS as HUST_AXES, hust_file_name, load_hust, parse_hust_name
from bearingtwin.data.recording import Recording, WindowedDataset, warn_of_quality
from bearingtwin.data.units import acceleration_unit, convert_acceleration
from bearingtwin.data.windows import check_split, check_windows_fit, cut_windows
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS, BearingGeometry
from bearingtwin.signal.sampling_rate import require_plausible_rate

KEY_IGNORES = ("root", "split", "train_fraction")
"""Config fields that do not change the windows: moving the data or re-splitting keeps the key."""


def build_cwru_dataset(data_cfg, data_root: str | Path | None = None) -> WindowedDataset:
    """Windows of the CWRU records at ``data.load`` hp, one record per class in ``data.classes``.

    ``data_root`` is the folder holding the .mat files (default: ``data.root``).
    """
    cfg = plain_config(data_cfg, "data config")
    window_length, samples_per_class = check_windowing(cfg)
    paths = cwru_paths(cfg, data_root)
    bearing = load_bearing(cfg["bearing"], "data.bearing") if cfg.get("bearing") else None  # the rate check's second witness
    recordings = []
    for path in paths:
        recordings.append(
            load_cwru(
                path,
                channel=_get(cfg, "channel"),
                fs=declared_fs_hz(path, _get(cfg, "fs"), cfg.get("fs_by_record")),
                check_fs=bool(_get(cfg, "check_fs")),
                tolerance=float(_get(cfg, "fs_check_tolerance")),
                bearing=bearing,
            )
        )
    return windows_from_recordings(recordings, window_length, samples_per_class, "data.samples_per_class",
                                   dataset_key(paths, cfg))


def cwru_paths(data_cfg, data_root: str | Path | None = None) -> list[Path]:
    """The record each class of a CWRU data config reads (FAULTS order), found in ``data.root``
    (or ``data_root``); raises naming the folder or the class whose record is not there."""
    cfg = plain_config(data_cfg, "data config")
    root = Path(data_root if data_root is not None else _get(cfg, "root"))
    load = _get(cfg, "load")
    if load not in (0, 1, 2, 3):
        raise BearingTwinError(f"data.load={load!r} is not a CWRU motor load; choose 0, 1, 2 or 3 (hp)")
    stems = _get(cfg, "files")
    return [_find_cwru_file(root, stems, fault, load) for fault in _classes(cfg["classes"], allowed=stems)]


def build_hust_dataset(data_cfg) -> WindowedDataset:
    """Windows of the HUST files of ``data.classes`` at ``data.condition`` (the paper's Table 5 set)."""
    cfg = plain_config(data_cfg, "data config")
    window_length, samples_per_class, files = check_hust_settings(cfg)
    paths = list(files.values())
    root, names = Path(_get(cfg, "root")), [path.name for path in paths]
    missing = [path.name for path in paths if not path.is_file()]
    if missing:
        raise BearingTwinError(
            f"HUST files missing in {root}: {', '.join(missing)}. This data set needs {', '.join(names)} "
            f"(from the HUST bearing data set); put them in one folder and pass data.root=<dir>"
        )
    recordings = [load_hust(path, channel=_get(cfg, "channel"), fs=_get(cfg, "fs"), channel_key="data.channel",
                            fs_key="data.fs") for path in paths]
    return windows_from_recordings(recordings, window_length, samples_per_class, "data.samples_per_class",
                                   dataset_key(paths, cfg))


def hust_paths(data_cfg) -> dict[str, Path]:
    """The file each class of a HUST data config reads (FAULTS order), known without reading any,
    so that a sweep can check them all before it starts; a class whose file name states another state is refused."""
    cfg = plain_config(data_cfg, "data config")
    root, stems = Path(_get(cfg, "root")), _get(cfg, "classes")
    if root.is_file():
        raise BearingTwinError(f"data.root={root} is a file; point it at the folder of the HUST files")
    paths = {fault: root / hust_file_name(stems[fault], _get(cfg, "condition"))
             for fault in _classes(list(stems), allowed=FAULTS)}
    for fault, path in paths.items():
        named = parse_hust_name(path)
        if named is None or named.fault != fault:
            stated = "no state" if named is None else (named.fault or "inner and outer races combined")
            raise BearingTwinError(f"data.classes.{fault}={stems[fault]!r} names {path.name}, whose name states {stated}")
    return paths


def check_hust_settings(data_cfg) -> tuple[int, int, dict[str, Path]]:
    """A HUST config's window length, windows per class and each class's file, checked as :func:`check_windowing`
    with its axis (X, Y or Z), condition and classes, before any file is read or run opened."""
    cfg = plain_config(data_cfg, "data config")
    window_length, samples_per_class = check_windowing(cfg)
    if _get(cfg, "channel") not in HUST_AXES:
        raise BearingTwinError(f"data.channel={cfg['channel']!r} is not a HUST accelerometer axis; choose one of "
                               f"{', '.join(HUST_AXES)}")
    return window_length, samples_per_class, hust_paths(cfg)


log = logging.getLogger(__name__)

LABEL_COLUMNS = ("record", "state", "rpm", "fs")
"""Columns of a labels table: ``record`` (file name in ``data.root``) and ``state`` are required (a diagnosis may
leave the state out: :func:`labels_table_with_bad_rows`)."""
DEFAULT_LABELS = "labels.csv"
"""The labels table ``data=files`` reads from ``data.root`` unless ``data.labels`` names another."""


def build_files_dataset(data_cfg) -> WindowedDataset:
    """Windows of every labelled recording in ``data.root``: the user's own data, checked as CWRU's.

    The state of each file comes from the labels table ``data.labels`` (default
    ``<root>/labels.csv``: columns ``record,state[,rpm,fs]``, one row per file) or, when
    ``data.pattern`` is set, from the regular expression's ``state`` group matched on every
    readable file's name. ``rpm`` and ``fs`` fill in what a file does not state (a row's value
    before ``data.rpm`` / ``data.fs``); a value the file contradicts is an error.
    """
    cfg = plain_config(data_cfg, "data config")
    window_length, windows_per_record, default_rpm, default_fs = check_files_settings(cfg)
    root = Path(_get(cfg, "root")).expanduser()
    if not root.is_dir():
        raise BearingTwinError(f"data.root={root} is not a folder; point it at the folder of your recordings")
    rows = _rows_from_pattern(root, cfg) if cfg.get("pattern") else rows_from_labels(root, cfg)
    recordings = [
        load_recording(path, channel=cfg.get("channel"), fault=state,
                       rpm=rpm if rpm is not None else default_rpm, fs=fs if fs is not None else default_fs,
                       channel_key="data.channel", fs_key="data.fs" if fs is None else "the labels row's fs",
                       fault_key="data.pattern's state" if cfg.get("pattern") else "the labels row's state",
                       rpm_key="data.rpm" if rpm is None else "the labels row's rpm")
        for path, state, rpm, fs in rows
    ]
    named = None if cfg.get("bearing") else bearing_the_files_name(recordings)
    if bool(_get(cfg, "check_fs")):
        bearing_name = cfg.get("bearing") or named
        bearing = load_bearing(bearing_name, "data.bearing") if bearing_name else None
        for recording, (_, _, row_rpm, row_fs) in zip(recordings, rows):
            check_stated_rate(recording, "data.fs" if row_fs is None else "the labels row's fs", "data.check_fs", bearing,
                              rpm_key="data.rpm" if row_rpm is None else "the labels row's rpm")
    labelling = [(path.name, state, rpm, fs) for path, state, rpm, fs in rows]
    # What only checks the records (check_fs, the bearing whose lines witness a rate) leaves the windows alone.
    windowed = {key: value for key, value in cfg.items() if key not in ("check_fs", "bearing")}
    dataset = windows_from_recordings(
        recordings, window_length, windows_per_record, "data.windows_per_record",
        dataset_key([path for path, *_ in rows], {**windowed, "labels": labelling, "pattern": None}),
    )
    return dataclasses.replace(dataset, bearing=named)


def bearing_the_files_name(recordings: list[Recording]) -> str | None:
    """The ``conf/bearing`` name every recording names itself (a HUST export's ER-16K, a CWRU fan-end record's SKF
    6203, ``bearingtwin-simulate``'s), read where no ``data.bearing`` is given; None where one names none, or names
    one no config describes, or where they name different bearings (said: one model reads one bearing's lines)."""
    from bearingtwin.config import unknown_bearing_note

    named = {recording.meta.get("bearing") for recording in recordings}
    if None in named or not named:
        return None
    if len(named) > 1:
        log.warning("the files name different bearings (%s): the data's bearing is the config's; give "
                    "data.bearing=<name> for the one the model is for", ", ".join(sorted(map(str, named))))
        return None
    name = str(named.pop())
    unknown = unknown_bearing_note(name, "the data's bearing is the config's")
    if unknown:
        log.warning("data.root: %s", unknown)
        return None
    return name


def check_stated_rate(recording: Recording, fs_key: str, check_key: str, bearing: BearingGeometry | None = None,
                      rpm_key: str | None = None) -> None:
    """The rate a setting or a labels row gave a record, checked against its shaft line as a CWRU record's declared
    one is: refused where the shaft series contradicts it (``fs_key`` named as its source, and ``rpm_key`` where
    that setting gave the speed, not the file); one the file itself
    records (a time column, a header, an .npz's fs) only logged (one data.rpm for a folder: a record whose half orders
    read as half its speed would stop the training); unchecked without a speed. Without the
    record's ``bearing`` a fault record's contradiction is only logged: its defect comb can stand where the
    shaft series is looked for, and only the bearing's defect lines tell the two apart."""
    if recording.rpm is None or recording.meta.get("fs_origin") == SIMULATED_RATE:  # exact, and no shaft line to read
        return
    given = recording.meta.get("fs_origin") in ("config", "declared")
    require_plausible_rate(recording.signal, recording.fs, recording.rpm, recording.source, fs_key,
                           defect_hz=bearing.defect_frequencies(recording.rpm) if bearing is not None else None,
                           refuse=given and (bearing is not None or recording.fault == "normal"), check_key=check_key,
                           rpm_key=speed_setting(recording, rpm_key) if rpm_key else None)


def rows_from_labels(root: Path, cfg: dict, alternative: str = " or give data.pattern=<regex with a (?P<state>...) group>",
                     warn_unlisted: bool = True) -> list[tuple[Path, str, float | None, float | None]]:
    """``(file, state, rpm, fs)`` per row of the labels table ``data.labels`` (default ``<root>/labels.csv``);
    ``alternative`` ends the message when there is no such table; ``warn_unlisted``: say which recordings of
    ``root`` the table leaves out (where the data is built, not in the checks before it)."""
    table = labels_path(root, cfg)
    if not table.is_file():
        raise BearingTwinError(
            f"data.labels: no labels file {table}; write one with columns {','.join(LABEL_COLUMNS)} "
            f"(one row per file){alternative}"
        )
    rows, labelled_at = [], {}
    for where, record, state, rpm, fs in labels_table(table):
        path = labelled_file(root, record, where)
        same = path.resolve()  # a stem and its file's name (or rig/../x and x): one record named twice
        if same in labelled_at:
            raise BearingTwinError(f"{where}: record {record!r} is labelled again ({labelled_at[same]} names "
                                   f"{path.name} too); one row per record")
        labelled_at[same] = where
        rows.append((path, state, rpm, fs))
    if not rows:
        raise BearingTwinError(f"{table}: lists no recordings")
    recordings, others = recordings_and_others(root)
    unlisted = sorted(set(recordings) - {path for path, *_ in rows} - {table})
    if warn_unlisted:
        if unlisted:
            log.warning("%s: %s not labelled in %s, left out", root, ", ".join(path.name for path in unlisted), table.name)
        warn_left_out(root, {name: reason for name, reason in others.items()
                             if root / name not in {path for path, *_ in rows} and root / name != table})
    return rows


def labels_path(root: Path, cfg: dict) -> Path:
    """The labels table a folder of recordings is read with: ``data.labels``, else ``<root>/labels.csv``."""
    return Path(str(cfg.get("labels") or root / DEFAULT_LABELS)).expanduser()


def labels_table(table: Path) -> list[tuple[str, str, str, float | None, float | None]]:
    """``(where, record, state, rpm, fs)`` per row of a labels table (columns ``record,state[,rpm,fs]``);
    ``where`` is the file and line, for messages. A bad header raises, and so does a bad row (naming its line and
    field): what reads every row, a training set, would otherwise be built without that record."""
    rows, bad_rows = labels_table_with_bad_rows(table)
    if bad_rows:
        raise BearingTwinError(bad_rows[0][1])
    return rows


def labels_table_with_bad_rows(table: Path, state_required: bool = True) -> tuple[
        list[tuple[str, str, str | None, float | None, float | None]], list[tuple[str, str]]]:
    """The rows of a labels table that read, as :func:`labels_table` gives them, and ``(record, message)`` for
    each that does not (more values than the header has columns, a record labelled again, a state that is no
    bearing state, an rpm or fs that is no positive number), in the table's order: a bad row is its record's
    concern alone where a command reads one file's row, or each file of a folder its own. A table that cannot be
    read, or whose header is wrong, raises: none of its rows can be read.

    ``state_required=False`` (a diagnosis, where a fleet's states are what is asked): the ``state`` column may be
    left out and its cells left empty, such a row's state None (unknown) and its rpm and fs read all the same; a
    state given must still be a bearing state. Training keeps it required: there the state is the label."""
    try:
        with open(table, newline="", encoding="utf-8-sig") as handle:  # -sig: a spreadsheet's byte-order mark
            header = handle.readline()
            handle.seek(0)
            # A spreadsheet set to a decimal comma separates its columns with semicolons (the table holds no decimals
            # beside rpm and fs, which such a spreadsheet writes with commas too).
            semicolons = ";" in header and "," not in header
            reader = csv.DictReader(handle, delimiter=";" if semicolons else ",")
            # Record,State,RPM,Fs as a spreadsheet capitalizes them: the same columns.
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
                    numbers = {key: (row.get(key) or "").replace(",", ".") if semicolons else row.get(key)
                               for key in ("rpm", "fs")}
                    state = row.get("state", "")  # no column, or an empty cell: unknown where that is allowed
                    rows.append((where, record, _state(state, where) if state or state_required else None,
                                 _optional_number(numbers["rpm"], "rpm", "rev/min", where),
                                 _optional_number(numbers["fs"], "fs", "Hz", where)))
                except BearingTwinError as error:
                    bad_rows.append((record, str(error)))
    except (OSError, UnicodeDecodeError) as error:
        raise BearingTwinError(f"{table}: cannot read it ({error})") from None
    return rows, bad_rows


def read_labels(path: Path | None, state_required: bool = True) -> tuple[
        dict[str, tuple[str, str | None, float | None, float | None]], dict[str, list[tuple[str, str]]]]:
    """``stem -> (record, state, rpm, fs)`` from a labels table (``record,state[,rpm,fs]``; record: file name or
    stem; :func:`names_file` says which file a row is for), and ``stem -> [(record, message), ...]``, the rows of
    that stem that do not read (:func:`labels_table_with_bad_rows`, which ``state_required`` goes to): their
    records' errors, not the others'.

    Records are named by their stem here (an output folder, a summary row), so two rows of one stem (``rec.npz`` and
    ``rec``) label neither: both are that stem's bad rows."""
    rows, bad_rows = labels_table_with_bad_rows(path, state_required) if path is not None else ([], [])
    labels, lines = {}, {}
    for where, record, state, rpm, fs in rows:
        stem = _record_stem(record)
        if stem in lines:
            message = f"{where}: record {record!r} is labelled again ({lines[stem]} names {stem} too); one row per record"
            bad_rows += [(labels.pop(stem)[0], message)] if stem in labels else []
            bad_rows.append((record, message))
            continue
        labels[stem], lines[stem] = (record, state, rpm, fs), where
    refused: dict[str, list[tuple[str, str]]] = {}
    for record, message in bad_rows:  # a.npz's and a.npy's rows share the stem a: each kept, for its own file
        refused.setdefault(_record_stem(record), []).append((record, message))
    return labels, refused


def _record_stem(record: str) -> str:
    """The record name a labels row's ``record`` gives: its file name's stem (``a.npz``: ``a``), or the name itself
    where it has no recording's suffix (``run.2024``: ``run.2024``)."""
    name = PurePath(record).name
    return PurePath(name).stem if PurePath(name).suffix.lower() in FORMATS else name


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


def labels_row(path: Path, state_required: bool = True) -> tuple[str, str | None, float | None, float | None] | None:
    """``(where, state, rpm, fs)`` of the row of the ``labels.csv`` beside ``path`` that names it
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
    naming = [(where, state, rpm, fs) for where, record, state, rpm, fs in rows if names_file(record, path)]
    if len(naming) > 1:  # rec.npy and rec both name rec.npy
        raise BearingTwinError(f"{naming[1][0]}: names {path.name} again ({naming[0][0]} names it too); one row per record")
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


def recordings_in(folder: Path) -> list[Path]:
    """The files of a folder bearingtwin reads as recordings, sorted (:func:`recordings_and_others`)."""
    return recordings_and_others(folder)[0]


def recordings_and_others(folder: Path) -> tuple[list[Path], dict[str, str]]:
    """A folder's recordings, sorted by name, and why each of its other files is none (``name -> reason``): a format
    bearingtwin does not read, or a text table of something else or a note (:func:`why_not_a_recording`). The labels table and
    hidden files (a name starting with '.') are neither."""
    recordings, others = [], {}
    for path in sorted(folder.iterdir()):
        if not path.is_file() or path.name == DEFAULT_LABELS or path.name.startswith("."):  # ._x.npy: macOS metadata
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


def _rows_from_pattern(root: Path, cfg: dict) -> list[tuple[Path, str, None, None]]:
    """``(file, state, None, None)`` for every readable file in ``root``, the state from its name."""
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
        rows.append((path, _state(match["state"], f"{path} (data.pattern)"), None, None))
    return rows


def _state(value: str, where: str) -> str:
    if value not in FAULTS:
        raise BearingTwinError(f"{where}: state {value!r} is not a bearing state; choose one of {', '.join(FAULTS)}")
    return value


def _optional_setting(cfg: dict, name: str, unit: str) -> float | None:
    """``data.<name>`` (rpm, fs): None when unset, else a positive number, checked before any file is read."""
    return None if cfg.get(name) is None else positive_number(cfg[name], f"data.{name}", unit)


def _optional_number(value: str | None, name: str, unit: str, where: str) -> float | None:
    """A labels row's rpm or fs: None where the cell is empty, else a positive number (:func:`positive_number`)."""
    return positive_number(value, name, unit, f"{where}: ") if value else None


def windows_from_recordings(
    recordings: list[Recording], window_length: int, windows_per_record: int, count_key: str, key: str
) -> WindowedDataset:
    """Cut the same number of windows from every recording; labels are FAULTS indices. ``count_key`` is the
    setting ``windows_per_record`` comes from, as messages name it."""
    rates = {recording.fs for recording in recordings}
    if len(rates) != 1:
        listing = ", ".join(f"{Path(r.source).name}: {r.fs:g} Hz" for r in recordings)
        raise BearingTwinError(f"the records have different sampling rates ({listing}); windows would span different times")
    for recording in recordings:
        if recording.signal.size < window_length:
            raise BearingTwinError(
                f"{recording.source}: {recording.signal.size} samples, shorter than one window of {window_length}"
            )
    check_windows_fit(len(recordings), window_length, windows_per_record, count_key)
    warn_of_quality(recordings)
    converted, unit = in_one_unit(recordings)
    if converted is not recordings:  # other windows than the files' own numbers: another key (and feature cache)
        log.info("the records state %s: each converted to %s", ", ".join(sorted({r.unit for r in recordings})), unit)
        recordings, key = converted, content_key({"records": key, "unit": unit})
    windows, labels, record_ids, starts, lengths = [], [], [], [], []
    for index, recording in enumerate(recordings):
        cut, first = cut_windows(recording.signal, window_length, windows_per_record)
        windows.append(cut)
        starts.append(first)
        labels.append(np.full(len(cut), recording.label))
        record_ids.append(np.full(len(cut), index))
        lengths.append(recording.signal.size)
    return WindowedDataset(
        windows=np.concatenate(windows),
        labels=np.concatenate(labels),
        record_ids=np.concatenate(record_ids),
        starts=np.concatenate(starts),
        records=[recording.source for recording in recordings],
        fs=rates.pop(),
        class_names=FAULTS,
        key=key,
        record_lengths=lengths,
        # Shaft speeds when every record states one (CWRU): features on the shaft-order axis need them.
        record_rpms=None if any(r.rpm is None for r in recordings) else [float(r.rpm) for r in recordings],
        unit=unit,
    )


def in_one_unit(recordings: list[Recording]) -> tuple[list[Recording], str]:
    """The recordings in one unit, and its name: the one they share ("" when none states one); m/s^2 when they
    state different acceleration units (g and m/s^2, mg, ...). Records stating different units of which one is no
    acceleration unit (V beside g) are refused: their windows would differ in level by a factor nothing converts."""
    units = {acceleration_unit(recording.unit) for recording in recordings}
    if None in units:
        stated = {recording.unit for recording in recordings}
        first = {}
        for recording in recordings:
            first.setdefault(recording.unit, Path(recording.source).name)
        if "" in stated and len(stated) > 1:  # 9.81 apart (g beside m/s^2) or not: nothing tells
            other = next(iter(stated - {""}))
            raise BearingTwinError(f"{first['']} states no unit, {first[other]} states {other}: state every record's "
                                   "unit (a CSV header such as 'acc (g)', an .npz's 'unit' entry), or none")
        if len(stated) > 1:
            raise BearingTwinError("the records state units not converted into one another (" + ", ".join(
                f"{unit}: {name}" for unit, name in first.items()) + "); only acceleration units (g, m/s^2, "
                "mg, mm/s^2, ...) are converted: give the records all in those, or all in one unit")
        return recordings, stated.pop()
    if len(units) == 1:
        return recordings, units.pop()
    return [dataclasses.replace(recording, signal=convert_acceleration(recording.signal, recording.unit, "m/s^2"),
                                unit="m/s^2") for recording in recordings], "m/s^2"


def dataset_key(paths: list[Path], cfg: dict) -> str:
    """Hash of the files' names and contents and of the config fields that shape the windows.

    Contents, not sizes or paths: recordings of one length in another folder, or a file written
    over, are other data (a size alone let their cached features be reused); the same files
    copied elsewhere are the same data."""
    content = {
        "files": [(Path(path).name, file_digest(Path(path))) for path in paths],
        "config": {name: value for name, value in cfg.items() if name not in KEY_IGNORES},
    }
    return content_key(content)


def _find_cwru_file(root: Path, stems: dict, fault: str, load: int) -> Path:
    if not root.is_dir():
        raise BearingTwinError(f"data.root={root} is not a folder; point it at the CWRU .mat files")
    matches = sorted(
        path
        for path in root.glob("*.mat")
        if path.stem.startswith(f"{stems[fault]}_{load}_") and parse_cwru_name(path) is not None
    )
    if len(matches) == 1:
        return matches[0]
    if matches:
        raise BearingTwinError(f"{root}: several {fault} records at {load} hp: {', '.join(p.name for p in matches)}")
    if fault == "normal" and load != 0:
        raise BearingTwinError(
            f"{root}: no healthy record at {load} hp (the CWRU files here have one only at 0 hp); "
            "build the three fault classes with data.classes=[inner,ball,outer]"
        )
    raise BearingTwinError(f"{root}: no file {stems[fault]}_{load}_<record>.mat for class {fault}")


def _classes(classes, allowed) -> list[str]:
    classes = list(classes)
    for name in classes:
        if name not in FAULTS or name not in allowed:
            raise BearingTwinError(f"data.classes: {name!r} is not a class here; choose from {', '.join(allowed)}")
    if len(set(classes)) != len(classes) or not classes:
        raise BearingTwinError(f"data.classes must list distinct classes, got {classes}")
    return sorted(classes, key=FAULTS.index)


def check_windowing(data_cfg, count: str = "samples_per_class") -> tuple[int, int]:
    """A real-data config's ``data.window_length`` and windows per record (``data.<count>``), after checking
    ``data.split`` and ``data.train_fraction``: values refused before any file is read or run opened."""
    cfg = plain_config(data_cfg, "data config")
    check_split(_get(cfg, "split"), _get(cfg, "train_fraction"))
    return whole_number("data.window_length", _get(cfg, "window_length")), whole_number(f"data.{count}", _get(cfg, count))


def check_files_settings(data_cfg) -> tuple[int, int, float | None, float | None]:
    """A ``data=files`` config's window length, windows per record, and the rpm and rate (None: unset) that fill
    in what a file does not state; checked as :func:`check_windowing`."""
    cfg = plain_config(data_cfg, "data config")
    return (*check_windowing(cfg, "windows_per_record"),
            _optional_setting(cfg, "rpm", "rev/min"), _optional_setting(cfg, "fs", "Hz"))


def _get(cfg: dict, name: str):
    if name not in cfg or cfg[name] is None:
        raise BearingTwinError(f"data.{name} is missing")
    return cfg[name]


