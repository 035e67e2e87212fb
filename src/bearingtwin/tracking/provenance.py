"""Where numbers come from: the code (its commit) and the package versions a run or a model was made with, the
command's overrides and the lock the environment came from, and which run sizes produced a results file's numbers (a
smoke run cannot replace a full one).

A table regenerated after a smoke sweep (2 s of signal, 12 windows, 2 epochs) looks just
like the committed full-size one, with other numbers. So every generated block records the
size settings of the runs it was computed from, and :func:`check_replacement` refuses to
write smaller sizes over a file made from larger ones unless told (``force=true``). A file
without a record (written before records existed) counts as made at the configured defaults.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import json
import os
import re
import subprocess
from pathlib import Path

from bearingtwin.errors import BearingTwinError


def installed_versions(packages) -> dict[str, str | None]:
    """Each package's installed version (None when it is not installed)."""
    versions = {}
    for package in packages:
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            versions[package] = None
    return versions


def short_commit(commit: str) -> str:
    """A commit as a person reads it: its first 12 hex digits, and ``-dirty`` where the checkout had changes."""
    return commit[:12] + ("-dirty" if commit.endswith("-dirty") else "")


@functools.lru_cache(maxsize=1)
def git_commit() -> str:
    """The checkout's commit, ``-dirty`` where a file of the code, its configs or its environment changed or a file
    not yet added lies under the code or its configs (a new module imported changes what runs; a results page or the
    README does not); once per process, whose code is what it imported."""
    from bearingtwin.config import REPO_ROOT  # here: a served model imports this module, and need not load Hydra

    def git(*args: str) -> str:
        # GIT_OPTIONAL_LOCKS=0: a status that may refresh the index would take its lock and rewrite it, under a user's
        # own git command in the same checkout.
        return subprocess.run(["git", "-C", str(REPO_ROOT), *args], capture_output=True, text=True, timeout=10,
                              check=True, env={**os.environ, "GIT_OPTIONAL_LOCKS": "0"}).stdout.strip()

    try:
        commit = git("rev-parse", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", "src", "conf", "pyproject.toml",
                    "requirements.lock") or git("status", "--porcelain", "--untracked-files=normal", "--", "src", "conf")
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit + ("-dirty" if dirty else "")


def environment_tags() -> dict[str, str]:
    """The command line's overrides (Hydra's, as given: the run's config is also its artifact) and the lock the
    environment was installed from (its SHA-256, first 16 hex digits), where there are such."""
    tags = {}
    try:
        from hydra.core.hydra_config import HydraConfig

        tags["overrides"] = overrides_tag(HydraConfig.get().overrides.task)
    except ValueError:  # not under Hydra (the Python API)
        pass
    from bearingtwin.config import REPO_ROOT

    lock = REPO_ROOT / "requirements.lock"
    if lock.is_file():
        tags["requirements_lock"] = hashlib.sha256(lock.read_bytes()).hexdigest()[:16]
    return tags


def code_tag() -> str:
    """The ``code`` tag of a run: a key of every module of bearingtwin (:func:`~bearingtwin.storage.code_fingerprint`),
    which tells apart two states of one commit with changes not committed, where ``git_commit`` reads
    ``<commit>-dirty`` for both."""
    from bearingtwin.storage import code_fingerprint

    return code_fingerprint(".")


def computed_by_other_code(run) -> str:
    """"at <commit> (this code: <commit>-dirty)" where ``run`` was computed by other code than this checkout's (one
    with changes not committed counts as other than the commit without, and two such states of one commit as two
    where the run's ``code`` tag says so), "" where by this."""
    then, now = run.data.tags.get("git_commit", "unknown"), git_commit()
    if then != now:
        return f"at {short_commit(then)} (this code: {short_commit(now)})"
    then_code = run.data.tags.get("code")  # of a checkout with changes only: at a clean commit the commit says it all
    if then.endswith("-dirty") and then_code and then_code != code_tag():
        return f"at {short_commit(then)} with other changes not committed (code {then_code}; this code: {code_tag()})"
    return ""


def code_version(tags: dict) -> str:
    """A run's version of the code in words, from its tags: its commit, and where it had changes not committed, the
    key of its code (:func:`code_tag`), so that two such states of one commit are two versions."""
    commit = tags.get("git_commit", "unknown")
    dirty_code = tags.get("code") if commit.endswith("-dirty") else None
    return short_commit(commit) + (f" code {dirty_code}" if dirty_code else "")


def overrides_tag(overrides) -> str:
    """A command's overrides as one tag's value, within MLflow's limit on one (5000 characters)."""
    return " ".join(overrides)[:5000]


