"""Benchmark: diagnose a 10 s, 12 kHz CWRU record with the proposed model (SABO-VMD global + CNN-BiLSTM).

Goal: at least 100x faster than real time on 2 cores. Times what ``bearingtwin-diagnose`` does
per record (``read_record`` + ``diagnose_recording``, figures and file writing excluded) over
``--repeats`` runs after one warm-up, median, as shipped (one thread each for numba and torch, set
when the model loads) and with both at one thread per core (interleaved). The split into stages - reading (+ shaft-line check,
+ resampling when the rates differ), VMD features, network, physics evidence, and the rest
(pyfunc wrapper: schema check, DataFrame; windows; the result) - comes from cProfile over as
many diagnoses again. ``--profile`` prints the profiles' listings.

Without ``--model`` it trains its own model into a temporary MLflow store first
(``bearingtwin-train data=cwru`` at smoke size: the cost of a prediction does not depend on
the training size). With ``--model models:/<name>@<alias>`` it uses ``MLFLOW_TRACKING_URI``.

Usage:
    python benchmarks/diagnose.py [--repeats 15] [--record PATH] [--profile]
    MLFLOW_TRACKING_URI=sqlite:///... python benchmarks/diagnose.py --model models:/bearing@champion
"""

from __future__ import annotations

import argparse
import cProfile
import io
import os
import platform
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from bearingtwin.config import CONF_DIR, data_root
from bearingtwin.diagnosis.mlflow_model import load_diagnosis_model
from bearingtwin.diagnosis.record import diagnose_recording, read_record, resample_to

CWRU = data_root() / "cwru"
DEFAULT_RECORD = CWRU / "12k_Drive_End_IR007_1_106.mat"  # 10.1 s at 12 kHz, 1 hp inner race
# The proposed method at smoke size: default features (SABO-VMD pe_mie, vmd_params=global) and classifier (CNN-BiLSTM).
TRAIN_OVERRIDES = ["data=cwru", "data.samples_per_class=30", "trainer.max_epochs=3", "search.population=6",
                   "search.iterations=3", "features.progress=false"]
MODEL_NAME, MODEL_ALIAS = "diagnose-benchmark", "champion"
GOAL_REAL_TIME_RATIO = 100.0


def train_model(store_dir: Path) -> tuple[str, str]:
    """Train and register the proposed model into a fresh SQLite store; its URI and the store's."""
    tracking_uri = f"sqlite:///{store_dir / 'mlflow.db'}"
    env = dict(os.environ, MLFLOW_TRACKING_URI=tracking_uri, BEARINGTWIN_CACHE=str(store_dir / "cache"))
    command = [sys.executable, "-m", "bearingtwin.cli.train", *TRAIN_OVERRIDES,
               f"register={MODEL_NAME}", f"register_alias={MODEL_ALIAS}"]
    print("training:", " ".join(command[1:]), flush=True)
    start = time.perf_counter()
    done = subprocess.run(command, env=env, cwd=store_dir, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"bearingtwin-train failed ({done.returncode}):\n{done.stderr[-3000:]}")
    print(f"trained in {time.perf_counter() - start:.0f} s", flush=True)
    return f"models:/{MODEL_NAME}@{MODEL_ALIAS}", tracking_uri


