"""The sim2real protocol's physics-first rule beside a classifier that knows nothing.

Protocol version 9 lets the envelope spectrum decide each test window where one defect series leaves no doubt, and
its classifier the rest. How much of its score is the rule's: the same rule, on the same test windows, with a
"classifier" that calls every window it is left one state. Reads the protocol in force (``+experiment=sim2real``)
for the records, the windows and the rule's thresholds; simulates nothing.

    python scripts/sim2real_constant_class.py                 # the protocol in force (a few seconds)
    python scripts/sim2real_constant_class.py +experiment=sim2real_v9
"""

from __future__ import annotations

import sys

import numpy as np

from bearingtwin.config import compose_config
from bearingtwin.data.cwru import declared_fs_hz, load_cwru
from bearingtwin.data.twin_to_real import check_twin_to_real_settings, protocol_records
from bearingtwin.data.windows import cut_windows
from bearingtwin.models.experiment import physics_first_from
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.tracking.tables import markdown_table


def refuse(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def main(overrides: list[str]) -> None:
    composed = compose_config("train", overrides or ["+experiment=sim2real"])
    cfg = check_twin_to_real_settings(composed.data, composed.bearing)
    rule = physics_first_from(composed)
    if rule is None:
        refuse(f"protocol {composed.get('protocol', '?')} lets its classifier decide every window: no rule to score "
               "beside it (version 9 and later have one)")
    if cfg.get("labels"):
        refuse("this script reads the CWRU records by their names; a labels table's rig is not read here")
    calibration, tests = protocol_records(cfg, None)
    # As the protocol scores them: its test records, and the calibration records' validation windows (record 97's
    # for false alarms); the rates as the protocol declares them.
    scored = [(path, cfg["test"]["windows_per_record"]) for path in tests]
    scored += [(path, cfg["calibration"]["validation_windows_per_record"]) for path in calibration]
    physics = {}  # per record: its true state and the rule's state of each window (None: left to the classifier)
    for path, n_windows in scored:
        record = load_cwru(path, channel=cfg["channel"], fs=declared_fs_hz(path, cfg["fs"]), check_fs=False)
        windows, _ = cut_windows(record.signal, int(cfg["window_length"]), int(n_windows))
        physics[path.stem] = record.fault, rule.states(windows, record.fs, record.rpm, dict(composed.bearing))
    rows = []
    for constant in FAULTS:
        right = total = records_right = 0
        healthy_shares = []
        calibration_names = {path.stem for path in calibration}
        for name, (truth, states) in physics.items():
            called = np.array([state or constant for state in states])
            if name in calibration_names:  # scored for false alarms (the healthy one) or not at all
                if truth == "normal":
                    healthy_shares.append(float(np.mean(called == "normal")))
                continue
            right += int(np.sum(called == truth))
            total += called.size
            records_right += int(max(FAULTS, key=lambda state: np.sum(called == state)) == truth)
        rows.append([f"every window left to it called {constant}", f"{100 * right / total:.1f} ({right}/{total})",
                     f"{records_right}/{len(tests)}",
                     ", ".join(f"{100 * share:.0f}" for share in healthy_shares) or "-"])
    test_states = [physics[path.stem][1] for path in tests]
    decided = sum(state is not None for states in test_states for state in states)
    print(f"Protocol {composed.get('protocol', '?')}: the physics decides {decided} of "
          f"{sum(len(states) for states in test_states)} test windows "
          f"({rule.threshold_db:g} dB over the floor, {rule.margin_db:g} dB above the others).\n")
    print(markdown_table(["classifier under the rule", "test windows right %", "test records right",
                          "healthy record's windows called healthy %"], rows))


if __name__ == "__main__":
    main(sys.argv[1:])
