"""Order tracking in a diagnosis: what a drifting shaft speed does to the physics evidence, what steadying the record
gives back, and what it costs.

Each CWRU drive-end record at 12 kHz (the nine 0.007 in fault records at 1-3 hp, and the healthy 0 hp one) is
re-timed so that its shaft speed swings by +-2, +-4 or +-8 % once over the record (a fan or conveyor under a changing
load), or runs up linearly by 16 % of its speed (-8 % to +8 % of the stated one). The envelope spectrum's evidence
(bearingtwin.diagnosis.evidence.physics_evidence, the diagnosis' defaults) is read on each record as recorded and
as `bearingtwin-diagnose` reads it (diagnosis.record.steadied: the speed read from the shaft series, the record
tracked where it spreads by more than 2 % and its shaft series stands sharper tracked, then read at its mean speed). The steady records (no drift) say whether tracking leaves them alone.
Time: reading the speed (speed_profile) and steadying the record as a diagnosis does (steadied: tracking, the second
pass, the sharpness check) on a 10 s record at 12 kHz and a 245 s one at 51.2 kHz, in this process.

    python benchmarks/order_tracking.py            # about 15 s
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
import scipy.signal
from scipy.interpolate import CubicSpline

from bearingtwin.config import REPO_ROOT, bearing_config
from bearingtwin.data.formats import load_recording
from bearingtwin.data.recording import Recording
from bearingtwin.diagnosis.evidence import physics_evidence
from bearingtwin.diagnosis.record import steadied
from bearingtwin.signal.speed import UNSTEADY, speed_profile

RECORDS = ["12k_Drive_End_IR007_1_106", "12k_Drive_End_IR007_2_107", "12k_Drive_End_IR007_3_108",
           "12k_Drive_End_B007_1_119", "12k_Drive_End_B007_2_120", "12k_Drive_End_B007_3_121",
           "12k_Drive_End_OR007@6_1_131", "12k_Drive_End_OR007@6_2_132", "12k_Drive_End_OR007@6_3_133", "normal_0_97"]
DRIFTS = {"steady": None, "+-2 %": 0.02, "+-4 %": 0.04, "+-8 %": 0.08, "run-up 16 %": "run-up"}


def retimed(signal: np.ndarray, fs: float, drift) -> np.ndarray:
    """``signal`` as recorded by a shaft whose speed, relative to the recorded one, follows ``drift``: a sine of that
    depth over the record, or a linear run-up from 0.92 to 1.08 (the record is read up to 8 % ahead, so it ends
    early)."""
    if drift is None:
        return signal
    t = np.arange(int(signal.size / 1.09)) / fs
    ratio = (0.92 + 0.16 * t / t[-1]) if drift == "run-up" else 1 + drift * np.sin(2 * np.pi * t / t[-1])
    recorded_at = np.concatenate([[0.0], np.cumsum((ratio[1:] + ratio[:-1]) / 2) / fs])
    return CubicSpline(np.arange(signal.size) / fs, signal)(recorded_at)


def truth(name: str) -> str:
    return "normal" if name.startswith("normal") else {"IR": "inner", "B0": "ball", "OR": "outer"}[name.split("_")[3][:2]]


def accuracy(data_root: Path) -> list[list[str]]:
    bearing = bearing_config("cwru_6205")
    rows = []
    for label, drift in DRIFTS.items():
        right = {"as recorded": 0, "steadied": 0}
        tracked, lines, gains = 0, {"as recorded": [], "steadied": []}, []
        for name in RECORDS:
            recording = load_recording(data_root / f"{name}.mat")
            signal = retimed(recording.signal, recording.fs, drift)
            made = Recording(signal, recording.fs, rpm=recording.rpm, source=name)
            steady, _, speed, _ = steadied(made, True, UNSTEADY)
            tracked += speed["tracked"]
            if speed.get("sharpening") is not None:
                gains.append(speed["sharpening"])
            for how, x, rpm in (("as recorded", signal, recording.rpm), ("steadied", steady.signal, steady.rpm)):
                evidence = physics_evidence(x, recording.fs, rpm, bearing)
                right[how] += evidence.evidence_state == truth(name)
                if truth(name) in ("inner", "outer"):  # the races' lines: how far they stand over their floor
                    lines[how].append(evidence.prominence_db[truth(name)])
        rows.append([label, f"{tracked}/{len(RECORDS)}", f"{right['as recorded']}/{len(RECORDS)}",
                     f"{right['steadied']}/{len(RECORDS)}", f"{np.median(lines['as recorded']):.1f}",
                     f"{np.median(lines['steadied']):.1f}",
                     f"{min(gains):.2g}-{max(gains):.2g}" if gains else "—"])
    return rows


def timing(data_root: Path) -> list[list[str]]:
    recording = load_recording(data_root / "12k_Drive_End_OR007@6_1_131.mat")
    ten_s = retimed(recording.signal, recording.fs, 0.04)
    long = np.tile(scipy.signal.resample_poly(recording.signal, 64, 15), 24)  # 51.2 kHz, about 240 s
    rows = []
    long = retimed(long, 51200.0, 0.04)  # drifting: steadied as a diagnosis steadies it
    for label, x, fs in (("10 s at 12 kHz", ten_s, recording.fs), (f"{long.size / 51200:.0f} s at 51.2 kHz", long, 51200.0)):
        start = time.perf_counter()
        speed_profile(x, fs, recording.rpm)
        read = time.perf_counter() - start
        start = time.perf_counter()
        _, _, speed, _ = steadied(Recording(x, fs, rpm=recording.rpm, source=label), True, UNSTEADY)
        steady = time.perf_counter() - start
        rows.append([label, f"{read:.2f}", f"{steady:.2f}" + ("" if speed["tracked"] else " (not tracked)")])
    return rows


def table(header: list[str], rows: list[list[str]]) -> str:
    return "\n".join(["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
                     + ["| " + " | ".join(row) + " |" for row in rows])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("BEARINGTWIN_DATA", REPO_ROOT.parent / "shared" / "data")))
    args = parser.parse_args()
    data_root = args.data / "cwru"
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}\n")
    print(table(["drift of the shaft speed", "records tracked", "physics right as recorded", "physics right steadied",
                 "race lines, dB over floor, as recorded (median)", "steadied", "shaft series' sharpening"],
                accuracy(data_root)))
    print()
    print(table(["record (drifting +-4 %)", "reading the speed, s", "steadying it, s"], timing(data_root)))


if __name__ == "__main__":
    main()
