"""No run left RUNNING: signals sent to real training processes, a sweep's workers, dead owners.

The training processes simulate 10 s (40 s where they are stopped early) of each bearing state into a fresh cache, which
takes several seconds: long enough to be caught with a run open.
"""

import os
import signal
import sqlite3
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from mlflow import MlflowClient
from omegaconf import OmegaConf

from bearingtwin.tracking.lifecycle import STOPPING_SIGNALS, owner_tags, register_open_run, stop_cleanly
from bearingtwin.tracking.mlflow_logging import open_store, train_tracked

from test_tracking import CHOICES, fake_train, make_cfg

SLOW = ["classifier=svm", "features=raw", "data.samples_per_class=12"]


def start_training(base: Path, *args: str, duration_s: float = 10) -> subprocess.Popen:
    """``bearingtwin-train`` simulating ``duration_s`` of each state: a test that stops it early gives it longer, so
    that on a loaded machine the signal still finds the run open (at 10 s, polled while the suite ran on both cores,
    a run had finished between the poll that saw it RUNNING and the signal)."""
    command = [sys.executable, "-m", "bearingtwin.cli.train", *args, *SLOW, f"data.duration={duration_s:g}",
               f"tracking.uri=sqlite:///{base}/mlflow.db", f"paths.cache_dir={base}/cache"]
    return subprocess.Popen(command, cwd=base, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def runs(base: Path, experiment: str = "bearingtwin") -> list:
    # Plain SQL until the process under test has created the schema: an MLflow client opening
    # a half-made database would try to create it too.
    try:
        with sqlite3.connect(f"file:{base}/mlflow.db?mode=ro", uri=True) as database:
            if not database.execute("select count(*) from runs").fetchone()[0]:
                return []
    except sqlite3.Error:
        return []
    client = MlflowClient(f"sqlite:///{base}/mlflow.db")
    found = client.get_experiment_by_name(experiment)
    return [] if found is None else client.search_runs([found.experiment_id])


def wait_for_running(base: Path, process: subprocess.Popen, n_runs: int, timeout_s: float = 120, kind: str = "train",
                     experiment: str = "bearingtwin") -> list:
    """Poll the store until ``n_runs`` runs of ``kind`` (the ``bt.kind`` tag) are RUNNING."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()[1][-2000:]
        running = [r for r in runs(base, experiment) if r.info.status == "RUNNING" and r.data.tags.get("bt.kind") == kind]
        if len(running) >= n_runs:
            return running
        time.sleep(0.3)
    process.kill()
    raise AssertionError(f"no {kind} run started in time")


def child_pids(pid: int) -> set[int]:
    """Processes whose parent is ``pid`` (joblib's workers), read from /proc."""
    children = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            if ppid == pid:
                children.add(int(entry.name))
    return children


def alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])  # SIGHUP: a terminal closed
def test_a_signalled_run_is_killed_with_one_line_and_128_plus_signal(tmp_path, signum):
    if signum == signal.SIGHUP and signal.getsignal(signal.SIGHUP) == signal.SIG_IGN:
        # Started under nohup, the training inherits the ignored hang-up and keeps it, as a nohup'd command should.
        pytest.skip("SIGHUP is ignored in this process (nohup): the training rightly ignores it too")
    process = start_training(tmp_path, duration_s=40)
    (run,) = wait_for_running(tmp_path, process, 1)
    assert run.data.tags["bt.pid"] == str(process.pid)
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum, err[-2000:]
    assert err.strip().splitlines()[-1] == f"interrupted by {signal.Signals(signum).name}; marked KILLED: run {run.info.run_id}"
    assert "Traceback" not in err
    assert [r.info.status for r in runs(tmp_path)] == ["KILLED"]


