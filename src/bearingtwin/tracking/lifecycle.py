"""No MLflow run left RUNNING: what happens to runs when a process stops before closing them.

Three ways a run can be left open, three remedies:

* **A signal** (Ctrl-C, SIGTERM from a scheduler, SIGHUP from a terminal closed or a connection lost):
  :func:`stop_cleanly` turns SIGINT, SIGTERM and SIGHUP into :class:`Interrupted`, marks every run this process opened and has not
  closed KILLED (a sweep parent's still-running children too, whose worker processes
  joblib kills as the exception unwinds through it), prints one line and exits
  ``128 + signal``. Any other exception escaping an entry point marks them FAILED.
* **A dead owner** (SIGKILL, power loss): every run is tagged with the host and process
  that opened it (:func:`owner_tags`); :func:`reap_dead_runs`, called when a training, a sweep, a twin or a
  diagnosis opens its run, marks RUNNING runs of this host whose process is gone KILLED, in every experiment of the
  store.
* **An orphaned worker**: a joblib or submitit worker whose sweep process died would go on computing
  and log a FINISHED run nobody waits for; :func:`watch_sweep_process` ends it instead.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import signal
import socket
import sys
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable
from unittest import mock

from bearingtwin.errors import BearingTwinError

if TYPE_CHECKING:  # MLflow is imported where a run is closed: a command refusing its input need not load it
    from mlflow import MlflowClient

log = logging.getLogger(__name__)

HOST_TAG, PID_TAG = "bt.host", "bt.pid"
SPACE_TAG = "bt.pid_space"
"""Tag of the boot and pid namespace a run's owner pid belongs to (:func:`pid_space`)."""
SWEEP_PID_ENV = "BEARINGTWIN_SWEEP_PID"
"""Set by the sweep's process for its workers, which inherit it: the process they live for."""


# A command started under nohup (or by anything that ignores SIGHUP for it) keeps ignoring it: it was asked to outlive
# its terminal. Read once, at import, before any handler of this module is installed.
_HANGUP_IGNORED = hasattr(signal, "SIGHUP") and signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
STOPPING_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                         if hasattr(signal, name) and not (name == "SIGHUP" and _HANGUP_IGNORED))
"""The signals that stop a command with its runs KILLED: Ctrl-C, a scheduler's, a closed terminal's (none on
Windows; not under nohup)."""


