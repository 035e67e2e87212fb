"""bearingtwin-inspect: a JSON summary of readable files (NaNs counted, not refused), exit 2 naming
the file and problem otherwise, and the bearing's defect frequencies from conf/bearing."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bearingtwin.cli.inspect import main
from bearingtwin.config import data_root

from processes import run_here

HUST = Path(__file__).parent / "fixtures" / "hust"
CWRU = data_root() / "cwru"


def run(capsys, monkeypatch, *overrides):
    """``bearingtwin-inspect <overrides>`` in this process: exit status, stdout, stderr."""
    return run_here(main, "bearingtwin-inspect", capsys, monkeypatch, *overrides)


def test_hust_file_with_er16k_defect_frequencies(capsys, monkeypatch):
    code, out, _ = run(capsys, monkeypatch, f"path={HUST / '0.5X_O_65Hz.xls'}", "bearing=er16k")
    summary = json.loads(out)
    assert code == 0
    assert summary["format"] == "hust-xls" and summary["channels"] == ["speed", "X", "Y", "Z"]
    assert summary["fs_hz"] == 25600 and summary["fs_origin"] == "header" and summary["rpm"] == 3900
    assert summary["n_samples"] == 1280 and summary["duration_s"] == pytest.approx(1280 / 25600, rel=1e-4)
    # README: ER-16K BPFO 3.572 and BPFI 5.428 times the shaft speed.
    assert summary["defect_frequencies_hz"]["bpfo"] == pytest.approx(3.572 * 65, rel=1e-3)
    assert summary["defect_orders"]["bpfi"] == pytest.approx(5.428, rel=1e-3)


def test_nan_cell_is_reported_not_refused(capsys, monkeypatch):
    code, out, _ = run(capsys, monkeypatch, f"path={HUST / 'damaged' / 'nan_cell.xls'}")
    assert code == 0 and json.loads(out)["nan_count"] == {"speed": 0, "X": 0, "Y": 0, "Z": 1}
    assert json.loads(out)["quality"]["Z"] == ["not checked: 1 NaN or infinite samples"]


@pytest.mark.parametrize(
    "name,problem",
    [("truncated.xls", "line 222 has 3 columns"), ("empty.xls", "the file is empty"), ("non_numeric.xls", "'abc' is not a number")],
)
def test_unreadable_files_exit_2_naming_file_and_problem(capsys, monkeypatch, name, problem):
    code, out, err = run(capsys, monkeypatch, f"path={HUST / 'damaged' / name}")
    assert code == 2 and out == ""
    assert name in err and problem in err


def test_npy_with_options_and_unknown_bearing(capsys, monkeypatch, tmp_path):
    path = tmp_path / "x.npy"
    np.save(path, np.ones((2, 500)))
    code, out, _ = run(capsys, monkeypatch, f"path={path}", "fs=1000", "rpm=1797", "bearing=cwru_6205", "channel=1")
    summary = json.loads(out)
    assert code == 0 and summary["channels"] == ["0", "1"] and summary["nan_count"] == {"1": 0}
    assert summary["duration_s"] == 0.5 and summary["fs_origin"] == "option"
    # README: CWRU drive-end bearing BPFI 5.4152 x shaft.
    assert summary["defect_frequencies_hz"]["bpfi"] == pytest.approx(5.4152 * 1797 / 60, rel=1e-4)
    assert summary["shaft_line_check"]["verdict"] == "not checked"  # 0.5 s cannot resolve a 30 Hz series
    code, _, err = run(capsys, monkeypatch, f"path={path}", "+fs_hz=1000")
    assert code == 2 and "fs_hz is not a setting of inspect" in err
    code, _, err = run(capsys, monkeypatch, f"path=[{path},{path}]")  # was a TypeError traceback
    assert code == 2 and "give one file (inspect reads one at a time)" in err and "Traceback" not in err


def test_runs_as_a_module_with_hydra_overrides_and_a_help_text():
    done = subprocess.run(
        [sys.executable, "-m", "bearingtwin.cli.inspect", f"path={HUST / 'damaged' / 'no_data_line.xls'}"],
        capture_output=True, text=True,
    )
    assert done.returncode == 2 and "no_data_line.xls: no line reading 'Data'" in done.stderr
    usage = subprocess.run([sys.executable, "-m", "bearingtwin.cli.inspect", "--help"], capture_output=True, text=True)
    assert usage.returncode == 0 and "Usage: bearingtwin-inspect path=<file> [bearing=<name>]" in usage.stdout


def test_a_cwru_file_without_a_speed_reports_the_nominal_one_and_where_it_is_from(capsys, monkeypatch, tmp_path):
    import scipy.io

    path = tmp_path / "12k_Drive_End_B028_1_3006.mat"  # the Data Center's packaging: X049_DE_time, no RPM
    scipy.io.savemat(path, {"X049_DE_time": np.random.default_rng(0).standard_normal((12000, 1))})
    code, out, _ = run(capsys, monkeypatch, f"path={path}")
    summary = json.loads(out)
    assert code == 0 and (summary["rpm"], summary["rpm_origin"], summary["fault"]) == (1772.0, "nominal", "ball")
    assert any("X049_*" in note for note in summary["meta"]["notes"])
    assert summary["meta"]["notes"][-1] == "speed 1772 rpm: the Data Center's nominal speed at 1 hp (no X049RPM variable)"
    code, out, _ = run(capsys, monkeypatch, f"path={path}", "rpm=1770")
    assert (json.loads(out)["rpm"], json.loads(out)["rpm_origin"]) == (1770, "option")



@pytest.mark.skipif(not (CWRU / "12k_Drive_End_B007_0_118.mat").is_file(), reason=f"CWRU record 118 not in {CWRU}")
def test_every_channel_of_a_file_witnesses_its_rate_as_the_commands_read_it(capsys, monkeypatch):
    """Record 118's fan-end channel alone shows a 53.7 Hz series and would contradict the 12 kHz its name
    declares; its drive-end and accelerometer-base channels show the shaft series and confirm it, as
    bearingtwin-diagnose and the twin decide. Twice the rate is contradicted: the drive-end and base channels show the
    shaft series at twice its place, which outweighs the fan-end series landing on BPFO by chance."""
    record = f"path={CWRU / '12k_Drive_End_B007_0_118.mat'}"
    code, out, _ = run(capsys, monkeypatch, record, "channel=FE", "bearing=cwru_6205")
    check = json.loads(out)["shaft_line_check"]
    assert code == 0 and check["verdict"] == "consistent" and check["channel"] != "FE"
    assert check["channels"]["FE"] == "contradicted" and set(check["channels"]) == {"DE", "FE", "BA"}
    code, out, _ = run(capsys, monkeypatch, record, "channel=FE", "fs=24000", "bearing=cwru_6205")
    check = json.loads(out)["shaft_line_check"]
    assert code == 0 and check["verdict"] == "contradicted" and check["channel"] != "FE"
    # Read at twice its rate, the fan-end series (53.7 Hz) stands where BPFO belongs (107.3 Hz): by itself a
    # witness of the wrong rate, outweighed by the shaft series the other channels show at twice its place.
    assert check["channels"] == {"DE": "contradicted", "FE": "consistent", "BA": "contradicted"}


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
def test_a_speed_given_at_half_that_the_cage_lines_bear_out_is_doubted(capsys, monkeypatch, tmp_path):
    """Record 130's drive-end channel as a bare array, its speed given at half: the cage's envelope lines, read at
    their second harmonic, make the rate consistent, as the twin and a diagnosis found; the twin refuses the speed and
    a diagnosis doubts it, and the summary had said nothing. It names the speed the shaft series stands at."""
    from scipy.io import loadmat

    record = loadmat(CWRU / "12k_Drive_End_OR007@6_0_130.mat")
    np.save(tmp_path / "bare.npy", record["X130_DE_time"].ravel())
    given = [f"path={tmp_path / 'bare.npy'}", "fs=12000", "bearing=cwru_6205"]
    code, out, _ = run(capsys, monkeypatch, *given, "rpm=898")
    check = json.loads(out)["shaft_line_check"]
    assert code == 0 and check["verdict"] == "consistent" and check["witness"] == "envelope"
    assert check["speed_doubt"].endswith("stand where they belong at 1796 rpm (2 times higher); only the cage's or a "
                                         "defect's lines bear out 898 rpm, read at their harmonics: check the speed")
    code, out, _ = run(capsys, monkeypatch, *given, "rpm=1796")
    assert "speed_doubt" not in json.loads(out)["shaft_line_check"]


def test_what_a_file_leaves_unsaid_is_read_from_a_labels_table_beside_it(capsys, monkeypatch, tmp_path):
    fs, rpm = 12000.0, 1797.0
    t = np.arange(int(4 * fs)) / fs
    np.save(tmp_path / "outer_a.npy", sum(np.sin(2 * np.pi * k * rpm / 60 * t) / k for k in range(1, 8))
            + np.random.default_rng(0).standard_normal(t.size))
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nouter_a.npy,outer,1797,12000\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'outer_a.npy'}", "bearing=cwru_6205")
    summary = json.loads(out)
    where = f"{tmp_path / 'labels.csv'} line 2"
    assert code == 0 and (summary["fs_hz"], summary["rpm"], summary["fault"]) == (fs, rpm, "outer")
    assert summary["fs_origin"] == summary["rpm_origin"] == where
    assert summary["shaft_line_check"]["verdict"] == "consistent"
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'outer_a.npy'}", "rpm=1800")
    assert json.loads(out)["rpm_origin"] == "option"  # an option given wins over the table
    # A row's unit is the samples' where the file states none; its scale is said, the levels staying the file's own;
    # a unit the file contradicts is said too (inspect had failed on any row once the table took a unit).
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs,unit\nouter_a.npy,outer,1797,12000,g\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'outer_a.npy'}")
    assert code == 0 and json.loads(out)["unit"] == "g"
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs,unit,scale\nouter_a.npy,outer,1797,12000,g,5\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'outer_a.npy'}")
    summary = json.loads(out)
    assert code == 0 and summary["unit"] is None and (f"{where} reads its samples x 5 in g (scale, unit): the levels here "
                                                      "are the file's own samples, before it") in summary["meta"]["notes"]
    np.savez(tmp_path / "stated.npz", signal=np.load(tmp_path / "outer_a.npy"), fs=fs, rpm=rpm, unit="m/s^2")
    (tmp_path / "labels.csv").write_text("record,state,unit\nstated.npz,outer,g\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'stated.npz'}")
    assert code == 0 and (f"{where} gives unit g, which the file's m/s^2 contradicts: training, a diagnosis and the twin "
                          "refuse it") in json.loads(out)["meta"]["notes"]


def test_a_bad_row_of_another_file_is_passed_over_and_named_and_the_files_own_refuses_it(capsys, caplog, monkeypatch,
                                                                                          tmp_path):
    """One file's inspection reads that file's row: a typo in another's state or a speed that is no number is that
    file's concern (a one-line warning names it), while a bad row of the file inspected exits 2 naming its line."""
    for name in ("good", "typo"):
        np.save(tmp_path / f"{name}.npy", np.random.default_rng(0).standard_normal(24000))
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\ngood.npy,outer,1797,12000\ntypo.npy,outter,1797,12000\n"
                                         "gone.npy,normal,fast,12000\n")
    with caplog.at_level("WARNING"):
        code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'good.npy'}")
    summary = json.loads(out)
    assert code == 0 and (summary["fs_hz"], summary["rpm"], summary["fault"]) == (12000.0, 1797.0, "outer")
    warned = [message for message in caplog.messages if "passed over rows of other files" in message]
    assert len(warned) == 1 and "\n" not in warned[0]
    assert "labels.csv line 3: state 'outter'" in warned[0] and "labels.csv line 4: rpm='fast'" in warned[0]
    code, _, err = run(capsys, monkeypatch, f"path={tmp_path / 'typo.npy'}")
    assert code == 2 and f"error: {tmp_path / 'labels.csv'} line 3: state 'outter' is not a bearing state" in err


