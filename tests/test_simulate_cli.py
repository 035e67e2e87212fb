"""bearingtwin-simulate run as a user runs it: a subprocess with Hydra overrides."""

import json
import logging
import os
import shlex

import numpy as np
import pytest
from processes import run_module

from bearingtwin.config import compose_config
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import simulate


def run(tmp_path, *overrides):
    return run_module("bearingtwin.cli.simulate", *overrides, cwd=tmp_path, timeout=300)


def test_writes_npz_and_plots(tmp_path, caplog):
    out = tmp_path / "runs" / "run.npz"
    result = run(tmp_path, "fault=inner", "simulator.rpm=1797", "simulator.fs=10000", "simulator.duration=1.0",
                 "bearing=cwru_6205", "bearing.clearance_mm=0.004", f"out={out}", "plot=true")
    assert result.returncode == 0, result.stderr
    assert "simulate inner:" not in result.stderr  # its progress bar is for a terminal, not a log (stderr is a pipe)
    with np.load(out) as run_file:
        assert run_file["channels"].shape == (4, 10000)
        np.testing.assert_array_equal(run_file["signal"], run_file["channels"][0])  # default sensor inner_x
        assert float(run_file["fs"]) == 10000 and float(run_file["rpm"]) == 1797
        assert str(run_file["unit"]) == "m/s^2" and str(run_file["bearing"]) == "cwru_6205"
        signal = run_file["signal"]
    # What the file says of itself is what a reader reports: its unit, and its bearing, whose defect frequencies
    # bearingtwin-inspect then reads with no bearing= given.
    from bearingtwin.cli.inspect import summarize

    summary = summarize(out)
    assert summary["unit"] == "m/s^2" and summary["bearing"] == "cwru_6205" and "defect_frequencies_hz" in summary
    # Its rate is exact, and the twin has no shaft line: no check reads the balls' passing series as the shaft's
    # (one had called the twin's own record's rate contradicted).
    assert summary["fs_origin"] == "simulation" and summary["shaft_line_check"]["verdict"] == "not checked"
    from bearingtwin.data.formats import load_recording
    from bearingtwin.data.real import check_stated_rate

    with caplog.at_level(logging.WARNING):  # a folder of the twin's records trained on (data=files): nothing logged
        check_stated_rate(load_recording(out), "fs", "data.check_fs", bearing=BearingGeometry(52, 25, 7.94, 39.04, 9))
    assert not caplog.records, caplog.records
    # the inner-race defect repeats at the CWRU bearing's BPFI (1 s: 1 Hz bins)
    envelope = np.abs(np.fft.rfft(np.abs(signal) - np.abs(signal).mean()))
    bpfi = BearingGeometry(52, 25, 7.94, 39.04, 9).bpfi_hz(1797)
    band = slice(round(bpfi) - 20, round(bpfi) + 21)
    assert abs(np.argmax(envelope[band]) + band.start - bpfi) <= 1
    assert (tmp_path / "runs" / "run_signal.png").stat().st_size > 10_000
    assert (tmp_path / "runs" / "run_envelope.png").stat().st_size > 10_000


