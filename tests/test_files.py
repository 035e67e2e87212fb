"""Generic recordings: every format round-trips its samples and facts; bad files and
contradictions are refused with the file named."""

import os
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.io.wavfile

from bearingtwin.data.formats import load_recording, read_raw, resolve_fs, unit_in_name
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError

FS = 8000.0


@pytest.fixture
def signal():
    t = np.arange(4096) / FS
    return np.sin(2 * np.pi * 157.0 * t) + 0.1 * np.random.default_rng(1).standard_normal(t.size)


def test_npz_as_the_simulator_writes_it(tmp_path, signal):
    path = tmp_path / "sim.npz"
    np.savez(path, signal=signal, accelerations=np.stack([signal, 2 * signal]), fs=FS, rpm=1797.0, fault="outer")
    recording = load_recording(path, channel="signal")
    np.testing.assert_array_equal(recording.signal, signal)
    assert (recording.fs, recording.rpm, recording.fault) == (FS, 1797.0, "outer")
    np.testing.assert_array_equal(load_recording(path, channel="accelerations[1]").signal, 2 * signal)
    with pytest.raises(BearingTwinError, match=r"sim.npz: fs=9000 Hz contradicts the file's 8000 Hz"):
        load_recording(path, channel="signal", fs=9000)
    with pytest.raises(BearingTwinError, match=r"sim.npz: rpm=1000.0 contradicts the file's rpm=1797.0"):
        load_recording(path, channel="signal", rpm=1000.0)
    # A speed within 1 % of the file's measured one is the same speed: the file's is read, and said so.
    close = load_recording(path, channel="signal", rpm=1790.0)
    assert close.rpm == 1797.0 and "rpm=1790 given; the file's measured 1797 rpm read" in close.meta["notes"]
    with pytest.raises(BearingTwinError, match=r"rpm=1770.0 contradicts the file's rpm=1797.0 \(more than 1% apart\)"):
        load_recording(path, channel="signal", rpm=1770.0)
    np.testing.assert_array_equal(load_recording(path).signal, signal)  # `signal` is the .npz default channel
    two = tmp_path / "two.npz"
    np.savez(two, left=signal, right=2 * signal, fs=FS)
    with pytest.raises(BearingTwinError, match=r"two.npz: holds channels left, right; choose one"):
        load_recording(two)


def test_npy_needs_fs_from_config(tmp_path, signal):
    path = tmp_path / "x.npy"
    np.save(path, signal)
    with pytest.raises(BearingTwinError, match="x.npy: the file does not state its sampling rate"):
        load_recording(path)
    recording = load_recording(path, fs=FS, rpm=600.0, fault="normal")
    assert recording.duration == pytest.approx(signal.size / FS)
    np.testing.assert_array_equal(recording.signal, signal)


def test_csv_header_time_column_and_channel_by_name_or_index(tmp_path, signal):
    path = tmp_path / "rec.csv"
    t = np.arange(signal.size) / FS
    np.savetxt(path, np.column_stack([t, signal, -signal]), delimiter=",", header="time,acc_x,acc_y", comments="", fmt="%.9f")
    raw = read_raw(path)
    assert list(raw.channels) == ["acc_x", "acc_y"] and raw.fs == pytest.approx(FS, rel=1e-6)
    np.testing.assert_allclose(load_recording(path, channel="acc_y").signal, -signal, atol=1e-9)
    np.testing.assert_allclose(load_recording(path, channel=0).signal, signal, atol=1e-9)
    headerless = tmp_path / "plain.csv"
    np.savetxt(headerless, np.column_stack([signal, -signal]), delimiter=",")
    assert list(read_raw(headerless).channels) == ["0", "1"]


def test_text_tables_saved_as_txt_or_tsv_read_as_a_csv_does(tmp_path, signal):
    """A data logger's export under .txt (tab-separated, a header with the time) or .tsv, and a headerless
    whitespace table of four accelerometers (as some run-to-failure rigs write them) under .txt."""
    t = np.arange(signal.size) / FS
    logged = tmp_path / "run.txt"
    np.savetxt(logged, np.column_stack([t, signal]), delimiter="\t", header="Time (s)\tacc (g)", comments="",
               fmt="%.9f")
    recording = load_recording(logged)
    assert recording.fs == pytest.approx(FS, rel=1e-6) and recording.unit == "g"
    np.testing.assert_allclose(recording.signal, signal, atol=1e-9)
    tabbed = tmp_path / "run.tsv"
    np.savetxt(tabbed, np.column_stack([signal, -signal]), delimiter="\t", header="x\ty", comments="")
    np.testing.assert_allclose(load_recording(tabbed, channel="y", fs=FS).signal, -signal, atol=1e-9)
    bearings = tmp_path / "2003.10.22.12.06.24.txt"
    np.savetxt(bearings, np.column_stack([signal, 2 * signal, 3 * signal, 4 * signal]), fmt="%.6f")
    assert list(read_raw(bearings).channels) == ["0", "1", "2", "3"]
    np.testing.assert_allclose(load_recording(bearings, channel=2, fs=FS).signal, 3 * signal, atol=1e-5)
    (tmp_path / "notes.txt").write_text("Rig B, sensor on the housing.\n")
    with pytest.raises(BearingTwinError, match=r"notes.txt: the file holds a header but no data rows"):
        load_recording(tmp_path / "notes.txt", fs=FS)
    (tmp_path / "export.tsv").write_bytes("a\tb\n1\t2\n".encode("utf-16"))
    with pytest.raises(BearingTwinError, match=r"export.tsv: not a text file, so no table of numbers \(.csv, .txt, .tsv\)"):
        load_recording(tmp_path / "export.tsv", fs=FS)


def test_csv_non_numeric_cell_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("a,b\n1,2\n3,abc\n")
    with pytest.raises(BearingTwinError, match="bad.csv: line 3, column 2: 'abc' is not a number"):
        read_raw(path)


def test_generic_mat_and_wav(tmp_path, signal):
    mat = tmp_path / "rec.mat"
    scipy.io.savemat(mat, {"vib": signal[:, None], "fs": FS, "rpm": 900.0})
    recording = load_recording(mat)
    assert (recording.fs, recording.rpm, recording.channel) == (FS, 900.0, "vib")
    np.testing.assert_array_equal(recording.signal, signal)
    wav = tmp_path / "rec.wav"
    pcm = np.round(signal * 10000).astype(np.int16)
    scipy.io.wavfile.write(wav, int(FS), np.stack([pcm, -pcm], axis=1))
    raw = read_raw(wav)
    assert raw.fs == FS and raw.fs_origin == "header" and list(raw.channels) == ["0", "1"]
    # PCM counts at the recorder's full scale, and said so: a unit the file states none of (which a diagnosis then
    # reads as if in the model's, as any record stating none), not one the reader knows to be unknown
    np.testing.assert_array_equal(load_recording(wav, channel="1").signal, -pcm / 32768.0)
    assert raw.meta["notes"] == ["integer samples (int16, as scipy reads them) scaled to the recorder's full scale (1.0), "
                                 "which states no physical unit: a scale and a unit given read it in one (scale=50 "
                                 "unit=g where full scale is 50 g)"] and raw.unit == ""
    # Read with a scale and a unit, the advice is taken and not given again beside what was done
    assert load_recording(wav, channel="0", scale=5, unit="g").meta["notes"] == [
        "integer samples (int16, as scipy reads them) scaled to the recorder's full scale (1.0)",
        "samples x 5 read in g (scale=5 unit=g)"]
    unsigned = tmp_path / "u8.wav"
    scipy.io.wavfile.write(unsigned, int(FS), np.array([128, 255, 0, 192], dtype=np.uint8))
    np.testing.assert_array_equal(read_raw(unsigned).channels["0"], [0.0, 127 / 128, -1.0, 0.5])
    with pytest.raises(BearingTwinError, match="rec.wav: fs=12000 Hz contradicts the file's 8000 Hz"):
        load_recording(wav, channel="0", fs=12000)


def test_a_rate_the_file_states_exactly_must_be_given_exactly_one_measured_from_stamps_within_1_percent(tmp_path, signal):
    """An .npz / .mat fs and a .wav header are exact: 1 % off is another rate (a model at the wrong one), float
    rounding is not; a time column's rate, measured from rounded stamps, allows 1 %."""
    npz, mat, wav, csv = (tmp_path / f"rec.{ext}" for ext in ("npz", "mat", "wav", "csv"))
    np.savez(npz, signal=signal, fs=FS)
    scipy.io.savemat(mat, {"vib": signal[:, None], "fs": FS})
    scipy.io.wavfile.write(wav, int(FS), np.round(signal * 10000).astype(np.int16))
    for path in (npz, mat, wav):
        with pytest.raises(BearingTwinError, match=rf"rec.{path.suffix[1:]}: fs=8050 Hz contradicts the file's 8000 Hz"):
            load_recording(path, fs=8050)
        assert load_recording(path, fs=FS * (1 + 1e-12)).fs == FS * (1 + 1e-12)
    np.savetxt(csv, np.column_stack([np.arange(signal.size) / FS, signal]), delimiter=",", header="time,acc",
               comments="", fmt="%.9f")
    assert load_recording(csv, fs=8050).fs == 8050
    with pytest.raises(BearingTwinError, match=r"rec.csv: fs=8100 Hz contradicts the file's 8000 Hz \(from its time column\)"):
        load_recording(csv, fs=8100)


