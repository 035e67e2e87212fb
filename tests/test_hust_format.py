"""HUST exports as users hand them in: each channel's unit from the header's Units row (and what a training set in
g does with it), exports holding fewer channels than the four, and exports under names of the user's own. Every
file here is the synthetic fixture tests/fixtures/hust/0.5X_O_65Hz.xls, edited in a temporary folder."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.data.formats import read_raw
from bearingtwin.data.hust import load_hust
from bearingtwin.data.real import build_hust_dataset
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.sampling_rate import rate_witnesses

HUST = Path(__file__).parent / "fixtures" / "hust"
OUTER = HUST / "0.5X_O_65Hz.xls"
LEGEND, UNITS = "Legend\tSpeed\tX\tY\tZ", "Units\tV\tg\tg\tg"


def export(folder: Path, name: str = "0.5X_O_65Hz.xls", legend: str = LEGEND, units: str | None = UNITS,
           keep=(0, 1, 2, 3, 4)) -> Path:
    """The outer-race fixture with its Legend and Units rows replaced (``units=None``: no Units row) and only the
    data columns ``keep`` (0 time, 1 speed, 2 X, 3 Y, 4 Z), written as ``folder/name``."""
    lines = OUTER.read_text(encoding="latin-1").splitlines()
    at = lines.index("Data")
    header = [legend if line == LEGEND else units if line == UNITS else line for line in lines[:at + 1]]
    rows = ["\t".join(cells[column] for column in keep) for cells in (line.split("\t") for line in lines[at + 1:])]
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(("\n".join(line for line in header if line is not None) + "\n" + "\n".join(rows) + "\n")
                     .encode("utf-8"))
    return path


def data_config(*overrides):
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(overrides=["+data=hust", "+paths=default", *overrides]).data


# ---------------------------------------------------------------- units


def test_the_units_row_gives_each_channel_its_unit():
    raw = read_raw(OUTER)
    assert raw.channel_units == {"speed": "V", "X": "g", "Y": "g", "Z": "g"}
    for axis in "XYZ":
        assert load_hust(OUTER, channel=axis).unit == "g"


@pytest.mark.parametrize("legend,units,expected,note", [
    # The Units row follows the Legend's order, whatever order that is.
    ("Legend\tY\tZ\tSpeed\tX", "Units\tg\tg\tV\tm/s²", "m/s^2", None),
    # A Legend naming the time column too: its unit's cell is skipped with it.
    ("Legend\tTime\tSpeed\tX\tY\tZ", "Units\ts\tV\tmg\tg\tg", "mg", None),
    ("Legend\tSpeed\tX\tY\tZ", "Units\ts\tV\tmg\tg\tg", "mg", None),  # the time column's unit alone, first
    ("Legend\tTime\tSpeed\tX\tY\tZ", "Units\tV\tmg\tg\tg", "mg", None),  # a unit per channel, none for time
    ("Legend\tTime\tSpeed\tX\tY\tZ", "Units\ts\tV\tmg\tg\t", "mg", None),  # time's unit, Z's cell left empty
    ("Legend\tSpeed\tX\tY\tZ", "Units:\tV\tG\tg\tg\t", "g", None),
    ("Legend\tSpeed\tX\tY\tZ", "Units\tV\tV\tg\tg\tg", "", "the header's Units row gives 5 units (V, V, g, g, g) "
                                                           "for the 4 columns the header's Legend (Speed, X, Y, Z) names: "
                                                           "no unit read from it"),
    ("Legend\tSpeed\tX\tY\tZ", "Units\tV\tEU\tg\tg", "", "the header's Units row gives X the unit 'EU', none known here: "
                                                        "read as stating no unit"),
    ("Legend\tSpeed\tX\tY\tZ", None, "", None),  # no Units row: no unit, as before
])
def test_the_units_row_is_read_beside_the_legend(tmp_path, legend, units, expected, note):
    keep = (0, 3, 4, 1, 2) if legend.startswith("Legend\tY") else (0, 1, 2, 3, 4)  # the rows in the Legend's order
    path = export(tmp_path, legend=legend, units=units, keep=keep)
    recording = load_hust(path, channel="X")
    assert recording.unit == expected
    np.testing.assert_array_equal(recording.signal, load_hust(OUTER, channel="X").signal)
    assert (note in recording.meta["notes"]) if note else not any("Units row" in n for n in recording.meta["notes"])


def test_a_hust_training_set_states_g_and_keeps_the_files_numbers():
    """Every HUST record states g, so the windows stay in g, the files' own numbers (as CWRU's, also all in g): only
    records in different acceleration units are converted (to m/s^2). The model then states g."""
    dataset = build_hust_dataset(data_config(f"data.root={HUST}", "data.window_length=256", "data.samples_per_class=12"))
    assert dataset.unit == "g"
    for index, path in enumerate(dataset.records):
        signal = read_raw(path).channels["X"]
        rows = np.flatnonzero(dataset.record_ids == index)
        for row in rows:
            np.testing.assert_array_equal(dataset.windows[row], signal[dataset.starts[row]:dataset.starts[row] + 256])


def test_a_model_trained_in_g_checks_a_hust_records_unit(tmp_path):
    """A HUST record states g: against a model trained in g its unit is 'as stated' (before: 'not checked' for a
    model trained on HUST, 'assumed' for one trained on CWRU); a record in m/s^2 is converted for such a model."""
    from bearingtwin.diagnosis.pipeline import DiagnosisPipeline
    from bearingtwin.diagnosis.record import read_record
    from bearingtwin.features.extractor import RawFeatures
    from bearingtwin.models.svm import SvmClassifier

    windows = np.random.default_rng(0).standard_normal((8, 256))
    in_g = DiagnosisPipeline(RawFeatures().fit(windows), SvmClassifier().fit(windows, np.arange(8) % 4), 256, 25600.0,
                             unit="g")
    prepared = read_record(OUTER, in_g, channel="X")
    assert prepared.unit_check == "as stated" and prepared.recording.unit == "g"
    in_si = export(tmp_path, units="Units\tV\tm/s^2\tm/s^2\tm/s^2")
    converted = read_record(in_si, in_g, channel="X")
    assert converted.unit_check == "converted"
    np.testing.assert_allclose(converted.recording.signal, prepared.recording.signal / 9.80665)


# ---------------------------------------------------------------- fewer channels


@pytest.mark.parametrize("legend,keep,present,absent", [
    ("Legend\tSpeed\tY\tZ", (0, 1, 3, 4), ("Y", "Z"), "X"),
    ("Legend\tSpeed\tX\tY", (0, 1, 2, 3), ("X", "Y"), "Z"),
])
def test_an_export_of_fewer_channels_is_read_by_the_names_its_legend_gives(tmp_path, legend, keep, present, absent):
    path = export(tmp_path, legend=legend, units="Units\tV\tg\tg", keep=keep)
    raw = read_raw(path)
    assert list(raw.channels) == ["speed", *present]
    assert raw.channel_units == {"speed": "V", **{axis: "g" for axis in present}}
    for axis in present:
        recording = load_hust(path, channel=axis)
        np.testing.assert_array_equal(recording.signal, load_hust(OUTER, channel=axis).signal)
        assert recording.unit == "g" and recording.rpm == 3900 and recording.fault == "outer"
    with pytest.raises(BearingTwinError) as refused:
        load_hust(path, channel=absent, channel_key="data.channel")
    cells = legend.split("\t")[1:]
    assert str(refused.value) == (f"{path}: data.channel={absent}, but the header's Legend ({', '.join(cells)}) names "
                                  f"no {absent} column; choose one of {', '.join(present)}")


def test_a_hust_data_set_asking_for_a_channel_its_exports_lack_names_the_file_and_the_legend(tmp_path):
    for stem in ("H", "0.5X_I", "0.5X_B", "0.5X_O"):
        export(tmp_path, name=f"{stem}_65Hz.xls", legend="Legend\tSpeed\tY\tZ", units="Units\tV\tg\tg", keep=(0, 1, 3, 4))
    with pytest.raises(BearingTwinError, match=r"H_65Hz.xls: data.channel=X, but the header's Legend \(Speed, Y, Z\) "
                                               r"names no X column; choose one of Y, Z$"):
        build_hust_dataset(data_config(f"data.root={tmp_path}", "data.window_length=256"))
    dataset = build_hust_dataset(data_config(f"data.root={tmp_path}", "data.window_length=256", "data.channel=Z",
                                             "data.samples_per_class=8"))
    assert dataset.windows.shape == (32, 256) and dataset.unit == "g"


def test_rows_that_do_not_match_a_shorter_legend_are_refused_naming_it(tmp_path):
    five = export(tmp_path / "five", legend="Legend\tSpeed\tY\tZ", units="Units\tV\tg\tg")
    with pytest.raises(BearingTwinError, match=r"0.5X_O_65Hz.xls: data rows have 5 columns, expected 4 \(time, speed, "
                                               r"Y, Z\) as the header's Legend \(Speed, Y, Z\) names them$"):
        read_raw(five)
    # A Legend of all four above rows of four is refused as before.
    with pytest.raises(BearingTwinError, match=r"data rows have 4 columns, expected 5 \(time, speed, X, Y, Z\)$"):
        read_raw(export(tmp_path / "four", keep=(0, 1, 3, 4)))
    short = export(tmp_path / "short", legend="Legend\tSpeed\tY\tZ", units="Units\tV\tg\tg", keep=(0, 1, 3, 4))
    lines = short.read_text().splitlines()
    lines[40] = "\t".join(lines[40].split("\t")[:3])
    short.write_text("\n".join(lines) + "\n")
    with pytest.raises(BearingTwinError, match=r"line 41 has 3 columns, expected 4 \(time, speed, Y, Z\)$"):
        read_raw(short)


# ---------------------------------------------------------------- names of one's own


@pytest.mark.parametrize("name", ["0.5X_OR_65Hz.xls", "outer_65Hz.xls"])
def test_an_export_under_a_name_of_ones_own_is_read_and_says_its_name_gives_no_speed_or_state(tmp_path, name):
    path = export(tmp_path, name=name)
    recording = load_hust(path)
    assert recording.rpm is None and recording.fault is None and recording.unit == "g"
    assert recording.meta["notes"] == [
        f"the name {name!r} is not a HUST file name (<state>_<speed>Hz.xls: <state> H, I, O, B or C, after 0.5X_ for "
        "medium damage; <speed> the shaft's in Hz, or VS_0_40_0 for the variable-speed run; e.g. 0.5X_O_65Hz.xls): "
        "its shaft speed and bearing state are not read from it"]
    assert load_hust(OUTER).meta["notes"] == []  # a HUST name says nothing of the kind


def test_inspect_and_diagnose_say_why_an_export_under_another_name_has_no_speed(tmp_path, capsys, monkeypatch):
    from bearingtwin.cli.inspect import main
    from bearingtwin.diagnosis.pipeline import DiagnosisPipeline
    from bearingtwin.diagnosis.record import read_record
    from bearingtwin.features.extractor import RawFeatures
    from bearingtwin.models.svm import SvmClassifier

    path = export(tmp_path, name="outer_65Hz.xls")
    monkeypatch.setattr(sys, "argv", ["bearingtwin-inspect", f"path={path}"])
    with pytest.raises(SystemExit) as stop:
        main()
        raise SystemExit(0)
    summary = json.loads(capsys.readouterr().out)
    assert stop.value.code == 0 and summary["rpm"] is None
    assert summary["unit"] == {"speed": "V", "X": "g", "Y": "g", "Z": "g"}
    assert any(note.startswith("the name 'outer_65Hz.xls' is not a HUST file name (<state>_<speed>Hz.xls")
               for note in summary["meta"]["notes"]), summary["meta"]

    windows = np.random.default_rng(0).standard_normal((8, 256))
    pipeline = DiagnosisPipeline(RawFeatures().fit(windows), SvmClassifier().fit(windows, np.arange(8) % 4), 256,
                                 25600.0, unit="g")
    prepared = read_record(path, pipeline, channel="X")
    assert prepared.recording.rpm is None and prepared.true_state is None
    assert prepared.notes[-1] == ("the file states no shaft speed (its name is not a HUST file name, which would give "
                                  "it): no physics evidence and no rate check (give rpm=<rev/min>, or the file's speed "
                                  "in the rpm column of a labels.csv beside it)")
    given = read_record(path, pipeline, channel="X", rpm=3900)  # the speed given: read at it, the name note stays
    assert given.recording.rpm == 3900 and not any("states no shaft speed" in note for note in given.notes)


def test_the_speed_column_of_a_hust_export_witnesses_no_rate():
    """The export's speed column (every sample 0) is listed, but the rate check's witnesses are its vibration
    channels alone: a flat column has no shaft line to confirm or contradict a rate with."""
    raw = read_raw(OUTER)
    assert list(raw.channels) == ["speed", "X", "Y", "Z"] and not np.any(raw.channels["speed"])
    assert list(raw.vibration_channels) == ["X", "Y", "Z"]
    assert list(rate_witnesses(raw.channels["X"], raw.vibration_channels)) == ["X", "Y", "Z"]


def test_the_twin_holds_a_hust_export_against_its_vibration_channels_alone():
    """The channels the twin's rate check reads as witnesses (:func:`read_measurement`'s second value)."""
    from bearingtwin.twin.report import read_measurement

    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("twin", overrides=[f"measured.path={OUTER}", "measured.channel=Y", "bearing=er16k"])
    recording, witnesses = read_measurement(cfg.measured)
    assert list(witnesses) == ["X", "Y", "Z"] and recording.rpm == 3900


# ---------------------------------------------------------------- exports as other software versions write them


@pytest.mark.parametrize("legend,keep,note", [
    ("Legend\tDrehzahl\tZ\tY\tX", (0, 1, 4, 3, 2), "'Drehzahl', no name known here, as the speed column"),
    ("Legend\tTacho\tZ\tY\tX", (0, 1, 4, 3, 2), None),
    ("Legend\tSpeed\tY\tX\tZ axis", (0, 1, 3, 2, 4), None),
    ("Legend\tRPM\tAcc X\tAcc Y\tAcc Z", (0, 1, 2, 3, 4), None),
])
def test_an_export_whose_legend_names_its_axes_in_other_words_or_order_is_read_by_their_names(tmp_path, legend, keep,
                                                                                               note):
    """A Legend that names the axes in another order beside a cell no name known here reads had been read by
    position, whole: the Z axis was taken for X, without a word in a training run."""
    path = export(tmp_path, legend=legend, units=None, keep=keep)
    raw = read_raw(path)
    for axis in ("X", "Y", "Z"):
        np.testing.assert_array_equal(raw.channels[axis], read_raw(OUTER).channels[axis])
    column_notes = [said for said in raw.meta["notes"] if "speed column" in said or "by position" in said]
    assert len(column_notes) == (note is not None) and all(note in said for said in column_notes), column_notes


def test_a_legend_naming_an_axis_where_its_position_reads_another_beside_unknown_cells_is_refused(tmp_path):
    odd = export(tmp_path, legend="Legend\tCh0\tZ\tCh2\tX", units=None, keep=(0, 1, 4, 3, 2))
    with pytest.raises(BearingTwinError) as refused:
        read_raw(odd)
    message = str(refused.value)
    assert message.startswith(f"{odd}: the header's Legend reads 'Ch0 Z Ch2 X': it names Z where the reported layout")
    assert "'Ch0', 'Ch2'" in message and "\n" not in message
    twice = export(tmp_path / "twice", legend="Legend\tSpeed\tX\tX\tZ", units=None)
    with pytest.raises(BearingTwinError, match=r"Legend reads 'Speed X X Z': it names X twice, so its columns cannot"):
        read_raw(twice)
    # A time cell named otherwise than Time or t, before the four columns named in full, is the time column's.
    for time_cell in ("Time_s", "Timestamp", "Zeit"):
        timed = export(tmp_path / time_cell, legend=f"Legend\t{time_cell}\tSpeed\tX\tY\tZ", units=None)
        np.testing.assert_array_equal(read_raw(timed).channels["Z"], read_raw(OUTER).channels["Z"])
    # A bad header Legend does not refuse a file whose row of names below Data names its columns.
    named_below = _edited(tmp_path, "0.5X_O_65Hz.xls", lambda lines: [
        *("Legend\tCh0\tZ\tCh2\tX" if line == LEGEND else line for line in lines[:lines.index("Data") + 1]),
        "Time\tSpeed\tX\tY\tZ", *lines[lines.index("Data") + 1:]])
    np.testing.assert_array_equal(read_raw(named_below).channels["X"], read_raw(OUTER).channels["X"])


@pytest.mark.parametrize("name,state,rpm", [("h_65hz.xls", "normal", 3900), ("0.5x_i_65Hz.xls", "inner", 3900),
                                            ("H_65HZ.XLS", "normal", 3900), ("0.5X_b_65Hz.xls", "ball", 3900),
                                            ("0.5x_o_vs_0_40_0hz.xls", "outer", None)])
def test_a_hust_file_name_in_other_letter_case_states_its_state_and_speed(tmp_path, name, state, rpm):
    from bearingtwin.data.hust import parse_hust_name

    named = parse_hust_name(tmp_path / name)
    assert (named.fault, named.rpm) == (state, rpm)
    assert named.condition in ("65Hz", "VS_0_40_0Hz")


def test_a_hust_data_set_finds_its_files_under_names_in_another_letter_case(tmp_path):
    for stem in ("h", "0.5x_i", "0.5X_b", "0.5x_O"):
        (tmp_path / f"{stem}_65hz.xls").write_bytes(OUTER.read_bytes())
    from bearingtwin.data.real import hust_paths

    paths = hust_paths(data_config(f"data.root={tmp_path}", "data.condition=65"))
    assert sorted(path.name for path in paths.values()) == ["0.5X_b_65hz.xls", "0.5x_O_65hz.xls", "0.5x_i_65hz.xls",
                                                            "h_65hz.xls"]


@pytest.mark.parametrize("names", [("H_65Hz.xls", "h_65hz.xls"), ("H_65HZ.xls", "h_65hz.xls")])
def test_two_files_that_are_one_hust_name_in_other_letter_cases_are_refused_naming_both(tmp_path, names):
    """The exact name had been taken silently beside another copy, and two in other cases reported missing."""
    for stem in ("0.5X_I", "0.5X_B", "0.5X_O"):
        (tmp_path / f"{stem}_65Hz.xls").write_bytes(OUTER.read_bytes())
    (tmp_path / names[0]).write_bytes(OUTER.read_bytes())
    (tmp_path / names[1]).write_bytes((HUST / "H_65Hz.xls").read_bytes())  # another record
    from bearingtwin.data.real import hust_paths

    with pytest.raises(BearingTwinError, match=rf"^{tmp_path}: 2 files are H_65Hz.xls in one letter case or another "
                                               rf"\({names[0]}, {names[1]}\); keep one of them in the folder$"):
        hust_paths(data_config(f"data.root={tmp_path}", "data.condition=65"))


def test_a_hust_data_set_missing_its_files_names_the_conditions_the_folder_holds(tmp_path):
    for stem in ("H", "0.5X_I", "0.5X_B", "0.5X_O"):
        (tmp_path / f"{stem}_65Hz.xls").write_bytes(OUTER.read_bytes())
    with pytest.raises(BearingTwinError, match=rf"HUST files missing in {tmp_path}: H_56Hz.xls, .*0.5X_O_56Hz.xls; "
                                               rf"{tmp_path} holds HUST files for data.condition=65\. This data set"):
        build_hust_dataset(data_config(f"data.root={tmp_path}", "data.condition=56"))


def _edited(tmp_path: Path, name: str, edit) -> Path:
    lines = OUTER.read_text(encoding="latin-1").splitlines()
    path = tmp_path / name
    path.write_text("\n".join(edit(lines)) + "\n", encoding="latin-1")
    return path


def test_exports_of_other_software_versions_are_read_with_what_they_state(tmp_path):
    """An upper-case DATA line, a rate written with its unit, a blank speed column (never read), a time column
    printed coarser than a sample period, or counting milliseconds: each had refused the file."""
    reference = read_raw(OUTER)
    at = OUTER.read_text(encoding="latin-1").splitlines().index("Data")

    def rows_with(column, text):
        return lambda lines: lines[:at + 1] + ["\t".join(text(c) if i == column else c for i, c in
                                                         enumerate(line.split("\t"))) for line in lines[at + 1:]]

    cases = {
        "upper_data": lambda lines: [("DATA" if line == "Data" else line) for line in lines],
        "hz": lambda lines: [(line + " Hz" if line.startswith("Sampling Rate") else line) for line in lines],
        "khz": lambda lines: [("Sampling Rate\t25.6 kHz" if line.startswith("Sampling Rate") else line)
                              for line in lines],
        "blank_speed": rows_with(1, lambda cell: ""),
        "coarse_time": rows_with(0, lambda cell: f"{float(cell):.4f}"),
        "ms_time": rows_with(0, lambda cell: f"{1000 * float(cell):.6f}"),
    }
    for folder, edit in cases.items():
        (tmp_path / folder).mkdir()
        path = _edited(tmp_path / folder, "0.5X_O_65Hz.xls", edit)
        raw = read_raw(path)
        assert raw.fs == 25600.0, folder
        np.testing.assert_array_equal(raw.channels["X"], reference.channels["X"])
        assert load_hust(path).rpm == 3900
        said = " ".join(raw.meta["notes"])
        assert ("coarser than a sample period" in said) == (folder == "coarse_time"), (folder, said)
        assert ("counts milliseconds" in said) == (folder == "ms_time"), (folder, said)
    wrong = _edited(tmp_path, "0.5X_I_65Hz.xls",
                    lambda lines: [("Sampling Rate\t51.2 kHz" if line.startswith("Sampling Rate") else line)
                                   for line in lines])
    with pytest.raises(BearingTwinError, match="Sampling Rate 51.2 kHz contradicts the time column's 25600"):
        read_raw(wrong)
