"""``bearingtwin-twin``: compare the twin with a measurement, calibrate it, rank the effects it misses.

    bearingtwin-twin measured.path=<file> measured.fs=12000 measured.rpm=1797 measured.fault=outer out=<dir>

Writes <dir>/twin_report.json (baseline_error, ranking, steps, final_error, summary) and
PNG figures beside it; logs them to MLflow unless tracking.enabled=false.
"""

from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from bearingtwin.config import CONF_DIR, exit_on_user_error, refuse_unknown_keys
from bearingtwin.tracking.lifecycle import stop_cleanly
from bearingtwin.twin.report import run_twin


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="twin")
@exit_on_user_error
def twin(cfg: DictConfig) -> None:
    refuse_unknown_keys(HydraConfig.get())
    fit, files = run_twin(cfg)
    print(fit.summary)
    print(f"wrote {files[0]} and {len(files) - 1} figures")


main = stop_cleanly(twin)  # a signal marks the MLflow run KILLED, never left RUNNING


if __name__ == "__main__":
    main()
