"""``bearingtwin-inspect <file>``: a JSON summary of any vibration file the project reads.

Reports what the file holds (format, channels, samples, NaN count, sampling rate, speed)
rather than judging it, so a file with NaNs is described, not refused; a file that cannot
be read at all (missing, empty, truncated, non-numeric) exits 2 naming the file and the
problem. With ``--bearing`` the bearing's defect frequencies are added, in Hz when the
speed is known and always as orders (multiples of the shaft speed). CWRU records also get
the shaft-line check of their declared sampling rate.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
from hydra import compose, initialize_config_dir
from hydra.errors import MissingConfigException

from bearingtwin.config import CONF_DIR
from bearingtwin.data.cwru import check_shaft_line
from bearingtwin.data.files import read_raw, resolve_fs
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="bearingtwin-inspect", description=__doc__.splitlines()[0])
    parser.add_argument("file", help="a .npy, .npz, .csv, .mat (generic or CWRU), .wav or .xls (HUST) file")
    parser.add_argument("--bearing", help="bearing config name in conf/bearing (paper, cwru_6205, er16k)")
    parser.add_argument("--fs", type=float, help="sampling rate in Hz, when the file does not state it")
    parser.add_argument("--rpm", type=float, help="shaft speed in rev/min, when the file does not state it")
    parser.add_argument("--channel", help="channel to summarise in detail (default: all)")
    args = parser.parse_args(argv)
    try:
        summary = summarize(args.file, bearing=args.bearing, fs=args.fs, rpm=args.rpm, channel=args.channel)
    except BearingTwinError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
    print(json.dumps(summary, indent=2))


def summarize(path, bearing: str | None = None, fs: float | None = None, rpm: float | None = None, channel=None) -> dict:
    """The inspect report of one file as a JSON-ready dict."""
    raw = read_raw(path)
    names = [raw.channel(channel)[0]] if channel is not None else list(raw.channels)
    fs_hz = resolve_fs(raw, fs) if (fs is not None or raw.fs is not None) else None
    rpm = rpm if rpm is not None else raw.rpm
    lengths = {name: int(raw.channels[name].size) for name in names}
    n_samples = next(iter(lengths.values())) if len(set(lengths.values())) == 1 else lengths
    summary = {
        "file": raw.path,
        "format": raw.format,
        "channels": list(raw.channels),
        "fs_hz": fs_hz,
        "fs_origin": "option" if fs is not None else (raw.fs_origin or None),
        "rpm": rpm,
        "fault": raw.fault,
        "unit": raw.unit or None,
        "n_samples": n_samples,
        "duration_s": None if fs_hz is None or isinstance(n_samples, dict) else n_samples / fs_hz,
        "nan_count": {name: int(np.count_nonzero(np.isnan(raw.channels[name]))) for name in names},
        "inf_count": {name: int(np.count_nonzero(np.isinf(raw.channels[name]))) for name in names},
        "meta": {key: value for key, value in raw.meta.items() if key != "header"},
    }
    if raw.format == "cwru-mat" and rpm is not None and fs_hz is not None:
        signal = raw.channels[names[0]]
        if np.all(np.isfinite(signal)):
            summary["shaft_line_check"] = check_shaft_line(signal, fs_hz, rpm).as_dict()
    if bearing is not None:
        geometry = load_bearing(bearing)
        summary["bearing"] = bearing
        summary["defect_orders"] = {key: value for key, value in geometry.defect_frequencies(60.0).items() if key != "shaft"}
        if rpm is not None:
            summary["defect_frequencies_hz"] = geometry.defect_frequencies(rpm)
    return summary


def load_bearing(name: str) -> BearingGeometry:
    """The geometry of ``conf/bearing/<name>.yaml``, composed as Hydra would."""
    try:
        with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
            cfg = compose(overrides=[f"+bearing={name}"])
    except MissingConfigException:
        raise BearingTwinError(f"--bearing {name!r}: no such bearing config in {CONF_DIR}/bearing") from None
    return BearingGeometry.from_config(cfg.bearing)


if __name__ == "__main__":
    main()
