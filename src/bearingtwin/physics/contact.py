"""Hertz point-contact stiffness of a ball between two raceways (the paper's k_b).

The paper gives the combination rule k_b = [(1/k_bi)^(2/3) + (1/k_bo)^(2/3)]^(-3/2)
but not k_bi, k_bo themselves, so they are derived here from the bearing geometry
and the steel's elastic constants, in the form Harris & Kotzalas use (Rolling
Bearing Analysis, 5th ed., vol. 1, ch. 6 "Contact stress and deformation"): the
load-deflection law Q = K delta^1.5 of two bodies in elliptical contact,

    K = pi k E' sqrt(2 Ecal R / (9 Fcal^3)),

with E' = E / (1 - nu^2) (two equal steels), R the effective radius 1/R = 1/Rx + 1/Ry,
and the ellipticity k and complete elliptic integrals Fcal, Ecal replaced by the
closed-form approximations of Hamrock & Brewe (1983), "Simplified solution for
stresses and deformations", J. Lubrication Technology 105(2):171-177:

    k = (Ry / Rx)^(2/pi),  Ecal = 1 + (pi/2 - 1) Rx / Ry,  Fcal = pi/2 + (pi/2 - 1) ln(Ry / Rx),

which they report to be within a few per cent of the exact Hertz solution over the
range of ball bearings; dropping the iterative elliptic-integral solution keeps the
parameters cheap to rebuild when an effect changes the geometry.
"""

from __future__ import annotations

import math

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry


def point_contact_stiffness(rx_m: float, ry_m: float, youngs_modulus_pa: float, poisson_ratio: float) -> float:
    """Hertz load-deflection constant K (N/m^1.5) of two equal-steel bodies, Hamrock-Brewe form.

    Args:
        rx_m, ry_m: effective radii of curvature (m) in the two principal planes,
            1/R = 1/R_body1 + 1/R_body2 in each plane (positive: convex overall).
    """
    if not (rx_m > 0 and ry_m > 0):
        raise BearingTwinError(f"contact radii must be positive, got Rx={rx_m} m, Ry={ry_m} m")
    ratio = max(rx_m, ry_m) / min(rx_m, ry_m)
    ellipticity = ratio ** (2.0 / math.pi)
    second_kind = 1.0 + (math.pi / 2.0 - 1.0) / ratio
    first_kind = math.pi / 2.0 + (math.pi / 2.0 - 1.0) * math.log(ratio)
    reduced_modulus = youngs_modulus_pa / (1.0 - poisson_ratio**2)
    effective_radius = 1.0 / (1.0 / rx_m + 1.0 / ry_m)
    return math.pi * ellipticity * reduced_modulus * math.sqrt(2.0 * second_kind * effective_radius / (9.0 * first_kind**3))


def race_contact_radii(geometry: BearingGeometry, groove_radius_factor: float) -> dict[str, tuple[float, float]]:
    """Effective radii (Rx rolling direction, Ry across the groove) in m of the inner and outer contact.

    Rolling direction: the ball (radius D/2) against the race's contact circle, convex on
    the inner race and concave on the outer, gamma = D cos(alpha) / Dm. Across the groove:
    the ball against a groove of radius f D (concave on both races).
    """
    if not 0.5 < groove_radius_factor < 1.0:
        raise BearingTwinError(f"bearing.groove_radius_factor must lie in (0.5, 1), got {groove_radius_factor}")
    ball_d = geometry.ball_diameter_mm / 1000.0
    gamma = ball_d * math.cos(math.radians(geometry.contact_angle_deg)) / (geometry.pitch_diameter_mm / 1000.0)
    across = groove_radius_factor * ball_d / (2.0 * groove_radius_factor - 1.0)
    return {
        "inner": (ball_d * (1.0 - gamma) / 2.0, across),
        "outer": (ball_d * (1.0 + gamma) / 2.0, across),
    }


def combined_contact_stiffness(inner_n_per_m1_5: float, outer_n_per_m1_5: float) -> float:
    """Series combination of the two contacts of one ball (the paper's k_b formula)."""
    return ((1.0 / inner_n_per_m1_5) ** (2.0 / 3.0) + (1.0 / outer_n_per_m1_5) ** (2.0 / 3.0)) ** -1.5


def bearing_contact_stiffness(geometry: BearingGeometry, youngs_modulus_gpa: float, poisson_ratio: float,
                              groove_radius_factor: float) -> float:
    """k_b in N/m^1.5 for a steel ball between the inner and outer race of ``geometry``."""
    if not youngs_modulus_gpa > 0:
        raise BearingTwinError(f"bearing.youngs_modulus_gpa must be positive, got {youngs_modulus_gpa}")
    if not 0.0 <= poisson_ratio < 0.5:
        raise BearingTwinError(f"bearing.poisson_ratio must lie in [0, 0.5), got {poisson_ratio}")
    radii = race_contact_radii(geometry, groove_radius_factor)
    inner, outer = (point_contact_stiffness(*radii[race], youngs_modulus_gpa * 1e9, poisson_ratio)
                    for race in ("inner", "outer"))
    return combined_contact_stiffness(inner, outer)
