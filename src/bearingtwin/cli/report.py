"""``bearingtwin-report <name> [key=value ...]``: tables from the MLflow store beside the paper's.

Names: table3, table4, vmd_params, seeds, repeat (``run_id=<id>``), and any report
registered in :mod:`bearingtwin.tracking.reports`. Common settings: ``uri=``,
``experiment=``, ``out=``, ``sweep_dir=``, ``source=`` (default simulated; ``all``), ``force=true`` (replace
a file of results from larger runs).
Exit status: 0, 1 when ``repeat`` finds a metric that differs, 2 for bad input, 130 / 143 when interrupted.
"""

from __future__ import annotations

import argparse
import os
import sys

from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.lifecycle import stop_cleanly
from bearingtwin.tracking.reports import COMMON_KEYS, REPORTS, run_report


def report_command(argv: list[str] | None = None) -> int:
    takes = "; ".join(f"{name}: {', '.join(keys)}" for name, (_, keys) in sorted(REPORTS.items()) if keys)
    parser = argparse.ArgumentParser(
        prog="bearingtwin-report", description=__doc__.splitlines()[0],
        epilog=f"Every report takes {', '.join(f'{key}=' for key in COMMON_KEYS)} (uri: the MLflow store, default "
               "MLFLOW_TRACKING_URI or the checkout's mlruns/mlflow.db, wherever the command runs; out: the markdown file, "
               "default results/<name>.md under the current folder (a variant's results/<name>_<variant>.md: "
               "table3_per_class.md, cwru_load1.md); sweep_dir: "
               "that sweep's runs only; source: data.source, default simulated, or all; force=true: replace results "
               f"of larger runs). Further settings by report: {takes}.")
    # Optional to argparse, so that its error names the one argument required (with a required positional before a
    # nargs="*" one it names both).
    parser.add_argument("name", nargs="?", help=f"report: {', '.join(sorted(REPORTS))}")
    parser.add_argument("settings", nargs="*", metavar="key=value")
    args = parser.parse_args(argv)
    if args.name is None:
        parser.error(f"the report's name is required: one of {', '.join(sorted(REPORTS))}")
    # A report reads one small artifact per run: MLflow's per-download progress bar would bury the table.
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
    settings = {}
    try:
        malformed = [item for item in args.settings if "=" not in item]
        if malformed:
            raise BearingTwinError(f"settings are key=value, got {', '.join(malformed)}")
        settings = dict(item.split("=", 1) for item in args.settings)
        report = run_report(args.name, settings)
    except BearingTwinError as error:
        message = str(error)
        if "uri" in settings and message.startswith("tracking.uri="):  # the store by the key this command takes
            message = message.replace("tracking.uri=", "uri=", 1)
        print(f"error: {message}", file=sys.stderr)
        sys.exit(2)
    print(report.markdown)
    print(f"written: {report.written} (MLflow run {report.run_id})", file=sys.stderr)  # stdout is the report itself
    if not report.ok:
        sys.exit(1)
    return 0


main = stop_cleanly(report_command)  # an interrupt (a repeat trains for minutes) says so and exits 130, as training does


if __name__ == "__main__":
    main()
