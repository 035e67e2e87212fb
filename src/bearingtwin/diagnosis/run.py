"""Everything ``bearingtwin-diagnose`` does: find the records, diagnose each, score, write, log.

Per record ``<out>/<record stem>/diagnosis.json`` and ``diagnosis.png``; and
``<out>/summary.csv`` (one row per record; ``true_state, correct`` when the truth is known from
CWRU file names, the files themselves or a labels table: ``labels=<csv>`` or the
``labels.csv`` of the folder the files lie in, columns ``record,state[,rpm,fs,unit,scale]``, whose ``rpm``, ``fs`` and ``unit`` fill in what a file does
not state, before the command's ``rpm=`` / ``fs=``). A record that cannot be diagnosed, its labels row not
reading among the reasons, is reported in ``summary.csv`` with its error and the others go on; the command then
exits 2. A folder's or glob's tables that hold no signal are left out, and named. A labels table may leave the
state out, or a row's state empty: that file's rpm and fs are read, and its verdict is of unknown truth.

A folder's or glob's run leaves ``out`` holding its own per-record outputs alone: what an earlier run wrote there
(:data:`OUTPUT_FILES`, ``summary.csv``) is removed before the first record is diagnosed, so a record deleted since,
or failing now, or not reached by an interrupt, leaves no verdict of the earlier run to pass for this one's; a
single file's run replaces that record's outputs alone (:func:`remove_earlier_outputs`) and its row of the
``summary.csv`` there (:func:`update_summary`), begun by the first such run."""

from __future__ import annotations

import contextlib
import csv
import fcntl
import glob
import io
import json
import logging
import os
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING

from omegaconf import DictConfig, OmegaConf
from tqdm.auto import tqdm

from bearingtwin.checks import positive_number, true_or_false
from bearingtwin.config import bearing_config, output_folder
from bearingtwin.data.cwru import parse_cwru_name
from bearingtwin.data.formats import FORMATS, known_unit, scale_and_unit
from bearingtwin.data.labels import (DEFAULT_LABELS, NOT_LISTED, LabelsRow, first_messages, labels_row,
                                     labels_table_with_bad_rows, names_file, read_labels, recordings_and_others,
                                     scale_and_unit_given, warn_left_out, why_not_a_recording)
from bearingtwin.diagnosis.evidence import PhysicsEvidence, check_segment, evidence_settings
from bearingtwin.diagnosis.mlflow_model import deleted_run_words, load_diagnosis_model
from bearingtwin.diagnosis.record import (CONDITION_KEYS, FEW_WINDOWS, diagnose_recording, one_line, plot_diagnosis,
                                         read_record)
from bearingtwin.errors import BearingTwinError
from bearingtwin.storage import file_digest
from bearingtwin.tracking.lifecycle import raise_if_interrupted

if TYPE_CHECKING:
    from mlflow import MlflowClient

SUMMARY_COLUMNS = ("record", "verdict", "share", "mean_probability", "evidence_state", "agree", "rate_check")
TRUTH_COLUMNS = ("true_state", "correct", "physics_correct")
SUMMARY_FIELDS = (
    *SUMMARY_COLUMNS, "fault_size_in", *TRUTH_COLUMNS, "error", "bearing", "load_hp", "position", "severity",
    "original_fs",  # the rate the file was read at (Hz), before any resampling to the model's
    "unit_check", "level_unseen",  # how its unit was read, and a level the model never saw
    # The classifier's own majority and the share of windows the envelope spectrum decided (physics_first): a verdict
    # the physics gave is not the classifier's.
    "classifier_verdict", "physics_decided",
    "speed_spread", "order_tracked",  # how steadily the shaft turned; resampled to a steady speed
    "speed_unseen",  # a shaft speed well beyond the model's training windows'
    "features_unseen",  # the share of windows the classifier decided beyond its training features
    "scale",  # what the file's samples were multiplied by (scale=, or its labels row's), empty where nothing
    # Its windows, those right where its truth is known, and those the classifier alone got right (the same where the
    # envelope spectrum decided none): what a score over windows, or over the classifier alone, sums.
    "windows", "windows_right", "classifier_windows_right",
)
"""``summary.csv``'s columns, in every run: a record's own values, its truth where known, the error of one that failed,
its condition and how it was read."""

log = logging.getLogger(__name__)


@dataclass
class DiagnosisRun:
    """What one command did: the rows of ``summary.csv``, failures, scores and where it wrote."""

    rows: list[dict] = field(default_factory=list)
    failures: dict[str, str] = field(default_factory=dict)
    out: Path = Path(".")
    files: list[Path] = field(default_factory=list)
    scores: dict[str, float] = field(default_factory=dict)
    run_id: str | None = None  # the command's MLflow run (None untracked), named in every diagnosis.json
    earlier: list[str] = field(default_factory=list)  # records whose outputs an earlier run left in out, removed
    # One file's run: the records of out diagnosed by another model than this run's (its version -> their names), whose
    # rows summary.csv keeps beside this one's.
    other_models: dict[str, list[str]] = field(default_factory=dict)
    model_note: str = ""  # what the store says of the model's run where it says anything (deleted), else ""


