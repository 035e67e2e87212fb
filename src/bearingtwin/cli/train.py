"""``bearingtwin-train``: train a classifier on a dataset's features and log the run to MLflow.

Single run: ``bearingtwin-train classifier=svm seed=3``. Sweep: ``bearingtwin-train -m
+sweep=table4`` (add ``hydra/launcher=joblib`` or ``launcher=joblib`` to run jobs in
parallel). A failing job in a sweep is logged FAILED and the sweep goes on.
"""

from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.config import CONF_DIR, exit_on_user_error
from bearingtwin.models.experiment import run_experiment
from bearingtwin.tracking.mlflow_logging import sweep_info, train_tracked


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="train")
def main(cfg: DictConfig) -> float | None:
    hydra_cfg = HydraConfig.get()
    metrics = exit_on_user_error(train_tracked)(
        cfg, dict(hydra_cfg.runtime.choices), sweep_info(hydra_cfg), hydra_cfg.runtime.output_dir, run_experiment
    )
    return None if metrics is None else metrics.get("accuracy")


if __name__ == "__main__":
    main()
