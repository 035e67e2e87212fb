"""Every command in the README and in docs/guide.md runs as written.

The bash blocks are read in order, the README's first, and each command runs in one temporary
working directory against one temporary MLflow store, so a command may use what an earlier
one wrote (a simulated record, a sweep's runs); a command the guide repeats from the README
is not run twice. Commands run two at a time, each after the earlier ones it depends on (those
naming the same file or folder; for a report, all of them). Only size is changed: where a
command trains or calibrates, smoke settings are appended (for the keys its composed config
has), and a sweep runs one job of its grid (every swept key pinned to its first value); a
diagnosis and a twin draw no figures (tests/test_diagnose.py and tests/test_twin_cli.py check them).
Paths are the documents' own with two substitutions: ``/tmp/`` becomes the test's folder and
``../shared/data`` the data root (``paths.data_root``). A command that needs data which is
not present is skipped, naming it. Commands that are not bearingtwin's (install, the test
suite itself, a server) are listed in ``NOT_RUN`` with the reason; any other command fails
the test, so a new kind of example cannot go unchecked.

By default the README's commands run, and the guide's are checked as their commands check their
input before any work (each composes, every config group exists, a single run's keys are declared,
a report takes its settings): a renamed setting fails here in seconds. ``-m slow`` runs the guide's
commands too.
"""

from __future__ import annotations

import os
import glob
import re
import shlex
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from mlflow import MlflowClient
from omegaconf import OmegaConf
from processes import run_module

from bearingtwin.config import CONF_DIR, REPO_ROOT, data_root

DOCUMENTS = ("README.md", "docs/guide.md")

# Appended where the command's composed config has the key: every stage still runs, on little data.
TRAIN_SMOKE = {
    "data.duration": "1.0",
    "data.samples_per_class": "12",
    "data.windows_per_record": "12",
    "data.twin.duration": "0.5",
    "data.twin.windows_per_record": "2",
    "data.test.windows_per_record": "3",
    "data.test.loads": "[1]",
    "data.calibration.validation_windows_per_record": "2",
    "search.population": "3",
    "search.iterations": "1",
    "search.windows": "2",
    "features.progress": "false",
    "trainer.max_epochs": "2",
}
TWIN_SMOKE = ["twin.duration=0.5", "compare.envelope_segment_s=0.25", "compare.lines_segment_s=0.25",
              "calibration.n_trials_base=3", "calibration.n_trials_effect=3", "calibration.n_trials_refine=3",
              "calibration.n_polish=3", "calibration.n_polish_effect=2", "ranking.max_effects=1"]

NOT_RUN = {
    "pip install": "installs the package: the suite runs on the installed package",
    "python -m pytest": "the test suite itself",
    "mlflow ui": "starts a web server",
    "mlflow models serve": "starts a model server (tests/test_serve.py serves and queries one)",
    "curl ": "queries the model server above",
    "pip-compile": "refreshes the lock (pip-tools is not installed by the project)",
    "sed -i": "part of refreshing the lock",
    "python scripts/": "studies over full-size sweeps (their pieces are tested on their own)",
    "python benchmarks/identifiability.py --records": "a benchmark over another rig's records "
                                                      "(tests/test_identifiability_records.py runs one on exported cases)",
    "mlflow server": "starts a team's tracking server (tests/test_tracking_server.py runs one and logs to it)",
    "export ": "points the commands after it at that server",
    "ray ": "starts or stops a Ray cluster (tests/test_ray_launcher.py starts one)",
    "bearingtwin-train -m +sweep=table4 launcher=ray": "a sweep on Ray (tests/test_ray_launcher.py runs one)",
    "bearingtwin-train -m +sweep=table4 launcher=submitit_slurm": "needs a SLURM cluster (tests/test_submitit_launcher.py "
                                                                  "checks the submission it makes)",
    "bearingtwin-train -m classifier=svm seed=0,1 launcher=submitit_local": "tests/test_submitit_launcher.py runs it",
}
SHELL_COMMANDS = ("printf ", "mkdir ")  # file set-up steps of an example, run as written by bash
SUMMARY_TITLES = {"simulate": "== bearingtwin-simulate ==", "twin": "== bearingtwin-twin:", "train": "== bearingtwin-train:",
                  "diagnose": "== bearingtwin-diagnose:"}


def document_commands(document: str) -> list[str]:
    """The commands of a document's bash blocks, in order: continuations joined, comments and
    blank lines dropped, ``a && b`` as two commands."""
    text = (REPO_ROOT / document).read_text()
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip()
            if line and not line.startswith("#"):
                commands += [part.strip() for part in line.split("&&")]
    return commands


