"""Child processes and loopback servers that end-to-end tests start, wait for and always stop.

``run_module`` runs ``python -m <module>`` as :func:`subprocess.run` would, forked from a server that
has the heavy libraries imported already (tests/forkserver.py). Shared by the tests that serve a model (test_serve.py), run against a tracking server
(test_tracking_server.py) and sweep on other launchers (test_ray_launcher.py, test_submitit_launcher.py).
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import pytest

# Smallest training that still goes through every stage (twin data, SABO-VMD, classifier, model logging).
SMOKE = ["data.samples_per_class=12", "data.duration=1.0", "search.population=3", "search.iterations=1",
         "search.windows=2", "features.progress=false"]

# Straight to the loopback server: an http_proxy in the environment must not intercept it.
LOOPBACK = urllib.request.build_opener(urllib.request.ProxyHandler({}))


def free_loopback_port() -> int:
    """A port the kernel just handed out on 127.0.0.1 (released again for the server to bind)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def child_env(store_uri: str, cache: Path | None = None, **extra: str) -> dict:
    """This environment with its own MLflow store, and this interpreter's scripts first on PATH (``mlflow
    models serve`` execs ``uvicorn`` by name: it must be this interpreter's, not another's). The cache is
    the session's shared one (tests/conftest.py) unless the test checks what its commands cache: ``cache``."""
    env = dict(os.environ, MLFLOW_TRACKING_URI=store_uri, MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR="false", **extra)
    if cache is not None:
        env["BEARINGTWIN_CACHE"] = str(cache)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def start(args: list[str], env: dict, cwd: Path, log: Path) -> subprocess.Popen:
    """A child in its own process group (so a server's workers are ended with it), output in ``log``."""
    with open(log, "wb") as handle:
        return subprocess.Popen(args, env=env, cwd=cwd, stdout=handle, stderr=subprocess.STDOUT, start_new_session=True)


def stop(process: subprocess.Popen) -> None:
    """End ``process`` and every process of its group: TERM, then KILL if it lingers."""
    for sig, grace_s in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, sig)
        try:
            process.wait(timeout=grace_s)
            break
        except subprocess.TimeoutExpired:
            continue
    # The group may outlive its leader (uvicorn under mlflow's shell): make sure nothing of it is left.
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)


def assert_done(done: subprocess.CompletedProcess, what: str, returncode: int = 0, lines: int = 30) -> None:
    """A finished command (``run_module``) exited ``returncode``; else fail with the end of its output."""
    output = "\n".join((done.stdout + done.stderr).splitlines()[-lines:])
    assert done.returncode == returncode, f"{what} exited {done.returncode}:\n{output}"


def tail(log: Path, lines: int = 30) -> str:
    return "\n".join(log.read_text(errors="replace").splitlines()[-lines:])


def wait_until_answers(url: str, server: subprocess.Popen, log: Path, what: str, timeout_s: float) -> None:
    """Poll ``url`` until it answers 200; fail early if the server died, and after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if server.poll() is not None:
            pytest.fail(f"{what} exited {server.returncode} before answering:\n{tail(log)}")
        with contextlib.suppress(OSError):
            with LOOPBACK.open(url, timeout=2) as answer:
                if answer.status == 200:
                    return
        time.sleep(0.25)
    pytest.fail(f"{what} did not answer {url} within {timeout_s} s:\n{tail(log)}")


FORKSERVER = Path(__file__).with_name("forkserver.py")


class _ForkServer:
    """One ``tests/forkserver.py`` process: runs one command at a time."""

    def __init__(self):
        # Unbuffered bytes: a reply must wait in this object's buffer, never in a file object's read-ahead
        # where select() cannot see it.
        self.process = subprocess.Popen([sys.executable, str(FORKSERVER)], stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, bufsize=0)
        self.received = b""
        self.read(timeout_s=300)  # {"ready": true}: the libraries are imported

    def read(self, timeout_s: float) -> dict:
        """The server's next reply; TimeoutError if none comes within ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self.received:
            ready, _, _ = select.select([self.process.stdout], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                raise TimeoutError
            chunk = os.read(self.process.stdout.fileno(), 65536)
            if not chunk:
                raise RuntimeError(f"the fork server exited {self.process.wait()}")
            self.received += chunk
        line, self.received = self.received.split(b"\n", 1)
        return json.loads(line)

    def run(self, module: str, args: list[str], cwd, env: dict, timeout_s: float) -> subprocess.CompletedProcess:
        with tempfile.TemporaryDirectory() as folder:
            out, err = Path(folder, "stdout"), Path(folder, "stderr")
            request = {"module": module, "args": [str(a) for a in args], "cwd": str(cwd or os.getcwd()),
                       "env": dict(env), "stdout": str(out), "stderr": str(err)}
            self.process.stdin.write(json.dumps(request).encode() + b"\n")
            self.process.stdin.flush()
            pid = self.read(timeout_s=60)["pid"]
            with _lock:
                _running.add(pid)
            try:
                returncode = self.read(timeout_s)["returncode"]
            except BaseException as error:  # a timeout, or the test interrupted: the command ends with it
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)  # not reaped yet: the server answers once it has reaped it
                with contextlib.suppress(Exception):
                    self.read(timeout_s=60)
                if isinstance(error, TimeoutError):
                    raise subprocess.TimeoutExpired([module, *args], timeout_s, out.read_text(errors="replace"),
                                                    err.read_text(errors="replace")) from None
                raise
            finally:
                with _lock:
                    _running.discard(pid)
            return subprocess.CompletedProcess([sys.executable, "-m", module, *args], returncode,
                                               out.read_text(errors="replace"), err.read_text(errors="replace"))

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.process.stdin.close()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.process.stdout.close()


_idle: list[_ForkServer] = []
_all: list[_ForkServer] = []
_running: set[int] = set()  # pids of the commands running now, in any thread
_lock = threading.Lock()


def kill_running_commands() -> None:
    """End every command ``run_module`` is running, in whichever thread: a fixture that fails or is
    interrupted while its commands run in a thread pool ends them before it waits for the pool."""
    with _lock:
        pids = list(_running)
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


@atexit.register
def _close_fork_servers() -> None:
    for server in _all:
        server.close()


def run_module(module: str, *args: str, cwd=None, env: dict | None = None,
               timeout: float = 600) -> subprocess.CompletedProcess:
    """``subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, env=env, capture_output=True, text=True,
    timeout=timeout)``, the process forked from a fork server (one per command running at once)."""
    with _lock:
        server = _idle.pop() if _idle else None
    if server is None:
        server = _ForkServer()
        with _lock:
            _all.append(server)
    try:
        done = server.run(module, list(args), cwd, os.environ if env is None else env, timeout)
    except BaseException:
        server.close()
        with _lock:
            _all.remove(server)
        raise
    with _lock:
        _idle.append(server)
    return done


def run_here(main, name: str, capsys, monkeypatch, *overrides: str) -> tuple[int, str, str]:
    """``<name> <overrides>`` run by its entry point ``main`` in this process, as its console script would be: exit
    status, stdout, stderr."""
    monkeypatch.setattr(sys, "argv", [name, *overrides])
    with pytest.raises(SystemExit) as stop:
        main()
        raise SystemExit(0)
    out, err = capsys.readouterr()
    return stop.value.code, out, err