@pytest.mark.parametrize("overrides, field", [
    (["fault=cracked"], "fault"),
    (["simulator.rpm=-5"], "simulator.rpm"),
    (["simulator.fs=600"], "simulator.fs"),
    (["simulator.defect.depth_mm=-0.1"], "simulator.defect.depth_mm"),
    # Found by probing: a record still labelled faulty with the defect nowhere (exit 0) ...
    (["fault=outer", "simulator.defect.outer_angle_deg=nan"], "simulator.defect.outer_angle_deg"),
    (["bearing.contact_angle_deg=90"], "bearing.contact_angle_deg"),  # BPFI = BPFO
    (["fault=inner", "simulator.rpm=200000", "simulator.fs=2000", "simulator.duration=0.2"], "simulator.fs"),
    # ... a numpy allocation error, tracebacks ...
    (["simulator.duration=1e9"], "simulator.duration"),
    (["simulator.fast.steps_per_period=0"], "simulator.fast.steps_per_period"),
    (["simulator.seed=abc"], "simulator.seed"),
    # ... and messages naming no field, after simulating or over two lines.
    (["simulator.duration=1e-5"], "simulator.duration"),
    (["simulator.load_y_n=inf"], "simulator.load_y_n"),
    (["progress=maybe"], "progress must be auto, true or false"),
])
def test_bad_input_exits_non_zero_naming_the_field(tmp_path, overrides, field):
    result = run(tmp_path, *overrides, f"out={tmp_path / 'x.npz'}")
    assert result.returncode == 2, result.stderr[-2000:]
    assert result.stderr.startswith("error: ") and field in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr[-2000:]  # one line, no traceback
    assert not (tmp_path / "x.npz").exists()


def test_an_output_that_is_not_an_npz_archive_is_refused_before_simulating(tmp_path):
    """numpy would write out.txt.npz and the summary would point at out.txt."""
    from bearingtwin.data.formats import read_raw

    result = run(tmp_path, f"out={tmp_path / 'out.txt'}", "simulator.duration=0.1")
    assert result.returncode == 2 and "give out=<name>.npz" in result.stderr and not list(tmp_path.glob("out.txt*"))
    # An archive's name in capitals is an archive's name: written as given (numpy's own savez had added .npz to it),
    # and read back.
    upper = run(tmp_path, f"out={tmp_path / 'OUT.NPZ'}", "simulator.duration=0.1", "plot=false")
    assert upper.returncode == 0, upper.stderr[-2000:]
    assert sorted(path.name for path in tmp_path.glob("OUT*")) == ["OUT.NPZ"]
    assert read_raw(tmp_path / "OUT.NPZ").fs > 0


def test_the_twin_call_it_suggests_holds_the_simulations_sensor_bearing_and_load(tmp_path):
    """Without them the twin's defaults (a housing sensor, a loaded rig) are fitted to a record they cannot match."""
    out = tmp_path / "o.npz"
    result = run(tmp_path, "fault=outer", "bearing=cwru_6205", "simulator.sensor=outer_y", "simulator.sensor_angle_deg=60",
                 "simulator.load_y_n=-300", "simulator.fs=12000", "simulator.duration=1.0", "simulator.oversample=2",
                 f"out={out}")
    assert result.returncode == 0, result.stderr
    suggested = next(line for line in result.stdout.splitlines() if "next:" in line)
    command = suggested.split("next:", 1)[1].split(" holds ")[0].split()
    assert command[:2] == ["bearingtwin-twin", f"measured.path={out}"]
    assert "simulator.oversample=2" in command  # the twin heard as the record was made
    twin = run_module("bearingtwin.cli.twin", *command[1:], f"out={tmp_path / 'twin'}", "tracking.enabled=false",
                      "figures=false", "twin.duration=0.5", "calibration.n_trials_base=2", "calibration.n_polish=0",
                      "candidates=[noise]", "calibration.n_trials_effect=1", "calibration.n_polish_effect=0",
                      "calibration.n_trials_refine=1", cwd=tmp_path, timeout=300)
    assert twin.returncode == 0, twin.stderr
    report = json.loads((tmp_path / "twin" / "twin_report.json").read_text())
    held = report["operating_point"]
    assert held["sensor"]["held"] and held["sensor"]["race"] == "outer" and held["sensor"]["angle_deg"] == 60.0
    assert held["radial_load_n"] == {"value": 300.0, "unit": "N", "held": True}
    assert report["measured"]["bearing"] == "cwru_6205"


