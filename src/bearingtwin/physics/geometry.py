"""Bearing geometry and the kinematic defect frequencies (paper section 3.2.2, formulas (2)-(6)).

All frequencies are in Hz, angular velocities in rad/s, lengths in mm as in the
paper's Table 1. The ball-spin frequency follows the paper's formula (5),

    BSF = Dm / (2 Db) * fn * (1 - (Db / Dm * cos(alpha))**2),

which is the ball's spin relative to the cage: a defect on one ball strikes one
race at BSF and both races at 2 x BSF. (Some vendors, the CWRU Data Center among
them, quote 2 x BSF as the "rolling element" frequency.)

Note on the paper's numbers: with its Table 1 pitch diameter Dm = 39 mm at 1797 rpm
this gives BPFO 107.34 Hz and BSF 70.51 Hz as the paper reports, but BPFI
162.21 Hz, not the 162.19 Hz it quotes; 162.19 Hz is what Dm = 39.04 mm (the CWRU
6205 bearing) gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Mapping

from bearingtwin.checks import ball_count, finite_number
from bearingtwin.errors import BearingTwinError

FAULTS = ("normal", "inner", "ball", "outer")
"""Bearing states in the order of the paper's labels 1-4 (Table 5): Normal, Inner race,
Rolling element, Outer race. Integer class labels in this project are indices into it."""


FAULT_FREQUENCY = {"normal": None, "inner": "bpfi", "ball": "bsf", "outer": "bpfo"}
"""The key in :meth:`BearingGeometry.defect_frequencies` of each state's fundamental defect frequency."""


_LINE_NAMES = {"shaft": "shaft line", "bpfi": "inner-race defect line (BPFI)", "bpfo": "outer-race defect line (BPFO)",
               "bsf": "ball spin line (BSF)", "ftf": "cage line (FTF)"}
"""The keys of :meth:`BearingGeometry.defect_frequencies` in a message's words."""


def check_fault(fault: str) -> str:
    """Return ``fault`` if it names a bearing state, else raise naming the valid ones."""
    if fault not in FAULTS:
        given = "null" if fault is None else repr(fault)
        raise BearingTwinError(f"fault={given} is not a bearing state; choose one of {', '.join(FAULTS)}")
    return fault


def shaft_frequency_hz(rpm: float) -> float:
    """Shaft rotation frequency fn = n / 60 (formula (2))."""
    if not rpm > 0:
        raise BearingTwinError(f"rpm must be positive, got {rpm}")
    return rpm / 60.0


SIZE_KEYS = ("outer_diameter_mm", "inner_diameter_mm", "ball_diameter_mm", "pitch_diameter_mm", "n_balls")
"""The settings that size a bearing and, with its contact angle (0 for the deep-groove bearing the twin is made for,
where not given), fix its defect frequencies: a bearing's own config file states each."""


