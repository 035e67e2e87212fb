"""The closing block every entry point prints: what it did, where the run is, where the files are.

A newcomer reads the last lines of a command's output, so each command ends with the same
short block on stdout::

    == bearingtwin-train: sabo_vmd_pemie+cnn_bilstm simulated global seed=0 ==
      accuracy: 96.00 %
      F1 per class: normal 1.000, inner 0.950, ball 0.930, outer 0.960
      MLflow run: 3f2c... in experiment bearingtwin  (mlflow ui --backend-store-uri sqlite:////home/me/...)
      output: /home/me/bearingtwin/outputs/2026-01-01/12-00-00

Progress bars and warnings go to stderr, so ``cmd > result.txt`` keeps just this block.
"""

from __future__ import annotations

from typing import Mapping, Sequence

from bearingtwin.tracking import open_command


def closing_summary(
    title: str,
    lines: Sequence[str] | Mapping[str, object],
    run_id: str | None = None,
    tracking_uri: str | None = None,
    out: str | None = None,
    experiment: str | None = None,
) -> str:
    """The closing block of a command, ready to print.

    Args:
        title: what ran, e.g. ``"bearingtwin-train: sabo_vmd_pemie+cnn_bilstm simulated global seed=0"``.
        lines: the key results, as ready-made lines or as ``{label: value}`` (printed ``label: value``).
        run_id: the MLflow run that holds everything; omitted when nothing was logged.
        tracking_uri: the MLflow store of ``run_id``; gives the command that opens it.
        out: the folder or file the command wrote; omitted when None.
        experiment: the MLflow experiment of ``run_id`` (a ``MLFLOW_EXPERIMENT_NAME`` in the shell changes it).
    """
    body = [f"{label}: {value}" for label, value in lines.items()] if isinstance(lines, Mapping) else list(lines)
    if run_id is not None:
        body.append(f"MLflow run: {run_id}" + (f" in experiment {experiment}" if experiment else "")
                    + (f"  ({open_command(tracking_uri)})" if tracking_uri else ""))
    if out is not None:
        body.append(f"output: {out}")
    return "\n".join([f"== {title} ==", *(f"  {line}" for line in body)])


def percent(fraction: float) -> str:
    """A score in [0, 1] as the percentage the results files use (``0.96`` -> ``96.00 %``)."""
    return f"{100 * fraction:.2f} %"
