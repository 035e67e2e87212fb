"""``data=files``: a folder of the user's recordings, labelled by labels.csv or a name pattern,
windowed and split as CWRU's; every bad folder is refused naming the file or field."""

from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR, REPO_ROOT, data_root
from bearingtwin.data.build import build_dataset
from bearingtwin.data.cwru import load_cwru
from bearingtwin.data.windows import split_indices
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS

CWRU = data_root() / "cwru"

FS = 8000.0
TONES_HZ = {"normal": 150.0, "inner": 410.0, "ball": 730.0, "outer": 1210.0}


def tone(state: str, seconds: float = 1.0, seed: int = 0) -> np.ndarray:
    t = np.arange(int(seconds * FS)) / FS
    return np.sin(2 * np.pi * TONES_HZ[state] * t) + 0.1 * np.random.default_rng(seed).standard_normal(t.size)


@pytest.fixture
def folder(tmp_path):
    """Two .npy recordings of normal and outer, one .csv (with a time column) of inner, a labels table."""
    root = tmp_path / "mine"
    root.mkdir()
    np.save(root / "a.npy", tone("normal"))
    np.save(root / "b.npy", tone("normal", seed=1))
    np.save(root / "c.npy", tone("outer"))
    signal = tone("inner")
    np.savetxt(root / "d.csv", np.column_stack([np.arange(signal.size) / FS, signal]), delimiter=",",
               header="time,acc", comments="", fmt="%.9f")
    (root / "labels.csv").write_text("record,state,rpm\na.npy,normal,1797\nb.npy,normal,1797\nc.npy,outer,1797\nd.csv,inner,1797\n")
    return root


