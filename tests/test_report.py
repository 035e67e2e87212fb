"""bearingtwin-report on the store of a real smoke sweep: our figures beside the paper's."""

import json
import os
import re
import shutil
import sqlite3
from pathlib import Path

import pytest
from mlflow import MlflowClient
from processes import SMOKE, run_module

from bearingtwin.cli.report import main
from bearingtwin.config import REPO_ROOT
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.provenance import recorded_sizes
from bearingtwin.tracking import paper, reports
from bearingtwin.tracking.reports import GENERATED, mean_std
from bearingtwin.tracking.tables import generated_text

from test_sweep_e2e import session_folder, smoke_sweep_store


@pytest.fixture(scope="session")
def uri(tmp_path_factory):
    return smoke_sweep_store(session_folder(tmp_path_factory))[0]


def copy_store(uri, path) -> str:
    """A consistent copy of the SQLite store at ``uri`` (the sweep's tests may be writing to it meanwhile)."""
    source, copy = sqlite3.connect(uri.removeprefix("sqlite:///")), sqlite3.connect(path)
    try:
        source.backup(copy)
    finally:
        source.close()
        copy.close()
    return f"sqlite:///{path}"


def report(name, *settings):
    return run_module("bearingtwin.cli.report", name, *settings, timeout=600)


def finished(uri, method):
    client = MlflowClient(uri)
    experiment_id = client.get_experiment_by_name("bearingtwin").experiment_id
    return client.search_runs([experiment_id], f"tags.method = '{method}' and attributes.status = 'FINISHED'")


def test_a_generated_block_opens_a_new_file_under_its_heading_and_keeps_hand_written_text_after(tmp_path):
    from bearingtwin.tracking.tables import write_generated

    path, marker = tmp_path / "new" / "report.md", "<!-- generated -->"
    write_generated(path, "| a |", marker, heading="# Title")
    assert path.read_text() == f"# Title\n\n{marker}\n\n| a |\n\n{marker}\n"
    path.write_text(path.read_text() + "\n## Discussion\n")
    write_generated(path, "| b |", marker, heading="# Another title")  # an existing file keeps its own
    assert path.read_text() == f"# Title\n\n{marker}\n\n| b |\n\n{marker}\n\n## Discussion\n"
    bare = tmp_path / "bare.md"
    write_generated(bare, "| a |", marker)
    assert bare.read_text() == f"{marker}\n\n| a |\n\n{marker}\n"


def test_paper_figures_are_consistent_with_their_stated_statistics():
    mean, std = mean_std(paper.SEED_ACCURACIES)
    assert (round(mean, 2), round(std, 2)) == (paper.ACCURACY_MEAN, paper.ACCURACY_STD)
    assert paper.TABLE4[paper.PROPOSED] in paper.SEED_ACCURACIES


def test_table4_puts_each_method_beside_the_paper(uri, tmp_path):
    done = report("table4", f"uri={uri}", f"out={tmp_path}/table4.md")
    assert done.returncode == 0, done.stderr
    lines = {line.split(" | ")[1]: line for line in done.stdout.splitlines() if line.count("|") > 5 and "+" in line}
    for method, published in paper.TABLE4.items():
        (run,) = finished(uri, method)
        ours = 100 * run.data.metrics["accuracy"]
        assert lines[method].startswith(f"| {paper.TABLE4_NAMES[method]} | ")  # at its configured settings: no label
        assert f"| {ours:.2f} ± 0.00 | 1 | {published:.2f} | {ours - published:+.2f} |" in lines[method]
    written = (tmp_path / "table4.md").read_text()
    assert generated_text(tmp_path / "table4.md", GENERATED) == done.stdout.strip()  # between the markers
    # A file that is not a generated report is not written over (nor a folder, nor a place that cannot be).
    notes = tmp_path / "notes.md"
    notes.write_text("# My notes\nkept\n")
    for out, message in ((notes, "holds text that is not a generated report"), (tmp_path, "is a folder"),
                         ("/dev/null/table4.md", "cannot be written")):
        refused = report("table4", f"uri={uri}", f"out={out}")
        assert refused.returncode == 2 and message in refused.stderr and "Traceback" not in refused.stderr, refused.stderr
    assert notes.read_text() == "# My notes\nkept\n"
    misspelled = report("table4", f"uri={uri}", "experiment=bearingtwni", f"out={tmp_path}/t.md")
    assert misspelled.returncode == 2 and "experiment=bearingtwni: no such experiment" in misspelled.stderr, misspelled.stderr
    assert MlflowClient(uri).get_experiment_by_name("bearingtwni") is None  # not left behind
    mixed = report("cwru", f"uri={uri}", "source=all", f"out={tmp_path}/c.md")  # simulated runs in a CWRU table
    assert mixed.returncode == 2 and "source=all: this report reads data.source=cwru runs only" in mixed.stderr, mixed.stderr
    assert recorded_sizes(written) == {"data.duration": [1.0], "data.samples_per_class": [12.0], "search.iterations": [1.0],
                                       "search.population": [3.0], "search.windows": [2.0], "trainer.max_epochs": [2.0],
                                       "runs": [float(len(paper.TABLE4))]}  # one run of each method
    client = MlflowClient(uri)
    experiment_id = client.get_experiment_by_name("bearingtwin").experiment_id
    logged = client.search_runs([experiment_id], "tags.`bt.kind` = 'report' and tags.report = 'table4'")
    assert logged and {"table4.md", "runs.json"} <= {a.path for a in client.list_artifacts(logged[0].info.run_id)}
    # Its owner named, as every command's run: a report stopped while it logs is closed by the next command.
    assert {"bt.pid", "bt.host", "mlflow.user"} <= set(logged[0].data.tags) and logged[0].info.status == "FINISHED"
    # Which runs the table came from, and by which code.
    used = json.loads(Path(client.download_artifacts(logged[0].info.run_id, "runs.json", str(tmp_path))).read_text())
    assert {row["method"] for row in used} == set(paper.TABLE4) and all(row["git_commit"] for row in used)


