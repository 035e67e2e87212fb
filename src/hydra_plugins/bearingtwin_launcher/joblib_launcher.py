"""Hydra's joblib launcher, except that a job whose worker process dies fails alone.

With hydra-joblib-launcher, a worker killed from outside Python (the OS's out-of-memory killer,
``kill -9``) breaks joblib's process pool: every job running beside it is stopped, the jobs not yet
started never run, and the sweep ends in a traceback. A launcher is the only place that can tell
(no code inside a job survives SIGKILL), and neither joblib nor Hydra offers this, hence this
subclass (``conf/launcher/joblib.yaml`` selects it).

The jobs run as there, in a pool of reused workers. When a worker dies, the runs its death
stopped are marked KILLED, and every job that had not returned runs again, each in a process of
its own, so that a second death is pinned on its own job: that job's run is marked FAILED with the
worker's exit code, and the others go on. A job that had finished before the crash but had not
yet returned finds its FINISHED run and is skipped (``bearingtwin-train`` skips a config already
finished).
"""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import Sequence

from hydra.core.singleton import Singleton
from hydra.core.utils import JobReturn, JobStatus, configure_log, filter_overrides, setup_globals
from hydra_plugins.hydra_joblib_launcher._core import execute_job, process_joblib_cfg
from hydra_plugins.hydra_joblib_launcher.joblib_launcher import JoblibLauncher

log = logging.getLogger(__name__)


class SurvivingJoblibLauncher(JoblibLauncher):
    """:class:`JoblibLauncher` whose sweep survives a worker's death (module docstring)."""

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
        from joblib import Parallel, delayed
        from joblib.externals.loky.process_executor import TerminatedWorkerError

        setup_globals()
        configure_log(self.config.hydra.hydra_logging, self.config.hydra.verbose)
        Path(str(self.config.hydra.sweep.dir)).mkdir(parents=True, exist_ok=True)
        settings = dict(self.joblib, backend="loky")  # processes: the threading backend is incompatible with Hydra
        process_joblib_cfg(settings)
        log.info("Joblib.Parallel(%s) is launching %d jobs", ",".join(f"{k}={v}" for k, v in settings.items()),
                 len(job_overrides))
        for idx, overrides in enumerate(job_overrides):
            log.info("\t#%d : %s", initial_job_idx + idx, " ".join(filter_overrides(overrides)))
        arguments = (self.hydra_context, self.config, self.task_function, Singleton.get_state())
        returns: dict[int, JobReturn] = {}
        try:
            for idx, job_return in Parallel(**settings, return_as="generator_unordered")(
                delayed(_numbered)(idx, initial_job_idx + idx, overrides, *arguments)
                for idx, overrides in enumerate(job_overrides)
            ):
                returns[idx] = job_return
        except TerminatedWorkerError as error:
            left = [idx for idx in range(len(job_overrides)) if idx not in returns]
            log.warning("a worker process died (%s): the runs it stopped are marked KILLED, and the %d job(s) "
                        "that had not returned run again, each in a process of its own", _exit_codes(error), len(left))
            store = _SweepStore(self.config)
            store.mark_dead_workers_runs()
            returns.update(self._run_each_alone([(idx, initial_job_idx + idx, job_overrides[idx]) for idx in left],
                                                arguments, _pool_size(settings.get("n_jobs")), store))
            store.mark_dead_workers_runs()  # a worker the pool stopped may have outlived the first look
        return [returns[idx] for idx in range(len(job_overrides))]

    def _run_each_alone(self, jobs: list[tuple[int, int, Sequence[str]]], arguments: tuple, n_jobs: int,
                        store: "_SweepStore") -> dict[int, JobReturn]:
        """Each job (its place in the batch, its number, its overrides) in a process of its own, ``n_jobs`` at
        a time. A job whose process dies has its run marked FAILED; an interrupt stops every process at once."""
        from concurrent.futures import FIRST_COMPLETED, wait

        from joblib.externals.loky import ProcessPoolExecutor

        waiting, running, returns = list(jobs), {}, {}
        try:
            while waiting or running:
                while waiting and len(running) < n_jobs:
                    idx, job_num, overrides = waiting.pop(0)
                    executor = ProcessPoolExecutor(max_workers=1)
                    running[executor.submit(execute_job, job_num, overrides, *arguments)] = (idx, job_num, overrides,
                                                                                               executor)
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    idx, job_num, overrides, executor = running.pop(future)
                    executor.shutdown(wait=True)
                    returns[idx] = _job_return(future, job_num, overrides, store)
        finally:  # an interrupt: the jobs' runs are then marked KILLED by the sweep's process (stop_cleanly)
            for *_, executor in running.values():
                executor.shutdown(wait=False, kill_workers=True)
        return returns


