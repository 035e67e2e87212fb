"""A fork server for the tests' command runs: the heavy libraries imported once, each command a fresh fork.

Every ``python -m bearingtwin.cli.<name>`` a test starts spends 5-15 s importing MLflow, Lightning,
torch and scikit-learn before its own work begins, and the suite starts about a hundred of them.
This process imports those libraries once, then, for each request on its stdin, forks: the child
takes the request's working directory, environment and output files and runs the module as
``python -m`` would (``sys.argv``, ``sys.path[0]``, ``__main__``), so the command is still a
process of its own, with its own exit code, its own stdout and stderr, its own atexit handlers and
children; only the interpreter's start, the imports and the module teardown at exit are spared. (The standard library's
``multiprocessing`` forkserver runs a function, not a module as ``__main__``, and ends its
children with ``os._exit``, skipping the atexit handlers MLflow ends its runs with: hence this
small one.)

Protocol, one JSON object a line: request ``{"module", "args", "cwd", "env", "stdout", "stderr"}``;
answers ``{"pid": N}`` once forked, then ``{"returncode": N}`` (negative: killed by that signal,
as :mod:`subprocess` reports it). The parent (``tests/processes.py``) ends the server by closing
its stdin.

Libraries read some settings at import (OpenMP threads, matplotlib's backend); the server is
started with the tests' own environment, which every command shares, and a child re-reads the
temporary folder, which does differ. What a fork cannot show, a module that forgot an import some
other module happened to make, a warning printed while the libraries import (printed once, by
this process), settings read at interpreter start (``PYTHONHASHSEED``, OpenMP's), is left to the
commands the tests still start afresh (the tracking server's, the served model's, the interrupted
runs').
"""

import atexit
import contextlib
import json
import os
import runpy
import sys
import tempfile
import threading

# The imports every command pays for; importing them here is the point of this process.
import hydra  # noqa: F401
import lightning  # noqa: F401
import matplotlib  # noqa: F401
import mlflow  # noqa: F401
import optuna  # noqa: F401
import scipy.signal  # noqa: F401
import scipy.stats  # noqa: F401
import sklearn.svm  # noqa: F401
import torch  # noqa: F401

# What those libraries import lazily on a command's way, about 3 s a command: MLflow's SQL store, its model loading,
# the git and notebook look-ups behind a run's tags; a MATLAB v7.3 reader.
import git  # noqa: F401
import h5py  # noqa: F401
import IPython  # noqa: F401
import mlflow.pyfunc  # noqa: F401
import mlflow.store.tracking.sqlalchemy_store  # noqa: F401
import scipy.io  # noqa: F401

# The project's own modules behind every command (not the commands' modules: those run as __main__);
# none of them reads the environment when imported.
import bearingtwin.data.build  # noqa: F401
import bearingtwin.diagnosis.pipeline  # noqa: F401
import bearingtwin.models.experiment  # noqa: F401
import bearingtwin.tracking.mlflow_logging  # noqa: F401
import bearingtwin.twin.report  # noqa: F401


def warm_up() -> None:
    """What a command otherwise builds once for its process, about 3 s: the map of installed packages MLflow checks a
    loaded model's requirements against (every distribution's files read; no test installs one into this
    interpreter), matplotlib's mathtext parser (a figure's first ``$...$`` label), and the fingerprints of the code
    behind the cache's entries (the package's sources do not change while the tests run)."""
    from matplotlib.mathtext import MathTextParser
    from mlflow.utils import requirements_utils

    from bearingtwin.storage import FEATURE_CODE, SIMULATION_CODE, code_fingerprint

    code_fingerprint(*SIMULATION_CODE)
    code_fingerprint(*FEATURE_CODE)

    MathTextParser("agg").parse(r"$g^4/\mathrm{Hz}$")
    init_map = getattr(requirements_utils, "_init_packages_to_modules_map", None)  # private: skipped if renamed
    if init_map is not None:
        init_map()


def answer(message: dict) -> None:
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


def become(request: dict) -> None:
    """In the child: the request's files, folder and environment, then the module as ``python -m`` runs it.

    The output files first, so that anything going wrong from here on is the command's own stderr."""
    stdin = os.open(os.devnull, os.O_RDONLY)
    os.dup2(stdin, 0)
    for fd, path in ((1, request["stdout"]), (2, request["stderr"])):
        handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(handle, fd)
        os.close(handle)
    os.close(stdin)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    tempfile.tempdir = None  # gettempdir() reads TMPDIR again
    sys.argv = [request["module"], *request["args"]]
    sys.path[0] = os.getcwd()
    runpy.run_module(request["module"], run_name="__main__", alter_sys=True)


def exit_code(exit_: SystemExit) -> int:
    """The exit status the interpreter gives a ``SystemExit``: None 0, an int itself, anything else printed and 1."""
    if exit_.code is None or isinstance(exit_.code, int):
        return exit_.code or 0
    print(exit_.code, file=sys.stderr)
    return 1


def end(code: int) -> None:
    """Leave the child as the interpreter's exit would, up to the module teardown.

    Threads are joined and atexit handlers run (MLflow ends its runs there), the standard streams
    flushed; then ``os._exit``: tearing down the modules of torch, Lightning and MLflow takes about
    4 s here. Skipped with it: flushing a file object a command left open, which no command here
    does (each writes in a ``with`` block)."""
    threading._shutdown()  # what Py_FinalizeEx does first: wait for the non-daemon threads
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)


def serve() -> None:
    warm_up()
    answer({"ready": True})
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            try:
                become(request)
                code = 0
            except SystemExit as exit_:
                code = exit_code(exit_)
            except BaseException:  # as the interpreter reports an uncaught exception
                sys.excepthook(*sys.exc_info())
                code = 1
            end(code)
        answer({"pid": pid})
        _, status = os.waitpid(pid, 0)
        answer({"returncode": os.waitstatus_to_exitcode(status)})


if __name__ == "__main__":
    serve()
