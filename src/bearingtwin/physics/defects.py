"""Localized defects as the depth function h_j(t) in the contact deflection of ball j.

A defect is a pit of circumferential width w and depth d on the outer race (fixed),
the inner race (turning with the shaft) or one ball (turning with the ball's spin, so
it meets the outer race and, half a spin later, the inner race: twice per spin).

Depth actually seen by the ball: a ball of radius Rb cannot reach the bottom of a pit
narrower than itself; it rests on the two edges, its centre dropping by at most the
ball's sagitta over the chord w, Rb - sqrt(Rb^2 - (w/2)^2) (about 9 um for
w = 0.533 mm, Db = 7.94 mm), corrected by the race's own sagitta over the same chord,
R - sqrt(R^2 - (w/2)^2): added on the convex inner race (its surface falls away under
the edges), subtracted on the concave outer race (its surface rises to meet them); about
+-2 um here. The effective depth is the smaller of that and d. The correction is what
makes the two strikes of a ball defect unequal (inner-race contact drops deeper), so the
ball-defect envelope shows BSF and not only 2 x BSF.

Profile: h = h_max cos^2(pi s / w) for |s| < w/2 (s: arc length from the pit centre
along the contact path), zero outside. This is a choice, not the exact ball-on-edge
trajectory: it is continuous with a continuous slope at the edges, so an adaptive
solver needs no event handling, a fixed-step solver does not depend on where an edge
falls inside a step, and both see the same well-defined excitation. The ball enters
and leaves over w/2 each, taking ~0.15 ms each way at 1797 rpm.

Limits of the lumped pit, which the paper shares. The drop is bounded by the curvatures in the
rolling direction only, as for a trough across the whole track: a round pit of the same width
(CWRU's EDM holes) in a conforming groove lets the ball drop much less, since the contact
ellipse, wider across the groove than such a pit, bridges it. And with massless balls and a
smooth profile a pit can only unload a ball, never strike it on re-entry: the peak acceleration
is capped near the ball's load over the race's mass: under gravity alone (the paper's set-up) the
peaks hardly grow above a width of about 0.36 mm while the RMS and the envelope lines still do;
under a radial load of some hundred newtons they keep growing. A pit deeper than the ball's deflection
under its load (about 9 um at 500 N on the 6205, reached at about 0.6 mm wide) lifts the ball off the
race; the ball then comes back over a distance sqrt(8 Rb delta) / pi (delta its deflection) whatever the
width, for as long as the drop is the sagitta, growing as w^2. Once the pit's depth caps the drop (about
3 mm wide for a 0.28 mm deep pit), the cos^2 edges spread the return over a distance growing with w, the
strikes soften and the vibration falls (RMS at 500 N, outer race: 6, 20, 27, 18, 14 m/s^2 for 0.53, 1, 2,
4, 7 mm), where a real spall's edges stay sharp whatever its length. Read the twin's pits as up to about
2 mm wide (CWRU's seeded faults are 0.18-1.0 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bearingtwin.checks import finite_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS, BearingGeometry, check_fault

INNER, BALL, OUTER = FAULTS.index("inner"), FAULTS.index("ball"), FAULTS.index("outer")


@dataclass(frozen=True)
class Defect:
    """A defect as the solvers need it.

    Attributes:
        fault: bearing state (``normal`` has no defect).
        half_angle_rad: half the defect's angular extent along the contact path: on the
            race (outer, inner) or on the ball's spin circle (ball).
        depth_m: effective depth (geometric limit applied); for a ball defect, when it
            faces the outer race.
        angle_rad: outer: fixed angular position; inner: position relative to the shaft
            angle; ball: spin angle at which the defect faces the outer race.
        ball_index: the ball carrying a ball defect.
        inner_strike_depth_m: a ball defect's effective depth when it faces the inner race.
    """

    fault: str
    half_angle_rad: float
    depth_m: float
    angle_rad: float
    ball_index: int = 0
    inner_strike_depth_m: float = 0.0

    def as_array(self) -> np.ndarray:
        """Packed form the numba code reads: [fault code, half angle, depth, angle, ball, inner-strike depth]."""
        return np.array([FAULTS.index(self.fault), self.half_angle_rad, self.depth_m, self.angle_rad, self.ball_index,
                         self.inner_strike_depth_m], dtype=np.float64)


def _sagitta(radius_m: float, width_m: float) -> float:
    return radius_m - math.sqrt(radius_m**2 - (width_m / 2.0) ** 2)


def max_drop_m(ball_radius_m: float, width_m: float, race_radius_m: float = math.inf, convex_race: bool = True) -> float:
    """How far a ball's centre can sink into a pit of width ``width_m`` (on the ball or the race).

    Rb - sqrt(Rb^2 - (w/2)^2) on a flat race (``race_radius_m`` infinite), plus the race's
    sagitta on a convex (inner) race, minus it on a concave (outer) race.
    """
    race = 0.0 if math.isinf(race_radius_m) else _sagitta(race_radius_m, width_m)
    return _sagitta(ball_radius_m, width_m) + (race if convex_race else -race)


DEFECT_KEYS = ("width_mm", "depth_mm", "outer_angle_deg", "inner_angle_deg", "ball_index", "ball_angle_deg")
"""The settings of ``simulator.defect``, each read whatever the fault (the data set simulates all four from one)."""


def build_defect(fault: str, geometry: BearingGeometry, defect_cfg, load_zone_angle_rad: float) -> Defect:
    """The defect of ``fault`` from the ``simulator.defect`` config.

    ``defect_cfg.outer_angle_deg: null`` centres an outer-race defect on the load zone,
    ``load_zone_angle_rad`` (where the static load presses the balls hardest).
    """
    check_fault(fault)
    missing = [key for key in DEFECT_KEYS if key not in defect_cfg]
    if missing:  # a defect of the caller's own (the Python API) without them would fail on a bare KeyError
        raise BearingTwinError(f"simulator.defect has no {', '.join(missing)}; give every one of {', '.join(DEFECT_KEYS)} "
                               "(conf/simulator/default.yaml's defect holds them all)")
    width_m = finite_number("simulator.defect.width_mm", defect_cfg["width_mm"], "a width in mm") / 1000.0
    depth_m = finite_number("simulator.defect.depth_mm", defect_cfg["depth_mm"], "a depth in mm") / 1000.0
    if not width_m > 0 or width_m >= geometry.ball_diameter_mm / 1000.0:
        raise BearingTwinError(
            f"simulator.defect.width_mm must be positive and below the ball diameter "
            f"{geometry.ball_diameter_mm} mm, got {defect_cfg['width_mm']}"
        )
    if not depth_m > 0:  # a pit of no depth sheds no load: the record would be a healthy bearing's, labelled a fault
        raise BearingTwinError(f"simulator.defect.depth_mm must be positive, got {defect_cfg['depth_mm']} (a healthy "
                               "bearing is fault=normal)")
    ball_index = whole_number("simulator.defect.ball_index", defect_cfg["ball_index"], minimum=0)
    if not ball_index < geometry.n_balls:
        raise BearingTwinError(f"simulator.defect.ball_index must lie in 0..{geometry.n_balls - 1}, got {ball_index}")
    # Every fault's angle, not only this one's: the data set simulates all four from one config. A NaN
    # angle would put the defect nowhere and give a near-silent record still labelled faulty.
    outer_angle = defect_cfg["outer_angle_deg"]  # null: the centre of the load zone
    if outer_angle is not None:
        outer_angle = math.radians(finite_number("simulator.defect.outer_angle_deg", outer_angle,
                                                 "null or a finite angle in degrees"))
    inner_angle, ball_angle = (
        math.radians(finite_number(f"simulator.defect.{name}", defect_cfg[name], "a finite angle in degrees"))
        for name in ("inner_angle_deg", "ball_angle_deg"))
    ball_radius, inner_radius, outer_radius = geometry.ball_radius_m, geometry.inner_race_radius_m, geometry.outer_race_radius_m
    inner_depth = min(depth_m, max_drop_m(ball_radius, width_m, inner_radius, convex_race=True))
    outer_depth = min(depth_m, max_drop_m(ball_radius, width_m, outer_radius, convex_race=False))
    if fault == "outer":
        angle = load_zone_angle_rad if outer_angle is None else outer_angle
        return Defect(fault, width_m / 2.0 / outer_radius, outer_depth, angle)
    if fault == "inner":
        return Defect(fault, width_m / 2.0 / inner_radius, inner_depth, inner_angle)
    if fault == "ball":
        return Defect(fault, width_m / 2.0 / ball_radius, outer_depth, ball_angle, ball_index, inner_depth)
    return Defect(fault, 0.0, 0.0, 0.0)


def crossing_time_s(geometry: BearingGeometry, rpm: float, width_mm: float) -> float:
    """Shortest time a ball takes to roll across a defect of ``width_mm`` on any race or ball.

    The surface speeds relative to the defect are omega_c R_o (outer), (omega - omega_c) R_i
    (inner) and omega_spin R_b (ball); under pure rolling they are nearly equal.
    """
    omega = 2.0 * math.pi * rpm / 60.0
    omega_cage = geometry.cage_angular_velocity(rpm)
    speeds = (
        omega_cage * geometry.outer_race_radius_m,
        (omega - omega_cage) * geometry.inner_race_radius_m,
        2.0 * math.pi * geometry.bsf_hz(rpm) * geometry.ball_radius_m,
    )
    return width_mm / 1000.0 / max(speeds)


@njit(cache=True)
def _pit_profile(angle, half_angle, depth):
    """cos^2 pit of half-width ``half_angle`` centred at angle 0 (angle wrapped to [-pi, pi))."""
    wrapped = (angle + np.pi) % (2.0 * np.pi) - np.pi
    if abs(wrapped) >= half_angle:
        return 0.0
    c = math.cos(0.5 * np.pi * wrapped / half_angle)
    return depth * c * c


@njit(cache=True)
def defect_depths(defect, ball_angles, shaft_angle, spin_angle, depths_out):
    """Write h_j (m) for every ball into ``depths_out`` given ``Defect.as_array()`` and the angles (rad)."""
    code = int(defect[0])
    half_angle = defect[1]
    depth = defect[2]
    angle = defect[3]
    depths_out[:] = 0.0
    if code == INNER:
        for j in range(ball_angles.size):
            depths_out[j] = _pit_profile(ball_angles[j] - shaft_angle - angle, half_angle, depth)
    elif code == OUTER:
        for j in range(ball_angles.size):
            depths_out[j] = _pit_profile(ball_angles[j] - angle, half_angle, depth)
    elif code == BALL:
        relative = spin_angle - angle
        depths_out[int(defect[4])] = _pit_profile(relative, half_angle, depth) + _pit_profile(
            relative - np.pi, half_angle, defect[5]
        )
