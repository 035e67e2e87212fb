"""Sim2real on another rig: the protocol at fault sizes and outer-race positions CWRU's shared records lack.

The CWRU records under ``../shared/data`` are all 0.007 in spalls with the outer-race one at 6
o'clock; a user's bearings, and the private blind set, have other sizes and positions. This
benchmark writes a set of records of the independent test rig (:mod:`bearingtwin.testrig`: an
impulse train through a housing-and-sensor path, no code shared with the twin) in exactly the
CWRU format and naming (MATLAB 5 ``X<nnn>_DE_time`` in g, ``X<nnn>RPM``, ``12k_Drive_End_IR014_2_<nnn>.mat``),
at the CWRU bearing (SKF 6205), speeds (0-3 hp) and sizes (0.007-0.028 in; EDM depth 0.011 in,
0.05 in for 0.028 in) and three outer-race positions, and scores models on them with
``bearingtwin-diagnose``, beside the physics baseline (envelope analysis, no learning):

* ``cwru``: the registered ``+experiment=sim2real`` model (``models:/sim2real@champion``, trained
  on the twin calibrated on CWRU records 97 and 130), unchanged: a model carried to a rig it was
  not calibrated on;
* one per protocol version of ``--protocols`` (default versions 3 and 4), run on this rig as a user
  with the rig would run it: the twin calibrated by ``bearingtwin-twin`` (its defaults) on the rig's 0 hp
  healthy and outer-race (6 o'clock) records (every effect found kept), then
  ``bearingtwin-train +experiment=<version>`` with those records and reports, and its model tested
  on every other record.

The rig's load zone follows its radial load and clearance (a spall outside it is not struck), so
its outer-race positions are 6 o'clock (the load zone's centre), 5 and 4 o'clock (30 and 60
degrees from it), not CWRU's 3 and 12 o'clock, which the rig would not strike at all. Exploratory:
version 4 of the protocol was written after version 3's run here (results/sim2real_protocol.md),
so these records are where version 4's rule was found, not a test of it.

    bearingtwin-train +experiment=sim2real                       # first: the CWRU model (needs ../shared/data/cwru)
    python benchmarks/sim2real_rig.py --out /tmp/sim2real_rig    # records, calibration, training, scoring (~25 min, 2 cores)
    python benchmarks/sim2real_rig.py --out /tmp/sim2real_rig --results results   # also writes results/sim2real_rig.md

Each step is skipped when its output exists in ``--out``, so a finished step is not repeated.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import NoReturn

import numpy as np
import scipy.io

from bearingtwin.config import REPO_ROOT
from bearingtwin.data.cwru import NOMINAL_RPM_BY_LOAD_HP, parse_cwru_name
from bearingtwin.diagnosis.mlflow_model import model_identity
from bearingtwin.testrig import FAULTS, RigOperatingPoint, simulate_rig
from bearingtwin.tracking.tables import markdown_table, write_generated

SIZES_IN = (0.007, 0.014, 0.021, 0.028)
EDM_DEPTH_IN = {0.007: 0.011, 0.014: 0.011, 0.021: 0.011, 0.028: 0.050}
"""The Data Center's EDM pits: 0.011 in deep, 0.050 in for the 0.028 in size."""
OUTER_POSITIONS = {6: 0.0, 5: 30.0, 4: 60.0}
"""o'clock -> the rig's defect angle from the load zone's centre (6 o'clock), degrees."""
CALIBRATION = ("normal_0", "12k_Drive_End_OR007@6_0")
"""The protocol's calibration records: healthy and outer race (6 o'clock) at 0 hp, as CWRU's 97 and 130."""
FIRST_RECORD = 9001
RIG_RUN_METRICS = ("accuracy", "calibration_accuracy", "band_power_kept", "band_power_calibration_accuracy",
                   "lines_only_calibration_accuracy", "cage_lines_kept", "cage_lines_calibration_accuracy",
                   "without_cage_lines_calibration_accuracy")
"""What each protocol's run on the rig scored: its own test windows (1-3 hp, 0.007 in), its calibration
records, and the choices its calibration records made (version 4: the band power; version 8: the cage-rate
lines too)."""
MM_PER_IN = 25.4


