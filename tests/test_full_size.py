"""Full-size checks (``python -m pytest -m slow``): what the README promises a newcomer, at the size it says."""

import re
import subprocess
import sys

import pytest
from mlflow import MlflowClient


@pytest.mark.slow
def test_the_main_job_prints_the_accuracy_the_readme_shows(tmp_path):
    """``bearingtwin-train`` as the README's first set-up command runs it: the paper's method on the
    full simulated dataset, seed 0 (results/table4.md's seed 0). The network trains on one thread on any
    machine, so the accuracy is the README's to the digit."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    done = subprocess.run([sys.executable, "-m", "bearingtwin.cli.train", f"tracking.uri={uri}"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "== bearingtwin-train: sabo_vmd_pemie+cnn_bilstm simulated global seed=0 ==" in done.stdout
    from bearingtwin.config import REPO_ROOT

    promised = re.search(r"accuracy: ([\d.]+) %", (REPO_ROOT / "README.md").read_text())[1]
    assert f"accuracy: {promised} %" in done.stdout, done.stdout
    run_id = re.search(r"MLflow run: (\w+)", done.stdout)[1]
    assert MlflowClient(uri).get_run(run_id).data.metrics["n_test"] == 180  # 30 % of 4 x 150 windows