def find_records(path: str, labels_path: Path | None) -> list[Path]:
    """The recordings ``path`` names: one file, every readable file of a folder, or a glob (``**`` reaching every
    folder below); a table that holds no signal (notes, results, a labels table under another name) is left out of a folder or glob, and named."""
    if not path.strip():  # Path("") is the working directory, which the user did not name
        raise BearingTwinError("path is empty: give path=<file | folder | glob>")
    candidate = Path(path).expanduser()
    is_glob = not candidate.exists() and glob.has_magic(path)
    labels = {labels_path.resolve()} if labels_path is not None else set()

    def is_labels(file: Path) -> bool:  # read as the labels, not as a recording nor left out as a table of notes
        return file.resolve() in labels or file.name == DEFAULT_LABELS

    if candidate.is_dir():
        found, by_name = recordings_and_others(candidate)
        others = {candidate / name: reason for name, reason in by_name.items()}
        folder = candidate
    elif candidate.is_file():
        return [candidate]  # named on its own: read as a recording, its reader naming what it is not
    elif is_glob:
        # ** reaches every folder below (records/**/*.csv holds records/*.csv too), as a shell's globstar does.
        matched = sorted(Path(p) for p in glob.glob(str(candidate), recursive=True)
                         if Path(p).is_file() and not Path(p).name.startswith(NOT_LISTED))  # *.xls meets ~$x.xls
        if not matched:
            raise BearingTwinError(f"path={path}: the pattern matches no file")
        reasons = {p: why_not_a_recording(p) for p in matched}
        found = [p for p, reason in reasons.items() if reason is None]
        others = {p: reason for p, reason in reasons.items() if reason is not None}
        folder = matched[0].parent
    else:
        raise BearingTwinError(f"path={path}: no such file or folder")
    # A file a labels row names is a recording, whatever it holds: its reader says what is wrong with it.
    named = _records_named(labels_path or folder / DEFAULT_LABELS)
    found = sorted(found + [file for file in others if any(names_file(record, file) for record in named)])
    others = {file: reason for file, reason in others.items() if file not in found and not is_labels(file)}
    warn_left_out(path, {(file.name if candidate.is_dir() else str(file)): reason for file, reason in others.items()})
    found = [p for p in found if not is_labels(p)]
    if not found:
        inside = " (subfolders are not searched: point at one, or use a glob)" if candidate.is_dir() and any(
            child.is_dir() for child in candidate.iterdir()) else ""
        holds = "matches" if is_glob else "holds"  # a glob that matched only the labels table
        raise BearingTwinError(f"path={path}: {holds} no recording ({', '.join(FORMATS)}){inside}")
    # Each file as seen from the folder all of them lie in: week01/m01.csv beside week02/m01.csv from a glob.
    common = Path(os.path.commonpath([file.parent for file in found]))
    by_stem: dict[str, list[str]] = {}
    for file in found:
        by_stem.setdefault(file.stem, []).append(file.relative_to(common).as_posix())
    clashes = [f"{', '.join(names)} share the record name {stem}" for stem, names in by_stem.items() if len(names) > 1]
    if clashes:  # a record is named by its stem: its output folder, its summary row and its labels row
        raise BearingTwinError(f"path={path}: {'; '.join(clashes)}; rename them, or point at one folder or file")
    return found


def _records_named(table: Path) -> list[str]:
    """The record of every row of a labels table, whether the row reads or not; none where there is no table or
    it cannot be read (the labels are read, and refused, after the records are found)."""
    try:
        rows, bad_rows = labels_table_with_bad_rows(table, state_required=False) if table.is_file() else ([], [])
    except BearingTwinError:
        return []
    return [row.record for row in rows] + [record for record, _ in bad_rows]


def given_labels(cfg: DictConfig) -> Path | None:
    """The table ``labels=<csv>`` names, if any."""
    return None if cfg.labels is None else Path(str(cfg.labels)).expanduser()


def labels_path(cfg: DictConfig, records: list[Path]) -> Path | None:
    """The labels table: ``labels=<csv>``, else the ``labels.csv`` of the folder the records lie in (the folder
    ``path=`` names, as training reads one, or the one folder a glob's files share), else none (a single file's
    row in the table beside it is :func:`row_beside`'s). A glob across folders with tables of their own is
    refused: their rows name records by stem, which one table cannot hold apart."""
    if cfg.labels is not None:
        return given_labels(cfg)
    if Path(str(cfg.path)).expanduser().is_file():
        return None
    folders = sorted({record.parent for record in records})
    tables = [folder / DEFAULT_LABELS for folder in folders if (folder / DEFAULT_LABELS).is_file()]
    if len(folders) > 1 and tables:
        raise BearingTwinError(f"path={cfg.path}: matches files in {len(folders)} folders, and "
                               f"{', '.join(str(table) for table in tables)} label{'s' if len(tables) == 1 else ''} "
                               "some of them; give labels=<csv> or diagnose one folder at a time")
    return tables[0] if tables else None