def median_time(task, repeats: int) -> tuple[float, object]:
    """Median wall time of ``task()`` over ``repeats`` calls, and its last result."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = task()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), result


def load_average() -> str:
    try:
        return " ".join(f"{value:.2f}" for value in os.getloadavg())
    except OSError:
        return "n/a"


def describe_machine() -> str:
    import numba
    import torch

    return (f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}, "
            f"numba {numba.__version__} ({numba.get_num_threads()} threads), torch {torch.__version__} "
            f"({torch.get_num_threads()} threads)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="models:/<name>@<alias> | runs:/<id>/model (store: MLFLOW_TRACKING_URI)")
    parser.add_argument("--record", type=Path, default=DEFAULT_RECORD)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--profile", action="store_true", help="print the cProfile listing behind the split")
    args = parser.parse_args()
    if not args.record.is_file():
        sys.exit(f"record not found: {args.record} (set BEARINGTWIN_DATA or --record)")

    with tempfile.TemporaryDirectory(prefix="bearingtwin-diagnose-bench-") as folder:
        if args.model:
            model_uri = args.model
            tracking_uri = os.environ.get("MLFLOW_TRACKING_URI") or sys.exit("--model needs MLFLOW_TRACKING_URI")
        else:
            model_uri, tracking_uri = train_model(Path(folder))
        run(model_uri, tracking_uri, args)


def run(model_uri: str, tracking_uri: str, args) -> None:
    import numba
    import torch

    evidence_settings = OmegaConf.to_container(OmegaConf.load(Path(CONF_DIR) / "diagnose.yaml").evidence, resolve=True)
    print(f"machine: {describe_machine()}")
    print(f"load average at start: {load_average()}")

    start = time.perf_counter()
    model, pipeline, _ = load_diagnosis_model(model_uri, tracking_uri)
    load_s = time.perf_counter() - start
    extractor = pipeline.extractor
    print(f"model {model_uri}: {type(extractor).__name__} (vmd_params={getattr(extractor, 'vmd_params', '-')}, "
          f"k, alpha = {[(r['k'], round(r['alpha'])) for r in getattr(extractor, 'vmd_params_', [])]}) + "
          f"{type(pipeline.classifier).__name__}; {pipeline.window_length} samples at {pipeline.fs_hz:g} Hz; "
          f"loaded in {load_s:.2f} s")

    def diagnose_once():
        prepared = read_record(args.record, pipeline)
        return diagnose_recording(prepared, model, pipeline, model_uri, evidence_settings)[0]

    start = time.perf_counter()
    result = diagnose_once()  # warm-up: numba's compiled code is loaded from its cache or compiled here
    first_s = time.perf_counter() - start

    # numba (VMD) and torch (network) each run their own OpenMP thread pool; on 2 cores the two pools
    # can spin against each other. Both thread counts can be changed at run time, so the settings are
    # compared in one process, interleaved repeat by repeat so that the machine's load hits them alike.
    # Loading the model sets one thread each (diagnosis.mlflow_model.use_one_thread_per_library); the other
    # setting is what both libraries would start with on this machine.
    cores = os.cpu_count() or 1
    settings = {"as shipped": (numba.get_num_threads(), torch.get_num_threads()), "one thread per core each": (cores, cores)}
    times = {name: [] for name in settings}
    profilers = {name: cProfile.Profile() for name in settings}  # where the time goes, from the same calls
    for _ in range(args.repeats):
        for name, (numba_threads, torch_threads) in settings.items():
            numba.set_num_threads(numba_threads)
            torch.set_num_threads(torch_threads)
            start = time.perf_counter()
            result = diagnose_once()
            times[name].append(time.perf_counter() - start)
    for _ in range(args.repeats):  # profiled separately: cProfile's overhead stays out of the timings
        for name, (numba_threads, torch_threads) in settings.items():
            numba.set_num_threads(numba_threads)
            torch.set_num_threads(torch_threads)
            profilers[name].enable()
            diagnose_once()
            profilers[name].disable()
    numba.set_num_threads(settings["as shipped"][0])
    torch.set_num_threads(settings["as shipped"][1])

    prepared = read_record(args.record, pipeline)
    recording = prepared.recording
    other_fs = 10000.0 if abs(recording.fs - 10000.0) > 1 else 12000.0  # what a record at another rate would cost
    resample_s, _ = median_time(lambda: resample_to(recording, other_fs), args.repeats)

    duration_s = recording.signal.size / recording.fs
    n_windows = len(result["windows"])
    print(f"load average at end: {load_average()}")
    print(f"\nrecord {args.record.name}: {duration_s:.2f} s at {recording.fs:g} Hz, rpm {recording.rpm:g}, "
          f"{n_windows} windows; verdict {result['verdict']} ({result['share']:.0%}), physics {result['evidence_state']}; "
          f"first diagnosis (warm-up) {first_s * 1e3:.0f} ms\n")
    print(f"| threads (numba, torch) | median of {args.repeats} ms | min ms | x real time | ms per window |\n|---|---|---|---|---|")
    for name, (numba_threads, torch_threads) in settings.items():
        median_s, best_s = float(np.median(times[name])), min(times[name])
        print(f"| {name} ({numba_threads}, {torch_threads}) | {median_s * 1e3:.1f} | {best_s * 1e3:.1f} | "
              f"{duration_s / median_s:.0f}x | {median_s / n_windows * 1e3:.2f} |")
    print(f"(goal: >= {GOAL_REAL_TIME_RATIO:.0f}x faster than real time)\n")

    print("| stage (cProfile, ms per diagnosis) | " + " | ".join(settings) + " |\n|---|" + "---|" * len(settings))
    splits = {name: profile_split(pstats.Stats(profiler), args.repeats) for name, profiler in profilers.items()}
    for stage in next(iter(splits.values())):
        cells = [f"{splits[name][stage] * 1e3:.1f} ({splits[name][stage] / splits[name]['total'] if stage != 'total' else 1:.0%})"
                 for name in settings]
        print(f"| {stage} | " + " | ".join(cells) + " |")
    print(f"\nresample_poly {recording.fs:g} -> {other_fs:g} Hz of this record, were its rate not the model's: "
          f"{resample_s * 1e3:.1f} ms (this model runs at the record's rate: not in the timings above)")
    if args.profile:
        for name, profiler in profilers.items():
            stream = io.StringIO()
            pstats.Stats(profiler, stream=stream).sort_stats("cumulative").print_stats(25)
            print(f"\ncProfile of {args.repeats} diagnoses, {name} (cumulative):\n" + stream.getvalue())


def profile_split(profile: pstats.Stats, calls: int) -> dict[str, float]:
    """Seconds per diagnosis of each stage, from the cumulative times of the functions that do it."""
    at = {name: cumulative_s(profile, *where) / calls for name, where in PROFILED.items()}
    # decide = features + classifier + overrule; physics_evidence runs for the record alone (overrule reads the
    # windows' spectra in one batch, without it).
    return {
        "read file + shaft-line check": at["read"],
        "VMD features (normalise, VMD, mode choice, 9 features)": at["features"],
        "network (states and probabilities)": at["classify"] - at["features"] - at["physics first"],
        "physics first (the windows' envelope spectra, physics_first models)": at["physics first"],
        "physics evidence (the record's)": at["evidence"],
        "pyfunc wrapper, windows, result": at["diagnose"] - at["classify"] - at["evidence"],
        "total": at["total"],
    }


# Stage -> (file name ending, function name) whose cumulative time the profile gives it.
PROFILED = {
    "total": ("benchmarks/diagnose.py", "diagnose_once"),
    "read": ("diagnosis/record.py", "read_record"),
    "diagnose": ("diagnosis/record.py", "diagnose_recording"),
    "classify": ("diagnosis/pipeline.py", "decide"),
    "physics first": ("diagnosis/pipeline.py", "overrule"),
    "features": ("diagnosis/pipeline.py", "features"),
    "evidence": ("diagnosis/evidence.py", "physics_evidence"),
}


def cumulative_s(profile: pstats.Stats, file_ending: str, function: str) -> float:
    """Total cumulative seconds of ``function`` defined in a file ending with ``file_ending``."""
    found = [ct for (file, _, name), (_, _, _, ct, _) in profile.stats.items()
             if name == function and file.replace(os.sep, "/").endswith(file_ending)]
    if not found:
        raise RuntimeError(f"{file_ending}:{function} not in the profile: the diagnosis path changed, update PROFILED")
    return sum(found)


if __name__ == "__main__":
    main()
