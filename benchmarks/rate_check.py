"""How the sampling-rate check judges wrong rates: every CWRU record, declared at rates it was not sampled at.

Each of the 13 CWRU records is checked (``check_sampling_rate``, the drive-end channel, the SKF 6205's defect
frequencies as the second witness) at its true 12 kHz and at four wrong rates near a whole fraction of it
(0.4875, 0.48, 0.52 and 0.34 of 12 kHz) and two at the ratio of its races' defect frequencies (2/3 and 3/2); the
same record resampled to 25.6 kHz is checked there and at 12 kHz, 0.48, 0.52, 0.34, 2/3 and 3/2 times 25.6 kHz. A wrong rate the check calls ``consistent`` is one it lets through silently;
``contradicted`` refuses it (and names a rate, right when within 1 % of the true one); ``ambiguous`` logs a doubt.

Every CWRU record shows its shaft's harmonic series. A machine with one 1x line and nothing else is the other
common case: the independent test rig (``bearingtwin.testrig``: impulse trains through its own path, a residual
unbalance its only shaft line), the CWRU bearing at 12 kHz, each state at three speeds (4 s records), declared at
its true rate and at 1.25, 0.8, 0.5 and 2 times it (a rate typed for another rig's, or a whole factor off).

A speed given wrong is the same question from the other side: each CWRU record at its true 12 kHz with its
speed given 2, 3, 5 and 10 times too high (a digit too many), the defect frequencies at that speed.

A user's recording is often a few seconds cut from a longer one: each CWRU record's drive-end channel cut to 3, 5
and 10 s (from its start, its middle and its end) is checked at its true rate and at the same wrong rates. And the
twin's own records, as the README's "Your own recordings" makes them (each state, 4 s at 12 kHz, the twin's
default bearing: no shaft line but the balls' passing series), are checked at their true rate and at those rates.

A speed typed beside a rate the file records (an .npz's fs, a time column) is refused only where the check
contradicts the pair and the record is consistent with a speed a whole factor lower (``speeds_a_whole_factor_off``):
the CWRU records, whole and cut to 5 s, and the independent rig's and the twin's (with noise) records, each at its
true speed and 2, 3 and 10 times it.

A logger adds a noise floor the CWRU records barely have (their shaft lines stand a few milli-g over it): each
CWRU record's drive-end channel with white noise at 40, 30 and 20 dB below its RMS (one seeded draw per record and
level) is checked at its true rate and at the wrong rates of the first table.

Every command reads a CWRU file's three channels (drive end, fan end, base), each a witness of the file's one
rate (``check_channels``, ``decisive_channel``): the last table declares each file at the rates acquisition
systems record at (4 to 51.2 kHz), the verdict the record's.

    python benchmarks/rate_check.py            # a table per verdict and record set on stdout (about 90 s)
"""

from __future__ import annotations

import argparse
import os
from collections import Counter
from pathlib import Path

import numpy as np
import scipy.signal

from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR, REPO_ROOT, load_bearing
from bearingtwin.data.cwru import load_cwru
from bearingtwin.data.formats import read_raw
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import CHANNELS, simulate
from bearingtwin.signal.sampling_rate import (check_channels, check_sampling_rate, decisive_channel, rate_witnesses,
                                              speeds_a_whole_factor_off)
from bearingtwin.testrig import FAULTS, RigOperatingPoint, simulate_rig

WRONG_FACTORS = {12000.0: (5850 / 12000, 0.48, 0.52, 0.34, 2 / 3, 1.5),
                 25600.0: (12000 / 25600, 0.48, 0.52, 0.34, 2 / 3, 1.5)}
