"""The rig's load zone: how a radial load shares itself among the balls (Stribeck / Harris).

A ball at angle psi from the load direction is compressed by

    delta(psi) = (delta_r cos(psi) - Gr / 2) cos(alpha),

where delta_r is the radial shift of the inner ring and Gr the radial internal clearance
(the total radial play, ISO 5753). Balls with delta <= 0 carry nothing, so the load zone
spans |psi| < psi_l with cos(psi_l) = Gr / (2 delta_r). With the load-distribution factor

    epsilon = (1 - Gr / (2 delta_r)) / 2   (the fraction of the diameter in the load zone),

the ball loads follow Q(psi) = Q_max [1 - (1 - cos psi) / (2 epsilon)]^n, n = 3/2 for ball
bearings (10/9 for rollers), and the radial load balances them through Harris's load
integral: Fr = Z Q_max J_r(epsilon) cos(alpha), with
J_r = 1/(2 pi) int_{-psi_l}^{psi_l} [1 - (1 - cos psi) / (2 epsilon)]^n cos psi dpsi.
Q_max = K delta_max^n closes the system: one equation in delta_r, solved numerically.

A larger load pushes the ring further (delta_r grows) and epsilon rises towards 1/2: more
balls share it, the zone widens. A larger clearance lowers epsilon: a narrower zone. With
zero clearance epsilon is 1/2 (psi_l = 90 deg) whatever the load.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import integrate, optimize

from bearingtwin.errors import BearingTwinError
from bearingtwin.testrig.geometry import RigBearing


def load_integral(epsilon: float, exponent: float) -> float:
    """Harris's radial load integral J_r(epsilon) for 0 <= epsilon <= 1/2 (dimensionless)."""
    if epsilon <= 0.0:
        return 0.0
    half_angle = math.acos(1.0 - 2.0 * epsilon)
    value, _ = integrate.quad(lambda psi: (1.0 - (1.0 - math.cos(psi)) / (2.0 * epsilon)) ** exponent * math.cos(psi),
                              -half_angle, half_angle)
    return value / (2.0 * math.pi)


@dataclass(frozen=True)
class LoadZone:
    """Ball loads around the bearing for one radial load and clearance.

    Attributes:
        epsilon: load-distribution factor (0 < epsilon <= 1/2 here).
        max_ball_load_n: Q_max, the load on a ball at the centre of the zone.
        radial_shift_m: delta_r, the inner ring's radial displacement.
        radial_stiffness_n_per_m: dFr / d delta_r at this load, the stiffness the rotor rests on.
        exponent: n of the load-deflection law.
    """

    epsilon: float
    max_ball_load_n: float
    radial_shift_m: float
    radial_stiffness_n_per_m: float
    exponent: float

    @property
    def half_angle_rad(self) -> float:
        """psi_l: the zone spans |psi| < psi_l around the load direction."""
        return math.acos(1.0 - 2.0 * self.epsilon)

    def ball_load_n(self, psi_rad) -> np.ndarray:
        """Q(psi) in N for balls at angles ``psi_rad`` from the load direction (any shape; zero outside the zone)."""
        share = 1.0 - (1.0 - np.cos(np.asarray(psi_rad, dtype=np.float64))) / (2.0 * self.epsilon)
        return self.max_ball_load_n * np.clip(share, 0.0, None) ** self.exponent


def _radial_force_n(bearing: RigBearing, radial_shift_m: float, clearance_m: float) -> float:
    """Fr carried when the inner ring has moved ``radial_shift_m`` (0 while the clearance is not closed)."""
    max_deflection = radial_shift_m - clearance_m / 2.0
    if max_deflection <= 0.0:
        return 0.0
    cos_alpha = math.cos(math.radians(bearing.contact_angle_deg))
    epsilon = max_deflection / (2.0 * radial_shift_m)
    max_load = bearing.contact_stiffness_n_per_m1_5 * (max_deflection * cos_alpha) ** bearing.load_exponent
    return bearing.n_balls * max_load * load_integral(epsilon, bearing.load_exponent) * cos_alpha


def load_zone(bearing: RigBearing, radial_load_n: float, clearance_um: float) -> LoadZone:
    """Solve the ring's radial shift for ``radial_load_n`` (N) and radial clearance ``clearance_um`` (um)."""
    if not (math.isfinite(radial_load_n) and radial_load_n > 0):
        raise BearingTwinError(f"operating_point.radial_load_n must be a positive number, got {radial_load_n}")
    if not (math.isfinite(clearance_um) and clearance_um >= 0):
        raise BearingTwinError(f"operating_point.clearance_um must be a non-negative number, got {clearance_um}")
    clearance_m = clearance_um * 1e-6
    # Fr grows monotonically with the shift from zero at Gr / 2; 1 mm of ball compression
    # carries far more than any load a bearing survives, so the root is bracketed.
    low, high = clearance_m / 2.0, clearance_m / 2.0 + 1e-3
    shift = optimize.brentq(lambda d: _radial_force_n(bearing, d, clearance_m) - radial_load_n, low, high,
                            xtol=1e-15, rtol=1e-12)
    step = 1e-4 * shift
    stiffness = (_radial_force_n(bearing, shift + step, clearance_m)
                 - _radial_force_n(bearing, shift - step, clearance_m)) / (2.0 * step)
    max_deflection = shift - clearance_m / 2.0
    cos_alpha = math.cos(math.radians(bearing.contact_angle_deg))
    return LoadZone(
        epsilon=max_deflection / (2.0 * shift),
        max_ball_load_n=bearing.contact_stiffness_n_per_m1_5 * (max_deflection * cos_alpha) ** bearing.load_exponent,
        radial_shift_m=shift,
        radial_stiffness_n_per_m=stiffness,
        exponent=bearing.load_exponent,
    )