def test_a_load_in_another_direction_is_held_in_a_frame_turned_until_the_forces_point_down(tmp_path):
    """The twin knows a downward load only; the model is isotropic and sees only the sum of the constant forces on
    the inner ring, so the hint turns the frame: the twin simulated as the hint says makes the same record (its
    spectrum), where the sensor's own direction with the load left out did not hold what the simulation set."""
    import scipy.signal
    from hydra import compose, initialize_config_dir

    from bearingtwin.cli.simulate import twin_command
    from bearingtwin.config import CONF_DIR

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["fault=normal", "simulator.sensor=outer_x", "simulator.load_x_n=-800",
                                             "simulator.fs=12000", "simulator.duration=1.0"])
    words = dict(word.split("=", 1) for word in twin_command(tmp_path / "r.npz", None, cfg.bearing, cfg.simulator,
                                                              "outer_x").split()[1:])
    weight = cfg.bearing.inner_mass_kg * cfg.simulator.gravity_m_per_s2
    assert float(words["operating_point.radial_load_n"]) == pytest.approx(np.hypot(800, weight) - weight, abs=0.1)
    assert float(words["operating_point.sensor_angle_deg"]) == pytest.approx(90 - np.degrees(np.arctan2(weight, 800)),
                                                                              abs=0.1)
    turned = cfg.copy()
    turned.simulator.load_x_n = 0.0
    turned.simulator.load_y_n = -float(words["operating_point.radial_load_n"])
    turned.simulator.sensor_angle_deg = float(words["operating_point.sensor_angle_deg"])
    spectra = []
    for setting in (cfg, turned):
        recording, _ = simulate(setting.fault, setting.bearing, setting.simulator, setting.effects)
        spectra.append(scipy.signal.welch(recording.signal, recording.fs, nperseg=1024)[1])
    level_db = 10 * np.log10(spectra[1] / spectra[0])
    assert np.median(np.abs(level_db)) < 0.5 and abs(10 * np.log10(spectra[1].sum() / spectra[0].sum())) < 0.5
    # A small load leaning the forces' sum off vertical (30 N across, 40 N up against a weight of 54 N): the frame is
    # still turned, and the load, smaller than the weight the twin adds, left to be fitted.
    cfg.simulator.load_x_n, cfg.simulator.load_y_n = 30.0, 40.0
    small = dict(word.split("=", 1) for word in twin_command(tmp_path / "r.npz", None, cfg.bearing, cfg.simulator,
                                                              "outer_x").split()[1:])
    assert float(small["operating_point.sensor_angle_deg"]) == pytest.approx(
        -90 - np.degrees(np.arctan2(40 - weight, 30)), abs=0.1)
    assert "operating_point.radial_load_n" not in small


def test_the_summary_names_the_effects_the_record_was_made_with(tmp_path):
    """The .npz states no effects: the summary is where a user sees what went into the record (a clipping whose
    level no sample reaches changes nothing, and its level is there to see)."""
    made = run(tmp_path, "fault=outer", "simulator.duration=0.2", "effects=[clipping]", f"out={tmp_path / 'c.npz'}")
    assert made.returncode == 0 and "  effects: clipping (clip_level 4.0)" in made.stdout, made.stdout
    bare = run(tmp_path, "fault=outer", "simulator.duration=0.2", f"out={tmp_path / 'b.npz'}")
    assert "  effects: none" in bare.stdout
    assert "  defect: 0.533 mm wide, 0.28 mm deep (a ball sinks 7.44 um into it)," in bare.stdout, bare.stdout
    # A setting left at null (noise's reference_rms: each signal's own) is no value to print ("reference_rms None").
    noisy = run(tmp_path, "fault=outer", "simulator.duration=0.2", "effects=[noise]", f"out={tmp_path / 'n.npz'}")
    assert "  effects: noise (snr_db " in noisy.stdout and "None" not in noisy.stdout, noisy.stdout