def test_a_lone_run_at_other_settings_than_its_methods_is_named_so_beside_the_paper(tmp_path):
    """A SABO-VMD-SVM run on another bearing at another rate had stood in Table 4 as the method itself, beside the
    paper's figure: only runs of one method at several settings were told apart. Its row now names what sets it apart
    from the method as configured (conf/method/); a run at the configured settings stays unlabelled
    (test_table4_puts_each_method_beside_the_paper)."""
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    env = dict(os.environ, MLFLOW_TRACKING_URI=uri)
    done = run_module("bearingtwin.cli.train", *SMOKE, "+method=sabo_pemie_svm", "bearing=cwru_6203", "data.fs=12000",
                      f"hydra.run.dir={tmp_path}/run", cwd=tmp_path, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    done = report("table4", f"uri={uri}", f"out={tmp_path}/table4.md")
    assert done.returncode == 0, done.stderr
    (row,) = [line for line in done.stdout.splitlines() if "| sabo_vmd_pemie+svm |" in line]
    assert row.startswith("| SABO-VMD-SVM (PE-MIE) (bearing.name=cwru_6203, data.fs=12000) | sabo_vmd_pemie+svm | "), row


def test_a_setting_is_told_by_its_values_not_by_how_they_were_typed():
    """``data.fs=10000`` on the command line logs 10000, the config's default 10000.0: one setting. A bearing's own
    diameters stand behind its name; a ball count changed beside it is named."""
    from bearingtwin.tracking.reports import _differing_keys, _given_by_bearing_choice

    typed, default = {"data.fs": "10000", "__run_seed__": "0"}, {"data.fs": "10000.0", "__run_seed__": "1"}
    assert _differing_keys([[typed], [default]]) == set()
    assert _differing_keys([[typed], [{"data.fs": "12000", "__run_seed__": "2"}]]) == {"data.fs"}
    own = [{"bearing.name": "cwru_6203", "bearing.n_balls": "8", "bearing.pitch_diameter_mm": "28.499"}]
    changed = [{"bearing.name": "cwru_6203", "bearing.n_balls": "7", "bearing.pitch_diameter_mm": "28.499"}]
    assert _given_by_bearing_choice("bearing.n_balls", own) and _given_by_bearing_choice("bearing.pitch_diameter_mm", own)
    assert not _given_by_bearing_choice("bearing.n_balls", changed) and not _given_by_bearing_choice("bearing.name", own)
    # A bearing of the user's own, no config of it here (the report is no Hydra command: no search path): its name
    # stands for the geometry every run naming it logged alike, and no longer where two runs logged two.
    mine = [{"bearing.name": "skf_6206", "bearing.n_balls": "9"}]
    assert _given_by_bearing_choice("bearing.n_balls", mine, {("skf_6206", "bearing.n_balls"): {"9"}})
    assert not _given_by_bearing_choice("bearing.n_balls", mine, {("skf_6206", "bearing.n_balls"): {"9", "10"}})


def report_here(capsys, *args) -> tuple[int, str]:
    """``bearingtwin-report <args>`` in this process: exit status and stderr."""
    try:
        code = main(list(args))
    except SystemExit as stop:
        code = stop.code
    return code, capsys.readouterr().err


def test_results_go_to_the_working_directory_and_smoke_runs_do_not_replace_full_ones(uri, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    checkout_results = {path: path.stat().st_mtime for path in (REPO_ROOT / "results").glob("*.md")}
    assert report_here(capsys, "table4", f"uri={uri}")[0] == 0
    assert (tmp_path / "results" / "table4.md").is_file()
    assert {path: path.stat().st_mtime for path in (REPO_ROOT / "results").glob("*.md")} == checkout_results
    # A file made from full-size runs (the committed table4.md records none: it counts as full size).
    full = tmp_path / "full.md"
    shutil.copy(REPO_ROOT / "results" / "table4.md", full)
    code, err = report_here(capsys, "table4", f"uri={uri}", f"out={full}")
    assert code == 2 and full.read_text() == (REPO_ROOT / "results" / "table4.md").read_text()
    (line,) = err.strip().splitlines()
    assert f"{full}: holds results of larger runs than these" in line
    assert "data.samples_per_class=12 (file: 150)" in line and "trainer.max_epochs=2 (file: 100)" in line and "force=true" in line
    assert report_here(capsys, "table4", f"uri={uri}", f"out={full}", "force=true")[0] == 0
    assert recorded_sizes(full.read_text())["data.samples_per_class"] == [12.0]
    assert "Commands, from the checkout root" in full.read_text()  # the hand-written header is kept
    assert report_here(capsys, "table4", f"uri={uri}", f"out={full}")[0] == 0  # same sizes: no force needed
    # A part of the table (one method's runs gone: another sweep's table) does not replace the whole without force:
    # that method's row would read "not run".
    partial = copy_store(uri, tmp_path / "partial.db")
    for run in finished(partial, "raw+cnn_bilstm"):
        MlflowClient(partial).delete_run(run.info.run_id)
    before = full.read_text()
    code, err = report_here(capsys, "table4", f"uri={partial}", f"out={full}")
    n = len(paper.TABLE4)
    assert code == 2 and f"runs={n - 1} (file: {n})" in err and full.read_text() == before, err



def test_rows_of_runs_of_different_sizes_are_said_to_be_so_where_a_reader_sees_it(uri, tmp_path, capsys):
    """The size record is an HTML comment; a table whose rows were computed at different sizes says so in words."""
    assert report_here(capsys, "table4", f"uri={uri}", f"out={tmp_path}/same.md")[0] == 0
    same = (tmp_path / "same.md").read_text()
    assert "different sizes" not in same  # the smoke sweep: one size throughout
    # ...but smaller than the configured one, which a reader of the rendered table must see beside the paper's.
    assert "Smaller runs than the configured ones: data.duration=1 (configured " in same
    assert "they are no measure beside the paper's" in same
    mixed = copy_store(uri, tmp_path / "mixed.db")
    (run,) = finished(mixed, "raw+cnn_bilstm")
    with sqlite3.connect(tmp_path / "mixed.db") as database:  # params are write-once: the store's row is edited
        database.execute("update params set value = '7' where run_uuid = ? and key = 'trainer.max_epochs'",
                         (run.info.run_id,))
    assert report_here(capsys, "table4", f"uri={mixed}", f"out={tmp_path}/mixed.md")[0] == 0
    assert "Runs of different sizes stand side by side here: trainer.max_epochs 2, 7." in (tmp_path / "mixed.md").read_text()
    assert "several versions of the code" not in same  # the smoke sweep: one commit
    # Numbers of another version of the code beside this one's: said in words, not only in the run's runs.json.
    MlflowClient(mixed).set_tag(run.info.run_id, "git_commit", "0123456789abcdef0123-dirty")
    assert report_here(capsys, "table4", f"uri={mixed}", f"out={tmp_path}/mixed.md")[0] == 0
    said = (tmp_path / "mixed.md").read_text()
    assert "Runs of several versions of the code stand side by side here: " in said
    assert re.search(r"0123456789ab-dirty code [0-9a-f]{12} \(1 run\)", said), said  # with the key of its code
    # Two states of one commit with changes not committed are two versions, told apart by their code's key (the same
    # git_commit tag had read as one version).
    client = MlflowClient(mixed)
    for other in client.search_runs(run.info.experiment_id, "attributes.status = 'FINISHED'"):
        client.set_tag(other.info.run_id, "git_commit", "0123456789abcdef0123-dirty")
        client.set_tag(other.info.run_id, "code", "aaaaaaaaaaaa" if other.info.run_id == run.info.run_id else "bbbbbbbbbbbb")
    assert report_here(capsys, "table4", f"uri={mixed}", f"out={tmp_path}/mixed.md")[0] == 0
    said = (tmp_path / "mixed.md").read_text()
    assert "0123456789ab-dirty code aaaaaaaaaaaa (1 run)" in said and "0123456789ab-dirty code bbbbbbbbbbbb (" in said


def test_a_run_larger_than_configured_is_a_row_of_its_own_not_the_methods_seeds(uri, tmp_path, capsys, monkeypatch):
    """An epochs ablation (trainer.max_epochs=1500 against the configured 100) had replaced a method's five
    configured seeds as 'a larger run of the method', its row unnamed: a size beyond the configured one is a setting
    of its own, named in its row, while a smaller one (a smoke run) stays a smaller run of the same setting."""
    from types import SimpleNamespace

    from bearingtwin.tracking import reports

    def logged(run_id, seed, epochs, start):
        return SimpleNamespace(info=SimpleNamespace(run_id=run_id, start_time=start), data=SimpleNamespace(
            tags={"method": "raw+cnn_bilstm", "seed": str(seed)},
            params={"classifier.name": "cnn_bilstm", "features.kind": "raw", "seed": str(seed),
                    "trainer.max_epochs": str(epochs)}))

    configured = [logged(f"c{seed}", seed, 100, seed) for seed in range(5)]
    runs = [logged("long", 0, 1500, 10), logged("smoke", 7, 3, 11), *configured][::-1]
    monkeypatch.setattr(reports, "find_runs", lambda *args: sorted(runs, key=lambda run: -run.info.start_time))
    source = reports.ReportInput(None, "0", {})
    kept = source.training_runs(beside_paper=True)
    assert sorted(run.info.run_id for run in kept) == ["c0", "c1", "c2", "c3", "c4", "long"]
    assert source.setting(next(run for run in kept if run.info.run_id == "long")) == "trainer.max_epochs=1500"
    assert {source.setting(run) for run in kept if run.info.run_id != "long"} == {"trainer.max_epochs=100"}
    assert source.left_out == ["raw+cnn_bilstm seed 7 (trainer.max_epochs=3)"]  # the smoke run, smaller


def test_table3_per_class_beside_the_paper(uri, tmp_path):
    done = report("table3", f"uri={uri}", f"out={tmp_path}/table3.md")
    assert done.returncode == 0, done.stderr
    (run,) = finished(uri, paper.PROPOSED)
    recall = run.data.metrics["recall_normal"]
    assert f"| normal | recall | {recall:.3f} ± 0.000 | 0.933 | {recall - 0.933:+.3f} |" in done.stdout
    assert f"{paper.ACCURACY_MEAN:.2f} ± {paper.ACCURACY_STD:.2f}" in done.stdout


def test_seeds_and_vmd_params_reports(uri, tmp_path):
    (run,) = finished(uri, paper.PROPOSED)
    ours = 100 * run.data.metrics["accuracy"]
    seeds = report("seeds", f"uri={uri}", f"out={tmp_path}/seeds.md")
    assert seeds.returncode == 0, seeds.stderr
    assert (f"| {paper.PROPOSED} | {run.data.tags['seed']}: {ours:.2f} | {ours:.2f} ± 0.00 | "
            "98.33, 98.88, 98.88, 97.78, 98.33 |") in seeds.stdout, seeds.stdout
    scopes = report("vmd_params", f"uri={uri}", f"out={tmp_path}/vmd.md")
    assert scopes.returncode == 0 and f"| global | {ours:.2f} ± 0.00 | 1 | — |" in scopes.stdout, scopes.stdout


def test_a_later_run_with_other_vmd_params_does_not_displace_the_tables_runs(uri, tmp_path):
    (proposed,) = finished(uri, paper.PROPOSED)
    (raw,) = finished(uri, "raw+cnn_bilstm")
    copy = copy_store(uri, tmp_path / "copy.db")
    client = MlflowClient(copy)
    tags = {"bt.kind": "train", "method": paper.PROPOSED, "seed": proposed.data.tags["seed"]}
    later = client.create_run(proposed.info.experiment_id, tags=tags).info.run_id  # newer than every smoke run
    client.log_param(later, "features.vmd_params", "per_class")
    client.log_param(later, "data.source", proposed.data.params["data.source"])
    client.log_metric(later, "accuracy", 0.25)
    client.set_terminated(later, "FINISHED")
    honest = report("table4", f"uri={copy}", f"out={tmp_path}/global.md")
    leaky = report("table4", f"uri={copy}", "vmd_params=per_class", f"out={tmp_path}/per_class.md")
    assert honest.returncode == 0 and leaky.returncode == 0, honest.stderr + leaky.stderr
    assert f"| {100 * proposed.data.metrics['accuracy']:.2f} ± 0.00 | 1 |" in honest.stdout and "vmd_params=global" in honest.stdout
    assert f"| {paper.PROPOSED} | 25.00 ± 0.00 | 1 |" in leaky.stdout
    assert f"| {100 * raw.data.metrics['accuracy']:.2f} ± 0.00 | 1 |" in leaky.stdout  # raw features have no VMD parameters


def test_a_smoke_run_is_not_averaged_with_full_size_runs_of_its_method(uri, tmp_path):
    """A store holding a full-size run of a method (another seed, ten times the data) beside the smoke sweep's:
    the table is the full-size run's alone, and the smoke run is named as left out, in the file as on screen."""
    from mlflow.entities import Param

    (proposed,) = finished(uri, paper.PROPOSED)
    copy = copy_store(uri, tmp_path / "copy.db")
    client = MlflowClient(copy)
    duration = float(proposed.data.params["data.duration"])
    full = client.create_run(proposed.info.experiment_id,
                             tags={"bt.kind": "train", "method": paper.PROPOSED, "seed": "8"}).info.run_id
    client.log_batch(full, params=[Param(key, str(10 * duration) if key == "data.duration" else value)
                                   for key, value in proposed.data.params.items()])
    client.log_metric(full, "accuracy", 0.5)
    client.set_terminated(full, "FINISHED")
    # A newer smoke run of the full-size run's seed does not hide it.
    newer = client.create_run(proposed.info.experiment_id,
                              tags={"bt.kind": "train", "method": paper.PROPOSED, "seed": "8"}).info.run_id
    client.log_batch(newer, params=[Param(key, value) for key, value in proposed.data.params.items()])
    client.log_metric(newer, "accuracy", 0.25)
    client.set_terminated(newer, "FINISHED")
    done = report("table4", f"uri={copy}", f"out={tmp_path}/table4.md")
    assert done.returncode == 0, done.stderr
    assert f"| {paper.PROPOSED} | 50.00 ± 0.00 | 1 |" in done.stdout
    left_out = (f"Left out, smaller than the other runs of their method (a smoke run is not averaged with full-size "
                f"ones): {paper.PROPOSED} seed {proposed.data.tags['seed']} (data.duration={duration:g}")
    assert left_out in done.stdout and left_out in (tmp_path / "table4.md").read_text()


def repeat_here(uri, run_id, out, capsys) -> tuple[int, str]:
    """``bearingtwin-report repeat`` in this process: its exit status and what it printed."""
    try:
        code = main(["repeat", f"uri={uri}", f"run_id={run_id}", f"out={out}"])
    except SystemExit as stop:
        code = stop.code
    return code, capsys.readouterr().out


def test_repeat_reproduces_a_logged_run_and_catches_a_difference(uri, tmp_path, capsys):
    (run,) = finished(uri, "sabo_vmd_pemie+svm")
    same = report("repeat", f"uri={uri}", f"run_id={run.info.run_id}", f"out={tmp_path}/repeat.md")
    assert same.returncode == 0, same.stderr
    assert "every metric matches" in same.stdout and "| NO |" not in same.stdout
    assert "| n_train |" in same.stdout and "| n_test |" in same.stdout  # every metric the run logged, these too
    # Computed afresh: the run's own cache (its config names it) would have handed its features back unchanged.
    assert "its simulation and features computed afresh" in same.stdout and "repeated by the code at " in same.stdout
    tampered = copy_store(uri, tmp_path / "copy.db")
    MlflowClient(tampered).log_metric(run.info.run_id, "accuracy", run.data.metrics["accuracy"] - 0.1)
    # The command's exit status and table, in this process (the command itself ran above): the run trained again.
    code, differs = repeat_here(tampered, run.info.run_id, tmp_path / "repeat2.md", capsys)
    assert code == 1 and "MISMATCH" in differs
    assert "| accuracy |" in differs and "| NO |" in differs


def test_repeat_simulates_and_extracts_afresh(uri, tmp_path, capsys, monkeypatch):
    """The stored config names the run's own cache, which would hand its simulation and features back unchanged: a
    repeat reads and writes a cache of its own, and leaves the run's as it was. Its progress bars are the repeat's
    own (none into a log), not those the run showed in its terminal."""
    import bearingtwin.models.experiment as experiment
    from bearingtwin.tracking.mlflow_logging import stored_config

    (run,) = finished(uri, "sabo_vmd_pemie+svm")
    own = Path(stored_config(MlflowClient(uri), run.info.run_id).paths.cache_dir)
    before = sorted(path.name for path in own.rglob("*.npz"))

    def as_run_in_a_terminal(client, run_id):  # its bars shown: the repeat shows them as it is run (here, a log)
        cfg = stored_config(client, run_id)
        cfg.trainer.progress_bar = cfg.features.progress = True
        return cfg

    monkeypatch.setattr(reports, "stored_config", as_run_in_a_terminal)
    used = []
    original = experiment.run_experiment
    monkeypatch.setattr(experiment, "run_experiment", lambda cfg, root_dir: used.append(
        (cfg.paths.cache_dir, cfg.trainer.progress_bar, cfg.features.progress)) or original(cfg, root_dir))
    code, said = repeat_here(uri, run.info.run_id, tmp_path / "repeat.md", capsys)
    assert code == 0 and "every metric matches" in said
    ((cache_dir, *bars),) = used
    assert Path(cache_dir).resolve() != own.resolve() and not Path(cache_dir).exists()  # removed after
    assert bars == [False, False]
    assert sorted(path.name for path in own.rglob("*.npz")) == before


def test_repeat_compares_a_training_curve_at_every_epoch(uri, tmp_path, capsys):
    """The network's curves are metrics too: one epoch's loss logged otherwise is a mismatch, though the last
    epoch's value and every final score agree."""
    run = finished(uri, paper.PROPOSED)[0]
    history = MlflowClient(uri).get_metric_history(run.info.run_id, "test_loss")
    assert len(history) >= 2  # a curve of several epochs to tamper with below the last
    tampered = copy_store(uri, tmp_path / "copy.db")
    first = min(history, key=lambda point: point.step)
    MlflowClient(tampered).log_metric(run.info.run_id, "test_loss", first.value + 1.0, step=first.step)
    code, said = repeat_here(tampered, run.info.run_id, tmp_path / "repeat.md", capsys)
    assert code == 1 and "MISMATCH" in said
    (row,) = [line for line in said.splitlines() if line.startswith("| test_loss (")]
    assert f"({len(history)} epochs, the last shown)" in row and row.endswith("| NO |")
    assert "| accuracy | " in said and all(line.endswith("| yes |") for line in said.splitlines()
                                           if line.startswith("| accuracy |"))


def test_a_run_logged_when_the_test_curves_were_called_val_is_repeated_as_it_was(uri, tmp_path, capsys):
    """The network's per-epoch curves on the test windows were logged as val_loss and val_accuracy before they took
    their names test_*: such a run repeats as matching, not as missing two curves."""
    run = finished(uri, paper.PROPOSED)[0]
    older = copy_store(uri, tmp_path / "older.db")
    with sqlite3.connect(older.removeprefix("sqlite:///")) as store:
        for table in ("metrics", "latest_metrics"):
            store.execute(f"UPDATE {table} SET key = 'val_' || substr(key, 6) WHERE key IN ('test_loss', 'test_accuracy')"
                          " AND run_uuid = ?", (run.info.run_id,))
    assert "val_loss" in MlflowClient(older).get_run(run.info.run_id).data.metrics
    code, said = repeat_here(older, run.info.run_id, tmp_path / "repeat.md", capsys)
    assert code == 0 and "every metric matches" in said and "| test_loss (" in said, said


def test_a_sweep_folder_no_sweep_ran_in_is_said_so_with_the_folders_the_store_knows(uri, capsys, tmp_path):
    """sweep_dir= a folder of no sweep of the store (a typo, a relative path read from elsewhere): not "train them
    first" (they ran), but where this store's sweeps did run."""
    client = MlflowClient(uri)
    ran = {run.data.tags["sweep_dir"] for run in client.search_runs(
        [e.experiment_id for e in client.search_experiments()], "tags.`bt.kind` = 'sweep'")}
    with pytest.raises(SystemExit) as exit_info:
        main(["seeds", f"uri={uri}", f"sweep_dir={tmp_path}/no_such_sweep", f"out={tmp_path}/seeds.md"])
    said = capsys.readouterr().err
    assert exit_info.value.code == 2 and f"no sweep of this store ran in {tmp_path}/no_such_sweep" in said
    assert "train them first" not in said and any(folder in said for folder in ran), said


@pytest.mark.parametrize("report, command", [
    ("table4", "bearingtwin-train -m +sweep=table4 launcher=joblib"),
    ("seeds", "bearingtwin-train -m +sweep=table4 launcher=joblib"),
    ("vmd_params", "bearingtwin-train -m +sweep=vmd_params launcher=joblib"),
    ("cwru", "bearingtwin-train -m +sweep=cwru launcher=joblib"),
])
def test_a_report_with_no_runs_names_the_command_that_trains_them(capsys, tmp_path, report, command):
    uri = f"sqlite:///{tmp_path}/mlflow.db"
    MlflowClient(uri).create_experiment("bearingtwin", (tmp_path / "artifacts").as_uri())  # a store, no runs
    with pytest.raises(SystemExit) as exit_info:
        main([report, f"uri={uri}", f"out={tmp_path}/{report}.md"])
    said = capsys.readouterr().err
    assert exit_info.value.code == 2 and said.rstrip().endswith(f"train them first: {command}"), said


def test_bad_requests_exit_2_naming_the_problem(uri, capsys, tmp_path):
    with pytest.raises(SystemExit) as exit_info:  # argparse had called key=value required too
        main([])
    assert exit_info.value.code == 2 and capsys.readouterr().err.splitlines()[-1] == (
        "bearingtwin-report: error: the report's name is required: one of cwru, hust, repeat, seeds, sim2real, table3, "
        "table4, vmd_params")
    with pytest.raises(SystemExit) as exit_info:
        main(["table5", f"uri={uri}"])
    assert exit_info.value.code == 2 and "unknown report 'table5'" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["table4", f"uri={uri}", "colour=blue"])
    assert "table4 does not take colour" in capsys.readouterr().err
    for setting, allowed in (("vmd_params=bogus", "global, per_class, per_sample"), ("source=bogus", "simulated, cwru")):
        with pytest.raises(SystemExit) as exit_info:  # it would find no runs, and say "train them first"
            main(["table4", f"uri={uri}", setting])
        assert exit_info.value.code == 2 and f"{setting}: choose one of {allowed}" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["repeat", f"uri={uri}", "run_id=0123"])
    assert "run_id=0123" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:  # pasted into MLflow's filter, a quote broke it with a traceback
        main(["table4", f"uri={uri}", "sweep_dir=/tmp/a'b"])
    assert exit_info.value.code == 2 and "sweep_dir=/tmp/a'b: a quote cannot be matched" in capsys.readouterr().err
    (proposed,) = finished(uri, paper.PROPOSED)  # a run an interrupt stopped has no results to repeat
    copy = copy_store(uri, tmp_path / "copy.db")
    killed = MlflowClient(copy).create_run(proposed.info.experiment_id, tags={"bt.kind": "train"}).info.run_id
    MlflowClient(copy).set_terminated(killed, "KILLED")
    with pytest.raises(SystemExit) as exit_info:
        main(["repeat", f"uri={copy}", f"run_id={killed}", f"out={tmp_path}/repeat.md"])
    assert exit_info.value.code == 2 and f"run_id={killed}: the run is KILLED, not FINISHED" in capsys.readouterr().err


