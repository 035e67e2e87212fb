"""Saving and loading a fitted SVM: bearingtwin.models.persistence against skops.io, in fresh processes.

Every training run saves its classifier and every diagnosis (or model server) loads it, each in a
process of its own, so what counts is a fresh process's time to import the format's code and read
the file, beside which reading the file alone is small. The SVM is fitted on random features of a
typical size (four classes x 150 windows, 30 features); each measurement is the median of
``--repeats`` fresh processes, which also check that both files predict the same probabilities.

    python benchmarks/model_files.py [--repeats 5]

skops (the reference) is installed with MLflow, which depends on it.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

LOAD = {
    "skops.io": "import skops.io; m = skops.io.load('{folder}/svm.skops', trusted=[t for t in skops.io.get_untrusted_types("
                "file='{folder}/svm.skops') if t.startswith(('sklearn.', 'bearingtwin.'))])",
    "bearingtwin.models.persistence": "from bearingtwin.models.persistence import load_estimator; "
                                      "m = load_estimator('{folder}/svm')",
}
SAVE = {
    "skops.io": "import skops.io; skops.io.dump(m, '{folder}/svm.skops')",
    "bearingtwin.models.persistence": "from bearingtwin.models.persistence import save_estimator; "
                                      "save_estimator(m, '{folder}/svm')",
}
FIT = ("import numpy as np; from bearingtwin.models.svm import SvmClassifier; rng = np.random.default_rng(0); "
       "X = rng.standard_normal((600, 30)) + np.repeat(np.arange(4), 150)[:, None]; "
       "m = SvmClassifier().fit(X, np.repeat(np.arange(4), 150)); ")
CHECK = "; import numpy as np; np.save('{folder}/{name}.npy', m.predict_proba(np.random.default_rng(1).standard_normal((50, 30))))"


def seconds(code: str) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        fit_only = statistics.median(seconds(FIT) for _ in range(args.repeats))
        rows = {}
        for name in LOAD:
            save = statistics.median(seconds(FIT + SAVE[name].format(folder=folder)) for _ in range(args.repeats)) - fit_only
            load = statistics.median(seconds(LOAD[name].format(folder=folder) + CHECK.format(folder=folder, name=name))
                                     for _ in range(args.repeats))
            rows[name] = (save, load)
        same = np.array_equal(*(np.load(f"{folder}/{name}.npy") for name in LOAD))
    reference = rows["skops.io"]
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, Python {platform.python_version()}; "
          f"median of {args.repeats} fresh processes each")
    print("| format | save (process time beyond the fit) | load (fresh process) | load ratio (skops / this) |")
    print("|---|---|---|---|")
    for name, (save, load) in rows.items():
        saved = f"{save:.2f} s" if save > 0.05 else "under 0.05 s (within the noise of the fit's own process)"
        print(f"| {name} | {saved} | {load:.2f} s | {reference[1] / load:.1f}x |")
    print(f"same probabilities from both files: {same}")


if __name__ == "__main__":
    main()
