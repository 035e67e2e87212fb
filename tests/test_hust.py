"""HUST text exports: the reader returns the written columns, the physics of the file name, and
names the file and the problem for every damaged layout (fixtures: tests/fixtures/make_hust_fixtures.py)."""

import sys
from pathlib import Path

import numpy as np
import pytest

from bearingtwin.data.formats import read_raw
from bearingtwin.data.hust import load_hust, parse_hust_name
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.envelope import envelope

FIXTURES = Path(__file__).parent / "fixtures"
HUST = FIXTURES / "hust"
sys.path.insert(0, str(FIXTURES))
import make_hust_fixtures as fixtures  # noqa: E402


def impact_rate_hz(signal: np.ndarray, fs: float) -> float:
    """Repetition rate of the impacts: the strongest envelope autocorrelation lag below 1 kHz."""
    env = envelope(signal)
    env = env - env.mean()
    corr = np.correlate(env, env, mode="full")[env.size - 1 :]
    shortest = int(fs / 1000.0)
    lag = shortest + int(np.argmax(corr[shortest : env.size // 3]))
    return fs / lag


@pytest.mark.parametrize("index,stem", list(enumerate(fixtures.CLASSES)))
def test_loader_returns_the_written_axes(index, stem):
    fault = fixtures.CLASSES[stem]
    written = fixtures.synthetic_axes(fault, fixtures.SEED + index)
    for axis, expected in zip("XYZ", written):
        recording = load_hust(HUST / f"{stem}_65Hz.xls", channel=axis, fs=25600)
        np.testing.assert_allclose(recording.signal, expected, atol=5.1e-4)  # printed with 3 decimals
        assert recording.channel == axis
        assert recording.fault == fault
        assert recording.rpm == 65 * 60
        assert recording.fs == 25600


def test_fs_is_the_headers_sampling_rate_checked_against_the_time_column(tmp_path):
    raw = read_raw(HUST / "H_65Hz.xls")
    assert raw.fs == fixtures.FS_HZ == 25600 and raw.fs_origin == "header"  # exact, not 25599.9997
    assert load_hust(HUST / "H_65Hz.xls").fs == 25600
    text = (HUST / "H_65Hz.xls").read_text(encoding="latin-1")
    (tmp_path / "H_65Hz.xls").write_text(text.replace("Sampling Rate\t25600", "Sampling Rate\t51200"), encoding="latin-1")
    with pytest.raises(BearingTwinError, match=r"H_65Hz.xls: the header's Sampling Rate 51200 Hz contradicts the time column's 25600"):
        read_raw(tmp_path / "H_65Hz.xls")
    (tmp_path / "H_65Hz.xls").write_text(text.replace("Sampling Rate\t25600", "Sampling Rate\t25600,0"), encoding="latin-1")
    with pytest.raises(BearingTwinError, match=r"Sampling Rate '25600,0' \(read as 256000 Hz, a comma taken for a thousands"):
        read_raw(tmp_path / "H_65Hz.xls")
    (tmp_path / "H_65Hz.xls").write_text(text.replace("Sampling Rate\t25600\n", ""), encoding="latin-1")
    without = read_raw(tmp_path / "H_65Hz.xls")
    assert without.fs_origin == "time column" and without.fs == pytest.approx(25600, rel=1e-4)


def test_columns_are_read_by_the_name_the_legend_gives(tmp_path):
    """An export whose Legend lists the channels in another order is read by name; one whose Legend names
    other channels is read by position, with a note saying so."""
    text = (HUST / "0.5X_O_65Hz.xls").read_text(encoding="latin-1")
    lines = text.splitlines()
    start = lines.index("Data") + 1
    moved = ["\t".join([cells[0], cells[3], cells[4], cells[1], cells[2]])  # time, Y, Z, speed, X
             for cells in (line.split("\t") for line in lines[start:])]
    header = [line.replace("Legend\tSpeed\tX\tY\tZ", "Legend\tY\tZ\tSpeed\tX") for line in lines[:start]]
    (tmp_path / "0.5X_O_65Hz.xls").write_text("\n".join(header + moved) + "\n", encoding="latin-1")
    original, reordered = read_raw(HUST / "0.5X_O_65Hz.xls"), read_raw(tmp_path / "0.5X_O_65Hz.xls")
    for channel in ("speed", "X", "Y", "Z"):
        np.testing.assert_array_equal(reordered.channels[channel], original.channels[channel])
    (tmp_path / "0.5X_O_65Hz.xls").write_text(text.replace("Legend\tSpeed\tX\tY\tZ", "Legend\tA\tB\tC\tD"),
                                              encoding="latin-1")
    positional = read_raw(tmp_path / "0.5X_O_65Hz.xls")
    np.testing.assert_array_equal(positional.channels["X"], original.channels["X"])
    assert positional.meta["notes"] == ["the header's Legend reads 'A B C D', not Speed, X, Y and Z: the columns after "
                                        "time are read by position as speed, X, Y, Z"]


@pytest.mark.parametrize("stem,defect", [("0.5X_I", "bpfi"), ("0.5X_O", "bpfo")])
def test_impacts_repeat_at_the_er16k_defect_frequency(stem, defect):
    recording = load_hust(HUST / f"{stem}_65Hz.xls", channel="X")
    geometry = fixtures.er16k()
    expected = geometry.defect_frequencies(recording.rpm)[defect]
    assert impact_rate_hz(recording.signal, recording.fs) == pytest.approx(expected, rel=0.03)


@pytest.mark.parametrize(
    "name,state,severity,rpm,fault",
    [
        ("0.5X_I_65Hz.xls", "I", "medium", 3900.0, "inner"),
        ("B_20Hz.xls", "B", "severe", 1200.0, "ball"),
        ("H_VS_0_40_0Hz.xls", "H", "none", None, "normal"),
        ("0.5X_C_80Hz.xls", "C", "medium", 4800.0, None),
    ],
)
def test_file_names_give_state_and_speed(name, state, severity, rpm, fault):
    parsed = parse_hust_name(name)
    assert (parsed.state, parsed.severity, parsed.rpm, parsed.fault) == (state, severity, rpm, fault)


def test_other_names_are_not_hust_names():
    assert parse_hust_name("X_65Hz.xls") is None
    assert parse_hust_name("H_65.xls") is None


@pytest.mark.parametrize(
    "name,problem",
    [
        ("no_data_line.xls", "no line reading 'Data'"),
        ("wrong_columns.xls", "4 columns, expected 5"),
        ("non_numeric.xls", "line 73 column Y: 'abc' is not a number"),
        ("truncated.xls", "line 222 has 3 columns"),
        ("empty.xls", "the file is empty"),
        ("row_count.xls", "declares 300 data rows"),
    ],
)
def test_damaged_files_name_file_and_problem(name, problem):
    with pytest.raises(BearingTwinError) as error:
        load_hust(HUST / "damaged" / name)
    assert name in str(error.value) and problem in str(error.value)


def test_a_copy_cut_short_after_a_tab_or_within_a_number_is_said_to_be_truncated(tmp_path):
    lines = (HUST / "H_65Hz.xls").read_text().splitlines()
    at = next(index for index in range(lines.index("Data") + 50, len(lines)) if "\t-" in lines[index][-7:])  # Z < 0
    kept, cut = "\n".join(lines[:at]) + "\n", lines[at][:lines[at].rindex("\t") + 1]
    for name, text, problem in [("after_tab.xls", kept + cut, "column Z is empty"),
                                ("in_number.xls", kept + cut + "-", "column Z: '-' is not a number")]:
        (tmp_path / name).write_text(text)
        with pytest.raises(BearingTwinError, match=rf"{name}: line {at + 1} {problem} \(truncated last row\?\)$"):
            read_raw(tmp_path / name)
    (tmp_path / "inside.xls").write_text(kept + cut + "\n" + "\n".join(lines[at + 1:]) + "\n")  # not the last line
    with pytest.raises(BearingTwinError, match=rf"inside.xls: line {at + 1} column Z is empty$"):
        read_raw(tmp_path / "inside.xls")


def test_nan_cell_is_counted_raw_and_refused_when_loaded():
    path = HUST / "damaged" / "nan_cell.xls"
    raw = read_raw(path)
    assert {name: int(np.isnan(values).sum()) for name, values in raw.channels.items()} == {
        "speed": 0, "X": 0, "Y": 0, "Z": 1
    }
    with pytest.raises(BearingTwinError, match=r"nan_cell.xls: 1 NaN or infinite values in channel Z"):
        load_hust(path, channel="Z")


def test_unknown_axis_and_contradicting_fs_are_refused():
    with pytest.raises(BearingTwinError, match="^channel='W'.*X, Y, Z"):
        load_hust(HUST / "H_65Hz.xls", channel="W")
    with pytest.raises(BearingTwinError, match="^data.channel='W'.*X, Y, Z"):
        load_hust(HUST / "H_65Hz.xls", channel="W", channel_key="data.channel")
    with pytest.raises(BearingTwinError, match=r"H_65Hz.xls: fs=48000 Hz contradicts the file's 25600 Hz"):
        load_hust(HUST / "H_65Hz.xls", fs=48000)
    with pytest.raises(BearingTwinError, match=r"H_65Hz.xls: data.fs=48000 Hz contradicts the file's 25600 Hz"):
        load_hust(HUST / "H_65Hz.xls", fs=48000, fs_key="data.fs")
    # The header's rate is checked against the time column within 1 %, and a rate given for it is too.
    assert load_hust(HUST / "H_65Hz.xls", fs=25700).fs == 25700


def test_a_byte_order_mark_and_a_data_line_with_a_colon_are_read(tmp_path):
    """A file an editor saved again as UTF-8 may start with a byte-order mark, before the header or before a
    'Data' line with no header above it; 'Data:' is written as the header's other keys are."""
    text = (HUST / "H_65Hz.xls").read_bytes()
    original = read_raw(HUST / "H_65Hz.xls")
    variants = {
        "bom_header": b"\xef\xbb\xbf" + text,
        "bom_data": b"\xef\xbb\xbf" + text[text.index(b"Data\n"):],
        "colon": text.replace(b"\nData\n", b"\nData:\n"),
    }
    for name, content in variants.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "H_65Hz.xls").write_bytes(content)
        raw = read_raw(tmp_path / name / "H_65Hz.xls")
        np.testing.assert_array_equal(raw.channels["X"], original.channels["X"])
        assert raw.fs == pytest.approx(25600, rel=1e-4)
    assert read_raw(tmp_path / "bom_header" / "H_65Hz.xls").meta["header"] == original.meta["header"]  # "Title", not "\xef\xbb\xbfTitle"


def test_lines_of_tabs_alone_are_skipped_as_blank_lines(tmp_path):
    """A spreadsheet saving an export again leaves lines of tabs alone after the data (pandas read each as a row of
    NaN: refused against Total Data Rows, or as a time column with no rate); one among the rows, or one of more tabs
    than a row has cells, is skipped too."""
    text = (HUST / "H_65Hz.xls").read_text()
    lines = text.splitlines()
    original = read_raw(HUST / "H_65Hz.xls")
    at = lines.index("Data") + 100
    variants = {
        "after": text + "\t\t\t\t\n\t\t\t\t\n",
        "after_crlf": text.replace("\n", "\r\n") + "\t\t\t\t\r\n",
        "no_total": "\n".join(line for line in lines if not line.startswith("Total Data Rows")) + "\n\t\t\t\t\n",
        "among_rows": "\n".join(lines[:at] + ["\t\t\t\t", ""] + lines[at:]) + "\n",
        "more_tabs": text + "\t\t\t\t\t\t\t\n",
    }
    for name, content in variants.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "H_65Hz.xls").write_bytes(content.encode())
        raw = read_raw(tmp_path / name / "H_65Hz.xls")
        np.testing.assert_array_equal(raw.channels["X"], original.channels["X"], err_msg=name)
        assert raw.fs == 25600, name


def test_a_time_stamp_that_is_not_finite_is_named_by_its_row(tmp_path):
    lines = [line for line in (HUST / "H_65Hz.xls").read_text().splitlines()
             if not line.startswith(("Sampling Rate", "Total Data Rows"))]  # the time column alone gives the rate
    at = lines.index("Data")
    lines[at + 7] = "nan" + lines[at + 7][lines[at + 7].index("\t"):]
    (tmp_path / "H_65Hz.xls").write_text("\n".join(lines) + "\n")
    with pytest.raises(BearingTwinError, match=r"H_65Hz.xls: the time column holds nan at data row 7: a sampling rate "
                                               r"needs every stamp finite$"):
        read_raw(tmp_path / "H_65Hz.xls")
    (tmp_path / "one.xls").write_text("\n".join(lines[:at + 2]) + "\n")
    with pytest.raises(BearingTwinError, match=r"one.xls: the time column holds 1 value: a sampling rate needs at "
                                               r"least two$"):
        read_raw(tmp_path / "one.xls")


def test_an_export_saved_again_with_decimal_commas_closing_tabs_or_a_row_of_names_reads_the_same(tmp_path):
    """A spreadsheet or a regional setting may write numbers with decimal commas, close every row with a tab, or
    name the columns in a row below 'Data' (in their own order, with units): each reads the same axes."""
    lines = (HUST / "0.5X_O_65Hz.xls").read_text().splitlines()
    at = lines.index("Data")
    header, rows = lines[:at + 1], lines[at + 1:]
    original = read_raw(HUST / "0.5X_O_65Hz.xls")

    def reorder(row: str) -> str:  # time, speed, Z, X, Y
        time, speed, x, y, z = row.split("\t")
        return "\t".join([time, speed, z, x, y])

    comma_header = [line.replace("Sampling Rate\t25600", "Sampling Rate\t25600,0") for line in header]
    variants = {
        "comma": comma_header + [row.replace(".", ",") for row in rows],
        "unnamed_time": header + ["\tSpeed\tX\tY\tZ"] + rows,
        "closing_tab": header + [row + "\t" for row in rows],
        "names": header + ["Time (s)\tSpeed\tZ (g)\tX (g)\tY (g)"] + [reorder(row) for row in rows],
        "all_three": header + ["Time (s)\tSpeed\tX\tY\tZ\t"] + [row.replace(".", ",") + "\t" for row in rows],
    }
    for name, text in variants.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "0.5X_O_65Hz.xls").write_text("\r\n".join(text) + "\r\n")
        raw = read_raw(tmp_path / name / "0.5X_O_65Hz.xls")
        for axis in ("X", "Y", "Z"):
            np.testing.assert_array_equal(raw.channels[axis], original.channels[axis], err_msg=f"{name}: {axis}")
        assert raw.fs == pytest.approx(25600, rel=1e-4) and raw.fault == "outer"
    assert "decimal commas" in " ".join(read_raw(tmp_path / "comma" / "0.5X_O_65Hz.xls").meta["notes"])
    # A first row of numbers with its time cell empty is a damaged row, not a row of names.
    (tmp_path / "blank.xls").write_text("\n".join(header + ["\t" + rows[0].split("\t", 1)[1]] + rows[1:]) + "\n")
    with pytest.raises(BearingTwinError, match=rf"blank.xls: line {at + 2} column time is empty"):
        read_raw(tmp_path / "blank.xls")
    bad = header + ["Time\tSpeed\tX\tY\tZ"] + rows[:10] + [rows[10].replace("\t", "\tx", 1)] + rows[11:]
    (tmp_path / "bad.xls").write_text("\n".join(bad) + "\n")
    with pytest.raises(BearingTwinError, match=rf"bad.xls: line {at + 13} column speed: 'x.*' is not a number"):
        read_raw(tmp_path / "bad.xls")