def test_a_rate_given_a_thousand_times_from_the_time_stamps_reads_them_as_in_another_unit(tmp_path, signal):
    """Seconds under a header of milliseconds give a rate a thousand times too high; the rate given, a thousand times
    lower, is read and said to be, where another factor is still a contradiction; a short record's refusal names the
    rate its stamps gave."""
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack([np.arange(signal.size) / FS, signal]), delimiter=",", header="time [ms],acc",
               comments="", fmt="%.9f")
    assert read_raw(csv).fs == pytest.approx(FS * 1000)
    recording = load_recording(csv, fs=FS)
    assert recording.fs == FS and recording.meta["fs_origin"] == "config"
    assert ("fs=8000 Hz given, 0.001 times the 8e+06 Hz the file's time stamps give: read as stamps in another unit "
            "than their column's name states") in recording.meta["notes"]
    for other in (FS * 100, FS * 1000 * 1.05):
        with pytest.raises(BearingTwinError, match=r"contradicts the file's 8e\+06 Hz \(from its time column\)"):
            load_recording(csv, fs=other)


def test_bad_inputs_are_named(tmp_path, signal):
    unknown = tmp_path / "rec.parquet"
    unknown.write_text("x")
    with pytest.raises(BearingTwinError, match=r"rec.parquet: unknown file type .parquet; supported: .npy"):
        read_raw(unknown)
    with pytest.raises(BearingTwinError, match="nothing.npy: no such file"):
        read_raw(tmp_path / "nothing.npy")
    bad = signal.copy()
    bad[[10, 20]] = [np.nan, np.inf]
    path = tmp_path / "holes.npy"
    np.save(path, bad)
    assert np.isnan(read_raw(path).channels["0"]).sum() == 1
    with pytest.raises(BearingTwinError, match=r"holes.npy: 2 NaN or infinite values in channel 0, the first at sample 10, the last at 20 "
                                               r"\(0.00125 s to 0.0025 s\); no value is made up for them"):
        load_recording(path, fs=FS)
    np.save(path, np.full(100, np.nan))  # nothing between the gaps to give on its own
    with pytest.raises(BearingTwinError, match=r"holes.npy: channel 0 holds no value: every one of its 100 samples is "
                                               r"NaN or infinite$"):
        load_recording(path, fs=FS)
    with pytest.raises(BearingTwinError, match=r"holes.npy: no channel 'Q'; the file holds channel 0 \(choose with channel=<name>, or channel=null for its only one\)"):
        load_recording(path, channel="Q", fs=FS)
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"not a zip archive")
    with pytest.raises(BearingTwinError, match=r"corrupt.npz: not a NumPy .npz archive \(it is no zip archive, as "
                                               r"numpy.savez writes\)") as refused:
        read_raw(corrupt)
    assert "pickle" not in str(refused.value)  # numpy's reading of any file that is no zip archive


def test_a_file_its_reader_cannot_parse_is_named_whatever_the_reader_raised(tmp_path):
    """scipy, numpy and zipfile raise their own types on a corrupt file (UnboundLocalError, MatReadError,
    BadZipFile): each is one error naming the file."""
    (tmp_path / "text.npy").write_text("1.0\n2.0\n")
    with pytest.raises(BearingTwinError, match=r"text.npy: not a NumPy .npy file \(it does not start with the .npy header\)"):
        read_raw(tmp_path / "text.npy")
    np.savez(tmp_path / "complex.npz", sig=np.ones(100), fs=np.array(1 + 2j))
    with pytest.raises(BearingTwinError, match=r"complex.npz: fs must be a single number, got array\(1\.\+2\.j\)"):
        read_raw(tmp_path / "complex.npz")
    for name, content in [("header_only.wav", b"RIFF\x24\x00\x00\x00WAVEjunkjunk"),
                          ("text.mat", b"this is not MATLAB"), ("cut.npz", b"PK\x03\x04" + b"x" * 64)]:
        (tmp_path / name).write_bytes(content)
        with pytest.raises(BearingTwinError, match=rf"^{tmp_path / name}: not a readable \.{name.split('.')[1]} file"):
            read_raw(tmp_path / name)


