"""``bearingtwin-train``: train a classifier on a dataset's features and log the run to MLflow.

Single run: ``bearingtwin-train classifier=svm seed=3``. Sweep: ``bearingtwin-train -m
+sweep=table4`` (add ``hydra/launcher=joblib`` or ``launcher=joblib`` to run jobs in
parallel). A failing job in a sweep is logged FAILED and the sweep goes on.

Data files a config names (HUST) are checked before any MLflow run is opened: a single run
checks its own, a sweep whose ``mlflow_sweep`` callback is :class:`DataCheckedSweepParentRun`
(``sweeps/hust.yaml``) checks every job's at its start. Absent files end the command with
exit status 2 and a message naming them and ``data.root=``, leaving the store untouched.
"""

from __future__ import annotations

from typing import Iterator

import hydra
from hydra._internal.core_plugins.basic_sweeper import BasicSweeper  # its job expansion, reused as is
from hydra.core.global_hydra import GlobalHydra
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig

from bearingtwin.config import CONF_DIR, exit_on_user_error
from bearingtwin.data.build import require_files
from bearingtwin.models.experiment import run_experiment
from bearingtwin.tracking.mlflow_logging import SweepParentRun, sweep_info, train_tracked


def sweep_job_configs(config: DictConfig) -> Iterator[DictConfig]:
    """Every job's composed config, expanded and composed as Hydra's basic sweeper does."""
    params = [f"{key}={value}" for key, value in (config.hydra.sweeper.get("params") or {}).items()]
    overrides = OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task))
    loader = GlobalHydra.instance().config_loader()
    for batch in BasicSweeper.split_arguments(overrides, None):
        for job in batch:
            yield loader.load_sweep_config(config, list(job))


class DataCheckedSweepParentRun(SweepParentRun):
    """The sweep's parent run, opened only once every job's data files are present.

    Exits (status 2, not an exception: Hydra turns a callback's exception into a warning and
    would go on) before the parent run exists, so a sweep on absent data logs nothing.
    """

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        exit_on_user_error(require_files)(sweep_job_configs(config))
        super().on_multirun_start(config, **kwargs)


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="train")
def main(cfg: DictConfig) -> float | None:
    hydra_cfg = HydraConfig.get()
    sweep = sweep_info(hydra_cfg)
    if sweep is None:
        exit_on_user_error(require_files)([cfg])
    metrics = exit_on_user_error(train_tracked)(cfg, dict(hydra_cfg.runtime.choices), sweep, hydra_cfg.runtime.output_dir, run_experiment)
    return None if metrics is None else metrics.get("accuracy")


if __name__ == "__main__":
    main()