def test_a_twin_run_is_open_during_its_calibration_and_an_interrupt_kills_it(tmp_path):
    """bearingtwin-twin opens its MLflow run before the calibration (so a store that cannot serve is named
    before any work, and an interrupt has a run to mark), not after it."""
    import numpy as np

    np.save(tmp_path / "measured.npy", np.random.default_rng(0).normal(size=24000))
    command = [sys.executable, "-m", "bearingtwin.cli.twin", f"measured.path={tmp_path}/measured.npy",
               "measured.fs=12000", "measured.rpm=1797", "measured.fault=outer", "measured.check_fs=false",
               "twin.duration=0.5", "calibration.n_trials_base=5000", "figures=false", f"out={tmp_path}/report",
               f"tracking.uri=sqlite:///{tmp_path}/mlflow.db"]
    process = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    (run,) = wait_for_running(tmp_path, process, 1, kind="twin", experiment="bearingtwin-twin")
    time.sleep(1.0)  # into the calibration's trials
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err[-2000:]
    assert err.strip().splitlines()[-1] == f"interrupted by SIGINT; marked KILLED: run {run.info.run_id}"
    assert "Traceback" not in err, err[-3000:]
    assert [r.info.status for r in runs(tmp_path, "bearingtwin-twin")] == ["KILLED"]
    assert not (tmp_path / "report" / "twin_report.json").exists()


def test_a_terminated_sweep_kills_its_runs_and_its_workers(tmp_path):
    process = start_training(tmp_path, "-m", "seed=0,1", "launcher=joblib", f"hydra.sweep.dir={tmp_path}/multirun")
    running = wait_for_running(tmp_path, process, 2)
    workers = child_pids(process.pid)
    assert workers and {int(r.data.tags["bt.pid"]) for r in running} <= workers
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err[-2000:]
    # (loky's resource tracker may add a warning about the semaphores of the killed workers)
    assert any(line.startswith("interrupted by SIGTERM; marked KILLED: ") for line in err.splitlines())
    statuses = {r.data.tags["bt.kind"]: r.info.status for r in runs(tmp_path)}
    assert [r.info.status for r in runs(tmp_path)] == ["KILLED"] * 3 and set(statuses) == {"sweep", "train"}
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not any(alive(pid) for pid in workers), "a joblib worker outlived its sweep"


def wait_for_job_run(base: Path, process: subprocess.Popen, job: int, not_these: set[str] = frozenset(),
                     timeout_s: float = 120):
    """The RUNNING run of sweep job ``job`` that is none of ``not_these`` (an earlier attempt's)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()[1][-2000:]
        for run in runs(base):
            if (run.info.status == "RUNNING" and run.data.tags.get("sweep_job") == str(job)
                    and run.info.run_id not in not_these):
                return run
        time.sleep(0.3)
    process.kill()
    raise AssertionError(f"no run of job {job} started in time")


def test_a_sweep_job_whose_worker_is_killed_fails_alone_and_the_others_finish(tmp_path):
    """The OS's out-of-memory killer sends SIGKILL, which no code in the job survives: joblib's pool breaks, and
    Hydra's joblib launcher would end the sweep there. Killed in the pool, then again when run alone, the job is
    FAILED with the exit code; the job its pool's death stopped runs again and finishes, as does the third."""
    process = start_training(tmp_path, "-m", "seed=0,1,2", "launcher=joblib", f"hydra.sweep.dir={tmp_path}/multirun")
    first = wait_for_job_run(tmp_path, process, 0)
    os.kill(int(first.data.tags["bt.pid"]), signal.SIGKILL)
    second = wait_for_job_run(tmp_path, process, 0, {first.info.run_id})
    assert int(second.data.tags["bt.pid"]) != int(first.data.tags["bt.pid"])
    os.kill(int(second.data.tags["bt.pid"]), signal.SIGKILL)
    out, err = process.communicate(timeout=300)
    assert process.returncode == 1, err[-2000:]
    assert "Traceback" not in err
    assert "3 jobs, 2 finished, 1 failed, 0 skipped" in out
    assert "FAILED: seed=0: its process was killed (exit code SIGKILL(-9)" in out
    by_job = {}
    for run in runs(tmp_path):  # newest first
        by_job.setdefault(run.data.tags.get("sweep_job", run.data.tags["bt.kind"]), []).append(run)
    assert [r.info.status for r in by_job["0"]] == ["FAILED", "KILLED"]
    assert "SIGKILL" in by_job["0"][0].data.tags["error"]
    for job in ("1", "2"):  # a run its pool's death stopped (KILLED) may precede the FINISHED one
        assert by_job[job][0].info.status == "FINISHED" and {r.info.status for r in by_job[job][1:]} <= {"KILLED"}
    assert [r.info.status for r in by_job["sweep"]] == ["FAILED"]