def compose_train(overrides: list[str]):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("train", overrides=overrides, return_hydra_config=True)


def train_additions(args: list[str]) -> tuple[list[str], str | None]:
    """Smoke settings and sweep pins for a ``bearingtwin-train`` command, and the data folder
    it needs (None when it makes its own data)."""
    multirun = "-m" in args
    cfg = compose_train([arg for arg in args if arg != "-m"])
    added = [f"{key}={value}" for key, value in TRAIN_SMOKE.items() if OmegaConf.select(cfg, key) is not None]
    if multirun:
        for key, values in (cfg.hydra.sweeper.params or {}).items():
            values = str(values)
            added.append(f"{key}={values if '[' in values else values.split(',')[0]}")
    # A folder of one's own recordings (data=files, or a labels table) is made by the documents' earlier commands.
    own = cfg.data.source in ("simulated", "files") or cfg.data.get("labels")
    needs = None if own else str(cfg.data.root)
    return added, needs


def present(path: str) -> bool:
    """Whether a path a command needs exists (a Hydra-quoted glob: whether it matches anything)."""
    path = path.strip("'\"")
    return bool(glob.glob(path)) if glob.has_magic(path) else Path(path).exists()


def newest_finished_training_run(uri: str) -> str:
    client = MlflowClient(uri)
    experiment = client.get_experiment_by_name("bearingtwin")
    (run,) = client.search_runs([experiment.experiment_id], "tags.`bt.kind` = 'train' and attributes.status = 'FINISHED'",
                                max_results=1, order_by=["attributes.start_time DESC"])
    return run.info.run_id


def summary_problem(stdout: str, title: str, uri: str) -> str:
    """What is wrong with a command's closing summary ("" when nothing): it must be there, and the
    MLflow run it names must exist, be FINISHED and hold the accuracy it prints."""
    if title not in stdout:
        return f"no closing summary {title!r}"
    named = re.search(r"MLflow run: (\w+)", stdout)
    if named is None:
        return ""
    run = MlflowClient(uri).get_run(named[1])
    if run.info.status != "FINISHED":
        return f"the summary's run {named[1]} is {run.info.status}"
    printed = re.search(r"accuracy: ([\d.]+) %", stdout)
    if printed and printed[1] != f"{100 * run.data.metrics['accuracy']:.2f}":
        return f"the summary says accuracy {printed[1]} %, the run logged {run.data.metrics['accuracy']}"
    return ""


def checkout_state() -> str:
    return subprocess.run(["git", "-C", str(REPO_ROOT), "status", "--porcelain", "--untracked-files=all"],
                          capture_output=True, text=True, check=True).stdout


def named_paths(words: list[str]) -> list[Path]:
    """The files and folders a command names: words (or ``key=value`` values) holding a ``/``, and
    values of keys ending in root, path, out or labels."""
    paths = []
    for word in words:
        key, _, value = word.rpartition("=")
        if "/" in value or key.endswith(("root", "path", "out", "labels")):
            paths.append(Path(value))
    return paths


def related(first: list[Path], second: list[Path], workdir: Path) -> bool:
    """Whether two commands name the same file or folder, one inside the other, or two files of
    one folder other than the working directory (an example's folder of recordings)."""
    def near(a: Path, b: Path) -> bool:
        return a == b or a in b.parents or b in a.parents or (a.parent == b.parent and a.parent not in (workdir, Path(".")))
    return any(near(a, b) for a in first for b in second)


def test_every_guide_command_is_accepted_as_written():
    """What each command checks before it works: the config its overrides compose, no key that no config
    declares (for a sweep, its jobs' keys are checked when it starts: composition only here), a report's
    name and settings."""
    from bearingtwin.config import refuse_bad_overrides
    from bearingtwin.tracking.reports import check_report_settings

    checked = []
    for written in document_commands("docs/guide.md"):
        if any(written.startswith(prefix) for prefix in NOT_RUN) or written.startswith(SHELL_COMMANDS):
            continue
        name, *args = shlex.split(written)
        assert name.startswith("bearingtwin-"), f"docs/guide.md: {written!r} is neither bearingtwin's nor in NOT_RUN"
        name = name.removeprefix("bearingtwin-")
        if name == "report":
            check_report_settings(args[0], dict(arg.split("=", 1) for arg in args[1:]))
        else:
            refuse_bad_overrides(name, args)
        checked.append(written)
    assert len(checked) >= 10, checked


