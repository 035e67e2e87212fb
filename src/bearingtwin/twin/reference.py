"""A reference record of the same rig: what it found is held, so a new record's ranking names what changed.

A rig's sensor placement, load, clearance and defect size, and the effects its transfer path
and noise floor need, are the same from one record to the next; what a new record adds (a
resonance that appeared, a supply line, clipping) is the question. So a user first holds the
twin against a baseline record (``bearingtwin-twin ... out=baseline``) and then against the new
one with ``reference=baseline/twin_report.json``: the reference's operating point is held
wherever the new run would otherwise fit it, and its effects are kept in the twin at their fitted
values; as candidates they are tried changed (an unbalance grown since the reference). Its noise is
kept at the absolute level it had there (``noise.reference_rms``, the report's ``noise_reference_rms``),
not as a ratio to the new twin's signal: the floor is the sensor's and the machine's, and a grown
defect must not raise it. A defect's size is held only from a reference of the same bearing state (a
healthy reference has none; a report that does not say its state gives none either). A reference
of a bearing of another geometry is refused, and so is an ``out=`` folder that holds the reference.
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import fields
from pathlib import Path
from typing import Mapping

from omegaconf import DictConfig, OmegaConf, open_dict

from bearingtwin.checks import is_finite_number
from bearingtwin.config import bearing_choices, load_bearing
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.physics.simulator import CHANNELS
from bearingtwin.twin.operating_point import BASE_PARAMETERS, DEFECT_PARAMETERS, RACES


def reference_file(reference) -> Path:
    """The report ``reference=`` names: the file given, or the ``twin_report.json`` of an earlier run's ``out=``
    folder given instead."""
    path = Path(str(reference)).expanduser()
    return path / "twin_report.json" if path.is_dir() else path


def read_reference(path) -> dict:
    """The ``twin_report.json`` at ``path`` (or in that folder), checked to hold what a reference gives: an
    operating point of numbers with the sensor's race and direction, and the final twin's effects."""
    path = reference_file(path)
    where = f"reference={path}"
    if not path.is_file():
        raise BearingTwinError(f"{where}: no such file (give the twin_report.json of an earlier bearingtwin-twin run)")
    try:
        report = json.loads(path.read_text())
    except OSError as error:
        raise BearingTwinError(f"{where}: cannot be read ({error.strerror})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise BearingTwinError(f"{where}: not a JSON file ({error})") from None
    if not isinstance(report, dict) or not isinstance(report.get("operating_point"), dict) or not (
            isinstance(report.get("steps"), list) and report["steps"]):
        raise BearingTwinError(f"{where}: not a twin_report.json (it has no operating_point and steps)")
    if "sensor" not in report["operating_point"]:
        raise BearingTwinError(f"{where}: operating_point gives no sensor (its race and angle_deg)")
    if not isinstance(report.get("measured", {}), dict):
        raise BearingTwinError(f"{where}: measured is not a mapping (the record's fault, bearing and geometry)")
    for name, entry in report["operating_point"].items():
        if name == "sensor":
            if not (isinstance(entry, dict) and entry.get("race") in RACES and is_finite_number(entry.get("angle_deg"))):
                raise BearingTwinError(f"{where}: operating_point.sensor gives no race (inner or outer) and angle_deg")
        elif not (isinstance(entry, dict) and is_finite_number(entry.get("value"))):
            raise BearingTwinError(f"{where}: operating_point.{name} has no numeric value")
    level = report.get("noise_reference_rms")
    if level is not None and not (is_finite_number(level) and level > 0):
        raise BearingTwinError(f"{where}: noise_reference_rms={level!r} is not a positive number (m/s^2) or null")
    effects = report["steps"][-1].get("params") if isinstance(report["steps"][-1], dict) else None
    if not isinstance(effects, dict) or not all(isinstance(params, dict) for params in effects.values()):
        raise BearingTwinError(f"{where}: steps[-1].params is not the final twin's effects (name -> parameters)")
    return report


def rig_geometry(geometry: BearingGeometry) -> dict:
    """What a reference's report records of its bearing to be compared by: every geometric field but the
    clearance, which is an operating-point parameter (``operating_point.clearance_um``) held from it like the load."""
    return {field.name: getattr(geometry, field.name) for field in fields(geometry) if field.name != "clearance_mm"}


def geometry_difference(recorded: Mapping, ours: Mapping) -> str | None:
    """The first field of :func:`rig_geometry` ``ours`` that ``recorded`` (a report's, or another bearing's
    :func:`rig_geometry`) gives otherwise; None where every field it gives agrees."""
    return next((name for name, value in recorded.items()
                 if name in ours and not (is_finite_number(value) and math.isclose(value, ours[name], rel_tol=1e-9))),
                None)


def reference_bearing(report: Mapping | None) -> str | None:
    """The bearing config a report's record was read with, where its name still gives the geometry the report
    recorded (a report of ``bearing.n_balls=12`` keeps the name of the bearing it changed); None otherwise."""
    measured = (report or {}).get("measured") or {}
    name, recorded = measured.get("bearing"), measured.get("geometry")
    if not name or name not in bearing_choices() or not isinstance(recorded, Mapping):
        return None
    return name if geometry_difference(recorded, rig_geometry(load_bearing(name))) is None else None


def require_same_bearing(bearing_cfg, measured: Mapping, source: str, role: str = "a reference") -> None:
    """Refuse a reference whose record's bearing has another geometry than ``bearing_cfg``, naming the field: a name
    says nothing of the geometry (``bearing.name=my6206 bearing.n_balls=12`` keeps the name). A report written
    before it recorded the geometry is compared by the bearing's name, all it holds."""
    recorded = measured.get("geometry")
    if isinstance(recorded, Mapping):
        ours = rig_geometry(BearingGeometry.from_config(bearing_cfg))
        name = geometry_difference(recorded, ours)
        if name is not None:
            named, ours_name = measured.get("bearing"), bearing_cfg.get("name")
            fits = named != ours_name and reference_bearing({"measured": measured}) is not None
            # Either run may be the one read with the wrong bearing (a baseline left at the default): both ways out.
            hint = (f" (the report's bearing is {named}, this one {ours_name}: give bearing={named} if this record is "
                    f"of it, or make the reference again with bearing={ours_name})" if fits else "")
            raise BearingTwinError(f"{source}: its record's bearing has {name}={recorded[name]}, this one "
                                   f"bearing.{name}={ours[name]}; {role} must come from the same rig{hint}")
    elif measured.get("bearing") and bearing_cfg.get("name") and measured["bearing"] != bearing_cfg.name:
        raise BearingTwinError(f"{source}: its record is of bearing {measured['bearing']}, this one of "
                               f"{bearing_cfg.name}; {role} must come from the same rig")


