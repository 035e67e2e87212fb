"""Generic recordings: every format round-trips its samples and facts; bad files and
contradictions are refused with the file named."""

import numpy as np
import pytest
import scipy.io
import scipy.io.wavfile

from bearingtwin.data.files import load_recording, read_raw
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


def test_csv_non_numeric_cell_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("a,b\n1,2\n3,abc\n")
    with pytest.raises(BearingTwinError, match="bad.csv: could not convert string 'abc'"):
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
    np.testing.assert_array_equal(load_recording(wav, channel="1").signal, -pcm)
    with pytest.raises(BearingTwinError, match="rec.wav: fs=12000 Hz contradicts the file's 8000 Hz"):
        load_recording(wav, channel="0", fs=12000)


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
    with pytest.raises(BearingTwinError, match="holes.npy: 2 NaN or infinite values"):
        load_recording(path, fs=FS)
    with pytest.raises(BearingTwinError, match=r"holes.npy: no channel 'Q'; the file holds 0"):
        load_recording(path, channel="Q", fs=FS)
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"not a zip archive")
    with pytest.raises(BearingTwinError, match="corrupt.npz: not a readable .npz"):
        read_raw(corrupt)