def row_beside(cfg: DictConfig) -> tuple[Path | None, dict]:
    """For one file given without ``labels=``: the ``labels.csv`` beside it and its row (``stem -> row``, a
    :class:`~bearingtwin.data.labels.LabelsRow`), read as the twin and inspect read it (:func:`~bearingtwin.data.labels.labels_row`: that row alone);
    ``(None, {})`` when there is none."""
    path = Path(str(cfg.path)).expanduser()
    if cfg.labels is not None or not path.is_file():
        return None, {}
    row = labels_row(path, state_required=False)
    if row is None:
        return None, {}
    return path.parent / DEFAULT_LABELS, {path.stem: row._replace(record=path.name)}


def chosen_bearing(cfg: DictConfig) -> str | None:
    """The ``conf/bearing`` file ``bearing=<name>`` chose (None when none was), read as it is written: a
    model is asked for a bearing by name, so ``bearing.*`` overrides on top of it are refused."""
    if cfg.get("bearing") is None:
        return None
    from hydra.core.hydra_config import HydraConfig

    name = HydraConfig.get().runtime.choices["bearing"]
    if {**OmegaConf.to_container(cfg.bearing, resolve=True), "name": name} != bearing_config(name):
        raise BearingTwinError(f"bearing.*: bearingtwin-diagnose reads conf/bearing/{name}.yaml as written (a model is "
                               "asked for a bearing by its name); describe another bearing in a conf/bearing file of its own")
    return name


NOT_REACHED = "not diagnosed: the command was interrupted"
"""``summary.csv``'s error for the records an interrupt left, so a partial summary does not read as a whole one."""


def diagnose_paths(cfg: DictConfig) -> DiagnosisRun:
    """Diagnose every record ``cfg.path`` names with ``cfg.model``; write and log the results."""
    tracking_uri = str(cfg.tracking.uri)
    out = output_folder(cfg.out).resolve()  # named in the closing summary: where it is from anywhere
    figures = true_or_false(cfg.figures, "figures")
    logged = true_or_false(cfg.tracking.enabled, "tracking.enabled")  # to MLflow
    settings = evidence_settings(OmegaConf.to_container(cfg.evidence, resolve=True))
    order_tracking = (true_or_false(cfg.order_tracking.enabled, "order_tracking.enabled"),
                      _unsteady(cfg.order_tracking.unsteady))
    bearing = chosen_bearing(cfg)
    for name, unit in (("rpm", "rev/min"), ("fs", "Hz")):  # once, before any file: it applies to every one
        if cfg[name] is not None:
            positive_number(cfg[name], name, unit)
    if cfg.get("scale") is not None:
        scale_and_unit(cfg.scale, cfg.get("unit"))
    elif cfg.get("unit") is not None:
        known_unit(cfg.unit, "unit")
    records = find_records(str(cfg.path), given_labels(cfg))  # first: an empty path= would have ./labels.csv read
    table = labels_path(cfg, records)
    labels, bad_rows = read_labels(table, state_required=False)  # a fleet's states are what is asked
    beside, row = row_beside(cfg)
    if beside is not None:  # one file: its row fills in what the command leaves out, as the twin's does
        table, labels = beside, row
    model, pipeline, pinned = load_diagnosis_model(str(cfg.model), tracking_uri)  # pinned: the version an alias named
    model_note = deleted_run_words(model, str(cfg.model), tracking_uri)
    if model_note:
        log.warning("model=%s: %s", cfg.model, model_note)
    pipeline.check_can_diagnose()
    check_segment(settings["segment_s"], pipeline.fs_hz)  # every record is read at the model's rate
    with writing_alone(out, whole_folder=len(records) > 1):
        # Once the command can diagnose (a mistyped model costs no earlier results), before the first record: an
        # interrupted run then leaves its own records' outputs alone, never beside an earlier run's.
        refuse_replacing_another_file(out, records)
        tracked = open_diagnosis_run(cfg, table, bearing, pinned) if logged else None
        earlier = remove_earlier_outputs(out, records)  # after the store answered: a failing store costs no results
        run = DiagnosisRun(out=out, run_id=tracked[1] if tracked else None, earlier=earlier, model_note=model_note)
        interrupted = False
        try:
            diagnose_records(run, records, cfg, model, pipeline, settings, labels, bad_rows, table, bearing, figures,
                             pinned, order_tracking)
        except KeyboardInterrupt:  # an interrupt (SIGINT, SIGTERM): the records it left are listed as left, not omitted
            reached = len(run.rows)  # one row per record, in the records' order
            run.rows += [{"record": path.stem, "error": NOT_REACHED} for path in records[reached:]]
            interrupted = True
            raise
        finally:  # interrupted too: the summary of the records diagnosed, not an earlier run's left beside them
            summary = out / "summary.csv"
            try:  # one file's row into the rows earlier runs wrote (files diagnosed one by one as they arrive)
                run.files.append(write_summary(run.rows, summary) if len(records) > 1 else
                                 update_summary(run.rows, summary))
            except BearingTwinError as error:
                if not interrupted:
                    raise
                log.warning("%s", error)  # said; the interrupt, not the disk, ends the command (its runs KILLED)
        if len(records) == 1:
            run.other_models = models_beside(out, records[0].stem, pinned)
        if tracked:
            log_diagnosis(*tracked, run, len(records))
    return run