def test_a_truncated_wav_is_refused_not_read_in_part(tmp_path):
    """scipy reads a .wav cut short up to the cut and only warns: the part would have been diagnosed as the record."""
    path = tmp_path / "cut.wav"
    scipy.io.wavfile.write(path, int(FS), np.sin(np.arange(12000) / 3).astype(np.float32))
    whole = path.read_bytes()
    path.write_bytes(whole[:len(whole) // 3])
    with pytest.raises(BearingTwinError, match=rf"^{tmp_path / 'cut.wav'}: not a readable \.wav file, truncated \(Reached "
                                               rf"EOF prematurely; finished at \d+ bytes, expected {len(whole)} bytes"):
        read_raw(path)
    # A writer that states the RIFF size 8 bytes too large (its own header counted) left every sample in: read whole.
    over = bytearray(whole)
    over[4:8] = (int.from_bytes(whole[4:8], "little") + 8).to_bytes(4, "little")
    path.write_bytes(bytes(over))
    whole_read = read_raw(path)
    assert next(iter(whole_read.channels.values())).size == 12000
    assert not any("EOF" in note for note in whole_read.meta.get("notes", [])), whole_read.meta  # nothing amiss to say


def test_numbers_with_units_or_out_of_range_are_refused_naming_the_field(tmp_path, signal):
    path = tmp_path / "rec.npz"
    np.savez(path, signal=signal, fs=np.array("8 kHz"))
    with pytest.raises(BearingTwinError, match=r"rec.npz: fs='8 kHz' must be a positive number of Hz \(a plain number"):
        read_raw(path)
    np.savez(path, signal=signal, rpm=0.0)
    with pytest.raises(BearingTwinError, match=r"rec.npz: rpm=0.0 must be a positive number of rev/min"):
        read_raw(path)
    np.save(tmp_path / "rec.npy", signal)
    for given, field in [({"fs": "12k"}, "fs='12k'"), ({"fs": float("inf")}, "fs=inf"), ({"fs": FS, "rpm": "abc"}, "rpm='abc'")]:
        with pytest.raises(BearingTwinError, match=f"{field} must be a positive number"):
            load_recording(tmp_path / "rec.npy", **given)


def test_samples_by_channels_arrays_are_read_along_their_long_axis(tmp_path, signal):
    """A column per channel (MATLAB, a spreadsheet) as well as a row per channel: a record holds more samples than channels."""
    np.save(tmp_path / "columns.npy", np.stack([signal, -signal, 2 * signal], axis=1))
    raw = read_raw(tmp_path / "columns.npy")
    assert list(raw.channels) == ["0", "1", "2"]
    np.testing.assert_array_equal(raw.channels["2"], 2 * signal)
    np.save(tmp_path / "square.npy", np.ones((3, 3)))
    with pytest.raises(BearingTwinError, match=r"square.npy: its array has shape \(3, 3\), so which axis is time is not clear"):
        read_raw(tmp_path / "square.npy")
    scipy.io.savemat(tmp_path / "columns.mat", {"data": np.stack([signal, -signal], axis=1), "fs": FS})
    assert {name: values.size for name, values in read_raw(tmp_path / "columns.mat").channels.items()} == {
        "data[0]": signal.size, "data[1]": signal.size}


def test_csv_time_columns_in_seconds_milli_micro_or_nanoseconds_gaps_and_a_byte_order_mark(tmp_path, signal):
    t = np.arange(signal.size) / FS
    def write(name, header, time, values=signal, encoding="utf-8"):
        lines = [header] + [f"{float(a)!r},{float(b)!r}" for a, b in zip(time, values)]
        (tmp_path / name).write_text("\n".join(lines) + "\n", encoding=encoding)
        return tmp_path / name
    assert read_raw(write("ms.csv", "time_ms,acc", 1000 * t)).fs == pytest.approx(FS)
    for header, scale in (("Time [µs],acc", 1e6), ("t in microseconds,acc", 1e6), ("time_ns,acc", 1e9)):
        assert read_raw(write("fine.csv", header, scale * t, encoding="utf-8")).fs == pytest.approx(FS), header
    assert list(read_raw(write("bom.csv", "time,acc", t, encoding="utf-8-sig")).channels) == ["acc"]
    with pytest.raises(BearingTwinError, match=r"stamps.csv: the time column gives 8 samples per second.*head it time_ms"):
        read_raw(write("stamps.csv", "time,acc", 1000 * t))
    (tmp_path / "comma.csv").write_text("0,0324\n-1,5\n0,0117\n")
    with pytest.raises(BearingTwinError, match=r"comma.csv: its row '0,0324' reads as numbers written with decimal commas"):
        read_raw(tmp_path / "comma.csv")
    # A German spreadsheet's one column whose first rows show no leading zero: a later row or a "-0" gives it away.
    (tmp_path / "later.csv").write_text("0,3456\n0,8216\n1,3304\n0,0417\n")
    with pytest.raises(BearingTwinError, match=r"later.csv: its row '0,0417' reads as numbers written with decimal"):
        read_raw(tmp_path / "later.csv")
    (tmp_path / "closed.csv").write_text("0,3456,\n0,8216,\n1,0304,\n")  # each row closed by a separator
    with pytest.raises(BearingTwinError, match=r"closed.csv: its row '1,0304' reads as numbers written with decimal"):
        read_raw(tmp_path / "closed.csv")
    (tmp_path / "sign.csv").write_text("0,3456\n-0,8216\n1,3304\n")
    with pytest.raises(BearingTwinError, match=r"sign.csv: its row '-0,8216' reads as numbers written with decimal"):
        read_raw(tmp_path / "sign.csv")
    (tmp_path / "counts.csv").write_text("0,3456\n1,8216\n2,3304\n")  # integers: a sample index and ADC counts
    assert read_raw(tmp_path / "counts.csv").channels["1"].tolist() == [3456.0, 8216.0, 3304.0]
    rounded = np.round(np.arange(96000) / 48000.0, 5)  # 48 kHz stamps printed to five decimals: steps 2e-5 or 3e-5 s
    np.testing.assert_allclose(read_raw(write("rounded.csv", "time,acc", rounded, np.ones(96000))).fs, 48000.0, rtol=1e-4)
    keep = np.r_[0:1000, 1200:signal.size]
    with pytest.raises(BearingTwinError, match=r"gap.csv: the time column steps 0.025125 s at data row 1001, not its usual "
                                               r"0.000125 s: rows missing"):
        read_raw(write("gap.csv", "time,acc", t[keep], signal[keep]))


def test_csv_as_spreadsheets_and_loggers_write_it(tmp_path, signal):
    """Semicolons with decimal commas, tabs, spaces, quoted cells, a trailing separator, comment and blank lines
    before the header, a time column headed with its unit: each read to the same samples and rate."""
    t = np.arange(signal.size) / FS
    rows = list(zip(t, signal))
    files = {
        "semicolons.csv": "Time (s);acc\n" + "".join(f"{a:.6f};{b:.6f}\n".replace(".", ",") for a, b in rows),
        "tabs.csv": "t [ms]\tacc\n" + "".join(f"{1000 * a:.3f}\t{b:.6f}\n" for a, b in rows),
        "spaces.csv": "time_ms acc\n" + "".join(f"{1000 * a:.3f} {b:.6f}\n" for a, b in rows),
        "quoted.csv": '"time","acc"\n' + "".join(f'"{a:.6f}","{b:.6f}"\n' for a, b in rows),
        "trailing.csv": "time,acc,\n" + "".join(f"{a:.6f},{b:.6f},\n" for a, b in rows),
        "preamble.csv": "\n# logger 2.1, channel 3\n\ntime,acc\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in rows),
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text)
        raw = read_raw(tmp_path / name)
        assert list(raw.channels) == ["acc"] and raw.fs == FS, name
        np.testing.assert_allclose(raw.channels["acc"], signal, atol=1e-6, err_msg=name)
    (tmp_path / "late.csv").write_text("\n# a note\ntime,acc\n0,1\n\n0.000125,2\n0.00025,x\n")
    with pytest.raises(BearingTwinError, match=r"late.csv: line 7, column 2: 'x' is not a number"):
        read_raw(tmp_path / "late.csv")


def test_csv_without_a_header_is_read_along_its_longer_axis_and_repeated_names_are_told_apart(tmp_path, signal):
    (tmp_path / "row.csv").write_text(",".join(f"{v:.6f}" for v in signal) + "\n")  # MATLAB's csvwrite of a 1 x N vector
    raw = read_raw(tmp_path / "row.csv")
    assert list(raw.channels) == ["0"] and raw.channels["0"].size == signal.size
    (tmp_path / "rows.csv").write_text("".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in (signal, -signal)))
    raw = read_raw(tmp_path / "rows.csv")
    assert list(raw.channels) == ["0", "1"]
    np.testing.assert_allclose(raw.channels["1"], -signal, atol=1e-6)
    (tmp_path / "twice.csv").write_text("acc,acc,temp\n" + "".join(f"{v:.6f},{-v:.6f},20\n" for v in signal))
    raw = read_raw(tmp_path / "twice.csv")
    assert list(raw.channels) == ["acc", "acc.1", "temp"] and "more than one column is headed 'acc'" in raw.meta["notes"][0]
    np.testing.assert_allclose(raw.channels["acc"], signal, atol=1e-6)  # the first, left to right
    np.testing.assert_allclose(raw.channels["acc.1"], -signal, atol=1e-6)
    (tmp_path / "thrice.csv").write_text("acc,acc,acc.1\n" + "".join(f"{v:.6f},{2 * v:.6f},{3 * v:.6f}\n" for v in signal))
    raw = read_raw(tmp_path / "thrice.csv")
    assert list(raw.channels) == ["acc", "acc.2", "acc.1"]  # no column lost to a name another has
    np.testing.assert_allclose(raw.channels["acc.1"], 3 * signal, atol=1e-6)


@pytest.mark.parametrize("fs, decimals, rows", [(12000, 5, 24000), (25600, 5, 30000), (48000, 5, 50000), (10240.5, 12, 20000),
                                                (12000, 5, 300)])
def test_a_time_column_rounded_on_export_gives_the_rate_it_was_stamped_at(tmp_path, fs, decimals, rows):
    """Stamps printed to five decimals span 11999.98 samples per second at 12 kHz: the rounding of the span's two
    ends allows 12000, the rate the logger ran at. A rate that is no whole number of Hz stays as the stamps give it,
    and so does one whose rounding allows several."""
    t = 3.5 + np.arange(rows) / fs  # a logger's clock need not start at 0
    (tmp_path / "stamped.csv").write_text("time,acc\n" + "".join(f"{a:.{decimals}f},{i % 7}\n" for i, a in enumerate(t)))
    measured = read_raw(tmp_path / "stamped.csv").fs
    if rows == 300:  # 25 ms: the rounding allows 12000 +- 14 Hz, and no one whole number is the rate
        assert measured == (rows - 1) / (round(t[-1], decimals) - round(t[0], decimals))
    elif float(fs).is_integer():
        assert measured == fs != (rows - 1) / (round(t[-1], decimals) - round(t[0], decimals))  # not the span's
    else:
        assert measured == pytest.approx(fs, rel=1e-9)


def test_stamps_printed_coarser_than_the_sampling_period_state_no_rate(tmp_path):
    """A spreadsheet's export to four decimals stamps a 12 kHz record in 0.1 ms steps, so a stamp repeats every few
    rows: such stamps cannot show a lost or a doubled row, so they state no rate, and the file is read at the one
    given (it was refused as not increasing, given rate or not); a stamp that goes back is refused naming its row."""
    t = 1.0 + np.arange(5 * 12000) / 12000
    lines = [f"{a:.4f},{i % 7}\n" for i, a in enumerate(t)]
    (tmp_path / "coarse.csv").write_text("Time (s),acc\n" + "".join(lines))
    raw = read_raw(tmp_path / "coarse.csv")
    assert raw.fs is None and "the Time (s) stamps repeat, printed coarser than the sampling period" in raw.meta["notes"][0]
    assert load_recording(tmp_path / "coarse.csv", fs=12000).fs == 12000
    with pytest.raises(BearingTwinError, match=r"coarse.csv: the file does not state its sampling rate: the Time \(s\) "
                                               r"stamps repeat, printed coarser than the sampling period \(to 0.0001 "
                                               r"s\): the rate is not read from them; they span about 12000 rows a "
                                               r"second; give fs=<Hz>$"):
        load_recording(tmp_path / "coarse.csv")
    lines[500] = f"{t[400]:.4f},0\n"
    (tmp_path / "back.csv").write_text("Time (s),acc\n" + "".join(lines))
    with pytest.raises(BearingTwinError, match=r"back.csv: the Time \(s\) column does not increase at data row 501"):
        read_raw(tmp_path / "back.csv")


def test_a_loggers_clock_time_gives_the_time_stamps(tmp_path, signal):
    """A logger stamps its rows with its clock's time, to nanoseconds (``2024-03-01 23:59:59.750125000``), or in a
    ``Date`` and a ``Time`` column (``01.03.2024;23:59:59,750125``, with decimal commas): the stamps give the rate as
    a time column's do, through midnight too, and the dates are passed over; printed to milliseconds they repeat,
    giving none. The other columns' names state no unit by their letters (``signal``, ``gear``)."""
    seconds = 86400 - 0.25 + np.arange(signal.size) / FS  # from a quarter of a second before midnight

    def stamped(decimals: int) -> list[tuple[str, str, float]]:
        """Each sample with the day of March and the clock time it was taken at, printed to ``decimals``."""
        rows = []
        for at, value in zip(seconds, signal):
            day, rest = divmod(at, 86400)
            hours, rest = divmod(rest, 3600)
            minutes, second = divmod(rest, 60)
            rows.append((f"{int(day) + 1:02d}", f"{int(hours):02d}:{int(minutes):02d}:{second:0{3 + decimals}.{decimals}f}",
                         value))
        return rows

    (tmp_path / "iso.csv").write_text("Timestamp,acc (g),signal,gear\n" + "".join(
        f"2024-03-{day} {time},{v:.6f},{v:.6f},{-v:.6f}\n" for day, time, v in stamped(9)))
    raw = read_raw(tmp_path / "iso.csv")
    assert list(raw.channels) == ["acc (g)", "signal", "gear"] and (raw.fs, raw.fs_origin) == (FS, "time column")
    assert raw.channel_units == {"acc (g)": "g"}
    np.testing.assert_allclose(raw.channels["gear"], -signal, atol=1e-6)
    (tmp_path / "german.csv").write_text("Date;Time;acc (g)\n" + "".join(  # decimal commas; the date keeps its points
        f"{day}.03.2024;" + f"{time};{v:.6f}\n".replace(".", ",") for day, time, v in stamped(6)))
    recording = load_recording(tmp_path / "german.csv")
    assert (recording.channel, recording.fs, recording.unit) == ("acc (g)", FS, "g")
    np.testing.assert_allclose(recording.signal, signal, atol=1e-6)
    assert recording.meta["notes"][0] == "column Date passed over: the clock times of Time are the time stamps"
    (tmp_path / "ms.csv").write_text("Timestamp,acc\n" + "".join(f"2024-03-{day} {time},{v:.6f}\n"
                                                                  for day, time, v in stamped(3)))
    raw = read_raw(tmp_path / "ms.csv")
    assert raw.fs is None and raw.meta["notes"][0].startswith("the Timestamp stamps repeat, printed coarser than the "
                                                              "sampling period (to 0.001 s)")
    assert load_recording(tmp_path / "ms.csv", fs=FS).signal.size == signal.size
    # A logger's date line above its notes is a note, not a row of data; and a file of stamped rows without a header
    # loses no row to being read as names: it is refused at its first stamp, as before clock columns were read.
    (tmp_path / "dated.csv").write_text("2024-03-01 10:00:00\nSensor: A1\ntime,acc (g)\n" + "".join(
        f"{k / FS:.6f},{v:.6f}\n" for k, v in enumerate(signal)))
    assert (load_recording(tmp_path / "dated.csv").fs, load_recording(tmp_path / "dated.csv").signal.size) == (FS, signal.size)
    (tmp_path / "bare.csv").write_text("".join(f"2024-03-{day} {time},{v:.6f}\n" for day, time, v in stamped(9)))
    with pytest.raises(BearingTwinError, match="line 1, column 1: '2024-03-01 23:59:59.750000000' is not a number "
                                               r"\(a clock time: give the file a header row naming its columns"):
        read_raw(tmp_path / "bare.csv")
    # Above a single column too, where a note's form alone tells notes from data.
    (tmp_path / "single.csv").write_text("2024-03-01 10:00:00\nDevice: X\nacc (g)\n" + "".join(f"{v:.6f}\n" for v in signal))
    assert load_recording(tmp_path / "single.csv", fs=FS).signal.size == signal.size


def test_mat_structs_and_cells_and_the_simulators_sensor_names(tmp_path, signal):
    scipy.io.savemat(tmp_path / "struct.mat", {"rec": {"data": signal, "fs": FS, "rpm": 1797.0}})
    raw = read_raw(tmp_path / "struct.mat")
    assert list(raw.channels) == ["rec.data"] and (raw.fs, raw.rpm) == (FS, 1797.0)
    scipy.io.savemat(tmp_path / "notes.mat", {"vib": signal, "fs": FS, "info": {"operator": "bob"},
                                              "labels": np.array(["x axis", "y axis"], dtype=object)})
    raw = read_raw(tmp_path / "notes.mat")
    assert list(raw.channels) == ["vib"] and raw.meta == {"info.operator": "bob", "labels": ["x axis", "y axis"]}
    scipy.io.savemat(tmp_path / "free.mat", {"vib": signal, "info": {"fault": "inner race, 0.007 in", "comment": [],
                                                                     "fs": FS}})
    raw = read_raw(tmp_path / "free.mat")  # a field's free text is no bearing state, an empty one nothing to read
    assert (list(raw.channels), raw.fault, raw.fs) == (["vib"], None, FS)
    assert raw.meta == {"info.fault": "inner race, 0.007 in", "info.comment": "empty"}
    np.savez(tmp_path / "sim.npz", signal=signal, channels=np.stack([signal, -signal]), channel_names=np.array(["inner_x", "outer_y"]),
             fs=FS, rpm=1797.0, fault="outer")
    np.testing.assert_array_equal(load_recording(tmp_path / "sim.npz", channel="outer_y").signal, -signal)


def write_mat73(path, variables: dict) -> None:
    """A MATLAB 7.3 file laid out as MATLAB writes one: HDF5 after a 512-byte header naming the format, arrays
    transposed, text as UTF-16 codes, a struct as a group, a cell array as references into '#refs#', each dataset
    tagged with its MATLAB class."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as file:
        def put(group, name, value):
            if isinstance(value, dict):
                struct = group.create_group(name)
                struct.attrs["MATLAB_class"] = np.bytes_("struct")
                for field, item in value.items():
                    put(struct, field, item)
                return
            if isinstance(value, str):
                data, kind = np.array([[ord(c) for c in value]], dtype=np.uint16).T, "char"
            elif isinstance(value, list):  # a cell array of text
                refs = file.require_group("#refs#")
                for i, item in enumerate(value):
                    put(refs, f"{name}{i}", item)
                data, kind = np.array([[refs[f"{name}{i}"].ref for i in range(len(value))]], dtype=h5py.ref_dtype).T, "cell"
            else:
                data, kind = np.atleast_2d(np.asarray(value, dtype=np.float64)), "double"
            group.create_dataset(name, data=data.T).attrs["MATLAB_class"] = np.bytes_(kind)
        for name, value in variables.items():
            put(file, name, value)
    with open(path, "r+b") as handle:
        handle.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116) + bytes(8) + b"\x00\x02IM")


def test_a_matlab_7_3_file_is_read_as_the_older_formats_are(tmp_path, signal):
    """MATLAB saves large records (and any with -v7.3) as HDF5, which scipy does not read."""
    write_mat73(tmp_path / "big.mat", {"vib": signal[:, None], "fs": FS, "info": {"operator": "bob", "rpm": 1797.0},
                                       "labels": ["x axis", "y axis"]})
    raw = read_raw(tmp_path / "big.mat")
    assert list(raw.channels) == ["vib"] and (raw.fs, raw.rpm) == (FS, 1797.0)
    np.testing.assert_array_equal(raw.channels["vib"], signal)
    assert raw.meta == {"info.operator": "bob", "labels": ["x axis", "y axis"]}
    write_mat73(tmp_path / "columns.mat", {"data": np.stack([signal, -signal], axis=1), "fs": FS})
    np.testing.assert_array_equal(read_raw(tmp_path / "columns.mat").channels["data[1]"], -signal)  # MATLAB's N x 2


def test_an_hdf5_file_without_matlabs_header_is_read_as_matlab_7_3_is(tmp_path, signal):
    """h5py writes HDF5 without the 512 bytes MATLAB puts before it (scipy had called it an unknown MAT file type,
    version 0, 0): its arrays and scalars are read as a 7.3 file's, a 2-D array along its longer axis."""
    import h5py

    with h5py.File(tmp_path / "h5py.mat", "w") as file:
        file["acc"] = signal
        file["both"] = np.stack([signal, -signal], axis=1)
        file["fs"] = FS
    raw = read_raw(tmp_path / "h5py.mat")
    assert (raw.format, list(raw.channels), raw.fs) == ("mat", ["acc", "both[0]", "both[1]"], FS)
    np.testing.assert_array_equal(raw.channels["acc"], signal)
    np.testing.assert_array_equal(raw.channels["both[1]"], -signal)


def test_csv_layouts_that_used_to_read_still_do(tmp_path, signal):
    """numpy.savetxt's header (a comment line), a single column under a name with spaces, text in a cp1252 header."""
    t = np.arange(signal.size) / FS
    np.savetxt(tmp_path / "savetxt.csv", np.column_stack([t, signal]), delimiter=",", header="time,acc", fmt="%.9f")
    raw = read_raw(tmp_path / "savetxt.csv")
    assert list(raw.channels) == ["acc"] and raw.fs == FS
    (tmp_path / "one.csv").write_text("Acc (g)\n" + "".join(f"{v:.6f}\n" for v in signal))
    assert list(read_raw(tmp_path / "one.csv").channels) == ["Acc (g)"]
    (tmp_path / "excel.csv").write_bytes(("Zeit;a in m/s²\n" + "".join(f"{a:.6f};{b:.6f}\n".replace(".", ",")
                                                                      for a, b in zip(t, signal))).encode("cp1252"))
    raw = read_raw(tmp_path / "excel.csv")
    assert list(raw.channels) == ["a in m/s²"] and raw.fs == pytest.approx(FS, rel=1e-6)  # Zeit: the time stamps
    assert raw.channel_units == {"a in m/s²": "m/s^2"}
    np.testing.assert_allclose(raw.channels["a in m/s²"], signal, atol=1e-6)


@pytest.mark.parametrize("text, refusal", [
    ("a;b\n1,234;0.5\n2,345;0.7\n", r"its numbers \('0.5' and '1,234'\) use more than one decimal mark"),
    ("a;b\n1.234;0,5\n987;0,9\n", r"its numbers \('1.234' and '0,5'\) use more than one decimal mark"),
    ("a\tb\n1,234,5\t0\n", r"its numbers \('1,234,5'\) use more than one decimal mark, or a thousands separator"),
    ("a;b\n" + "0,5;1,5\n" * 300 + "1.234;0,5\n", r"line 302: '1.234' is written with '.' where the rows above use ','"),
    ("0.1,0.2,\n0.3,0.4,0.5\n", r"line 2 has 3 columns where the rows above have 2"),
    ("time,acc,\n0,0.1,5\n0.1,0.2,6\n", r"the header names 2 columns but the rows have 3$"),
    ("time,acc\n0,0001,0,0324\n0,0002,0,0311\n", r"the header names 2 columns but the rows have 4 \(numbers written with "
                                                r"decimal commas\? save the file with decimal points"),
    ("a\tb\n1\t2\nhello, world\t3\n", r"line 3, column 1: 'hello, world' is not a number"),
    # A column of text beside numbers is passed over, but not a table of text alone, nor a stray word in numbers.
    ("name,verdict\nrun1,ok\nrun2,bad\n", r"line 2, column 1: 'run1' is not a number"),
    ("acc,status\n0.1,OK\n0.2,OK\nlost,OK\n0.3,OK\n", r"line 4, column 1: 'lost' is not a number"),
    # A damaged row among the numbers is no logger's preamble: refused by its line, nothing above it dropped;
    ("time,acc\n0,0.1\n0.001,0.2\nsensor lost\n0.003,0.3\n", r"line 4 has 1 columns where the rows above have 2"),
    # nor is a second row of names that are no units: the names would be lost to it.
    ("Time,Acc\nch1,ch2\n0,0.1\n0.001,0.2\n", r"line 2, column 1: 'ch1' is not a number"),
    ('time,acc\n"0,000","0,1"\n"0,001","0,2"\n', r"line 2, column 1: '0,000' is not a number \(a number written with a "
                                                r"decimal comma\? save the file with decimal points"),
])
def test_csv_numbers_that_cannot_be_read_one_way_are_refused_not_misread(tmp_path, text, refusal):
    """A thousands separator beside a decimal mark would read 1,234 as 1.234 (or 1.234 as 1.234 where the file means
    1234); a value past a closing separator would be dropped. Each is refused, naming the cell or line."""
    (tmp_path / "t.csv").write_text(text)
    with pytest.raises(BearingTwinError, match=refusal):
        read_raw(tmp_path / "t.csv")


def test_a_csv_header_without_rows_is_refused_in_its_one_line_and_nothing_else(tmp_path):
    """numpy warns of an empty input on its own; the refusal naming the file is all a user should read."""
    import warnings

    # Also under a logger's notes, and above a row of units: the header is not named as a cell that is no number.
    for text in ("time_s,acc_g\n", "Device: logger-7\nTime (s),acc (g)\n", "Device: logger-7\nSample rate: 25600 Hz\n"
                 "Time,Acc\ns,g\n"):
        (tmp_path / "t.csv").write_text(text)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a warning would fail the test before the refusal
            with pytest.raises(BearingTwinError, match=r"t.csv: the file holds a header but no data rows$"):
                read_raw(tmp_path / "t.csv")


@pytest.mark.parametrize("header, seconds", [("Time (sec)", 1.0), ("Time [sec]", 1.0), ("time/s", 1.0), ("Time_sec", 1.0),
                                             ("Timestamp", 1.0), ("Zeit [s]", 1.0), ("time in ms", 1e-3),
                                             ("t (msec)", 1e-3)])
def test_time_columns_under_the_names_loggers_give_them(tmp_path, signal, header, seconds):
    """A time column a reader does not know would be offered as a channel, and a diagnosis of it reads a ramp."""
    t = np.arange(signal.size) / FS / seconds
    (tmp_path / "log.csv").write_text(f"{header},acc\n" + "".join(f"{a:.9f},{b:.6f}\n" for a, b in zip(t, signal)))
    raw = read_raw(tmp_path / "log.csv")
    assert list(raw.channels) == ["acc"] and raw.fs == pytest.approx(FS, rel=1e-6) and raw.fs_origin == "time column"
    assert f"sampling rate 8000 Hz from the time stamps {header}" in raw.meta["notes"]


def test_a_loggers_lines_above_the_header_are_notes_not_data(tmp_path, signal):
    t = np.arange(signal.size) / FS
    (tmp_path / "logger.csv").write_text(
        "Device: ACC-3\nSample rate: 8000 Hz\nStart: 2026-11-29 08:00\n\nTime (s),Acceleration (g)\n"
        + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, signal)))
    recording = load_recording(tmp_path / "logger.csv")
    np.testing.assert_allclose(recording.signal, signal, atol=1e-6)
    assert recording.fs == pytest.approx(FS) and recording.unit == "g"
    assert recording.meta["notes"][0] == ("the 3 lines above the header read as notes, not data (Device: ACC-3; "
                                          "Sample rate: 8000 Hz; Start: 2026-11-29 08:00)")


