"""``bearingtwin-diagnose``: diagnose recordings with a trained model from MLflow.

    bearingtwin-diagnose path=<file | folder | glob> model=models:/<name>@<alias> out=<dir>

Writes <out>/<record>/diagnosis.json and diagnosis.png per record, and <out>/summary.csv (a row
per record), prints one line per record and a closing summary (verdicts, scores, disagreements); logs to MLflow (experiment
``bearingtwin-diagnose``) unless tracking.enabled=false. Exit status 2 when any record could
not be diagnosed (the others are still diagnosed) or the model cannot be used.
"""

from __future__ import annotations

import os
import sys
from collections import Counter
from typing import TYPE_CHECKING

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.cli.summary import closing_summary, percent
from bearingtwin.config import exit_on_user_error, hydra_command, refuse_unknown_keys
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.tracking.lifecycle import stop_cleanly

if TYPE_CHECKING:
    from bearingtwin.diagnosis.run import DiagnosisRun


@hydra_command("diagnose")
@exit_on_user_error
def diagnose(cfg: DictConfig) -> None:
    refuse_unknown_keys(HydraConfig.get())
    from bearingtwin.diagnosis.run import diagnose_paths  # MLflow and the models once the input is accepted

    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")  # one bar: over the files
    run = diagnose_paths(cfg)
    print(closing_summary(f"bearingtwin-diagnose: {cfg.path} with {cfg.model}", diagnosis_lines(run), run.run_id,
                          str(cfg.tracking.uri) if run.run_id else None, str(run.out),
                          str(cfg.tracking.experiment) if run.run_id else None))
    if run.failures:
        for reason in run.failures.values():  # each names its file
            print(f"error: {reason}", file=sys.stderr)
        sys.exit(2)


UNSEEN_WORDS = {("calibrated",): "the model's twin was not calibrated on", ("trained",): "the model was not trained on",
                ("calibrated", "trained"): "the model was neither trained on nor its twin calibrated on"}
"""The records a score over the records the model never saw counts, by how it saw the others."""


def unseen_words(rows: list[dict]) -> str:
    """Which records a score over the unseen ones counts (:data:`UNSEEN_WORDS`), by how the model saw the others."""
    return UNSEEN_WORDS[tuple(sorted({how for row in rows for how, seen in row.get("seen", {}).items() if seen}))]