def models_beside(out: Path, record: str, model_version_uri: str) -> dict[str, list[str]]:
    """The models (their versions) other than ``model_version_uri`` that diagnosed the records of ``out`` but
    ``record``, each with their names: summary.csv keeps their rows beside a one-file run's."""
    others: dict[str, list[str]] = {}
    for folder in sorted(out.iterdir()):
        diagnosis = _written_here(folder) if folder.name != record and not folder.is_symlink() else None
        used = diagnosis and diagnosis.get("model_version_uri")
        if used and used != model_version_uri:
            others.setdefault(str(used), []).append(folder.name)
    return others


@contextlib.contextmanager
def writing_alone(out: Path, whole_folder: bool):
    """``out`` claimed for this command while it writes there (a lock on the folder, which the system releases when
    the process ends, however it ends): a command over several records (``whole_folder``), which removes an earlier
    run's outputs of every record, alone; commands over one file each (one record folder's outputs apiece), side by
    side. Two diagnoses of a folder into one ``out`` (a job started again before the last ended) had each removed the
    other's outputs as an earlier run's and left a folder of both. Where the file system locks nothing (some network
    file systems refuse a folder's lock), the command goes on unclaimed. Folders made for the claim and left empty are
    removed."""
    made = []  # the folders the claim makes, inner first
    for folder in (out, *out.parents):
        if folder.exists():
            break
        made.append(folder)
    out.mkdir(parents=True, exist_ok=True)
    handle = os.open(out, os.O_RDONLY)
    try:
        try:
            fcntl.flock(handle, (fcntl.LOCK_EX if whole_folder else fcntl.LOCK_SH) | fcntl.LOCK_NB)
        except BlockingIOError:
            raise BearingTwinError(f"out={out}: another bearingtwin-diagnose is writing there; wait for it to end, or "
                                   "give this one an out= of its own") from None
        except OSError as error:
            log.info("out=%s not claimed (%s): its file system locks no folder", out, error.strerror or error)
        yield
    finally:
        for folder in made:  # inner first, while still claimed: no other command's files are in an empty folder
            with contextlib.suppress(OSError):
                if not any(folder.iterdir()):
                    folder.rmdir()
        os.close(handle)


OUTPUT_FILES = ("diagnosis.json", "diagnosis.png")
"""What the command writes into each record's folder of ``out``: all it removes there, never another file."""


def remove_earlier_outputs(out: Path, records: list[Path]) -> list[str]:
    """Remove what an earlier run wrote into ``out`` and name the records it had written: a verdict left beside this
    run's would pass for one of them, for a record deleted since, failing now or not reached. A run of several records
    removes every record folder's outputs and the earlier ``summary.csv``; a run of one file only that record's (files
    diagnosed one by one as they arrive build up their results). Only files this command wrote are removed (a
    ``diagnosis.json`` naming its own record and a model, the ``diagnosis.png`` beside it, a ``summary.csv`` with
    its columns), never a symlinked folder's, and a folder only when nothing else is left in it."""
    names = None if len(records) > 1 else {records[0].stem}
    folders = sorted(folder for folder in out.glob("*") if not folder.is_symlink()
                     and (names is None or folder.name in names) and _written_here(folder) is not None)
    summary = out / "summary.csv"
    if names is None and summary.exists() and not _summary_written_here(summary):
        raise BearingTwinError(f"{summary} is not one this command wrote; it is kept: move it or choose another out=")
    try:
        if names is None and summary.exists():
            summary.unlink()
        for folder in folders:
            remove_outputs(folder)
    except OSError as error:
        raise BearingTwinError(f"out={out}: cannot remove an earlier run's outputs ({error.strerror}: "
                               f"{error.filename})") from None
    return [folder.name for folder in folders]


def _summary_written_here(path: Path) -> bool:
    """Whether ``path`` is a ``summary.csv`` this command wrote (a file that starts with its columns)."""
    try:
        with open(path, errors="replace") as handle:
            return handle.readline().startswith(",".join(SUMMARY_COLUMNS))
    except OSError:
        return False