@pytest.mark.parametrize("documents", [
    pytest.param(DOCUMENTS[:1], id="readme"),
    pytest.param(DOCUMENTS, id="readme_and_guide", marks=pytest.mark.slow),
])
def test_every_documented_command_runs_as_written(tmp_path, documents):
    documented = [(document, command) for document in documents for command in document_commands(document)]
    assert {document for document, command in documented if command.startswith("bearingtwin-train")} == set(documents)
    root = data_root().resolve()
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    env = {**os.environ, "MLFLOW_TRACKING_URI": uri}
    before = checkout_state()
    # Each command once, in order, as (document, as written, module, arguments); skips and shell steps apart.
    runs, skipped, seen, unregistered = [], [], set(), set()
    for document, written in documented:
        if any(written.startswith(prefix) for prefix in NOT_RUN) or written in seen:
            continue
        seen.add(written)
        command = written.replace("/tmp/", f"{tmp_path}/").replace("../shared/data", str(root))
        if command.startswith(SHELL_COMMANDS):
            runs.append((document, written, None, command))
            continue
        assert command.startswith("bearingtwin-"), f"{document}: {written!r} is neither bearingtwin's nor in NOT_RUN"
        name, *args = shlex.split(command)
        name = name.removeprefix("bearingtwin-")
        needs = next((arg.split("=", 1)[-1] for arg in args if str(root) in arg), None)
        if name == "train":
            added, needs = train_additions(args)
            args += added
        elif name == "twin":
            args += [*TWIN_SMOKE, "figures=false"]  # eleven PNGs a run; the figures are tested in tests/test_twin_cli.py
        elif name == "diagnose":
            args.append("figures=false")  # the figures are tested in tests/test_diagnose.py
        elif name == "report":
            args.append(f"out={tmp_path}/results/{args[0]}.md")  # never the checkout's results/
        if needs is not None and not present(needs):
            skipped.append(f"{written} (needs {needs}, not present)")
            unregistered.update(arg.split("=", 1)[1] for arg in args if arg.startswith("register="))
            continue
        model = next((arg.split("=", 1)[1] for arg in args if arg.startswith("model=models:/")), "")
        if model.removeprefix("models:/").split("/")[0].split("@")[0] in unregistered:
            skipped.append(f"{written} (needs {model}, registered by a command skipped above)")
            continue
        runs.append((document, written, name, args))

    def run(document, written, name, args) -> str | None:
        """Run one command; a description of what went wrong, or None."""
        if name is None:
            subprocess.run(["bash", "-c", args], cwd=tmp_path, check=True)
            return None
        if any("<id>" in arg for arg in args):  # run_id=<id>: a run logged by an earlier command
            args = [arg.replace("<id>", newest_finished_training_run(uri)) for arg in args]
        done = run_module(f"bearingtwin.cli.{name}", *args, cwd=tmp_path, env=env, timeout=900)
        title = SUMMARY_TITLES.get(name) if "-m" not in args else None
        problem = "" if done.returncode == 0 else f"exit {done.returncode}"
        if not problem and title is not None:
            problem = summary_problem(done.stdout, title, uri)
        return f"{document}: {written}\n  {problem}\n  stdout: {done.stdout[-800:]}\n  stderr: {done.stderr[-1500:]}" if problem else None

    # Two at a time, for two cores: a command waits for the earlier ones that name a file or folder
    # it names (a twin needs its simulated record, a training its folder of recordings); a report
    # waits for every earlier command (its sweep, the run it repeats). Tasks start in document
    # order, so whatever a waiting task waits for is already running or done. A diagnosis waits for
    # every earlier training too: the model it names is registered by one.
    words = [shlex.split(args) if name is None else args for _, _, name, args in runs]
    after = [list(range(i)) if runs[i][2] == "report"
             else [j for j in range(i) if related(named_paths(words[i]), named_paths(words[j]), tmp_path)
                   or (runs[i][2] == "diagnose" and runs[j][2] == "train")] for i in range(len(runs))]
    futures = []

    def run_after(i):
        for j in after[i]:
            futures[j].result()
        return run(*runs[i])

    with ThreadPoolExecutor(max_workers=2) as pool:
        for i in range(len(runs)):
            futures.append(pool.submit(run_after, i))
        failures = [problem for problem in (future.result() for future in futures) if problem]
    assert not failures, f"{len(failures)} of {len(runs)} commands failed:\n" + "\n".join(failures)
    assert checkout_state() == before, "a documented command wrote into the checkout"
    if skipped:
        pytest.skip(f"ran {len(runs)} commands; skipped for absent data: " + "; ".join(skipped))