def test_an_interrupt_while_jobs_run_alone_kills_their_runs_at_once(tmp_path):
    """After a worker's death each job runs in a process of its own; a SIGTERM then stops them all, not after
    the running jobs finish."""
    process = start_training(tmp_path, "-m", "seed=0,1,2", "launcher=joblib", f"hydra.sweep.dir={tmp_path}/multirun")
    first = wait_for_job_run(tmp_path, process, 0)
    os.kill(int(first.data.tags["bt.pid"]), signal.SIGKILL)
    again = wait_for_job_run(tmp_path, process, 0, {first.info.run_id})
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err[-2000:]
    assert {r.info.status for r in runs(tmp_path)} == {"KILLED"}
    deadline = time.monotonic() + 10
    while alive(int(again.data.tags["bt.pid"])) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not alive(int(again.data.tags["bt.pid"])), "a job's own process outlived its sweep"


# A sweep process (SIGKILLed below) and its worker, which opens a run and watches the sweep as a
# joblib worker of bearingtwin-train does; a stand-in for a whole sweep, to keep the test fast.
SWEEP = """
import os, subprocess, sys, time
os.environ["BEARINGTWIN_SWEEP_PID"] = str(os.getpid())
subprocess.Popen([sys.executable, "-c", *sys.argv[1:]])
time.sleep(600)
"""
WORKER = """
import sys, time
from mlflow import MlflowClient
from bearingtwin.tracking.lifecycle import owner_tags, register_open_run, watch_sweep_process
client = MlflowClient(sys.argv[1])
run = client.create_run(client.get_experiment_by_name("bearingtwin").experiment_id, tags={"bt.kind": "train", **owner_tags()})
register_open_run(client, run.info.run_id)
watch_sweep_process(poll_s=0.2)
time.sleep(600)
"""


def test_a_worker_of_a_killed_sweep_stops_and_closes_its_run(tmp_path):
    """SIGKILL cannot be caught: the worker notices its sweep process is gone."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin"}))
    sweep = subprocess.Popen([sys.executable, "-c", SWEEP, WORKER, uri])
    (run,) = wait_for_running(tmp_path, sweep, 1)
    worker = int(run.data.tags["bt.pid"])
    assert worker in child_pids(sweep.pid)
    sweep.kill()
    sweep.wait(timeout=60)
    deadline = time.monotonic() + 15
    while alive(worker) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not alive(worker), "the worker outlived its sweep"
    assert [r.info.status for r in runs(tmp_path)] == ["KILLED"]


CONTROLLER = """
import subprocess, sys, time
subprocess.Popen([sys.executable, "-c", *sys.argv[1:]])
time.sleep(600)
"""


def test_a_worker_a_controller_started_stops_when_the_sweep_is_killed(tmp_path):
    """submitit's local launcher starts each job from a controller process of its own, which outlives the sweep: the
    worker, the sweep's grandchild, notices the sweep gone from its ancestry, closes its run KILLED and stops (it
    went on and ended its run FINISHED)."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    open_store(OmegaConf.create({"uri": uri, "experiment": "bearingtwin"}))
    sweep = subprocess.Popen([sys.executable, "-c", SWEEP, CONTROLLER, WORKER, uri])
    (run,) = wait_for_running(tmp_path, sweep, 1)
    worker = int(run.data.tags["bt.pid"])
    controllers = child_pids(sweep.pid)
    assert worker not in controllers and any(worker in child_pids(pid) for pid in controllers)
    sweep.kill()
    sweep.wait(timeout=60)
    deadline = time.monotonic() + 15
    while alive(worker) and time.monotonic() < deadline:
        time.sleep(0.2)
    for pid in controllers:  # the controller is no worker of ours: it lingers until killed
        os.kill(pid, signal.SIGKILL)
    assert not alive(worker), "the worker outlived its sweep"
    assert [r.info.status for r in runs(tmp_path)] == ["KILLED"]