def files_cfg(root, *overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose("train", overrides=["data=files", f"data.root={root}", "data.windows_per_record=10",
                                           "data.window_length=512", "data.fs=8000", *overrides])


def test_labels_table_gives_each_file_its_state_and_the_split_keeps_records_apart(folder):
    dataset = build_dataset(files_cfg(folder))
    assert [name.rsplit("/", 1)[-1] for name in dataset.records] == ["a.npy", "b.npy", "c.npy", "d.csv"]
    states = [FAULTS[label] for label in dataset.labels[::10]]
    assert states == ["normal", "normal", "outer", "inner"] and dataset.windows.shape == (40, 512)
    assert dataset.fs == FS and dataset.record_rpms == [1797.0] * 4
    train, test = split_indices(dataset.labels, dataset.record_ids, dataset.starts, dataset.record_lengths,
                                512, method="block", train_fraction=0.7, seed=0)
    for record in range(4):  # block split: per record, every training window ends before the first test window
        of_record = dataset.record_ids == record
        ends = dataset.starts[train][of_record[train]] + 512
        assert ends.max() <= dataset.starts[test][of_record[test]].min()
    # The key follows the content and labelling, not where the folder lives.
    assert build_dataset(files_cfg(folder)).key == dataset.key
    import shutil

    moved = folder.parent / "moved"
    shutil.copytree(folder, moved)
    assert build_dataset(files_cfg(moved)).key == dataset.key
    np.save(moved / "c.npy", tone("normal", seed=2))  # written over: same name, same size, other data
    assert (moved / "c.npy").stat().st_size == (folder / "c.npy").stat().st_size
    assert build_dataset(files_cfg(moved)).key != dataset.key
    (folder / "labels.csv").write_text("record,state,rpm\na.npy,normal,1797\nb.npy,normal,1797\nc.npy,outer,1750\n"
                                       "d.csv,inner,1797\n")
    assert build_dataset(files_cfg(folder)).key != dataset.key  # a row's speed
    (folder / "labels.csv").write_text("record,state\na.npy,normal\nb.npy,ball\nc.npy,outer\nd.csv,inner\n")
    assert build_dataset(files_cfg(folder)).key != dataset.key


def test_a_labels_rows_unit_reads_a_file_that_states_none_beside_files_that_state_theirs(tmp_path):
    """A logger's WAV states no unit: beside .npz files in m/s^2 it had refused the folder ("states no unit"), whatever
    the user knew. Its row's unit reads it (in g, converted to m/s^2 with the others); a row's unit the file
    contradicts, or one no unit known here, is refused naming the row. An integer WAV's row gives its full scale
    (scale), which training had no way to take."""
    import scipy.io.wavfile

    root = tmp_path / "plant"
    root.mkdir()
    signal = tone("normal")
    scipy.io.wavfile.write(root / "pump.wav", int(FS), (signal / 9.80665).astype(np.float32))  # the logger's, in g
    for state in ("inner", "ball", "outer"):
        np.savez(root / f"{state}.npz", signal=tone(state), fs=FS, unit="m/s^2")
    rows = "".join(f"{state}.npz,{state},1797\n" for state in ("inner", "ball", "outer"))
    (root / "labels.csv").write_text("record,state,rpm\npump.wav,normal,1797\n" + rows)
    with pytest.raises(BearingTwinError, match=r"pump.wav states no unit, inner.npz states m/s\^2"):
        build_dataset(files_cfg(root))
    (root / "labels.csv").write_text("record,state,rpm,unit\npump.wav,normal,1797,g\n" + rows)
    dataset = build_dataset(files_cfg(root))
    assert dataset.unit == "m/s^2"  # the WAV's windows in the others' unit, its samples 9.81 times larger
    np.testing.assert_allclose(dataset.windows[0], signal[:512], rtol=1e-6)
    (root / "labels.csv").write_text("record,state,rpm,unit\npump.wav,normal,1797,g\n" + rows.replace(",1797\n", ",1797,g\n"))
    with pytest.raises(BearingTwinError, match=r"^3 of 4 files refused: \S*inner.npz: the labels row's unit=g "
                                               r"contradicts the file's unit, m/s\^2; \S*ball.npz: "):
        build_dataset(files_cfg(root))
    (root / "labels.csv").write_text("record,state,rpm,unit\npump.wav,normal,1797,gee\n" + rows)
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: unit='gee' is no unit known here"):
        build_dataset(files_cfg(root))
    # An integer WAV holds fractions of its recorder's full scale: its row's scale (5 g) reads it in g.
    counts = np.round(signal / 9.80665 / 5 * 32767).astype(np.int16)
    (root / "pump.wav").unlink()
    scipy.io.wavfile.write(root / "pump.wav", int(FS), counts)
    (root / "labels.csv").write_text("record,state,rpm,unit,scale\npump.wav,normal,1797,g,5\n" + rows)
    np.testing.assert_allclose(build_dataset(files_cfg(root)).windows[0], signal[:512], atol=5 * 9.80665 / 32767)
    (root / "labels.csv").write_text("record,state,rpm,scale\npump.wav,normal,1797,5\n" + rows)
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: scale 5 needs a unit in the row"):
        build_dataset(files_cfg(root))


def test_every_file_that_cannot_be_read_is_named_in_one_refusal(folder):
    """Training had stopped at the first bad file, so a folder with several was mended one run at a time: one line
    now names each (the first three and a count), and a single bad file is refused in its own words, as before."""
    np.save(folder / "a.npy", np.array([1.0, np.nan, 2.0] * 4000))
    (folder / "b.npy").write_bytes(b"")
    with pytest.raises(BearingTwinError, match=r"^2 of 4 files refused: \S*a.npy: .*NaN.*; \S*b.npy: the file is empty$"):
        build_dataset(files_cfg(folder))
    np.save(folder / "b.npy", tone("normal", seed=1))
    with pytest.raises(BearingTwinError, match=r"^\S*a.npy: .*NaN"):
        build_dataset(files_cfg(folder))


def test_a_file_name_pattern_labels_instead_of_a_table(tmp_path):
    for state in ("normal", "ball"):
        np.save(tmp_path / f"{state}_run1.npy", tone(state))
    (tmp_path / "labels.csv").write_text("record,state\nnormal_run1.npy,inner\n")  # not read, not a recording
    dataset = build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'"))
    assert sorted({FAULTS[label] for label in dataset.labels}) == ["ball", "normal"] and len(dataset.records) == 2
    np.save(tmp_path / "run2.npy", tone("outer"))
    with pytest.raises(BearingTwinError, match=r"run2.npy: data.pattern=.* does not match its name"):
        build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'"))


@pytest.mark.parametrize("change, message", [
    (lambda root: (root / "labels.csv").unlink(), "data.labels: no labels file"),
    (lambda root: (root / "labels.csv").write_text("record,state\na.npy,cracked\n"), "labels.csv line 2: state 'cracked' is not a bearing state"),
    (lambda root: (root / "labels.csv").write_text("record,state\nz.npy,normal\n"), "labels.csv line 2: record 'z.npy' is not a file"),
    # A training set built without the record a row fails to label would be a wrong result: refused, not skipped.
    (lambda root: (root / "labels.csv").write_text("record,state,rpm\na.npy,normal,1797\nc.npy,outer,fast\n"),
     "labels.csv line 3: rpm='fast' must be a positive number of rev/min"),
    (lambda root: (root / "labels.csv").write_text("record,state,fs\na.npy,normal,8000\nc.npy,outer,-8000\n"),
     "labels.csv line 3: fs='-8000' must be a positive number of Hz"),
    (lambda root: (root / "labels.csv").write_text("file,state\na.npy,normal\n"), "labels.csv: no column record"),
    (lambda root: ((root / "labels.csv").write_text("record,state,fs\nc.npy,outer,8000\n"), (root / "c.npy").write_bytes(b"x")),
     "c.npy: not a NumPy .npy file"),
    (lambda root: (root / "labels.csv").write_text("record,state,fs\na.npy,normal,8000\nc.npy,outer,16000\n"),
     "different sampling rates (a.npy: 8000 Hz, c.npy: 16000 Hz)"),
    (lambda root: None, "a.npy: the file does not state its sampling rate; give data.fs=<Hz>"),
    (lambda root: np.save(root / "a.npy", np.stack([tone("normal"), tone("normal", seed=3)], axis=1)),
     "a.npy: holds channels 0, 1; choose one with data.channel=<name>"),
])
def test_a_bad_folder_is_refused_naming_the_file_or_field(folder, change, message):
    change(folder)
    with pytest.raises(BearingTwinError) as error:
        build_dataset(files_cfg(folder, "data.fs=null"))  # rates from the files or the labels table
    assert message in str(error.value) and "\n" not in str(error.value)


def test_files_that_name_a_bearing_no_config_describes_are_refused_unless_data_bearing_says_which(folder):
    """A folder of one's own simulations (``bearingtwin-simulate bearing=skf_6206`` with a search path) trained without
    it had been read with the config's bearing, a log line aside: refused, naming data.bearing; given, it is read."""
    for name in ("a", "b", "c"):
        np.savez(folder / f"{name}.npz", signal=np.load(folder / f"{name}.npy"), bearing="skf_6206")
        (folder / f"{name}.npy").unlink()
    (folder / "d.csv").unlink()
    (folder / "labels.csv").write_text("record,state,rpm\na.npz,normal,1797\nb.npz,normal,1797\nc.npz,outer,1797\n")
    with pytest.raises(BearingTwinError) as error:
        build_dataset(files_cfg(folder))
    assert str(error.value) == ("data.root: the file names bearing skf_6206, which no conf/bearing config here describes: "
                                "its defect frequencies are unknown here (give data.bearing=<name>, with hydra.searchpath "
                                "for one of your own)")
    assert build_dataset(files_cfg(folder, "data.bearing=paper")).windows.shape == (30, 512)


def test_no_folder_given_is_named_in_one_line():
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("train", overrides=["data=files"])
    with pytest.raises(BearingTwinError, match=r"^data.root is missing; give data.root=<value>$") as error:
        build_dataset(cfg)
    assert "\n" not in str(error.value)


def test_a_labels_table_names_each_file_once(tmp_path):
    """Training reads files by their path in the folder: one stem in two subfolders is two records, the same
    path twice is refused naming both lines; a spreadsheet's byte-order mark and a non-positive rate are handled."""
    from bearingtwin.data.labels import labels_table

    table = tmp_path / "labels.csv"
    table.write_text("record,state\nhealthy/run1.npy,normal\nouter/run1.npy,outer\n", encoding="utf-8-sig")
    assert [(row.record, row.state) for row in labels_table(table)] == [
        ("healthy/run1.npy", "normal"), ("outer/run1.npy", "outer")]
    table.write_text("record,state\nrun1.npy,normal\n./run1.npy,outer\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 3: record './run1.npy' is labelled again \(line 2\)"):
        labels_table(table)
    table.write_text("record,state,\nrun1.npy,normal,\n")  # a spreadsheet's trailing comma
    assert [row.state for row in labels_table(table)] == ["normal"]
    table.write_text("record,state\nrun1.npy,normal,\n")  # ... on the rows only
    assert [row.state for row in labels_table(table)] == ["normal"]
    table.write_text("record,state,,\nrun1.npy,normal,\nrun2.npy,outer,1750,\n")  # ... under a column of no name
    with pytest.raises(BearingTwinError, match=r"labels.csv line 3: more values than the header has columns"):
        labels_table(table)
    table.write_text("record,state\nrun1.npy,normal\nrun2.npy,outer,1750,12000\n")  # a speed under no column
    with pytest.raises(BearingTwinError, match=r"labels.csv line 3: more values than the header has columns "
                                               r"\(record, state\); name every column in the header"):
        labels_table(table)
    table.write_text("record;state;rpm;fs\nrun1.npy;normal;1797,5;12000\n")  # a decimal-comma spreadsheet's
    assert [row[1:5] for row in labels_table(table)] == [("run1.npy", "normal", 1797.5, 12000.0)]
    table.write_text("record;state;rpm;fs\nrun1.npy;normal;1797;12.000\n")  # its point groups thousands: 12 or 12000?
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: fs '12.000' reads two ways in a table of semicolons "
                                               r"\(a spreadsheet's with decimal commas\): 12 or 12000; write it without "
                                               r"the point$"):
        labels_table(table)
    table.write_text("record,state,speed\nrun1.npy,normal,1500\n")  # passed over, the file would be read at another
    with pytest.raises(BearingTwinError, match=r"labels.csv: column 'speed' is not one of record, state, rpm, fs, unit, scale$"):
        labels_table(table)
    table.write_text("record,state\n\nrun1.npy,normal\n\nrun2.npy,cracked\n")  # blank lines count as lines
    with pytest.raises(BearingTwinError, match=r"labels.csv line 5: state 'cracked'"):
        labels_table(table)
    table.write_text("record,state\nrun1.npy,normal\n\nrun1.npy,outer\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 4: record 'run1.npy' is labelled again \(line 2\)"):
        labels_table(table)
    table.write_text("record,state,fs\nrun1.npy,normal,0\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: fs='0' must be a positive number of Hz"):
        labels_table(table)


