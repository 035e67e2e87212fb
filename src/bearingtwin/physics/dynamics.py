"""The 4-DOF bearing model of the paper's section 3.2.2, in SI units.

State: [x_i, y_i, x_o, y_o, x_i', y_i', x_o', y_o'] (m, m/s); y points up, so gravity
is -g. Ball j at angle theta_j is compressed by

    delta_j = (x_i - x_o) cos(theta_j) + (y_i - y_o) sin(theta_j) - c_d - h_j

and pushes with Q_j = k_b delta_j^1.5 H(delta_j). The contact force sum F = sum Q_j
(cos theta_j, sin theta_j) restores the inner race (-F) and pushes the outer race
(+F):

    m_i x_i'' + c_i x_i' + k_i x_i = -F_x + m_i e omega^2 cos(phi) + W_x
    m_i y_i'' + c_i y_i' + k_i y_i = -F_y + m_i e omega^2 sin(phi) - m_i g + W_y
    m_o x_o'' + c_o x_o' + k_o x_o = +F_x
    m_o y_o'' + c_o y_o' + k_o y_o = +F_y - m_o g

(phi: shaft angle). :func:`state_derivative` is the readable numpy form the reference
solver integrates; the fast solver re-implements the same equations in numba and is
tested against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from bearingtwin.checks import finite_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.contact import bearing_contact_stiffness
from bearingtwin.physics.geometry import BearingGeometry


BEARING_SETTINGS = ("inner_mass_kg", "outer_mass_kg", "inner_damping_ns_per_m", "outer_damping_ns_per_m",
                    "inner_stiffness_n_per_m", "outer_stiffness_n_per_m")
"""The bearing config's settings :class:`DynamicParameters` takes as they are."""


@dataclass(frozen=True)
class DynamicParameters:
    """Everything the equations of motion read besides the angles (SI units).

    Effects replace it with :func:`dataclasses.replace` in ``modify_parameters``.
    """

    inner_mass_kg: float
    outer_mass_kg: float
    inner_damping_ns_per_m: float
    outer_damping_ns_per_m: float
    inner_stiffness_n_per_m: float
    outer_stiffness_n_per_m: float
    contact_stiffness_n_per_m1_5: float
    clearance_m: float  # gap per ball, half the catalogue's radial play (BearingGeometry.clearance_mm); negative = preload
    n_balls: int
    eccentricity_m: float = 0.0
    load_x_n: float = 0.0
    load_y_n: float = 0.0
    gravity_m_per_s2: float = 9.81
    contact_damping_ns_per_m: float = 0.0  # viscous damping of each loaded contact (lubricant film)

    def __post_init__(self) -> None:
        for name in ("inner_mass_kg", "outer_mass_kg", "contact_stiffness_n_per_m1_5"):
            if not getattr(self, name) > 0:
                raise BearingTwinError(f"{name} must be positive, got {getattr(self, name)}")
        for name in ("inner_damping_ns_per_m", "outer_damping_ns_per_m", "inner_stiffness_n_per_m",
                     "outer_stiffness_n_per_m", "eccentricity_m", "contact_damping_ns_per_m"):
            if not getattr(self, name) >= 0:
                raise BearingTwinError(f"{name} must not be negative, got {getattr(self, name)}")
        if not np.isfinite(self.clearance_m):
            raise BearingTwinError(f"clearance_m must be finite (negative = preload), got {self.clearance_m}")

    def as_array(self) -> np.ndarray:
        """Packed form the numba kernel reads (order = field order)."""
        return np.array([getattr(self, name) for name in self.__dataclass_fields__], dtype=np.float64)

    @classmethod
    def from_config(cls, bearing_cfg, simulator_cfg) -> "DynamicParameters":
        """Masses, supports and clearance from ``bearing``, loads and unbalance from ``simulator``.

        ``bearing.contact_stiffness_n_per_m1_5: null`` derives k_b from Hertz theory
        (:mod:`bearingtwin.physics.contact`); a number overrides it.
        """
        geometry = BearingGeometry.from_config(bearing_cfg)
        contact = bearing_cfg["contact_stiffness_n_per_m1_5"]
        if contact is None:
            contact = bearing_contact_stiffness(geometry, bearing_cfg["youngs_modulus_gpa"], bearing_cfg["poisson_ratio"],
                                                bearing_cfg["groove_radius_factor"])
        elif not contact > 0:
            raise BearingTwinError(f"bearing.contact_stiffness_n_per_m1_5 must be positive or null, got {contact}")
        if not finite_number("simulator.eccentricity_mm", simulator_cfg["eccentricity_mm"]) >= 0:
            raise BearingTwinError(f"simulator.eccentricity_mm must not be negative, got {simulator_cfg['eccentricity_mm']}")
        for name in ("load_x_n", "load_y_n", "gravity_m_per_s2"):  # a NaN leaves the static equilibrium unsolvable
            finite_number(f"simulator.{name}", simulator_cfg[name])
        try:
            return cls(
                inner_mass_kg=float(bearing_cfg["inner_mass_kg"]),
                outer_mass_kg=float(bearing_cfg["outer_mass_kg"]),
                inner_damping_ns_per_m=float(bearing_cfg["inner_damping_ns_per_m"]),
                outer_damping_ns_per_m=float(bearing_cfg["outer_damping_ns_per_m"]),
                inner_stiffness_n_per_m=float(bearing_cfg["inner_stiffness_n_per_m"]),
                outer_stiffness_n_per_m=float(bearing_cfg["outer_stiffness_n_per_m"]),
                contact_stiffness_n_per_m1_5=float(contact),
                clearance_m=geometry.clearance_mm / 1000.0,
                n_balls=geometry.n_balls,
                eccentricity_m=float(simulator_cfg["eccentricity_mm"]) / 1000.0,
                load_x_n=float(simulator_cfg["load_x_n"]),
                load_y_n=float(simulator_cfg["load_y_n"]),
                gravity_m_per_s2=float(simulator_cfg["gravity_m_per_s2"]),
            )
        except BearingTwinError as error:  # the range checks name a field, which the user set as bearing.<field>
            said = str(error)
            raise BearingTwinError(f"bearing.{said}" if said.split(" ")[0] in BEARING_SETTINGS else said) from None