def refuse(message: str) -> NoReturn:
    """Stop on bad input: one line on stderr, exit code 2 (as the bearingtwin commands do)."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def rig_records(folder: Path, seed: int) -> list[Path]:
    """Write the rig's records in CWRU format: healthy and every fault, size and position at 0-3 hp."""
    folder.mkdir(parents=True, exist_ok=True)
    # Records already in the folder are reused, so they must come from the same --seed. The stamp is hidden: the
    # folder is diagnosed whole, and a file of one number beside the records is no recording.
    stamp, earlier = folder / ".seed", folder / "seed.txt"  # (seed.txt: the stamp's earlier name)
    if earlier.is_file() and not stamp.is_file():
        earlier.rename(stamp)
    written = stamp.read_text().strip() if stamp.is_file() else ("unknown" if any(folder.glob("*.mat")) else None)
    if written is not None and written != str(seed):
        refuse(f"--out: {folder} holds rig records of --seed {written}, not {seed}; give another --out for another seed")
    stamp.write_text(f"{seed}\n")
    rng = np.random.default_rng(seed)
    plan = [("normal", "normal", None, 0.0)]
    for size in SIZES_IN:
        code = f"{round(size * 1000):03d}"
        plan += [(f"12k_Drive_End_IR{code}", "inner", size, 0.0), (f"12k_Drive_End_B{code}", "ball", size, 0.0)]
        if size < 0.028:  # the Data Center has no 0.028 in outer-race record
            plan += [(f"12k_Drive_End_OR{code}@{clock}", "outer", size, angle) for clock, angle in OUTER_POSITIONS.items()]
    paths, number = [], FIRST_RECORD
    for stem, fault, size, angle in plan:
        for load, rpm in NOMINAL_RPM_BY_LOAD_HP.items():
            # Each record its own operating point: speed near the nominal one, radial load, sensor gain.
            op = RigOperatingPoint(rpm=rpm + rng.normal(0.0, 2.0), fs=12000.0, duration_s=10.0,
                                   radial_load_n=float(rng.uniform(300.0, 700.0)), clearance_um=10.0,
                                   sensor_angle_deg=90.0, defect_width_mm=(size or 0.007) * MM_PER_IN,
                                   defect_depth_mm=EDM_DEPTH_IN[size or 0.007] * MM_PER_IN, defect_angle_deg=angle,
                                   gain=float(10.0 ** rng.uniform(-0.3, 0.3)), unit="g")
            path = folder / f"{stem}_{load}_{number}.mat"
            if not path.is_file():
                signal = simulate_rig(fault, op, seed=number)
                scipy.io.savemat(path, {f"X{number}_DE_time": signal[:, None], f"X{number}RPM": np.array([[round(op.rpm)]])})
            paths.append(path)
            number += 1
    return paths


def require_model(model: str, tracking_uri: str, option: str = "--cwru-model", skip_hint: bool = True) -> None:
    """Stop before any work if ``model`` (given as ``option``) cannot be loaded from ``tracking_uri``."""
    from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model

    try:
        load_diagnosis_model(model, tracking_uri)
    except Exception as error:  # MLflow raises several kinds for a missing model or store
        refuse(f"{option}: {str(error).splitlines()[0]}; run bearingtwin-train +experiment=sim2real first"
               + (f", or pass {option} none" if skip_hint else ""))


def record_named(folder: Path, prefix: str) -> Path:
    """The one record of ``folder`` whose name starts with ``<prefix>_`` (a state and load)."""
    (path,) = [p for p in folder.glob(f"{prefix}_*.mat")]
    return path


def run(command: list[str], log: Path) -> str:
    """Run a bearingtwin command, its output to ``log``; stop with its message if it fails."""
    print("$", " ".join(command), flush=True)
    with open(log, "w") as handle:
        done = subprocess.run(command, stdout=handle, stderr=subprocess.STDOUT, text=True)
    text = log.read_text()
    if done.returncode != 0:
        sys.exit(f"failed (exit {done.returncode}); see {log}:\n" + "\n".join(text.splitlines()[-5:]))
    return text