@pytest.mark.parametrize("gap", ["\n", ""])
def test_a_loggers_notes_above_a_single_column_are_notes_too(tmp_path, signal, gap):
    """A logger exporting one channel and no time column writes notes above a header of one name: every note has
    one cell as the rows do, so the notes are told by their form (``label: value``); a line of one name above a row
    of units is the header and its units, blank line between or not, as is one of two names above two units."""
    notes = "Device: VibLogger 3000\nSerial: A1234\nSample rate: 8000 Hz\nStart: 2024-03-01 10:00:00\n"
    (tmp_path / "logger.txt").write_text(notes + gap + "acc (g)\n" + "".join(f"{v:.6f}\n" for v in signal))
    recording = load_recording(tmp_path / "logger.txt", fs=FS)
    np.testing.assert_allclose(recording.signal, signal, atol=1e-6)
    assert recording.unit == "g" and recording.channel == "acc (g)"
    assert recording.meta["notes"][0].startswith("the 4 lines above the header read as notes, not data (Device: "
                                                 "VibLogger 3000; Serial: A1234; Sample rate: 8000 Hz; ...)")
    # The rate the logger notes is the record's own: no fs= needed, and another one given is a contradiction.
    read = load_recording(tmp_path / "logger.txt")
    assert read.fs == FS and read.meta["fs_origin"] == "header"
    assert "sampling rate 8000 Hz from the note 'Sample rate: 8000 Hz' above the header" in read.meta["notes"]
    with pytest.raises(BearingTwinError, match=r"logger.txt.*12000.*8000"):
        load_recording(tmp_path / "logger.txt", fs=12000.0)
    (tmp_path / "units.txt").write_text("Acceleration\n" + gap + "g\n" + "".join(f"{v:.6f}\n" for v in signal))
    recording = load_recording(tmp_path / "units.txt", fs=FS)
    assert (recording.channel, recording.unit, recording.signal.size) == ("Acceleration (g)", "g", signal.size)
    (tmp_path / "two.csv").write_text("time,acc\n" + gap + "s,g\n" + "".join(f"{k / FS:.6f},{v:.6f}\n"
                                                                         for k, v in enumerate(signal)))
    recording = load_recording(tmp_path / "two.csv")
    assert (recording.channel, recording.unit, recording.fs) == ("acc (g)", "g", FS)
    assert "the row under the header read as the columns' units: time (s), acc (g)" in recording.meta["notes"]


