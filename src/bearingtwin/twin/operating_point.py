"""The operating point every rig has: where the sensor sits, the load, the clearance, the defect's size.

A measurement comes from a rig whose sensor position, radial load, clearance and
defect size the user may know only roughly. These are not *effects* (physics the twin
lacks) but *base parameters* the twin has and must be set to before any effect can be
judged: a twin with the sensor on the wrong race or the load zone of the wrong width
differs from the measurement in ways that effects such as ``load_zone`` or ``noise``
would otherwise be blamed for. Known values are held; unknown ones are fitted. The sensor
gain is fitted in closed form by the comparison.

The sensor is categorical (which race) and continuous (its direction in the x-y plane);
moving it costs no simulation (:class:`bearingtwin.twin.model.TwinModel` caches the four
race accelerations), so the calibration searches it on a grid inside every trial.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from bearingtwin.checks import finite_number, mapping
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.simulator import CHANNELS
from bearingtwin.twin.calibrate import Bounds, parse_space


@dataclass(frozen=True)
class BaseParameter:
    """A named operating-point parameter and the config key it sets (config value = ``scale`` x value)."""

    key: str
    scale: float
    unit: str
    description: str


BASE_PARAMETERS = {
    "radial_load_n": BaseParameter("simulator.load_y_n", -1.0, "N", "radial load (downward)"),
    "clearance_um": BaseParameter("bearing.clearance_mm", 1e-3, "um", "radial clearance per ball"),
    "defect_depth_mm": BaseParameter("simulator.defect.depth_mm", 1.0, "mm", "defect depth"),
    "defect_width_mm": BaseParameter("simulator.defect.width_mm", 1.0, "mm", "defect width"),
}
"""Continuous operating-point parameters, by the name a user gives in ``operating_point.<name>``."""

RACES = ("inner", "outer")
SENSOR_NAMES = (*CHANNELS, *RACES)
DEFECT_PARAMETERS = ("defect_depth_mm", "defect_width_mm")
"""The operating-point parameters a healthy bearing has none of."""


def held_outside_ranges(known: Mapping, bounds: Mapping) -> list[str]:
    """A note for each held value outside the range a fit of it would search (``calibration.ranges``): held as
    given, but a value so far from a rig's is more often one in another unit (a load of 2 meant in hp or kN)."""
    notes = []
    for name, value in known.items():
        if name not in bounds or bounds[name][0] <= value <= bounds[name][1] or value == 0:  # 0: an unloaded rig
            continue
        low, high = bounds[name][:2]
        parameter = BASE_PARAMETERS[name]
        side = "below" if value < low else "above"
        notes.append(f"operating_point.{name}={value:g} is held {side} the range a fit searches ({low:g}-{high:g} "
                     f"{parameter.unit}, calibration.ranges.{name}): check it is in {parameter.unit}")
    return notes