def test_binary_workbook_is_named(tmp_path):
    path = tmp_path / "H_65Hz.xls"
    path.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(512))
    with pytest.raises(BearingTwinError, match="H_65Hz.xls: is a binary Excel workbook") as error:
        load_hust(path)
    # Read for data.root, bearingtwin-diagnose's path= or bearingtwin-twin's measured.path=: no one setting named.
    assert str(error.value).endswith("save it as tab-separated text, or give the original exports instead")


def test_fixtures_are_what_the_script_writes(tmp_path, monkeypatch):
    monkeypatch.setattr(fixtures, "HERE", tmp_path)
    fixtures.main()
    for path in sorted(HUST.rglob("*.xls")):
        assert (tmp_path / path.relative_to(HUST)).read_bytes() == path.read_bytes(), path


@pytest.mark.parametrize("condition, written", [(65, "65"), (65.0, "65"), (62.5, "62.5"), ("VS_0_40_0", "VS_0_40_0")])
def test_a_condition_is_written_as_the_file_names_write_it(condition, written):
    from bearingtwin.data.hust import hust_file_name

    assert hust_file_name("0.5X_I", condition) == f"0.5X_I_{written}Hz.xls"


def test_a_label_calling_a_combined_damage_export_one_state_is_refused(tmp_path):
    """A C export (inner and outer races damaged together) labelled outer in a labels table would train as outer."""
    from bearingtwin.data.formats import load_recording

    text = (HUST / "0.5X_O_65Hz.xls").read_text()
    (tmp_path / "0.5X_C_65Hz.xls").write_text(text)
    with pytest.raises(BearingTwinError, match=r"0.5X_C_65Hz.xls: the labels row's state=outer given, but the file "
                                               r"states inner and outer races damaged together \(C in its name\)"):
        load_recording(tmp_path / "0.5X_C_65Hz.xls", channel="X", fault="outer", fault_key="the labels row's state")
    assert load_recording(tmp_path / "0.5X_C_65Hz.xls", channel="X").fault is None


def test_inspect_reads_the_axes_and_lists_the_speed_column_without_checking_it():
    """The exports' speed column holds zeros: inspect had checked the rate on it and called it a dead channel."""
    from bearingtwin.cli.inspect import summarize

    summary = summarize(FIXTURES / "hust" / "0.5X_O_65Hz.xls")
    assert summary["channels"] == ["speed", "X", "Y", "Z"] and summary["nan_count"]["speed"] == 0
    assert "speed" not in summary["quality"] and "speed" not in summary["shaft_speed"]
    check = summary["shaft_line_check"]
    assert check["channel"] == "X" and "speed" not in check.get("channels", {}), check