def test_a_bad_row_is_its_records_concern_for_a_reader_of_some_rows_and_every_readers_for_training(tmp_path):
    """Read row by row, a table's good rows are read and each bad row is given with its record and the message that
    names its line and field; read whole (training), its first bad row refuses it. A bad header is every row's."""
    from bearingtwin.data.labels import labels_table, labels_table_with_bad_rows

    table = tmp_path / "labels.csv"
    table.write_text("record,state,rpm,fs\ngood.npy,outer,1797,12000\nrpm.npy,normal,fast,12000\n"
                     "state.npy,outter,1797,12000\nfs.npy,normal,1797,-5\ngood.npy,inner,1797,12000\n"
                     "wide.npy,normal,1797,12000,3\n")
    rows, bad_rows = labels_table_with_bad_rows(table)
    assert [row[1:5] for row in rows] == [("good.npy", "outer", 1797.0, 12000.0)]
    assert [record for record, _ in bad_rows] == ["rpm.npy", "state.npy", "fs.npy", "good.npy", "wide.npy"]
    messages = [message for _, message in bad_rows]
    assert all(message.startswith(f"{table} line {line}: ") for message, line in zip(messages, range(3, 8)))
    assert messages[0] == f"{table} line 3: rpm='fast' must be a positive number of rev/min (a plain number, no unit)"
    assert "state 'outter' is not a bearing state" in messages[1] and "fs='-5' must be a positive number" in messages[2]
    assert "record 'good.npy' is labelled again (line 2)" in messages[3] and "more values than the header" in messages[4]
    with pytest.raises(BearingTwinError) as error:  # every bad row named at once (the first three and a count)
        labels_table(table)
    assert str(error.value) == f"5 rows of {table} do not read: {'; '.join(messages[:3])}; and 2 more"
    table.write_text("record,status\ngood.npy,outer\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv: no column state"):
        labels_table_with_bad_rows(table)
    table.write_text("Record,State,RPM,Fs\ngood.npy,outer,1797,12000\n")  # as a spreadsheet capitalizes them
    assert [row[1:5] for row in labels_table_with_bad_rows(table)[0]] == [("good.npy", "outer", 1797.0, 12000.0)]
    table.write_text("record,state,rpm,RPM\ngood.npy,outer,1797,1750\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv: the header names column rpm more than once \(in any case\)"):
        labels_table_with_bad_rows(table)