def test_a_row_of_units_under_a_loggers_header_and_names_given_without_their_unit(tmp_path, signal):
    """Loggers write the units in a row of their own (``s;m/s²``, bracketed or not; ``-`` for a column of none),
    under notes or not; a column is then asked for by its name, as it is by the name of a header that holds its unit
    (``FE`` for ``FE (g)``), where no other column goes by it; a time column in milliseconds is read so."""
    rows = "".join(f"{k / FS * 1000:.6f};{v:.6f};{v / 9.80665:.6f};{k % 2}\n".replace(".", ",")
                   for k, v in enumerate(signal))
    (tmp_path / "logger.csv").write_text("Device: ACC-3\nTime;Acc;Acc;Trigger\n[ms];[m/s²];(g);-\n" + rows)
    raw = read_raw(tmp_path / "logger.csv")
    assert list(raw.channels) == ["Acc (m/s²)", "Acc (g)", "Trigger"] and raw.fs == pytest.approx(FS)
    assert raw.channel_units == {"Acc (m/s²)": "m/s^2", "Acc (g)": "g"}
    assert raw.meta["notes"][0].startswith("the 1 line above the header read as notes")
    np.testing.assert_allclose(raw.channels["Acc (g)"], signal / 9.80665, atol=1e-6)
    with pytest.raises(BearingTwinError, match=r"logger.csv: no channel 'Acc'"):  # two columns go by it
        load_recording(tmp_path / "logger.csv", channel="Acc")
    (tmp_path / "cwru.csv").write_text("DE (g),FE (g),BA (g)\n" + "".join(f"{v:.6f},{-v:.6f},0\n" for v in signal))
    recording = load_recording(tmp_path / "cwru.csv", channel="FE", fs=FS)
    assert (recording.channel, recording.unit) == ("FE (g)", "g")
    np.testing.assert_allclose(recording.signal, -signal, atol=1e-6)