def test_a_labels_row_is_read_as_the_twin_reads_it(capsys, monkeypatch, tmp_path):
    """A row for a file in a subfolder is not the file beside the table of that name; a row's rate replaces one
    a CWRU file merely declares; a row's speed or state the file contradicts is refused, naming the line."""
    np.save(tmp_path / "x.npy", np.random.default_rng(0).standard_normal(24000))
    (tmp_path / "labels.csv").write_text("record,state,rpm,fs\nrig_a/x.npy,outer,1797,12000\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'x.npy'}")
    assert code == 0 and json.loads(out)["fs_hz"] is None and json.loads(out)["fault"] is None
    # A rate the file stores is the file's: a row that says another is refused, as training and diagnose refuse it.
    np.savez(tmp_path / "r.npz", signal=np.random.default_rng(0).standard_normal(24000), fs=12000.0)
    (tmp_path / "labels.csv").write_text("record,state,fs\nr.npz,outer,48000\n")
    code, _, err = run(capsys, monkeypatch, f"path={tmp_path / 'r.npz'}")
    assert code == 2 and "labels.csv line 2: fs=48000 Hz contradicts the file's 12000 Hz (stored in it)" in err
    (tmp_path / "labels.csv").write_text("record,state,fs\nr.npz,outer,12000\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'r.npz'}")
    assert code == 0 and (json.loads(out)["fs_hz"], json.loads(out)["fs_origin"]) == (12000.0, "file")
    if not (CWRU / "12k_Drive_End_OR007@6_0_130.mat").is_file():
        pytest.skip(f"CWRU files not found in {CWRU}")
    import shutil

    shutil.copy(CWRU / "12k_Drive_End_OR007@6_0_130.mat", tmp_path / "130.mat")
    (tmp_path / "labels.csv").write_text("record,state,fs\n130.mat,outer,48000\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / '130.mat'}")
    summary = json.loads(out)
    assert code == 0 and summary["fs_hz"] == 48000.0 and summary["fs_origin"] == f"{tmp_path / 'labels.csv'} line 2"
    assert summary["shaft_line_check"]["verdict"] == "contradicted"  # 130 is a 12 kHz record: the check says so
    # A speed within 1 % of the file's measured one is the file's (a motor drifts by a few rpm), as the twin and a
    # diagnosis read it, said in a note; one further off is refused, and so is a speed given as an option.
    (tmp_path / "labels.csv").write_text("record,state,rpm\n130.mat,outer,1790\n")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / '130.mat'}")
    summary = json.loads(out)
    assert code == 0 and (summary["rpm"], summary["rpm_origin"]) == (1796.0, "file")
    assert f"{tmp_path / 'labels.csv'} line 2: rpm=1790 given; the file's measured 1796 rpm read" in summary["meta"]["notes"]
    (tmp_path / "labels.csv").write_text("record,state,rpm\n130.mat,inner,1750\n")
    code, _, err = run(capsys, monkeypatch, f"path={tmp_path / '130.mat'}")
    assert code == 2 and "labels.csv line 2: rpm=1750.0 contradicts the file's rpm=1796.0 (more than 1% apart)" in err
    code, _, err = run(capsys, monkeypatch, f"path={tmp_path / '130.mat'}", "rpm=1750")
    assert code == 2 and "rpm=1750.0 contradicts the file's rpm=1796.0" in err


