"""Benchmark: the network on the pinned CPU kernels against the machine's own (``bearingtwin.PINNED_CPU_KERNELS``).

Importing bearingtwin pins torch to its portable kernels and MKL to its conditional numerical reproducibility, so
that every x86-64 machine trains the same model; this measures what that costs. Each measurement runs in a
fresh process (the kernels are chosen when torch loads), the two settings interleaved ``--repeats`` times, on
the CNN-BiLSTM as the paper's method runs it (one torch thread): fitting ``--epochs`` epochs and classifying one
sample, on the nine features of a VMD mode and on raw 2048-point windows. Ratios are pinned / native medians.

Usage:
    python benchmarks/cpu_kernels.py [--repeats 3] [--epochs 10]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys

import numpy as np

MEASURE = """
import json, sys, time
import numpy as np
import bearingtwin
import torch
from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier

epochs = int(sys.argv[1])
rng = np.random.default_rng(0)
out = {"capability": torch.backends.cpu.get_cpu_capability()}
for name, width, n in (("features", 9, 420), ("raw", 2048, 120)):
    y = np.repeat(np.arange(4), n // 4)
    X = rng.normal(size=(n, width)) + y[:, None]
    start = time.perf_counter()
    classifier = CnnBiLstmClassifier(max_epochs=epochs, random_state=0).fit(X, y)
    out[f"{name}_fit_s"] = time.perf_counter() - start
    times = []
    for row in X[:40]:
        start = time.perf_counter()
        classifier.predict_proba(row[None])
        times.append(time.perf_counter() - start)
    out[f"{name}_predict_ms"] = 1000 * float(np.median(times))
print(json.dumps(out))
"""


def native_environment() -> dict[str, str]:
    """The environment in which torch and MKL choose their kernels by the machine: each pinned variable set to the
    machine's own choice (bearingtwin would otherwise set its pinned value)."""
    from bearingtwin import PINNED_CPU_KERNELS

    unpinned = {name: value for name, value in os.environ.items() if name not in PINNED_CPU_KERNELS}
    probe = subprocess.run([sys.executable, "-c", "import torch; print(torch.backends.cpu.get_cpu_capability())"],
                           env=unpinned, capture_output=True, text=True, check=True)
    return {**unpinned, "ATEN_CPU_CAPABILITY": probe.stdout.strip().lower(), "MKL_CBWR": "AUTO",
            "DNNL_MAX_CPU_ISA": "ALL"}


def measure(env: dict[str, str], epochs: int) -> dict:
    done = subprocess.run([sys.executable, "-c", MEASURE, str(epochs)], env=env, capture_output=True, text=True,
                          check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--epochs", type=int, default=10)
    args = parser.parse_args()
    from bearingtwin import PINS_CPU_KERNELS

    if not PINS_CPU_KERNELS:
        sys.exit("the pinned kernels are x86's: nothing to compare on this machine")
    settings = {"pinned": dict(os.environ), "native": native_environment()}
    runs: dict[str, list[dict]] = {name: [] for name in settings}
    for _ in range(args.repeats):  # interleaved: the machine's load falls on both alike
        for name, env in settings.items():
            runs[name].append(measure(env, args.epochs))
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
          f"kernels: pinned {runs['pinned'][0]['capability']}, native {runs['native'][0]['capability']}; "
          f"{args.repeats} interleaved runs, {args.epochs} epochs, medians")
    print("| what | pinned | native | pinned / native |")
    print("|---|---|---|---|")
    for key in (key for key in runs["pinned"][0] if key != "capability"):
        pinned = float(np.median([run[key] for run in runs["pinned"]]))
        native = float(np.median([run[key] for run in runs["native"]]))
        print(f"| {key} | {pinned:.3g} | {native:.3g} | {pinned / native:.2f} |")


if __name__ == "__main__":
    main()