def refuse_replacing_another_file(out: Path, records: list[Path]) -> None:
    """Refuse one file whose record folder in ``out`` holds the diagnosis of another file of its name (a logger's dated
    folders give motor1.npz every day): that verdict, another day's, would be lost, as a folder's run or a glob refuses
    two files of one name."""
    folder = out / records[0].stem
    diagnosis = None if len(records) > 1 or folder.is_symlink() else _written_here(folder)
    # A relative source depends on where that run started: only an absolute one names the file it diagnosed.
    source = Path(str(diagnosis.get("source"))) if diagnosis else None
    earlier = source.resolve() if source is not None and source.is_absolute() else None
    if earlier is not None and earlier != records[0].resolve():
        raise BearingTwinError(f"out={out} holds {records[0].stem}'s diagnosis of {earlier}, which {records[0]} would "
                               f"replace: give another out= (one per folder or day), or remove {folder} to replace it")


def _written_here(folder: Path) -> dict | None:
    """The diagnosis.json ``folder`` holds where this command wrote it (one naming the folder's record and a model),
    else None."""
    try:
        result = json.loads((folder / "diagnosis.json").read_text())
    except (OSError, ValueError):  # no such file (a plain file for a folder among them), or not JSON
        return None
    return result if isinstance(result, dict) and result.get("record") == folder.name and "model_uri" in result else None


def remove_outputs(folder: Path) -> None:
    """Remove :data:`OUTPUT_FILES` from a record's folder, and the folder when nothing else is left in it."""
    for name in OUTPUT_FILES:
        (folder / name).unlink(missing_ok=True)
    with contextlib.suppress(OSError):  # a file of the user's own keeps the folder
        folder.rmdir()


def write_outputs(result: dict, evidence: PhysicsEvidence | None, class_names: list[str], folder: Path,
                  figures: bool) -> list[Path]:
    """``diagnosis.json`` and, with ``figures``, ``diagnosis.png`` in the record's ``folder``; a write that fails or
    is interrupted leaves neither (nor the folder it made), so no record folder holds a part of a diagnosis. A folder
    that is a link, or that holds such a file this command did not write (its own were removed before the first
    record), is refused rather than written through or over."""
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise BearingTwinError(f"out={folder.parent}: {folder.name} is a link or a file, not a folder this command "
                               "made; it is kept: move it or choose another out=")
    theirs = [folder / name for name in OUTPUT_FILES if (folder / name).exists()]
    if theirs:
        raise BearingTwinError(f"{theirs[0]} is not one this command wrote; it is kept: move it or choose another out=")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        written = [plot_diagnosis(result, evidence, class_names, folder / "diagnosis.png")] if figures else []
        (folder / "diagnosis.json").write_text(json.dumps(result, indent=1))
    except BaseException as error:  # an interrupt (KeyboardInterrupt) too
        with contextlib.suppress(OSError):  # a full disk may refuse even the cleaning up
            remove_outputs(folder)
        if isinstance(error, OSError):  # a full disk, a read-only folder: the record's failure, said in a line
            raise BearingTwinError(f"out={folder.parent}: {folder.name}'s diagnosis cannot be written there "
                                   f"({error.strerror or error})") from None
        raise
    return [folder / "diagnosis.json", *written]


