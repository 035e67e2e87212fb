"""What in a record may spoil a reading of it without making it unreadable: clipping and dropouts, named."""

import numpy as np
import pytest

from bearingtwin.data.recording import Recording

FS = 12000.0


def impacts(seconds=3.0, seed=0):
    """A bearing-like record: impacts ringing at 3 kHz, 107 per second, under noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    x = 0.2 * rng.standard_normal(t.size)
    for start in np.arange(0.0, seconds, 1 / 107.0):
        after = t >= start
        x[after] += 4.0 * np.exp(-(t[after] - start) * 800) * np.sin(2 * np.pi * 3000 * (t[after] - start))
    return x


def test_a_clean_record_even_on_a_coarse_converter_draws_no_note():
    x = impacts()
    assert Recording(x, FS).quality_notes() == []
    # A 100 Hz tone at 12 kHz reaches its peak on one sample of every period, a single sample each time.
    tone = np.sin(2 * np.pi * 100.0 * np.arange(int(3 * FS)) / FS)
    assert np.count_nonzero(tone == tone.max()) == 300 and Recording(tone, FS).quality_notes() == []
    coarse = np.round(x / np.ptp(x) * 2**8) / 2**8  # an 8-bit converter: its codes repeat, its extremes barely
    assert Recording(coarse, FS).quality_notes() == []


def test_a_clipped_record_is_named_with_its_extremes():
    x = impacts()
    limit = 2.0 * np.sqrt(np.mean(x**2))
    (note,) = Recording(np.clip(x, -limit, limit), FS).quality_notes()
    share, rest = note.split(" % of the samples pile up at ", 1)
    # The ringing is too fast for flat tops: the limit piles samples up (with the few just below it, within the edge).
    assert float(share) == pytest.approx(100 * np.mean(np.abs(x) >= limit), abs=0.2)
    assert rest.startswith(f"its maximum, {limit:g} and its minimum, {-limit:g}, in ")
    assert ": the sensor or the converter clipped" in rest
    # One side alone; and an amplifier's limit reaching a 16-bit converter with a code of noise, not one value.
    (note,) = Recording(np.clip(x, -10 * limit, limit), FS).quality_notes()
    assert f"pile up at its maximum, {limit:g}, in " in note and "minimum" not in note
    lsb = 20.0 / 2**16 * np.ptp(x) / 10  # a +-10 V range, the signal spanning half of it
    noisy = np.round((np.clip(x, -limit, limit) + lsb * np.random.default_rng(1).standard_normal(x.size)) / lsb) * lsb
    assert "the sensor or the converter clipped" in Recording(noisy, FS).quality_notes()[0]


def test_a_clipped_record_is_named_with_where_it_clipped():
    """As a dropout is: a record three times as strong from 1 s to 2 s clips there alone, in a stretch per impact."""
    x = impacts()
    x[int(1.0 * FS):int(2.0 * FS)] *= 3.0
    limit = 1.5 * np.abs(impacts()).max()  # above every impact outside that second, below those within it
    (note,) = Recording(np.clip(x, -limit, limit), FS).quality_notes()
    clipped = np.abs(x) >= limit
    stretches = np.count_nonzero(np.diff(clipped.astype(int)) == 1)
    assert f"its minimum, {-limit:g}, in {stretches} stretches from 1 s to 1.99 s: the sensor" in note
    assert 107 <= stretches  # at least one per impact within that second


def test_a_flat_or_two_level_channel_is_no_clipping():
    """A dead channel is said to be one; a tacho's two levels pile up at both ends by design, not by a limit."""
    assert Recording(np.zeros(1000), FS).quality_notes() == ["every sample is 0: no vibration recorded"]
    tacho = 5.0 * ((np.arange(int(FS)) / FS * 30.0) % 1.0 < 0.1)
    assert not any("clipped" in note for note in Recording(tacho, FS).quality_notes())


