"""Labelled windows from real measurements: the CWRU and HUST data sets, and a folder of your
own recordings, as WindowedDatasets.

CWRU and HUST: each class is one record (one file); ``samples_per_class`` windows of
``window_length`` samples are spread evenly over it (``data.windows.cut_windows``), so the
stride follows the record length. Your own folder (``data=files``): any number of files per
state, ``windows_per_record`` windows from each, the state of each file from a labels table
or a file-name pattern (:func:`build_files_dataset`; the table and pattern: :mod:`bearingtwin.data.labels`). Labels are indices into ``FAULTS`` whatever subset of classes is built, so a
three-class CWRU set at 1-3 hp (no healthy record there) still labels an inner-race window 1.
The split is not made here: ``data.windows.split_indices`` takes the dataset's ``labels``,
``record_ids``, ``starts`` and ``record_lengths`` with ``data.split`` and ``data.train_fraction``.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np

from bearingtwin.checks import positive_number, whole_number
from bearingtwin.config import load_bearing, plain_config
from bearingtwin.storage import content_key, file_digest
from bearingtwin.data.cwru import declared_fs_hz, load_cwru, parse_cwru_name
from bearingtwin.data.formats import SIMULATED_RATE, file_bearing, load_recording, speed_setting
from bearingtwin.data.hust import CHANNELS as HUST_AXES, HustName, hust_file_name, load_hust, parse_hust_name
from bearingtwin.data.labels import first_messages, rows_from_labels, rows_from_pattern
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
        held = hust_folder_holds(root)
        raise BearingTwinError(
            f"HUST files missing in {root}: {', '.join(missing)}{f'; {held}' if held else ''}. This data set needs "
            f"{', '.join(names)} (from the HUST bearing data set); put them in one folder and pass data.root=<dir>"
        )
    recordings = [load_hust(path, channel=_get(cfg, "channel"), fs=_get(cfg, "fs"), channel_key="data.channel",
                            fs_key="data.fs") for path in paths]
    for recording in recordings:  # how each file was read (its columns by position, its rate unchecked ...), as CWRU's
        for note in [*recording.meta.get("notes", []), *filter(None, [recording.meta.get("no_speed")])]:
            log.warning("%s: %s", recording.source, note)
    return windows_from_recordings(recordings, window_length, samples_per_class, "data.samples_per_class",
                                   dataset_key(paths, cfg))


def hust_paths(data_cfg) -> dict[str, Path]:
    """The file each class of a HUST data config reads (FAULTS order), known without reading any,
    so that a sweep can check them all before it starts; a class whose file name states another state is refused."""
    cfg = plain_config(data_cfg, "data config")
    root, stems = Path(_get(cfg, "root")), _get(cfg, "classes")
    if root.is_file():
        raise BearingTwinError(f"data.root={root} is a file; point it at the folder of the HUST files")
    paths = {fault: _in_any_case(root, hust_file_name(stems[fault], _get(cfg, "condition")))
             for fault in _classes(list(stems), allowed=FAULTS)}
    for fault, path in paths.items():
        named = parse_hust_name(path)
        if named is None or named.fault != fault:
            stated = "no state" if named is None else (named.fault or "inner and outer races combined")
            raise BearingTwinError(f"data.classes.{fault}={stems[fault]!r} names {path.name}, whose name states {stated}")
    return paths


def hust_folder_holds(root: Path) -> str:
    """What a folder short of a condition's HUST files holds, as a refusal says it: the conditions its HUST files
    are at (``/data holds HUST files for data.condition=60, 65, VS_0_40_0``), or, holding none, the subfolders
    one level down that hold some (an archive unpacked into a folder of its own); "" where it holds neither."""
    if not root.is_dir():
        return ""
    here = _hust_names(root)
    if here:
        conditions = sorted({(name.shaft_hz is None, name.shaft_hz or 0.0, name.condition.removesuffix("Hz"))
                             for name in here})  # by speed, the variable-speed run last
        return f"{root} holds HUST files for data.condition={', '.join(condition for *_, condition in conditions)}"
    below = sorted(folder.name for folder in root.iterdir() if folder.is_dir() and _hust_names(folder))
    if len(below) == 1:
        return f"{root} holds no HUST file, but its subfolder {below[0]} does: data.root={root / below[0]}"
    return f"{root} holds no HUST file, but its subfolders {', '.join(below)} do" if below else ""


def _hust_names(folder: Path) -> list[HustName]:
    """What the names of a folder's HUST files say (:func:`~bearingtwin.data.hust.parse_hust_name`); none for a folder
    that cannot be listed (lost+found at a mount's root)."""
    try:
        paths = list(folder.iterdir())
    except OSError:
        return []
    return [name for path in paths if path.suffix.lower() == ".xls" and path.is_file()
            and (name := parse_hust_name(path)) is not None]


def _in_any_case(root: Path, name: str) -> Path:
    """The file of ``root`` named ``name`` in any letter case (``h_65hz.xls``: a copy through another operating
    system or archive may change the case); ``root / name`` where there is none. Two such files (``H_65Hz.xls``
    beside ``h_65hz.xls``) are refused: which one the data set means, nothing tells."""
    if not root.is_dir():
        return root / name
    same = sorted(other.name for other in root.iterdir() if other.name.lower() == name.lower() and other.is_file())
    if len(same) > 1:
        raise BearingTwinError(f"{root}: {len(same)} files are {name} in one letter case or another "
                               f"({', '.join(same)}); keep one of them in the folder")
    return root / (same[0] if same else name)


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

def build_files_dataset(data_cfg) -> WindowedDataset:
    """Windows of every labelled recording in ``data.root``: the user's own data, checked as CWRU's.

    The state of each file comes from the labels table ``data.labels`` (default
    ``<root>/labels.csv``: columns ``record,state[,rpm,fs,unit,scale]``, one row per file) or, when
    ``data.pattern`` is set, from the regular expression's ``state`` group matched on every
    readable file's name. ``rpm``, ``fs`` and ``unit`` fill in what a file does not state, ``scale`` multiplying its
    samples first (a row's rpm and fs
    before ``data.rpm`` / ``data.fs``); a value the file contradicts is an error (a speed the record itself bears out
    against the file's excepted: :func:`~bearingtwin.data.formats.resolve_speed`).
    """
    cfg = plain_config(data_cfg, "data config")
    window_length, windows_per_record, default_rpm, default_fs = check_files_settings(cfg)
    root = Path(_get(cfg, "root")).expanduser()
    if not root.is_dir():
        raise BearingTwinError(f"data.root={root} is not a folder; point it at the folder of your recordings")
    rows = rows_from_pattern(root, cfg) if cfg.get("pattern") else rows_from_labels(root, cfg)
    recordings = every_file_or_refused(rows, lambda row: load_recording(
        row.path, channel=cfg.get("channel"), fault=row.state,
        rpm=row.rpm if row.rpm is not None else default_rpm, fs=row.fs if row.fs is not None else default_fs,
        channel_key="data.channel", fs_key="data.fs" if row.fs is None else "the labels row's fs",
        fault_key="data.pattern's state" if cfg.get("pattern") else "the labels row's state",
        rpm_key="data.rpm" if row.rpm is None else "the labels row's rpm", **row.unit_settings()))
    named = None if cfg.get("bearing") else bearing_the_files_name(recordings)
    if bool(_get(cfg, "check_fs")):
        bearing_name = cfg.get("bearing") or named
        bearing = load_bearing(bearing_name, "data.bearing") if bearing_name else None
        every_file_or_refused(list(zip(recordings, rows)), lambda pair: check_stated_rate(
            pair[0], "data.fs" if pair[1].fs is None else "the labels row's fs", "data.check_fs", bearing,
            rpm_key="data.rpm" if pair[1].rpm is None else "the labels row's rpm"))
    labelling = [(row.path.name, *row.key_facts()) for row in rows]
    # What only checks the records (check_fs, the bearing whose lines witness a rate) leaves the windows alone.
    windowed = {key: value for key, value in cfg.items() if key not in ("check_fs", "bearing")}
    dataset = windows_from_recordings(
        recordings, window_length, windows_per_record, "data.windows_per_record",
        dataset_key([row.path for row in rows], {**windowed, "labels": labelling, "pattern": None}),
    )
    return dataclasses.replace(dataset, bearing=named)


def every_file_or_refused(items: list, read) -> list:
    """``read(item)`` of every item (a labels row, a recording), or one refusal naming each that failed (the first
    three messages and a count): a folder with three bad files is mended in one pass, not three runs."""
    done, refusals = [], []
    for item in items:
        try:
            done.append(read(item))
        except BearingTwinError as error:
            refusals.append(str(error))
    if len(refusals) == 1:
        raise BearingTwinError(refusals[0])
    if refusals:
        raise BearingTwinError(f"{len(refusals)} of {len(items)} files refused: {first_messages(refusals)}")
    return done


def bearing_the_files_name(recordings: list[Recording]) -> str | None:
    """The ``conf/bearing`` name every recording names itself (:func:`~bearingtwin.data.formats.file_bearing`: a HUST
    export's ER-16K, a CWRU record's SKF 6205 or 6203, ``bearingtwin-simulate``'s), read where no ``data.bearing`` is
    given; None where one names none, or where they name different bearings (said: one model reads one bearing's
    lines); refused where they name one no config describes."""
    from bearingtwin.config import refuse_unknown_bearing

    named = {file_bearing(recording.meta, recording.channel) for recording in recordings}
    if None in named or not named:
        return None
    if len(named) > 1:
        log.warning("the files name different bearings (%s): the data's bearing is the config's; give "
                    "data.bearing=<name> for the one the model is for", ", ".join(sorted(map(str, named))))
        return None
    name = str(named.pop())
    refuse_unknown_bearing(name, "data.root", "data.bearing")
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


def windows_from_recordings(
    recordings: list[Recording], window_length: int, windows_per_record: int, count_key: str, key: str
) -> WindowedDataset:
    """Cut the same number of windows from every recording; labels are FAULTS indices. ``count_key`` is the
    setting ``windows_per_record`` comes from, as messages name it."""
    rates = {recording.fs for recording in recordings}
    if len(rates) != 1:
        listing = ", ".join(f"{Path(r.source).name}: {r.fs:g} Hz" for r in recordings)
        raise BearingTwinError(f"the records have different sampling rates ({listing}); windows would span different times")
    shortest = min(recordings, key=lambda recording: recording.signal.size)
    size = shortest.signal.size
    # The longest window of which the record holds windows_per_record that differ by at least one sample's start.
    distinct_length = size - windows_per_record + 1
    if size < window_length:
        remedy = (f"data.window_length={distinct_length} or less gives {count_key}={windows_per_record} distinct windows"
                  if distinct_length >= 1 else f"a data.window_length well below {size} and fewer windows ({count_key})")
        raise BearingTwinError(f"{shortest.source}: {size} samples, shorter than one window of "
                               f"data.window_length={window_length}; {remedy}")
    distinct = size - window_length + 1
    if distinct < windows_per_record:
        log.warning("%s (the shortest record): %d samples hold %d distinct window%s of data.window_length=%d, fewer "
                    "than %s=%d: some windows repeat (a shorter data.window_length or a lower %s avoids it)",
                    shortest.source, size, distinct, "" if distinct == 1 else "s", window_length, count_key,
                    windows_per_record, count_key)
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
        raise BearingTwinError(f"data.root={root} is not a folder; point it at the CWRU .mat files (by default "
                               "<paths.data_root>/cwru: paths.data_root=<folder>, or BEARINGTWIN_DATA=<folder>)")
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


def _optional_setting(cfg: dict, name: str, unit: str) -> float | None:
    """``data.<name>`` (rpm, fs): None when unset, else a positive number, checked before any file is read."""
    return None if cfg.get(name) is None else positive_number(cfg[name], f"data.{name}", unit)


def _get(cfg: dict, name: str):
    if name not in cfg or cfg[name] is None:
        raise BearingTwinError(f"data.{name} is missing")
    return cfg[name]