def context_tags() -> dict[str, str]:
    """The tags MLflow's fluent API gives a run and a run created by ``MlflowClient`` lacks: the user, the command
    (``mlflow.source.name``, ``mlflow.source.type``) and the commit of the code (``mlflow.source.git.commit``; the
    ``git_commit`` tag says whether the checkout had changes), as the MLflow UI shows and searches them."""
    from mlflow.tracking.context.registry import resolve_tags

    tags = resolve_tags()
    commit = git_commit().removesuffix("-dirty")
    if commit != "unknown":
        tags["mlflow.source.git.commit"] = commit
    return tags


SIZE_KEYS = (
    "data.duration",
    "data.samples_per_class",
    "data.twin.duration",
    "data.twin.windows_per_record",
    "data.test.windows_per_record",
    "search.population",
    "search.iterations",
    "search.windows",
    "trainer.max_epochs",
)
"""Logged params that set how much a run computes, not what: smaller means a smoke run."""

_RECORD = re.compile(r"<!-- settings of the runs behind these numbers: (\{.*?\}) -->")


def used_sizes(run) -> dict[str, float]:
    """The size settings a run logged and used (search.* only where SABO-VMD searched: other features ignore it;
    trainer.* only where a network trained: other classifiers ignore the epochs)."""
    searched = run.data.params.get("features.kind") == "sabo_vmd"
    trained = run.data.params.get("classifier.name") == "cnn_bilstm"
    sizes = {}
    for key in SIZE_KEYS:
        if (key.startswith("search.") and not searched) or (key.startswith("trainer.") and not trained):
            continue
        try:
            sizes[key] = float(run.data.params.get(key))
        except (TypeError, ValueError):
            continue  # not logged by this kind of run (or None)
    return sizes


def run_sizes(runs) -> dict[str, list[float]]:
    """Each size setting the runs logged and used, with its distinct values (ascending)."""
    sizes: dict[str, set[float]] = {}
    for run in runs:
        for key, value in used_sizes(run).items():
            sizes.setdefault(key, set()).add(value)
    return {key: sorted(values) for key, values in sizes.items()}


def run_size(run) -> tuple[float, ...]:
    """A run's size settings in :data:`SIZE_KEYS` order (one not logged, or not used: 0), to order runs by."""
    used = used_sizes(run)
    return tuple(used.get(key, 0.0) for key in SIZE_KEYS)


def size_words(run) -> str:
    """A run's size settings as a reader would give them (``data.duration=2, trainer.max_epochs=3``)."""
    return ", ".join(f"{key}={_fmt(value)}" for key, value in zip(SIZE_KEYS, run_size(run)) if value)


def size_record(sizes: dict[str, list[float]]) -> str:
    """The line a generated block carries (an HTML comment: invisible in rendered markdown)."""
    return f"<!-- settings of the runs behind these numbers: {json.dumps(sizes, sort_keys=True)} -->"


def recorded_sizes(text: str) -> dict[str, list[float]] | None:
    """The sizes a results file records, or None when it records none."""
    match = _RECORD.search(text)
    return None if match is None else json.loads(match.group(1))


def check_replacement(path: Path, sizes: dict[str, list[float]], defaults: dict[str, float], force: bool) -> None:
    """Raise naming the settings if ``sizes`` are smaller than those of the results in ``path`` (``runs``, where
    recorded: how many runs the table was computed from).

    ``defaults``: the configured size of each key, assumed for a file that records none but
    already holds generated results (every committed results file is full size).
    """
    if force or not path.exists():
        return
    text = path.read_text()
    before = recorded_sizes(text)
    if before is None:
        if "generated by bearingtwin-report" not in text:
            return
        before = {key: [value] for key, value in defaults.items()}
    shared = sorted(set(sizes) & set(before))
    smaller = [f"{key}={_fmt(min(sizes[key]))} (file: {_fmt(min(before[key]))})"
               for key in shared if min(sizes[key]) < min(before[key])]
    # Larger runs replace smaller ones however few they are: one full-size run says more than five smoke runs.
    larger_runs = any(min(sizes[key]) > min(before[key]) for key in shared if key != "runs")
    smaller_runs = any(min(sizes[key]) < min(before[key]) for key in shared if key != "runs")
    if larger_runs and not smaller_runs:
        return
    if smaller:
        raise BearingTwinError(
            f"{path}: holds results of larger runs than these, or more of them ({', '.join(smaller)}); "
            "write elsewhere with out=<file>, or replace it with force=true"
        )


def _fmt(value: float) -> str:
    return f"{value:g}"