def test_the_units_a_header_states_are_reported_per_channel_where_they_differ(capsys, monkeypatch, tmp_path):
    path = tmp_path / "logger.csv"
    rows = "".join(f"{i / 1000:.3f},{np.sin(i):.6f},{np.cos(3 * i):.6f}\n" for i in range(600))
    path.write_text("Device: ACC-3\nOperator: bob\nTime [sec],acc (g),tacho [V]\n" + rows)
    code, out, _ = run(capsys, monkeypatch, f"path={path}")
    summary = json.loads(out)
    assert code == 0 and summary["channels"] == ["acc (g)", "tacho [V]"] and summary["fs_hz"] == pytest.approx(1000)
    assert summary["unit"] == {"acc (g)": "g", "tacho [V]": "V"}
    assert summary["meta"]["notes"][0].startswith("the 2 lines above the header read as notes, not data")
    code, out, _ = run(capsys, monkeypatch, f"path={path}", "channel='acc (g)'")
    assert code == 0 and json.loads(out)["unit"] == "g" and json.loads(out)["quality"] == {}


def test_clipping_and_a_dropout_are_named_per_channel(capsys, monkeypatch, tmp_path):
    t = np.arange(24000) / 12000.0
    x = np.sin(2 * np.pi * 157.0 * t) + 0.3 * np.random.default_rng(0).standard_normal(t.size)
    clipped, held = np.clip(x, -0.8, 0.8), x.copy()
    held[12000:13200] = 0.0
    path = tmp_path / "two.npz"
    np.savez(path, clipped=clipped, held=held, fs=12000.0)
    code, out, _ = run(capsys, monkeypatch, f"path={path}")
    quality = json.loads(out)["quality"]
    assert code == 0 and set(quality) == {"clipped", "held"}
    assert "pile up at its maximum, 0.8 and its minimum, -0.8, in " in quality["clipped"][0]
    assert " s to 2 s: the sensor or the converter clipped" in quality["clipped"][0]  # where: up to the record's end
    assert quality["held"] == ["samples from 1 s to 1.1 s are all 0 (a dropout, or a stretch held at one value): the "
                               "windows over it read no vibration"]


