"""The sampling-rate check on a long multi-channel recording: how its time and memory grow with the length.

A data-acquisition system writes minutes at 51.2 kHz over several accelerometers. Here CWRU record 130's three
channels (drive end, fan end, base), resampled from 12 to 51.2 kHz and repeated to 30-240 s, stand for
such a file, and its speed is typed three times too high: the check contradicts the pair, and then tries every
speed a whole factor lower (``speeds_a_whole_factor_off``), the path that reads every channel's spectrum and envelope
most often. Each case runs in a fresh process, which reports its wall time and peak memory (resident set).

    python benchmarks/rate_check_long.py                         # this checkout's check (about 1 min)
    PYTHONPATH=<other checkout>/src python benchmarks/rate_check_long.py   # another version's, to compare
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

SECONDS = (30, 60, 120, 240)
FS = 51200.0
RECORD = "12k_Drive_End_OR007@6_0_130.mat"


def one_case(seconds: float, data_root: Path) -> dict:
    """The check on ``seconds`` of the three channels; run in its own process (the peak memory is its own)."""
    import numpy as np
    import scipy.io
    import scipy.signal

    from bearingtwin.config import load_bearing
    from bearingtwin.errors import BearingTwinError
    from bearingtwin.signal.sampling_rate import require_plausible_rate

    variables = scipy.io.loadmat(data_root / "cwru" / RECORD)
    rpm = float(np.ravel(next(v for k, v in variables.items() if k.endswith("RPM")))[0])
    channels = {}
    for key in sorted(k for k in variables if k.endswith("_time")):
        resampled = scipy.signal.resample_poly(np.ravel(variables[key]), 64, 15)  # 12 kHz to 51.2 kHz
        channels[key] = np.resize(resampled, int(seconds * FS))
    signal = next(values for key, values in channels.items() if key.endswith("DE_time"))
    typed = 3.0 * rpm
    started = time.perf_counter()
    try:
        require_plausible_rate(signal, FS, typed, RECORD, "fs", defect_hz=load_bearing("cwru_6205").defect_frequencies(typed),
                               channels=channels, rpm_key="rpm")
        outcome = "accepted"
    except BearingTwinError:
        outcome = "refused"
    return {"seconds": seconds, "channels": len(channels), "wall_s": time.perf_counter() - started, "outcome": outcome,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", type=float, help=argparse.SUPPRESS)  # one case, in a process of its own
    parser.add_argument("--data-root", type=Path, default=Path(os.environ.get("BEARINGTWIN_DATA", Path(__file__).resolve()
                                                                               .parents[2] / "shared" / "data")))
    args = parser.parse_args()
    if args.case is not None:
        print(json.dumps(one_case(args.case, args.data_root)))
        return
    import bearingtwin

    print(f"# {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"bearingtwin from {Path(bearingtwin.__file__).parent}")
    print("| length | channels | outcome | wall time (s) | peak memory (MB) |\n|---|---|---|---|---|")
    for seconds in SECONDS:
        done = subprocess.run([sys.executable, __file__, "--case", str(seconds), "--data-root", str(args.data_root)],
                              capture_output=True, text=True, check=True)
        case = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"| {seconds} s at {FS / 1000:g} kHz | {case['channels']} | {case['outcome']} | {case['wall_s']:.1f} | "
              f"{case['peak_mb']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