def test_a_relaunch_marks_runs_of_dead_processes_killed(tmp_path):
    cfg = make_cfg(tmp_path)
    client, experiment_id = open_store(cfg.tracking)
    finished = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead = client.create_run(experiment_id, tags={**owner_tags(), "bt.pid": finished.stdout.strip()})
    living = client.create_run(experiment_id, tags=owner_tags())  # this test's process: alive
    foreign = client.create_run(experiment_id, tags={"bt.host": "elsewhere", "bt.pid": finished.stdout.strip()})
    # A diagnosis's run, in an experiment of its own, whose process died: no later diagnosis had looked there.
    elsewhere = client.create_run(client.create_experiment("bearingtwin-diagnose"),
                                  tags={**owner_tags(), "bt.pid": finished.stdout.strip()})
    # A model the dead process was logging is FAILED with its run; the living process's is left to finish.
    models = {run.info.run_id: client.create_logged_model(experiment_id, source_run_id=run.info.run_id).model_id
              for run in (dead, living)}
    train_tracked(cfg, CHOICES, None, None, fake_train)
    status = {run.info.run_id: run.info.status for run in client.search_runs([experiment_id])}
    assert status[dead.info.run_id] == "KILLED" and "ended without closing" in client.get_run(dead.info.run_id).data.tags["bt.killed"]
    assert [client.get_logged_model(models[run.info.run_id]).status for run in (dead, living)] == ["FAILED", "PENDING"]
    assert status[living.info.run_id] == "RUNNING" and status[foreign.info.run_id] == "RUNNING"
    assert sorted(status.values()) == ["FINISHED", "KILLED", "RUNNING", "RUNNING"]
    assert client.get_run(elsewhere.info.run_id).info.status == "KILLED"


def test_a_store_without_logged_models_still_has_its_runs_closed(tmp_path, monkeypatch):
    """A tracking server of MLflow 2 has no logged models to search: the runs are closed all the same."""
    from mlflow.exceptions import MlflowException

    from bearingtwin.tracking.lifecycle import close_open_runs

    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    sweep = client.create_run(experiment_id).info.run_id
    jobs = [client.create_run(experiment_id, tags={"mlflow.parentRunId": sweep}).info.run_id for _ in range(2)]

    def no_such_endpoint(*args, **kwargs):
        raise MlflowException("404: no logged-model endpoint on this server")

    monkeypatch.setattr(client, "search_logged_models", no_such_endpoint)
    register_open_run(client, sweep, label="sweep", with_children=True)
    assert sorted(close_open_runs("KILLED")) == sorted([f"run {job}" for job in jobs] + [f"sweep {sweep}"])
    assert [client.get_run(run_id).info.status for run_id in (*jobs, sweep)] == ["KILLED"] * 3


def exit_status_under_stop_cleanly(entry_point) -> int:
    """The exit status ``stop_cleanly(entry_point)()`` ends with; the test process gets its own signal
    handlers back."""
    handlers = {signum: signal.getsignal(signum) for signum in STOPPING_SIGNALS}
    try:
        with pytest.raises(SystemExit) as stopped:
            stop_cleanly(entry_point)()
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    return stopped.value.code