@pytest.mark.parametrize("note, rate", [
    ("Sampling frequency = 25.6 kHz", 25600.0), ("fs: 48000 Hz", 48000.0), ("Sample rate (Hz): 12000", 12000.0),
    ("SAMPLE_RATE=8000 S/s", 8000.0), ("Sampling rate: 25.6kHz", 25600.0), ("Sampling frequency [Hz]: 12000", 12000.0),
    ("Sample rate: 12000 Hz, 24 bit", 12000.0), ("Sample rate: 51.2 kS/s", 51200.0), ("Sampling rate: 25.6 ksps", 25600.0),
    # The time between samples, to the digits it was printed with; its unit stated.
    ("Sampling interval: 1.953125e-05 s", 51200.0), ("dt [ms] = 0.02", 50000.0), ("Delta t: 8.333e-05 s", 12000.0),
    ("dt [ms] = 0.04", 25000.0), ("Sampling interval: 4 us", 250000.0), ("dt [μs] = 20", 50000.0),
    ("dt: 0.5", None),
    # No rate rather than a misread one: a sensor's full scale, a bare number under fs, thousands separators.
    ("FS: 50 g", None), ("FS: 10", None), ("Sample rate: 12,800 Hz", None), ("Sample rate: 12.000,0 Hz", None),
    ("Rate: 100 ms", None)])
def test_a_rate_a_loggers_note_states(tmp_path, note, rate):
    (tmp_path / "log.csv").write_text(f"Logger: X\n{note}\n\nacc\n" + "0.1\n-0.2\n" * 50)
    raw = read_raw(tmp_path / "log.csv")
    assert raw.fs == rate and raw.fs_origin == ("header" if rate else "")
    # Written as '#' comment lines, as many loggers and numpy.savetxt's header= write them, the note says the same,
    # above a header or above the numbers alone (where it is no column's name).
    (tmp_path / "commented.csv").write_text(f"# Logger: X\n# {note}\nacc\n" + "0.1\n-0.2\n" * 50)
    for columns in (1, 2):
        np.savetxt(tmp_path / f"savetxt{columns}.csv", np.tile([[0.1], [-0.2]], (50, columns)), header=note, delimiter=",")
    for name in ("commented.csv", "savetxt1.csv", "savetxt2.csv"):
        commented = read_raw(tmp_path / name)
        assert commented.fs == rate and commented.fs_origin == ("header" if rate else ""), name
    assert list(read_raw(tmp_path / "savetxt1.csv").channels) == ["0"]


def test_a_noted_rate_is_read_with_the_files_decimal_mark_or_named_as_not_read(tmp_path):
    """Among numbers written with decimal commas '25,6 kHz' is 25.6 kHz (it had been passed over: no rate stated), and
    '25.600 Hz' may be 25.6 Hz or 25600 Hz (a thousands point): not misread as 25.6 Hz, but named where the file is
    said to state no rate, as '12,800 Hz' is among decimal points. A spreadsheet's two cells ('Sample rate;25600')
    state a rate as a note does, and a single column of decimal commas under notes gets the decimal-comma remedy."""
    rows = "".join(f"{value:.4f};{-value:.4f}\n".replace(".", ",") for value in np.linspace(-1, 1, 200))
    for note, rate in [("Sampling frequency:\t25,6 kHz", 25600.0), ("Sample rate;25600", 25600.0),
                       ("Sample rate\t12000", 12000.0), ("Sample rate: 25.600 Hz", None)]:
        (tmp_path / "comma.csv").write_text(f"Device: X\n{note}\nDate;2026-11-29\n\nacc x [g];acc y [g]\n{rows}")
        raw = read_raw(tmp_path / "comma.csv")
        assert (raw.fs, list(raw.channels)) == (rate, ["acc x [g]", "acc y [g]"]), note
    with pytest.raises(BearingTwinError, match=(
            r"comma.csv: the file does not state its sampling rate: its note 'Sample rate: 25.600 Hz' writes the rate so "
            r"that it reads as more than one number \(a thousands separator, or a decimal mark other than its numbers' "
            r"','\); give fs=<Hz>$")):
        resolve_fs(raw, None)
    (tmp_path / "point.csv").write_text("Sample rate: 12,800 Hz\n\nacc\n" + "0.1\n-0.2\n" * 50)
    with pytest.raises(BearingTwinError, match=r"its note 'Sample rate: 12,800 Hz' writes the rate so that it reads as "
                                               r"more than one number .* other than its numbers' '\.'\); give fs"):
        resolve_fs(read_raw(tmp_path / "point.csv"), None)
    # One column under its header: its comma can only be a decimal mark, where each row is a number's two parts.
    (tmp_path / "one.csv").write_text("Device: X\nSample rate: 25600 Hz\n\nacc [g]\n" + "0,1\n-0,25\n" * 50)
    one = read_raw(tmp_path / "one.csv")
    np.testing.assert_array_equal(one.channels["acc [g]"], [0.1, -0.25] * 50)
    assert "one column under its header, each number written with a decimal comma ('0,1'): read so" in one.meta["notes"]
    (tmp_path / "two.csv").write_text("Device: X\nSample rate: 25600 Hz\n\nacc [g]\n" + "0,1\n-0,-0.2\n" * 50)
    with pytest.raises(BearingTwinError, match=r"two.csv: the header names 1 columns but the rows have 2 \(numbers "
                                               r"written with decimal commas\? save the file with decimal points"):
        read_raw(tmp_path / "two.csv")  # a second column's own sign and point: two columns, one name


def test_a_loggers_notes_give_the_shaft_speed_and_the_unit(tmp_path):
    """'Speed: 1796 rpm' and 'Unit: g' above the header had been passed over, the record read as if in m/s^2, 9.81
    times too low; a speed in Hz is read in rev/min, one with no unit is not read (rev/min or Hz?) and said so, a
    column's own unit stands over the note's. Above a single column, the last note ('Units: m/s^2') had become its
    name."""
    column = "0.1\n-0.2\n" * 50
    (tmp_path / "log.csv").write_text("Device: X\nSample rate: 12 kHz\nSpeed: 1796 rpm\nUnit: g\n\nacc\n" + column)
    raw = read_raw(tmp_path / "log.csv")
    assert (raw.fs, raw.rpm, raw.unit, list(raw.channels)) == (12000.0, 1796.0, "g", ["acc"])
    assert "shaft speed 1796 rpm from the note 'Speed: 1796 rpm'" in raw.meta["notes"]
    assert load_recording(tmp_path / "log.csv").unit == "g"
    (tmp_path / "hz.csv").write_text("Shaft speed [Hz]: 29,9\nEinheit: m/s²\n\nacc (mg);b\n" + "0,1;0,3\n-0,2;0,1\n" * 50)
    raw = read_raw(tmp_path / "hz.csv")
    assert raw.rpm == pytest.approx(1794.0) and raw.unit == "m/s^2"
    assert [load_recording(raw.path, channel=name, fs=FS).unit for name in ("acc", "b")] == ["mg", "m/s^2"]
    (tmp_path / "bare.csv").write_text("Speed: 1796\nUnit: furlongs\n\nacc\n" + column)
    raw = read_raw(tmp_path / "bare.csv")
    assert raw.rpm is None and raw.unit == ""
    assert "the note 'Speed: 1796' is not read as the shaft speed (a positive number in rev/min or Hz, its unit " \
           "stated): give rpm=" in raw.meta["notes"]
    assert "the note 'Unit: furlongs' names no unit known here: not read" in raw.meta["notes"]
    (tmp_path / "one.csv").write_text("Device: X\nSample rate: 12000 Hz\nUnits: m/s^2\n" + column)
    raw = read_raw(tmp_path / "one.csv")
    assert (raw.fs, raw.unit, list(raw.channels)) == (12000.0, "m/s^2", ["0"])


