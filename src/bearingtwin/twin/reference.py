"""A reference record of the same rig: what it found is held, so a new record's ranking names what changed.

A rig's sensor placement, load, clearance and defect size, and the effects its transfer path
and noise floor need, are the same from one record to the next; what a new record adds (a
resonance that appeared, a supply line, clipping) is the question. So a user first holds the
twin against a baseline record (``bearingtwin-twin ... out=baseline``) and then against the new
one with ``reference=baseline/twin_report.json``: the reference's operating point is held
wherever the new run would otherwise fit it, and its effects are kept in the twin, no longer
candidates. A defect's size is held only from a reference of the same bearing state (a
healthy reference has none).
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Mapping

from omegaconf import DictConfig, OmegaConf, open_dict

from bearingtwin.errors import BearingTwinError
from bearingtwin.twin.operating_point import BASE_PARAMETERS

_DEFECT_PARAMETERS = ("defect_depth_mm", "defect_width_mm")


def read_reference(path) -> dict:
    """The ``twin_report.json`` at ``path``, checked to hold what a reference gives."""
    path = Path(str(path)).expanduser()
    if not path.is_file():
        raise BearingTwinError(f"reference={path}: no such file (give the twin_report.json of an earlier bearingtwin-twin run)")
    try:
        report = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise BearingTwinError(f"reference={path}: not a JSON file ({error})") from None
    if not isinstance(report, dict) or not isinstance(report.get("operating_point"), dict) or not report.get("steps"):
        raise BearingTwinError(f"reference={path}: not a twin_report.json (it has no operating_point and steps)")
    sensor = report["operating_point"].get("sensor")
    if not isinstance(sensor, dict) or not {"race", "angle_deg"} <= set(sensor):
        raise BearingTwinError(f"reference={path}: operating_point.sensor gives no race and angle_deg")
    return report


def hold_reference(cfg: DictConfig, report: Mapping, fault: str, source: str = "reference") -> DictConfig:
    """A copy of the ``twin`` config with what ``report`` (a reference's twin report) found held.

    Every operating-point value the config leaves to be fitted (null) takes the reference's; the
    sensor takes the reference's race and direction unless the config names a direction itself;
    further fitted keys (``calibration.base``) are set to the reference's values and no longer
    fitted. The reference's effects (its final twin's, with their fitted parameters) come first
    in ``effects``, the config's own after them, and leave ``candidates``.
    """
    held = copy.deepcopy(cfg)
    operating = report["operating_point"]
    measured = report.get("measured") or {}
    if measured.get("bearing") and cfg.bearing.get("name") and measured["bearing"] != cfg.bearing.name:
        raise BearingTwinError(f"{source}: its record is of bearing {measured['bearing']}, this one of {cfg.bearing.name}; "
                               "a reference must come from the same rig")
    same_state = measured.get("fault") in (None, fault)
    with open_dict(held):
        for name, entry in operating.items():
            if name == "sensor":
                continue
            if name in BASE_PARAMETERS:
                if name in _DEFECT_PARAMETERS and (not same_state or fault == "normal"):
                    continue
                if held.operating_point.get(name) is None:
                    held.operating_point[name] = float(entry["value"])
            elif name in held.calibration.base:  # a further key the reference fitted: held at its value
                OmegaConf.update(held, name, float(entry["value"]), force_add=False)
                del held.calibration.base[name]
        sensor, race, angle = held.operating_point.get("sensor"), operating["sensor"]["race"], operating["sensor"]["angle_deg"]
        if sensor is None or sensor == race:
            held.operating_point.sensor = race
            if held.operating_point.get("sensor_angle_deg") is None:
                held.operating_point.sensor_angle_deg = float(angle)
        elif sensor in ("inner", "outer"):
            raise BearingTwinError(f"{source}: its sensor was on the {race} race, operating_point.sensor={sensor} says "
                                   f"the {sensor}; give operating_point.sensor={race} or another reference")
        effects = dict(report["steps"][-1].get("params") or {})
        held.effects = {**effects, **OmegaConf.to_container(held.effects, resolve=True)}
        held.candidates = [name for name in held.candidates if name not in held.effects]
    return held
