"""Every case of benchmarks/rate_check.py's rate tables, one line each, to tell two versions of the check apart case
by case (its tables give counts only): which record, at which declared rate, and the check's verdict.

    python benchmarks/rate_check_cases.py > cases_a.txt      # one version of the check
    PYTHONPATH=<other checkout>/src python benchmarks/rate_check_cases.py > cases_b.txt
    diff cases_a.txt cases_b.txt                              # the cases whose verdict moved (about 3 min)
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir

sys.path.insert(0, str(Path(__file__).parent))
import rate_check as tables  # noqa: E402  (the cases and their settings are rate_check.py's own)

from bearingtwin.config import CONF_DIR, REPO_ROOT, load_bearing  # noqa: E402
from bearingtwin.data.cwru import load_cwru  # noqa: E402
from bearingtwin.data.formats import read_raw  # noqa: E402
from bearingtwin.physics.geometry import BearingGeometry  # noqa: E402
from bearingtwin.physics.simulator import CHANNELS, simulate  # noqa: E402
from bearingtwin.testrig import FAULTS, RigOperatingPoint, simulate_rig  # noqa: E402


def say(table: str, case: str, checks) -> None:
    for declared, check in checks:
        print(f"{table} | {case} | {declared:g} Hz | {check.verdict}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("BEARINGTWIN_DATA", REPO_ROOT.parent / "shared" / "data"),
                        help="the folder holding cwru/ (default: ../shared/data)")
    records = sorted((Path(parser.parse_args().data) / "cwru").glob("*.mat"))
    if not records:
        raise SystemExit("no CWRU records found")
    bearing = load_bearing("cwru_6205")
    rates = tables.rates_around(12000.0, tables.WRONG_FACTORS[12000.0])
    for number, path in enumerate(records):
        recording = load_cwru(path, check_fs=False)
        defect_hz = bearing.defect_frequencies(recording.rpm)
        for seconds in tables.CUT_SECONDS:
            size = int(seconds * 12000)
            for start in (0, (recording.signal.size - size) // 2, recording.signal.size - size):
                say("cut", f"{path.stem} {seconds} s from sample {start}",
                    tables.checks_at(recording.signal[start:start + size], rates, recording.rpm, defect_hz))
        for snr_db in tables.NOISE_SNR_DB:
            noise = np.random.default_rng([number, snr_db]).standard_normal(recording.signal.size)
            noisy = recording.signal + noise * np.std(recording.signal) * 10 ** (-snr_db / 20)
            say("noise", f"{path.stem} {snr_db} dB", tables.checks_at(noisy, rates, recording.rpm, defect_hz))
        raw = read_raw(path)
        say("every channel", path.stem, tables.file_checks_at(raw.channels, tables.DAQ_RATES_HZ, raw.rpm,
                                                              bearing.defect_frequencies(raw.rpm)))
    for number, (fault, rpm) in enumerate((fault, rpm) for fault in FAULTS for rpm in tables.RIG_SPEEDS_RPM):
        signal = simulate_rig(fault, RigOperatingPoint(rpm=rpm, fs=12000.0, duration_s=4.0), seed=number)
        say("rig", f"{fault} {rpm:g} rpm", tables.checks_at(signal, tables.rates_around(12000.0, tables.RIG_FACTORS),
                                                             rpm, bearing.defect_frequencies(rpm)))
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        settings = compose("simulate", overrides=["simulator.fs=12000", "simulator.duration=4"])
    twin_bearing = BearingGeometry.from_config(settings.bearing)
    for fault in FAULTS:
        recording, channels = simulate(fault, settings.bearing, settings.simulator, settings.effects)
        witnesses = {"signal": recording.signal, **dict(zip(CHANNELS, channels))}
        say("twin", fault, tables.file_checks_at(witnesses, rates, recording.rpm,
                                                 twin_bearing.defect_frequencies(recording.rpm)))


if __name__ == "__main__":
    main()