def refuse_reference_folder(reference, out: Path) -> None:
    """Refuse an ``out=`` folder that holds the reference's report: this run would write its own report and
    figures over the reference's."""
    reference = reference_file(reference).resolve()
    if reference.parent == out.expanduser().resolve():
        raise BearingTwinError(f"out={out} is the folder of reference={reference}: this run's report and figures "
                               "would overwrite the reference's; give this run a folder of its own")


def hold_reference(cfg: DictConfig, report: Mapping, fault: str, source: str = "reference") -> DictConfig:
    """A copy of the ``twin`` config with what ``report`` (a reference's twin report) found held.

    Every operating-point value the config leaves to be fitted (null) takes the reference's; the
    sensor takes the reference's race and direction unless the config names a direction itself;
    further keys the config would fit (``calibration.base``) are held at the reference's values
    (``calibration.base_held``), so this run's report lists them as held, as a later run reads them.
    The reference's effects (its final twin's, with their fitted parameters; its noise at the absolute level the
    report gives, ``noise_reference_rms``) come first in ``effects``, the config's own after them; those among
    ``candidates`` stay there, to be tried as changed.
    """
    held = copy.deepcopy(cfg)
    OmegaConf.set_readonly(held, False)
    operating = report["operating_point"]
    measured = report.get("measured") or {}
    require_same_bearing(cfg.bearing, measured, source)
    effects = dict(report["steps"][-1]["params"])
    level = report.get("noise_reference_rms")
    if "noise" in effects and effects["noise"].get("reference_rms") is None and level is not None:
        # The sensor's floor, in the twin's m/s^2: as a ratio to this twin's signal, a grown defect would raise it.
        effects["noise"] = {**effects["noise"], "reference_rms": float(level)}
    clash = sorted(set(effects) & set(cfg.effects))
    if clash:
        raise BearingTwinError(f"effects.{clash[0]}: the reference already keeps {clash[0]} at its fitted values; "
                               "leave it out of effects=")
    with open_dict(held):
        for name, entry in operating.items():
            if name == "sensor":
                continue
            if name in BASE_PARAMETERS:
                if name in DEFECT_PARAMETERS and measured.get("fault") != fault:  # (a healthy report has none)
                    continue
                if held.operating_point.get(name) is None:
                    held.operating_point[name] = float(entry["value"])
            elif name in held.calibration.base:  # a further key the reference fitted: held at its value
                held.calibration.base_held[name] = float(entry["value"])
                del held.calibration.base[name]
        sensor, race = held.operating_point.get("sensor"), operating["sensor"]["race"]
        given_race = sensor.split("_")[0] if sensor in CHANNELS else sensor
        if given_race not in (None, race):
            raise BearingTwinError(f"{source}: its sensor was on the {race} race, operating_point.sensor={sensor} says "
                                   f"the {given_race}; give operating_point.sensor={race} or another reference")
        if sensor not in CHANNELS:  # a channel names its direction itself
            held.operating_point.sensor = race
            if held.operating_point.get("sensor_angle_deg") is None:
                held.operating_point.sensor_angle_deg = float(operating["sensor"]["angle_deg"])
        held.effects = {**effects, **OmegaConf.to_container(held.effects, resolve=True)}
    return held
