"""Read time of one full-size HUST export (262,144 rows): the project's reader vs numpy.loadtxt.

Writes a synthetic file of the real size in a temporary folder, then times each reader
(best of 3). Usage: python benchmarks/hust_read.py
"""

import tempfile
import time
from pathlib import Path

import numpy as np

from bearingtwin.data.hust import read_hust_raw

ROWS = 262_144
FS_HZ = 25600.0


def best_of(n, task):
    times = []
    for _ in range(n):
        start = time.perf_counter()
        task()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "H_65Hz.xls"
        rng = np.random.default_rng(0)
        table = np.column_stack([np.arange(ROWS) / FS_HZ, np.zeros(ROWS), rng.standard_normal((ROWS, 3))])
        with open(path, "w") as handle:
            handle.write("".join(f"Header line {i}:\tvalue\n" for i in range(21)) + "Data\n")
            np.savetxt(handle, table, fmt=["%.6f", "%.1f", "%.6f", "%.6f", "%.6f"], delimiter="\t")
        reference = best_of(3, lambda: np.loadtxt(path, skiprows=22, delimiter="\t"))
        ours = best_of(3, lambda: read_hust_raw(path))
        print(f"numpy.loadtxt: {reference:.3f} s   read_hust_raw: {ours:.3f} s   ratio loadtxt/ours: {reference / ours:.1f}")


if __name__ == "__main__":
    main()