def test_a_bearing_given_against_the_one_the_file_names_is_noted(tmp_path):
    """Read with another bearing's defect lines, as asked, but not without a word (diagnose notes it, the twin
    refuses it)."""
    from bearingtwin.cli.inspect import summarize
    from bearingtwin.config import load_bearing

    path = tmp_path / "record.npz"
    np.savez(path, signal=np.random.default_rng(0).standard_normal(12000), fs=12000.0, rpm=1797.0, bearing="cwru_6205")
    summary = summarize(path, bearing=load_bearing("er16k"), bearing_name="er16k")
    assert "bearing=er16k given, where the file names cwru_6205" in " ".join(summary["meta"]["notes"])
    assert not any("bearing=" in note for note in summarize(path)["meta"].get("notes", []))


def test_a_rate_too_low_for_the_bearings_defect_lines_is_noted(tmp_path):
    """25.6 Hz (25.6 kHz written in Hz) holds no defect line of the 6205 at 1797 rev/min: reported, as diagnose
    refuses it; 12 kHz holds them all."""
    from bearingtwin.cli.inspect import summarize

    signal = np.random.default_rng(0).standard_normal(3000)
    np.savez(tmp_path / "low.npz", signal=signal, fs=25.6, rpm=1797.0, bearing="cwru_6205")
    np.savez(tmp_path / "usual.npz", signal=signal, fs=12000.0, rpm=1797.0, bearing="cwru_6205")
    assert ("a rate of 25.6 Hz is too low for a diagnosis: the Nyquist frequency, 12.8 Hz, lies "
            "below the inner-race defect line (BPFI) at 1797 rev/min (162.2 Hz)") in " ".join(
        summarize(tmp_path / "low.npz")["meta"]["notes"])
    assert not any("too low" in note for note in summarize(tmp_path / "usual.npz")["meta"].get("notes", []))