def contact_force(state: np.ndarray, ball_angles: np.ndarray, depths: np.ndarray, params: DynamicParameters) -> np.ndarray:
    """Total ball force (F_x, F_y) in N that the inner race exerts on the outer race.

    A loaded contact also resists the races' approach speed along its line of action with
    ``contact_damping_ns_per_m`` (zero for the paper's dry model); it can push, never pull.
    """
    relative_x, relative_y = state[0] - state[2], state[1] - state[3]
    cos, sin = np.cos(ball_angles), np.sin(ball_angles)
    deflection = relative_x * cos + relative_y * sin - params.clearance_m - depths
    approach_speed = (state[4] - state[6]) * cos + (state[5] - state[7]) * sin
    load = params.contact_stiffness_n_per_m1_5 * np.clip(deflection, 0.0, None) ** 1.5
    load = np.where(deflection > 0, np.clip(load + params.contact_damping_ns_per_m * approach_speed, 0.0, None), 0.0)
    return np.array([load @ cos, load @ sin])


def state_derivative(state: np.ndarray, ball_angles: np.ndarray, depths: np.ndarray, shaft_angle: float,
                     shaft_speed: float, params: DynamicParameters) -> np.ndarray:
    """d(state)/dt of the four equations of motion (module docstring)."""
    p = params
    force_x, force_y = contact_force(state, ball_angles, depths, p)
    unbalance = p.inner_mass_kg * p.eccentricity_m * shaft_speed**2
    acceleration = np.array([
        (-force_x + unbalance * math.cos(shaft_angle) + p.load_x_n
         - p.inner_damping_ns_per_m * state[4] - p.inner_stiffness_n_per_m * state[0]) / p.inner_mass_kg,
        (-force_y + unbalance * math.sin(shaft_angle) + p.load_y_n - p.inner_mass_kg * p.gravity_m_per_s2
         - p.inner_damping_ns_per_m * state[5] - p.inner_stiffness_n_per_m * state[1]) / p.inner_mass_kg,
        (force_x - p.outer_damping_ns_per_m * state[6] - p.outer_stiffness_n_per_m * state[2]) / p.outer_mass_kg,
        (force_y - p.outer_mass_kg * p.gravity_m_per_s2
         - p.outer_damping_ns_per_m * state[7] - p.outer_stiffness_n_per_m * state[3]) / p.outer_mass_kg,
    ])
    return np.concatenate([state[4:], acceleration])


