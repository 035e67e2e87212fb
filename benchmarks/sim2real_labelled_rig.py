"""Sim2real on a rig of another bearing, rate and unit, through a labels table: the protocol as a user runs it.

``benchmarks/sim2real_rig.py`` meets the independent test rig in CWRU's own format, bearing and rate.
A user's rig is none of those: here the rig (:mod:`bearingtwin.testrig`, sharing no code with the twin)
carries an ER-16K (the HUST bearing, ``conf/bearing/er16k.yaml``), is sampled at 25.6 kHz in m/s^2, and
writes plain ``.npy`` files whose states, speeds and rates only a ``labels.csv`` states (the nominal speed,
as HUST's file names give it; each record runs within a few rpm of it), at four shaft speeds (20-35 Hz), the HUST damage sizes (races 0.15 and 0.3 mm, balls 0.25 and 0.5 mm) and two outer-race
positions (the load zone's centre and 30 degrees from it). The protocol (``+experiment=sim2real``,
unchanged) is run exactly as docs/guide.md "Your own rig" runs it:

1. ``bearingtwin-twin`` on the healthy and the medium outer-race record at the lowest speed (the sensor
   known to sit vertically on the housing, everything else fitted);
2. ``bearingtwin-train +experiment=sim2real data.labels=...`` with those two records' reports, every effect
   they found kept; every other labelled record is a test record;
3. ``bearingtwin-diagnose`` on every record with the trained model, the physics baseline beside it.

Fixed before its run: the rig's settings above, the calibration records, the protocol's own config; the
numbers are what one run gives (exploratory: one rig, one seed).

    python benchmarks/sim2real_labelled_rig.py --out /tmp/labelled_rig                    # ~7 min from an empty --out, 2 cores
    python benchmarks/sim2real_labelled_rig.py --out /tmp/labelled_rig --results results  # also writes results/sim2real_labelled_rig.md
    python benchmarks/sim2real_labelled_rig.py --out /tmp/labelled_rig_v7 --protocol sim2real_v7  # another protocol version

Each step is skipped when its output exists in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import shutil
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from bearingtwin.storage import save_npy_atomic
from bearingtwin.testrig import FAULTS, RigOperatingPoint, simulate_rig
from bearingtwin.testrig.geometry import RigBearing
from bearingtwin.testrig.rig import RigSetup
from bearingtwin.tracking.tables import markdown_table, write_generated
from sim2real_rig import plot_records_right, refuse, run

FS_HZ = 25600.0
DURATION_S = 10.0
SPEEDS_HZ = (20.0, 25.0, 30.0, 35.0)
SIZES_MM = {"medium": {"inner": 0.15, "outer": 0.15, "ball": 0.25}, "severe": {"inner": 0.3, "outer": 0.3, "ball": 0.5}}
"""Spall width by damage grade and state: the HUST data set's (0.5X_ prefix = medium)."""
OUTER_POSITIONS_DEG = (0.0, 30.0)
"""Outer-race spall from the load zone's centre."""
RIG = RigSetup(bearing=RigBearing(n_balls=9, ball_diameter_mm=7.94, pitch_diameter_mm=38.52))
"""The ER-16K of conf/bearing/er16k.yaml."""
CALIBRATION = ("H_20Hz", "0.5X_O0_20Hz")
"""The healthy and the medium outer-race (load zone's centre) record at the lowest speed."""
MODEL = "labelled_rig"


def write_records(folder: Path, seed: int) -> dict[str, dict]:
    """The rig's records as .npy files and their labels.csv; what each record is, by stem."""
    folder.mkdir(parents=True, exist_ok=True)
    plan = [("H", "normal", "-", None)]
    for grade, prefix in (("medium", "0.5X_"), ("severe", "")):
        plan += [(f"{prefix}I", "inner", grade, None), (f"{prefix}B", "ball", grade, None)]
        plan += [(f"{prefix}O{angle:.0f}", "outer", grade, angle) for angle in OUTER_POSITIONS_DEG]
    rng = np.random.default_rng(seed)
    records, rows, number = {}, [], 0
    for code, state, grade, angle in plan:
        for speed in SPEEDS_HZ:
            stem = f"{code}_{speed:.0f}Hz"
            width = SIZES_MM[grade][state] if state != "normal" else 0.15
            op = RigOperatingPoint(rpm=60.0 * speed + rng.normal(0.0, 2.0), fs=FS_HZ, duration_s=DURATION_S,
                                   radial_load_n=float(rng.uniform(300.0, 700.0)), clearance_um=10.0,
                                   sensor_angle_deg=90.0, defect_width_mm=width, defect_depth_mm=0.1,
                                   defect_angle_deg=angle or 0.0, gain=float(10.0 ** rng.uniform(-0.3, 0.3)),
                                   unit="m/s^2")
            path = folder / f"{stem}.npy"
            if not path.is_file():  # written whole or not at all: an interrupted run leaves no short record
                save_npy_atomic(path, simulate_rig(state, op, seed=seed + number, setup=RIG))
            # The table gives the nominal speed, as HUST's file names do (its speed column is not meaningful).
            records[stem] = {"state": state, "grade": grade, "position": "-" if angle is None else f"{angle:g} deg",
                             "rpm": 60.0 * speed}
            rows.append(f"{path.name},{state},{60.0 * speed:g},{FS_HZ:g}")
            number += 1
    (folder / "labels.csv").write_text("record,state,rpm,fs\n" + "\n".join(rows) + "\n")
    return records