def diagnosis_lines(run: DiagnosisRun) -> dict[str, str]:
    """Verdicts, scores where the truth is known, disagreements with the physics, failures."""
    diagnosed = [row for row in run.rows if "error" not in row]
    verdicts = Counter(row["verdict"] for row in diagnosed)
    lines = {"records diagnosed": f"{len(diagnosed)} of {len(run.rows)}",
             "verdicts": ", ".join(f"{state} {count}" for state, count in verdicts.most_common()) or "none"}
    bearings = sorted({row["bearing"] for row in diagnosed if row.get("bearing")})
    if bearings:  # whose defect lines were read: bearing=, the file's own, else the model's
        lines["bearing"] = ", ".join(bearings)
        unnamed = [row["record"] for row in diagnosed if row.get("bearing_given") is False]
        if unnamed:  # a user's own files: the model's bearing stood in, which may not be theirs
            lines["bearing"] += (f" (the model's, for {'every record' if len(unnamed) == len(diagnosed) else ', '.join(unnamed)}"
                                 ": no bearing= given and the files name none; where they are of another bearing, give "
                                 "bearing=<name>: the physics evidence reads the defect lines of the bearing named)")
    if run.scores:
        lines["records right"] = f"{percent(run.scores['accuracy_records'])} of {run.scores['n_scored']} with a known state"
        seen = [row for row in diagnosed if "correct" in row and any(row.get("seen", {}).values())]
        if "n_scored_tested" in run.scores:
            lines["records right"] += (f"; {percent(run.scores['accuracy_records_tested'])} of the "
                                       f"{run.scores['n_scored_tested']} {unseen_words(diagnosed)}")
        elif seen:  # every record scored was one the model learnt from (or its twin was fitted to): no test of it
            lines["records right"] += f"; none {unseen_words(seen)}: no test of the model"
        lines["windows right"] = percent(run.scores["accuracy_windows"])
        if "share_windows_physics_decided" in run.scores:  # the model's score is the physics' on those windows
            lines["windows right"] += (f" (the envelope spectrum decided {percent(run.scores['share_windows_physics_decided'])}"
                                       f" of them; the classifier alone: {percent(run.scores['accuracy_windows_classifier'])})")
        if "accuracy_windows_tested" in run.scores:  # as the records: those the model learnt from test nothing
            lines["windows right"] += (f"; {percent(run.scores['accuracy_windows_tested'])} of the windows of the "
                                       f"{run.scores['n_scored_tested']} {unseen_words(diagnosed)}")
    if "accuracy_records_physics" in run.scores:
        lines["physics alone right"] = (f"{percent(run.scores['accuracy_records_physics'])} of the "
                                        f"{run.scores['n_scored_physics']} with a known state and physics evidence")
    by_size = records_right_by_size(diagnosed)
    if by_size:
        lines["records right by state and fault size (model, physics)"] = by_size
        alone = "share_windows_physics_decided" in run.scores  # the classifier's own answers differ from the model's
        lines["windows right by state and fault size (model" + (", classifier alone)" if alone else ")")] = \
            windows_right_by_size(diagnosed, alone)
    unscored = [row["record"] for row in diagnosed if "correct" not in row]
    if run.scores and unscored:  # a score over some records: which it leaves out
        lines["not scored (no state known, or one the model cannot answer: see their notes)"] = ", ".join(unscored)
    relabelled = [f"{row['record']} ({row['true_state']}, named {row['named_state']})" for row in diagnosed
                  if row.get("named_state")]
    if relabelled:  # scored by the label, which may be the wrong one: the score moves with it
        lines["labelled otherwise than their names say (scored by the label: check it)"] = ", ".join(relabelled)
    reread = [f"{row['record']} ({row['declared_fs']:g} -> {row['original_fs']:g} Hz)" for row in diagnosed
              if row.get("declared_fs")]
    if reread:  # the rate the name, catalogue or data set declared was refused by the shaft line: the file is mislabelled
        lines["read at another rate than declared (the shaft line refused it: see their notes)"] = ", ".join(reread)
    contradicted = [row["record"] for row in diagnosed if row.get("rate_check") == "contradicted"]
    if contradicted:  # a wrong speed or rate misplaces every defect line: such a verdict is in doubt (still scored)
        lines["speed or rate in doubt (the shaft line contradicts them: check them)"] = ", ".join(contradicted)
    off = [row["record"] for row in diagnosed if row.get("speed_off")]
    if off:  # every defect line looked for beside where it stands (their notes give the speed read)
        lines["speed read (shaft series or tachometer) another than the one stated (see their notes)"] = ", ".join(off)
    tracked = [row["record"] for row in diagnosed if row.get("order_tracked") is True]
    if tracked:  # their verdicts read the records as steadied (order_tracking): said, so none is taken for as recorded
        lines["shaft speed varied: resampled to a steady speed (order tracking)"] = ", ".join(tracked)
    refused = [row["record"] for row in diagnosed if row.get("steadying_refused")]
    if refused:  # the speed read flipped, but steadied to it the shaft's series stood no sharper: a misread profile
        lines["speed read in doubt (steadied, the shaft's series stood no sharper: read as recorded)"] = ", ".join(refused)
    unsteady = [row["record"] for row in diagnosed if row.get("speed_in_doubt") and not row.get("steadying_refused")]
    if unsteady:  # every defect line smeared over the speeds the shaft passed through
        lines["shaft speed varies, left unsteady (its lines smeared: in doubt)"] = ", ".join(unsteady)
    unconfirmed = [row["record"] for row in diagnosed if row.get("rate_check") == "ambiguous"]
    if unconfirmed:  # the record's notes say why: no shaft series to check by, or one a wrong rate could fake
        lines["sampling rate unconfirmed by the shaft line (see their notes)"] = ", ".join(unconfirmed)
    unchecked = [row["record"] for row in diagnosed if row.get("rate_unchecked")]
    if unchecked:  # too short for the shaft line to place the rate: a wrong one given goes unnoticed
        key = "sampling rate not checked (too short for the shaft line to confirm it: see their notes)"
        lines[key] = ", ".join(unchecked)
    left_out = [f"{row['record']} ({row['windows_left_out']})" for row in diagnosed if row.get("windows_left_out")]
    if left_out:  # their verdicts stand on fewer windows than the records hold
        lines["windows left out over dropouts or samples with no value"] = ", ".join(left_out)
    few = [row["record"] for row in diagnosed if row.get("few_windows")]
    if few:  # a majority of one or two windows: one misread window decides it
        lines["verdict on one or two windows (a longer record gives a surer one)"] = ", ".join(few)
    unweighed = [row for row in diagnosed if row.get("no_evidence")]
    varying = [row["record"] for row in unweighed if row.get("speed_varies")]
    if varying:  # a model's verdict alone: no one speed to read the defect lines at
        lines["no physics evidence (variable-speed runs: no one speed to read their lines at)"] = ", ".join(varying)
    if len(varying) < len(unweighed):  # a model's verdict alone
        lines["no physics evidence (no shaft speed or bearing known)"] = ", ".join(
            row["record"] for row in unweighed if not row.get("speed_varies"))
    narrower = [row["record"] for row in diagnosed if row.get("original_fs") and row["original_fs"] < row["fs"]]
    if narrower:  # upsampled: the model reads a band these records never held, so their verdicts are in doubt
        lines["recorded below the model's rate (no content above their Nyquist)"] = ", ".join(narrower)
    assumed = [row["record"] for row in diagnosed if row.get("unit_check") == "assumed"]
    if assumed:  # read by a model that reads levels in its unit, which the file may not be in
        lines["unit assumed (the file states none known here: read in the model's)"] = ", ".join(assumed)
    unseen = [row["record"] for row in diagnosed if row.get("level_unseen")]
    if unseen:  # a unit or gain the model never saw: every amplitude-dependent feature reads it as another state
        lines["level a decade or more outside the model's training windows"] = ", ".join(unseen)
    faster_or_slower = [row["record"] for row in diagnosed if row.get("speed_unseen")]
    if faster_or_slower:  # read by a model that never learnt the bearing at such a speed (their notes give it)
        lines["shaft speed well beyond the model's training windows' (see their notes)"] = ", ".join(faster_or_slower)
    extrapolated = [row["record"] for row in diagnosed if (row.get("features_unseen") or 0.0) >= 0.5]
    if extrapolated:  # the classifier read most windows beyond every training window's features, unawares
        lines["most windows' features beyond the model's training windows' (see their notes)"] = ", ".join(extrapolated)
    disagreements = [row["record"] for row in diagnosed if row.get("agree") is False]
    if disagreements:
        lines["model and physics disagree on"] = ", ".join(disagreements)
    if run.failures:
        lines["could not be diagnosed"] = ", ".join(run.failures)
    if run.model_note:  # loaded all the same: a model its owner removed is said to be
        lines["the model"] = run.model_note
    if run.other_models:  # rows summary.csv keeps beside a one-file run's: their verdicts are another model's
        lines["summary.csv also holds records another model diagnosed"] = "; ".join(
            f"{uri}: {', '.join(records)}" for uri, records in run.other_models.items())
    if run.earlier:  # removed before the first record (diagnose_paths): out holds this run's outputs alone
        again = {row["record"] for row in diagnosed}
        removed = [record for record in run.earlier if record not in again]
        named = f" ({', '.join(removed)})" if removed else ""
        lines["an earlier run's record outputs in out"] = (f"{len(run.earlier) - len(removed)} replaced by this run's, "
                                                           f"{len(removed)} removed{named}")
    return lines


