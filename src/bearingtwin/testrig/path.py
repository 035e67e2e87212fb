"""The rig's transfer path from the bearing to the accelerometer, as frequency responses.

Force reaches the sensor in three stages, each a closed-form frequency response evaluated
on the record's FFT bins (the rig convolves in the frequency domain, so the record is
stationary from its first sample: no start-up transient):

1. **Strike.** A ball reaching a spall pivots on the leading edge and sinks in, shedding load
   smoothly over the fall time; it rolls on and strikes the trailing edge one crossing time
   (width / rolling speed) after the leading edge, re-loading at once with an impact: a short
   half-sine pulse whose spectrum is flat up to about 1 / (2 duration). Entry and exit make a
   double event, the entry's energy lower in frequency than the exit's (Sawalhi & Randall 2011)
   (:func:`strike_spectrum`).
2. **Contact ringing.** Part of each impact (``contact_share``) sets the rotor ringing on the
   stiffness of the loaded balls and reaches the outer ring as a damped oscillation at
   f_c = sqrt(k_r / m_rotor) / (2 pi), k_r the radial stiffness of the load zone (a few hundred
   Hz, rising with load); the rest passes straight into the outer ring
   (:meth:`RigPath.contact_transmissibility`).
3. **Housing and sensor.** Per direction (x horizontal, y vertical) a 2-DOF chain:
   the housing mass on its support stiffness (stiffer vertically, as on a foot-mounted
   housing), the accelerometer's mass on its mount stiffness on the housing. The sensor
   measures the projection of its own acceleration on its axis; the mount is taken as
   isotropic, so the sensor reading is cos(angle) a_x + sin(angle) a_y. A bolted housing is
   never perfectly symmetric: a share ``cross_coupling`` of each force direction drives the
   other direction's chain. Extra structural modes (``extra_modes``) add modal responses in
   parallel (:meth:`RigPath.sensor_frf`).

References: McFadden & Smith, J. Sound Vib. 96 (1984) for the impulse train through a
transfer path; Sawalhi & Randall, MSSP 25 (2011) for the entry/exit events of a spall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bearingtwin.errors import BearingTwinError


def _regular_ratio(numerator: np.ndarray, denominator: np.ndarray, limit: float) -> np.ndarray:
    """numerator / denominator, with ``limit`` where both vanish together (a removable singularity)."""
    singular = np.abs(denominator) < 1e-9
    return np.where(singular, limit, numerator / np.where(singular, 1.0, denominator))


def half_sine_spectrum(freqs_hz: np.ndarray, duration_s: float) -> np.ndarray:
    """Fourier transform (N s per N of peak force) of a unit half-sine pulse centred on t = 0.

    P(f) = (2 T / pi) cos(pi f T) / (1 - (2 f T)^2), real since the pulse is symmetric.
    """
    u = 2.0 * np.asarray(freqs_hz, dtype=np.float64) * duration_s
    return 2.0 * duration_s / math.pi * _regular_ratio(np.cos(math.pi * u / 2.0), 1.0 - u**2, math.pi / 4.0)


def raised_cosine_spectrum(freqs_hz: np.ndarray, duration_s: float) -> np.ndarray:
    """Fourier transform of a unit-area raised-cosine (Hann) kernel of total length T centred on t = 0.

    H(f) = sinc(f T) / (1 - (f T)^2): one at DC, a smooth low-pass above 1 / T.
    """
    u = np.asarray(freqs_hz, dtype=np.float64) * duration_s
    return _regular_ratio(np.sinc(u), 1.0 - u**2, 0.5)


def strike_spectrum(freqs_hz: np.ndarray, crossing_s: float, fall_s: float, impact_duration_s: float,
                    impact_factor: float) -> np.ndarray:
    """Force of one strike per newton of load the ball sheds, with t = 0 at the spall's leading edge.

    The shed load is a box from 0 to ``crossing_s`` whose edges ramp over ``fall_s`` (a raised
    cosine), and the trailing edge adds an impact of ``impact_factor`` newtons per newton shed,
    a half-sine of ``impact_duration_s`` at ``crossing_s``. Returned as a complex spectrum in
    N s per N.
    """
    freqs_hz = np.asarray(freqs_hz, dtype=np.float64)
    delay = np.exp(-2j * math.pi * freqs_hz * crossing_s)
    box = crossing_s * np.sinc(freqs_hz * crossing_s) * np.exp(-1j * math.pi * freqs_hz * crossing_s)
    return (-box * raised_cosine_spectrum(freqs_hz, fall_s)
            + impact_factor * half_sine_spectrum(freqs_hz, impact_duration_s) * delay)


def mode_frf(freqs_hz: np.ndarray, natural_frequency_hz: float, damping_ratio: float) -> np.ndarray:
    """Acceleration response of a unit-mass mode to a force, -w^2 / (wn^2 - w^2 + 2 i zeta wn w).

    Its magnitude is 1 / (2 zeta) at the natural frequency and tends to one far above it.
    """
    w = 2.0 * math.pi * np.asarray(freqs_hz, dtype=np.float64)
    wn = 2.0 * math.pi * natural_frequency_hz
    return -(w**2) / (wn**2 - w**2 + 2j * damping_ratio * wn * w)


@dataclass(frozen=True)
class Mode:
    """An extra structural mode in the path.

    Attributes:
        natural_frequency_hz: where it rings.
        damping_ratio: zeta; the mode's peak is 1 / (2 zeta) times its high-frequency level.
        peak_gain: its peak response relative to the largest response of the rig's own path.
    """

    natural_frequency_hz: float
    damping_ratio: float
    peak_gain: float


@dataclass(frozen=True)
class RigPath:
    """Mechanical parameters of the rig's path (defaults: a 6205 in a small foot-mounted housing).

    Attributes:
        housing_mass_kg: housing mass moving on its support.
        housing_x_hz, housing_y_hz: housing natural frequency on its support, horizontally
            and vertically (feet are stiffer vertically).
        housing_damping_ratio: zeta of the housing on its support.
        sensor_mass_kg: accelerometer mass.
        mount_hz: accelerometer-on-mount natural frequency (stud: 20+ kHz, magnet: 2-7 kHz).
        mount_damping_ratio: zeta of the mount.
        cross_coupling: share of a force in one direction that drives the other direction's chain.
        rotor_mass_kg: mass of the shaft and rotor resting on the bearing's load zone.
        contact_share: share of an impact that passes through the rotor's contact ringing.
        contact_damping_ratio: zeta of the rotor ringing on the contacts.
        contact_stiffness_ratio: contact stiffness / dry Hertz stiffness (below 1 with an oil
            film in series); scales the ringing frequency by its square root.
        contact_time_s: duration of an impact at a spall's trailing edge with a dry contact.
        extra_modes: structural modes added in parallel (effects ``resonance``, ``second_resonance``).
    """

    housing_mass_kg: float = 2.0
    housing_x_hz: float = 1100.0
    housing_y_hz: float = 1700.0
    housing_damping_ratio: float = 0.05
    sensor_mass_kg: float = 0.03
    mount_hz: float = 4200.0
    mount_damping_ratio: float = 0.04
    cross_coupling: float = 0.15
    rotor_mass_kg: float = 5.0
    contact_share: float = 0.5
    contact_damping_ratio: float = 0.06
    contact_stiffness_ratio: float = 1.0
    contact_time_s: float = 40e-6
    extra_modes: tuple[Mode, ...] = ()

    def check_nyquist(self, fs: float) -> None:
        """Refuse extra modes the sampling rate cannot show (the rig's own modes are simply band-limited)."""
        for mode in self.extra_modes:
            if mode.natural_frequency_hz >= fs / 2.0:
                raise BearingTwinError(
                    f"natural_frequency_hz={mode.natural_frequency_hz} must lie below the Nyquist frequency "
                    f"{fs / 2.0} Hz of operating_point.fs={fs}")

    def impact_duration_s(self) -> float:
        """Contact time of an edge impact: a softer contact (film) lengthens it as 1 / sqrt(stiffness)."""
        return self.contact_time_s / math.sqrt(self.contact_stiffness_ratio)

    def contact_ringing_hz(self, radial_stiffness_n_per_m: float) -> float:
        """Natural frequency of the rotor on the load zone's stiffness, scaled by the film's softening."""
        stiffness = radial_stiffness_n_per_m * self.contact_stiffness_ratio
        return math.sqrt(stiffness / self.rotor_mass_kg) / (2.0 * math.pi)

    def contact_transmissibility(self, freqs_hz: np.ndarray, radial_stiffness_n_per_m: float) -> np.ndarray:
        """Force into the outer ring per unit impact force: (1 - share) + share x (rotor ringing)."""
        w = 2.0 * math.pi * np.asarray(freqs_hz, dtype=np.float64)
        wc = 2.0 * math.pi * self.contact_ringing_hz(radial_stiffness_n_per_m)
        ringing = wc**2 / (wc**2 - w**2 + 2j * self.contact_damping_ratio * wc * w)
        return (1.0 - self.contact_share) + self.contact_share * ringing

    def _chain_frf(self, freqs_hz: np.ndarray, housing_hz: float) -> np.ndarray:
        """Sensor acceleration per unit force on the housing, (m/s^2)/N, for one direction's 2-DOF chain."""
        w = 2.0 * math.pi * np.asarray(freqs_hz, dtype=np.float64)
        k_h = self.housing_mass_kg * (2.0 * math.pi * housing_hz) ** 2
        k_s = self.sensor_mass_kg * (2.0 * math.pi * self.mount_hz) ** 2
        c_h = 2.0 * self.housing_damping_ratio * math.sqrt(k_h * self.housing_mass_kg)
        c_s = 2.0 * self.mount_damping_ratio * math.sqrt(k_s * self.sensor_mass_kg)
        coupling = k_s + 1j * w * c_s  # mount spring and damper between housing and sensor
        housing = k_h + 1j * w * c_h - w**2 * self.housing_mass_kg + coupling
        sensor = coupling - w**2 * self.sensor_mass_kg
        # [housing, -coupling; -coupling, sensor] [X_h; X_s] = [F; 0]  ->  X_s by Cramer's rule.
        sensor_displacement = coupling / (housing * sensor - coupling**2)
        return -(w**2) * sensor_displacement

    def sensor_frf(self, freqs_hz: np.ndarray, sensor_angle_rad: float) -> tuple[np.ndarray, np.ndarray]:
        """Sensor-axis acceleration per unit force in x and in y, (m/s^2)/N: (H_from_x, H_from_y)."""
        h_x = self._chain_frf(freqs_hz, self.housing_x_hz)
        h_y = self._chain_frf(freqs_hz, self.housing_y_hz)
        if self.extra_modes:
            reference = max(np.abs(h_x).max(), np.abs(h_y).max())
            extra = sum(mode.peak_gain * reference * 2.0 * mode.damping_ratio
                        * mode_frf(freqs_hz, mode.natural_frequency_hz, mode.damping_ratio)
                        for mode in self.extra_modes)
            h_x, h_y = h_x + extra, h_y + extra
        along_x, along_y = math.cos(sensor_angle_rad), math.sin(sensor_angle_rad)
        return (along_x * h_x + self.cross_coupling * along_y * h_y,
                along_y * h_y + self.cross_coupling * along_x * h_x)