def test_a_shaft_speed_a_supplys_lines_could_pass_for_is_not_read_and_says_why(tmp_path):
    """At 1797 rpm twice the shaft rate is 59.9 Hz, a 60 Hz supply's line: the CWRU 0 hp records' speed had been
    reported null with no reason."""
    from bearingtwin.cli.inspect import summarize

    t = np.arange(4 * 12000) / 12000.0
    shaft = sum(np.sin(2 * np.pi * k * 1797 / 60 * t) / k for k in range(1, 8))
    np.savez(tmp_path / "r.npz", signal=shaft + 0.1 * np.random.default_rng(0).standard_normal(t.size), fs=12000.0,
             rpm=1797.0)
    summary = summarize(tmp_path / "r.npz")
    assert summary["shaft_speed"] == {"signal": None}
    assert "lies near a supply frequency (50, 60 Hz)" in summary["shaft_speed_not_read"]["signal"], summary


def test_how_steadily_the_shaft_turned_is_reported_per_channel(capsys, monkeypatch, tmp_path):
    """A drifting vibration channel and the tachometer beside it both read the swing a diagnosis would steady; a
    channel of noise reads nothing."""
    from test_speed import FS, RPM, machine, tachometer

    drifting, _ = machine(drift=0.04)
    noise = np.random.default_rng(1).standard_normal(drifting.size)
    path = tmp_path / "fan.npz"
    np.savez(path, vib=drifting, tach=tachometer(0.04), noise=noise, fs=FS, rpm=RPM)
    code, out, _ = run(capsys, monkeypatch, f"path={path}")
    summary = json.loads(out)
    speeds = summary["shaft_speed"]
    assert code == 0 and speeds["noise"] is None
    assert summary["shaft_speed_not_read"] == {"noise": "no shaft series stood out in enough segments to read a speed"}
    for name in ("vib", "tach"):
        assert speeds[name]["unsteady"] and speeds[name]["spread"] == pytest.approx(0.08, abs=0.015), speeds[name]
        assert speeds[name]["median_rpm"] == pytest.approx(RPM, rel=0.02)
    # No speed stated (nor a tachometer beside it): why none is read stands where a reader looks for the speed.
    np.savez(tmp_path / "bare.npz", vib=drifting, fs=FS)
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'bare.npz'}")
    bare = json.loads(out)
    assert code == 0 and bare["shaft_speed"] is None and bare["shaft_speed_not_read"] == (
        "the file states no shaft speed: give rpm=<rev/min> (or the rpm column of a labels.csv beside it)")