def calibrate(out: Path, records: Path) -> dict[str, Path]:
    """bearingtwin-twin (its defaults) on the two calibration records, as scripts/cwru_twin_study.py runs it."""
    reports = {}
    for prefix in CALIBRATION:
        path = record_named(records, prefix)
        folder = out / "calibration" / path.stem
        report = folder / "twin_report.json"
        if not report.is_file():
            folder.mkdir(parents=True, exist_ok=True)
            run(["bearingtwin-twin", f"measured.path={path}", "measured.fs=12000", "measured.channel=DE",
                 "bearing=cwru_6205", "twin.duration=2.0", "seed=0", "operating_point.sensor=outer_y",
                 f"out={folder}", f"tracking.uri=sqlite:///{out / 'mlflow.db'}"], folder / "twin.log")
        reports[prefix] = report
    return reports


def train(out: Path, records: Path, reports: dict[str, Path], protocol: str) -> tuple[str, dict]:
    """A protocol version (``+experiment=<protocol>``) on the rig's calibration records: its model's URI and
    the run's metrics."""
    done = out / f"rig_model_{protocol}.json"
    if done.is_file():
        print(f"{protocol}: the model trained on this rig in {out} earlier is kept ({done}; delete it to train again)",
              flush=True)
    else:
        healthy, fault = (record_named(records, prefix).stem for prefix in CALIBRATION)
        text = run(["bearingtwin-train", f"+experiment={protocol}", f"data.root={records}",
                    f'data.calibration.records=[{healthy},"{fault}"]', f'data.calibration.record="{fault}"',
                    f'data.calibration.report="{reports[CALIBRATION[1]]}"', "data.calibration.step=all",
                    f"data.calibration.healthy.record={healthy}",
                    f'data.calibration.healthy.report="{reports[CALIBRATION[0]]}"',
                    "data.calibration.healthy.step=all", "register=null", "register_alias=null",
                    f"tracking.uri=sqlite:///{out / 'mlflow.db'}", f"paths.cache_dir={out / 'cache'}",
                    f"hydra.run.dir={out / ('train_' + protocol)}"], out / f"train_{protocol}.log")
        uri = re.search(r"model: (runs:/\S+)", text)[1]
        from mlflow import MlflowClient

        metrics = MlflowClient(f"sqlite:///{out / 'mlflow.db'}").get_run(uri.split("/")[1]).data.metrics
        done.write_text(json.dumps({"uri": uri, "metrics": metrics}, indent=1))
    saved = json.loads(done.read_text())
    return saved["uri"], saved["metrics"]


def diagnose(out: Path, records: Path, name: str, model: str, tracking_uri: str, log_run: bool) -> list[dict]:
    """bearingtwin-diagnose on every record; the rows of its summary.csv. ``log_run``: also as an MLflow run
    in ``tracking_uri`` (not into a store this benchmark does not own)."""
    folder = out / f"diagnose_{name}"
    done = folder / "done.json"
    asked = {"model": model, "identity": model_identity(model, tracking_uri), "records": str(records)}
    if done.is_file() and json.loads(done.read_text()) == asked:
        print(f"{name}: the diagnoses in {folder} are of this model and these records: kept", flush=True)
    else:  # another model behind the same URI (an alias moved), or none finished: diagnosed again
        shutil.rmtree(folder, ignore_errors=True)
        run(["bearingtwin-diagnose", f"path={records}", f"model={model}", f"out={folder}", "figures=false",
             f"tracking.uri={tracking_uri}", f"tracking.enabled={str(log_run).lower()}"], out / f"diagnose_{name}.log")
        done.write_text(json.dumps(asked))
    with open(folder / "summary.csv") as handle:
        return list(csv.DictReader(handle))


def group(record: str) -> tuple[str, str, str]:
    """(state, size, position) of a record name."""
    name = parse_cwru_name(f"{record}.mat")
    size = "-" if name.fault_size_in is None else f"{name.fault_size_in:.3f} in"
    return name.fault, size, f"{name.position} o'clock" if name.position else "-"