"""Declared / true rate of the wrong rates tried, per true rate: near half (a supply or 2x line then sits
near the shaft's place), near a third, and 2/3 and 3/2 (8 against 12 kHz, 32 against 48 kHz), where one race's
defect comb stands at the other's place: the SKF 6205's BPFI is 1.51 times its BPFO."""
RIG_FACTORS = (1.25, 0.8, 0.5, 2.0)
"""Declared / true rate of the wrong rates tried on the test rig's records."""
RIG_SPEEDS_RPM = (1797.0, 1750.0, 1730.0)
SPEED_FACTORS = (2, 3, 5, 10)
"""Given / true speed of the wrong speeds tried on the CWRU records."""
NOISE_SNR_DB = (40, 30, 20)
"""Record RMS over the white noise added, dB: a logger's floor, from a good one to a poor one."""
CUT_SECONDS = (3, 5, 10)
"""Lengths of the cuts of the CWRU records, s."""
DAQ_RATES_HZ = (4000.0, 6000.0, 8000.0, 10000.0, 10240.0, 12000.0, 12800.0, 16000.0, 20000.0, 20480.0, 24000.0,
                25600.0, 32000.0, 40000.0, 44100.0, 48000.0, 50000.0, 51200.0)
"""Rates the CWRU files are declared at with all their channels: what acquisition systems and sound cards record
at, a half and a third of 12 kHz among them."""


def tally(checks, true_fs: float, right_rate: Counter, wrong: Counter) -> None:
    """Count each check's verdict: ``checks`` yields (declared rate, check)."""
    for declared, check in checks:
        if declared == true_fs:
            right_rate[check.verdict] += 1
            continue
        named = check.implied_fs_hz is not None and abs(check.implied_fs_hz / true_fs - 1.0) <= 0.01
        wrong[check.verdict + (" naming the true rate" if check.verdict == "contradicted" and named else "")] += 1


def tally_speeds(recording, bearing, speeds: Counter) -> None:
    """Count the verdicts on a 12 kHz CWRU ``recording`` with its speed given :data:`SPEED_FACTORS` times too high,
    by bearing state."""
    for factor in SPEED_FACTORS:
        rpm = recording.rpm * factor
        check = check_sampling_rate(recording.signal, 12000.0, rpm, defect_hz=bearing.defect_frequencies(rpm))
        # A rate m times too high at the given speed is that speed m times too high at the true rate.
        named = check.implied_fs_hz is not None and abs(rpm * 12000.0 / check.implied_fs_hz / recording.rpm - 1) <= 0.01
        state = "healthy" if recording.fault == "normal" else recording.fault
        speeds[f"{state}: {check.verdict}" + (" naming the true speed" if check.verdict == "contradicted" and named
                                              else "")] += 1


TYPED_SPEED_FACTORS = (1, 2, 3, 10)
"""Given / true speed of the speeds typed beside a rate the file records."""


def tally_typed_speeds(signal, fs: float, rpm: float, bearing, channels, typed: Counter) -> None:
    """Count what a command does with ``signal`` (``channels``: its file's, witnesses) at its true ``fs`` and a speed
    typed :data:`TYPED_SPEED_FACTORS` times the true ``rpm``: refused (naming the true speed or another), or read
    (the check's verdict logged)."""
    for factor in TYPED_SPEED_FACTORS:
        given = rpm * factor
        checks = check_channels(rate_witnesses(signal, channels), fs, given, defect_hz=bearing.defect_frequencies(given))
        verdict = checks[decisive_channel(checks)].verdict
        lower = (speeds_a_whole_factor_off(signal, fs, given, bearing.defect_frequencies(given), channels)
                 if verdict == "contradicted" else [])
        speed = "the true speed" if factor == 1 else f"{factor} x the true speed"
        named = ("it first" if lower[0] == factor else "it among others" if factor in lower else "others") if lower else ""
        typed[(speed, f"refused naming {named}" if lower else f"read ({verdict})")] += 1


def print_table(title: str, right_rate: Counter, wrong: Counter) -> None:
    print(f"{title}\n\n| declared rate | verdict | cases |\n|---|---|---|")
    for verdict, count in sorted(right_rate.items()):
        print(f"| the true one | {verdict} | {count} |")
    for verdict, count in sorted(wrong.items()):
        print(f"| a wrong one | {verdict} | {count} |")
    print()