def calibrate(out: Path, records: Path, plan: dict[str, dict]) -> dict[str, Path]:
    """bearingtwin-twin on the two calibration records, the housing sensor's direction known."""
    reports = {}
    for stem in CALIBRATION:
        folder = out / "calibration" / stem
        report = folder / "twin_report.json"
        if not report.is_file():
            folder.mkdir(parents=True, exist_ok=True)
            run(["bearingtwin-twin", f"measured.path={records / (stem + '.npy')}", f"measured.fs={FS_HZ:g}",
                 f"measured.rpm={plan[stem]['rpm']}", f"measured.fault={plan[stem]['state']}", "bearing=er16k",
                 "twin.duration=2.0", "seed=0", "operating_point.sensor=outer_y", f"out={folder}",
                 "tracking.enabled=false"], folder / "twin.log")
        reports[stem] = report
    return reports


def train(out: Path, records: Path, reports: dict[str, Path], protocol: str) -> tuple[str, str]:
    """The protocol (``+experiment=<protocol>``) in labels mode; the registered model's URI and the training summary."""
    log = out / "train.log"
    if not log.is_file() or "model:" not in log.read_text():
        shutil.rmtree(out / "diagnose", ignore_errors=True)  # the diagnosis of an earlier model
        healthy, fault = CALIBRATION
        run(["bearingtwin-train", f"+experiment={protocol}", f"data.root={records}", f"data.labels={records / 'labels.csv'}",
             "data.channel=null", "bearing=er16k", "data.bearing=er16k", f"data.fs={FS_HZ:g}",
             f'data.calibration.records=[{healthy},"{fault}"]', f'data.calibration.record="{fault}"',
             f'data.calibration.report="{reports[fault]}"', "data.calibration.step=all",
             f"data.calibration.healthy.record={healthy}", f'data.calibration.healthy.report="{reports[healthy]}"',
             "data.calibration.healthy.step=all", f"register={MODEL}",
             f"tracking.uri=sqlite:///{out / 'mlflow.db'}", f"paths.cache_dir={out / 'cache'}",
             f"hydra.run.dir={out / 'train'}"], log)
    text = log.read_text()
    summary = text[text.index("== bearingtwin-train"):] if "== bearingtwin-train" in text else text[-2000:]
    return f"models:/{MODEL}@champion", summary


def diagnose(out: Path, records: Path, model: str) -> list[dict]:
    """bearingtwin-diagnose on every record (labels.csv gives their states); the rows of its summary.csv."""
    folder = out / "diagnose"
    if not (folder / "summary.csv").is_file():
        run(["bearingtwin-diagnose", f"path={records}", f"model={model}", f"out={folder}", "figures=false",
             f"tracking.uri=sqlite:///{out / 'mlflow.db'}"], out / "diagnose.log")
    with open(folder / "summary.csv") as handle:
        return list(csv.DictReader(handle))