def test_a_diagnosis_reads_a_labels_table_without_states_where_training_does_not(tmp_path):
    """For a fleet the states are what is asked: a diagnosis reads a table whose state column is left out or whose
    state cells are empty, for its speeds and rates (the state None: unknown), while a state given must still be one;
    training refuses either, its states being its labels."""
    from bearingtwin.data.labels import labels_table, labels_table_with_bad_rows

    table = tmp_path / "labels.csv"
    table.write_text("record,rpm,fs\na.npy,1500,12000\n")
    assert [row[1:5] for row in labels_table_with_bad_rows(table, state_required=False)[0]] == [
        ("a.npy", None, 1500.0, 12000.0)]
    with pytest.raises(BearingTwinError, match=r"labels.csv: no column state; the header must read "
                                               r"record,state,rpm,fs,unit,scale \(rpm, fs, unit, scale optional\)$"):
        labels_table(table)
    table.write_text("record,state,rpm\na.npy,,1500\nb.npy,outter,1500\nc.npy,inner,\n")
    rows, bad_rows = labels_table_with_bad_rows(table, state_required=False)
    assert [row[1:5] for row in rows] == [("a.npy", None, 1500.0, None), ("c.npy", "inner", None, None)]
    assert [record for record, _ in bad_rows] == ["b.npy"]
    with pytest.raises(BearingTwinError, match=r"labels.csv line 2: state '' is not a bearing state"):
        labels_table(table)
    table.write_text("file,rpm\na.npy,1500\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv: no column record; the header must read "
                                               r"record,state,rpm,fs,unit,scale \(state, rpm, fs, unit, scale optional\)$"):
        labels_table_with_bad_rows(table, state_required=False)