def diagnose_records(run: DiagnosisRun, records: list[Path], cfg: DictConfig, model, pipeline, settings: dict,
                     labels: dict, bad_rows: dict, table: Path | None, bearing: str | None, figures: bool,
                     pinned_uri: str, order_tracking: tuple[bool, float]) -> None:
    """Diagnose ``records`` one by one into ``run`` (its rows, files, failures and scores); a record whose labels
    row does not read (``bad_rows``, :func:`~bearingtwin.data.labels.read_labels`) fails with its row's error.
    ``order_tracking``: whether an unsteady record is order-tracked, and the spread of its speed that is unsteady.
    ``pinned_uri``: the model's URI with an alias replaced by the version it names (:func:`~bearingtwin.diagnosis.mlflow_model.load_diagnosis_model`)."""
    out = run.out
    windows_total = windows_correct = classifier_correct = physics_decided = 0
    # A bar over the files in a terminal only (None: tqdm's own test), not in a file the output goes to.
    progress = tqdm(records, desc="diagnose", unit="file", disable=True if len(records) < 2 else None)
    labelled = _rows_of(records, labels)
    refused = {path.stem: message for path in records for record, message in bad_rows.get(path.stem, [])
               if names_file(record, path)}
    unlisted = sorted([row.record for stem, row in labels.items() if stem not in labelled]
                      + [record for stem, rows in bad_rows.items() for record, _ in rows if stem not in refused])
    single = Path(str(cfg.path)).expanduser().is_file()
    if unlisted and not single:  # a table of a folder, not of the one file given
        progress.write(f"{table}: rows for {', '.join(unlisted)}, which {cfg.path} does not hold, left out")
    passed_over = [message for stem, rows in bad_rows.items() for _, message in rows if stem not in refused]
    if passed_over and single:  # as inspect and the twin say it of the table beside a file
        progress.write(f"{table}: passed over rows of other files that do not read: {first_messages(passed_over)}")
    calibrated, trained = calibration_records(pipeline), set(pipeline.training_records.values())
    calibrated_digests = set(pipeline.calibration_records.values())
    for path in progress:
        raise_if_interrupted()  # a signal a library swallowed (loading the model, say) stops here, not at the end
        prepared = None
        try:
            if path.stem in refused:
                raise BearingTwinError(refused[path.stem])
            table_row = labelled.get(path.stem) or LabelsRow("", path.name, None, None, None, None)
            fs, fs_from_row = _fact(cfg.fs, table_row.fs, command_first=single)
            rpm, rpm_from_row = _fact(cfg.rpm, table_row.rpm, command_first=single)
            scale, unit, unit_from_row = scale_and_unit_given(cfg.get("scale"), cfg.get("unit"), table_row,
                                                              command_first=single)
            its_row = f"{table if table else 'labels'} (its row for {path.name}): "
            prepared = read_record(path, pipeline, cfg.channel, fs, rpm, table_row.state, bearing, unit=unit, scale=scale,
                                   fs_key=its_row + "fs" if fs_from_row else "fs",
                                   rpm_key=its_row + "rpm" if rpm_from_row else "rpm",
                                   unit_key=its_row + "unit" if unit_from_row else "unit",
                                   scale_key=its_row + "scale" if unit_from_row else "scale", order_tracking=order_tracking,
                                   unit_fills_in=not (single or unit_from_row))
            if table_row.scale is not None and not unit_from_row:  # the command's unit holds: the row's scale unread
                prepared.notes.append(f"{table_row.where} gives scale {table_row.scale:g} (unit {table_row.unit}), not "
                                      "applied: the unit= and scale= given hold for the one file they name")
            result, evidence = diagnose_recording(prepared, model, pipeline, str(cfg.model), settings, pinned_uri)
            digest = file_digest(path) if trained or calibrated_digests else None
            # By contents as well as names: a copy (the Data Center's 97.mat for normal_0_97.mat) is no new record.
            calibrated_on = bool(_names_of(path, table) & calibrated) or digest in calibrated_digests
            trained_on = digest in trained
            result["calibration_record"], result["training_record"] = calibrated_on, trained_on
            if calibrated_on:
                result["notes"].append("the model's twin was calibrated on this record (data.calibration.records): "
                                       "its verdict is no test of the model")
            if trained_on:
                result["notes"].append("the model was trained on windows of this record (the same contents): its "
                                       "verdict is no test of the model")
            # Which run wrote it, and when: results of different runs are told apart.
            result["run_id"] = run.run_id
            result["diagnosed_at"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
            written = write_outputs(result, evidence, pipeline.class_names, out / result["record"], figures)
        except Exception as error:  # one record's failure, expected or not, must not lose the others'
            message = str(error) if isinstance(error, BearingTwinError) else f"{type(error).__name__}: {error}"
            if not message.startswith(f"{path}: "):  # a reader's message names the file already; name it once
                message = f"{path}: {message}"
            if path.stem not in labelled and ("give fs=" in message or "give rpm=" in message):
                # What a row's rpm and fs would give: the command's value is every file's, a row is one file's.
                message += (f" (or a row in {table}, which has none for it)" if table is not None else
                            f" (every file's), or this file's in a {DEFAULT_LABELS} beside it (columns record,state,rpm,fs)"
                            if not single else f" (or a row in a {DEFAULT_LABELS} beside it: record,state,rpm,fs)")
            elif path.stem in labelled and "give fs=" in message:  # its row leaves the rate out (the speed's message
                # names the rpm column itself)
                message += f" (or this file's in the fs column of its row in {table})"
            if not isinstance(error, BearingTwinError):
                log.exception("%s: unexpected failure", path)
            run.failures[path.name] = message
            run.rows.append({"record": path.stem, "error": message, **stated_truth(path, labelled)})
            for note in [] if prepared is None else prepared.notes:  # what reading it found may say why it failed
                progress.write(f"{path.stem}: {note}")
            progress.write(f"{path.stem}: FAILED - {message}")
            continue
        run.files += written
        for note in result["notes"]:
            progress.write(f"{result['record']}: {note}")
        progress.write(one_line(result))
        row = {name: result[name] for name in SUMMARY_COLUMNS}
        row["seen"] = {"calibrated": calibrated_on, "trained": trained_on}  # by the model (not a column)
        row.update({key: result[key] for key in CONDITION_KEYS if key in result})
        if "true_state" in result:
            row.update({name: result[name] for name in TRUTH_COLUMNS if name in result})
            windows_total += len(result["windows"])
            windows_correct += result["windows_correct"]
            classifier_correct += result["classifier_windows_correct"]
            physics_decided += sum(window.get("decided_by") == "physics" for window in result["windows"])
            row["windows_right"], row["classifier_windows_right"] = (result["windows_correct"],
                                                                     result["classifier_windows_correct"])
        row["windows"] = len(result["windows"])
        row["bearing"], row["original_fs"] = result["bearing"], result["original_fs"]
        row["declared_fs"] = result["declared_fs"]  # for the closing summary (not a column)
        row["named_state"] = result["named_state"]  # for the closing summary (not a column)
        row["bearing_given"] = result["bearing_given"]  # for the closing summary (not a column)
        row["fs"] = result["fs"]  # the model's rate, read at (not a column of summary.csv)
        row["unit_check"], row["level_unseen"] = result["unit_check"], result["level_unseen"]
        row["scale"] = "" if result["scale"] is None else result["scale"]
        row["speed_unseen"] = result["speed_unseen"]
        row["few_windows"] = len(result["windows"]) < FEW_WINDOWS  # for the closing summary (not a column)
        row["features_unseen"] = "" if result["features_unseen"] is None else result["features_unseen"]
        row["classifier_verdict"] = result["classifier_verdict"] or ""  # empty where the physics decided every window
        row["physics_decided"] = result["physics_decided"]
        # A measured record with a speed whose rate the shaft line could not check (too short to resolve it).
        row["rate_unchecked"] = result["rate_check"] == "not checked" and result["speed"] is not None  # (not a column)
        speed = result["speed"] or {}  # the spread of the shaft speed read, and whether the record was steadied
        row["speed_spread"] = "" if speed.get("spread") is None else speed["spread"]
        row["order_tracked"] = speed.get("tracked", "")
        row["speed_in_doubt"] = speed.get("in_doubt", False)  # for the closing summary (not a column)
        row["speed_off"] = speed.get("off", False)  # the same
        row["steadying_refused"] = speed.get("steadying_refused", False)  # the same
        row["windows_left_out"] = result["windows_left_out"]  # the same
        row["no_evidence"] = result["evidence"] is None  # the same: no speed (or bearing), no physics to hold it to
        run.rows.append(row)
    scored = [row for row in run.rows if "correct" in row]
    if scored:
        run.scores = {"accuracy_records": sum(row["correct"] for row in scored) / len(scored),
                      "accuracy_windows": windows_correct / windows_total, "n_scored": len(scored)}
        if physics_decided:  # a model that lets the envelope spectrum decide where it leaves no doubt (physics_first)
            run.scores["share_windows_physics_decided"] = physics_decided / windows_total
            run.scores["accuracy_windows_classifier"] = classifier_correct / windows_total
    tested = [row for row in scored if not any(row["seen"].values())]
    if tested and len(tested) < len(scored):  # records the model learnt from, or its twin was fitted to, test nothing
        run.scores["accuracy_records_tested"] = sum(row["correct"] for row in tested) / len(tested)
        run.scores["n_scored_tested"] = len(tested)
        run.scores["accuracy_windows_tested"] = (sum(row["windows_right"] for row in tested)
                                                 / sum(row["windows"] for row in tested))
    with_physics = [row for row in scored if "physics_correct" in row]
    if with_physics:  # the envelope analysis alone, on the same records: what the model must beat
        run.scores["accuracy_records_physics"] = sum(row["physics_correct"] for row in with_physics) / len(with_physics)
        run.scores["n_scored_physics"] = len(with_physics)


def _rows_of(records: list[Path], rows: dict[str, LabelsRow]) -> dict[str, LabelsRow]:
    """The rows (``stem -> row``) that name one of ``records``: by its file name, or by its stem where the
    row gives no suffix (a row for a.npz is not a.npy's). One file per stem (:func:`find_records`)."""
    by_stem = {path.stem: path for path in records}
    return {stem: row for stem, row in rows.items() if stem in by_stem and names_file(row.record, by_stem[stem])}


def _fact(command, row, command_first: bool):
    """A file's speed or rate, and whether its labels row gave it: the row comes first where the command's value is
    every file's of a folder, the command's where it names the one file given."""
    if (command_first and command is not None) or row is None:
        return command, False
    return row, True


def _names_of(path: Path, table: Path | None) -> set[str]:
    """The names a training config may give a record by: its file name or stem, or, under a labels table's
    folder, its path from there (``rig_a/healthy_a``: a record in a subfolder), with or without its suffix."""
    names = {path.stem, path.name}
    if table is not None and path.resolve().is_relative_to(table.resolve().parent):
        relative = path.resolve().relative_to(table.resolve().parent)
        names |= {relative.as_posix(), relative.with_suffix("").as_posix()}
    return names


def _unsteady(value) -> float:
    """``order_tracking.unsteady``: a relative spread of the shaft speed, a positive number below 1."""
    spread = positive_number(value, "order_tracking.unsteady", "relative spread of the shaft speed")
    if spread >= 1:
        raise BearingTwinError(f"order_tracking.unsteady must be a relative spread below 1 (0.02: 2 %), got {value}")
    return spread


def calibration_records(pipeline) -> set[str]:
    """The records (names as the training config gives them) a twin-trained model's twin was calibrated on."""
    data = pipeline.config.get("data") or {}
    if data.get("source") != "twin_to_real":
        return set()
    return {str(name) for name in (data.get("calibration") or {}).get("records") or []}


def write_summary(rows: list[dict], path: Path) -> Path:
    """``summary.csv`` of ``rows`` at ``path``, written over whatever an earlier run left there."""
    text = summary_text(rows)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w", newline="") as handle:
            handle.write(text)
    except OSError as error:
        raise _unwritable(path, error) from None
    return path


def update_summary(rows: list[dict], path: Path) -> Path:
    """``summary.csv`` at ``path`` with ``rows`` in place of the rows of the same records, the other records' rows
    kept: a one-file run adds its record to the summary of the files diagnosed before it, never over them. Runs
    side by side take turns (an exclusive lock on the file while it is read and written); a file this command did
    not write is refused and kept; a write that fails puts the earlier contents back."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a+", newline="") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX)  # released when the file is closed
            handle.seek(0)
            earlier = handle.read()
            if earlier and not earlier.startswith(",".join(SUMMARY_COLUMNS)):
                raise BearingTwinError(f"{path} is not one this command wrote; it is kept: move it or choose another "
                                       "out=")
            # A row read back holds every column of the file; its empty cells were no value of that record's.
            kept = [{name: value for name, value in row.items() if value != ""}
                    for row in csv.DictReader(io.StringIO(earlier, newline=""))]  # a cell may hold a line break
            replaced = {row["record"]: row for row in rows}
            merged = [replaced.pop(row.get("record"), row) for row in kept] + list(replaced.values())
            text = summary_text(merged)
            handle.truncate(0)  # appended from the start ("a+"): the whole file in one write
            try:
                handle.write(text)
                handle.flush()
            except OSError:
                handle.truncate(0)
                handle.write(earlier)
                raise
    except OSError as error:
        raise _unwritable(path, error) from None
    return path


def _unwritable(path: Path, error: OSError) -> BearingTwinError:
    return BearingTwinError(f"out={path.parent}: {path.name} cannot be written there ({error.strerror or error})")


def stated_truth(path: Path, labelled: dict) -> dict:
    """The true state of a record that could not be diagnosed, as its labels row or its CWRU name states it (none where
    neither does): a failed record's row says which state went unanswered."""
    state = labelled[path.stem].state if path.stem in labelled else None
    name = parse_cwru_name(path)
    if name is not None and path.suffix.lower() != ".mat" and name.form != "long":  # read by a long name only
        name = None
    state = state or (name.fault if name is not None else None)
    return {} if state is None else {"true_state": state}


def summary_text(rows: list[dict]) -> str:
    """The CSV text of ``summary.csv``: one row per record under :data:`SUMMARY_FIELDS`, the same columns in every run
    (a cell a record has no value for is empty), so a script reading several runs' summaries finds each by name and
    place."""
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=SUMMARY_FIELDS, restval="", extrasaction="ignore")  # its columns only
    writer.writeheader()
    writer.writerows(rows)
    return text.getvalue()