def test_a_loggers_noted_rate_and_its_time_stamps_must_agree(tmp_path, signal):
    """Printed to a few decimals the time stamps only approximate the rate the note states exactly: within 1 % the
    note's is kept, beyond it the two contradict each other and the file is refused naming both."""
    t = np.arange(signal.size) / FS
    table = "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, signal))
    (tmp_path / "agree.csv").write_text(f"Sample rate: {FS:g} Hz\n\ntime_s,acc_g\n" + table)
    raw = read_raw(tmp_path / "agree.csv")
    assert raw.fs == FS and raw.fs_origin == "header" and list(raw.channels) == ["acc_g"]
    assert f"sampling rate {FS:g} Hz from the note 'Sample rate: {FS:g} Hz' above the header" in raw.meta["notes"]
    (tmp_path / "contradict.csv").write_text("Sample rate: 12000 Hz\n\ntime_s,acc_g\n" + table)
    with pytest.raises(BearingTwinError, match=r"contradict.csv: its sampling rate, 12000 Hz, contradicts its time "
                                               r"stamps time_s, 8000 Hz"):
        read_raw(tmp_path / "contradict.csv")


@pytest.mark.parametrize("name, unit", [("acc_g", "g"), ("Accel_G", "g"), ("a_m/s2", "m/s^2"), ("acc_x", ""),
                                        ("ch_1", ""), ("acc (g)", "g"), ("acc_g.1", "g"), ("accel_ms2", "m/s^2"),
                                        ("acc_m_s2", "m/s^2"), ("acc_mps2", "m/s^2"), ("acc_mg", "mg"),
                                        ("acc (mm/s^2)", "mm/s^2"), ("acc [mm/s²]", "mm/s^2"), ("acc (mg)", "mg"),
                                        ("a [µg]", "µg"), ("a (Gal)", "cm/s^2"), ("v (mm/s)", "mm/s"),
                                        ("signal", ""), ("gear", ""), ("rig_2", ""), ("vel_mm_s", "mm/s"),
                                        ("vel_ips", "ips"), ("velocity_mm/s", "mm/s"), ("gap_um", "um"),
                                        ("time_s", ""), ("volt_v", ""), ("speed_rpm", ""),
                                        # a velocity a plant's logger names by its word alone, or with a
                                        # detector's word after its unit: none may pass for an acceleration in g
                                        ("Velocity", "Velocity"), ("vel_mms", "mms"), ("vel_x", "vel"),
                                        ("Velocity [mm/s RMS]", "mm/s RMS"), ("Velocity (mm/s pk)", "mm/s pk"),
                                        ("Displacement (pump 2)", "Displacement"), ("level", ""), ("travel_x", ""),
                                        ("Accel (G's)", "g"), ("acc (g pk)", "g")])
def test_an_acceleration_unit_after_an_underscore(name, unit):
    """Loggers and scripts name a column ``acc_g`` as often as ``acc (g)``, and write m/s² as ``ms2`` or ``m_s2``
    there; after an underscore an acceleration unit counts, and a velocity's or displacement's (``vel_mm_s`` had been
    read as an acceleration, its spectrum's tilt taken for physics), so ``acc_x`` (a direction), ``ch_1``, ``time_s``
    and ``speed_rpm`` state none, and a name's own letters are none (``signal`` and ``gear`` end in a g)."""
    from bearingtwin.data.formats import unit_in_name
    from bearingtwin.data.units import INTEGRATED_QUANTITIES, quantity_of

    assert unit_in_name(name) == unit
    if name.lower().startswith(("vel", "disp")):
        assert quantity_of(unit) in INTEGRATED_QUANTITIES


def test_units_a_header_states_and_a_rate_under_other_names(tmp_path, signal):
    import scipy.io

    (tmp_path / "si.csv").write_text("acceleration (m/s^2);tacho [V]\n" + "".join(f"{v:.6f};1\n" for v in signal))
    assert load_recording(tmp_path / "si.csv", channel=0, fs=FS).unit == "m/s^2"
    assert load_recording(tmp_path / "si.csv", channel="tacho [V]", fs=FS).unit == "V"
    assert load_recording(tmp_path / "si.csv", channel=0, fs=FS).meta["notes"] == []
    # A name with spaces or brackets is typed quoted on a command line (bare, Hydra cannot parse it): shown so.
    with pytest.raises(BearingTwinError, match=r"choose one with channel=<name>; quote a name like 'acceleration "
                                               r"\(m/s\^2\)' in single quotes inside double: "
                                               r"channel=\"'acceleration \(m/s\^2\)'\"$"):
        load_recording(tmp_path / "si.csv", fs=FS)
    for name in ("SampleRate", "sampling_rate", "Fs", "sample rate"):
        scipy.io.savemat(tmp_path / "rate.mat", {"data": signal, name: FS})
        assert read_raw(tmp_path / "rate.mat").fs == FS, name
    # A time vector beside the signal gives the rate and is no channel.
    t = np.arange(signal.size) / FS
    scipy.io.savemat(tmp_path / "tx.mat", {"t": t, "x": signal})
    raw = read_raw(tmp_path / "tx.mat")
    assert list(raw.channels) == ["x"] and raw.fs == pytest.approx(FS) and raw.fs_origin == "time column"
    np.savez(tmp_path / "stamped.npz", signal=signal, time_s=t, fs=FS)  # ... agreeing with a rate the file states
    assert list(read_raw(tmp_path / "stamped.npz").channels) == ["signal"]
    np.savez(tmp_path / "clash.npz", signal=signal, t=t, fs=2 * FS)
    with pytest.raises(BearingTwinError, match=r"clash.npz: its sampling rate, 16000 Hz, contradicts its time stamps t, "
                                               r"8000 Hz"):
        read_raw(tmp_path / "clash.npz")
    # A variable called T that does not rise (a temperature), or a short one, is a channel, not time stamps.
    np.savez(tmp_path / "temperature.npz", signal=signal, T=20 + 0.01 * signal, fs=FS)
    assert list(read_raw(tmp_path / "temperature.npz").channels) == ["signal", "T"]
    np.savez(tmp_path / "short.npz", signal=signal, t=t[:100])
    assert list(read_raw(tmp_path / "short.npz").channels) == ["signal", "t"]
    # Bracketed text that is no unit states none; a repeated header's column keeps its unit.
    assert (unit_in_name("ch1 (left)"), unit_in_name("chan[0]"), unit_in_name("acc (g).1")) == ("", "", "g")
    np.save(tmp_path / "counts.npy", np.round(1000 * signal).astype(np.int16))
    assert "integer samples (int16)" in read_raw(tmp_path / "counts.npy").meta["notes"][0]
    # An archive or a MATLAB file of counts says so too, whatever unit it states (g here, read as counts of g).
    np.savez(tmp_path / "counts.npz", signal=np.round(1000 * signal).astype(np.int16), fs=FS, unit="g")
    scipy.io.savemat(tmp_path / "counts.mat", {"acc": np.round(1000 * signal).astype(np.int16), "fs": FS})
    for name, which in (("counts.npz", "signal (int16)"), ("counts.mat", "acc (int16)")):
        assert any(note.startswith(f"integer samples ({which}): converter counts")
                   for note in read_raw(tmp_path / name).meta["notes"]), name
    np.savez(tmp_path / "volts.npz", signal=signal, fs=FS)
    assert "notes" not in read_raw(tmp_path / "volts.npz").meta


def test_time_stamps_read_as_the_channel_are_refused(tmp_path, signal):
    """The stamps of a time column its reader took for a channel only rise, and a coarse counter only steps up: no
    vibration does."""
    t = np.arange(signal.size) / FS
    np.savetxt(tmp_path / "plain.csv", np.column_stack([t, signal]), delimiter=",", header="a,b", comments="")
    with pytest.raises(BearingTwinError, match=r"plain.csv: channel a rises throughout, from 0 to 0.511875: time "
                                               r"stamps or sample numbers, not a vibration"):
        load_recording(tmp_path / "plain.csv", channel="a", fs=FS).require_vibration()
    load_recording(tmp_path / "plain.csv", channel="b", fs=FS).require_vibration()
    counter = Recording(np.floor(np.arange(signal.size) / 8.0), FS, source="counter")  # steps up every 8 samples
    with pytest.raises(BearingTwinError, match=r"counter: channel \? rises throughout"):
        counter.require_vibration()


