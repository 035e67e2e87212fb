"""The twin's comparison: Welch spectra with the transform built once, against scipy.signal.welch per call.

    python benchmarks/compare_welch.py [--repeats 200]

``Comparator.profile`` reads two Welch spectra of every twin signal (the band levels and the
lines view). :class:`bearingtwin.signal.welch.WelchPSD` builds each ``ShortTimeFFT`` once per
measurement; the reference it replaces is ``scipy.signal.welch``, which builds it on every
call. Both profile the same 1 s twin signals (the fit half of a 2 s record) in one process,
alternating; the profiles are checked equal to the bit. Prints a markdown block for
benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np
import scipy.signal as sps
from hydra import compose, initialize_config_dir

from bearingtwin.config import CONF_DIR
from bearingtwin.data.recording import Recording
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.twin.compare import Comparator, CompareSettings

RATES_HZ = (12000.0, 25600.0, 48000.0)


class ScipyWelch:
    """The reference: ``scipy.signal.welch`` on every call, with the same window."""

    def __init__(self, fs_hz: float, window: np.ndarray):
        self.fs_hz, self.window = fs_hz, window

    def __call__(self, x):
        return sps.welch(x, fs=self.fs_hz, window=self.window, nperseg=self.window.size)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        geometry = BearingGeometry.from_config(compose("twin", overrides=["bearing=cwru_6205",
                                                                          "measured.path=unused"]).bearing)
    rng = np.random.default_rng(0)
    rows = []
    for fs in RATES_HZ:
        measured = Recording(rng.standard_normal(int(fs)), fs, 1772.0, "outer", source="noise")
        ours = Comparator(measured, geometry, CompareSettings())
        reference = Comparator(measured, geometry, CompareSettings())
        reference.psd_welch = ScipyWelch(fs, sps.get_window("hann", reference.nperseg))
        reference.lines_welch = ScipyWelch(fs, sps.get_window("blackmanharris", reference.lines_nperseg))
        twins = rng.standard_normal((8, int(fs)))
        for twin in twins:
            a, b = ours.profile(twin), reference.profile(twin)
            if not (np.array_equal(a.band_db, b.band_db) and np.array_equal(a.lines_psd, b.lines_psd)):
                raise SystemExit(f"{fs:g} Hz: WelchPSD's profile differs from scipy.signal.welch's")
        times = {"scipy.signal.welch per call": [], "WelchPSD": []}
        pair = [("scipy.signal.welch per call", reference), ("WelchPSD", ours)]
        for repeat in range(args.repeats):
            twin = twins[repeat % len(twins)]
            for name, comparator in pair if repeat % 2 == 0 else pair[::-1]:  # each goes first every other time
                start = time.perf_counter()
                comparator.compare_profiles(comparator.profile(twin))
                times[name].append(time.perf_counter() - start)
        old, new = (statistics.median(t) for t in times.values())
        rows.append(f"| {fs / 1000:g} kHz | {1000 * old:.1f} | {1000 * new:.1f} | {old / new:.2f}x | identical |")
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
          f"`python benchmarks/compare_welch.py --repeats {args.repeats}`; medians of alternating repeats.\n")
    print("| sampling rate | one comparison, scipy.signal.welch per call (ms) | with WelchPSD (ms) | speed-up | profiles |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
