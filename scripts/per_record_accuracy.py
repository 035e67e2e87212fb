"""Test accuracy of each test record over seeds, for any training config: which file fails.

Runs ``bearingtwin.models.experiment.run_experiment`` (the code path of ``bearingtwin-train``,
without tracking) once per seed and prints a markdown table, one row per record. Each run's
``per_record.csv`` artifact in MLflow holds the same numbers for one seed.

    python scripts/per_record_accuracy.py --seeds 0 1 2 3 4 -- +sweep=sim2real_variants \\
        features=envelope_prominence classifier.kernel=linear data.calibration.healthy.step=1 data.calibration.step=3
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.models.experiment import run_experiment
from bearingtwin.tracking.tables import markdown_table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of conf/train.yaml")
    args = parser.parse_args()
    per_record: dict[tuple[str, str], list[float]] = {}
    accuracies = []
    for seed in args.seeds:
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            cfg = compose("train", overrides=[*args.overrides, f"seed={seed}"])
        with tempfile.TemporaryDirectory() as root_dir:
            result = run_experiment(cfg, root_dir=root_dir)
        accuracies.append(result.metrics["accuracy"])
        for row in result.per_record:
            per_record.setdefault((row["record"], row["class"]), []).append(row["accuracy"])
        print(f"seed {seed}: accuracy {100 * accuracies[-1]:.2f} %", flush=True)
    rows = [[record, name, f"{100 * np.mean(values):.1f}", len(values)] for (record, name), values in per_record.items()]
    print(f"\noverall {100 * np.mean(accuracies):.2f} ± {100 * np.std(accuracies):.2f} %\n")
    print(markdown_table(["record", "class", "accuracy % (mean over seeds)", "seeds"], rows))


if __name__ == "__main__":
    main()
