"""The series the solvers read: shaft, cage and ball spin angles, per-ball offsets and contact roughness.

The paper writes the ball positions as theta_j = 2 pi (j - 1) / Nb + omega_c t + theta_0,
i.e. perfect rolling at constant speed. The solvers do not compute omega t
themselves: they read these series, sampled on a uniform grid and interpolated
linearly between grid points, so that an effect (ball slip, speed fluctuation) can
replace them without touching the equations of motion. For constant speed the
angles are linear in time and the interpolation is exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry, shaft_frequency_hz


@dataclass(frozen=True)
class Kinematics:
    """Angle series on the grid t_k = k / fs_hz, k = 0 .. n - 1 (all angles unwrapped, rad).

    Attributes:
        fs_hz: grid rate in Hz.
        shaft_angle_rad: (n,) inner-race (shaft) angle, carries an inner-race defect.
        shaft_speed_rad_s: (n,) shaft angular velocity, scales the unbalance force m e omega^2.
        cage_angle_rad: (n,) angle of ball 0 (cage angle plus theta_0); ball j sits 2 pi j / Nb ahead.
        ball_spin_angle_rad: (n,) spin of the balls relative to the cage, carries a ball defect.
        ball_offset_rad: (n, Nb) extra angle of each ball (slip, cage clearance); zero for rigid rolling.
        contact_roughness_m: (n, Nb) height of the surfaces each ball's contacts roll over (m), taken off the
            ball's compression as a defect's depth is; None for ideally smooth surfaces.
    """

    fs_hz: float
    shaft_angle_rad: np.ndarray
    shaft_speed_rad_s: np.ndarray
    cage_angle_rad: np.ndarray
    ball_spin_angle_rad: np.ndarray
    ball_offset_rad: np.ndarray
    contact_roughness_m: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.shaft_angle_rad)
        for name in ("shaft_speed_rad_s", "cage_angle_rad", "ball_spin_angle_rad", "ball_offset_rad",
                     "contact_roughness_m"):
            array = getattr(self, name)
            if array is None:  # smooth surfaces
                continue
            if len(array) != n or not np.all(np.isfinite(array)):
                raise BearingTwinError(f"kinematics.{name} must hold {n} finite samples (got shape {np.shape(array)})")
        if np.ndim(self.ball_offset_rad) != 2:
            raise BearingTwinError(f"kinematics.ball_offset_rad must have shape (n, n_balls), got {np.shape(self.ball_offset_rad)}")
        offsets_shape = np.shape(self.ball_offset_rad)
        if self.contact_roughness_m is not None and np.shape(self.contact_roughness_m) != offsets_shape:
            raise BearingTwinError(f"kinematics.contact_roughness_m must have shape {offsets_shape}, "
                                   f"got {np.shape(self.contact_roughness_m)}")

    @property
    def n_balls(self) -> int:
        return self.ball_offset_rad.shape[1]

    @property
    def n_samples(self) -> int:
        return len(self.shaft_angle_rad)

    def solver_arrays(self) -> tuple[np.ndarray, ...]:
        """The series as the compiled solvers read them, in :func:`sample_kinematics`'s and :func:`add_roughness`'s
        order: shaft, speed, cage, spin, offsets, roughness (no rows where the surfaces are smooth)."""
        roughness = np.zeros((0, self.n_balls)) if self.contact_roughness_m is None else self.contact_roughness_m
        return tuple(np.ascontiguousarray(a, dtype=np.float64) for a in (
            self.shaft_angle_rad, self.shaft_speed_rad_s, self.cage_angle_rad, self.ball_spin_angle_rad,
            self.ball_offset_rad, roughness))


def rigid_kinematics(geometry: BearingGeometry, rpm: float, fs_hz: float, n_samples: int,
                     initial_cage_angle_rad: float = 0.0) -> Kinematics:
    """Constant shaft speed and pure rolling (paper formulas (2), (5), (6))."""
    t = np.arange(n_samples) / fs_hz
    omega = 2.0 * math.pi * shaft_frequency_hz(rpm)
    return Kinematics(
        fs_hz=float(fs_hz),
        shaft_angle_rad=omega * t,
        shaft_speed_rad_s=np.full(n_samples, omega),
        cage_angle_rad=initial_cage_angle_rad + geometry.cage_angular_velocity(rpm) * t,
        ball_spin_angle_rad=2.0 * math.pi * geometry.bsf_hz(rpm) * t,
        ball_offset_rad=np.zeros((n_samples, geometry.n_balls)),
    )


@njit(cache=True)
def sample_kinematics(t_s, fs_hz, shaft, speed, cage, spin, offsets, ball_angles_out):
    """Kinematics at time ``t_s`` by linear interpolation; writes theta_j into ``ball_angles_out``.

    Returns (shaft angle, shaft speed, ball spin angle). Shared by both solvers so they
    read exactly the same excitation.
    """
    position = t_s * fs_hz
    k = min(int(position), shaft.size - 2)
    frac = position - k
    n_balls = offsets.shape[1]
    cage_now = cage[k] + frac * (cage[k + 1] - cage[k])
    for j in range(n_balls):
        offset = offsets[k, j] + frac * (offsets[k + 1, j] - offsets[k, j])
        ball_angles_out[j] = cage_now + 2.0 * np.pi * j / n_balls + offset
    return (
        shaft[k] + frac * (shaft[k + 1] - shaft[k]),
        speed[k] + frac * (speed[k + 1] - speed[k]),
        spin[k] + frac * (spin[k + 1] - spin[k]),
    )


@njit(cache=True)
def add_roughness(t_s, fs_hz, roughness, depths_out):
    """Add each ball's contact roughness at time ``t_s`` (linear interpolation) to ``depths_out`` (m); nothing
    where ``roughness`` has no rows (smooth surfaces). Shared by both solvers."""
    if roughness.shape[0] == 0:
        return
    position = t_s * fs_hz
    k = min(int(position), roughness.shape[0] - 2)
    frac = position - k
    for j in range(depths_out.size):
        depths_out[j] += roughness[k, j] + frac * (roughness[k + 1, j] - roughness[k, j])