class Interrupted(KeyboardInterrupt):
    """SIGINT, SIGTERM or SIGHUP arrived. A KeyboardInterrupt, so that no ``except Exception`` on the
    way up mistakes it for a failed computation, and so that a library waiting outside Python
    stops waiting as it does on Ctrl-C: Ray's ``ray.get`` turns a KeyboardInterrupt raised by a
    signal handler into its own, which is why the signal is also remembered (``_received``)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@dataclass(frozen=True)
class OpenRun:
    client: MlflowClient
    run_id: str
    label: str  # "run" or "sweep": how the exit line names it
    with_children: bool  # a sweep parent: its children may run in other processes


_open_runs: list[OpenRun] = []
_received: list[int] = []  # the signals that arrived, for a KeyboardInterrupt a library raised in their place
_stopping = threading.Event()  # set once an interrupt is reported and the command exits


@functools.cache
def pid_space() -> str:
    """What a pid names here: this boot and this pid namespace (Linux's ``/proc``; "" where there is none). Containers
    sharing the host's name, and machines of one name, number their processes apart: a pid seen from another space
    says nothing of whether its process lives."""
    try:
        boot = open("/proc/sys/kernel/random/boot_id").read().strip()
        return f"{boot} {os.readlink('/proc/self/ns/pid')}"
    except OSError:
        return ""


def owner_tags() -> dict[str, str]:
    """Tags naming the process that opens a run, so a later process can tell whether it died."""
    space = pid_space()
    return {HOST_TAG: socket.gethostname(), PID_TAG: str(os.getpid()), **({SPACE_TAG: space} if space else {})}


def register_open_run(client: MlflowClient, run_id: str, label: str = "run", with_children: bool = False) -> None:
    """Remember a run this process opened: if the process stops early, the run is closed for it."""
    _open_runs.append(OpenRun(client, run_id, label, with_children))


def open_owned_run(client: MlflowClient, experiment_id: str, run_name: str, tags: dict[str, str], label: str = "run",
                   with_children: bool = False):
    """A new run of this process, returned: tagged with ``tags``, MLflow's context (the user, the command, the commit:
    :func:`~bearingtwin.tracking.provenance.context_tags`) and its owner (:func:`owner_tags`, which
    :func:`reap_dead_runs` reads), and closed for it if the process stops early (:func:`register_open_run`)."""
    from bearingtwin.tracking.provenance import context_tags

    run = client.create_run(experiment_id, run_name=run_name, tags={**tags, **context_tags(), **owner_tags()})
    register_open_run(client, run.info.run_id, label, with_children)
    return run


def forget_open_run(run_id: str) -> None:
    """Stop closing ``run_id`` for this process: its store can no longer be reached (a tracking server gone)."""
    _open_runs[:] = [run for run in _open_runs if run.run_id != run_id]


def close_open_runs(status: str) -> list[str]:
    """Mark every registered run still RUNNING (and, for a sweep, its RUNNING children) ``status``.

    Returns ``"<label> <run id>"`` for each run closed; a store that cannot be reached is
    logged and skipped, so one dead connection does not keep the others open.
    """
    if not _open_runs:  # a command that ended before opening a run (a refused input) need not load MLflow
        return []
    from mlflow.exceptions import MlflowException

    from bearingtwin.tracking.mlflow_logging import all_experiment_ids  # it imports this module

    closed = []
    for run in reversed(_open_runs):
        try:
            if run.with_children:  # in any experiment of the store: a sweep may vary tracking.experiment
                children = run.client.search_runs(
                    all_experiment_ids(run.client),
                    f"tags.`mlflow.parentRunId` = '{run.run_id}' and attributes.status = 'RUNNING'",
                )
                for child in children:
                    run.client.set_terminated(child.info.run_id, status)
                    closed.append(f"run {child.info.run_id}")
                    fail_pending_models(run.client, child.info)
            info = run.client.get_run(run.run_id).info
            if info.status == "RUNNING":
                run.client.set_terminated(run.run_id, status)
                closed.append(f"{run.label} {run.run_id}")
                fail_pending_models(run.client, info)
        except MlflowException as error:
            log.error("could not mark %s %s %s: %s", run.label, run.run_id, status, error)
    _open_runs.clear()
    return closed


def fail_pending_models(client: MlflowClient, run_info) -> list[str]:
    """Mark FAILED the logged models (MLflow 3's) of a run that ended while their upload was under way (``run_info``:
    the run's ``RunInfo``): left PENDING, without their files, they read as still being written and load as an error.
    Returns their ids; none where the store cannot say (a tracking server of MLflow 2 has no logged models), which
    must not keep the runs after this one from being closed."""
    from mlflow.exceptions import MlflowException

    try:
        pending = [model.model_id for model in client.search_logged_models(
            [run_info.experiment_id], filter_string=f"source_run_id = '{run_info.run_id}'") if model.status == "PENDING"]
        for model_id in pending:
            client.finalize_logged_model(model_id, "FAILED")
    except MlflowException as error:
        log.warning("run %s: its logged models could not be checked: %s", run_info.run_id, error)
        return []
    return pending


def _raise_interrupted(signum, frame):
    _received.append(signum)
    raise Interrupted(signum)


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal came and its exception was lost: raised inside a C
    callback (numba's compiler calls back into Python), it is printed and dropped, and the work
    would go on to finish a run the user stopped."""
    if _received:
        raise Interrupted(_received[-1])


@contextlib.contextmanager
def signals_kept():
    """Around a library that takes the signals over: Lightning's ``Trainer.fit`` catches an interrupt, ignores
    SIGINT from then on and calls ``exit(1)``, which would leave the runs FAILED, not KILLED. Here that exit is
    the interrupt it was, and the handlers installed before (:func:`handle_signals`) are installed again."""
    ours = signal.getsignal(signal.SIGINT) is _raise_interrupted
    try:
        yield
    except SystemExit:
        raise_if_interrupted()
        raise
    finally:
        if ours and threading.current_thread() is threading.main_thread():
            handle_signals()


def _quiet_lost_interrupt(report_others: Callable) -> Callable:
    """A ``sys.unraisablehook``: an :class:`Interrupted` raised where Python cannot propagate it (a weakref
    or garbage-collection callback, such as SQLAlchemy's) is not printed as a traceback; the signal is
    remembered and :func:`raise_if_interrupted` stops the command. Everything else goes to ``report_others``
    (the hook installed before)."""

    def hook(unraisable) -> None:
        # Once an interrupt's one line is out, a finalizer failing as the interpreter shuts down belongs to an
        # object the signal left half built (llvmlite's, when it lands during a numba compile): noise, not news.
        torn_by_the_interrupt = _stopping.is_set() and sys.is_finalizing()
        if not isinstance(unraisable.exc_value, Interrupted) and not torn_by_the_interrupt:
            report_others(unraisable)

    hook.quiets_lost_interrupts = True
    return hook


def handle_signals() -> None:
    """SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` in the main thread (see :func:`stop_cleanly`)."""
    for signum in STOPPING_SIGNALS:
        signal.signal(signum, _raise_interrupted)
    if not getattr(sys.unraisablehook, "quiets_lost_interrupts", False):  # once, around whatever hook was there
        sys.unraisablehook = _quiet_lost_interrupt(sys.unraisablehook)


RAY_ANSWER_TIMEOUT_S = 10.0
"""How long a Ray cluster's address is given to answer before the sweep is refused."""


def start_ray_keeping_signals(init_cfg) -> None:
    """Start or join Ray for a sweep's Ray launcher (its ``ray.init`` settings), then handle the
    signals again: ``ray.init`` replaces SIGTERM's handler with an immediate exit, which would leave
    the sweep's runs FAILED instead of KILLED. The launcher then finds Ray running and uses it."""
    from hydra_plugins.hydra_ray_launcher._launcher_util import start_ray  # the launcher's own start, not a copy

    address = str(init_cfg.get("address") or "")
    host, _, port = address.rpartition(":")
    if host and port.isdigit() and "://" not in address:  # Ray would retry an address no cluster answers at for ever
        try:
            socket.create_connection((host.strip("[]"), int(port)), timeout=RAY_ANSWER_TIMEOUT_S).close()  # [::1]:6379
        except OSError as error:
            raise BearingTwinError(f"hydra.launcher.ray.init.address={address}: no Ray cluster answers there ({error}); "
                                   "start one (ray start --head) or leave the address out for the sweep's own") from None
    try:
        start_ray(init_cfg)
    except ConnectionError as error:  # address=auto with no cluster running on this machine
        raise BearingTwinError(f"hydra.launcher.ray.init.address={address}: {str(error).splitlines()[0]}") from None
    handle_signals()


def stop_ray_jobs() -> None:
    """Leave Ray, where this process drives a sweep's Ray jobs: Ray ends the tasks of a driver that leaves. Its
    workers are no children of this process, and went on after the interrupt, finishing runs already marked KILLED
    and starting new ones, unless Ray is left before the runs still open are marked."""
    ray = sys.modules.get("ray")
    if ray is not None and ray.is_initialized():
        with contextlib.suppress(Exception):  # a cluster already gone: there is nothing left to stop
            ray.shutdown()


def stop_cleanly(entry_point: Callable) -> Callable:
    """Wrap a command's ``main`` so that no run it opened outlives it in state RUNNING.

    SIGINT / SIGTERM / SIGHUP: open runs KILLED, one line on stderr, exit status 128 + signal number
    (130, 143, 129). An exception: open runs FAILED, then the exception goes on as before.
    """

    @functools.wraps(entry_point)
    def wrapped(*args, **kwargs):
        _received.clear()  # a signal an earlier command in this process (a notebook's) took is not this one's
        _stopping.clear()
        handle_signals()
        try:
            result = entry_point(*args, **kwargs)
            raise_if_interrupted()
            return result
        except KeyboardInterrupt as stop:
            signum = stop.signum if isinstance(stop, Interrupted) else (_received or [signal.SIGINT])[-1]
            _received.clear()  # handled: a process that goes on (a test's) starts afresh
            # A second signal while closing the runs must not leave half of them open.
            for ignored in STOPPING_SIGNALS:
                signal.signal(ignored, signal.SIG_IGN)
            stop_ray_jobs()
            closed = close_open_runs("KILLED")
            what = f"marked KILLED: {', '.join(closed)}" if closed else "no run was open"
            print(f"interrupted by {signal.Signals(signum).name}; {what}", file=sys.stderr)
            _stopping.set()
            sys.exit(128 + signum)
        except BaseException:
            _received.clear()
            close_open_runs("FAILED")
            raise

    return wrapped


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def reap_dead_runs(client: MlflowClient) -> list[str]:
    """Mark KILLED the RUNNING runs of the store opened on this host by a process that no longer exists, in every
    experiment (a diagnosis's, a twin's and a training's live in experiments of their own).

    Only this host's runs can be judged (a pid means nothing elsewhere), and of them only those opened in this
    process's pid space (:func:`pid_space`: another container of the same host name, or this host before a reboot,
    numbers its processes apart); a run without owner tags (logged by another tool) is left alone. Returns the ids
    marked.
    """
    from bearingtwin.tracking.mlflow_logging import all_experiment_ids

    host = socket.gethostname()
    running = client.search_runs(
        all_experiment_ids(client), f"attributes.status = 'RUNNING' and tags.`{HOST_TAG}` = '{host}'", max_results=1000
    )
    reaped = []
    for run in running:
        pid = run.data.tags.get(PID_TAG, "")
        if run.data.tags.get(SPACE_TAG, pid_space()) != pid_space():  # (a run tagged before the space was: as before)
            continue
        # Read again once the process is found gone: a run that ended well between the search and now is FINISHED,
        # which no KILLED may overwrite (a training's run in a store another command was opening).
        if (pid.isdigit() and not _process_alive(int(pid))
                and client.get_run(run.info.run_id).info.status == "RUNNING"):
            # Without MLflow's "View run <name> at <url>" (a tracking server's run prints it as it ends), which would
            # open this command's output naming another process's run.
            with mock.patch.dict(os.environ, {"MLFLOW_SUPPRESS_PRINTING_URL_TO_STDOUT": "true"}):
                client.set_terminated(run.info.run_id, "KILLED")
            client.set_tag(run.info.run_id, "bt.killed", f"process {pid} on {host} ended without closing the run")
            fail_pending_models(client, run.info)
            reaped.append(run.info.run_id)
    if reaped:
        log.warning("marked KILLED %d run(s) left RUNNING by processes that died: %s", len(reaped), ", ".join(reaped))
    return reaped


_watching = threading.Event()


def _ancestors() -> list[int]:
    """This process's parent, its parent's parent, ... up to init, read from ``/proc`` (Linux); where there is no
    ``/proc``, the parent alone."""
    chain, pid = [], os.getpid()
    while True:
        try:
            with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stat:
                # "pid (comm) state ppid ...": comm may hold spaces and parentheses, so read after the last ")".
                pid = int(stat.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            return chain or [os.getppid()]
        if pid <= 1:
            return chain
        chain.append(pid)


def watch_sweep_process(poll_s: float = 1.0) -> None:
    """In a sweep's worker process: end this process when the sweep's process is gone.

    Started once per worker; a no-op in the sweep's own process, where jobs run in line, and
    where the sweep process is no ancestor (remote launchers). A worker may be the sweep's child
    (joblib) or its grandchild (submitit's local launcher starts each job from a controller process).
    The worker's open runs are marked KILLED first, so the store says what happened.
    """
    sweep_pid = os.environ.get(SWEEP_PID_ENV, "")
    # The ancestry, not the sweep pid's existence, is the witness: a killed sweep process lingers as a zombie
    # until its own parent reaps it, but its children are re-parented at once, and the chain up from here loses it.
    if not sweep_pid.isdigit() or int(sweep_pid) not in _ancestors() or _watching.is_set():
        return
    _watching.set()

    def watch():
        while int(sweep_pid) in _ancestors():
            time.sleep(poll_s)
        close_open_runs("KILLED")
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="bearingtwin-sweep-watch", daemon=True).start()