@dataclass(frozen=True)
class BearingGeometry:
    """Geometry of a deep-groove ball bearing (lengths in mm, angle in degrees).

    ``contact_angle_deg`` enters the defect frequencies and the Hertz contact radii; the dynamics
    stay radial (no axial load, no cos(alpha) projection of the contact force), which is the
    deep-groove bearing at alpha = 0 the twin is made for. An angular-contact bearing gets its
    defect frequencies right and its impacts only roughly.
    """

    outer_diameter_mm: float
    inner_diameter_mm: float
    ball_diameter_mm: float
    pitch_diameter_mm: float
    n_balls: int
    contact_angle_deg: float = 0.0
    # The radial clearance as the paper's contact law subtracts it from every ball's deflection: the gap between
    # each ball and the races when they are concentric (Harris's Pd/2), so half the catalogue's radial internal
    # clearance (ISO 5753's total radial play; a 6205 C0 has 5-20 um of play, a gap of 2.5-10 um).
    clearance_mm: float = 0.0

    def __post_init__(self) -> None:
        for field in fields(self):  # a string or a NaN would fail the comparisons below with a traceback, or pass them
            finite_number(f"bearing.{field.name}", getattr(self, field.name))
        for name in ("outer_diameter_mm", "inner_diameter_mm", "ball_diameter_mm", "pitch_diameter_mm"):
            if not getattr(self, name) > 0:
                raise BearingTwinError(f"bearing.{name} must be positive, got {getattr(self, name)}")
        # The ball's load line leans by alpha from the radial plane; at 90 degrees it is a thrust
        # bearing, where cos(alpha) = 0 makes BPFI = BPFO and the radial model of this project void.
        if not 0.0 <= self.contact_angle_deg < 90.0:
            raise BearingTwinError(f"bearing.contact_angle_deg must lie in [0, 90) degrees for a radial or "
                                   f"angular-contact ball bearing, got {self.contact_angle_deg!r}")
        if self.clearance_mm < 0:
            raise BearingTwinError(f"bearing.clearance_mm must not be negative, got {self.clearance_mm}")
        # The balls run between the rings: from the inner raceway (pitch - ball) to the outer (pitch + ball),
        # both within the bore and the outer diameter.
        inner_race_mm = self.pitch_diameter_mm - self.ball_diameter_mm
        outer_race_mm = self.pitch_diameter_mm + self.ball_diameter_mm
        if not self.inner_diameter_mm < inner_race_mm < outer_race_mm < self.outer_diameter_mm:
            raise BearingTwinError(
                f"bearing.ball_diameter_mm={self.ball_diameter_mm:g} on bearing.pitch_diameter_mm="
                f"{self.pitch_diameter_mm:g} spans {inner_race_mm:g} to {outer_race_mm:g} mm across; the balls must "
                f"lie between the rings, bearing.inner_diameter_mm={self.inner_diameter_mm:g} and "
                f"bearing.outer_diameter_mm={self.outer_diameter_mm:g}")
        # 8.0 balls from a YAML or an override are 8: the kinematics index them
        object.__setattr__(self, "n_balls", ball_count(self.n_balls, self.ball_diameter_mm, self.pitch_diameter_mm))

    @classmethod
    def from_config(cls, bearing_cfg: Mapping) -> "BearingGeometry":
        """The geometry part of a ``conf/bearing/*.yaml`` config (masses, stiffnesses etc. are ignored); a geometry
        given as one is taken as it is."""
        if isinstance(bearing_cfg, cls):
            return bearing_cfg
        if not isinstance(bearing_cfg, Mapping):  # a bearing's name, from Python
            raise BearingTwinError(f"bearing: give the bearing's config (bearingtwin.config.bearing_config('<name>')) "
                                   f"or its BearingGeometry, got {type(bearing_cfg).__name__} {str(bearing_cfg)[:60]!r}")
        names = [f.name for f in fields(cls)]
        missing = [name for name in SIZE_KEYS if name not in bearing_cfg]
        if missing:
            raise BearingTwinError(f"bearing config lacks {', '.join('bearing.' + m for m in missing)}")
        return cls(**{name: bearing_cfg[name] for name in names if name in bearing_cfg})

    @property
    def ball_radius_m(self) -> float:
        return self.ball_diameter_mm / 2000.0

    @property
    def inner_race_radius_m(self) -> float:
        """Radius of the inner raceway's contact circle, (Dm - Db) / 2."""
        return (self.pitch_diameter_mm - self.ball_diameter_mm) / 2000.0

    @property
    def outer_race_radius_m(self) -> float:
        """Radius of the outer raceway's contact circle, (Dm + Db) / 2."""
        return (self.pitch_diameter_mm + self.ball_diameter_mm) / 2000.0

    @property
    def _diameter_ratio(self) -> float:
        """Db cos(alpha) / Dm, the ratio every defect frequency is built from."""
        return self.ball_diameter_mm / self.pitch_diameter_mm * math.cos(math.radians(self.contact_angle_deg))

    def bpfi_hz(self, rpm: float) -> float:
        """Ball-pass frequency of the inner race, (Nb / 2) fn (1 + Db/Dm cos a) (formula (3))."""
        return self.n_balls / 2.0 * shaft_frequency_hz(rpm) * (1.0 + self._diameter_ratio)

    def bpfo_hz(self, rpm: float) -> float:
        """Ball-pass frequency of the outer race, (Nb / 2) fn (1 - Db/Dm cos a) (formula (4))."""
        return self.n_balls / 2.0 * shaft_frequency_hz(rpm) * (1.0 - self._diameter_ratio)

    def bsf_hz(self, rpm: float) -> float:
        """Ball-spin frequency, Dm / (2 Db) fn (1 - (Db/Dm cos a)^2) (formula (5))."""
        ratio = self._diameter_ratio
        return self.pitch_diameter_mm / (2.0 * self.ball_diameter_mm) * shaft_frequency_hz(rpm) * (1.0 - ratio**2)

    def ftf_hz(self, rpm: float) -> float:
        """Fundamental train (cage) frequency, fn / 2 (1 - Db/Dm cos a)."""
        return shaft_frequency_hz(rpm) / 2.0 * (1.0 - self._diameter_ratio)

    def cage_angular_velocity(self, rpm: float) -> float:
        """Cage angular velocity in rad/s, omega_c = (1 - Db/Dm) omega / 2 (formula (6))."""
        return 2.0 * math.pi * self.ftf_hz(rpm)

    def defect_frequencies(self, rpm: float) -> dict[str, float]:
        """All characteristic frequencies in Hz: shaft, bpfi, bpfo, bsf, ftf."""
        return {
            "shaft": shaft_frequency_hz(rpm),
            "bpfi": self.bpfi_hz(rpm),
            "bpfo": self.bpfo_hz(rpm),
            "bsf": self.bsf_hz(rpm),
            "ftf": self.ftf_hz(rpm),
        }

    def rate_too_low(self, fs_hz: float, rpm: float) -> str | None:
        """Why a record sampled at ``fs_hz`` cannot show this bearing's faults at ``rpm`` (rev/min), None where it can:
        a rate whose Nyquist frequency lies below the highest defect line (the inner race's) records no line of a
        fault in one race at least, and no resampling brings it back."""
        lines = self.defect_frequencies(rpm)
        name = max(lines, key=lines.get)
        if fs_hz > 2.0 * lines[name]:
            return None
        return (f"the Nyquist frequency, {fs_hz / 2:g} Hz, lies below the {_LINE_NAMES[name]} at {rpm:g} rev/min "
                f"({lines[name]:.1f} Hz): a record shows this bearing's faults above fs = {2 * lines[name]:.0f} Hz")

    def describe_orders(self) -> str:
        """The outer- and inner-race defect frequencies as orders of the shaft, as messages name a bearing by them."""
        orders = self.defect_frequencies(60.0)  # in Hz at one revolution a second: orders of the shaft
        return f"BPFO {orders['bpfo']:.3f}, BPFI {orders['bpfi']:.3f} x shaft"

    def fault_frequency_hz(self, fault: str, rpm: float) -> float | None:
        """The defect frequency a fault shows in the envelope spectrum (None for a healthy bearing)."""
        key = FAULT_FREQUENCY[check_fault(fault)]
        return None if key is None else self.defect_frequencies(rpm)[key]
