"""Test-session isolation: no test writes into the checkout's caches or MLflow store.

Caches and the default MLflow store are redirected to a per-session temporary
folder through the same environment variables a user would set, so the code paths
under test are the real ones.

One OpenMP / BLAS thread per process (torch's network, numpy's linear algebra), in this process
and in every command a test starts: two workers on two cores, each often with two children,
already fill the machine, and threads spinning for a busy core slow an LSTM's many small steps
several times over (the README's smoke raw CNN-BiLSTM run: 64 s beside the other commands, 18 s
on one thread). Numbers do not depend on it beyond the float32 rounding of the network's losses;
``OMP_NUM_THREADS`` set by the caller is kept.

Temporary folders (pytest's ``tmp_path``, this session's caches and store, and those of every
command a test starts) are in memory, on ``/dev/shm``, where the machine has one with room (a
session writes tens of MB) and ``TMPDIR`` is not set: they are real files and SQLite databases all
the same, but a fresh MLflow store's schema (about 330 statements, each committed to disk) takes
about 1 s there against 5-6 s on this machine's disk, and the suite makes dozens of stores.

Every temporary file is inside this session's folder, removed when the session ends: ``TMPDIR``
then points into it, for this process and every command a test starts. Libraries leave their own
behind (MLflow's model logging, about 380 KB a model, never removed), which in ``/dev/shm`` would
hold memory until the machine restarts. pytest's ``tmp_path`` folders are there too, so they go
with the session instead of the last three being kept (``--basetemp=<dir>`` keeps a session's).
Each xdist worker imports this file in its own process, so has its own session folder, inside
the controller's, and the controller removes all of it when it ends.
"""

import atexit
import os
import shutil
import tempfile

import pytest


def _memory_folder(path: str = "/dev/shm", room_bytes: int = 2 * 2**30) -> bool:
    if not (os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)):
        return False
    stats = os.statvfs(path)
    return stats.f_bavail * stats.f_frsize >= room_bytes


if "TMPDIR" not in os.environ and _memory_folder():
    os.environ["TMPDIR"] = "/dev/shm"
    tempfile.tempdir = None  # gettempdir() reads TMPDIR again

_session_dir = tempfile.mkdtemp(prefix="bearingtwin-tests-")
atexit.register(shutil.rmtree, _session_dir, ignore_errors=True)  # in memory: leave nothing behind
os.environ["TMPDIR"] = os.path.join(_session_dir, "tmp")
os.mkdir(os.environ["TMPDIR"])
tempfile.tempdir = None  # gettempdir() reads TMPDIR again; pytest's tmp_path asks it on first use
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")
# One simulation and feature cache for the whole session, its xdist workers included (they inherit the
# controller's environment): entries are keyed by their content and written whole (src/bearingtwin/storage.py),
# so a worker reads the smoke data another simulated. Tests of the cache itself, and end-to-end tests that
# check what a command wrote to its cache, name a cache of their own.
if "PYTEST_XDIST_WORKER" not in os.environ:  # the controller, or a run without workers: this session's own
    os.environ["BEARINGTWIN_TEST_SESSION"] = _session_dir
os.environ["BEARINGTWIN_CACHE"] = os.path.join(os.environ["BEARINGTWIN_TEST_SESSION"], "cache")
os.environ["MLFLOW_TRACKING_URI"] = "sqlite:///" + os.path.join(_session_dir, "mlflow.db")


# The longest files first (longest processing time first): with ``--dist loadfile`` a file is one unit of
# work, handed out in collection order (``--no-loadscope-reorder`` in pyproject.toml: xdist would otherwise put
# the files with most tests first), and a long file handed out last (the README's commands: two tests) would
# run alone on one worker while the other sat idle.
LONGEST_FIRST = ("test_readme_commands.py", "test_report.py", "test_diagnose.py", "test_twin_to_real.py",
                 "test_tracking_server.py", "test_serve.py")


def pytest_collection_modifyitems(items):
    rank = {name: position for position, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: each file's own order is kept


# Nothing a test does may write into the checkout, whose generated folders git ignores (an MLflow store's
# default artifact root is ./mlruns, the checkout when the suite runs there): the files under them are
# listed before the session and after it, and any new one fails the session, named.
_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_GENERATED = ("mlruns", ".cache", "outputs", "multirun")


def _generated_files() -> set[tuple[str, int, int]]:
    """Each file under the generated folders with its size and modification time: a file written over counts."""
    found = set()
    for folder in _GENERATED:
        for root, _, files in os.walk(os.path.join(_REPO, folder)):
            for name in files:
                path = os.path.join(root, name)
                stat = os.stat(path)
                found.add((os.path.relpath(path, _REPO), stat.st_size, stat.st_mtime_ns))
    return found


_BEFORE = _generated_files() if "PYTEST_XDIST_WORKER" not in os.environ else None


def pytest_sessionfinish(session, exitstatus):
    if _BEFORE is None:  # a worker: the controller looks once all of them are done
        return
    written = sorted({path for path, *_ in _generated_files() - _BEFORE})
    if written:
        shown = ", ".join(written[:5]) + (f" and {len(written) - 5} more" if len(written) > 5 else "")
        writer = session.config.get_terminal_writer()
        writer.line()
        writer.line(f"tests wrote into the checkout: {shown}", red=True)
        if session.exitstatus == 0:  # an interrupted or failing session keeps its own status
            session.exitstatus = 1


@pytest.fixture(scope="session")
def report_path(tmp_path_factory):
    """A calibration report for ``data=twin_to_real`` in the format ``bearingtwin-twin`` writes: the bare twin
    and one ``noise`` step, so no test depends on the committed CWRU study."""
    import json

    from bearingtwin.twin.model import effect_defaults

    path = tmp_path_factory.mktemp("calibration") / "twin_report.json"
    steps = [{"effects": [], "params": {}, "base_params": {"simulator.defect.depth_mm": 0.01}},
             {"effects": ["noise"], "params": {"noise": effect_defaults("noise")},
              "base_params": {"simulator.defect.depth_mm": 0.005}}]
    path.write_text(json.dumps({"steps": steps}))
    return path
