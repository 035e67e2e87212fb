"""CWRU records: names, channels, measured speed, and sampling rates checked against the shaft line.

Runs on the real files in ../shared/data/cwru (or $BEARINGTWIN_DATA/cwru)."""

import re
from pathlib import Path

import numpy as np
import scipy.signal
import pytest

from bearingtwin.config import data_root, load_bearing
from bearingtwin.data.cwru import declared_fs_hz, load_cwru, parse_cwru_name
from bearingtwin.data.formats import load_recording, read_raw
from bearingtwin.errors import BearingTwinError
from bearingtwin.signal.envelope import envelope_spectrum
from bearingtwin.testrig import RigOperatingPoint, simulate_rig
from bearingtwin.signal.sampling_rate import (ShaftLineCheck, _shaft_comb_words, check_channels, check_sampling_rate,
                                              decisive_channel, require_plausible_rate)

CWRU = data_root() / "cwru"
needs_data = pytest.mark.skipif(not (CWRU / "normal_0_97.mat").is_file(), reason=f"CWRU files not found in {CWRU}")

# Multiples of shaft speed from the README (SKF 6205-2RS JEM).
BPFO_ORDER, BPFI_ORDER = 3.5848, 5.4152


def test_names_give_state_load_and_record():
    outer = parse_cwru_name("12k_Drive_End_OR007@6_0_130.mat")
    assert (outer.fault, outer.load_hp, outer.record, outer.fault_size_in, outer.position) == ("outer", 0, 130, 0.007, "6")
    inner = parse_cwru_name("12k_Drive_End_IR007_3_108.mat")
    assert (inner.fault, inner.load_hp, inner.record) == ("inner", 3, 108)
    normal = parse_cwru_name("normal_0_97.mat")
    assert (normal.fault, normal.load_hp, normal.record) == ("normal", 0, 97)
    assert parse_cwru_name("bearing.mat") is None


def test_the_data_centers_numbers_and_labels_name_state_size_position_and_load():
    """The Data Center names its download files by record number (its catalogue says what each holds; there is no
    157) and mirrors name them by its label of the condition: both give state, size, outer-race position and load.
    A number gives the 12 kHz drive end; a label gives no record, rate or end."""
    number = parse_cwru_name("258.mat")
    assert (number.fault, number.fault_size_in, number.position, number.load_hp, number.record) == ("outer", 0.021, "12", 0, 258)
    assert (number.rate_hz, number.end, number.bearing) == (12000.0, "drive", "cwru_6205")
    assert (parse_cwru_name("158.mat").position, parse_cwru_name("158.mat").load_hp) == ("12", 1)
    assert parse_cwru_name("157.mat") is None and parse_cwru_name("216.mat") is None  # numbers the Data Center skips
    # Its 48 kHz drive-end and 12 kHz fan-end records are numbered too: the number gives the rate and the bearing.
    fast = parse_cwru_name("217.mat")
    assert (fast.fault, fast.fault_size_in, fast.load_hp, fast.rate_hz, fast.end) == ("inner", 0.021, 3, 48000.0, "drive")
    fan = parse_cwru_name("309.mat")
    assert (fan.fault, fan.fault_size_in, fan.position, fan.load_hp) == ("outer", 0.014, "3", 1)
    assert (fan.rate_hz, fan.end, fan.bearing) == (12000.0, "fan", "cwru_6203")
    assert (parse_cwru_name("97.mat").fault, parse_cwru_name("97.mat").rate_hz) == ("normal", None)  # its rate in doubt
    label = parse_cwru_name("OR021@3_2.mat")
    assert (label.fault, label.fault_size_in, label.position, label.load_hp) == ("outer", 0.021, "3", 2)
    assert (label.record, label.rate_hz, label.end) == (None, None, None)
    assert (parse_cwru_name("Normal_3.mat").fault, parse_cwru_name("b028_1.MAT").fault_size_in) == ("normal", 0.028)


def test_a_labels_record_is_read_from_its_variables_with_the_names_load(tmp_path):
    """A label names no record: the file's own variables are read, its load gives the nominal speed where the file
    states none, and a note says that the rate and the bearing's end are the defaults, checked. A measured speed of
    another load than the name's is noted."""
    import scipy.io

    samples = np.random.default_rng(4).standard_normal((24000, 1))
    scipy.io.savemat(tmp_path / "B028_1.mat", {"X053_DE_time": samples})
    recording = load_recording(tmp_path / "B028_1.mat")
    assert (recording.rpm, recording.fault, recording.meta["record"], recording.meta["fault_size_in"]) == (1772.0, "ball", 53, 0.028)
    assert any("states no rate and no bearing end" in note for note in recording.meta["notes"])
    scipy.io.savemat(tmp_path / "IR021_2.mat", {"X211_DE_time": samples, "X211RPM": 1797.0})
    mislabelled = load_recording(tmp_path / "IR021_2.mat")
    assert mislabelled.rpm == 1797.0
    assert any("1797 rpm, is not the Data Center's 1750 rpm for the 2 hp" in note for note in mislabelled.meta["notes"])
    scipy.io.savemat(tmp_path / "IR021_3.mat", {"X212_DE_time": samples, "X212RPM": 1725.0})  # 3 hp's measured speed
    assert not any("is not the Data Center's" in note for note in load_recording(tmp_path / "IR021_3.mat").meta["notes"])
    scipy.io.savemat(tmp_path / "400.mat", {"X400_DE_time": samples, "X400RPM": 1797.0})
    assert any("record 400 is not in the Data Center's catalogue: read as a drive-end record declared at 12 kHz" in note
               for note in load_recording(tmp_path / "400.mat").meta["notes"])


@needs_data
def test_a_48_khz_record_named_by_its_number_is_read_at_48_khz(tmp_path):
    """The Data Center's 48 kHz drive-end files are named by number as its 12 kHz ones are (``110.mat``: the inner
    race's 0.007 in spall at 1 hp): read at 48 kHz, the rate its shaft line bears out. Stand-in: record 106, the same
    condition at 12 kHz, resampled to 48 kHz."""
    import scipy.io
    from scipy.signal import resample_poly

    twelve = load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat")
    scipy.io.savemat(tmp_path / "110.mat", {"X110_DE_time": resample_poly(twelve.signal, 4, 1)[:, None],
                                            "X110RPM": twelve.rpm})
    recording = load_cwru(tmp_path / "110.mat")
    assert (recording.fs, recording.fault, recording.meta["fault_size_in"], recording.meta["load_hp"]) == (
        48000.0, "inner", 0.007, 1)
    assert load_recording(tmp_path / "110.mat").fs == 48000.0
    assert recording.meta["shaft_line"]["matches"]
    given = load_recording(tmp_path / "110.mat", fs=12000, fs_key="measured.fs").meta["notes"]
    assert "measured.fs=12000 Hz given, where the Data Center's catalogue lists record 110 at 48000 Hz" in given


@needs_data
def test_a_rate_given_against_the_one_a_cwru_name_states_is_noted_beside_any_verdict(tmp_path):
    """A 12k_ file read at another rate: the name is a data set's convention, not the file's statement, so the rate is
    not refused for it, but it is said, beside a refusal (whose own suggestion may be another wrong rate: record 130
    read at 24 kHz shows a cage-order series where the shaft's belongs) and beside a rate the shaft line bears out."""
    from bearingtwin.cli.inspect import summarize

    path = CWRU / "12k_Drive_End_OR007@6_0_130.mat"
    note = "measured.fs=24000 Hz given, where its name states 12000 Hz"
    assert note in load_recording(path, fs=24000, fs_key="measured.fs").meta["notes"]
    assert not any("given, where" in n for n in load_recording(path, fs=12000, fs_key="measured.fs").meta["notes"])
    assert not any("given, where" in n for n in load_recording(path).meta["notes"])
    assert "fs=29904 Hz given, where its name states 12000 Hz" in summarize(path, fs=29904)["meta"]["notes"]
    assert not any("given, where" in n for n in summarize(path)["meta"]["notes"])


def test_declared_rate_per_record_then_the_name_then_the_default():
    assert declared_fs_hz("normal_0_97.mat", 12000, {97: 48000}) == 48000
    assert declared_fs_hz("12k_Drive_End_IR007_0_105.mat", 48000, {"97": 48000}) == 12000  # the name's, not data.fs
    # A name that states its rate is read at it whatever data.fs says; data.fs_by_record still overrides it.
    assert declared_fs_hz("48k_Drive_End_IR007_0_109.mat", 12000) == 48000
    assert declared_fs_hz("110.mat", 12000) == 48000 and declared_fs_hz("110.mat", 12000, {110: 12000}) == 12000
    assert declared_fs_hz("IR007_0.mat", 25600) == 25600  # a Data Center label states no rate
    assert declared_fs_hz("400.mat", 12000, {400: 48000}) == 48000  # a number the catalogue lacks: still its record


@needs_data
def test_training_on_48k_records_reads_them_at_the_rate_their_names_state(tmp_path):
    """data=cwru with files of the 48 kHz drive-end set: data.fs (12 kHz) is the rate of names that state none."""
    import scipy.io
    from scipy.signal import resample_poly

    from bearingtwin.config import compose_config
    from bearingtwin.data.real import build_cwru_dataset

    for source in ("12k_Drive_End_IR007_1_106", "12k_Drive_End_OR007@6_1_131"):
        twelve = load_cwru(CWRU / f"{source}.mat")
        record = int(source.rpartition("_")[2])
        name = source.replace("12k", "48k")
        scipy.io.savemat(tmp_path / f"{name}.mat", {f"X{record}_DE_time": resample_poly(twelve.signal, 4, 1)[:, None],
                                                    f"X{record}RPM": twelve.rpm})
    cfg = compose_config("train", ["data=cwru", f"data.root={tmp_path}", "data.load=1", "data.classes=[inner,outer]",
                                   "data.files.inner=48k_Drive_End_IR007", "data.files.outer=48k_Drive_End_OR007@6",
                                   "data.samples_per_class=4"])
    dataset = build_cwru_dataset(cfg.data)
    assert dataset.fs == 48000.0 and dataset.windows.shape == (8, 2048)