def score_table(scored: dict[str, list[dict]], calibration: set[str]) -> tuple[list[str], list[list[str]], dict]:
    """Records right per state, size and position for each model and the physics, calibration records apart."""
    counts: dict[tuple, dict[str, list[int]]] = defaultdict(lambda: defaultdict(lambda: [0, 0]))
    failed: dict[str, list[str]] = defaultdict(list)
    physics = {row["record"]: row["physics_correct"] == "True" for rows in scored.values() for row in rows
               if not row.get("error") and row["record"] not in calibration}
    for record, right in physics.items():
        counts[group(record)]["physics"][0] += right
        counts[group(record)]["physics"][1] += 1
    for name, rows in scored.items():
        for row in rows:
            if row["record"] in calibration:
                continue
            key = group(row["record"])
            counts[key][name][1] += 1
            if row.get("error"):
                failed[name].append(row["record"])
            else:
                counts[key][name][0] += row["correct"] == "True"
    columns = [*scored, "physics"]
    rows, totals = [], {column: [0, 0] for column in columns}
    for key in sorted(counts, key=lambda k: (FAULTS.index(k[0]), k[1], k[2])):
        cells = []
        for column in columns:
            right, n = counts[key][column]
            totals[column][0] += right
            totals[column][1] += n
            cells.append(f"{right}/{n}")
        rows.append([*key, *cells])
    rows.append(["**all**", "", "", *[f"**{r}/{n}** ({100 * r / n:.0f} %)" for r, n in totals.values()]])
    return columns, rows, {"totals": totals, "failed": dict(failed)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="working folder: records, calibration, training, diagnoses")
    parser.add_argument("--seed", type=int, default=2026, help="the rig set's operating points (records' own seeds follow)")
    parser.add_argument("--cwru-model", default="models:/sim2real@champion",
                        help="the model trained on CWRU (bearingtwin-train +experiment=sim2real); 'none' to skip")
    parser.add_argument("--cwru-tracking-uri",
                        default=os.environ.get("MLFLOW_TRACKING_URI", f"sqlite:///{REPO_ROOT / 'mlruns' / 'mlflow.db'}"),
                        help="the store that holds --cwru-model")
    parser.add_argument("--protocols", default="sim2real_v3,sim2real_v4",
                        help="protocol versions (conf/experiment/<name>.yaml) to run on the rig, comma-separated")
    parser.add_argument("--results", default=None, help="folder to write sim2real_rig.md into (e.g. results)")
    args = parser.parse_args()
    out = Path(args.out).expanduser().resolve()
    started = time.time()
    if args.cwru_model != "none":
        require_model(args.cwru_model, args.cwru_tracking_uri)
    records = out / "records"
    paths = rig_records(records, args.seed)
    print(f"{len(paths)} rig records in {records}")
    reports = calibrate(out, records)
    scored, rig_runs = {}, {}
    if args.cwru_model != "none":
        scored[f"CWRU-calibrated {args.cwru_model}"] = diagnose(out, records, "cwru", args.cwru_model,
                                                                 args.cwru_tracking_uri, False)
    for protocol in args.protocols.split(","):
        uri, metrics = train(out, records, reports, protocol)
        rig_runs[protocol] = {"uri": uri, **{key: metrics.get(key) for key in RIG_RUN_METRICS}}
        scored[f"rig-calibrated {protocol}"] = diagnose(out, records, f"rig_{protocol}", uri,
                                                        f"sqlite:///{out / 'mlflow.db'}", True)
    calibration = {record_named(records, prefix).stem for prefix in CALIBRATION}
    columns, rows, summary = score_table(scored, calibration)
    table = markdown_table(["state", "size", "outer-race position", *[f"{c}: records right" for c in columns]], rows)
    print(table)
    for name, failed in summary["failed"].items():
        print(f"{name}: not diagnosed: {', '.join(failed)}")
    (out / "summary.json").write_text(json.dumps({"columns": columns, "rows": rows, **summary,
                                                  "rig_runs": rig_runs, "cwru_model": args.cwru_model}, indent=1))
    figure = plot_records_right(rows, columns, out / "sim2real_rig.png")
    if args.results:
        results = Path(args.results)
        results.mkdir(parents=True, exist_ok=True)
        figure = Path(shutil.copy(figure, results / figure.name))
        path = results / "sim2real_rig.md"
        generated = results_markdown(table, summary, rig_runs, figure, args)
        write_generated(path, generated, MARKER,
                        heading="# Sim2real on another rig: other fault sizes and outer-race positions (exploratory)")
        print(f"wrote {path} and {figure}")
    print(f"done in {time.time() - started:.0f} s; everything in {out}")