@pytest.mark.parametrize("seconds, named", [(0.3, True), (0.004, False)])
def test_a_dropout_is_named_with_where_it_is(seconds, named):
    x = impacts()
    start = int(1.0 * FS)
    x[start:start + int(seconds * FS)] = 0.0
    notes = Recording(x, FS).quality_notes()
    if named:
        assert notes == [f"samples from 1 s to {1 + seconds:.3g} s are all 0 (a dropout, or a stretch held at one "
                         "value): the windows over it read no vibration"]
    else:  # shorter than 5 ms: a quiet moment or a clipped peak's flat top
        assert notes == []


def test_many_dropouts_are_counted_beside_the_longest():
    """Twenty 20 ms gaps (a logger's lost packets) had been named as the longest one alone."""
    x = impacts()
    for index in range(20):
        start = int((0.05 + 0.09 * index) * FS)
        x[start:start + int((0.02 if index != 7 else 0.03) * FS)] = 0.0
    (note,) = Recording(x, FS).quality_notes()
    assert note.startswith(f"samples from {0.05 + 0.09 * 7:.3g} s to {0.05 + 0.09 * 7 + 0.03:.3g} s are all 0")
    assert ", the longest of 20 such stretches: the windows over it read no vibration" in note


def test_records_read_for_training_warn_of_their_clipping_naming_the_file(caplog):
    """A training run reads real records as a diagnosis does: a clipped one is named in the log, a clean one not."""
    from bearingtwin.data.real import windows_from_recordings

    x = impacts()
    limit = 2.0 * np.sqrt(np.mean(x**2))
    recordings = [Recording(x, FS, fault="inner", source="rig/clean.npy"),
                  Recording(np.clip(impacts(seed=1), -limit, limit), FS, fault="outer", source="rig/clipped.npy")]
    with caplog.at_level("WARNING", logger="bearingtwin.data.recording"):
        windows_from_recordings(recordings, 2048, 4, "data.samples_per_class", "key")
    warned = [record.getMessage() for record in caplog.records]
    assert len(warned) == 1 and warned[0].startswith("clipped.npy: ") and "the sensor or the converter clipped" in warned[0]


def test_a_few_isolated_spikes_are_named_and_a_faults_recurring_impacts_are_not():
    """A cable knocked four times in 10 s had left no word, while its spikes buried the envelope spectrum's defect lines
    (physics: normal on an inner-race record). Strong impacts at a defect rate are the vibration's own: no note."""
    x = impacts(seconds=10.0)
    for start in (1.5, 4.0, 6.25, 9.0):
        x[int(start * FS):int(start * FS) + 3] += 40.0
    (note,) = Recording(x, FS).quality_notes()
    assert note.startswith("4 isolated spikes, up to ") and " at 1.5, 4, 6.25, 9 s: a cable knock" in note, note
    strong = impacts(seconds=10.0)
    strong[::112] += 40.0  # 107 a second, as a fault's impacts recur
    assert not any("spike" in note for note in Recording(strong, FS).quality_notes())
    # A knock rings for milliseconds: one spike, not one per crossing. A fault's impacts varying in strength from one
    # to the next (log-normal) stand far beyond the typical level again and again: their own train, no spike.
    t = np.arange(int(10 * FS)) / FS
    ringing = impacts(seconds=10.0)
    for start in (2.0, 7.0):
        after = (t >= start) & (t < start + 0.005)
        ringing[after] += 60.0 * np.exp(-(t[after] - start) * 800) * np.sin(2 * np.pi * 3000 * (t[after] - start))
    (note,) = Recording(ringing, FS).quality_notes()
    assert note.startswith("2 isolated spikes") and " at 2, 7 s: " in note, note
    rng = np.random.default_rng(1)
    tail = 0.2 * rng.standard_normal(t.size)
    for start in np.arange(0.0, 10.0, 1 / 107.0):
        after = (t >= start) & (t < start + 0.01)
        tail[after] += (rng.lognormal(1.0, 0.8) * np.exp(-(t[after] - start) * 800)
                        * np.sin(2 * np.pi * 3000 * (t[after] - start)))
    assert not any("spike" in note for note in Recording(tail, FS).quality_notes())