def test_the_twin_chosen_without_the_test_records_is_the_best_validated_then_the_simplest():
    from bearingtwin.tracking.reports import chosen_without_test

    def row(effects, val, step=0, hand_set=(), variants=None):
        return {"effects": list(effects), "calibration_accuracy_mean": val, "step": step, "hand_set_effects": list(hand_set),
                "variants": variants or {}}

    bare, slip = row([], 0.90), row(["slip"], 0.99, step=1)
    full = row(["slip", "load_zone", "noise"], 0.9995, step=2)
    varied = row(["slip", "load_zone", "noise"], 0.9992, step=2, variants={"spin_slip.jitter": [0.1, 0.4]})
    hand = row(["slip", "preload"], 1.0, step=1, hand_set=["preload"])
    # Within 0.1 % of the best, the simplest wins; a hand-set twin is never a candidate, however well it validates.
    assert chosen_without_test([bare, full, varied, slip, hand]) is full  # slip is 0.95 % below: not tied
    assert chosen_without_test([bare, row(["slip"], 0.9990, step=1), full, hand])["effects"] == ["slip"]
    assert chosen_without_test([row([], None), hand]) is None


def test_the_sim2real_figure_draws_validated_twins_with_the_healthy_records_noise_only(tmp_path):
    from bearingtwin.tracking.reports import _plot_sim2real

    def row(step, healthy_step=1, validated=True, variants=None):
        return {"method": "envelope_prominence+band_power+svm (linear)", "step": step, "healthy_step": healthy_step,
                "effects": ["slip", "load_zone", "resonance", "noise"],
                "hand_set_effects": [], "variants": variants or {}, "accuracy_mean": 0.5 + 0.1 * step,
                "accuracy_std": 0.02, "calibration_accuracy_mean": 0.9 if validated else None,
                "calibration_recall_normal_mean": 0.8 if validated else None}

    path = tmp_path / "sim2real.png"
    drawn = _plot_sim2real([row(s) for s in range(4)] + [row(s, variants={"spin_slip.jitter": [0.1]}) for s in range(4)], path)
    assert drawn == path and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
    other = tmp_path / "none.png"  # session-2 runs (no calibration check) and twins without 97's noise: nothing to draw
    assert _plot_sim2real([row(0, validated=False), row(1, healthy_step=0)], other) is None and not other.exists()