def test_the_summary_says_how_far_a_ball_sinks_into_the_pit():
    """A pit narrower than a ball is not reached to its bottom: the 0.28 mm deep pit of 0.533 mm lets a ball sink
    some micrometres (its sagitta over the chord, less the outer race's), which is what the record shows; the
    summary says both."""
    from bearingtwin.cli.simulate import defect_words
    from bearingtwin.physics.defects import max_drop_m

    geometry = BearingGeometry.from_config(compose_config("simulate").bearing)
    cfg = compose_config("simulate", ["simulator.duration=0.1"])
    record, _ = simulate("outer", cfg.bearing, cfg.simulator)
    sinks = max_drop_m(geometry.ball_diameter_mm / 2000, 0.533e-3, (geometry.pitch_diameter_mm
                                                                    + geometry.ball_diameter_mm) / 2000, convex_race=False)
    assert record.meta["defect_depth_m"] == pytest.approx(sinks, rel=1e-9) and 5e-6 < sinks < 10e-6
    words = defect_words(cfg.simulator.defect, "outer", record.meta["defect_depth_m"])
    assert words.startswith(f"0.533 mm wide, 0.28 mm deep (a ball sinks {sinks * 1e6:.3g} um into it), "), words


@pytest.mark.parametrize("folder", ["my conf", "josé"])  # quoted for Hydra: a space, a letter outside ASCII
def test_the_twin_call_it_suggests_finds_a_bearing_of_ones_own(tmp_path, folder):
    """The closing summary's bearingtwin-twin call carries the search path a bearing of one's own was found by
    (run as printed, it had been refused: no such bearing config)."""
    from bearingtwin.config import compose_config

    (tmp_path / folder / "bearing").mkdir(parents=True)
    (tmp_path / folder / "bearing" / "my6308.yaml").write_text(
        "defaults: [paper]\nname: my6308\nball_diameter_mm: 15.081\npitch_diameter_mm: 65.0\nn_balls: 8\n"
        "outer_diameter_mm: 90.0\ninner_diameter_mm: 40.0\n")
    result = run(tmp_path, f"hydra.searchpath=['file://{tmp_path / folder}']", "bearing=my6308",
                 "simulator.duration=0.2", f"out={tmp_path}/x.npz")
    assert result.returncode == 0, result.stderr
    call = next(line for line in result.stdout.splitlines() if "next:" in line).split("next: ")[1]
    words = shlex.split(call.removesuffix(" holds the twin against this record"))
    assert words[0] == "bearingtwin-twin"
    assert compose_config("twin", words[1:]).bearing.ball_diameter_mm == 15.081


def test_an_outer_race_defect_outside_the_load_zone_leaves_no_mark_and_is_said_to(tmp_path):
    """Under a downward load with clearance no ball is pressed at 12 o'clock: an outer-race defect there leaves the
    record a healthy bearing's (so the file, labelled outer, would teach a classifier nothing), and the simulation
    says so; at 6 o'clock, in the load zone, it changes the record by most of its level and nothing is said."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.load_y_n=-2000", "simulator.duration=0.3"])
    healthy, _ = simulate("normal", cfg.bearing, cfg.simulator)
    rms = {}
    for angle in (90.0, 270.0):
        cfg.simulator.defect.outer_angle_deg = angle
        faulty, _ = simulate("outer", cfg.bearing, cfg.simulator)
        rms[angle] = np.sqrt(np.mean((faulty.signal - healthy.signal) ** 2)) / np.sqrt(np.mean(healthy.signal ** 2))
        notes = faulty.meta.get("notes", [])
        if angle == 90.0:
            assert notes and "at 90 deg lies outside the static load zone" in notes[0]
        else:
            assert not notes
    assert rms[90.0] < 1e-3 and rms[270.0] > 0.5, rms


def test_without_clearance_a_downward_load_presses_the_lower_half_only():
    """At zero clearance the load zone spans a quarter circle either side of the load (Harris: acos(0) = 90 deg),
    not the whole circle: an outer-race defect at 12 o'clock is struck by no loaded ball, its record is the
    healthy one, and the simulation says so; at 4 o'clock (30 deg below horizontal), inside the zone, it shows."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.load_y_n=-2000", "simulator.duration=0.3",
                                             "bearing.clearance_mm=0"])
    healthy, _ = simulate("normal", cfg.bearing, cfg.simulator)
    for angle, outside in ((90.0, True), (-30.0, False)):
        cfg.simulator.defect.outer_angle_deg = angle
        faulty, _ = simulate("outer", cfg.bearing, cfg.simulator)
        change = np.sqrt(np.mean((faulty.signal - healthy.signal) ** 2)) / np.sqrt(np.mean(healthy.signal ** 2))
        notes = faulty.meta.get("notes", [])
        if outside:
            assert change < 1e-3 and notes and "the load zone spans 90 deg either side of 27" in notes[0]
        else:
            assert change > 0.1 and not notes, (change, notes)