def test_a_signal_whose_exception_a_c_callback_swallowed_still_kills(tmp_path, capsys):
    # Raised inside a C callback (numba's compiler calls back into Python), the handler's exception is
    # printed and dropped and the command goes on to its end: it must still stop, KILLED, with 130.
    from bearingtwin.tracking import lifecycle

    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    run_id = client.create_run(experiment_id).info.run_id

    def swallows_the_signal():
        register_open_run(client, run_id)
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            pass  # what a C callback does with it
        return "done"

    assert exit_status_under_stop_cleanly(swallows_the_signal) == 128 + signal.SIGINT
    assert not lifecycle._received  # handled: the process goes on afresh
    assert client.get_run(run_id).info.status == "KILLED"
    assert "interrupted by SIGINT" in capsys.readouterr().err


def test_a_signal_a_library_reraises_as_its_own_keyboard_interrupt_still_kills_with_its_status(tmp_path, capsys):
    # Ray's ray.get, interrupted by the signal handler's exception, raises a KeyboardInterrupt of its own:
    # the runs are still KILLED and the status is still the signal's (143 for SIGTERM, not Ctrl-C's 130).
    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    run_id = client.create_run(experiment_id).info.run_id
    # Stopped while its model was being logged: MLflow's logged model, left PENDING without its files, is FAILED.
    half_written = client.create_logged_model(experiment_id, source_run_id=run_id, name="model").model_id

    def waits_like_ray():
        register_open_run(client, run_id)
        try:
            signal.raise_signal(signal.SIGTERM)
        except KeyboardInterrupt:
            raise KeyboardInterrupt from None

    assert exit_status_under_stop_cleanly(waits_like_ray) == 128 + signal.SIGTERM
    assert client.get_run(run_id).info.status == "KILLED"
    assert client.get_logged_model(half_written).status == "FAILED"
    assert "interrupted by SIGTERM" in capsys.readouterr().err


def test_a_signal_lost_in_a_callback_prints_no_traceback_and_still_stops_the_command():
    """A signal landing in a weakref callback (SQLAlchemy has them) raises where Python cannot propagate:
    it is not reported, and the command still stops when it checks; other lost errors go to the hook
    that was installed before."""
    import gc
    import weakref

    from bearingtwin.tracking import lifecycle

    saved = {s: signal.getsignal(s) for s in STOPPING_SIGNALS}
    saved_hook = sys.unraisablehook
    reported = []
    try:
        sys.unraisablehook = lambda unraisable: reported.append(type(unraisable.exc_value).__name__)
        lifecycle.handle_signals()
        lifecycle.handle_signals()  # installed once, not wrapped twice

        class Thing:
            pass

        def lose(exception):
            thing = Thing()
            keep = weakref.ref(thing, lambda _: (_ for _ in ()).throw(exception))  # raises inside the callback
            del thing
            gc.collect()
            return keep

        lifecycle._received.append(signal.SIGINT)  # as the handler records it before raising
        lose(lifecycle.Interrupted(signal.SIGINT))
        lose(ValueError("an ordinary lost error"))
        assert reported == ["ValueError"]
        with pytest.raises(lifecycle.Interrupted):
            lifecycle.raise_if_interrupted()
    finally:
        lifecycle._received.clear()
        sys.unraisablehook = saved_hook
        for s, handler in saved.items():
            signal.signal(s, handler)