def static_equilibrium(params: DynamicParameters, ball_angles: np.ndarray) -> np.ndarray:
    """The resting state (zero velocity) under gravity and the constant loads W, healthy bearing.

    The time-varying unbalance is left out; its response is a steady forced vibration
    that the start-up transient (discarded by the simulator) settles into.
    """
    scale = 1e-6  # solve in micrometres so the residual and the unknowns are of order one
    no_defect = np.zeros_like(ball_angles)
    still = np.zeros(4)
    static = replace(params, eccentricity_m=0.0)

    def residual(displacement_um):
        state = np.concatenate([displacement_um * scale, still])
        return state_derivative(state, ball_angles, no_defect, 0.0, 0.0, static)[4:]

    load = np.array([params.load_x_n, params.load_y_n - params.inner_mass_kg * params.gravity_m_per_s2])
    total = load + np.array([0.0, -params.outer_mass_kg * params.gravity_m_per_s2])
    outer_guess = total / max(params.outer_stiffness_n_per_m, 1.0)
    magnitude = float(np.hypot(*load))
    direction = load / magnitude if magnitude > 0 else np.array([0.0, -1.0])
    # The inner race moves through the clearance, then compresses the loaded balls. A preload
    # (negative clearance) holds every ball compressed already, so the race hardly moves.
    squeeze = max(params.clearance_m, 0.0) + (magnitude / params.contact_stiffness_n_per_m1_5) ** (2.0 / 3.0)
    guess = np.concatenate([outer_guess + squeeze * direction, outer_guess]) / scale
    # Accelerations below this (m/s^2) are equilibrium: a millionth of gravity, far below any
    # force the model resolves, yet above the round-off of summing contact forces of ~1e3 N.
    tolerance = 1e-6 * params.gravity_m_per_s2 + 1e-9
    # Powell's hybrid method is fast but can stall where a ball's contact opens or closes (the
    # Hertz force has no second derivative at zero compression). Levenberg-Marquardt from where
    # it stopped gets past such a kink; Powell again polishes the result.
    point, message = guess, ""
    for method, options in (("hybr", {"xtol": 1e-12}), ("lm", {"xtol": 1e-15, "ftol": 1e-15}), ("hybr", {"xtol": 1e-12})):
        solution = scipy.optimize.root(residual, point, method=method, options=options)
        point, message = solution.x, solution.message
        if np.max(np.abs(residual(point))) <= tolerance:
            return np.concatenate([point * scale, still])
    raise BearingTwinError(f"no static equilibrium found for these loads and stiffnesses ({message})")


def linear_modes(params: DynamicParameters, state: np.ndarray, ball_angles: np.ndarray) -> tuple[float, float]:
    """Highest natural frequency (Hz) and slowest decay rate (1/s) of the model linearized at ``state``.

    The contact stiffness of a loaded ball is dQ/d(delta) = 1.5 k_b delta^0.5 along its line
    of action; these set how fine the fast solver must step, the lowest sampling rate
    that resolves the response, and how long the start-up transient lasts.
    """
    relative = state[0:2] - state[2:4]
    directions = np.stack([np.cos(ball_angles), np.sin(ball_angles)], axis=1)
    deflection = directions @ relative - params.clearance_m
    slope = 1.5 * params.contact_stiffness_n_per_m1_5 * np.sqrt(np.clip(deflection, 0.0, None))
    contact = (directions * slope[:, None]).T @ directions
    stiffness = np.block([[contact, -contact], [-contact, contact]])
    stiffness += np.diag([params.inner_stiffness_n_per_m] * 2 + [params.outer_stiffness_n_per_m] * 2)
    mass = np.array([params.inner_mass_kg] * 2 + [params.outer_mass_kg] * 2)
    loaded = params.contact_damping_ns_per_m * (deflection > 0)
    contact_damping = (directions * loaded[:, None]).T @ directions
    damping = np.block([[contact_damping, -contact_damping], [-contact_damping, contact_damping]])
    damping += np.diag([params.inner_damping_ns_per_m] * 2 + [params.outer_damping_ns_per_m] * 2)
    system = np.block([[np.zeros((4, 4)), np.eye(4)], [-stiffness / mass[:, None], -damping / mass[:, None]]])
    eigenvalues = np.linalg.eigvals(system)
    return float(np.max(np.abs(eigenvalues)) / (2.0 * math.pi)), float(np.min(-eigenvalues.real))