@pytest.mark.parametrize("fault, rpm, short_s, long_s", [("inner", 60, 0.4, 1.2), ("ball", 120, 0.5, 1.3)])
def test_an_inner_or_ball_defect_that_never_turns_through_the_load_zone_is_said_to(fault, rpm, short_s, long_s):
    """At a low speed a short record may see the inner-race defect (turning with the shaft) or the ball's (turning
    with the cage and spinning) only outside the load zone: struck by no loaded ball, the record is the healthy
    one sample for sample, and the simulation says so, naming the duration that lets it through; a record long
    enough for a revolution (of the shaft, of the cage) shows the fault and says nothing."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR

    records = {}
    for duration in (short_s, long_s):
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            cfg = compose("simulate", overrides=[f"simulator.rpm={rpm}", f"simulator.duration={duration}"])
        healthy, _ = simulate("normal", cfg.bearing, cfg.simulator)
        faulty, _ = simulate(fault, cfg.bearing, cfg.simulator)
        records[duration] = (np.max(np.abs(faulty.signal - healthy.signal)) / np.max(np.abs(healthy.signal)),
                             faulty.meta.get("notes", []))
    change, notes = records[short_s]
    assert change < 1e-9 and len(notes) == 1 and "the record is a healthy bearing's" in notes[0], (change, notes)
    revolution = "shaft" if fault == "inner" else "cage"
    assert f"simulator.duration of a {revolution} revolution" in notes[0]
    change, notes = records[long_s]
    assert change > 10.0 and not notes, (change, notes)  # the defect's strikes stand far above the healthy record


def test_a_record_describes_itself_and_names_no_bearing_whose_geometry_the_command_line_changed(tmp_path):
    """A bearing with another ball count and pitch than its config's: the record's lines are at this geometry's
    defect frequencies, so the file names no bearing config (a reader would take cwru_6205's BPFO, 107 Hz, for
    this record's 146 Hz); the summary says so and its twin call holds the changed geometry. The record states
    its load, sensor direction, defect, effects and seed, and names the sensor it read (a direction between the
    axes is the race at that angle, not the x axis)."""
    from bearingtwin.cli.inspect import summarize
    from bearingtwin.config import compose_config

    out = tmp_path / "r.npz"
    result = run(tmp_path, "fault=outer", "bearing=cwru_6205", "bearing.n_balls=12", "bearing.pitch_diameter_mm=42",
                 "simulator.duration=0.5", "simulator.fs=12000", "simulator.sensor_angle_deg=45",
                 "simulator.load_y_n=-500", f"out={out}")
    assert result.returncode == 0, result.stderr
    with np.load(out) as record:
        assert "bearing" not in record.files and str(record["sensor"]) == "inner race at 45 deg"
        assert float(record["load_y_n"]) == -500 and float(record["sensor_angle_deg"]) == 45
        assert float(record["defect_width_mm"]) > 0 and str(record["effects"]) == "none"
    assert "the file names no bearing config" in result.stdout
    assert summarize(out)["meta"]["bearing_geometry"] == "12 balls of 7.94 mm on a 42 mm pitch, contact angle 0 deg"
    call = next(line for line in result.stdout.splitlines() if "next:" in line).split("next: ")[1]
    words = shlex.split(call.removesuffix(" holds the twin against this record"))
    twin_cfg = compose_config("twin", words[1:])
    assert twin_cfg.bearing.n_balls == 12 and twin_cfg.bearing.pitch_diameter_mm == 42
    assert "operating_point.sensor_angle_deg=45" in words
    given = BearingGeometry.from_config(twin_cfg.bearing)
    assert given.fault_frequency_hz("outer", 1797) == pytest.approx(145.73, abs=0.01)
    assert summarize(out).get("bearing") is None  # no bearing's lines read off a record of another geometry
    twin = run_module("bearingtwin.cli.twin", *words[1:], f"out={tmp_path / 'twin'}", "tracking.enabled=false",
                      "twin.duration=0.5", "compare.envelope_segment_s=0.25", "compare.lines_segment_s=0.25",
                      "calibration.n_trials_base=2", "calibration.n_polish=2", "candidates=[]", cwd=tmp_path, timeout=300)
    assert twin.returncode == 0, twin.stderr[-2000:]  # the call runs as printed, and says the bearing it read
    assert "  bearing: cwru_6205 bearing.n_balls=12 bearing.pitch_diameter_mm=42" in twin.stdout

    kept = run(tmp_path, "fault=normal", "bearing=cwru_6205", "bearing.clearance_mm=0.01", "simulator.duration=0.2",
               f"out={tmp_path / 'kept.npz'}")
    assert kept.returncode == 0, kept.stderr
    with np.load(tmp_path / "kept.npz") as record:  # a clearance moves no defect line: the bearing is still named
        assert str(record["bearing"]) == "cwru_6205" and str(record["sensor"]) == "inner_x"
    assert "bearing.clearance_mm=0.01" in kept.stdout.split("next: ")[1]
    with np.load(tmp_path / "kept.npz") as record:  # what the named config does not say is the record's own
        assert str(record["settings"]) == "fault=normal bearing=cwru_6205 bearing.clearance_mm=0.01 simulator.duration=0.2"

    unstruck = run(tmp_path, "fault=inner", "simulator.rpm=60", "simulator.duration=0.4", f"out={tmp_path / 'slow.npz'}")
    assert unstruck.returncode == 0, unstruck.stderr
    with np.load(tmp_path / "slow.npz") as record:  # the summary's note stays with the file it is about
        assert "the record is a healthy bearing's" in str(record["simulation_notes"])
    assert summarize(tmp_path / "slow.npz")["meta"]["simulation_notes"] == str(np.load(tmp_path / "slow.npz")["simulation_notes"])


def test_a_library_cache_the_disk_refuses_is_one_line(tmp_path):
    """numba saves a kernel it compiled to its cache: on a full disk (here a file-size limit and an empty cache) that
    write had ended the command in a numba traceback; its file is not named (numba's error names none)."""
    import resource
    import subprocess
    import sys

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (1_000, 1_000))

    refused = subprocess.run([sys.executable, "-m", "bearingtwin.cli.simulate", "fault=outer", "simulator.fs=48000",
                              "simulator.duration=0.1", f"out={tmp_path / 'r.npz'}"], cwd=tmp_path, capture_output=True,
                             text=True, preexec_fn=limited, timeout=300,
                             env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")})
    assert refused.returncode == 2, refused.stderr[-2000:]
    assert refused.stderr.strip() == ("error: a file could not be written (File too large): free some space, or raise "
                                      "the file-size limit, and run it again"), refused.stderr[-2000:]


def test_a_write_the_disk_refuses_leaves_no_partial_file_and_an_earlier_one_as_it_was(tmp_path):
    """A file-size limit (as a full disk) had left a truncated .npz no reader opens, over the good one of an earlier
    run at that path, with a traceback: now one line, exit 2, and the earlier file untouched. Without gravity the
    summary names no inner ring's weight among the loads."""
    import resource
    import subprocess
    import sys

    out = tmp_path / "r.npz"
    first = run(tmp_path, "fault=outer", "simulator.duration=0.2", "simulator.gravity_m_per_s2=0", f"out={out}")
    assert first.returncode == 0, first.stderr
    assert "  load: 0 N along x, 0 N along y (no gravity)" in first.stdout
    before = out.read_bytes()

    def limited():  # Python ignores SIGXFSZ: a write past the limit fails with EFBIG, as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))

    # numba compiles the solver's 48 kHz kernel once and saves it to its cache: a fresh clone's first run at that rate
    # would meet the limit there (one line too: the test before), not at the record.
    warm = run(tmp_path, "fault=outer", "simulator.fs=48000", "simulator.duration=0.1", f"out={tmp_path / 'warm.npz'}")
    assert warm.returncode == 0, warm.stderr
    (tmp_path / "warm.npz").unlink()
    refused = subprocess.run([sys.executable, "-m", "bearingtwin.cli.simulate", "fault=outer", "simulator.fs=48000",
                              "simulator.duration=2", f"out={out}"], cwd=tmp_path, capture_output=True, text=True,
                             preexec_fn=limited, timeout=300)
    assert refused.returncode == 2, refused.stderr[-2000:]
    assert refused.stderr.strip().splitlines()[-1] == (
        f"error: out={out}: cannot be written (File too large); nothing was written, and a file already there is as "
        "it was")
    assert out.read_bytes() == before and sorted(path.name for path in tmp_path.glob("r*")) == ["r.npz"]


def test_an_interrupt_ends_the_simulation_in_one_line_and_writes_nothing(tmp_path):
    """Ctrl-C while the solver runs: one line on stderr and exit 130, as the other commands end, with no traceback
    from inside the solver and no file."""
    import os
    import select
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "long.npz"
    process = subprocess.Popen([sys.executable, "-m", "bearingtwin.cli.simulate", "fault=outer", "simulator.fs=48000",
                                "simulator.duration=100", f"out={out}", "progress=true"], cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    said, deadline = b"", time.monotonic() + 120
    while b"simulate outer" not in said:  # the solver's progress bar (asked for in a log): the simulation is under way
        assert process.poll() is None and time.monotonic() < deadline, said[-2000:]
        if select.select([process.stderr], [], [], 0.2)[0]:
            said += os.read(process.stderr.fileno(), 65536)
    process.send_signal(signal.SIGINT)
    _, rest = process.communicate(timeout=120)
    err = (said + rest).decode()
    assert process.returncode == 130, err[-2000:]
    assert err.rstrip().endswith("interrupted by SIGINT; no run was open") and "Traceback" not in err, err[-2000:]
    assert not out.exists()


def test_no_note_of_an_unstruck_defect_where_no_static_load_zone_exists():
    """Without gravity or a load the balls are pressed by the dynamics alone (an unbalance here): no static zone
    to judge the defect's passages by, so nothing is said, and the defect does change the record."""
    from hydra import compose, initialize_config_dir

    from bearingtwin.config import CONF_DIR

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("simulate", overrides=["simulator.gravity_m_per_s2=0", "simulator.eccentricity_mm=0.05",
                                             "simulator.duration=0.3"])
    healthy, _ = simulate("normal", cfg.bearing, cfg.simulator)
    faulty, _ = simulate("inner", cfg.bearing, cfg.simulator)
    assert not faulty.meta.get("notes") and np.max(np.abs(faulty.signal - healthy.signal)) > 0


def test_an_outer_race_angle_past_a_turn_is_said_as_the_angle_it_is():
    from omegaconf import OmegaConf

    from bearingtwin.cli.simulate import defect_position

    def defect(angle_deg):
        return OmegaConf.create({"outer_angle_deg": angle_deg, "inner_angle_deg": 0.0, "ball_index": 0})

    assert defect_position(defect(400.0), "outer") == "at 40 deg (0: 3 o'clock, 90: 12 o'clock)"
    assert defect_position(defect(-90.0), "outer").startswith("at 270 deg ")