@dataclass
class OperatingPoint:
    """What is held and what is fitted of the rig's operating point.

    Args:
        known: parameter name -> value held (names of :data:`BASE_PARAMETERS`).
        free: parameter name -> search bounds (low, high, log) for those fitted.
        races: races the sensor may sit on (one when known).
        sensor_angle_deg: the sensor's direction when known (0 = x, 90 = y, vertical), else None.
        angle_step_deg: grid step of the direction search when the direction is fitted.
        extra: further dotted ``bearing.*`` / ``simulator.*`` keys fitted as they are (advanced).
        extra_known: further dotted keys held at a value (those a reference fitted: ``calibration.base_held``).
        notes: what a reader should check of the held values (one outside the range a fit would search).
    """

    known: dict = field(default_factory=dict)
    free: dict = field(default_factory=dict)
    races: tuple = RACES
    sensor_angle_deg: float | None = None
    angle_step_deg: float = 30.0
    extra: dict = field(default_factory=dict)
    extra_known: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    @classmethod
    def from_config(cls, operating_cfg: Mapping, ranges: Mapping, extra_base: Mapping | None,
                    fault: str, angle_step_deg: float = 30.0, extra_held: Mapping | None = None) -> "OperatingPoint":
        """From ``operating_point`` (null = fit), ``calibration.ranges``, ``calibration.base`` (further keys to fit)
        and ``calibration.base_held`` (further keys held); a healthy bearing has no defect to size."""
        operating = mapping("operating_point", operating_cfg)
        unknown = set(operating) - set(BASE_PARAMETERS) - {"sensor", "sensor_angle_deg"}
        if unknown:
            raise BearingTwinError(f"operating_point.{sorted(unknown)[0]} is not an operating-point parameter; "
                                   f"known: sensor, sensor_angle_deg, {', '.join(BASE_PARAMETERS)}")
        bounds = parse_space(ranges, "calibration.ranges")
        known, free = {}, {}
        for name in BASE_PARAMETERS:
            if fault == "normal" and name in DEFECT_PARAMETERS:
                continue
            value = operating.get(name)
            if value is None:
                if name not in bounds:
                    raise BearingTwinError(f"calibration.ranges.{name} is needed to fit operating_point.{name}")
                free[name] = bounds[name]
            else:
                known[name] = finite_number(f"operating_point.{name}", value, "a finite number or null")
                may_be_zero = name in ("radial_load_n", "clearance_um")  # an unloaded rig, a bearing without play
                if not (known[name] >= 0 if may_be_zero else known[name] > 0):
                    sign = "non-negative" if may_be_zero else "positive"
                    raise BearingTwinError(f"operating_point.{name}={value} must be {sign} "
                                           f"({BASE_PARAMETERS[name].description}, {BASE_PARAMETERS[name].unit})")
        sensor = operating.get("sensor")
        angle = operating.get("sensor_angle_deg")
        if sensor is not None and sensor not in SENSOR_NAMES:
            raise BearingTwinError(f"operating_point.sensor={sensor!r}: choose one of {', '.join(SENSOR_NAMES)} or null")
        if angle is not None:
            angle = finite_number("operating_point.sensor_angle_deg", angle, "a finite number or null")
            if not -360.0 <= angle <= 360.0:
                raise BearingTwinError(f"operating_point.sensor_angle_deg={angle:g}: give a direction in degrees from "
                                       "horizontal, between -360 and 360")
            if sensor in CHANNELS:
                raise BearingTwinError(f"operating_point.sensor_angle_deg: sensor={sensor} already names the direction; "
                                       "give the race (inner or outer) with an angle")
        if sensor in CHANNELS:
            races, angle = (sensor.split("_")[0],), 0.0 if sensor.endswith("_x") else 90.0
        else:
            races = (sensor,) if sensor else RACES
        angle_step_deg = finite_number("calibration.sensor_angle_step_deg", angle_step_deg)
        if not 0 < angle_step_deg <= 90:
            raise BearingTwinError(f"calibration.sensor_angle_step_deg must lie in (0, 90], got {angle_step_deg}")
        extra = parse_space(extra_base, "calibration.base")
        extra_known = {key: finite_number(f"calibration.base_held.{key}", value, "a finite number or null")
                       for key, value in mapping("calibration.base_held", extra_held).items()}
        both = sorted(set(extra) & set(extra_known))
        if both:
            raise BearingTwinError(f"calibration.base.{both[0]}: also held in calibration.base_held; fit it or hold it")
        own = {parameter.key: name for name, parameter in BASE_PARAMETERS.items()}
        for group, keys in (("calibration.base", extra), ("calibration.base_held", extra_known)):
            taken = sorted(key for key in keys if key in own or key in ("simulator.sensor", "simulator.sensor_angle_deg"))
            if taken:
                name = own.get(taken[0], "sensor")
                raise BearingTwinError(f"{group}.{taken[0]}: the operating point's {name} sets it; give "
                                       f"operating_point.{name} instead")
        return cls(known, free, races, angle, angle_step_deg, extra, extra_known, held_outside_ranges(known, bounds))

    @property
    def space(self) -> dict[str, Bounds]:
        """Everything the calibration searches by Optuna (the sensor is searched on its grid)."""
        return {**self.free, **self.extra}

    def sensor_options(self) -> list[dict]:
        """Sensor placements a calibration trial tries: the known one, or every race x direction on the grid.

        Directions a and a + 180 read the same signal but for its sign, which no comparison
        view sees, so the grid spans [0, 180).
        """
        angles = ([self.sensor_angle_deg] if self.sensor_angle_deg is not None
                  else list(np.arange(0.0, 180.0, self.angle_step_deg)))
        return [{"simulator.sensor": f"{race}_x", "simulator.sensor_angle_deg": float(a)}
                for race in self.races for a in angles]

    @property
    def angle_fitted(self) -> bool:
        return self.sensor_angle_deg is None

    def to_base(self, values: Mapping[str, float], sensor: Mapping | None = None) -> dict:
        """The dotted config keys the twin takes: held values, ``values`` of the fitted ones, the sensor."""
        base = dict(self.extra_known)
        for name, value in {**self.known, **values}.items():
            parameter = BASE_PARAMETERS.get(name)
            base[parameter.key if parameter else name] = parameter.scale * value if parameter else value
        return {**base, **dict(sensor or {})}

    def start(self, twin_value) -> dict[str, float]:
        """The config's values of the fitted parameters, the first trial (clipped into the bounds)."""
        start = {}
        for name in self.space:
            parameter = BASE_PARAMETERS.get(name)
            value = twin_value(parameter.key if parameter else name)
            if value is not None:
                start[name] = float(value) / parameter.scale if parameter else float(value)
        return start


def in_downward_load_frame(sensor_angle_deg: float, load_x_n: float, load_y_n: float,
                           weight_n: float) -> tuple[float, float | None]:
    """A sensor's direction (deg from x) and a radial load (N, in x and y) as the operating point holds them, which
    knows a downward load only: the direction, within half a turn of x, and the load, None where it is to be fitted.

    The model is isotropic and sees only the sum of the constant forces on the inner ring (the load and its weight,
    ``weight_n``), so a load in another direction is the same record in a frame turned until that sum points down: the
    sensor's direction is given in that frame, and the load as the sum's size less the weight the twin adds itself
    (where the sum is smaller than the weight, the direction is still turned and the load left to be fitted)."""
    sum_x, sum_y = load_x_n, load_y_n - weight_n
    size = math.hypot(sum_x, sum_y)
    load = size - weight_n
    angle = sensor_angle_deg
    if load_x_n == 0.0 and load_y_n <= 0.0:
        load = -load_y_n  # the twin's own frame: nothing to turn
    elif size > 0.0:
        angle += -90.0 - math.degrees(math.atan2(sum_y, sum_x))  # the turn that points the forces' sum down
    return (angle + 180.0) % 360.0 - 180.0, (load if load >= 0.0 else None)  # 400 deg is 40


def describe_sensor(sensor: Mapping) -> str:
    """"outer race, 90 deg (vertical)" for a sensor placement."""
    race = str(sensor["simulator.sensor"]).split("_")[0]
    angle = sensor.get("simulator.sensor_angle_deg")
    if angle is None:
        return str(sensor["simulator.sensor"])
    named = {0.0: "horizontal", 90.0: "vertical"}.get(round(float(angle), 6))
    return f"{race} race, {named}" if named else f"{race} race, {angle:.0f} deg from horizontal"