def _job_return(future, job_num: int, overrides: Sequence[str], store: "_SweepStore") -> JobReturn:
    """A job's return from its own process; if that process died, a return like that of a job failing in its task."""
    from joblib.externals.loky.process_executor import TerminatedWorkerError

    try:
        return future.result()
    except TerminatedWorkerError as error:
        reason = (f"its process was killed ({_exit_codes(error)}; the OS does so when memory runs out), "
                  "running alone after a worker of the shared pool had died")
        log.error("job %d: %s", job_num, reason)
        store.mark_job_failed(job_num, reason)
        # Completed for Hydra, as a job that fails inside its task returns: the sweep goes on, and its
        # summary reads the job's outcome from MLflow.
        return JobReturn(overrides=list(overrides), status=JobStatus.COMPLETED, _return_value=None)


def _numbered(idx: int, job_num: int, overrides: Sequence[str], *arguments) -> tuple[int, JobReturn]:
    """A job's return with its place in the batch, for a pool that returns them as they come."""
    return idx, execute_job(job_num, overrides, *arguments)


def _pool_size(n_jobs) -> int:
    from joblib import effective_n_jobs

    return max(1, effective_n_jobs(n_jobs))


def _exit_codes(error: Exception) -> str:
    """The workers' exit codes joblib names in its message ('SIGKILL(-9)'), or its whole first line."""
    found = re.search(r"exit codes of the workers are \{(.*?)\}", str(error))
    return f"exit code {found[1]}" if found else str(error).splitlines()[0]


class _SweepStore:
    """The sweep's MLflow store and parent run, found once when first needed. Marking runs there is bookkeeping:
    if the store fails it, a warning says so and the sweep goes on (its summary reads the store again)."""

    def __init__(self, config):
        self.config = config
        self._found = None

    def _client_and_parent(self):
        from bearingtwin.tracking.mlflow_logging import (find_sweep_parent, open_store, sweep_folder,
                                                         sweep_job_configs, sweep_tracking)

        if self._found is None:
            client, _ = open_store(sweep_tracking(self.config, list(sweep_job_configs(self.config))))
            self._found = client, find_sweep_parent(client, sweep_folder(self.config.hydra))
        return self._found

    def mark_dead_workers_runs(self) -> None:
        """Runs left RUNNING by the workers the pool lost, KILLED: their jobs run again, in new runs."""
        from bearingtwin.tracking.lifecycle import reap_dead_runs

        try:
            client, _ = self._client_and_parent()
            reap_dead_runs(client)
        except Exception as error:  # the store's bookkeeping, not the jobs
            log.warning("could not mark the lost workers' runs KILLED: %s: %s", type(error).__name__, error)

    def mark_job_failed(self, job_num: int, reason: str) -> None:
        """The job's run (the sweep's child of its job number), FAILED with ``reason``; none if it had begun none."""
        from bearingtwin.tracking.mlflow_logging import all_experiment_ids, find_runs

        try:
            client, parent = self._client_and_parent()
            if parent is None:
                return
            children = find_runs(client, all_experiment_ids(client),
                                 f"tags.`mlflow.parentRunId` = '{parent.info.run_id}' and tags.sweep_job = '{job_num}'")
            for run in children[:1]:  # the newest: the run of this second attempt
                if run.info.status in ("RUNNING", "KILLED"):
                    client.set_tag(run.info.run_id, "error", reason)
                    client.set_terminated(run.info.run_id, "FAILED")
        except Exception as error:
            log.warning("could not mark job %d's run FAILED: %s: %s", job_num, type(error).__name__, error)