def open_diagnosis_run(cfg: DictConfig, labels: Path | None, bearing: str | None,
                       pinned_uri: str) -> tuple[MlflowClient, str]:
    """The command's MLflow run in ``tracking.experiment``, opened before the first record with the model (as given,
    and ``pinned_uri``: the version an alias names now) and path as params (and the labels table and the bearing the
    run reads): an interrupt marks it KILLED."""
    from mlflow.entities import Param

    from bearingtwin.tracking.lifecycle import open_owned_run, reap_dead_runs
    from bearingtwin.tracking.mlflow_logging import open_store

    client, experiment_id = open_store(cfg.tracking)
    reap_dead_runs(client)
    run_id = open_owned_run(client, experiment_id, f"diagnose {Path(str(cfg.path)).name} with {cfg.model}",
                            {"bt.kind": "diagnose", "model_uri": str(cfg.model),
                             "model_version_uri": pinned_uri}).info.run_id
    params = {"model": cfg.model, "path": cfg.path, "labels": labels, "channel": cfg.channel, "fs": cfg.fs, "rpm": cfg.rpm,
              "unit": cfg.get("unit"), "scale": cfg.get("scale"), "bearing": bearing}
    client.log_batch(run_id, params=[Param(key, str(value)[:6000]) for key, value in params.items()])
    return client, run_id


def log_diagnosis(client: MlflowClient, run_id: str, run: DiagnosisRun, n_records: int) -> str:
    """The run's scores, JSONs and figures; FAILED when a record could not be diagnosed, else FINISHED."""
    from mlflow.entities import Metric, RunStatus

    now = int(time.time() * 1000)
    metrics = {"n_records": n_records, "n_failed": len(run.failures), **run.scores}
    client.log_batch(run_id, metrics=[Metric(key, float(value), now, 0) for key, value in metrics.items()])
    for path in run.files:
        client.log_artifact(run_id, str(path), None if path.parent == run.out else path.parent.name)
    client.set_terminated(run_id, RunStatus.to_string(RunStatus.FAILED if run.failures else RunStatus.FINISHED))
    return run_id