def test_a_signal_during_a_lightning_fit_still_kills_with_its_status(tmp_path, capsys, monkeypatch):
    """Lightning's Trainer catches the interrupt, ignores SIGINT from then on and calls exit(1): a sweep's
    job stopped while its network trained was left FAILED with status 1. Under ``signals_kept`` (how
    training fits) the exit is the interrupt again: KILLED, 143, and the handlers are ours afterwards."""
    import numpy as np

    from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier, CnnBiLstmModule
    from bearingtwin.tracking import lifecycle

    client, experiment_id = open_store(make_cfg(tmp_path).tracking)
    run_id = client.create_run(experiment_id).info.run_id
    epoch_end = CnnBiLstmModule.on_train_epoch_end

    def signalled_at_the_second_epoch(module):
        epoch_end(module)
        if module.current_epoch == 1:
            signal.raise_signal(signal.SIGTERM)

    monkeypatch.setattr(CnnBiLstmModule, "on_train_epoch_end", signalled_at_the_second_epoch)

    def trains():
        register_open_run(client, run_id)
        X, y = np.random.default_rng(0).standard_normal((24, 9)), np.repeat([0, 1, 2], 8)
        with lifecycle.signals_kept():
            CnnBiLstmClassifier(max_epochs=50).fit(X, y)
        return "finished"

    handlers = {signum: signal.getsignal(signum) for signum in STOPPING_SIGNALS}
    lifecycle.handle_signals()
    try:
        assert exit_status_under_stop_cleanly(trains) == 128 + signal.SIGTERM
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    assert client.get_run(run_id).info.status == "KILLED"
    assert "interrupted by SIGTERM" in capsys.readouterr().err


def test_a_calibration_in_a_worker_thread_stops_at_its_next_evaluation_after_a_signal(monkeypatch):
    """A signal raises in the main thread only; the candidate fits of bearingtwin-twin's screening run in
    threads and would go through their whole trial budgets before the command could exit."""
    from bearingtwin.tracking import lifecycle
    from bearingtwin.twin.calibrate import minimize

    evaluations = []

    def objective(params):
        evaluations.append(params)
        if len(evaluations) == 3:
            lifecycle._received.append(signal.SIGINT)  # as the handler records it, raising in the main thread
        return params["x"] ** 2

    monkeypatch.setattr(lifecycle, "_received", [])
    with ThreadPoolExecutor(max_workers=1) as pool:
        future = pool.submit(minimize, objective, {"x": (-1.0, 1.0, False)}, 500, 0)
        with pytest.raises(lifecycle.Interrupted):
            future.result(timeout=60)
    assert len(evaluations) == 3
    # A signal an earlier command of this process took (a notebook's caught Ctrl-C) does not stop the next one.
    assert len(stop_cleanly(lambda: minimize(lambda params: params["x"] ** 2, {"x": (-1.0, 1.0, False)}, 5, 0))()
               .trial_errors) == 5