def strongest_envelope_line_hz(recording, low_hz=10.0, high_hz=400.0):
    freqs, amplitude = envelope_spectrum(recording.signal, recording.fs, window="hann")
    band = (freqs > low_hz) & (freqs < high_hz)
    return freqs[band][np.argmax(amplitude[band])]


@needs_data
@pytest.mark.parametrize("name,order", [("12k_Drive_End_OR007@6_0_130.mat", BPFO_ORDER), ("12k_Drive_End_IR007_0_105.mat", BPFI_ORDER)])
def test_envelope_spectrum_shows_the_defect_frequency(name, order):
    recording = load_cwru(CWRU / name)
    shaft_hz = recording.rpm / 60
    assert strongest_envelope_line_hz(recording) / shaft_hz == pytest.approx(order, rel=0.01)


@needs_data
def test_record_facts_come_from_file_and_name():
    recording = load_cwru(CWRU / "12k_Drive_End_IR007_0_105.mat", channel="FE")
    assert (recording.rpm, recording.fault, recording.channel, recording.unit) == (1797.0, "inner", "FE", "g")
    assert recording.meta["record"] == 105 and recording.meta["load_hp"] == 0
    assert recording.fs == 12000 and recording.signal.size == 121265
    assert recording.meta["shaft_line"]["matches"]
    default = load_recording(CWRU / "12k_Drive_End_IR007_0_105.mat")  # no channel asked for: the drive end
    assert default.channel == "DE" and not np.array_equal(default.signal, recording.signal)


@needs_data
@pytest.mark.parametrize("path", sorted(CWRU.glob("*.mat")), ids=lambda p: p.name)
def test_every_record_matches_its_declared_12_khz(path):
    recording = load_cwru(path)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    check = check_sampling_rate(recording.signal, recording.fs, recording.rpm, defect_hz=defect_hz)
    assert check.matches and check.observed_hz == pytest.approx(recording.rpm / 60, rel=0.005)
    # The healthy record has lines at half orders too, and no defect line to settle what they mean.
    assert check.verdict == ("ambiguous" if recording.fault == "normal" else "consistent"), check.reason


@needs_data
@pytest.mark.parametrize("factor", [2, 3, 5, 10])
@pytest.mark.parametrize("path", sorted(CWRU.glob("12k_*.mat")), ids=lambda p: p.name)
def test_a_speed_a_whole_factor_too_high_is_not_confirmed_by_a_harmonic_of_its_defect_line(path, factor):
    """A speed typed a whole factor too high (ten times: a digit too many) puts every defect frequency on a
    harmonic of its true one, and the true shaft series' lines between those of the series expected: a fault
    record's defect line at the wrong frequency is then no witness for the rate, and a race's comb, which stands
    at 1 / factor of it, contradicts it; a speed the refusal names is the true one."""
    recording = load_cwru(path)
    rpm = recording.rpm * factor
    check = check_sampling_rate(recording.signal, recording.fs, rpm,
                                defect_hz=load_bearing("cwru_6205").defect_frequencies(rpm))
    # A race's comb stands out in the envelope; a ball's (records 118-121) often does not, and may leave it in doubt.
    assert check.verdict == "contradicted" if recording.fault in ("inner", "outer") else check.verdict != "consistent"
    speed = re.search(r"a speed of (\d+) rpm", check.reason)
    assert speed is None or float(speed.group(1)) == pytest.approx(recording.rpm, rel=0.01), check.reason


