"""Sweeps through submitit (the ``slurm`` extra): the SLURM submission a sweep makes, and a real local sweep.

``launcher=submitit_slurm`` needs a cluster to run, not to submit: stand-ins for SLURM's commands on
PATH take the submission file and refuse it, and the test reads what a cluster would have been given. ``launcher=submitit_local`` runs a 2-job multirun for real, each job in a process of its own.
Skipped without the extra.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mlflow import MlflowClient
from processes import SMOKE, child_env, run_module

pytestmark = pytest.mark.skipif(importlib.util.find_spec("hydra_plugins.hydra_submitit_launcher") is None,
                                reason='the slurm extra is not installed (pip install -c requirements.lock -e ".[slurm]")')

SWEEP = ["seed=0,1", "classifier=svm", *SMOKE]
TIMEOUT_S = 600
# Stand-ins for SLURM's commands: sbatch keeps the file it is given, then refuses it as a cluster that
# cannot take the job would; srun only has to exist (submitit looks for it to tell it is on a cluster).
STAND_INS = {
    "sbatch": 'cp "$1" "$SBATCH_CAPTURE"\necho "sbatch: error: no cluster here (a test stand-in)" >&2\nexit 1\n',
    "srun": 'echo "srun: a test stand-in, never to be run" >&2\nexit 1\n',
}


def sweep(folder: Path, env: dict, *args: str) -> subprocess.CompletedProcess:
    return run_module("bearingtwin.cli.train", "-m", *SWEEP, *args, f"hydra.sweep.dir={folder / 'multirun'}", cwd=folder,
                      env=env, timeout=TIMEOUT_S)


def test_a_slurm_sweep_submits_one_array_task_per_job_with_the_sweeps_store_and_cache(tmp_path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, body in STAND_INS.items():
        (bin_dir / name).write_text("#!/bin/sh\n" + body)
        (bin_dir / name).chmod(0o755)
    env = child_env(f"sqlite:///{tmp_path / 'mlflow.db'}", tmp_path / "cache", SBATCH_CAPTURE=str(tmp_path / "submission.sh"))
    env["PATH"] = os.pathsep.join([str(bin_dir), env["PATH"]])
    done = sweep(tmp_path, env, "launcher=submitit_slurm", "hydra.launcher.partition=cpu")
    assert done.returncode == 1 and "no cluster here" in done.stderr, done.stderr[-3000:]
    lines = (tmp_path / "submission.sh").read_text().splitlines()
    sbatch = {line.split("=", 1)[0].removeprefix("#SBATCH --"): line.split("=", 1)[1] for line in lines if line.startswith("#SBATCH --")}
    assert {key: sbatch.get(key) for key in ("partition", "cpus-per-task", "mem", "time", "array", "nodes", "ntasks-per-node")} \
        == {"partition": "cpu", "cpus-per-task": "2", "mem": "8GB", "time": "120", "array": "0-1%2", "nodes": "1",
            "ntasks-per-node": "1"}  # conf/launcher/submitit_slurm.yaml, two jobs
    assert sbatch["output"].startswith(f"{tmp_path / 'multirun' / '.submitit'}/")
    assert f"export MLFLOW_TRACKING_URI='sqlite:///{tmp_path / 'mlflow.db'}'" in lines
    assert f"export BEARINGTWIN_CACHE='{tmp_path / 'cache'}'" in lines
    (run_line,) = [line for line in lines if "submitit.core._submit" in line]
    assert run_line.startswith("srun ") and f"{sys.executable} -u -m submitit.core._submit" in run_line


def test_a_local_submitit_sweep_runs_both_jobs(tmp_path):
    env = child_env(f"sqlite:///{tmp_path / 'mlflow.db'}")
    done = sweep(tmp_path, env, "launcher=submitit_local")
    assert done.returncode == 0, done.stderr[-3000:]
    assert "2 jobs, 2 finished, 0 failed, 0 skipped" in done.stdout
    client = MlflowClient(env["MLFLOW_TRACKING_URI"])
    experiment_id = client.get_experiment_by_name("bearingtwin").experiment_id
    (parent,) = client.search_runs([experiment_id], "tags.`bt.kind` = 'sweep'")
    runs = client.search_runs([experiment_id], "tags.`bt.kind` = 'train'")
    assert sorted(run.data.tags["seed"] for run in runs) == ["0", "1"]
    # The jobs' workers print their lines to their own logs: the closing summary gives each job's accuracy.
    by_seed = {run.data.tags["seed"]: run.data.metrics["accuracy"] for run in runs}
    assert (f"  accuracy: {100 * by_seed['0']:.2f} % (seed=0); {100 * by_seed['1']:.2f} % (seed=1)"
            in done.stdout.splitlines()), done.stdout[-2000:]
    assert all(run.info.status == "FINISHED" and run.data.tags["mlflow.parentRunId"] == parent.info.run_id for run in runs)
    # A sweep of command-line values is named by what its jobs vary, in its parent and in each job's own process.
    assert parent.info.run_name.startswith("sweep over seed ") and "sweep over seed (run " in done.stdout
    assert {run.data.tags["sweep"] for run in runs} == {parent.data.tags["sweep"]} == {"over seed"}
    # each job ran in a process of its own, not in the sweep's
    assert len({run.data.tags["bt.pid"] for run in runs} | {parent.data.tags["bt.pid"]}) == 3


def test_a_slurm_sweep_where_there_is_no_slurm_is_one_line_and_opens_no_run(tmp_path):
    env = child_env(f"sqlite:///{tmp_path / 'mlflow.db'}", tmp_path / "cache")
    env["PATH"] = os.pathsep.join(folder for folder in env["PATH"].split(os.pathsep)
                                  if not (Path(folder) / "sbatch").exists() and not (Path(folder) / "srun").exists())
    done = sweep(tmp_path, env, "launcher=submitit_slurm")
    assert done.returncode == 2, done.stderr[-3000:]
    errors = [line for line in done.stderr.splitlines() if line.startswith("error: ")]
    assert errors == ["error: launcher=submitit_slurm: no SLURM here (sbatch and srun not on PATH); run the sweep on "
                      "the cluster's login node, or try it here with launcher=submitit_local"], done.stderr[-3000:]
    assert "Traceback" not in done.stderr and not (tmp_path / "mlflow.db").exists()