def test_levels_of_each_vibration_channel(capsys, monkeypatch, tmp_path):
    """A sine's crest factor is sqrt(2) and its kurtosis 1.5; Gaussian noise's kurtosis 3; a flat channel has none."""
    t = np.arange(20000) / 10000.0
    noise = np.random.default_rng(0).normal(0.0, 2.0, t.size)
    path = tmp_path / "x.npy"
    tiny = np.zeros(t.size)
    tiny[::2] = 1e-160  # a variance below the smallest normal float: constant as far as a kurtosis goes
    np.save(path, np.stack([0.5 + 3.0 * np.sin(2 * np.pi * 50.0 * t), noise, np.full(t.size, 4.0), tiny]))
    code, out, _ = run(capsys, monkeypatch, f"path={path}", "fs=10000")
    levels = json.loads(out)["levels"]
    assert code == 0 and set(levels) == {"0", "1", "2", "3"} and levels["3"] is None
    sine = levels["0"]
    assert sine["mean"] == pytest.approx(0.5, abs=1e-9) and sine["peak"] == pytest.approx(3.5, rel=1e-6)
    assert sine["rms"] == pytest.approx(np.sqrt(0.25 + 4.5), rel=1e-9)
    assert sine["crest_factor"] == pytest.approx(3.5 / np.sqrt(4.75), rel=1e-6)
    assert sine["kurtosis"] == pytest.approx(1.5, rel=1e-3)
    assert levels["1"]["kurtosis"] == pytest.approx(3.0, abs=0.15) and levels["1"]["rms"] == pytest.approx(2.0, rel=0.02)
    assert levels["2"] is None


def test_levels_leave_out_a_hust_exports_speed_column(capsys, monkeypatch):
    code, out, _ = run(capsys, monkeypatch, f"path={HUST / '0.5X_O_65Hz.xls'}")
    assert code == 0 and list(json.loads(out)["levels"]) == ["X", "Y", "Z"]


