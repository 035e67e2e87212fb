"""``bearingtwin-twin``: compare the twin with a measurement, calibrate it, rank the effects it misses.

    bearingtwin-twin measured.path=<file> measured.fs=12000 measured.rpm=1797 measured.fault=outer out=<dir>

Writes <dir>/twin_report.json (the measurement, the verdict, the fitted operating point, the ranking, the effects
added step by step and what was left unexplained: README's "Holding the twin against a measurement" lists its keys)
and PNG figures beside it; logs them to MLflow unless tracking.enabled=false.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig

from bearingtwin.checks import show_progress_bar
from bearingtwin.cli.summary import closing_summary
from bearingtwin.config import exit_on_user_error, hydra_command, refuse_unknown_keys
from bearingtwin.tracking.lifecycle import stop_cleanly

if TYPE_CHECKING:
    from bearingtwin.twin.rank import TwinFit


def twin_summary(cfg: DictConfig, fit: TwinFit, files: list[Path], run_id: str | None,
                 notes: dict[str, str] | None = None) -> str:
    """The verdict, the effects found in order, how much of the discrepancy they closed, and what the run said of
    the record at its start (``bearing``: the record's own, read as no bearing= was given, or one no config
    describes; ``check``: the envelope questions the stated state)."""
    if fit.added:
        found = ", ".join(added.effect + (" (changed)" if added.changed_from is not None else "") for added in fit.added)
    elif not fit.ranking and not fit.found_nothing:
        found = f"no effect tried: {fit.not_tried}"
    elif fit.unclaimed is not None:
        found = f"none claimed ({fit.unclaimed.effect} paid only outside its signature's views)"
    else:
        found = f"none pays for its parameters on the {'held-out half' if fit.held_out else 'record'}"
    drop = fit.baseline_error - fit.final_error
    share = f" ({100 * drop / fit.baseline_error:.0f} % less)" if fit.baseline_error > 0 else ""
    new = fit.new_unexplained  # less the views the rig showed as they are in a reference record
    unexplained = ", ".join(left["view"] for left in new)
    lines = {
        "verdict": fit.verdict + (f" (unexplained in the {unexplained} view{'s' if len(new) > 1 else ''})"
                                  if unexplained else ""),
        "effects found": found,
        "discrepancy": (f"{fit.baseline_error:.2f} -> {fit.final_error:.2f} dB{share}" if fit.added
                        else f"{fit.baseline_error:.2f} dB, no effect added")
                       + (f", the measurement's own {fit.floor_error:.2f} dB" if fit.held_out
                          else " (too short to hold out half: its own is unknown)"),
        "written": f"{files[0].name} and {len(files) - 1} figures",
    }
    # A value held from a reference that its own record did not identify is a number that means little: said so, and
    # given to two digits.
    held = [(f"{name} {entry['value']}" if isinstance(entry["value"], str)  # the sensor: "outer race, vertical"
             else f"{name.removesuffix('_' + entry['unit'].lower()).replace('_', ' ')} "
                  f"{entry['value']:{'.2g' if entry.get('identified_by_reference') is False else '.4g'}} "
                  f"{entry['unit']}".rstrip())
            + (" (the reference record hardly identified it)" if entry.get("identified_by_reference") is False else "")
            for name, entry in fit.operating_point.items() if entry.get("held")]
    if held:  # given with operating_point.*, or held from a reference's report
        lines["operating point held"] = ", ".join(held)
    if fit.since_reference is not None:
        changes = [f"{entry['view']}: {entry['where']}" for entry in fit.since_reference]
        shapes = "; ".join(changes) or ("nothing else changed beyond the measurement's own scatter" if fit.level_change
                                        else "nothing changed beyond the measurement's own scatter")
        lines["since the reference record"] = "; ".join(filter(None, [fit.level_change, shapes]))
    elif fit.reference_note:
        lines["since the reference record"] = f"not compared: {fit.reference_note}"
    if cfg.effects:  # known present, in every step: the summary says so, as it says the reference's
        tried = [name for name in cfg.effects if name in cfg.candidates]
        lines["held in the twin"] = ", ".join(cfg.effects) + " (effects=)" + (
            f"; tried as changed: {', '.join(tried)}" if tried else "")
    lines = {**(notes or {}), **lines}
    if cfg.get("reference") is not None:
        kept = ", ".join(name + (" (its floor at the reference's absolute level)" if name == "noise" and params.get(
            "reference_rms") is not None else "") for name, params in fit.steps[0].effects.items()
            if name not in cfg.effects) or "none"
        lines = {"reference": f"{cfg.reference} (its operating point held where this run gives none; its effects "
                              f"kept: {kept})", **lines}
    title = f"bearingtwin-twin: {Path(str(cfg.measured.path)).name}"
    return closing_summary(title, lines, run_id, str(cfg.tracking.uri) if run_id else None,
                           str(files[0].parent.resolve()), str(cfg.tracking.experiment) if run_id else None)


@hydra_command("twin")
@exit_on_user_error
def twin(cfg: DictConfig) -> None:
    hydra_cfg = HydraConfig.get()
    refuse_unknown_keys(hydra_cfg)
    from bearingtwin.twin.report import run_twin  # MLflow and the simulator once the input is accepted

    # The calibration takes seconds to minutes: its stages are shown where someone watches (a terminal, one run).
    progress = show_progress_bar("auto", in_sweep=hydra_cfg.mode == RunMode.MULTIRUN)
    fit, files, run_id, notes = run_twin(cfg, progress)
    print(fit.summary)
    print(twin_summary(cfg, fit, files, run_id, notes))


main = stop_cleanly(twin)  # a signal marks the MLflow run KILLED, never left RUNNING


if __name__ == "__main__":
    main()
