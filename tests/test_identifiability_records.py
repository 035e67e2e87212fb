"""The identifiability benchmark on another rig's records: a manifest of files judged as the split's cases are.

Small trial budgets and two candidates keep each run to seconds; the full-size rates are in
results/identifiability.md.
"""

import csv
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

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
    spec = importlib.util.spec_from_file_location("identifiability", SCRIPT)
    loaded = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded)
    return loaded


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
    from_files = benchmark("--records", str(exported), "--out", str(tmp_path / "records"), *QUICK, cwd=tmp_path)
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
    assert not list(tmp_path.glob("results*"))  # nothing written where it was run


def test_a_different_seed_is_a_different_run(module, exported, twin_cfg, tmp_path):
    """The seed columns reach the twin: the round trip above depends on them."""
    listed = module.cases_from_manifest(exported, twin_cfg)
    assert [case["seed"] for case in listed] == [0, 1] and {case["reference_seed"] for case in listed} == {500}
    assert module.twin_seed(module.reference_of(listed[0])) == 500
    signal = module.measurement(listed[0], twin_cfg).signal
    assert np.array_equal(signal, np.load(exported.parent / listed[0]["measured"]["path"])["signal"])


def rewrite(manifest: Path, tmp_path: Path, **changes) -> Path:
    """A copy of ``manifest`` beside its records with the first row's columns changed (None: column removed)."""
    with manifest.open() as handle:
        rows = list(csv.DictReader(handle))
    rows[0].update({k: v for k, v in changes.items() if v is not None})
    columns = [c for c in rows[0] if changes.get(c, "") is not None]
    path = manifest.parent / f"edited_{len(list(manifest.parent.glob('edited_*')))}.csv"
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


@pytest.mark.parametrize(("changes", "message"), [
    ({"hidden": None}, r"has no column hidden"),
    ({"kind": "triple"}, r"line 2: kind 'triple' is not one of single, pair, null, out_of_library"),
    ({"kind": "pair"}, r"line 2: a pair case hides 2 effect\(s\)"),
    ({"hidden": "gear_mesh"}, r"line 2: hidden gear_mesh is not a library effect .*out_of_library"),
    ({"record": "missing.npz"}, r"line 2: record .*missing.npz does not exist"),
    ({"fs": "twelve"}, r"line 2: record 000_rig_single_outer_resonance.npz: could not convert"),
    ({"fault": "inner"}, r"line 2: record 000_rig_single_outer_resonance.npz: .*fault"),
    ({"seed": "-3"}, r"line 2: seed '-3' is not a seed"),
])
def test_a_bad_manifest_is_refused_naming_its_line(module, exported, twin_cfg, tmp_path, changes, message):
    with pytest.raises(BearingTwinError, match=message):
        module.cases_from_manifest(rewrite(exported, tmp_path, **changes), twin_cfg)


def test_a_reference_of_another_rate_is_refused(module, exported, twin_cfg):
    record = np.load(exported.parent / "reference_00.npz")
    np.savez(exported.parent / "reference_25k.npz", **{**record, "fs": 25600.0})
    path = rewrite(exported, exported.parent, reference="reference_25k.npz", fs=None)
    with pytest.raises(BearingTwinError, match=r"line 2: the reference is outer at 25600 Hz, the record outer at 12000"):
        module.cases_from_manifest(path, twin_cfg)


def test_the_command_refuses_a_bad_manifest_in_one_line(exported, tmp_path):
    done = benchmark("--records", str(rewrite(exported, tmp_path, kind="triple")), cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "kind 'triple'" in done.stderr
    assert not (tmp_path / "results").exists()