@needs_data
def test_a_record_at_four_times_its_declared_rate_is_followed_to_its_true_rate():
    """An inner race's record resampled to 48 kHz and declared at 12: its shaft series' in-between lines and its BPFI
    line at half its place name 24 kHz, where they stand at half their places again. The rate named is checked in
    turn and followed to 48 kHz; it had named 24 kHz, and only a second run at that rate named the true one."""
    import scipy.signal

    recording = load_cwru(CWRU / "12k_Drive_End_IR007_1_106.mat")
    at_48k = scipy.signal.resample_poly(recording.signal, 4, 1)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    check = check_sampling_rate(at_48k, 12000.0, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "contradicted" and check.implied_fs_hz == pytest.approx(48000.0, rel=0.005), check.reason
    assert "a rate of 24000 Hz; at 24000 Hz, the shaft series also stands between its harmonics" in check.reason
    assert check_sampling_rate(at_48k, 48000.0, recording.rpm, defect_hz=defect_hz).verdict == "consistent"


@needs_data
@pytest.mark.parametrize("declared", [8000.0, 18000.0])
@pytest.mark.parametrize("path", sorted(CWRU.glob("12k_*_[IO]R007*.mat")), ids=lambda p: p.name)
def test_a_races_comb_read_as_the_other_races_under_a_wrong_rate_does_not_confirm_it(path, declared):
    """The SKF 6205's BPFI is 1.51 times its BPFO: declared at 2/3 of its rate, an inner race's comb stands at
    BPFO's place, and at 3/2 an outer race's at BPFI's, each a defect line with its harmonics where the declared rate
    expects one. The shaft's line stands where the true rate puts it, not at its place, and tells the two readings
    apart: the rate is refused, and where the comb's other reading refuses it, the true rate is named."""
    recording = load_cwru(path, check_fs=False)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    check = check_sampling_rate(recording.signal, declared, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "contradicted", check.reason
    if check.witness == "comb":
        assert check.implied_fs_hz == pytest.approx(12000, rel=0.01), check.reason


@needs_data
@pytest.mark.parametrize("record, declared, verdict", [
    ("12k_Drive_End_IR007_0_105.mat", 6000, "contradicted"),
    ("12k_Drive_End_OR007@6_0_130.mat", 4000, "contradicted"),
    ("12k_Drive_End_OR007@6_0_130.mat", 6000, "contradicted"),  # its BPFO comb stands at half its place
])
def test_a_whole_fraction_of_the_true_rate_is_not_taken_for_it(record, declared, verdict):
    """Every k-th line of the true shaft series lands on the expected one, which still "matches";
    the lines in between and the defect lines tell."""
    recording = load_cwru(CWRU / record, check_fs=False)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    assert check_sampling_rate(recording.signal, declared, recording.rpm).verdict == "ambiguous"  # no second witness
    check = check_sampling_rate(recording.signal, declared, recording.rpm, defect_hz=defect_hz)
    assert check.matches and check.fraction == 12000 // declared and check.verdict == verdict
    if verdict == "contradicted":
        assert check.implied_fs_hz == 12000
        with pytest.raises(BearingTwinError, match=rf"{record}: fs = {declared} Hz contradicts .* belongs? at a rate of 12000 Hz"):
            load_cwru(CWRU / record, fs=declared, bearing=load_bearing("cwru_6205"))


@needs_data
@pytest.mark.parametrize("record, declared", [
    ("12k_Drive_End_IR007_1_106.mat", 5850),
    ("12k_Drive_End_IR007_3_108.mat", 5760),
    ("12k_Drive_End_IR007_3_108.mat", 6240),
    ("12k_Drive_End_OR007@6_3_133.mat", 5760),
    ("12k_Drive_End_OR007@6_3_133.mat", 4080),
])
def test_a_rate_near_a_whole_fraction_of_the_true_one_is_refused_naming_the_true_one(record, declared):
    """A rate a few per cent from half (or a third) of the true one puts the supply's 60 Hz series, or the
    shaft's own 2x series, within the match's tolerance of the shaft's place. The shaft's own series then
    stands between that series' harmonics, a motor's slip from where half the rate would put it, and the
    envelope's defect line stands where that rate puts it: the rate is refused with the true one named,
    directly or through the rate the nearest series implies."""
    recording = load_cwru(CWRU / record, check_fs=False)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    check = check_sampling_rate(recording.signal, declared, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "contradicted", check.reason
    assert check.implied_fs_hz == pytest.approx(12000, rel=0.005), check.reason
    alone = check_sampling_rate(recording.signal, declared, recording.rpm)  # no defect line to decide
    assert alone.verdict != "consistent", alone.reason


@needs_data
def test_a_record_read_at_about_half_its_rate_names_its_true_rate():
    """A 2 s CWRU record resampled to 25.6 kHz and declared at 12 kHz (a user's recorder set otherwise):
    the nearest strong series implies 12.3 kHz, at which the shaft's series would stand between the
    harmonics of the supply's; the defect lines name the true 25.6 kHz."""

    recording = load_cwru(CWRU / "12k_Drive_End_IR007_3_108.mat", check_fs=False)
    at_25k6 = scipy.signal.resample_poly(recording.signal, 32, 15)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    assert check_sampling_rate(at_25k6, 25600, recording.rpm, defect_hz=defect_hz).verdict == "consistent"
    check = check_sampling_rate(at_25k6, 12000, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "contradicted"
    assert check.implied_fs_hz == pytest.approx(25600, rel=0.005), check.reason
    assert "belong" in check.reason and "at a rate of 256" in check.reason


@needs_data
def test_training_on_cwru_at_half_the_rate_is_refused():
    from bearingtwin.config import compose_config
    from bearingtwin.data.real import build_cwru_dataset

    # The fault records' names state 12 kHz, which data.fs does not override: data.fs_by_record does.
    cfg = compose_config("train", ["data=cwru", "+data.fs_by_record.105=6000", f"data.root={CWRU}"])
    with pytest.raises(BearingTwinError, match="fs = 6000 Hz contradicts"):
        build_cwru_dataset(cfg.data)


@needs_data
def test_record_97_declared_at_48_khz_is_contradicted():
    with pytest.raises(BearingTwinError, match=r"normal_0_97.mat: fs = 48000 Hz contradicts the shaft speed.*fs_by_record.97"):
        load_cwru(CWRU / "normal_0_97.mat", fs=48000)
    unchecked = load_cwru(CWRU / "normal_0_97.mat", fs=48000, check_fs=False)
    assert unchecked.fs == 48000 and not unchecked.meta["shaft_line"]["matches"]


@needs_data
def test_a_defect_frequency_on_a_shaft_harmonic_is_no_witness_of_the_rate():
    """Record 97's fan-end channel read for the SKF 6203: its shaft series stands between its harmonics too,
    and the 6203's BSF (1.994 x shaft) has its half on the shaft line, so that line said nothing about the
    ball and still 'stood at half its frequency', refusing 12 kHz. Such a frequency witnesses nothing."""
    recording = load_cwru(CWRU / "normal_0_97.mat", channel="FE", check_fs=False)
    defect_hz = load_bearing("cwru_6203").defect_frequencies(recording.rpm)
    check = check_sampling_rate(recording.signal, 12000, recording.rpm, defect_hz=defect_hz)
    assert check.verdict != "contradicted", check.reason


@needs_data
@pytest.mark.parametrize("record", ["12k_Drive_End_IR007_0_105.mat", "12k_Drive_End_OR007@6_1_131.mat"])
def test_a_defect_line_at_its_frequency_witnesses_the_rate_where_the_shaft_series_is_weak(record):
    """The fan-end channel of a drive-end fault record shows a stronger series than the shaft's (40-58 Hz):
    the envelope's defect line at its own frequency (and not at a half, third or quarter of it) keeps the
    true 12 kHz; at twice or four times the rate nothing stands where it belongs, and the rate is contradicted."""
    recording = load_cwru(CWRU / record, channel="FE", check_fs=False)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    alone = check_sampling_rate(recording.signal, 12000, recording.rpm)
    assert alone.verdict == "contradicted" and not alone.matches  # the shaft series alone does not tell
    check = check_sampling_rate(recording.signal, 12000, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "consistent" and check.implied_fs_hz == 12000
    assert f"the envelope lines of {'bpfi' if 'IR' in record else 'bpfo'} and its second harmonic" in check.reason
    for wrong in (24000, 48000):
        assert check_sampling_rate(recording.signal, wrong, recording.rpm, defect_hz=defect_hz).verdict == "contradicted"
    # The fan-end bearing's ball spin frequency is 1.994 x shaft: at twice the rate the shaft's own line
    # stands there, and is no witness.
    fan_end = load_bearing("cwru_6203").defect_frequencies(recording.rpm)
    assert check_sampling_rate(recording.signal, 24000, recording.rpm, defect_hz=fan_end).verdict == "contradicted"


def test_a_channel_showing_the_rate_too_low_overrules_one_that_seems_consistent():
    """A channel's other lines can pass for the shaft series at a fraction of the true rate; a defect line
    at 1/k of its frequency in another channel overrules it, and lines between the shaft harmonics leave the
    record ambiguous unless a defect line showed them to be real subharmonics."""
    def check(verdict, fraction=None):
        return ShaftLineCheck(6000.0, 1797.0, 29.95, 29.95, None, 30.0, True, verdict, fraction)

    assert decisive_channel({"FE": check("consistent"), "DE": check("contradicted", 2)}) == "DE"
    assert decisive_channel({"FE": check("consistent"), "DE": check("ambiguous", 2)}) == "DE"
    assert decisive_channel({"FE": check("consistent"), "DE": check("ambiguous", 2), "BA": check("consistent", 2)}) == "FE"
    assert decisive_channel({"FE": check("contradicted"), "DE": check("consistent")}) == "DE"
    assert decisive_channel({"FE": check("contradicted"), "DE": check("ambiguous")}) == "DE"


def test_a_series_at_a_defect_frequency_is_outweighed_by_a_shaft_series_a_whole_factor_from_its_place():
    """A channel confirmed only by a series that stands on a defect frequency loses to another channel whose shaft
    series stands at twice its place (a wrong rate puts some series on a defect line by chance); against a
    contradiction at no whole factor, or alone, it stands."""
    def check(verdict, observed, witness=None):
        return ShaftLineCheck(24000.0, 1796.0, 29.93, observed, None, 30.0, False, verdict, None, witness=witness)

    by_series = check("consistent", 107.61, witness="series")
    assert decisive_channel({"FE": by_series, "DE": check("contradicted", 59.86)}) == "DE"
    assert decisive_channel({"FE": by_series, "DE": check("contradicted", 41.3)}) == "FE"
    assert decisive_channel({"FE": by_series}) == "FE"


def test_a_channel_confirmed_by_a_defect_line_alone_is_outweighed_by_a_refusal_naming_a_rate_it_confirms():
    """A defect line can stand where a wrong rate expects one (by chance, or another defect's under that rate): a
    channel whose refusal names a rate at which its own shaft series stands at its place outweighs it; a refusal
    whose rate is not confirmed does not, nor against a channel whose shaft series confirms the rate."""
    def check(verdict, witness=None, matches=False, confirmed=False):
        return ShaftLineCheck(8000.0, 1797.0, 29.95, 19.96, None if verdict != "contradicted" else 12006.0, 30.0,
                              matches, verdict, None, witness=witness, implied_confirmed=confirmed)

    by_envelope, by_series = check("consistent", witness="envelope"), check("consistent", witness="series")
    assert decisive_channel({"FE": by_envelope, "DE": check("contradicted", confirmed=True)}) == "DE"
    assert decisive_channel({"FE": by_series, "DE": check("contradicted", witness="comb", confirmed=True)}) == "DE"
    assert decisive_channel({"FE": by_envelope, "DE": check("contradicted")}) == "FE"
    by_shaft = check("consistent", matches=True)
    assert decisive_channel({"FE": by_shaft, "DE": check("contradicted", confirmed=True)}) == "FE"


def test_a_refusal_no_other_channel_confirms_does_not_outweigh_a_defect_witness_at_the_true_rate():
    """At its true rate a file may show no shaft series: one channel a race's impacts (confirmed by them alone), another
    some machine element's harmonic series, which refuses the rate naming the one at which it would be the shaft's.
    Read at that rate, that series stands at the shaft's place by construction; no other channel's does, so the
    refusal does not outweigh the impacts' witness, and the file's rate stands."""
    fs, rpm, seconds = 12000.0, 1797.0, 10.0
    bearing = load_bearing("cwru_6205")
    rng = np.random.default_rng(0)
    t = np.arange(int(fs * seconds)) / fs
    pulses = np.diff(np.floor(t * bearing.defect_frequencies(rpm)["bpfo"]), prepend=0.0)
    impacts = scipy.signal.sosfilt(scipy.signal.butter(2, [2500, 3500], "bandpass", fs=fs, output="sos"), pulses)
    element_hz = 2.63 * rpm / 60  # no whole order of the shaft
    element = sum(np.sin(2 * np.pi * m * element_hz * t) / m for m in range(1, 9))
    channels = {"DE": impacts + 1e-3 * impacts.std() * rng.standard_normal(t.size),
                "FE": element + 1e-3 * rng.standard_normal(t.size)}
    checks = check_channels(channels, fs, rpm, defect_hz=bearing.defect_frequencies(rpm))
    assert checks["DE"].verdict == "consistent" and checks["DE"].witness in ("series", "envelope"), checks["DE"].reason
    assert checks["FE"].verdict == "contradicted" and not checks["FE"].implied_confirmed, checks["FE"].reason
    assert checks[decisive_channel(checks)].verdict == "consistent"


def test_a_noiseless_twin_record_of_a_healthy_bearing_is_not_refused_at_its_own_rate():
    """The twin's own records are noiseless: over the median of bins at the arithmetic's precision every leakage skirt
    of its ball-pass lines stood as a prominent line, and a series at 21.6 Hz refused the healthy record's true rate
    (the README's "Your own recordings" folder). Floored far below any recorder's range, the spectrum reads its
    ball-pass series as the bearing's, and the rate stands."""
    from omegaconf import OmegaConf

    from bearingtwin.config import CONF_DIR, bearing_config
    from bearingtwin.physics.simulator import simulate

    simulator = OmegaConf.to_container(OmegaConf.load(Path(CONF_DIR) / "simulator" / "default.yaml"))
    simulator.update(fs=12000.0, duration=4.0)
    recording, _ = simulate("normal", bearing_config("paper"), simulator)
    check = check_sampling_rate(recording.signal, 12000.0, recording.rpm,
                                defect_hz=load_bearing("paper").defect_frequencies(recording.rpm))
    assert check.verdict == "consistent", check.reason


@needs_data
@pytest.mark.parametrize("record, declared", [("12k_Drive_End_IR007_0_105.mat", 8000.0),
                                              ("12k_Drive_End_OR007@6_0_130.mat", 18000.0)])
def test_a_file_whose_channels_disagree_is_refused_where_one_names_a_rate_it_confirms(record, declared):
    """Read with its three channels at 2/3 (3/2) of its rate, the fan-end channel of an inner-race (outer-race) record
    is confirmed by the other race's envelope comb alone, while the drive end refuses the rate naming the true one:
    the file is refused, naming 12 kHz."""
    with pytest.raises(BearingTwinError, match=r"12\d{3} Hz") as refusal:
        load_cwru(CWRU / record, fs=declared, bearing=load_bearing("cwru_6205"))
    assert f"{declared:g}" in str(refusal.value)


@needs_data
@pytest.mark.parametrize("record", ["12k_Drive_End_OR007@6_0_130.mat", "12k_Drive_End_IR007_0_105.mat"])
@pytest.mark.parametrize("declared", [44100.0, 48000.0, 51200.0])
def test_a_refusal_names_a_rate_the_record_does_not_refuse_in_turn(record, declared):
    """A refusal's rate is read off the strong series nearest the shaft's place, which may be another series; the
    record is read again at each rate named so, and one it refuses in turn is followed to the rate it names (record
    130 at 48 kHz names 13.1 kHz, where it is refused naming 12.1 kHz): the rate named is one the record, read at
    it, confirms, here within 1 % of its true 12 kHz."""
    raw = read_raw(CWRU / record)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(raw.rpm)
    checks = check_channels(raw.channels, declared, raw.rpm, defect_hz=defect_hz)
    check = checks[decisive_channel(checks)]
    assert check.verdict == "contradicted" and check.implied_fs_hz == pytest.approx(12000, rel=0.01), check.reason
    again = check_channels(raw.channels, check.implied_fs_hz, raw.rpm, defect_hz=defect_hz)
    assert again[decisive_channel(again)].verdict == "consistent"


@needs_data
def test_readings_that_lead_back_to_the_declared_rate_do_not_contradict_it():
    """2 s of record 105 with no defect frequency to decide: its shaft series is weak at the declared 12 kHz, the strong
    series nearest its place (226.7 Hz) read as the shaft's puts the rate at 1585 Hz, and there the in-between lines
    put it back at 12 kHz. A rate its readings lead back to is in doubt, not refused (the whole record confirms it)."""
    recording = load_cwru(CWRU / "12k_Drive_End_IR007_0_105.mat")
    check = check_sampling_rate(recording.signal[:24000], 12000.0, recording.rpm)
    assert check.verdict == "ambiguous" and check.implied_fs_hz is None, check.reason
    assert check.reason.endswith("the readings lead back to the declared 12000 Hz, which none contradicts")
    assert check_sampling_rate(recording.signal, 12000.0, recording.rpm).verdict == "consistent"


@needs_data
def test_a_wrong_rate_implies_the_true_one():
    recording = load_cwru(CWRU / "12k_Drive_End_OR007@6_0_130.mat")
    check = check_sampling_rate(recording.signal, 11000.0, recording.rpm)
    assert not check.matches
    assert check.implied_fs_hz == pytest.approx(12000, rel=0.01)


@needs_data
def test_missing_or_unknown_channel_is_named():
    with pytest.raises(BearingTwinError, match=r"normal_0_97.mat: no channel 'BA'; the file holds channels DE, FE"):
        load_cwru(CWRU / "normal_0_97.mat", channel="BA")
    with pytest.raises(BearingTwinError, match="channel='XY' is not a CWRU channel"):
        load_cwru(CWRU / "normal_0_97.mat", channel="XY")


def test_shaft_line_of_a_synthetic_record():
    fs, rpm = 10000.0, 1500.0
    t = np.arange(int(20 * fs)) / fs
    rng = np.random.default_rng(0)
    signal = sum(np.sin(2 * np.pi * k * rpm / 60 * t) / k for k in range(1, 13)) + rng.standard_normal(t.size)
    assert check_sampling_rate(signal, fs, rpm).verdict == "consistent"
    halved = check_sampling_rate(signal, fs / 2, rpm)  # lines 1, 3, 5 now fall between the expected ones
    assert halved.matches and halved.fraction == 2 and halved.verdict == "ambiguous"
    assert "fs may be 10000 Hz (2 times 5000 Hz), or the machine makes lines between its shaft orders" in halved.reason
    doubled = check_sampling_rate(signal, 2 * fs, rpm)
    assert not doubled.matches and doubled.implied_fs_hz == pytest.approx(fs, rel=0.01)
    with pytest.raises(BearingTwinError, match="too short"):
        check_sampling_rate(signal[:1000], fs, rpm)


@pytest.mark.parametrize("rpm,seed", [(1750.0, 7), (1730.0, 8)])
def test_a_defect_comb_and_the_shaft_line_both_off_by_one_factor_refuse_the_rate_and_name_the_true_one(rpm, seed):
    """The independent test rig's ball records (impacts through its own path; a residual unbalance its only shaft
    line) read at 0.8 times their rate: no shaft series settles it, but the envelope's 2 x BSF comb and the shaft's
    line both stand 0.8 times their places, and the record read at the rate they imply is confirmed there:
    refused, naming the true rate. At the true rate it passes; a healthy record, with no comb, is left in doubt."""
    defect_hz = load_bearing("cwru_6205").defect_frequencies(rpm)
    op = RigOperatingPoint(rpm=rpm, fs=12000.0, duration_s=4.0)
    signal = simulate_rig("ball", op, seed=seed)
    misread = check_sampling_rate(signal, 9600.0, rpm, defect_hz=defect_hz)
    assert misread.verdict == "contradicted" and misread.witness == "comb", misread.reason
    assert misread.implied_fs_hz == pytest.approx(12000.0, rel=0.01), misread.reason
    assert re.search(r"the envelope's 2 x BSF comb stands at 0\.(79|80)\d* times its frequency", misread.reason)
    assert check_sampling_rate(signal, 12000.0, rpm, defect_hz=defect_hz).verdict == "consistent"
    healthy = check_sampling_rate(simulate_rig("normal", op, seed=seed), 9600.0, rpm, defect_hz=defect_hz)
    assert healthy.verdict == "ambiguous" and healthy.implied_fs_hz is None, healthy.reason


@needs_data
def test_a_shaft_series_standing_weakly_at_its_place_leaves_the_rate_in_doubt_where_a_stronger_one_stands_elsewhere():
    """5 s of the healthy record at its true rate and speed had been refused as 4016 Hz: a series of its 3x lines
    stood higher than its own, which stood at its place (1x 32 times its floor). That is left in doubt. The same lines
    read under a rate twice too low put the true shaft's series at half the place, and its 2x at it: still refused."""
    recording = load_cwru(CWRU / "normal_0_97.mat")
    cut = recording.signal[:5 * 12000]
    bearing = load_bearing("cwru_6205")
    doubt = check_sampling_rate(cut, 12000.0, recording.rpm, defect_hz=bearing.defect_frequencies(recording.rpm))
    assert doubt.verdict == "ambiguous" and doubt.witness == "weak shaft series", doubt.reason
    assert "but the shaft's own series stands where the declared rate puts it, weaker" in doubt.reason
    halved = check_sampling_rate(cut, 6000.0, recording.rpm, defect_hz=bearing.defect_frequencies(recording.rpm))
    assert halved.verdict == "contradicted", halved.reason


@needs_data
@pytest.mark.parametrize("record, snr_db, seed", [("12k_Drive_End_OR007@6_0_130.mat", 40, [8, 40]),
                                                  ("12k_Drive_End_OR007@6_0_130.mat", 30, [8, 30]),
                                                  ("12k_Drive_End_OR007@6_2_132.mat", 40, [10, 40])])
def test_a_loggers_noise_floor_leaves_the_true_rate_in_doubt_not_refused(record, snr_db, seed):
    """White noise 30-40 dB below an outer-race record's RMS buries its shaft series (a few milli-g); a series at half
    the BPFO, with no line of its own at its fundamental, then stood nearest the shaft's place and the true rate was
    refused as 0.56 times too high. Its envelope's BPFO comb stands at BPFO, not at half it: the rate is now in doubt,
    the shaft's series not seen. Read at exactly half its rate (the comb itself at half its frequency) record 130 is
    still refused."""
    recording = load_cwru(CWRU / record, check_fs=False)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    noise = np.random.default_rng(seed).standard_normal(recording.signal.size)  # draws of benchmarks/rate_check.py
    noisy = recording.signal + noise * np.std(recording.signal) * 10 ** (-snr_db / 20)
    check = check_sampling_rate(noisy, 12000.0, recording.rpm, defect_hz=defect_hz)
    assert check.verdict == "ambiguous" and check.witness == "half comb", check.reason
    assert "lies at half the bearing's BPFO" in check.reason
    assert check_sampling_rate(recording.signal, 12000.0, recording.rpm, defect_hz=defect_hz).verdict == "consistent"
    if snr_db == 30:  # the comb itself at half its frequency, its envelope comb too: a rate exactly twice too low
        assert check_sampling_rate(noisy, 6000.0, recording.rpm, defect_hz=defect_hz).verdict == "contradicted"


@pytest.mark.parametrize("factor", [1.25, 0.8, 0.5])
def test_a_strong_series_off_the_shafts_place_is_named_in_both_its_readings_where_the_record_bears_both(factor):
    """The test rig's outer-race record (a residual 1x its only shaft line; the impacts a sharp series in the
    spectrum itself) read at a wrong rate: its strongest series, read as the shaft's, names a rate 3.6 times too
    low; read as BPFO's, the true rate, where a line stands at the shaft's 1x. The spectrum alone cannot tell a
    lone 1x under a race's series from a line below a shaft series (a belt's, a whirl's), so the refusal names
    the shaft reading's rate and says the other. A line at 2 x supply is no 1x (at twice the rate here)."""
    rpm = 1797.0
    defect_hz = load_bearing("cwru_6205").defect_frequencies(rpm)
    signal = simulate_rig("outer", RigOperatingPoint(rpm=rpm, fs=12000.0, duration_s=4.0))
    check = check_sampling_rate(signal, 12000.0 * factor, rpm, defect_hz=defect_hz)
    assert check.verdict == "contradicted" and check.implied_fs_hz == pytest.approx(3360.0, rel=0.01), check.reason
    other = re.search(r"if it is the shaft's series; read as BPFO's, it puts fs at (\d+) Hz, where the line standing "
                      r"near [\d.]+ Hz would be the shaft's 1x", check.reason)
    assert other and float(other.group(1)) == pytest.approx(12000.0, rel=0.01), check.reason
    # A diagnosis' note gives the speed of both readings, the defect's first: it had named the shaft reading's alone
    # (3.6 times the true speed) right after saying the series may be BPFO's.
    from bearingtwin.diagnosis.record import _speed_or_rate_wrong

    name, line_hz = check.defect_reading
    assert name == "BPFO" and line_hz == pytest.approx(rpm / 60 * factor, rel=0.01)  # the 1x, read at the rate given
    note = _speed_or_rate_wrong(check)
    assert (f"the line near {line_hz:.1f} Hz says {60 * line_hz:.0f} rpm if the series is BPFO's, "
            f"{rpm * check.fs_hz / check.implied_fs_hz:.0f} rpm if it is the shaft's") in note, note
    supply = check_sampling_rate(signal, 24000.0, rpm, defect_hz=defect_hz)  # its 1x would read at 59.6 Hz
    assert supply.verdict == "contradicted" and "read as" not in supply.reason, supply.reason
    # A shaft series at twice its rate, a line below it where BPFO's reading would put the 1x: the named rate
    # stays the shaft's series'.
    t = np.arange(int(20 * 10000.0)) / 10000.0
    below = 25.0 / (defect_hz["bpfo"] / defect_hz["shaft"])
    shaft = sum(np.sin(2 * np.pi * k * 25.0 * t) / k for k in range(1, 13)) + 0.5 * np.sin(2 * np.pi * below * t)
    noise = np.random.default_rng(0).standard_normal(t.size)
    doubled = check_sampling_rate(shaft + noise, 20000.0, 1500.0,
                                  defect_hz=load_bearing("cwru_6205").defect_frequencies(1500.0))
    assert doubled.implied_fs_hz == pytest.approx(10000.0, rel=0.01), doubled.reason


def test_a_motors_pull_in_the_envelope_and_another_line_do_not_refuse_a_right_rate():
    """Noise modulated at twice a 60 Hz supply (a motor's magnetic pull) puts a comb in the envelope at 120 and
    240 Hz, which a defect comb a factor off its place could read as; with another element's line standing that
    same factor off the shaft's place the two would agree. Lines the declared rate explains as the supply's are no
    comb elsewhere: the right rate is left in doubt, not refused."""
    fs, rpm = 12000.0, 1797.0
    rng = np.random.default_rng(0)
    t = np.arange(int(8 * fs)) / fs
    signal = rng.standard_normal(t.size) * (1 + 0.8 * np.sin(2 * np.pi * 120.0 * t)) + 2.0 * np.sin(2 * np.pi * 33.4 * t)
    check = check_sampling_rate(signal, fs, rpm, defect_hz=load_bearing("cwru_6205").defect_frequencies(rpm))
    assert check.verdict == "ambiguous" and check.implied_fs_hz is None and "comb" not in check.reason, check.reason


def test_a_record_without_any_harmonic_series_leaves_its_rate_unconfirmed_not_contradicted():
    """No shaft series near the expected line and none anywhere within 25 times of it (a machine without
    unbalance, a simulation): nothing contradicts the declared rate. A series 7 times too high does."""
    fs, rpm = 12000.0, 1800.0
    t = np.arange(int(10 * fs)) / fs
    rng = np.random.default_rng(1)
    noise = rng.standard_normal(t.size)
    alone = check_sampling_rate(noise + 0.02 * np.sin(2 * np.pi * 30.0 * t), fs, rpm)  # one weak line, no series
    assert alone.verdict == "ambiguous" and alone.observed_hz is None and alone.implied_fs_hz is None
    assert "nothing to check the rate against" in alone.reason
    lone = check_sampling_rate(noise + 3.0 * np.sin(2 * np.pi * 30.0 * t), fs, rpm)  # unbalance alone, no harmonics
    assert lone.verdict == "ambiguous" and "a lone line stands at 30.00 Hz" in lone.reason, lone.reason
    # A speed given 3 % high puts the search window on the line's skirt: the line is named where its peak stands, with
    # the speed that would put the shaft's line there (it had been said to stand at 30.85 Hz, on the stated place).
    off = check_sampling_rate(noise + 3.0 * np.sin(2 * np.pi * 30.0 * t), fs, 1851.0)
    assert off.verdict == "ambiguous" and ("a lone line without harmonics stands at 30.00 Hz (prominence " in off.reason
                                           and "2.8 % below the shaft line's place at 1851 rpm: if it is the shaft's, "
                                           "the speed is about 1800 rpm (or the rate 12340 Hz)" in off.reason), off.reason
    series = sum(np.sin(2 * np.pi * k * 210.0 * t) / k for k in range(1, 8))  # 7 x the expected 30 Hz
    far = check_sampling_rate(noise + series, fs, rpm)
    assert far.verdict == "contradicted" and far.observed_hz == pytest.approx(210.0, rel=0.005)
    assert far.implied_fs_hz == pytest.approx(fs / 7, rel=0.005)
    # A rate so low that its spectrum cannot hold the search (12 kHz samples declared at 600 Hz) shows
    # nothing, and that is no excuse: contradicted, as before.
    shaft = sum(np.sin(2 * np.pi * k * 30.0 * t) / k for k in range(1, 8))
    assert check_sampling_rate(noise + shaft, 600.0, rpm).verdict == "contradicted"
    # A channel that shows no series at all does not outvote one that contradicts the rate.
    silent = check_sampling_rate(noise, fs, rpm)
    assert decisive_channel({"FE": silent, "DE": far}) == "DE" and decisive_channel({"FE": silent}) == "FE"


def test_a_short_record_without_a_shaft_series_is_not_contradicted_for_its_length():
    """A 2 s record at 1500 rpm resolves no fundamental below 1 Hz, a 25th of the shaft's: the search reaches less
    far below the shaft's place. That is the record's length, not its rate (the Nyquist frequency is far above
    the search), so a record with no shaft series leaves the rate unconfirmed, as a longer one does."""
    fs, rpm = 12000.0, 1500.0
    noise = np.random.default_rng(3).standard_normal(int(2 * fs))
    check = check_sampling_rate(noise, fs, rpm)
    assert check.verdict == "ambiguous" and "nothing to check the rate against" in check.reason, check.reason
    assert "spectrum ends" not in check.reason


def test_a_motors_supply_lines_do_not_contradict_the_rate():
    """A motor's pull at twice the supply (100 Hz and its harmonics on a 50 Hz grid) where no shaft series
    stands: those lines stand there at any rate, so the rate is left unconfirmed, not refused (a 48 kHz record
    at 1730 rpm was refused as 13.9 kHz). A shaft series that a rate off by a whole factor moves onto a supply
    multiple (a 30 Hz shaft's read at four times the rate: 120 Hz, twice 60 Hz) still contradicts it."""
    fs, rpm = 48000.0, 1730.0
    t = np.arange(int(4 * fs)) / fs
    noise = np.random.default_rng(3).standard_normal(t.size)
    supply = sum(3.0 * np.sin(2 * np.pi * k * 100.0 * t) / k for k in range(1, 7))
    check = check_sampling_rate(noise + supply, fs, rpm)
    assert check.verdict == "ambiguous" and check.implied_fs_hz is None, check.reason
    assert "2 x the 50 Hz supply" in check.reason
    # As a command applies it to a rate the user gave (refused when contradicted): kept, the doubt logged.
    assert require_plausible_rate(noise + supply, fs, rpm, "record.csv", "measured.fs").verdict == "ambiguous"
    shaft_read_fast = sum(3.0 * np.sin(2 * np.pi * k * 120.0 * t) / k for k in range(1, 7))
    wrong = check_sampling_rate(noise + shaft_read_fast, fs, 1800.0)
    assert wrong.verdict == "contradicted" and wrong.implied_fs_hz == pytest.approx(fs / 4, rel=0.005)
    # Only the supply and twice it are a supply series' fundamentals: 150 Hz (3 x 50) and 104 Hz are not.
    for other_hz in (150.0, 104.0):
        series = sum(3.0 * np.sin(2 * np.pi * k * other_hz * t) / k for k in range(1, 7))
        assert check_sampling_rate(noise + series, fs, rpm).verdict == "contradicted", other_hz
    # A bearing whose BPFO falls on the supply's pull (an SKF 6205 at 1673 rpm: 99.96 Hz) does not make the
    # supply's series a witness of the rate: it is left unconfirmed.
    defect_hz = load_bearing("cwru_6205").defect_frequencies(1673.0)
    assert defect_hz["bpfo"] == pytest.approx(100.0, rel=0.001)
    assert check_sampling_rate(noise + supply, fs, 1673.0, defect_hz=defect_hz).verdict == "ambiguous"


def test_a_channel_showing_only_the_supply_does_not_outvote_one_that_contradicts_the_rate():
    """A 12.8 kHz record declared at 25.6 kHz: the drive end's shaft series stands at twice its place
    (contradicted), the fan end shows only 50 Hz supply lines, which read as 100 Hz (the supply's pull, so
    ambiguous on their own). The contradiction decides, and a rate the user gave is refused."""
    true_fs, rpm = 12800.0, 1730.0
    t = np.arange(int(4 * true_fs)) / true_fs
    rng = np.random.default_rng(4)
    drive_end = sum(np.sin(2 * np.pi * k * rpm / 60 * t) / k for k in range(1, 8)) + rng.standard_normal(t.size)
    fan_end = sum(3.0 * np.sin(2 * np.pi * k * 50.0 * t) / k for k in range(1, 7)) + rng.standard_normal(t.size)
    checks = check_channels({"DE": drive_end, "FE": fan_end}, 2 * true_fs, rpm)
    assert checks["FE"].verdict == "ambiguous" and checks["FE"].witness == "supply"
    assert checks["DE"].verdict == "contradicted" and decisive_channel(checks) == "DE"
    with pytest.raises(BearingTwinError, match=r"record.csv: fs = 25600 Hz contradicts"):
        require_plausible_rate(drive_end, 2 * true_fs, rpm, "record.csv", "measured.fs",
                               channels={"DE": drive_end, "FE": fan_end})


@pytest.mark.parametrize("bpfo_order", [3.5848, 4.530])
def test_a_defect_comb_where_the_shaft_series_should_be_does_not_contradict_the_rate(bpfo_order):
    """A spalled race on a machine without unbalance: the spectrum's strongest series is the BPFO comb,
    not the shaft's. At the declared rate it stands at the bearing's BPFO (the SKF 6205's 3.5848 orders, a
    6005-like bearing's 4.530), where a rate off by a whole factor puts no shaft series: the rate stands.
    Declared at twice the true rate, the comb stands at half of BPFO, which is no defect frequency."""
    fs, rpm = 20000.0, 1500.0
    t = np.arange(int(8 * fs)) / fs
    bpfo = bpfo_order * rpm / 60.0
    comb = sum(np.sin(2 * np.pi * k * bpfo * t) for k in range(1, 12))
    signal = comb + np.random.default_rng(2).standard_normal(t.size)
    defect_hz = {"shaft": rpm / 60.0, "bpfo": bpfo, "bpfi": 1.9 * bpfo, "bsf": 0.65 * bpfo, "ftf": 0.09 * bpfo}
    alone = check_sampling_rate(signal, fs, rpm)
    assert alone.verdict == "contradicted"
    check = check_sampling_rate(signal, fs, rpm, defect_hz=defect_hz)
    assert check.verdict == "consistent" and not check.matches and check.implied_fs_hz == fs, check.reason
    assert "that series is the bearing's BPFO" in check.reason
    assert check_sampling_rate(signal, 2 * fs, rpm, defect_hz=defect_hz).verdict == "contradicted"


@pytest.mark.parametrize("comb_order, declared_factor", [(2 * 2.357, 0.5), (2.357, 2.0)])
def test_a_ball_defects_comb_at_a_rate_off_by_two_is_not_taken_for_the_other_ball_line(comb_order, declared_factor):
    """BSF and 2 x BSF are one factor of two apart: under a rate off by two, a ball defect's comb at one stands
    where the other belongs, so neither witnesses a rate (the SKF 6205's orders; a 20 kHz record)."""
    fs, rpm = 20000.0, 1500.0
    t = np.arange(int(8 * fs)) / fs
    comb = sum(np.sin(2 * np.pi * k * comb_order * rpm / 60.0 * t) for k in range(1, 12))
    signal = comb + np.random.default_rng(5).standard_normal(t.size)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(rpm)
    check = check_sampling_rate(signal, declared_factor * fs, rpm, defect_hz=defect_hz)
    assert check.verdict != "consistent" or "that series is the bearing's" not in check.reason, check.reason


def test_the_data_centers_0028_in_packaging_is_read_with_its_nominal_speed(tmp_path):
    """The 0.028 in records keep their samples under another number (3001.mat holds X056_DE_time),
    drive end only, and record no speed: the name's motor load gives the Data Center's nominal speed."""
    import scipy.io

    samples = np.random.default_rng(0).standard_normal((24000, 1))
    path = tmp_path / "12k_Drive_End_IR028_2_3003.mat"
    scipy.io.savemat(path, {"X058_DE_time": samples})
    recording = load_recording(path)
    assert (recording.rpm, recording.fault, recording.channel) == (1750.0, "inner", "DE")
    assert recording.meta["record"] == 3003 and recording.meta["fault_size_in"] == 0.028
    np.testing.assert_array_equal(recording.signal, samples[:, 0])
    assert any("X058_*" in note for note in recording.meta["notes"])
    assert any("1750 rpm" in note and "2 hp" in note for note in recording.meta["notes"])
    given = load_recording(path, rpm=1747.0)  # a measured speed replaces the nominal one, no contradiction
    assert given.rpm == 1747.0 and not any("rpm" in note for note in given.meta["notes"])
    scipy.io.savemat(tmp_path / "3003.mat", {"X058_DE_time": samples})  # the Data Center's own name: its catalogue's
    numbered = load_recording(tmp_path / "3003.mat")
    assert (numbered.rpm, numbered.fault, numbered.meta["fault_size_in"], numbered.meta["load_hp"]) == (1750.0, "inner", 0.028, 2)
    scipy.io.savemat(tmp_path / "3009.mat", {"X058_DE_time": samples})  # a number the catalogue does not hold: no load
    assert load_recording(tmp_path / "3009.mat").rpm is None
    with pytest.raises(BearingTwinError, match="3009.mat: no X<nnn>RPM variable and no motor load in the name"):
        load_cwru(tmp_path / "3009.mat")


@needs_data
def test_a_record_names_the_bearing_it_was_made_on_as_every_command_reads_it(tmp_path):
    """A fault record's name gives its faulty bearing's end; a healthy record has none, so the bearing is the one
    under the accelerometer read; a Data Center label gives no end, its catalogued variables do.
    bearing_the_files_name (data=files) and inspect read it as diagnose and the twin do: a folder of the healthy
    record and drive-end faults is the 6205's."""
    from bearingtwin.cli.inspect import summarize
    from bearingtwin.data.formats import file_bearing
    from bearingtwin.data.real import bearing_the_files_name

    def named(path, channel=None):
        recording = load_recording(path, channel=channel)
        return file_bearing(recording.meta, recording.channel)

    assert named(CWRU / "12k_Drive_End_IR007_0_105.mat") == named(CWRU / "normal_0_97.mat") == "cwru_6205"
    assert named(CWRU / "normal_0_97.mat", "FE") == "cwru_6203" and named(CWRU / "12k_Drive_End_IR007_0_105.mat", "BA") == "cwru_6205"
    (tmp_path / "IR007_0.mat").write_bytes((CWRU / "12k_Drive_End_IR007_0_105.mat").read_bytes())
    # A Data Center label gives no end, but the catalogued record whose variables the file holds does (X105: drive end).
    assert named(tmp_path / "IR007_0.mat") == "cwru_6205"
    recordings = [load_recording(CWRU / name) for name in ("normal_0_97.mat", "12k_Drive_End_OR007@6_0_130.mat")]
    assert bearing_the_files_name(recordings) == "cwru_6205"
    assert summarize(CWRU / "normal_0_97.mat")["bearing"] == "cwru_6205"
    assert summarize(CWRU / "normal_0_97.mat", channel="FE")["bearing"] == "cwru_6203"


def test_a_file_holding_another_catalogued_records_variables_is_refused(tmp_path):
    """``105.mat`` (inner race) holding ``X118_*`` (a ball record) is a copy under the wrong name: read as its name it
    had been scored as an inner race. The catalogue names both, so the refusal names both."""
    import scipy.io

    samples = np.random.default_rng(2).standard_normal((24000, 1))
    for name in ("12k_Drive_End_IR007_0_105.mat", "105.mat"):
        scipy.io.savemat(tmp_path / name, {"X118_DE_time": samples, "X118RPM": 1796.0})
        with pytest.raises(BearingTwinError, match=(
                rf"{re.escape(name)}: holds record 118's variables \(X118_\*: B007_0 at 12 kHz, drive end in the Data "
                r"Center's catalogue\), while its name gives record 105 \(IR007_0 at 12 kHz, drive end\): name the file "
                r"by the record it holds$")):
            read_raw(tmp_path / name)
    scipy.io.savemat(tmp_path / "111.mat", {"X107_DE_time": samples, "X107RPM": 1750.0})  # IR007_2 at 48 kHz, not 12
    with pytest.raises(BearingTwinError, match=r"holds record 107's variables .*IR007_2 at 12 kHz.*IR007_2 at 48 kHz"):
        read_raw(tmp_path / "111.mat")
    # A label names no record, but a condition: an outer race's record under an inner race's label had been scored as
    # an inner race (the record's own label, of either rate, passes).
    scipy.io.savemat(tmp_path / "IR007_1.mat", {"X131_DE_time": samples, "X131RPM": 1772.0})
    with pytest.raises(BearingTwinError, match=(
            r"IR007_1.mat: holds record 131's variables \(X131_\*: OR007@6_1 at 12 kHz, drive end in the Data Center's "
            r"catalogue\), while its name is the label IR007_1: name the file by the record it holds$")):
        read_raw(tmp_path / "IR007_1.mat")
    for held in (106, 110):  # IR007_1 at 12 and at 48 kHz
        scipy.io.savemat(tmp_path / "IR007_1.mat", {f"X{held}_DE_time": samples, f"X{held}RPM": 1772.0})
        assert read_raw(tmp_path / "IR007_1.mat").meta["record"] == held


def test_a_file_holding_two_records_gives_the_one_its_name_names(tmp_path):
    """The Data Center's 99.mat holds X098_* beside its own X099_*."""
    import scipy.io

    rng = np.random.default_rng(1)
    own, other = rng.standard_normal((3000, 1)), rng.standard_normal((5000, 1))
    variables = {"X098_DE_time": other, "X098RPM": 1772.0, "X099_DE_time": own, "X099_FE_time": own, "X099RPM": 1750.0}
    for name in ("normal_2_99.mat", "99.mat"):
        scipy.io.savemat(tmp_path / name, variables)
        recording = load_recording(tmp_path / name)
        assert recording.rpm == 1750.0 and recording.meta["record"] == 99
        np.testing.assert_array_equal(recording.signal, own[:, 0])
        assert recording.meta["notes"] == ["X098_* in the same file left out: the name gives record 99"]
    scipy.io.savemat(tmp_path / "baseline.mat", variables)
    with pytest.raises(BearingTwinError, match=r"baseline.mat: holds the variables of records \[98, 99\] and its name names none"):
        load_recording(tmp_path / "baseline.mat")
    scipy.io.savemat(tmp_path / "normal_0_97.mat", variables)
    with pytest.raises(BearingTwinError, match=r"normal_0_97.mat: .* its name names record 97, which is not among them"):
        load_recording(tmp_path / "normal_0_97.mat")


def test_the_fan_end_bearing_has_the_data_centers_defect_frequencies():
    """SKF 6203-2RS JEM: the Data Center publishes BPFI 4.9469, BPFO 3.0530, cage 0.3817 and rolling element
    3.9874 x shaft (its rolling-element rate is twice the ball spin: a spall strikes both races per spin)."""
    orders = load_bearing("cwru_6203").defect_frequencies(60.0)  # 1 rev/s: Hz are multiples of the shaft rate
    orders["2bsf"] = 2 * orders["bsf"]
    published = {"bpfi": 4.9469, "bpfo": 3.0530, "ftf": 0.3817, "2bsf": 3.9874}
    assert {key: orders[key] for key in published} == pytest.approx(published, abs=2e-3)
    drive_end = load_bearing("cwru_6205").defect_frequencies(60.0)
    assert (drive_end["bpfo"], drive_end["bpfi"]) == pytest.approx((BPFO_ORDER, BPFI_ORDER), abs=2e-3)


def test_a_fan_end_fault_record_is_read_from_the_fan_end_accelerometer(tmp_path):
    """The name's Fan_End puts the fault in the SKF 6203: its own accelerometer (FE) is read, the bearing named."""
    import scipy.io

    rng = np.random.default_rng(2)
    drive, fan = rng.standard_normal((6000, 1)), rng.standard_normal((6000, 1))
    path = tmp_path / "12k_Fan_End_OR014@3_1_298.mat"
    scipy.io.savemat(path, {"X298_DE_time": drive, "X298_FE_time": fan, "X298RPM": 1772.0})
    name = parse_cwru_name(path)
    assert (name.end, name.bearing, name.fault, name.fault_size_in, name.position) == ("fan", "cwru_6203", "outer", 0.014, "3")
    recording = load_recording(path)
    assert recording.channel == "FE" and recording.meta["bearing"] == "cwru_6203"
    np.testing.assert_array_equal(recording.signal, fan[:, 0])
    assert any("fan-end bearing (SKF 6203" in note for note in recording.meta["notes"])
    np.testing.assert_array_equal(load_recording(path, channel="DE").signal, drive[:, 0])
    assert parse_cwru_name("12k_Drive_End_IR007_0_105.mat").bearing == "cwru_6205"


def test_a_rate_of_a_few_hz_is_contradicted_not_a_memory_error():
    """At fs = 1 Hz a 5 Hz background median spans millions of bins; it is held to the spectrum's length."""
    signal = np.random.default_rng(0).normal(size=120_000)
    check = check_sampling_rate(signal, 1.0, 1797.0)
    assert check.verdict == "contradicted" and "the spectrum ends at 0.5 Hz" in check.reason


def test_the_transforms_of_a_channel_are_computed_once_per_record_and_change_no_verdict(monkeypatch):
    """Every rate a record's check tries reads the same channels: within shared_transforms each channel's spectrum
    and envelope are computed once (the envelope read for the defect lines' second look), the verdicts (here one
    consistent, two contradicted) are those computed with nothing shared, and nothing is kept afterwards."""
    import importlib

    from bearingtwin.signal import sampling_rate

    envelope_module = importlib.import_module("bearingtwin.signal.envelope")  # the package's `envelope` is the function

    rpm, fs = 1797.0, 12000.0
    shaft_hz, bpfo_hz = rpm / 60.0, 3.5848 * rpm / 60.0
    rng = np.random.default_rng(5)
    t = np.arange(int(10 * fs)) / fs
    impacts = np.zeros(t.size)
    impacts[(np.arange(0, 10, 1 / bpfo_hz) * fs).astype(int)] = 1.0
    ring = np.exp(-900 * t[:300]) * np.sin(2 * np.pi * 3000 * t[:300])
    shaft = sum(np.sin(2 * np.pi * n * shaft_hz * t) / n for n in range(1, 6))
    channels = {"DE": shaft + 3 * np.convolve(impacts, ring)[: t.size] + 0.2 * rng.standard_normal(t.size),
                "FE": 0.5 * shaft + 0.3 * rng.standard_normal(t.size)}
    options = {"defect_hz": {"shaft": shaft_hz, "bpfo": bpfo_hz}}
    rates = (fs, 24000.0, 48000.0)
    counted = {"spectrum": 0, "envelope": 0}
    spectrum, envelope = sampling_rate._magnitude_spectrum, envelope_module.envelope

    def count(kind, compute):
        def counting(x):
            counted[kind] += 1
            return compute(x)
        return counting

    monkeypatch.setattr(sampling_rate, "_magnitude_spectrum", count("spectrum", spectrum))
    monkeypatch.setattr(envelope_module, "envelope", count("envelope", envelope))
    with monkeypatch.context() as unshared:
        unshared.setattr(sampling_rate, "_once", lambda kind, samples, compute: compute(samples))
        afresh = [check_channels(channels, rate, rpm, **options) for rate in rates]
    computed_afresh = dict(counted)
    counted.update(spectrum=0, envelope=0)
    hashed = []
    blake2b = sampling_rate.hashlib.blake2b
    monkeypatch.setattr(sampling_rate.hashlib, "blake2b", lambda data, **kw: hashed.append(len(data)) or blake2b(data, **kw))
    with sampling_rate.shared_transforms():
        shared = [check_channels(channels, rate, rpm, **options) for rate in rates]
    assert [check["DE"].verdict for check in afresh] == ["consistent", "contradicted", "contradicted"]
    assert shared == afresh
    # One spectrum per channel and per envelope, one envelope per channel read for its defect lines, at most;
    # and each array's content hashed once, however many rates look it up.
    assert counted["spectrum"] <= 4 and counted["envelope"] <= 2
    assert 0 < len(hashed) <= 4
    assert computed_afresh["spectrum"] > 2 * counted["spectrum"] and computed_afresh["envelope"] > counted["envelope"]
    assert sampling_rate._SHARED.get() is None
    # Past its memory cap it keeps nothing more and computes again, to the same verdicts.
    monkeypatch.setattr(sampling_rate, "SHARED_BYTES", 0)
    counted.update(spectrum=0, envelope=0)
    with sampling_rate.shared_transforms():
        assert [check_channels(channels, rate, rpm, **options) for rate in rates] == afresh
    assert counted == computed_afresh


@needs_data
@pytest.mark.parametrize("path", sorted(CWRU.glob("12k_*.mat")), ids=lambda p: p.name)
def test_a_tachometer_recorded_beside_the_accelerometer_is_no_witness_of_the_rate(tmp_path, path):
    """A data-acquisition system records a once-per-revolution tachometer beside the accelerometer: its pulse comb
    is no vibration's, and read as one it contradicted the true rate on 7 of the 12 fault records. It is left out
    of the witnesses, no channel choice falls on it, and choosing it names what it is."""
    from bearingtwin.signal.sampling_rate import is_pulse_train, rate_witnesses

    recording = load_cwru(path)
    t = np.arange(recording.signal.size) / recording.fs
    tach = 5.0 * ((t * recording.rpm / 60.0) % 1.0 < 0.1)  # 5 V pulses, a tenth of a revolution long
    assert is_pulse_train(tach) and not is_pulse_train(recording.signal)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    witnesses = rate_witnesses(recording.signal, {"acc": recording.signal, "tach": tach})
    assert list(witnesses) == ["acc"]
    checks = check_channels(witnesses, recording.fs, recording.rpm, defect_hz=defect_hz)
    assert checks[decisive_channel(checks)].verdict == "consistent"
    np.save(tmp_path / "two.npy", np.stack([recording.signal, tach]))
    raw = read_raw(tmp_path / "two.npy")
    assert raw.channel(None)[0] == "0" and "notes" not in raw.meta  # the only vibration among the two
    assert raw.channel("1")[0] == raw.channel("1")[0] == "1"  # asked for, it is read, and said (once) to be what it is
    assert raw.meta["notes"] == ["channel 1 holds two levels only: a tachometer's pulses, or a sensor saturated nine "
                                 "samples in ten; read as asked, it is no vibration's record"]
    # Where nothing states the speed, the pulses give it, at the one mark a turn the record's shaft series confirms.
    read = load_recording(tmp_path / "two.npy", fs=recording.fs)
    assert read.meta["rpm_origin"] == "tachometer" and read.rpm == pytest.approx(recording.rpm, rel=1e-3)
    assert f"shaft speed {recording.rpm:.0f} rpm from the tachometer channel 1: 1 pulse per revolution" in read.meta["notes"][0]
    np.save(tmp_path / "tach.npy", tach)  # a file of pulses alone is read, and said to be so
    assert load_recording(tmp_path / "tach.npy", fs=recording.fs).meta["notes"][0].startswith("channel 0 holds two levels")


@needs_data
@pytest.mark.parametrize("name", ["12k_Drive_End_OR007@6_0_130.mat", "12k_Drive_End_IR007_1_106.mat"])
def test_the_rate_check_reads_a_long_records_centre_and_judges_it_as_its_whole_length(monkeypatch, name):
    """A long recording's check reads its centre's RATE_CHECK_SAMPLES, so that a multi-channel recording of minutes
    is checked in seconds: a record ten times as long (a CWRU record tiled) is judged as it is when read whole, at
    its true rate and at twice it; and it is the centre that is read: a record whose first and last thirds are
    noise alone (a logger running before and after the machine) is judged on the machine's stretch."""
    from bearingtwin.signal import sampling_rate

    recording = load_cwru(CWRU / name)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(recording.rpm)
    long = np.tile(recording.signal, 10)
    assert long.size > sampling_rate.RATE_CHECK_SAMPLES > recording.signal.size

    def verdicts(signal):
        return [require_plausible_rate(signal, fs, recording.rpm, name, "fs", defect_hz=defect_hz, refuse=False).verdict
                for fs in (recording.fs, 2 * recording.fs)]

    centre = verdicts(long)
    quiet = np.random.default_rng(0).normal(scale=0.01 * recording.signal.std(), size=long.size)
    framed = np.concatenate([quiet, long, quiet])  # the machine's stretch alone holds the record's centre
    assert verdicts(framed) == centre
    monkeypatch.setattr(sampling_rate, "RATE_CHECK_SAMPLES", 10 * framed.size)
    assert centre == verdicts(long) and centre[1] == "contradicted"


def test_a_slow_shaft_is_checked_over_as_many_samples_as_its_line_needs():
    """At 90 rpm a 51.2 kHz channel needs 1.7 million samples to place the shaft line within 2 %: a minute of it is
    read whole enough to be checked, not called too short for it."""
    from bearingtwin.signal.sampling_rate import RATE_CHECK_SAMPLES

    fs, rpm = 51200.0, 90.0
    t = np.arange(int(60 * fs)) / fs
    shaft = sum(np.sin(2 * np.pi * k * rpm / 60 * t + k) / k for k in range(1, 8))
    signal = shaft + 0.3 * np.random.default_rng(0).normal(size=t.size)
    assert fs / RATE_CHECK_SAMPLES > 0.02 * rpm / 60  # the fewest samples read would not place it
    check = require_plausible_rate(signal, fs, rpm, "slow", "fs")
    assert check is not None and check.verdict == "consistent" and check.matches


def test_an_envelope_comb_near_the_shaft_rate_is_named_as_the_shafts_own_at_a_speed_off_as_well_as_a_rate():
    """An inner race's envelope carries the shaft's modulation at 1x. Where the shaft speeds up 3 % over the record
    (1750 to 1802 rpm, 1750 stated) that comb stands 1.2 % above the stated shaft rate, beyond the 1 % within which
    it reads as the shaft's: the rate stays unconfirmed, and beside the rate it would imply (42 kHz, no rate of
    this record) the check names the shaft's own modulation at a speed that far off."""
    fs, seconds = 12000.0, 6.0
    steady = simulate_rig("inner", RigOperatingPoint(rpm=1750.0, fs=fs, duration_s=1.05 * seconds), seed=1)
    t = np.arange(int(seconds * fs)) / fs
    drifting = np.interp(t + 0.015 * t**2 / seconds, np.arange(steady.size) / fs, steady)
    check = check_sampling_rate(drifting, fs, 1750.0, defect_hz=load_bearing("cwru_6205").defect_frequencies(1750.0))
    assert check.verdict == "ambiguous", check.reason
    said = re.search(r"fs may be (\d+) Hz, or it is the shaft's 1x modulation at a speed \+(\d\.\d) % from the one "
                     r"stated$", check.reason)
    assert said and abs(float(said[1]) - fs / 0.282) < 0.02 * fs / 0.282 and 1.0 < float(said[2]) < 3.0, check.reason
    # A comb between shaft orders is no shaft's: only the rate is named.
    assert _shaft_comb_words(1.5 * check.expected_hz, check) == ""
    assert _shaft_comb_words(2.04 * check.expected_hz, check) == (", or it is the shaft's 2x modulation at a speed "
                                                                  "+2.0 % from the one stated")


def test_a_label_named_file_is_read_as_the_catalogued_record_its_variables_are(tmp_path):
    """A mirror names the fan end's records by the drive end's labels (``IR007_0.mat`` holding ``X278_*``): read as a
    drive-end record it had been diagnosed on the wrong accelerometer with the wrong bearing's lines, unsaid. A long
    name the catalogue contradicts is read as it says, and said so; a fan-end record without its FE channel is refused
    rather than read off the drive end's accelerometer, where it holds several others, and its one other read, said
    so."""
    x = np.random.default_rng(0).standard_normal((12000, 1))
    rpm = np.array([[1797.0]])
    scipy.io.savemat(tmp_path / "IR007_0.mat", {"X278_DE_time": x, "X278_FE_time": x, "X278RPM": rpm})
    label = read_raw(tmp_path / "IR007_0.mat")
    assert (label.meta["bearing"], label.channel(None)[0], label.fs) == ("cwru_6203", "FE", 12000.0)
    assert ("its variables are X278_*, which the Data Center's catalogue lists as IR007_0 at 12 kHz, fan end: read so"
            in label.meta["notes"])
    (tmp_path / "drive").mkdir()
    scipy.io.savemat(tmp_path / "drive" / "IR007_0.mat", {"X105_DE_time": x, "X105_FE_time": x, "X105RPM": rpm})
    drive = read_raw(tmp_path / "drive" / "IR007_0.mat")
    assert (drive.meta["bearing"], drive.channel(None)[0]) == ("cwru_6205", "DE")
    scipy.io.savemat(tmp_path / "12k_Drive_End_IR007_0_278.mat", {"X278_DE_time": x, "X278RPM": rpm})
    contradicted = read_raw(tmp_path / "12k_Drive_End_IR007_0_278.mat")
    assert contradicted.meta["bearing"] == "cwru_6205" and any(
        note.startswith("the Data Center's catalogue lists record 278 as IR007_0 at 12 kHz, fan end, where the name "
                        "says IR007_0 at 12 kHz, drive end") for note in contradicted.meta["notes"])
    scipy.io.savemat(tmp_path / "12k_Drive_End_B007_0_105.mat", {"X105_DE_time": x, "X105RPM": rpm})
    assert ("the Data Center's catalogue lists record 105 as IR007_0 at 12 kHz, drive end, where the name says B007_0 "
            "at 12 kHz, drive end: read as the name says; check which the file holds"
            in read_raw(tmp_path / "12k_Drive_End_B007_0_105.mat").meta["notes"])
    assert not any("catalogue lists" in note for note in read_raw(CWRU / "12k_Drive_End_OR007@6_1_131.mat").meta["notes"])
    scipy.io.savemat(tmp_path / "12k_Fan_End_IR007_1_279.mat", {"X279_DE_time": x, "X279_BA_time": x, "X279RPM": rpm})
    with pytest.raises(BearingTwinError, match=r"12k_Fan_End_IR007_1_279.mat: holds no FE channel, the accelerometer on "
                                               r"the faulty bearing \(it holds DE, BA\); choose one with channel"):
        read_raw(tmp_path / "12k_Fan_End_IR007_1_279.mat").channel(None)
    (tmp_path / "one").mkdir()
    scipy.io.savemat(tmp_path / "one" / "12k_Fan_End_IR007_1_279.mat", {"X279_DE_time": x, "X279RPM": rpm})
    alone = read_raw(tmp_path / "one" / "12k_Fan_End_IR007_1_279.mat")
    assert alone.channel(None)[0] == "DE" and ("it holds no FE channel, the accelerometer on the faulty fan-end bearing: "
                                               "its one channel, DE, is read") in alone.meta["notes"]
    assert not any("FE, is read unless" in note for note in alone.meta["notes"])


def test_a_loose_machines_half_orders_are_no_defect_comb_a_speed_a_whole_factor_lower_would_put_there():
    """A loose outer-race machine (the independent rig's rattle, 2 s at 48 kHz) fills its envelope with half orders:
    on so short a record the comb at a seventh of BPFO (0.512 x shaft) falls a bin or two from them, and read as a
    defect's comb under a speed seven times lower it had refused a right rate and speed (the twin exited 2). Its BPFO
    line standing at its frequency now says the half orders are real."""
    from bearingtwin.testrig import RigOperatingPoint, simulate_rig

    point = RigOperatingPoint(rpm=1797, fs=48000, duration_s=2.0, radial_load_n=500.0, unit="g")
    record = simulate_rig("outer", point, {"looseness": {"level_db": 0.0}}, seed=9)
    defect_hz = load_bearing("cwru_6205").defect_frequencies(1797.0)
    check = check_sampling_rate(record, 48000.0, 1797.0, defect_hz=defect_hz)
    assert check.verdict == "consistent" and check.fraction == 2, check.reason
    assert "the envelope line of bpfo stands at its frequency: real subharmonics" in check.reason


def test_training_declares_a_label_named_file_at_its_catalogued_records_rate(tmp_path):
    """A diagnosis reads ``IR007_1.mat`` holding ``X110_*`` (IR007_1 at 48 kHz in the catalogue) at 48 kHz; data=cwru
    declares the same file at that rate too, not at data.fs."""
    x = np.zeros((4800, 1))
    scipy.io.savemat(tmp_path / "IR007_1.mat", {"X110_DE_time": x, "X110RPM": np.array([[1772.0]])})
    scipy.io.savemat(tmp_path / "B007_1.mat", {"X999_DE_time": x})  # no catalogued record: data.fs
    assert declared_fs_hz(tmp_path / "IR007_1.mat", 12000) == 48000.0 == read_raw(tmp_path / "IR007_1.mat").fs
    assert declared_fs_hz(tmp_path / "B007_1.mat", 12000) == 12000.0