def score_table(rows: list[dict], plan: dict[str, dict]) -> tuple[str, list[list[str]], dict]:
    """Records right per state, damage and position, model against physics, the calibration records apart."""
    counts: dict[tuple, list[int]] = defaultdict(lambda: [0, 0, 0, 0])
    for row in rows:
        if row["record"] in CALIBRATION or row.get("error"):
            continue
        what = plan[row["record"]]
        cell = counts[(what["state"], what["grade"], what["position"])]
        cell[0] += row["correct"] == "True"
        cell[1] += 1
        cell[2] += row["physics_correct"] == "True"
        cell[3] += 1
    table, totals = [], [0, 0, 0, 0]
    for key in sorted(counts, key=lambda k: (FAULTS.index(k[0]), k[1], k[2])):
        right, n, physics, n_physics = counts[key]
        totals = [a + b for a, b in zip(totals, counts[key])]
        table.append([*key, f"{right}/{n}", f"{physics}/{n_physics}"])
    table.append(["**all**", "", "", f"**{totals[0]}/{totals[1]}** ({100 * totals[0] / max(totals[1], 1):.0f} %)",
                  f"**{totals[2]}/{totals[3]}** ({100 * totals[2] / max(totals[3], 1):.0f} %)"])
    failed = [row["record"] for row in rows if row.get("error")]
    header = ["state", "damage", "outer-race position", "model: records right", "physics: records right"]
    return markdown_table(header, table), table, {"totals": totals, "failed": failed}


MARKER = "<!-- generated by benchmarks/sim2real_labelled_rig.py: text between these lines is rewritten -->"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="working folder: records, calibration, training, diagnosis")
    parser.add_argument("--seed", type=int, default=2026, help="the rig's operating points and records")
    parser.add_argument("--protocol", default="sim2real",
                        help="the protocol version trained (+experiment=<it>): sim2real, the one in force, or sim2real_v<N>")
    parser.add_argument("--results", default=None, help="folder to write sim2real_labelled_rig.md into (e.g. results)")
    args = parser.parse_args()
    out = Path(args.out).expanduser().resolve()
    records = out / "records"
    if args.results and args.protocol != "sim2real":
        refuse("--results writes the page of the protocol in force: drop --protocol, or --results")
    if (out / "train.log").is_file() and not (out / "protocol.txt").is_file():
        (out / "protocol.txt").write_text("sim2real\n")  # trained before --protocol existed: by the one in force
    for option, value in (("seed", str(args.seed)), ("protocol", args.protocol)):
        if (out / f"{option}.txt").is_file() and (out / f"{option}.txt").read_text().strip() != value:
            refuse(f"--out: {out} holds the run of another --{option}; give another --out")
    out.mkdir(parents=True, exist_ok=True)
    (out / "seed.txt").write_text(f"{args.seed}\n")
    (out / "protocol.txt").write_text(f"{args.protocol}\n")
    started = time.time()
    plan = write_records(records, args.seed)
    print(f"{len(plan)} rig records in {records}")
    reports = calibrate(out, records, plan)
    model, training = train(out, records, reports, args.protocol)
    rows = diagnose(out, records, model)
    table, table_rows, summary = score_table(rows, plan)
    print(table)
    if summary["failed"]:
        print(f"not diagnosed: {', '.join(summary['failed'])}")
    found = {stem: _effects_found(reports[stem]) for stem in CALIBRATION}
    (out / "summary.json").write_text(json.dumps({**summary, "protocol": args.protocol, "calibration_effects": found}, indent=1))
    figure = plot_records_right(table_rows, ["model (twin-trained)", "physics (envelope analysis)"],
                                out / "sim2real_labelled_rig.png",
                                title="ER-16K rig at 25.6 kHz, read through a labels table: records right by state and damage")
    if args.results:
        Path(args.results).mkdir(parents=True, exist_ok=True)
        figure = Path(shutil.copy(figure, Path(args.results) / figure.name))
        path = Path(args.results) / "sim2real_labelled_rig.md"
        command = f"python benchmarks/sim2real_labelled_rig.py --out {args.out} --seed {args.seed} --results {args.results}"
        block = (f"Records right (the majority of a record's windows, `bearingtwin-diagnose`'s scoring) on the rig's "
                 f"{len(plan) - len(CALIBRATION)} test records; the two calibration records left out.\n\n{table}\n\n"
                 + (f"Not diagnosed: {', '.join(summary['failed'])}.\n\n" if summary["failed"] else "")
                 + f"![records right by state and damage]({figure.name})\n\n"
                 f"Effects `bearingtwin-twin` found on the calibration records: "
                 + "; ".join(f"{stem}: {', '.join(effects) or 'none'}" for stem, effects in found.items())
                 + f".\n\nThe training run's summary:\n\n```text\n{training.strip()}\n```\n\n```bash\n{command}\n```\n\n"
                 f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}.\n")
        write_generated(path, block, MARKER, heading="# Sim2real on a rig of another bearing, rate and unit (exploratory)")
        print(f"wrote {path}")
    print(f"done in {time.time() - started:.0f} s; everything in {out}")


def _effects_found(report: Path) -> list[str]:
    return list(json.loads(report.read_text())["added"])


if __name__ == "__main__":
    sys.exit(main())