def rates_around(true_fs: float, factors) -> tuple[float, ...]:
    """The true rate, then the wrong ones it is declared at (``factors`` times it)."""
    return (true_fs, *(true_fs * factor for factor in factors))


def checks_at(signal, rates, rpm: float, defect_hz) -> list:
    """(declared rate, check) of one channel at each of ``rates``."""
    return [(fs, check_sampling_rate(signal, fs, rpm, defect_hz=defect_hz)) for fs in rates]


def file_checks_at(channels, rates, rpm: float, defect_hz) -> list:
    """(declared rate, check) of a file at each of ``rates``, every channel a witness, as the commands read it."""
    checks = []
    for fs in rates:
        by_channel = check_channels(channels, fs, rpm, defect_hz=defect_hz)
        checks.append((fs, by_channel[decisive_channel(by_channel)]))
    return checks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BEARINGTWIN_DATA", REPO_ROOT.parent / "shared" / "data"),
                        help="the folder holding cwru/ (default: ../shared/data)")
    args = parser.parse_args()
    records = sorted((Path(args.data) / "cwru").glob("*.mat"))
    if not records:
        raise SystemExit(f"no CWRU records in {Path(args.data) / 'cwru'}")
    bearing = load_bearing("cwru_6205")
    recordings = [load_cwru(path, check_fs=False) for path in records]
    right_rate, wrong, speeds = Counter(), Counter(), Counter()
    for recording in recordings:
        tally_speeds(recording, bearing, speeds)
        defect_hz = bearing.defect_frequencies(recording.rpm)
        for true_fs in WRONG_FACTORS:
            signal = (recording.signal if true_fs == 12000.0
                      else scipy.signal.resample_poly(recording.signal, 32, 15))  # 12 kHz -> 25.6 kHz
            tally(checks_at(signal, rates_around(true_fs, WRONG_FACTORS[true_fs]), recording.rpm, defect_hz), true_fs,
                  right_rate, wrong)
    print_table(f"{len(records)} CWRU records, at their true rate and resampled to 25.6 kHz:", right_rate, wrong)
    rig_right, rig_wrong, states = Counter(), Counter(), Counter()
    for number, (fault, rpm) in enumerate((fault, rpm) for fault in FAULTS for rpm in RIG_SPEEDS_RPM):
        signal = simulate_rig(fault, RigOperatingPoint(rpm=rpm, fs=12000.0, duration_s=4.0), seed=number)
        checks = checks_at(signal, rates_around(12000.0, RIG_FACTORS), rpm, bearing.defect_frequencies(rpm))
        tally(checks, 12000.0, rig_right, rig_wrong)
        states.update(f"{fault}: {check.verdict}" for fs, check in checks if fs != 12000.0)
    print_table(f"{len(FAULTS) * len(RIG_SPEEDS_RPM)} records of the independent test rig (one 1x line), 12 kHz:",
                rig_right, rig_wrong)
    print("wrong rates by state: " + ", ".join(f"{key} {count}" for key, count in sorted(states.items())))
    print(f"\n{len(records)} CWRU records at 12 kHz, the speed given {', '.join(map(str, SPEED_FACTORS))} times too high:"
          "\n\n| state | verdict | cases |\n|---|---|---|")
    for key, count in sorted(speeds.items()):
        state, verdict = key.split(": ")
        print(f"| {state} | {verdict} | {count} |")
    print()
    cut_right, cut_wrong = Counter(), Counter()
    for recording in recordings:
        defect_hz = bearing.defect_frequencies(recording.rpm)
        for seconds in CUT_SECONDS:
            size = int(seconds * 12000)
            for start in (0, (recording.signal.size - size) // 2, recording.signal.size - size):
                tally(checks_at(recording.signal[start:start + size], rates_around(12000.0, WRONG_FACTORS[12000.0]),
                                recording.rpm, defect_hz), 12000.0, cut_right, cut_wrong)
    print_table(f"{len(records)} CWRU records cut to {', '.join(map(str, CUT_SECONDS))} s (start, middle, end), 12 kHz:",
                cut_right, cut_wrong)
    noise_right, noise_wrong = Counter(), Counter()
    for number, recording in enumerate(recordings):
        defect_hz = bearing.defect_frequencies(recording.rpm)
        for snr_db in NOISE_SNR_DB:
            noise = np.random.default_rng([number, snr_db]).standard_normal(recording.signal.size)
            noisy = recording.signal + noise * np.std(recording.signal) * 10 ** (-snr_db / 20)
            checks = checks_at(noisy, rates_around(12000.0, WRONG_FACTORS[12000.0]), recording.rpm, defect_hz)
            tally(checks, 12000.0, noise_right, noise_wrong)
            noise_right.update(f"{check.verdict} at {snr_db} dB" for fs, check in checks if fs == 12000.0)
    print_table(f"{len(records)} CWRU records with white noise {', '.join(map(str, NOISE_SNR_DB))} dB below their RMS, "
                "12 kHz (the true rate's verdicts also by level):", noise_right, noise_wrong)
    twin_right, twin_wrong = Counter(), Counter()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        settings = compose("simulate", overrides=["simulator.fs=12000", "simulator.duration=4"])
    twin_bearing = BearingGeometry.from_config(settings.bearing)
    for fault in FAULTS:
        recording, channels = simulate(fault, settings.bearing, settings.simulator, settings.effects)
        # Every channel the .npz holds, as the commands read it: the sensor's signal and the four race channels.
        witnesses = {"signal": recording.signal, **dict(zip(CHANNELS, channels))}
        tally(file_checks_at(witnesses, rates_around(12000.0, WRONG_FACTORS[12000.0]), recording.rpm,
                             twin_bearing.defect_frequencies(recording.rpm)), 12000.0, twin_right, twin_wrong)
    print_table(f"the twin's own records of {len(FAULTS)} states (4 s, 12 kHz, its default bearing, every channel):",
                twin_right, twin_wrong)
    typed = Counter()
    for recording, path in zip(recordings, records):
        tally_typed_speeds(recording.signal, 12000.0, recording.rpm, bearing, read_raw(path).channels, typed)
        tally_typed_speeds(recording.signal[:5 * 12000], 12000.0, recording.rpm, bearing, None, typed)
    for number, (fault, rpm) in enumerate((fault, rpm) for fault in FAULTS for rpm in RIG_SPEEDS_RPM):
        signal = simulate_rig(fault, RigOperatingPoint(rpm=rpm, fs=12000.0, duration_s=4.0), seed=number)
        tally_typed_speeds(signal, 12000.0, rpm, bearing, None, typed)
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        noisy = compose("simulate", overrides=["simulator.fs=12000", "simulator.duration=4", "effects=[noise]"])
    for fault in FAULTS:
        recording, channels = simulate(fault, noisy.bearing, noisy.simulator, noisy.effects)
        tally_typed_speeds(recording.signal, 12000.0, recording.rpm, twin_bearing,
                           {"signal": recording.signal, **dict(zip(CHANNELS, channels))}, typed)
    print(f"\nA speed typed beside a rate the file records: {len(records)} CWRU records whole and cut to 5 s, "
          f"{len(FAULTS) * len(RIG_SPEEDS_RPM)} of the independent rig, {len(FAULTS)} of the twin with noise:\n\n"
          "| speed typed | what the command does | cases |\n|---|---|---|")
    for (speed, action), count in sorted(typed.items()):
        print(f"| {speed} | {action} | {count} |")
    every_right, every_wrong = Counter(), Counter()
    for path in records:
        raw = read_raw(path)
        tally(file_checks_at(raw.channels, DAQ_RATES_HZ, raw.rpm, bearing.defect_frequencies(raw.rpm)), 12000.0,
              every_right, every_wrong)
    print()
    print_table(f"{len(records)} CWRU files with every channel, declared at {len(DAQ_RATES_HZ)} rates from "
                f"{DAQ_RATES_HZ[0]:g} to {DAQ_RATES_HZ[-1]:g} Hz:", every_right, every_wrong)


if __name__ == "__main__":
    main()