def test_tables_that_hold_no_signal_are_no_recordings_of_a_folder(tmp_path, caplog):
    """Notes, a results table and a labels table under another name beside the recordings are left out, each named
    with why; a CSV of numbers is a recording, labelled or not, and so is one with a time column beside a text column
    (its reader then names the text). Labelled by file name, a run is built from the recordings alone."""
    from bearingtwin.data.labels import recordings_in, recordings_and_others

    for state in ("normal", "ball"):
        np.save(tmp_path / f"{state}_run1.npy", tone(state))
    np.savetxt(tmp_path / "outer_run2.csv", tone("outer"))
    (tmp_path / "notes.csv").write_text("date,operator,comment\n2024-01-02,ann,\"new sensor, glued\"\n")
    (tmp_path / "results.csv").write_text("record,verdict,share\nnormal_run1,normal,0.9\n")
    (tmp_path / "states.csv").write_text("record,state\nnormal_run1.npy,normal\n")
    (tmp_path / "logger.csv").write_text("time,acc,status\n0,0.1,ok\n0.001,0.2,ok\n")
    (tmp_path / "readme.txt").write_text("rig B")
    (tmp_path / "mounting.jpg").write_bytes(b"\xff\xd8\xff")
    np.savetxt(tmp_path / "inner_run3.txt", tone("inner"), delimiter="\t")  # a logger's text export is a recording
    (tmp_path / "loop.npy").symlink_to(tmp_path / "loop.npy")  # a link to itself, and one whose target is gone:
    (tmp_path / "gone.npy").symlink_to(tmp_path / "moved_away.npy")  # had been passed over without a word
    recordings, others = recordings_and_others(tmp_path)
    assert [path.name for path in recordings] == ["ball_run1.npy", "inner_run3.txt", "logger.csv", "normal_run1.npy",
                                                  "outer_run2.csv"]
    assert recordings_in(tmp_path) == recordings
    nothing = "a link to nothing (its target is gone, or it links back to itself)"
    assert others == {"gone.npy": nothing, "loop.npy": nothing,
                      "mounting.jpg": "not .npy, .npz, .csv, .txt, .tsv, .mat, .wav, .xls",
                      "notes.csv": "its column 'date' holds text ('2024-01-02'), not samples",
                      "readme.txt": "no row of numbers (notes, or a table of text), not samples",
                      "results.csv": "its column 'record' holds text ('normal_run1'), not samples",
                      "states.csv": "a labels table, columns record,state, not a recording"}
    (tmp_path / "logger.csv").unlink()
    with caplog.at_level("WARNING"):
        dataset = build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'"))
    assert sorted(name.rsplit("/", 1)[-1] for name in dataset.records) == ["ball_run1.npy", "inner_run3.txt",
                                                                            "normal_run1.npy", "outer_run2.csv"]
    assert f"{tmp_path}: left out notes.csv (its column 'date' holds text ('2024-01-02'), not samples)" in caplog.text
    # A logger's clock time is a recording's column: kept, its reader reading the clock times as its time stamps.
    (tmp_path / "logger.csv").write_text("Timestamp,acc\n2024-01-02 10:00:00.001,0.1\n2024-01-02 10:00:00.002,0.2\n")
    assert tmp_path / "logger.csv" in recordings_and_others(tmp_path)[0]
    (tmp_path / "logger.csv").unlink()
    # A picture the pattern would name is no recording it misses.
    (tmp_path / "outer_spectrum.png").write_bytes(b"\x89PNG")
    # A hidden file is no recording, whatever its suffix (macOS leaves ._<name> beside every file it copies).
    (tmp_path / "._normal_run1.npy").write_bytes(b"\x00\x05\x16\x07")
    assert "._normal_run1.npy" not in [path.name for path in recordings_and_others(tmp_path)[0]]
    # Nor is Excel's lock file beside a workbook open in it, though its name ends .xls (it had been read and refused
    # as a binary workbook).
    (tmp_path / "~$outer_run2.xls").write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(154))
    assert "~$outer_run2.xls" not in [path.name for path in recordings_and_others(tmp_path)[0]]
    assert "~$outer_run2.xls" not in recordings_and_others(tmp_path)[1]
    # Notes in words, a table of text and an empty file under .txt or .tsv are passed over even where the pattern
    # names them; a table of numbers under .tsv is a recording.
    (tmp_path / "inner_notes.txt").write_text("Rig B: the inner-race runs, sensor on the housing.\nTimes: 10 s each.\n")
    (tmp_path / "outer_scores.tsv").write_text("record\tscore\nnormal_run1\t0.9\n")
    (tmp_path / "ball_todo.txt").write_text("")
    others = recordings_and_others(tmp_path)[1]
    assert {others[name] for name in ("inner_notes.txt", "outer_scores.tsv", "ball_todo.txt")} == {
        "no row of numbers (notes, or a table of text), not samples"}
    assert len(build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'")).records) == 4
    for name in ("inner_notes.txt", "outer_scores.tsv", "ball_todo.txt"):
        (tmp_path / name).unlink()
    # A file of one number is a setting or a stamp beside the recordings (a benchmark's seed.txt, a rate.csv),
    # whatever its suffix; two numbers are a (short) recording, for its reader to judge.
    (tmp_path / "seed.txt").write_text("2026\n")
    (tmp_path / "inner_rate.csv").write_text("# the rig's rate\nfs\n12000\n")
    (tmp_path / "outer_pair.txt").write_text("0.1\n0.2\n")
    recordings, others = recordings_and_others(tmp_path)
    assert others["seed.txt"] == others["inner_rate.csv"] == "one number (a setting or a stamp), not samples"
    assert tmp_path / "outer_pair.txt" in recordings
    (tmp_path / "outer_pair.txt").unlink()  # (a recording of two samples is too short for a window)
    # Passed over even where the pattern names it, as notes are.
    assert len(build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'")).records) == 4
    for name in ("seed.txt", "inner_rate.csv"):
        (tmp_path / name).unlink()
    # A logger's clock under .txt is a recording as under .csv, for its reader to name the cell it cannot read.
    (tmp_path / "logger.txt").write_text("Timestamp\tacc\n2024-01-02 10:00:00.001\t0.1\n")
    assert tmp_path / "logger.txt" in recordings_and_others(tmp_path)[0]
    (tmp_path / "logger.txt").unlink()
    # A file the pattern names a recording is one: left out, the run would be short of it.
    (tmp_path / "outer_run3.csv").write_text("acc,status\n0.1,ok\n0.2,ok\n")
    with pytest.raises(BearingTwinError, match=r"outer_run3.csv: data.pattern='\^\(\?P<state>\[a-z\]\+\)_' names it a "
                                               r"recording, but it is none \(its column 'status' holds text"):
        build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'"))
    (tmp_path / "outer_run3.csv").unlink()
    assert len(build_dataset(files_cfg(tmp_path, "data.pattern='^(?P<state>[a-z]+)_'")).records) == 4  # the .png passed
    # Labelled by a table, the tables of notes beside it are named too.
    (tmp_path / "labels.csv").write_text("record,state\nnormal_run1.npy,normal\nball_run1.npy,ball\nouter_run2.csv,outer\n")
    caplog.clear()
    with caplog.at_level("WARNING"):
        build_dataset(files_cfg(tmp_path))
    assert f"{tmp_path}: left out notes.csv (its column 'date' holds text ('2024-01-02'), not samples)" in caplog.text


@pytest.mark.parametrize("setting, message", [
    ("data.window_length=abc", "data.window_length must be a positive integer, got 'abc'"),
    ("data.window_length=1.5", "data.window_length must be a positive integer, got 1.5"),
    ("data.window_length=true", "data.window_length must be a positive integer, got True"),
    ("data.window_length=512.9", "data.window_length must be a positive integer, got 512.9"),
    ("data.windows_per_record=abc", "data.windows_per_record must be a positive integer, got 'abc'"),
    ("data.windows_per_record=2.7", "data.windows_per_record must be a positive integer, got 2.7"),
    ("data.train_fraction=abc", "data.train_fraction must be a number strictly between 0 and 1, got 'abc'"),
    ("data.train_fraction=1.5", "data.train_fraction must lie strictly between 0 and 1, got 1.5"),
    ("data.fs=abc", "data.fs='abc' must be a positive number of Hz"),
    ("data.rpm=abc", "data.rpm='abc' must be a positive number of rev/min"),
])
def test_a_data_setting_of_the_wrong_kind_is_named_not_truncated(folder, setting, message):
    with pytest.raises(BearingTwinError) as error:
        build_dataset(files_cfg(folder, setting))
    assert str(error.value).startswith(message)


def test_windows_that_cannot_fit_in_memory_are_refused_before_any_is_cut(folder, monkeypatch):
    from bearingtwin.data import windows

    with pytest.raises(BearingTwinError, match=r"^data.windows_per_record=1000000000 windows of data.window_length=512 "
                       r"samples from each of 4 records need about 3.28e\+04 GB of memory.*lower data.windows_per_record"):
        build_dataset(files_cfg(folder, "data.windows_per_record=1e9"))
    monkeypatch.setattr(windows, "physical_memory_bytes", lambda: 1_000_000)  # 10 x 512 x 4 windows need 0.33 MB
    build_dataset(files_cfg(folder))
    monkeypatch.setattr(windows, "physical_memory_bytes", lambda: 600_000)
    with pytest.raises(BearingTwinError, match=r"this machine's 0.0006 GB"):
        build_dataset(files_cfg(folder))


def test_a_rate_the_file_states_exactly_is_not_replaced_by_a_labels_row(tmp_path):
    """An .npz states 8000 Hz: 8050 Hz (within the 1 % a rounded time column is allowed) is a contradiction."""
    root = tmp_path / "mine"
    root.mkdir()
    for state in ("normal", "outer"):
        np.savez(root / f"{state}.npz", signal=tone(state), fs=FS)
    (root / "labels.csv").write_text("record,state,fs\nnormal.npz,normal,8000\nouter.npz,outer,8050\n")
    with pytest.raises(BearingTwinError, match=r"outer.npz: the labels row's fs=8050 Hz contradicts the file's 8000 Hz"):
        build_dataset(files_cfg(root, "data.fs=null"))
    (tmp_path / "states.csv").write_text("record,state\nnormal.npz,normal\nouter.npz,outer\n")
    with pytest.raises(BearingTwinError, match=r"normal.npz: data.fs=8050 Hz contradicts the file's 8000 Hz"):
        build_dataset(files_cfg(root, "data.fs=8050", f"data.labels={tmp_path / 'states.csv'}"))
    assert build_dataset(files_cfg(root, "data.fs=8000", f"data.labels={tmp_path / 'states.csv'}")).fs == FS


def test_a_state_the_split_leaves_without_test_windows_stops_the_run_naming_it(tmp_path):
    """One state's file too short for a window after the 70 % mark: a run would score the other states only."""
    from bearingtwin.models.experiment import run_experiment

    root = tmp_path / "mine"
    root.mkdir()
    for state in FAULTS:
        np.save(root / f"{state}.npy", tone(state)[:1000] if state == "ball" else tone(state))
    (root / "labels.csv").write_text("record,state\n" + "".join(f"{state}.npy,{state}\n" for state in FAULTS))
    cfg = files_cfg(root, "classifier=svm", f"paths.cache_dir={tmp_path / 'cache'}")
    with pytest.raises(BearingTwinError, match=r"class ball no test windows .*its records: ball.npy \(1000 samples, "
                       r"10 windows\)\. Give records of at least 1707 samples"):
        run_experiment(cfg, root_dir=str(tmp_path))


def test_a_folder_of_several_recordings_a_state_trains_and_tests_on_whole_recordings(tmp_path):
    """data.split=record through a run: of each state's three recordings two train and one tests, none on both
    sides, and the run scores the held-out recordings; a state recorded once is refused before any feature."""
    from bearingtwin.models.experiment import run_experiment

    root = tmp_path / "mine"
    root.mkdir()
    rows = []
    for state in FAULTS:
        for take in range(3):
            np.save(root / f"{state}_{take}.npy", tone(state, seed=10 * FAULTS.index(state) + take))
            rows.append(f"{state}_{take}.npy,{state}\n")
    (root / "labels.csv").write_text("record,state\n" + "".join(rows))
    result = run_experiment(files_cfg(root, "classifier=svm", "features=raw", "data.split=record",
                                      f"paths.cache_dir={tmp_path / 'cache'}"), root_dir=str(tmp_path))
    tested = {row["record"] for row in result.per_record}
    assert len(tested) == 4 and {name.rsplit("_", 1)[0] for name in tested} == set(FAULTS), tested
    assert result.n_test == 4 * 10 and result.n_train == 8 * 10
    (root / "labels.csv").write_text("record,state\n" + "".join(rows[:-2]))  # outer recorded once
    with pytest.raises(BearingTwinError, match=r"data.split=record needs two records or more of each class; outer has "
                                               r"one \(outer_0.npy\)"):
        run_experiment(files_cfg(root, "classifier=svm", "features=raw", "data.split=record",
                                 f"paths.cache_dir={tmp_path / 'cache'}"), root_dir=str(tmp_path))


def test_a_folder_of_one_state_is_refused_before_any_feature_is_extracted(tmp_path, monkeypatch):
    from bearingtwin.models import experiment

    root = tmp_path / "mine"
    root.mkdir()
    for seed in range(2):
        np.save(root / f"run{seed}.npy", tone("normal", seed=seed))
    (root / "labels.csv").write_text("record,state\nrun0.npy,normal\nrun1.npy,normal\n")
    monkeypatch.setattr(experiment, "extract_features", lambda *args: pytest.fail("features extracted"))
    with pytest.raises(BearingTwinError, match=r"^the training windows are all of one bearing state \(normal\)"):
        experiment.run_experiment(files_cfg(root, "classifier=svm", f"paths.cache_dir={tmp_path / 'cache'}"),
                                  root_dir=str(tmp_path))



def test_a_recording_in_a_subfolder_that_a_labels_row_names_is_part_of_the_runs_hash(folder):
    """A run is its config and its files: a labelled recording written over in a subfolder is another run."""
    from bearingtwin.data.build import input_digest

    (folder / "sub").mkdir()
    np.save(folder / "sub" / "e.npy", tone("outer", seed=3))
    with open(folder / "labels.csv", "a") as table:
        table.write("sub/e.npy,outer,1797\n")
    cfg = files_cfg(folder)
    before = input_digest(cfg)
    np.save(folder / "sub" / "e.npy", tone("outer", seed=4))  # same name and size, other data
    assert input_digest(cfg) != before


def test_a_rate_a_labels_row_or_data_fs_gives_is_checked_against_the_shaft_line(tmp_path):
    """Recordings whose shaft (1797 rpm) shows its harmonic series, sampled at 12 kHz and labelled 8 kHz: read at
    8 kHz the series stands at two thirds of its place, so the rate is refused naming the file and where it came from;
    ``data.check_fs=false`` reads them as told, and the true rate passes."""
    root = tmp_path / "mine"
    root.mkdir()
    fs, shaft_hz = 12000.0, 1797.0 / 60.0
    t = np.arange(int(4 * fs)) / fs
    rng = np.random.default_rng(0)
    for state in ("normal", "outer"):
        series = sum(np.sin(2 * np.pi * k * shaft_hz * t + k) / k for k in range(1, 7))
        np.save(root / f"{state}.npy", series + 0.05 * rng.standard_normal(t.size))
    (root / "labels.csv").write_text("record,state,rpm,fs\nnormal.npy,normal,1797,8000\nouter.npy,outer,1797,8000\n")
    with pytest.raises(BearingTwinError, match=r"normal.npy: fs = 8000 Hz contradicts the shaft speed.*fs may be "
                                               r"120\d\d Hz .*; give the true rate with the labels row's fs=<Hz> \(or the true "
                                               r"speed with the labels row's rpm=<rev/min>\), or data.check_fs=false "
                                               r"if both 8000 Hz and 1797 rpm are true"):
        build_dataset(files_cfg(root, "data.fs=null"))
    assert build_dataset(files_cfg(root, "data.fs=null", "data.check_fs=false")).fs == 8000.0
    (root / "labels.csv").write_text("record,state,rpm\nnormal.npy,normal,1797\nouter.npy,outer,1797\n")
    with pytest.raises(BearingTwinError, match=r"normal.npy: fs = 8000 Hz contradicts .* with data.fs=<Hz>"):
        build_dataset(files_cfg(root, "data.fs=8000"))
    assert build_dataset(files_cfg(root, "data.fs=12000")).fs == fs


@pytest.mark.skipif(not CWRU.is_dir(), reason=f"CWRU records not present in {CWRU}")
@pytest.mark.parametrize("given", ["row", "setting"])
def test_a_speed_ten_times_too_high_is_refused_naming_the_speeds_setting_too(tmp_path, given):
    """A CWRU outer-race record at its true 12 kHz, labelled with a speed a digit too long: every defect
    frequency then falls on a harmonic of its true one, which confirmed the rate before. Its BPFO comb stands at
    a tenth of the frequency expected, so the rate is refused, and the message names the speed's setting as the
    other suspect."""
    root = tmp_path / "mine"
    root.mkdir()
    recording = load_cwru(CWRU / "12k_Drive_End_OR007@6_0_130.mat")
    np.save(root / "outer.npy", recording.signal)
    rpm, key = 10 * recording.rpm, ("the labels row's rpm" if given == "row" else "data.rpm")
    (root / "labels.csv").write_text(f"record,state,rpm,fs\nouter.npy,outer,{rpm if given == 'row' else ''},12000\n")
    overrides = ["data.fs=null", "data.bearing=cwru_6205", *([f"data.rpm={rpm}"] if given == "setting" else [])]
    with pytest.raises(BearingTwinError, match=rf"outer.npy: fs = 12000 Hz contradicts the shaft speed: at {rpm:g} rpm"
                                               rf".*give the true rate with the labels row's fs=<Hz> \(or the true "
                                               rf"speed with {key}=<rev/min>: its lines stand where they belong at "
                                               rf"{recording.rpm:g} rpm \(10 times lower\)\)"):
        build_dataset(files_cfg(root, *overrides))


def test_a_fault_records_defect_comb_does_not_get_its_right_rate_refused(tmp_path, caplog):
    """An outer-race record at its true 12 kHz whose strongest series is its BPFO comb (107 Hz at 1797 rpm on
    the SKF 6205), with no shaft line: the shaft-series search alone takes the comb for the shaft's series and
    implies 3.4 kHz. Without data.bearing that is only logged for a fault record; with it, the comb is the
    bearing's BPFO and the rate stands."""
    from bearingtwin.config import load_bearing

    root = tmp_path / "mine"
    root.mkdir()
    fs = 12000.0
    bpfo = load_bearing("cwru_6205").defect_frequencies(1797.0)["bpfo"]
    comb = np.zeros(int(4 * fs))
    comb[(np.arange(0, 4, 1 / bpfo) * fs).astype(int)] = 1.0
    np.save(root / "outer.npy", comb + 0.01 * np.random.default_rng(0).standard_normal(comb.size))
    np.save(root / "normal.npy", 0.01 * np.random.default_rng(1).standard_normal(comb.size))
    (root / "labels.csv").write_text("record,state,rpm,fs\nouter.npy,outer,1797,12000\nnormal.npy,normal,1797,12000\n")
    with caplog.at_level("WARNING"):
        assert build_dataset(files_cfg(root, "data.fs=null")).fs == fs
    assert "outer.npy: fs = 12000 Hz contradicts the shaft speed" in caplog.text  # logged, not refused
    caplog.clear()
    with caplog.at_level("WARNING"):
        assert build_dataset(files_cfg(root, "data.fs=null", "data.bearing=cwru_6205")).fs == fs
    assert "outer.npy: fs = 12000 Hz contradicts" not in caplog.text


def test_many_bad_rows_are_named_by_the_first_three_and_a_count():
    from bearingtwin.data.labels import first_messages

    assert first_messages(["a", "b"]) == "a; b"
    assert first_messages(["a", "b", "c", "d", "e"]) == "a; b; c; and 2 more"


def test_a_file_two_rows_name_is_refused_by_a_reader_of_its_row(tmp_path):
    """rec.npy and rec both name rec.npy: a command on that file does not take the first row silently."""
    from bearingtwin.data.labels import labels_row

    np.save(tmp_path / "rec.npy", np.zeros(8))
    (tmp_path / "labels.csv").write_text("record,state\nrec.npy,outer\nrec,inner\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 3: names rec.npy again \(.*labels.csv line 2 names it "
                                               r"too\); one row per record"):
        labels_row(tmp_path / "rec.npy")


def test_a_folder_of_files_that_name_their_bearing_is_read_with_it(tmp_path, caplog):
    """HUST exports name the ER-16K: without data.bearing, an outer-race export whose strongest series is its BPFO
    comb (no shaft line) has its true 25.6 kHz confirmed by that bearing's lines, not logged as contradicting the
    shaft, and the model is of the ER-16K, not of the twin's default bearing."""
    import sys

    from bearingtwin.config import load_bearing
    from bearingtwin.models.experiment import data_bearing

    sys.path.insert(0, str(REPO_ROOT / "tests" / "fixtures"))
    import make_hust_fixtures as hust

    root = tmp_path / "hust"
    root.mkdir()
    fs, seconds, rpm = hust.FS_HZ, 2.0, 65 * 60.0
    bpfo = load_bearing("er16k").defect_frequencies(rpm)["bpfo"]
    rng = np.random.default_rng(0)
    comb = np.zeros(int(seconds * fs))
    comb[(np.arange(0, seconds, 1 / bpfo) * fs).astype(int)] = 1.0
    for name, signal in (("0.5X_O_65Hz.xls", comb), ("H_65Hz.xls", np.zeros(comb.size))):
        axes = np.stack([signal + 0.01 * rng.standard_normal(comb.size) for _ in range(3)])
        hust.write(name, hust.header_lines(comb.size) + ["Data"] + hust.rows(axes), root)
    (root / "labels.csv").write_text("record,state\n0.5X_O_65Hz.xls,outer\nH_65Hz.xls,normal\n")
    cfg = files_cfg(root, "data.fs=null", "data.channel=X")
    with caplog.at_level("WARNING"):
        dataset = build_dataset(cfg)
    assert "contradicts" not in caplog.text
    assert dataset.fs == fs and dataset.bearing == "er16k"
    assert data_bearing(cfg, dataset.bearing)["name"] == "er16k"
    assert build_dataset(files_cfg(root, "data.fs=null", "data.channel=X", "data.bearing=er16k")).bearing is None


def test_a_labels_row_may_name_its_file_by_its_stem_as_a_diagnosis_reads_it(folder):
    """bearingtwin-diagnose reads a row 'a' as a.npy's; training had refused it as no file."""
    (folder / "labels.csv").write_text("record,state,rpm\na,normal,1797\nb.npy,normal,1797\nc,outer,1797\nd.csv,inner,1797\n")
    dataset = build_dataset(files_cfg(folder))
    assert sorted(Path(r).name for r in dataset.records) == ["a.npy", "b.npy", "c.npy", "d.csv"]
    (folder / "labels.csv").write_text("record,state,rpm\na,normal,1797\na.npy,normal,1797\nc.npy,outer,1797\n")
    with pytest.raises(BearingTwinError, match=r"labels.csv line 3: record 'a.npy' is labelled again \(.*line 2 names "
                                               r"a.npy too\)"):
        build_dataset(files_cfg(folder))
    np.save(folder / "e[1].npy", tone("normal", seed=2))  # a name glob would read as a pattern
    (folder / "labels.csv").write_text("record,state,rpm\ne[1],normal,1797\nc,outer,1797\nd.csv,inner,1797\n")
    assert sorted(Path(r).name for r in build_dataset(files_cfg(folder)).records) == ["c.npy", "d.csv", "e[1].npy"]
    np.savez(folder / "c.npz", signal=np.zeros(8))
    (folder / "labels.csv").write_text("record,state,rpm\nc,outer,1797\n")
    with pytest.raises(BearingTwinError, match=r"line 2: record 'c' names c.npy, c.npz; give the file name"):
        build_dataset(files_cfg(folder))