MARKER = "<!-- generated by benchmarks/sim2real_rig.py: text between these lines is rewritten -->"


def results_markdown(table: str, summary: dict, rig_runs: dict, figure: Path, args) -> str:
    """The generated block of results/sim2real_rig.md: the table, the figure, each rig run's own scores, the command."""
    failed = "".join(f"\n\nNot diagnosed ({name}): {', '.join(records)}." for name, records in summary["failed"].items())

    def percent(value) -> str:
        return "-" if value is None else f"{100 * value:.1f} %"

    def choice(run: dict, kept: str, with_it: str, without: str) -> list[str]:
        if run.get(kept) is None:
            return ["-", "-"]
        return ["yes" if run[kept] else "no", f"{percent(run[with_it])} / {percent(run[without])}"]

    runs = markdown_table(
        ["protocol on the rig", "its test windows right (0.007 in, 1-3 hp)", "calibration windows right",
         "band power kept", "calibration windows right with / without band power", "cage-rate lines kept",
         "calibration windows right with / without them"],
        [[protocol, percent(run["accuracy"]), percent(run["calibration_accuracy"]),
          *choice(run, "band_power_kept", "band_power_calibration_accuracy", "lines_only_calibration_accuracy"),
          *choice(run, "cage_lines_kept", "cage_lines_calibration_accuracy", "without_cage_lines_calibration_accuracy")]
         for protocol, run in rig_runs.items()])
    return (
        "Records right (the majority of a record's non-overlapping windows, `bearingtwin-diagnose`'s own scoring) "
        "on the independent test rig's records in CWRU format; the rig's two calibration records (healthy and outer "
        "race at 0 hp) left out.\n\n"
        f"{table}{failed}\n\n![records right by state and size]({figure.name})\n\n"
        f"Each protocol's run on the rig, as `bearingtwin-train` scored it:\n\n{runs}\n"
        "```bash\n"
        "bearingtwin-train +experiment=sim2real          # the CWRU-calibrated model, models:/sim2real@champion\n"
        f"{' '.join(['python', f'benchmarks/{Path(sys.argv[0]).name}', *map(shlex.quote, sys.argv[1:])])}\n"
        "```\n\n"
        f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}."
    )


def plot_records_right(rows: list[list[str]], columns: list[str], path: Path,
                       title: str = "independent test rig, CWRU format: records right by state and fault size") -> Path:
    """Grouped bars: share of records right per state and size (positions pooled), one bar per model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pooled: dict[tuple[str, str], list[list[int]]] = {}
    for row in rows[:-1]:
        key = (row[0], row[1])
        counts = [list(map(int, cell.split("/"))) for cell in row[3:]]
        pooled[key] = [[a + c[0], b + c[1]] for (a, b), c in zip(pooled.get(key, [[0, 0]] * len(counts)), counts)]
    labels = [state if size == "-" else f"{state}\n{size}" for state, size in pooled]
    figure, axes = plt.subplots(figsize=(11, 4.6))
    width = 0.8 / len(columns)
    for i, column in enumerate(columns):
        shares = [100 * counts[i][0] / counts[i][1] for counts in pooled.values()]
        axes.bar(np.arange(len(pooled)) + (i - (len(columns) - 1) / 2) * width, shares, width, label=column)
    axes.set_xticks(np.arange(len(pooled)), labels, fontsize=8)
    axes.set_ylabel("records right %")
    axes.set_ylim(0, 105)
    axes.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=len(columns), frameon=False)
    axes.set_title(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


if __name__ == "__main__":
    main()
