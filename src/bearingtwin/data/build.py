"""One entry to every data source: ``build_dataset(cfg)`` dispatches on ``cfg.data.source``.

Bearing reconciliation: the ``bearing`` config group describes the bearing the *twin*
simulates. A measured dataset's bearing is a fact of the measurement, so real-data
configs name it (``data.bearing``, logged as the param ``data.bearing``); the ``bearing``
group is not used to build real data (it only feeds the simulator). An experiment that
simulates and measures together selects the matching group itself (``bearing=cwru_6205``).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Iterable

from omegaconf import DictConfig
from omegaconf.errors import MissingMandatoryValue

from bearingtwin.data.recording import WindowedDataset
from bearingtwin.errors import BearingTwinError
from bearingtwin.storage import file_digest


def _simulated(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.simulated import build_simulated_dataset

    return build_simulated_dataset(cfg.data, cfg.bearing, cfg.simulator, cfg.effects, cfg.paths.cache_dir)


def _cwru(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.real import build_cwru_dataset

    return build_cwru_dataset(cfg.data)  # its folder is data.root (${paths.data_root}/cwru by default)


def _hust(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.real import build_hust_dataset

    return build_hust_dataset(cfg.data)


def _files(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.real import build_files_dataset

    return build_files_dataset(cfg.data)


def _twin_to_real(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.twin_to_real import build_twin_to_real_dataset

    return build_twin_to_real_dataset(cfg.data, cfg.bearing, cfg.simulator, cfg.effects, cfg.paths.cache_dir)


SOURCES = {"simulated": _simulated, "cwru": _cwru, "hust": _hust, "files": _files, "twin_to_real": _twin_to_real}


def _data_source(cfg: DictConfig) -> str:
    source = cfg.data.get("source")
    if source not in SOURCES:
        raise BearingTwinError(f"data.source={source!r} is not a data source; choose one of {', '.join(SOURCES)}")
    return source


def build_dataset(cfg: DictConfig) -> WindowedDataset:
    """The windowed dataset the composed config describes (``data``, plus ``bearing``,
    ``simulator``, ``effects`` and ``paths`` as the source needs them)."""
    return SOURCES[_data_source(cfg)](cfg)


def _check_simulated(cfg: DictConfig) -> None:
    from bearingtwin.data.simulated import check_simulated_settings

    check_simulated_settings(cfg.data)


def _check_cwru(cfg: DictConfig) -> None:
    from bearingtwin.data.real import check_windowing

    check_windowing(cfg.data)


def _check_hust(cfg: DictConfig) -> None:
    from bearingtwin.data.real import check_hust_settings

    check_hust_settings(cfg.data)


def _check_files(cfg: DictConfig) -> None:
    from bearingtwin.data.real import check_files_settings

    check_files_settings(cfg.data)


def _check_twin_to_real(cfg: DictConfig) -> None:
    from bearingtwin.data.twin_to_real import check_twin_to_real_settings

    check_twin_to_real_settings(cfg.data, cfg.bearing)


SETTINGS_CHECKS = {"simulated": _check_simulated, "cwru": _check_cwru, "hust": _check_hust, "files": _check_files,
                   "twin_to_real": _check_twin_to_real}


def check_data_settings(cfg: DictConfig) -> None:
    """Raise naming the first bad value of the composed config's data settings (source, split, counts, rates),
    read from the config alone: a single run refuses it before its MLflow run is opened."""
    SETTINGS_CHECKS[_data_source(cfg)](cfg)



def _hust_files(cfg: DictConfig) -> list[Path]:
    from bearingtwin.data.real import hust_paths

    return list(hust_paths(cfg.data).values())


def _cwru_files(cfg: DictConfig) -> list[Path]:
    from bearingtwin.data.real import cwru_paths

    return cwru_paths(cfg.data)


def _twin_to_real_files(cfg: DictConfig) -> list[Path]:
    from bearingtwin.config import plain_config
    from bearingtwin.data.twin_to_real import check_protocol

    data = plain_config(cfg.data, "data config")
    calibration, tests = check_protocol(data)
    # A rig's own records: their labels table is read too (a state corrected there is another run).
    return calibration + tests + ([Path(str(data["labels"])).expanduser()] if data.get("labels") else [])


def _twin_to_real_inputs(cfg: DictConfig) -> list[Path]:
    """The records and table a twin-to-real run reads, and the calibration reports that make its twin: a report
    fitted again is another run. (A missing report is named by its own setting where it is read.)"""
    from bearingtwin.data.twin_to_real import report_file

    calibration = cfg.data.calibration
    reports = [calibration.get("report"), (calibration.get("healthy") or {}).get("report")]
    return _twin_to_real_files(cfg) + [report_file(report) for report in reports if report]


# Every real-data source: the files a job will read, found from its config before any job
# starts. The HUST names are fixed, so absent files are listed; CWRU records are found by
# pattern, so their finders raise naming the folder or class with no record.
REQUIRED_FILES = {"hust": _hust_files, "cwru": _cwru_files, "twin_to_real": _twin_to_real_files}


def _files_files(cfg: DictConfig) -> list[Path]:
    """What a ``data=files`` run may read: every recording in ``data.root``, the labels table and the files its
    rows name (in a subfolder too; the rows' own checks come when the data is built)."""
    from bearingtwin.data.labels import labels_path, recordings_in, rows_from_labels

    root = Path(str(cfg.data.get("root"))).expanduser()
    if not root.is_dir():
        return []
    settings = {"labels": cfg.data.get("labels")}
    table = labels_path(root, settings)
    rows = set()
    if table.is_file():
        try:
            rows = {path for path, *_ in rows_from_labels(root, settings, warn_unlisted=False)}
        except BearingTwinError:  # a table the run cannot read: it fails on it, saying why
            rows = set()
    return sorted(set(recordings_in(root)) | rows | ({table} if table.is_file() else set()))


INPUT_FILES = {**REQUIRED_FILES, "twin_to_real": _twin_to_real_inputs, "files": _files_files}
"""Every data source that reads files, and the files a config's run reads (:func:`input_digest`)."""


def input_digest(cfg: DictConfig) -> str:
    """Hash of the names and contents of the files a config's data is read from; empty for simulated data.

    A run is what its config *and* its files make it: new recordings in a folder, a labels table
    corrected, a record written over are another run, though the config reads the same."""
    try:
        paths = INPUT_FILES.get(cfg.data.get("source"), lambda _: [])(cfg)
    except (BearingTwinError, MissingMandatoryValue):  # no data to be found: the run fails on it, saying why
        return ""
    present = [path for path in paths if path.is_file()]
    if not present:
        return ""
    digest = hashlib.sha256()
    for path in sorted(present, key=lambda p: p.name):
        digest.update(f"{path.name}\0{file_digest(path)}\0".encode())
    return digest.hexdigest()


def require_files(cfgs: Iterable[DictConfig]) -> None:
    """Raise naming every file the composed configs (one per job) need that is absent.

    Runs before any job so that a sweep on data that is not there stops at once, saying
    what to fetch and where to put it, instead of logging one failed run per job.
    """
    needed: dict[Path, str] = {}
    problems: list[str] = []
    for cfg in cfgs:
        source = cfg.data.get("source")
        try:
            paths = REQUIRED_FILES.get(source, lambda _: [])(cfg)
        except BearingTwinError as error:
            if str(error) not in problems:
                problems.append(str(error))
            continue
        for path in paths:
            needed.setdefault(path, source)
    missing = [path for path in needed if not path.is_file()]
    if missing:
        folders = ", ".join(sorted({str(path.parent) for path in missing}))
        sources = "/".join(sorted({needed[path].upper() for path in missing}))
        found = [path.name for path in needed if path not in missing]
        from bearingtwin.data.real import hust_folder_holds

        held = [note for folder in sorted({path.parent for path in missing if needed[path] == "hust"})
                if (note := hust_folder_holds(folder))]  # another condition's files, or the files one folder down
        problems.insert(0,
            f"{sources} data files missing from {folders}: {', '.join(path.name for path in missing)}"
            + (f" (found: {', '.join(found)})" if found else "") + "".join(f"; {note}" for note in held)
            + ". Put all of them in one folder and pass data.root=<that folder>"
        )
    if problems:
        more = f" (and {len(problems) - 3} more problems)" if len(problems) > 3 else ""
        raise BearingTwinError("; ".join(problems[:3]) + more)