def test_a_store_that_refuses_artifacts_fails_the_sweep_and_leaves_nothing_running(tmp_path):
    """Every artifact refused (an artifact root no store can write): each job's run is FAILED, not left RUNNING,
    and the sweep's parent too, with exit code 1 and one line saying why, not a warning Hydra swallows."""
    done = subprocess.run([sys.executable, "-m", "bearingtwin.cli.train", "-m", "seed=0,1", "classifier=svm",
                           "features=raw", "data.duration=2", "data.samples_per_class=8",
                           "tracking.experiment=refusing", "tracking.artifact_root=nosuch://nowhere",
                           f"tracking.uri=sqlite:///{tmp_path}/mlflow.db", f"paths.cache_dir={tmp_path}/cache"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 1, done.stderr[-2000:]
    statuses = {run.data.tags.get("bt.kind"): [] for run in runs(tmp_path, "refusing")}
    for run in runs(tmp_path, "refusing"):
        statuses[run.data.tags.get("bt.kind")].append(run.info.status)
    assert statuses.get("train") == ["FAILED", "FAILED"] and statuses.get("sweep") == ["FAILED"], statuses
    assert "UserWarning" not in done.stderr


TORN_MID_WORK = """
import os, signal, time
from bearingtwin.tracking.lifecycle import stop_cleanly

class HalfBuilt:  # as a compiler's object is when the signal lands inside its constructor
    def __del__(self):
        self.handle.close()

@stop_cleanly
def main():
    global left_behind
    left_behind = HalfBuilt()
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(10)

main()
"""


def test_teardown_noise_after_an_interrupt_does_not_follow_its_one_line(tmp_path):
    """Objects the signal left half built (llvmlite's, when it lands during a numba compile) fail in their
    finalizers as the interpreter exits; the interrupt's one line stays the last on stderr."""
    (tmp_path / "torn.py").write_text(TORN_MID_WORK)
    done = subprocess.run([sys.executable, str(tmp_path / "torn.py")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr.strip().splitlines() == ["interrupted by SIGTERM; no run was open"], done.stderr


def test_a_command_started_under_nohup_keeps_ignoring_a_hangup():
    """nohup asks a command to outlive its terminal: its SIGHUP, ignored, had been taken over (a sweep under nohup was
    KILLED at logout); without nohup a hangup stops it as Ctrl-C does."""
    probe = ("import signal; from bearingtwin.tracking.lifecycle import handle_signals; handle_signals(); "
             "print(signal.getsignal(signal.SIGHUP) == signal.SIG_IGN)")
    under_nohup = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                                 preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    plain = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                           preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL))  # whatever runs the tests
    assert (under_nohup.stdout.strip(), plain.stdout.strip()) == ("True", "False")


def test_a_run_that_ends_well_while_a_dead_process_is_sought_stays_finished(tmp_path):
    """A command opening a store marks KILLED the RUNNING runs of processes gone. A training whose run it found
    RUNNING, and whose process then ended well (the run FINISHED) before it looked for the process, had been marked
    KILLED: its summary named a run the store called killed (seen in the README's replay, commands sharing a store)."""
    import socket

    from bearingtwin.tracking.lifecycle import reap_dead_runs

    client = MlflowClient(f"sqlite:///{tmp_path / 'mlflow.db'}")
    experiment = client.create_experiment("x")
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead_pid = ended.stdout.strip()  # a process that has ended
    stale = client.create_run(experiment, tags={"bt.host": socket.gethostname(), "bt.pid": dead_pid})
    client.set_terminated(stale.info.run_id, "FINISHED")  # ended well after the search below saw it RUNNING
    gone = client.create_run(experiment, tags={"bt.host": socket.gethostname(), "bt.pid": dead_pid})  # truly left open
    searched = [client.get_run(gone.info.run_id), stale]  # what the search returned: both RUNNING then

    class Seen:  # the store as the reaper's search saw it a moment earlier
        def __getattr__(self, name):
            return getattr(client, name)

        def search_runs(self, *args, **kwargs):
            return searched

    assert reap_dead_runs(Seen()) == [gone.info.run_id]
    assert client.get_run(stale.info.run_id).info.status == "FINISHED"
    assert client.get_run(gone.info.run_id).info.status == "KILLED"


@pytest.mark.skipif(not Path("/proc/self/ns/pid").exists(), reason="no /proc pid namespace to name (not Linux)")
def test_a_run_whose_pid_belongs_to_another_pid_space_is_left_running(tmp_path):
    """A container sharing the host's name (host networking) numbers its processes apart: a training there, alive, had
    been marked KILLED by a diagnosis here that could not see its pid. A run opened in another pid space (another pid
    namespace, or this host before a reboot) is left alone; one of this space whose process is gone is marked KILLED,
    as is one tagged before runs named their space."""
    import socket

    from bearingtwin.tracking.lifecycle import SPACE_TAG, owner_tags, pid_space, reap_dead_runs

    assert pid_space() and owner_tags()[SPACE_TAG] == pid_space()  # Linux: /proc gives the boot and the namespace
    client = MlflowClient(f"sqlite:///{tmp_path / 'mlflow.db'}")
    experiment = client.create_experiment("x")
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    owner = {"bt.host": socket.gethostname(), "bt.pid": ended.stdout.strip()}  # a pid no process of this space has
    elsewhere = client.create_run(experiment, tags={**owner, SPACE_TAG: "another-boot pid:[4026531836]"})
    here = client.create_run(experiment, tags={**owner, SPACE_TAG: pid_space()})
    untagged = client.create_run(experiment, tags=owner)
    assert sorted(reap_dead_runs(client)) == sorted([here.info.run_id, untagged.info.run_id])
    assert client.get_run(elsewhere.info.run_id).info.status == "RUNNING"