DAMAGE_ORDER = {"none": 0, "medium": 1, "severe": 2}
"""A HUST name's damage levels, smallest first."""


def _size(row: dict) -> tuple[float, str] | None:
    """The defect size a record's name states, as (a key to sort by, words): a CWRU name's in inches, a HUST name's
    damage level; None where its name states none."""
    if "fault_size_in" in row:
        return row["fault_size_in"], f"{row['fault_size_in']:.3f} in"
    if row.get("severity") in ("medium", "severe"):
        return DAMAGE_ORDER[row["severity"]], row["severity"]
    return None


def size_groups(rows: list[dict]) -> dict[str, list[dict]]:
    """The scored ``rows`` grouped as a reader of a fault-size study groups them (``{}`` where no name gives a size):
    by true state, then by the defect size their names give (CWRU's in inches, HUST's damage, ``inner medium``),
    then by an outer race's defect position (``outer 0.021 in @3``) and, where the records were read at several rates,
    by the rate (``at 48 kHz``); a state's records without a size are one group, ``<state>, size unknown`` beside that
    state's sizes. Where the records are of several bearings, each group names its bearing (a size of another bearing
    is another fault: ``inner 0.007 in (cwru_6203)``)."""
    scored = [row for row in rows if "correct" in row]
    if not any(_size(row) for row in scored):
        return {}
    several = len({row.get("bearing") for row in scored}) > 1  # a size of another bearing is another fault
    several_rates = len({row.get("original_fs") for row in scored}) > 1
    sized_states = {row["true_state"] for row in scored if _size(row)}
    groups: dict[str, list[dict]] = {}
    order = {state: index for index, state in enumerate(FAULTS)}
    for row in sorted(scored, key=lambda row: (order.get(row["true_state"], len(order)), _size(row) is None,
                                               (_size(row) or (0.0, ""))[0], int(row.get("position") or 0),
                                               row.get("original_fs") or 0.0, str(row.get("bearing")))):
        state, size = row["true_state"], _size(row)
        name = (f"{state} {size[1]}" if size else f"{state}, size unknown" if state in sized_states else state)
        name += f" @{row['position']}" if row.get("position") else ""  # an outer race's defect, in o'clock
        name += f" at {row['original_fs'] / 1000:g} kHz" if several_rates and row.get("original_fs") else ""
        groups.setdefault(f"{name} ({row.get('bearing')})" if several else name, []).append(row)
    return groups


