"""The identifiability benchmark on another rig's records: a manifest of files judged as the split's cases are.

Small trial budgets and two candidates keep each run to seconds; the full-size rates are in
results/identifiability.md.
"""

import csv
import io
import re
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from script_modules import load_script
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "identifiability.py"
QUICK = ["calibration.n_trials_base=4", "calibration.n_trials_effect=2", "calibration.n_trials_refine=2",
         "calibration.n_polish=0", "calibration.n_polish_effect=0", "candidates=[slip,tones]", "ranking.n_jobs=1"]
SELECTION = ["--split", "dev", "--sources", "rig", "--faults", "outer", "--limit", "2"]


def benchmark(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def module():
    return load_script(SCRIPT)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    done = benchmark(*SELECTION, "--export", str(folder / "cases"), cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder / "cases" / "cases.csv"


@pytest.fixture(scope="module")
def twin_cfg():
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("twin", overrides=["bearing=cwru_6205", "measured.path=unused"])


def test_exported_records_are_judged_as_the_split_judges_its_cases(exported, tmp_path):
    with exported.open() as handle:
        rows = list(csv.DictReader(handle))
    assert [row["hidden"] for row in rows] == ["resonance", "slip"]
    assert len({row["reference"] for row in rows}) == 1  # one operating point: one reference, as in a run
    from_files = benchmark("--records", str(exported), "--out", str(tmp_path / "records"), *QUICK, "bearing=cwru_6205",
                           cwd=tmp_path)
    assert from_files.returncode == 0, from_files.stderr
    in_memory = benchmark(*SELECTION, "--out", str(tmp_path / "split"), *QUICK, cwd=tmp_path)
    assert in_memory.returncode == 0, in_memory.stderr
    listed = json.loads((tmp_path / "records" / "identifiability.json").read_text())
    made = json.loads((tmp_path / "split" / "identifiability_dev.json").read_text())
    assert [r["source"] for r in listed] == ["records", "records"]
    for record, case in zip(listed, made):
        assert record["hidden"] == case["hidden"]
        assert record["added"] == case["added"]
        assert record["reference_base"] == case["reference_base"]  # the reference fitted alike
        assert record["steps"] == pytest.approx(case["steps"], rel=1e-9)
        assert [entry[0] for entry in record["ranking"]] == [entry[0] for entry in case["ranking"]]
        assert [entry[3] for entry in record["ranking"]] == pytest.approx([entry[3] for entry in case["ranking"]])
    report = (tmp_path / "records" / "identifiability.md").read_text()
    assert "| case kind | goal | twin -> listed records |" in report
    assert str(exported) in report and "12000 Hz, g" in report
    # resonance is no candidate here: its case is a miss, named by its file
    assert f"| {Path(rows[0]['record']).name} | records | single | outer | resonance |" in report


def test_the_seed_columns_reach_the_runs(module, exported, twin_cfg):
    """A split's seeds travel in the manifest; edited, the record's run and its reference's take the new ones."""
    listed = module.cases_from_manifest(exported, twin_cfg)
    assert [case["seed"] for case in listed] == [0, 1] and {case["reference"]["seed"] for case in listed} == {500}
    assert module.twin_seed(module.reference_of(listed[0])) == 500
    edited = module.cases_from_manifest(rewrite(exported, seed="1234", reference_seed="2345"), twin_cfg)[0]
    assert module.twin_seed(edited) == 1234 and module.twin_seed(module.reference_of(edited)) == 2345
    # Another reference seed is another reference run, even for the same file.
    assert module._reference_key(edited) != module._reference_key(listed[0])
    signal = module.measurement(listed[0], twin_cfg).signal
    assert np.array_equal(signal, np.load(exported.parent / listed[0]["measured"]["path"])["signal"])


def rewrite(manifest: Path, *extra_rows: dict, blank_lines: int = 0, text_before: str = "", **changes) -> Path:
    """A copy of ``manifest`` beside its records with the first row's columns changed (None: column removed),
    ``blank_lines`` empty lines after the header and ``extra_rows`` appended."""
    with manifest.open() as handle:
        rows = list(csv.DictReader(handle))
    rows[0].update({k: v for k, v in changes.items() if v is not None})
    columns = [c for c in dict.fromkeys(key for row in (rows[0], *extra_rows) for key in row)
               if changes.get(c, "") is not None]
    lines = io.StringIO()
    writer = csv.DictWriter(lines, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    lines.write("\n" * blank_lines)
    writer.writerows([*rows, *extra_rows])
    path = manifest.parent / f"edited_{len(list(manifest.parent.glob('edited_*')))}.csv"
    path.write_text(text_before + lines.getvalue(), encoding="utf-8")
    return path


@pytest.mark.parametrize(("changes", "message"), [
    ({"hidden": None}, r"has no column hidden; its header reads record,reference,kind,seed,reference_seed"),
    ({"kind": "triple"}, r"line 2: kind 'triple' is not one of single, pair, null, out_of_library"),
    ({"kind": "pair"}, r"line 2: a case of kind pair hides two different effects"),
    ({"kind": "pair", "hidden": "slip+slip"}, r"line 2: a case of kind pair hides two different effects"),
    ({"hidden": "gear_mesh"}, r"line 2: hidden gear_mesh is not a library effect .*out_of_library"),
    ({"kind": "out_of_library", "hidden": "unbalance"}, r"line 2: hidden unbalance is a library effect"),
    ({"record": "missing.npz"}, r"line 2: record .*missing.npz does not exist"),
    ({"record": "."}, r"line 2: record .* is not a file"),
    ({"fs": "twelve"}, r"line 2: fs 'twelve' is not a number"),
    ({"record": ""}, r"line 2: the record column is empty"),
    ({"fault": "inner"}, r"line 2: .*000_rig_single_outer_resonance.npz: .*fault"),
    ({"seed": "-3"}, r"line 2: seed '-3' is not a seed"),
    ({"reference_seed": "\u00b2"}, r"line 2: reference_seed '\u00b2' is not a seed"),
    # A column no case reads (a labels table's name for the state, a speed beside rpm) had passed unseen.
    ({"state": "outer"}, r"no case reads a column state \(the manifest names it fault\); columns: record, reference"),
    ({"speed": "1750"}, r"no case reads a column speed \(the manifest names it rpm\)"),
])
def test_a_bad_manifest_is_refused_naming_its_line(module, exported, twin_cfg, changes, message):
    with pytest.raises(BearingTwinError, match=message):
        module.cases_from_manifest(rewrite(exported, **changes), twin_cfg)


def test_a_manifests_column_names_are_read_in_any_case(module, exported, twin_cfg):
    """A spreadsheet's Record, Kind, RPM: read as record, kind, rpm (it had been refused as having no column record)."""
    text = exported.read_text()
    header, _, rest = text.partition("\n")
    shouted = exported.parent / "shouted.csv"
    shouted.write_text(header.title() + "\n" + rest)
    assert len(module.cases_from_manifest(shouted, twin_cfg)) == len(module.cases_from_manifest(exported, twin_cfg))


def test_the_line_named_is_the_files_own(module, exported, twin_cfg):
    """Blank lines count, as a text editor counts them; a row whose quoted field spans lines is named by its last."""
    path = rewrite(exported, {"record": "000_rig_single_outer_resonance.npz", "reference": "reference_00.npz",
                              "kind": "null", "hidden": "\nslip"}, blank_lines=2)
    with pytest.raises(BearingTwinError, match=r"line 7: a case of kind null hides no effect"):
        module.cases_from_manifest(path, twin_cfg)


def test_a_reference_is_run_with_its_own_facts(module, exported, twin_cfg):
    """A reference of another state keeps its own (as bearingtwin-twin reference= reads it), and rows that read one
    reference file alike share its run, rows that read it otherwise (another speed) do not."""
    reference = np.load(exported.parent / "reference_00.npz")
    np.savez(exported.parent / "inner.npz", **{**reference, "fault": "inner"})
    np.save(exported.parent / "bare_reference.npy", reference["signal"])  # files that state no speed
    np.save(exported.parent / "bare_record.npy", np.load(exported.parent / "001_rig_single_outer_slip.npz")["signal"])
    row = {"reference": "bare_reference.npy", "kind": "null", "hidden": "", "fs": "12000", "fault": "outer"}
    listed = module.cases_from_manifest(rewrite(
        exported, {**row, "record": "inner.npz", "reference": "reference_00.npz", "fs": "", "fault": "",
                   "reference_seed": "500"},
        {**row, "record": "bare_record.npy", "rpm": "1797"}, {**row, "record": "bare_record.npy", "rpm": "1785"}),
        twin_cfg)
    assert listed[2]["fault"] == "inner" and module.reference_of(listed[2])["fault"] == "outer"
    assert module._reference_key(listed[2]) == module._reference_key(listed[0])  # the record's state is not the key
    assert module.reference_of(listed[4])["rpm"] == 1785.0
    assert module._reference_key(listed[3]) != module._reference_key(listed[4])


def test_a_spreadsheets_csv_is_read(module, exported, twin_cfg):
    """Excel's "CSV UTF-8" starts with a byte-order mark; spaces after the commas are no part of a name."""
    path = rewrite(exported, text_before="\ufeff")
    path.write_text(path.read_text(encoding="utf-8").replace(",", ", "), encoding="utf-8")
    assert [case["hidden"] for case in module.cases_from_manifest(path, twin_cfg)] == [["resonance"], ["slip"]]


def test_records_are_checked_as_the_twin_checks_them(module, exported, twin_cfg):
    """Before any run: a record shorter than the comparison's segments, and a rate its shaft line contradicts."""
    record = np.load(exported.parent / "000_rig_single_outer_resonance.npz")
    np.save(exported.parent / "short.npy", record["signal"][:1200])
    with pytest.raises(BearingTwinError, match=r"line 2: .*short.npy: .*shorter than one comparison segment"):
        module.cases_from_manifest(rewrite(exported, record="short.npy", fs="12000", rpm="1797", fault="outer"),
                                   twin_cfg)
    # Files that state no rate: the row's is checked, for the record and its reference.
    np.save(exported.parent / "bare.npy", record["signal"])
    np.save(exported.parent / "bare_reference.npy", np.load(exported.parent / "reference_00.npz")["signal"])
    halved = rewrite(exported, record="bare.npy", reference="bare_reference.npy", fs="6000", rpm="1797", fault="outer")
    # a rate half the true one reads as a speed twice the true one: both readings are named
    with pytest.raises(BearingTwinError, match=r"line 2: .*bare.npy.*give the true rate in the manifest's fs column \(or "
                                               r"the true speed in the manifest's rpm column: its lines stand where they "
                                               r"belong at 898.5 rpm \(2 times lower\)\)"):
        module.cases_from_manifest(halved, twin_cfg)
    unchecked = OmegaConf.merge(twin_cfg, {"measured": {"check_fs": False}})  # measured.check_fs=false: every row
    assert module.cases_from_manifest(halved, unchecked)[0]["fs"] == 6000.0


def test_the_command_refuses_bad_input_in_one_line(exported, tmp_path):
    done = benchmark("--records", str(rewrite(exported, kind="triple")), cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    # one line, after the other rows' reading notes (every row is read, to name every bad one at once)
    assert done.stderr.strip().splitlines()[-1].startswith("error: ") and "kind 'triple'" in done.stderr
    (tmp_path / "taken").write_text("a file, not a folder")
    done = benchmark(*SELECTION, "--export", str(tmp_path / "taken"), cwd=tmp_path)
    assert done.returncode == 2 and "--export" in done.stderr and "Traceback" not in done.stderr
    done = benchmark("--records", str(exported), "bearing=no_such_bearing", cwd=tmp_path)
    assert done.returncode == 2 and "no_such_bearing" in done.stderr and "Traceback" not in done.stderr


def test_a_split_at_another_rate_is_the_same_cases_at_that_rate(module, tmp_path):
    """``--fs``: how the rate alone moves the decisions (results/identifiability.md), so every case keeps its hidden
    effects, fault, conditions and seed, and only its rate changes; a manifest's records keep theirs."""
    as_split = module.cases("dev", ["rig"])
    at_48k = module.cases("dev", ["rig"], 48000.0)
    assert {case["fs"] for case in at_48k} == {48000.0} and {case["fs"] for case in as_split} == {12000.0}
    assert [{**case, "fs": None} for case in at_48k] == [{**case, "fs": None} for case in as_split]
    refused = benchmark("--records", str(tmp_path / "cases.csv"), "--fs", "48000", cwd=tmp_path)
    assert refused.returncode == 2 and "--fs 48000: a positive rate for a split's cases" in refused.stderr


def test_cases_on_bearings_of_another_state_come_after_the_splits_own_whose_seeds_stay(module, tmp_path):
    """--faults normal: the split's kinds of case on a healthy bearing, dealt after its own outer- and inner-race
    cases, which keep the seeds they had (the committed results stay reproducible); a state no bearing has is
    refused naming it."""
    for split, sources in [("dev", ["rig"]), ("test", ["twin", "rig"])]:
        own = module.cases(split, sources)
        more = module.cases(split, sources, other_faults=("normal",))
        assert more[:len(own)] == own
        healthy = more[len(own):]
        assert {case["fault"] for case in healthy} == {"normal"} and len(healthy) == len(own) // 2
        assert [case["kind"] for case in healthy] == [case["kind"] for case in own if case["fault"] == "outer"]
        assert len({case["seed"] for case in more}) == len(more)
    done = benchmark("--split", "dev", "--faults", "cracked", cwd=tmp_path)
    assert done.returncode == 2 and "--faults cracked: cracked is no bearing state; choose from normal, inner, ball, " \
                                   "outer" in done.stderr


def test_a_manifests_records_are_run_with_the_twin_commands_defaults_and_a_splits_with_its_bearing(module):
    """A user's records are run as ``bearingtwin-twin`` runs them (its default bearing unless the command line names
    another), not as the split's SKF 6205 cases: a rig of the twin's default bearing was judged with another's."""
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        default_bearing = compose("twin", overrides=["measured.path=unused"]).bearing
    assert default_bearing.name != "cwru_6205"  # else the test could not tell the two apart
    records = module.twin_config(*module.run_overrides(True, []))
    assert records.bearing == default_bearing
    assert module.twin_config(*module.run_overrides(True, ["bearing=er16k"])).bearing.name == "er16k"
    assert module.twin_config(*module.run_overrides(False, [])).bearing.name == "cwru_6205"


def test_every_bad_row_is_named_at_once_and_a_files_missing_facts_point_at_the_manifests_columns(module, exported,
                                                                                                  twin_cfg):
    """A manifest of several bad rows had been refused at its first, one rerun per row; a file that states no rate
    had pointed at measured.fs=, which would set every row's."""
    np.save(exported.parent / "bare.npy", np.load(exported.parent / "001_rig_single_outer_slip.npz")["signal"])
    edited = rewrite(exported, {"record": "bare.npy", "reference": "reference_00.npz", "kind": "single",
                                "hidden": "slip", "rpm": "1797", "fault": "outer"}, kind="triple")
    with pytest.raises(BearingTwinError) as refused:
        module.cases_from_manifest(edited, twin_cfg)
    said = str(refused.value)
    assert "line 2: kind 'triple'" in said and "(2 rows refused)" in said and "\n" not in said
    assert re.search(r"line 4: .*bare.npy: the file does not state its sampling rate; give it in the manifest's fs "
                     r"column", said), said


def test_a_reference_of_another_rate_or_speed_is_said_so(module, exported, twin_cfg, capsys):
    """A row pairing records of other operating points is held as bearingtwin-twin reference= holds it, and said so
    (a slip of the pen had scored the record against another operating point unsaid)."""
    reference = np.load(exported.parent / "reference_00.npz")
    np.savez(exported.parent / "faster.npz", **{**reference, "rpm": 1.1 * float(reference["rpm"])})
    listed = module.cases_from_manifest(rewrite(exported, reference="faster.npz"), twin_cfg)
    assert re.search(r"warning: .*line 2: the reference is outer at 12000 Hz and 1976.7 rpm, the record outer at "
                     r"12000 Hz and 1797 rpm", capsys.readouterr().err)
    assert listed[0]["reference_elsewhere"] and not listed[1]["reference_elsewhere"]  # the page says so too


def test_a_failing_case_is_listed_and_the_others_are_scored(module, exported, twin_cfg, tmp_path, monkeypatch):
    """One case's failure had ended the whole run, its finished cases lost: now that case is listed as failed, on
    the results page too, and the others are scored; a case whose reference failed fails with it."""
    listed = module.cases_from_manifest(exported, twin_cfg)
    assert module.run_listed_case(listed[0], [], {"error": "no luck"})["error"] == "its reference failed: no luck"

    def breaks(case, overrides, reference):
        raise ValueError("a bug")

    monkeypatch.setattr(module, "run_case", breaks)
    failure = module.run_listed_case(listed[1], [], {})
    assert failure["error"] == "ValueError: a bug" and failure["hidden"] == ["slip"]
    scored = {**listed[0], "reference_elsewhere": "the reference is inner at 12000 Hz", "added": ["resonance"], "ranking": [["resonance", 1.0, 1.0, 1.0]], "rounds": [],
              "unexplained": [], "final_error": 1.0, "baseline_error": 3.0, "seconds": 9.0}
    module.write_results([scored], tmp_path, "python benchmarks/identifiability.py", 30.0, exported, [failure])
    page = (tmp_path / "identifiability.md").read_text()
    assert "## Failed cases" in page and "| 001_rig_single_outer_slip.npz (line 3) | single | slip | ValueError: a bug |" in page
    assert "Regenerate (30 s on" in page
    assert "Held against a reference of another operating point: 000_rig_single_outer_resonance.npz (line 2), the " \
           "reference is inner at 12000 Hz." in page


def test_a_run_whose_every_case_failed_leaves_no_earlier_page_to_be_read_as_its_own(module, exported, twin_cfg, tmp_path):
    (tmp_path / "identifiability.json").write_text("[]")  # an earlier run's
    failure = {**module.cases_from_manifest(exported, twin_cfg)[0], "error": "its reference failed: no luck"}
    module.write_failures_only(tmp_path, [failure])
    page = (tmp_path / "identifiability.md").read_text()
    assert "Every case failed: nothing is scored." in page and "(line 2) | single | resonance | its reference failed" in page
    assert not (tmp_path / "identifiability.json").exists()


def test_the_pages_command_runs_from_any_folder(module, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    command = module.regenerating_command(["--records=recs/m.csv", "--out", "out", "candidates=[slip,tones]"])
    assert command == (f"python benchmarks/identifiability.py --records={tmp_path}/recs/m.csv {tmp_path}/out "
                       "'candidates=[slip,tones]'").replace(f" {tmp_path}/out", f" --out {tmp_path}/out")


def test_a_budget_the_twin_would_refuse_is_refused_before_any_run(exported, tmp_path):
    done = benchmark("--records", str(exported), "bearing=cwru_6205", "calibration.n_trials_base=0", cwd=tmp_path)
    assert done.returncode == 2 and "calibration.n_trials_base" in done.stderr.strip().splitlines()[-1]


def test_a_share_is_printed_as_a_reader_rounds_it(module):
    """Python's format rounds a half to the even neighbour (5/8 read "62%"); the results page rounds it up."""
    assert [module.whole_percent(k / n) for k, n in ((5, 8), (1, 8), (14, 22), (2, 2), (0, 4))] == \
        ["63%", "13%", "64%", "100%", "0%"]
