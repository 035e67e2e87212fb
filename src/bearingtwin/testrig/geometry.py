"""Bearing kinematics of the test rig, in orders of the shaft speed.

The rig works in the angle domain: every periodic event is a number of events per shaft
revolution (an *order*), and the time of an event follows from the shaft's angle, so a
varying speed moves every event consistently. With the diameter ratio
gamma = Db cos(alpha) / Dm and rolling without slip:

- cage (fundamental train) order: (1 - gamma) / 2, the ball centres' orbit;
- outer-race ball pass: Z (1 - gamma) / 2, balls passing a fixed point of the outer race;
- inner-race ball pass: Z (1 + gamma) / 2, balls passing a point of the turning inner race;
- ball spin (relative to the cage): Dm / (2 Db) (1 - gamma^2); a spall on a ball meets the
  outer and the inner race once each per spin revolution, so it strikes at 2 x BSF.

Frequencies in Hz are these orders times the shaft rate rpm / 60 (Harris & Kotzalas,
Rolling Bearing Analysis, ch. 8; Randall & Antoni, MSSP 2011, eq. 1-4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bearingtwin.checks import ball_count
from bearingtwin.errors import BearingTwinError


@dataclass(frozen=True)
class RigBearing:
    """A deep-groove ball bearing as the rig sees it; the defaults are an SKF 6205 (the CWRU drive end).

    Attributes:
        n_balls: number of balls Z.
        ball_diameter_mm: ball diameter Db.
        pitch_diameter_mm: pitch (ball-centre circle) diameter Dm.
        contact_angle_deg: contact angle alpha (0 for a radially loaded deep-groove bearing).
        contact_stiffness_n_per_m1_5: load-deflection constant K of one ball between both races,
            Q = K delta^n; published values for a 6205 lie around 7-9e9 N/m^1.5.
        load_exponent: n in Q = K delta^n: 3/2 for point contact (ball bearings), 10/9 for
            line contact (roller bearings).
    """

    n_balls: int = 9
    ball_diameter_mm: float = 7.94
    pitch_diameter_mm: float = 39.04
    contact_angle_deg: float = 0.0
    contact_stiffness_n_per_m1_5: float = 8.0e9
    load_exponent: float = 1.5

    def __post_init__(self) -> None:
        for name in ("ball_diameter_mm", "pitch_diameter_mm", "contact_stiffness_n_per_m1_5", "load_exponent"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise BearingTwinError(f"bearing.{name} must be a positive number, got {value}")
        ball_count(self.n_balls, self.ball_diameter_mm, self.pitch_diameter_mm)
        if not 0.0 <= self.contact_angle_deg < 90.0:
            raise BearingTwinError(f"bearing.contact_angle_deg must lie in [0, 90), got {self.contact_angle_deg}")

    @property
    def gamma(self) -> float:
        """Db cos(alpha) / Dm."""
        return self.ball_diameter_mm * math.cos(math.radians(self.contact_angle_deg)) / self.pitch_diameter_mm

    def orders(self) -> dict[str, float]:
        """Events per shaft revolution: ftf (cage), bpfo, bpfi, bsf (ball spin relative to the cage)."""
        gamma = self.gamma
        return {
            "ftf": (1.0 - gamma) / 2.0,
            "bpfo": self.n_balls * (1.0 - gamma) / 2.0,
            "bpfi": self.n_balls * (1.0 + gamma) / 2.0,
            "bsf": self.pitch_diameter_mm / (2.0 * self.ball_diameter_mm) * (1.0 - gamma**2),
        }

    def frequencies_hz(self, rpm: float) -> dict[str, float]:
        """Shaft rate and the defect frequencies in Hz at ``rpm`` (keys: shaft, ftf, bpfo, bpfi, bsf)."""
        if not (math.isfinite(rpm) and rpm > 0):
            raise BearingTwinError(f"rpm must be a positive number, got {rpm}")
        shaft_hz = rpm / 60.0
        return {"shaft": shaft_hz, **{name: order * shaft_hz for name, order in self.orders().items()}}

    def rolling_speed_m_s(self, shaft_hz: float) -> float:
        """Speed at which the contact point sweeps over either race and the ball, in m/s.

        Rolling without slip makes it the same on the outer race (cage rate times the outer
        contact radius), on the inner race (shaft-minus-cage rate times the inner contact radius)
        and on the ball (spin rate times the ball radius): pi fn Dm (1 - gamma^2) / 2.
        """
        return math.pi * shaft_hz * self.pitch_diameter_mm * 1e-3 * (1.0 - self.gamma**2) / 2.0

    def spall_drop_m(self, width_mm: float, depth_mm: float) -> float:
        """How deep a ball sinks into a spall: the pit's depth, at most the ball's sagitta over its width.

        A ball wider than the pit rests on its two edges, so its centre drops by
        Rb - sqrt(Rb^2 - (w/2)^2) at most (race curvature neglected).
        """
        radius_mm = self.ball_diameter_mm / 2.0
        half_width_mm = min(width_mm / 2.0, radius_mm)
        sagitta_mm = radius_mm - math.sqrt(radius_mm**2 - half_width_mm**2)
        return min(depth_mm, sagitta_mm) * 1e-3

    def fall_distance_m(self, drop_m: float) -> float:
        """How far a ball rolls past a spall's leading edge while it sinks by ``drop_m``: sqrt(h (Db - h)).

        The ball pivots on the edge, so its centre falls as a circle of its own radius; a drop
        of the full sagitta is reached at the middle of a narrow pit.
        """
        return math.sqrt(drop_m * (self.ball_diameter_mm * 1e-3 - drop_m))