def long_hust_export(folder: Path, seconds: float = 4.0) -> Path:
    """A HUST export of ``seconds`` at 25.6 kHz under the outer-race fixture's header: a 65 Hz shaft line and its
    harmonics over noise on X, Y and Z, and the speed column every export holds, 0 throughout."""
    lines = (HUST / "0.5X_O_65Hz.xls").read_text(encoding="latin-1").splitlines()
    header = lines[:lines.index("Data") + 1]
    fs, rng = 25600, np.random.default_rng(0)
    t = np.arange(int(seconds * fs)) / fs
    shaft = sum(np.sin(2 * np.pi * 65.0 * k * t + k) / k for k in (1, 2, 3))
    axes = [0.2 * gain * shaft + 0.05 * rng.standard_normal(t.size) for gain in (1.0, 0.7, 0.4)]
    rows = np.column_stack([t, np.zeros(t.size), *axes])
    path = folder / "0.5X_O_65Hz.xls"
    text = "\n".join(header) + "\n" + "\n".join("\t".join(f"{value:.6f}" for value in row) for row in rows) + "\n"
    path.write_text(text.replace("Total Data Rows\t1280", f"Total Data Rows\t{t.size}"), encoding="latin-1")
    return path


def test_a_hust_exports_speed_column_witnesses_no_rate(capsys, monkeypatch, tmp_path):
    """Long enough for the shaft line, the rate is witnessed by the vibration channels alone: the speed column,
    flat, would leave the check ambiguous and could be the channel that decides."""
    code, out, _ = run(capsys, monkeypatch, f"path={long_hust_export(tmp_path)}")
    check = json.loads(out)["shaft_line_check"]
    assert code == 0 and set(check["channels"]) == {"X", "Y", "Z"} and check["channel"] in ("X", "Y", "Z")
    assert check["verdict"] == "consistent", check


@pytest.mark.skipif(not (CWRU / "12k_Drive_End_OR007@6_1_131.mat").is_file(), reason=f"CWRU record 131 not in {CWRU}")
def test_a_given_speed_the_record_bears_out_is_read_over_the_one_its_file_stamps(capsys, monkeypatch, tmp_path):
    """A logger that stamps the nameplate's speed (1826 rpm) on a motor turning at 1772: the speed given is read where
    the record's shaft series reads it, with its origin the option's; a speed it does not read stays refused."""
    from scipy.io import loadmat

    signal = loadmat(CWRU / "12k_Drive_End_OR007@6_1_131.mat")["X131_DE_time"].ravel()
    np.savez(tmp_path / "stamped.npz", signal=signal, fs=12000.0, rpm=1826.0, unit="g")
    code, out, _ = run(capsys, monkeypatch, f"path={tmp_path / 'stamped.npz'}", "rpm=1772")
    summary = json.loads(out)
    assert code == 0 and (summary["rpm"], summary["rpm_origin"]) == (1772.0, "option"), out
    assert any(note.startswith("rpm=1772 given against the file's 1826 rpm: the shaft's harmonic series reads 177")
               for note in summary["meta"]["notes"]), summary["meta"]["notes"]
    code, _, err = run(capsys, monkeypatch, f"path={tmp_path / 'stamped.npz'}", "rpm=1700")
    assert code == 2 and err.strip().endswith("rpm=1700.0 contradicts the file's rpm=1826.0 (more than 1% apart); "
                                              "the shaft's harmonic series reads 1772 rpm"), err


def test_a_variable_speed_export_asks_for_no_speed_and_refuses_one(capsys, monkeypatch, tmp_path):
    """A HUST VS_ run states its speed varies: inspect says so where it had asked for rpm=, and refuses a speed given
    for it, as a diagnosis does (one speed puts every line of a run-up in the wrong place)."""
    variable = tmp_path / "H_VS_0_40_0Hz.xls"
    variable.write_bytes((HUST / "H_65Hz.xls").read_bytes())
    code, out, _ = run(capsys, monkeypatch, f"path={variable}")
    summary = json.loads(out)
    assert code == 0 and summary["shaft_speed"] is None
    assert summary["shaft_speed_not_read"].startswith("the file is a variable-speed run (VS_0_40_0Hz in its name)")
    code, _, err = run(capsys, monkeypatch, f"path={variable}", "rpm=1200")
    assert code == 2 and err.strip().splitlines() == [
        f"error: {variable}: rpm=1200.0 given, but the file is a variable-speed run (VS_0_40_0Hz in its name): its "
        "speed changes over the record: no one speed describes it"]