def records_right_by_size(rows: list[dict]) -> str:
    """``normal 1/1, 1/1; inner 0.007 in 4/4, 3/4; inner, size unknown 2/2, 2/2; ...`` (model, then physics evidence
    where there is some) over :func:`size_groups`; "" where no name gives a size."""

    def physics(group: list[dict]) -> str:
        judged = [row["physics_correct"] for row in group if "physics_correct" in row]
        return f"{sum(judged)}/{len(judged)}" if judged else "no evidence"

    return "; ".join(f"{name} {sum(row['correct'] for row in group)}/{len(group)}, {physics(group)}"
                     for name, group in size_groups(rows).items())


def windows_right_by_size(rows: list[dict], classifier_alone: bool = False) -> str:
    """``outer 0.014 in @6 100.00 % of 11, classifier alone 0.00 %; ...`` over :func:`size_groups`: the model's windows
    right, and with ``classifier_alone`` (the envelope spectrum decided some windows: physics_first) the classifier's
    own answer on the same windows; "" where no name gives a size."""
    parts = []
    for name, group in size_groups(rows).items():
        total = sum(row["windows"] for row in group)
        words = f"{name} {percent(sum(row['windows_right'] for row in group) / total)} of {total}"
        if classifier_alone:
            words += f", classifier alone {percent(sum(row['classifier_windows_right'] for row in group) / total)}"
        parts.append(words)
    return "; ".join(parts)


main = stop_cleanly(diagnose)  # a signal marks the MLflow run KILLED, never left RUNNING


if __name__ == "__main__":
    main()