def test_a_column_of_text_beside_the_numbers_is_passed_over_and_named(tmp_path, signal):
    """A logger's status column ('OK') had made the whole file unreadable, its vibration named or not (a table of
    text alone and a stray word among numbers are still refused: test_csv_numbers_that_cannot_be_read_one_way...)."""
    t = np.arange(signal.size) / FS
    (tmp_path / "logger.csv").write_text("time,acc_g,status,temp\n" + "".join(
        f"{a:.6f},{b:.6f},OK,{20 + i % 3}\n" for i, (a, b) in enumerate(zip(t, signal))))
    raw = read_raw(tmp_path / "logger.csv")
    assert list(raw.channels) == ["acc_g", "temp"] and raw.fs == pytest.approx(FS, rel=1e-6)
    assert "column 'status' holds text, not numbers: passed over" in raw.meta["notes"]
    np.testing.assert_allclose(load_recording(tmp_path / "logger.csv", channel="acc_g").signal, signal, atol=1e-6)


@pytest.mark.parametrize("notes, header, row", [
    ("Speed: 1748 rpm\n", "time_s,acc [mg],status", "{t:.7f},{a:.3f},OK"),
    ("Sample rate: 8000 Hz\n", "status,acc [mg]", "OK,{a:.3f}"),
    ("Device: VibLog 3000\nSample rate: 8,0 kHz\nSpeed: 1748 rpm\n", "Nr;acc [mg];status", "{i};{a_comma};OK"),
])
def test_a_loggers_notes_above_a_table_with_a_text_column_are_notes_and_the_text_passed_over(tmp_path, signal, notes,
                                                                                             header, row):
    """Notes above the header and a status column had each been read alone, but together the header was refused as
    a row whose first cell is not a number: the status column made no row below a row of numbers."""
    rows = "".join(row.format(t=i / FS, a=1000 * a, a_comma=f"{1000 * a:.3f}".replace(".", ","), i=i + 1) + "\n"
                   for i, a in enumerate(signal))
    (tmp_path / "logger.csv").write_text(notes + header + "\n" + rows)
    recording = load_recording(tmp_path / "logger.csv")
    assert recording.channel == "acc [mg]" and recording.fs == pytest.approx(FS, rel=1e-4)
    np.testing.assert_allclose(recording.signal, 1000 * signal, atol=1e-3)
    assert "column 'status' holds text, not numbers: passed over" in recording.meta["notes"]
    assert recording.meta["notes"][0].startswith("the ") and "above the header read as notes" in recording.meta["notes"][0]
    assert recording.rpm == (None if "Speed" not in notes else 1748.0)


def test_a_spreadsheets_row_numbers_are_no_channel_to_choose(tmp_path, signal):
    """A column 'Nr' counting 1, 2, 3 beside the vibration had forced channel=; it is read as sample numbers, and
    refused by name where chosen."""
    (tmp_path / "rows.csv").write_text("Nr;acc [g]\n" + "".join(f"{i + 1};{a:.6f}\n" for i, a in enumerate(signal)))
    raw = read_raw(tmp_path / "rows.csv")
    assert raw.channel(None)[0] == "acc [g]" and list(raw.vibration_channels) == ["acc [g]"]
    with pytest.raises(BearingTwinError, match=r"rows.csv: channel=Nr reads sample numbers \(1, 2, ...\), not a "
                                               r"vibration; choose one of acc \[g\]"):
        raw.channel("Nr")


def test_levels_no_vibration_reaches_in_any_unit_are_refused(signal):
    """At 1e150 a record's squared envelope overflowed and its NaN prominences decided windows; at 1e-200 squares
    vanish. Both are refused as numbers scaled wrong; 1e9 (a g in ng) and 1e-6 (in Mm/s^2) are vibrations."""
    for scale in (1e150, 1e-200):
        with pytest.raises(BearingTwinError, match=r"huge: channel \?'s largest magnitude, .*, lies outside 1e-30 to "
                                                   r"1e\+30, where a vibration lies in any unit: the numbers are scaled "
                                                   r"wrong or are no vibration$"):
            Recording(scale * signal, FS, source="huge").require_vibration()
    for scale in (1e9, 1e-6):
        Recording(scale * signal, FS, source="fine").require_vibration()


def test_compiled_kernels_are_cached_with_the_users_caches_not_beside_the_sources(tmp_path):
    """numba's cache=True would write into __pycache__ beside the package's sources (a checkout no command writes
    into, or an installation the user cannot write to): it goes under the user's cache folder."""
    import subprocess
    import sys

    import bearingtwin.physics.defects as defects

    sources = Path(defects.__file__).parent / "__pycache__"
    before = set(sources.glob("*.nb*")) if sources.exists() else set()
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = ("import numpy as np; from bearingtwin.physics.defects import _pit_profile; "
            "print(_pit_profile(0.1, 0.5, 1.0))")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    cached = list((tmp_path / "bearingtwin" / "numba").rglob("defects._pit_profile-*.nbi"))
    assert cached, list(tmp_path.rglob("*"))
    after = set(sources.glob("*.nb*")) if sources.exists() else set()
    assert after - before == set()


def test_a_speed_that_reads_as_a_frequency_in_hz_is_noted_with_the_rpm_it_would_be(tmp_path, signal):
    """29.17 given as rpm is a shaft at 0.49 Hz, which the rate check then finds too slow to check: the note names the
    likely slip (a frequency in Hz) and the speed it would be; a motor's speed gets no note."""
    np.save(tmp_path / "r.npy", signal)
    slow = load_recording(tmp_path / "r.npy", fs=12000, rpm=29.17, rpm_key="measured.rpm")
    assert "measured.rpm=29.17 is a shaft at 0.486 Hz; if 29.17 is the shaft's frequency in Hz, give measured.rpm=1750.2" \
        in slow.meta["notes"]
    assert not any("frequency in Hz" in n for n in load_recording(tmp_path / "r.npy", fs=12000, rpm=1750).meta["notes"])


def test_scripts_written_to_the_readers_former_module_name_keep_running_and_are_told_the_new_one():
    """The guide's Python example once imported ``load_recording`` from ``bearingtwin.data.files``: such a script
    reads its records as before, warned where the readers now live."""
    import importlib
    import sys

    from bearingtwin.data import formats

    sys.modules.pop("bearingtwin.data.files", None)
    with pytest.warns(DeprecationWarning, match="bearingtwin.data.formats"):
        former = importlib.import_module("bearingtwin.data.files")
    assert former.load_recording is formats.load_recording and former.read_raw is formats.read_raw


def test_numbers_under_names_not_read_as_a_rate_or_speed_are_named_where_one_is_missing(tmp_path, signal):
    """A .mat holding `fsamp` and `n_rpm` had been refused as stating no rate, though inspect listed both: the refusal
    names the numbers the file holds under names not read as one, and so does the note of a speed not stated."""
    import scipy.io

    path = tmp_path / "pump.mat"
    scipy.io.savemat(path, {"acc": signal, "fsamp": FS, "n_rpm": 1748.0})
    with pytest.raises(BearingTwinError, match=r"pump.mat: the file does not state its sampling rate: it holds "
                                               r"fsamp=\d+, n_rpm=1748, under names not read as one; give fs=<Hz>$"):
        load_recording(path)
    recording = load_recording(path, fs=FS)
    assert recording.rpm is None
    assert recording.meta["speed_unread"] == f"it holds fsamp={FS:g}, n_rpm=1748, under names not read as one"
    scipy.io.savemat(path, {"acc": signal, "fs": FS, "rpm": 1748.0})  # read as facts: nothing else to name
    assert load_recording(path).rpm == 1748.0 and "speed_unread" not in load_recording(path).meta


def test_a_headerless_table_whose_first_column_rises_in_even_steps_reads_it_as_time_stamps(tmp_path, signal):
    """``time,accel`` rows with no header (a plant logger's two-column export): the first column had been a channel to
    choose, and the rate asked for, beside stamps that give it. Two vibration channels are still both channels."""
    t = np.arange(signal.size) / FS
    np.savetxt(tmp_path / "stamped.csv", np.column_stack([t, signal]), delimiter=",", fmt="%.7f")
    raw = read_raw(tmp_path / "stamped.csv")
    assert raw.fs == FS and list(raw.channels) == ["1"] and raw.fs_origin == "time column"
    np.testing.assert_allclose(raw.channels["1"], signal, atol=1e-6)
    assert any(note.startswith("column 0 rises in even steps") for note in raw.meta["notes"])
    np.savetxt(tmp_path / "two.csv", np.column_stack([signal, -signal]), delimiter=",", fmt="%.7f")
    two = read_raw(tmp_path / "two.csv")
    assert two.fs is None and list(two.channels) == ["0", "1"]


def test_a_universal_file_export_is_named_as_such(tmp_path):
    """An analyzer's UFF 58 export saved as .txt had been refused as "line 3, column 1: 'Accel DE' is not a number"."""
    (tmp_path / "pump.txt").write_text("    -1\n    58\nAccel DE\nNONE\n" + " -2.77602E-01 -4.43448E-02\n" * 20 + "    -1\n")
    with pytest.raises(BearingTwinError, match=r"pump.txt: a Universal File Format export \(data set 58\), not a table "
                                               r"of numbers: not read here; export the time records as a table"):
        read_raw(tmp_path / "pump.txt")
