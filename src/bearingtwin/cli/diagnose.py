"""``bearingtwin-diagnose``: diagnose recordings with a trained model from MLflow.

    bearingtwin-diagnose path=<file | folder | glob> model=models:/<name>@<alias> out=<dir>

Writes <out>/<record>/diagnosis.json and diagnosis.png per record, <out>/summary.csv for
several, prints one line per record and a closing summary; logs to MLflow (experiment
``bearingtwin-diagnose``) unless tracking.enabled=false. Exit status 2 when any record could
not be diagnosed (the others are still diagnosed) or the model cannot be used.
"""

from __future__ import annotations

import os
import sys

import hydra
from omegaconf import DictConfig

from bearingtwin.config import CONF_DIR, exit_on_user_error
from bearingtwin.diagnosis.run import diagnose_paths


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="diagnose")
@exit_on_user_error
def main(cfg: DictConfig) -> None:
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")  # one bar: over the files
    run = diagnose_paths(cfg)
    diagnosed = [row for row in run.rows if "error" not in row]
    print(f"\ndiagnosed {len(diagnosed)} of {len(run.rows)} records with {cfg.model}")
    if run.scores:
        print(f"accuracy over {run.scores['n_scored']} records with known state: {run.scores['accuracy_records']:.1%} "
              f"(over their windows: {run.scores['accuracy_windows']:.1%})")
    disagreements = [row["record"] for row in diagnosed if row.get("agree") is False]
    if disagreements:
        print(f"model and physics disagree on: {', '.join(disagreements)}")
    print(f"wrote {run.out}/")
    if run.run_id:
        print(f"MLflow run {run.run_id}: mlflow ui --backend-store-uri {cfg.tracking.uri}")
    if run.failures:
        for name, reason in run.failures.items():
            print(f"error: {name}: {reason}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