def test_table3_says_a_class_without_test_windows_has_no_scores():
    """A CWRU run at a load without a healthy record scores no healthy class: a dash, not a KeyError."""
    from types import SimpleNamespace

    from bearingtwin.tracking.reports import table3

    metrics = {f"{metric}_{name}": 0.9 for name in paper.TABLE3 if name != "normal" for metric in ("precision", "recall", "f1")}
    run = SimpleNamespace(data=SimpleNamespace(metrics={**metrics, "accuracy": 0.9}))
    source = SimpleNamespace(settings={}, training_runs=lambda *args, **kwargs: [run], setting=lambda run: "")
    text = table3(source).markdown
    assert "| normal | recall | — | 0.933 | — |" in text
    assert "| inner | recall | 0.900 ± 0.000 |" in text


def test_help_lists_the_settings_each_report_takes(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    said = " ".join(capsys.readouterr().out.split())
    assert "Every report takes uri=, experiment=, out=, sweep_dir=, source=, force=" in said
    assert "repeat: run_id" in said and "table4: vmd_params" in said


def test_the_device_a_run_computed_on_is_no_setting_of_its_method():
    """A smoke run with trainer.accelerator=cpu beside a full run with auto showed as two rows of one method, where the
    smaller run is to be left out as such; a classifier's own setting still makes another row."""
    from types import SimpleNamespace

    from bearingtwin.tracking.reports import _same_setting, setting_params

    def run(**params):
        return SimpleNamespace(data=SimpleNamespace(params={"classifier.kernel": "linear", "seed": "0", **params}))

    on_cpu, on_auto = setting_params(run(**{"trainer.accelerator": "cpu"})), setting_params(run(**{"trainer.accelerator": "auto"}))
    assert _same_setting(on_cpu, on_auto) and "trainer.accelerator" not in on_cpu
    assert not _same_setting(setting_params(run(**{"classifier.kernel": "rbf"})), on_auto)


def test_a_run_that_let_the_physics_decide_is_another_setting_than_one_that_did_not():
    """physics_first is logged as one null key when unset and as its settings when set: the two must not pass for
    one setting (averaged together, or one taken for the other's seed), while a run from before the key is plain."""
    from types import SimpleNamespace

    from bearingtwin.tracking.reports import _same_setting, setting_params

    def run(**params):
        return SimpleNamespace(data=SimpleNamespace(params={"classifier.kernel": "linear", "seed": "0", **params}))

    before, plain = setting_params(run()), setting_params(run(physics_first="None"))
    gated = setting_params(run(**{"physics_first.threshold_db": "20.0", "physics_first.margin_db": "10.0"}))
    assert _same_setting(before, plain) and _same_setting(plain, before)
    assert not _same_setting(gated, plain) and not _same_setting(before, gated)
    assert gated["physics_first"] == "margin_db=10.0,threshold_db=20.0"


def test_a_run_with_other_effects_or_another_fixed_seed_is_another_row_not_a_seed():
    """A stray run beside a sweep had replaced one of its seeds unlabelled: with effects=[noise] (logged as
    effects.noise.* where the sweep logged effects={}, no key shared) or features.seed=7 (every key ending in seed had
    been dropped). A seed that follows the run's own (data.twin.seed: ${seed}) still differs from seed to seed of one
    setting."""
    from types import SimpleNamespace

    from bearingtwin.tracking.reports import _differing_keys, _same_setting, setting_params

    def run(seed, **params):
        return setting_params(SimpleNamespace(data=SimpleNamespace(params={
            "classifier.kernel": "linear", "seed": str(seed), "effects": "{}", "features.seed": "0", **params})))

    sweep = [run(seed) for seed in range(5)]
    assert all(_same_setting(a, b) for a in sweep for b in sweep) and not _differing_keys([sweep])
    noisy = run(0, **{"effects.noise.snr_db": "10.0"})
    assert noisy["effects"] == "noise(snr_db=10.0)" and not _same_setting(noisy, sweep[0])
    assert not _same_setting(run(0, **{"features.seed": "7"}), sweep[0])
    assert not _same_setting(run(1, **{"features.seed": "1"}), sweep[1])  # follows where the sweep's is fixed
    following = [run(seed, **{"data.twin.seed": str(seed)}) for seed in range(5)]
    assert all(_same_setting(a, b) for a in following for b in following)
    assert not _same_setting(run(0, **{"data.twin.seed": "7"}), following[1])
    assert _differing_keys([sweep, [run(0, **{"features.seed": "7"})]]) == {"features.seed"}
    assert _differing_keys([following, [run(1, **{"data.twin.seed": "1", "classifier.kernel": "rbf"})]]) == {
        "classifier.kernel"}


def test_an_svms_epochs_are_no_size_of_its_run():
    """An SVM is fitted in closed form: its logged trainer.max_epochs (the default, 100) would make a table of smoke
    networks look smaller than one of full-size SVMs, and a full table's network rows look larger than they were."""
    from types import SimpleNamespace

    from bearingtwin.tracking.provenance import run_sizes, used_sizes

    def logged(**params):
        return SimpleNamespace(data=SimpleNamespace(params={key.replace("__", "."): str(v) for key, v in params.items()}))

    svm = logged(classifier__name="svm", trainer__max_epochs=100, data__samples_per_class=150)
    network = logged(classifier__name="cnn_bilstm", trainer__max_epochs=3, data__samples_per_class=150)
    assert used_sizes(svm) == {"data.samples_per_class": 150.0}
    assert used_sizes(network) == {"data.samples_per_class": 150.0, "trainer.max_epochs": 3.0}
    assert run_sizes([svm, network])["trainer.max_epochs"] == [3.0]


def test_a_variants_table_has_a_file_of_its_own():
    """``table3 vmd_params=per_class`` had written over the global table's file."""
    from bearingtwin.tracking.reports import report_stem

    assert report_stem("table3", {}) == report_stem("table3", {"vmd_params": "global"}) == "table3"
    assert report_stem("table3", {"vmd_params": "per_class", "uri": "x"}) == "table3_per_class"
    assert report_stem("cwru", {"load": "1"}) == "cwru_load1" and report_stem("hust", {"condition": "65"}) == "hust_65Hz"
    with pytest.raises(BearingTwinError, match="condition='a/b': give a plain value"):
        report_stem("hust", {"condition": "a/b"})
    assert report_stem("repeat", {"run_id": "abc"}) == "repeat_abc"


def test_larger_runs_replace_smaller_ones_however_few_they_are(tmp_path):
    """One full-size run replaces five smoke runs; fewer runs of the same size, or smaller ones, do not."""
    from bearingtwin.tracking.provenance import check_replacement, size_record

    page = tmp_path / "table3.md"
    page.write_text(size_record({"data.duration": [2.0], "trainer.max_epochs": [3.0], "runs": [5.0]}))
    check_replacement(page, {"data.duration": [10.0], "trainer.max_epochs": [50.0], "runs": [1.0]}, {}, force=False)
    for smaller in ({"data.duration": [2.0], "trainer.max_epochs": [3.0], "runs": [4.0]},
                    {"data.duration": [10.0], "trainer.max_epochs": [2.0], "runs": [5.0]}):
        with pytest.raises(BearingTwinError, match="holds results of larger runs than these"):
            check_replacement(page, smaller, {}, force=False)
