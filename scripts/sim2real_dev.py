"""Development check of a sim2real protocol candidate, on records the protocol never tests.

    python scripts/sim2real_dev.py --seeds 0 1 -- +experiment=sim2real_v1
    python scripts/sim2real_dev.py --seeds 0 1 -- +experiment=sim2real_v1 data.window_length=4096 ...

Every CWRU fault record at 1-3 hp is a test record of the protocol, and records 97 (healthy) and
130 (outer race) at 0 hp calibrate the twin. The two fault records left, the inner race (105) and
the ball (118) at 0 hp, are where a candidate change can be judged without looking at a test
record; record 97's windows show false alarms. For each seed the candidate is trained (its output,
which scores the test records, is written to the work folder, not printed), registered in a
temporary MLflow store and applied by ``bearingtwin-diagnose`` to the 0 hp records; the windows
it gets right are printed per record, and beside them the windows right when a window starts every
``--hop`` samples (overlapping windows: several times as many readings of the same record, so a
difference between candidates is less the luck of where the windows fall). Twin simulations are cached in ``BEARINGTWIN_CACHE`` as for
any training run, so candidates that share a twin simulate it once.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from bearingtwin.config import data_root

DEV_RECORDS = "*_0_*.mat"  # 105 inner, 118 ball (development), 97 healthy (false alarms), 130 outer (calibration)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--data", default=str(data_root() / "cwru"),
                        help="folder of the CWRU .mat files (default: $BEARINGTWIN_DATA/cwru, as training reads them)")
    parser.add_argument("--work", default=None, help="folder for the store, logs and diagnoses (default: a temporary one)")
    parser.add_argument("--hop", type=int, default=1024, help="samples between the starts of the dense reading's windows")
    parser.add_argument("overrides", nargs="+", help="bearingtwin-train overrides of the candidate (after --)")
    args = parser.parse_args()
    if args.hop < 1:
        parser.error(f"--hop must be a positive number of samples, got {args.hop}")
    work = Path(args.work or tempfile.mkdtemp(prefix="sim2real-dev-"))
    work.mkdir(parents=True, exist_ok=True)
    # Training reads the records through paths.data_root: the same folder as the diagnosis.
    env = {**os.environ, "MLFLOW_TRACKING_URI": f"sqlite:///{work / 'mlflow.db'}",
           "BEARINGTWIN_DATA": str(Path(args.data).resolve().parent)}
    rows = []
    for seed in args.seeds:
        train = ["bearingtwin-train", *args.overrides, f"seed={seed}", "register=dev", f"register_alias=seed{seed}"]
        with open(work / f"train_seed{seed}.log", "w") as log:
            if subprocess.run(train, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=work).returncode:
                print(f"training failed for seed {seed}: {work / f'train_seed{seed}.log'}", file=sys.stderr)
                return 1
        out = work / f"diagnosis_seed{seed}"
        diagnose = ["bearingtwin-diagnose", f'path="{Path(args.data) / DEV_RECORDS}"', f"model=models:/dev@seed{seed}",
                    f"out={out}", "figures=false"]
        with open(work / f"diagnose_seed{seed}.log", "w") as log:
            if subprocess.run(diagnose, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=work).returncode:
                print(f"diagnosis failed for seed {seed}: {work / f'diagnose_seed{seed}.log'}", file=sys.stderr)
                return 1
        dense = dense_reading(f"models:/dev@seed{seed}", env["MLFLOW_TRACKING_URI"], Path(args.data), args.hop)
        for path in sorted(out.glob("*/diagnosis.json")):
            found = json.loads(path.read_text())
            right = sum(window["state"] == found["true_state"] for window in found["windows"]) / len(found["windows"])
            rows.append((seed, found["record"], found["true_state"], found["verdict"], right, len(found["windows"]),
                         *dense[Path(found["record"]).stem]))
    print(f"candidate: {' '.join(args.overrides)}")
    print(f"seed  record                          true    verdict  windows right      every {args.hop} samples")
    for seed, record, true, verdict, right, n, dense_right, dense_n in rows:
        print(f"{seed:>4}  {record:<30}  {true:<6}  {verdict:<7}  {100 * right:5.1f} % of {n:<4}  {100 * dense_right:5.1f} % of {dense_n}")
    print(f"work folder: {work}")
    return 0


def dense_reading(model_uri: str, tracking_uri: str, data: Path, hop: int) -> dict[str, tuple[float, int]]:
    """Record stem -> (share of windows right, windows) with a window starting every ``hop`` samples,
    the model's own pipeline applied as a diagnosis applies it."""
    from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model
    from bearingtwin.diagnosis.record import read_record

    _, pipeline, _ = load_diagnosis_model(model_uri, tracking_uri)
    shares = {}
    for path in sorted(data.glob(DEV_RECORDS)):
        prepared = read_record(path, pipeline)
        if prepared.gaps_s or prepared.dropouts_s:  # a diagnosis leaves the windows touching them out; this cuts all
            print(f"error: {path}: samples with no value (NaN) or a dropout; the dense reading needs records without "
                  "either", file=sys.stderr)
            sys.exit(2)
        signal = prepared.recording.signal
        starts = np.arange(0, signal.size - pipeline.window_length + 1, hop)
        states, _ = pipeline.predict(signal[starts[:, None] + np.arange(pipeline.window_length)], prepared.recording.rpm,
                                     prepared.bearing)
        shares[path.stem] = (float(np.mean(states == prepared.true_state)), len(starts))
    return shares


if __name__ == "__main__":
    sys.exit(main())
