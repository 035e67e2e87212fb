"""``bearingtwin-train``: train a classifier on a dataset's features and log the run to MLflow.

Single run: ``bearingtwin-train classifier=svm seed=3``. Sweep: ``bearingtwin-train -m
+sweep=table4`` (add ``hydra/launcher=joblib`` or ``launcher=joblib`` to run jobs in
parallel). A failing job in a sweep is logged FAILED and the sweep goes on.

Data files a config names are checked before any MLflow run is opened: a single run checks
its own here, a sweep checks every job's in :class:`SweepParentRun`. Absent files end the
command with exit status 2 and a message naming them and ``data.root=``.

Exit status: 0 when the run (every job of a sweep) finished or was skipped as already
finished; 1 when a sweep job failed (after all jobs ran, with a summary); 2 for bad input;
130 / 143 on SIGINT / SIGTERM, with the open runs marked KILLED.
"""

from __future__ import annotations

import logging

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.config import CONF_DIR, exit_on_user_error, refuse_unknown_keys
from bearingtwin.data.build import require_files
from bearingtwin.models.experiment import run_experiment
from bearingtwin.tracking.lifecycle import stop_cleanly, watch_sweep_process
from bearingtwin.tracking.mlflow_logging import sweep_info, train_tracked

log = logging.getLogger(__name__)


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="train")
def train(cfg: DictConfig) -> float | None:
    hydra_cfg = HydraConfig.get()
    sweep = sweep_info(hydra_cfg)
    if sweep is None:  # a sweep checks every job's before the first starts (SweepParentRun)
        exit_on_user_error(refuse_unknown_keys)(hydra_cfg)
        exit_on_user_error(require_files)([cfg])
        metrics = exit_on_user_error(train_tracked)(cfg, dict(hydra_cfg.runtime.choices), None, hydra_cfg.runtime.output_dir, run_experiment)
    else:
        watch_sweep_process()
        try:
            metrics = train_tracked(cfg, dict(hydra_cfg.runtime.choices), sweep, hydra_cfg.runtime.output_dir, run_experiment)
        except Exception as error:  # before its run existed: Hydra would end the sweep here, without a summary
            log.error("job %s did not start its run: %s: %s (the sweep goes on)", hydra_cfg.job.num, type(error).__name__, error)
            return None
    return None if metrics is None else metrics.get("accuracy")


main = stop_cleanly(train)


if __name__ == "__main__":
    main()
