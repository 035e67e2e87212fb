"""The effects the test rig can hide in a record, written for the rig alone.

Every effect is a frozen dataclass of its parameters (validated on construction, errors name
``effects.<effect>.<parameter>``) that acts at one stage of :func:`bearingtwin.testrig.simulate_rig`;
each hook is a no-op unless overridden:

1. ``modify_speed(factor, t_s, rng)``: the shaft speed over time, as a factor on the nominal speed;
2. ``modify_impact_times(times_s, rng)``: the impact times of a race defect;
3. ``modify_path(path)``: the mechanical transfer path (:class:`~bearingtwin.testrig.path.RigPath`);
4. ``component(context, rng)``: a signal added at the sensor (lines, noise, bursts), in m/s^2;
5. ``modify_record(x, context, rng)``: the sensor and its cable acting on the whole record.

Levels in dB refer to the RMS of the bearing's own signal (the defect and roughness response
through the path), ``context.reference_rms``: a line at 0 dB has the same RMS as the bearing.
The names of the effects the twin's library also has are the twin's, so a benchmark can
check which effect the twin ranks first; :data:`OUT_OF_LIBRARY` names the others. Every class
documents the signature it leaves and the view that shows it.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields, replace
from typing import Callable, ClassVar, Iterable, Mapping

import numpy as np

from bearingtwin.errors import BearingTwinError
from bearingtwin.testrig.path import Mode, RigPath


@dataclass(frozen=True)
class RigContext:
    """What the additive and sensor-stage effects need to know about the record.

    Attributes:
        fs: sampling rate in Hz.
        shaft_angle_rad: (n,) unwrapped shaft angle, random start.
        speed_ratio: (n,) instantaneous shaft speed / nominal speed.
        shaft_hz: nominal shaft rate rpm / 60.
        reference_rms: RMS of the bearing's own signal in m/s^2; levels in dB refer to it.
    """

    fs: float
    shaft_angle_rad: np.ndarray
    speed_ratio: np.ndarray
    shaft_hz: float
    reference_rms: float

    @property
    def n_samples(self) -> int:
        return self.shaft_angle_rad.size

    @property
    def t_s(self) -> np.ndarray:
        return np.arange(self.n_samples) / self.fs

    def line_amplitude(self, level_db: float) -> float:
        """Peak amplitude of a sinusoid whose RMS is ``level_db`` relative to the bearing signal's RMS."""
        return math.sqrt(2.0) * self.reference_rms * 10.0 ** (level_db / 20.0)

    def scaled_to(self, x: np.ndarray, level_db: float) -> np.ndarray:
        """``x`` rescaled so its RMS is ``level_db`` relative to the bearing signal's RMS."""
        rms = math.sqrt(float(np.mean(x**2)))
        return x * (self.reference_rms * 10.0 ** (level_db / 20.0) / rms) if rms > 0 else x


def coloured_noise(n_samples: int, fs: float, spectral_slope: float, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean Gaussian noise of unit RMS whose power density falls as f^-spectral_slope.

    Drawn directly in the frequency domain: complex Gaussian bins shaped by f^(-slope/2), with
    the shape pinned at the lowest non-zero bin so that DC stays empty and a steep slope finite.
    """
    freqs_hz = np.fft.rfftfreq(n_samples, d=1.0 / fs)
    shape = np.zeros_like(freqs_hz)
    shape[1:] = (freqs_hz[1:] / freqs_hz[1]) ** (-spectral_slope / 2.0)
    bins = shape * (rng.standard_normal(freqs_hz.size) + 1j * rng.standard_normal(freqs_hz.size))
    noise = np.fft.irfft(bins, n=n_samples)
    return noise / np.sqrt(np.mean(noise**2))


def sum_of_lines(phase_rad: np.ndarray, multiples, amplitudes, rng: np.random.Generator,
                 unit_hz: float, fs: float) -> np.ndarray:
    """sum_k a_k cos(m_k phase + random), leaving out lines at or above the Nyquist frequency.

    ``phase_rad`` is 2 pi t for lines at fixed frequencies (then ``multiples`` are in Hz and
    ``unit_hz`` is 1) or the shaft angle for shaft orders (``unit_hz`` the shaft rate).
    """
    total = np.zeros_like(phase_rad)
    for multiple, amplitude in zip(multiples, amplitudes):
        if multiple * unit_hz < fs / 2.0:
            total += amplitude * np.cos(multiple * phase_rad + rng.uniform(0.0, 2.0 * math.pi))
    return total


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and math.isfinite(value)


_RULES: dict[str, tuple[Callable[[float], bool], str]] = {
    "finite": (lambda v: True, "be a finite number"),
    "positive": (lambda v: v > 0, "be a positive number"),
    "positive integer": (lambda v: v >= 1 and int(v) == v, "be a positive integer"),
    "in [0, 1]": (lambda v: 0 <= v <= 1, "lie in [0, 1]"),
    "in (0, 1]": (lambda v: 0 < v <= 1, "lie in (0, 1]"),
    "in (0, 1)": (lambda v: 0 < v < 1, "lie in (0, 1)"),
    "in (0, 0.5)": (lambda v: 0 < v < 0.5, "lie in (0, 0.5)"),
    "in [0, 3]": (lambda v: 0 <= v <= 3, "lie in [0, 3]"),
}
"""Rules an effect's parameters are checked against, by name: (test of a finite number, requirement)."""


class RigEffect:
    """Base of the rig's effects: every stage leaves the record unchanged unless overridden.

    ``rules`` maps each parameter to a rule of :data:`_RULES`; a tuple-valued parameter
    (``" each"`` appended to the rule) is stored as a tuple, each element checked.
    """

    name: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    in_twin_library: ClassVar[bool] = True
    rules: ClassVar[dict[str, str]] = {}

    def __post_init__(self) -> None:
        for field, rule in self.rules.items():
            values = [getattr(self, field)]
            if rule.endswith(" each"):
                rule = rule.removesuffix(" each")
                if isinstance(values[0], str) or not isinstance(values[0], Iterable):
                    self._fail(field, "be a list of numbers")
                object.__setattr__(self, field, tuple(values[0]))
                values = getattr(self, field)
                if not values:
                    self._fail(field, "hold at least one number")
            test, requirement = _RULES[rule]
            if not all(_is_number(v) and test(v) for v in values):
                self._fail(field, requirement)
        self._check()

    def _check(self) -> None:
        """Checks across parameters, where a rule per parameter is not enough."""

    def _fail(self, field: str, requirement: str) -> None:
        raise BearingTwinError(f"effects.{self.name}.{field} must {requirement}, got {getattr(self, field)!r}")

    def modify_speed(self, factor: np.ndarray, t_s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return factor

    def modify_impact_times(self, times_s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return times_s

    def modify_path(self, path: RigPath) -> RigPath:
        return path

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray | None:
        return None

    def modify_record(self, x: np.ndarray, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        return x


# ---------------------------------------------------------------- effects the twin's library has


@dataclass(frozen=True)
class Resonance(RigEffect):
    """An extra structural mode in the path (a bracket, a cover, a loose sensor cable clamp).

    A modal response added in parallel to the rig's housing and mount modes, in both
    directions.

    Args:
        natural_frequency_hz: where the mode rings.
        damping_ratio: its zeta.
        peak_gain: its peak response relative to the largest response of the rig's own path.

    Signature (PSD band energy): a band of raised energy around the natural frequency, about
    2 zeta f_n wide; the impacts ring at it, so the envelope of that band carries the defect rate.
    """

    name: ClassVar[str] = "resonance"
    signature: ClassVar[str] = "raised PSD band around the natural frequency"
    rules: ClassVar[dict[str, str]] = {"natural_frequency_hz": "positive", "damping_ratio": "positive",
                                       "peak_gain": "positive"}
    natural_frequency_hz: float = 2500.0
    damping_ratio: float = 0.03
    peak_gain: float = 1.0

    def modify_path(self, path: RigPath) -> RigPath:
        mode = Mode(self.natural_frequency_hz, self.damping_ratio, self.peak_gain)
        return replace(path, extra_modes=path.extra_modes + (mode,))


@dataclass(frozen=True)
class SecondResonance(RigEffect):
    """Two extra structural modes, a second on top of a first (e.g. a magnet base on a bracket).

    Args:
        frequencies_hz: natural frequencies of the first and the second mode.
        damping_ratio: zeta of both.
        peak_gain: peak response of each relative to the largest response of the rig's own path.

    Signature (PSD band energy): two separate bands of raised energy, one per mode.
    """

    name: ClassVar[str] = "second_resonance"
    signature: ClassVar[str] = "two raised PSD bands"
    rules: ClassVar[dict[str, str]] = {"frequencies_hz": "positive each", "damping_ratio": "positive",
                                       "peak_gain": "positive"}
    frequencies_hz: tuple[float, float] = (1800.0, 3600.0)
    damping_ratio: float = 0.03
    peak_gain: float = 1.0

    def _check(self) -> None:
        if len(self.frequencies_hz) != 2:
            self._fail("frequencies_hz", "be two frequencies")

    def modify_path(self, path: RigPath) -> RigPath:
        modes = tuple(Mode(f, self.damping_ratio, self.peak_gain) for f in self.frequencies_hz)
        return replace(path, extra_modes=path.extra_modes + modes)


@dataclass(frozen=True)
class Slip(RigEffect):
    """Random slip of the balls: a race defect's impacts come early or late (Antoni & Randall 2003).

    Each impact time moves by an independent Gaussian amount of standard deviation ``jitter``
    times the local impact spacing (1-2 % in practice). Ball defects are left alone: their
    strikes follow the ball's spin, not the cage.

    Signature (envelope spectrum): harmonics of the defect frequency weaken with order and
    sink into a raised random floor; the PSD and time statistics hardly change.
    """

    name: ClassVar[str] = "slip"
    signature: ClassVar[str] = "envelope harmonics fall with order into a random floor"
    rules: ClassVar[dict[str, str]] = {"jitter": "in (0, 0.5)"}  # beyond, impacts would swap order
    jitter: float = 0.02

    def modify_impact_times(self, times_s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        if times_s.size < 2:
            return times_s
        return times_s + rng.normal(0.0, self.jitter, times_s.size) * np.gradient(times_s)


@dataclass(frozen=True)
class SpeedFluctuation(RigEffect):
    """Periodic shaft-speed variation: speed = nominal (1 + depth sin(2 pi frequency_hz t + phi)).

    Every rotating part (impacts, shaft-synchronous lines, gear mesh) follows the shaft angle,
    so all of them are frequency-modulated together.

    Args:
        depth: peak relative speed deviation.
        frequency_hz: modulation frequency (belt, coupling, load torque ripple).

    Signature (envelope spectrum, PSD): defect harmonics smear into sidebands at +-frequency_hz,
    spreading as harmonic order x depth x defect frequency / frequency_hz.
    """

    name: ClassVar[str] = "speed_fluctuation"
    signature: ClassVar[str] = "harmonics smeared more with order"
    rules: ClassVar[dict[str, str]] = {"depth": "in (0, 0.5)", "frequency_hz": "positive"}
    depth: float = 0.01
    frequency_hz: float = 2.0

    def modify_speed(self, factor: np.ndarray, t_s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return factor * (1.0 + self.depth * np.sin(2.0 * math.pi * self.frequency_hz * t_s
                                                   + rng.uniform(0.0, 2.0 * math.pi)))


@dataclass(frozen=True)
class Noise(RigEffect):
    """Background noise at the sensor: machinery, flow, electronics.

    Args:
        snr_db: bearing-signal power over noise power, dB.
        spectral_slope: noise PSD ~ f^-slope (0 white, 1 pink).

    Signature (PSD, time statistics): a raised floor where the bearing is quiet, lower kurtosis
    and crest factor, a raised envelope-spectrum floor.
    """

    name: ClassVar[str] = "noise"
    signature: ClassVar[str] = "raised floor, lower kurtosis"
    rules: ClassVar[dict[str, str]] = {"snr_db": "finite", "spectral_slope": "in [0, 3]"}
    snr_db: float = 10.0
    spectral_slope: float = 1.0

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        noise = coloured_noise(context.n_samples, context.fs, self.spectral_slope, rng)
        return context.reference_rms * 10.0 ** (-self.snr_db / 20.0) * noise


@dataclass(frozen=True)
class Tones(RigEffect):
    """Discrete lines from other machines on the rig (a fan, a pump, a neighbouring gearbox).

    Args:
        frequencies_hz: line frequencies, unrelated to the shaft rate and the supply.
        levels_db: each line's RMS relative to the bearing signal's, dB.

    Signature (PSD): narrow lines at those frequencies; no sidebands, nothing in the envelope.
    """

    name: ClassVar[str] = "tones"
    signature: ClassVar[str] = "discrete PSD lines unrelated to the shaft"
    rules: ClassVar[dict[str, str]] = {"frequencies_hz": "positive each", "levels_db": "finite each"}
    frequencies_hz: tuple[float, ...] = (47.0, 173.0, 311.0)
    levels_db: tuple[float, ...] = (0.0, -3.0, -6.0)

    def _check(self) -> None:
        if len(self.levels_db) != len(self.frequencies_hz):
            self._fail("levels_db", f"hold {len(self.frequencies_hz)} levels, one per frequency")

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        amplitudes = [context.line_amplitude(level) for level in self.levels_db]
        return sum_of_lines(2.0 * math.pi * context.t_s, self.frequencies_hz, amplitudes, rng, 1.0, context.fs)


@dataclass(frozen=True)
class Lubrication(RigEffect):
    """An oil film in the ball-race contacts: a softer, more damped contact.

    The film in series with the Hertz contact lowers the contact stiffness, so the rotor's
    ringing on the load zone moves down by sqrt(stiffness_ratio) and each edge impact lasts
    longer (1 / sqrt(stiffness_ratio)); its viscosity adds damping to the ringing.

    Args:
        stiffness_ratio: contact stiffness with the film / dry contact stiffness, in (0, 1].
        damping_ratio: zeta added to the rotor's contact ringing.

    Signature (PSD band energy): the contact-ringing band (a few hundred Hz) moves down and
    flattens; a little less energy at the highest frequencies.
    """

    name: ClassVar[str] = "lubrication"
    signature: ClassVar[str] = "contact-ringing band lower and flatter"
    rules: ClassVar[dict[str, str]] = {"stiffness_ratio": "in (0, 1]", "damping_ratio": "positive"}
    stiffness_ratio: float = 0.7
    damping_ratio: float = 0.06

    def modify_path(self, path: RigPath) -> RigPath:
        return replace(path, contact_stiffness_ratio=path.contact_stiffness_ratio * self.stiffness_ratio,
                       contact_damping_ratio=path.contact_damping_ratio + self.damping_ratio)


@dataclass(frozen=True)
class Unbalance(RigEffect):
    """Mass unbalance of the rotor: a centrifugal force turning with the shaft.

    The force grows with the square of the speed, so under a speed fluctuation the line is
    modulated in amplitude as well as in frequency.

    Args:
        level_db: the 1x line's RMS relative to the bearing signal's, dB (at nominal speed).

    Signature (PSD): a line at exactly rpm / 60 Hz, no harmonics.
    """

    name: ClassVar[str] = "unbalance"
    signature: ClassVar[str] = "PSD line at 1x shaft rate"
    rules: ClassVar[dict[str, str]] = {"level_db": "finite"}
    level_db: float = 0.0

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        line = sum_of_lines(context.shaft_angle_rad, (1.0,), (context.line_amplitude(self.level_db),), rng,
                            context.shaft_hz, context.fs)
        return line * context.speed_ratio**2


@dataclass(frozen=True)
class Misalignment(RigEffect):
    """Shaft misalignment at the coupling: a bending moment reversing twice per revolution.

    Args:
        level_db: RMS of the dominant 2x line relative to the bearing signal's, dB; the 1x line
            is 6 dB and the 3x line 10 dB below it (typical of angular-plus-parallel misalignment).

    Signature (PSD): lines at 1x, 2x, 3x shaft rate with 2x the largest.
    """

    name: ClassVar[str] = "misalignment"
    signature: ClassVar[str] = "PSD lines at 1x, 2x, 3x with 2x dominant"
    rules: ClassVar[dict[str, str]] = {"level_db": "finite"}
    level_db: float = 0.0
    RELATIVE_DB: ClassVar[tuple[float, float, float]] = (-6.0, 0.0, -10.0)

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        amplitudes = [context.line_amplitude(self.level_db + relative) for relative in self.RELATIVE_DB]
        return sum_of_lines(context.shaft_angle_rad, (1.0, 2.0, 3.0), amplitudes, rng, context.shaft_hz, context.fs)


@dataclass(frozen=True)
class Looseness(RigEffect):
    """Mechanical looseness: a loose foot or bearing seat rattling against its stop.

    The joint opens only when the rotating force plus a half-order rocking (it lands every
    other revolution) exceeds the hold-down: the response is that drive truncated at a
    threshold, r = max(0, cos(theta) + 0.6 cos(theta / 2 + phi) - 0.9). The truncation turns two
    smooth lines into short pulses, i.e. many harmonics of half the shaft rate.

    Args:
        level_db: RMS of the rattle relative to the bearing signal's, dB.

    Signature (PSD): half-order lines (0.5x, 1.5x, ...) and many integer harmonics of the shaft rate.
    """

    name: ClassVar[str] = "looseness"
    signature: ClassVar[str] = "half-order and many integer shaft harmonics"
    rules: ClassVar[dict[str, str]] = {"level_db": "finite"}
    level_db: float = 0.0

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        theta = context.shaft_angle_rad
        drive = np.cos(theta) + 0.6 * np.cos(theta / 2.0 + rng.uniform(0.0, 2.0 * math.pi))
        rattle = np.clip(drive - 0.9, 0.0, None)
        return context.scaled_to(rattle - rattle.mean(), self.level_db)


@dataclass(frozen=True)
class LineFrequency(RigEffect):
    """Electromagnetic pull of the motor: lines at twice the supply frequency and its harmonics.

    Args:
        supply_hz: mains frequency (50 or 60 Hz).
        level_db: RMS of the 2 x supply line relative to the bearing signal's, dB; harmonic k of
            it has 1/k of its amplitude.
        n_harmonics: lines at 2 k x supply_hz, k = 1..n_harmonics.

    Signature (PSD): lines at 100/200/300 Hz (50 Hz mains) or 120/240/360 Hz (60 Hz), whatever
    the shaft speed.
    """

    name: ClassVar[str] = "line_frequency"
    signature: ClassVar[str] = "PSD lines at 2 x supply and harmonics"
    rules: ClassVar[dict[str, str]] = {"supply_hz": "positive", "level_db": "finite", "n_harmonics": "positive integer"}
    supply_hz: float = 60.0
    level_db: float = 0.0
    n_harmonics: int = 3

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        orders = [2.0 * k * self.supply_hz for k in range(1, int(self.n_harmonics) + 1)]
        amplitudes = [context.line_amplitude(self.level_db) / k for k in range(1, int(self.n_harmonics) + 1)]
        return sum_of_lines(2.0 * math.pi * context.t_s, orders, amplitudes, rng, 1.0, context.fs)


@dataclass(frozen=True)
class Clipping(RigEffect):
    """Saturation of the sensor's amplifier or the acquisition's input range.

    Args:
        level_rms: clipping level in multiples of the record's RMS before clipping.

    Signature (time statistics): |x| capped at one level (flat tops), lower kurtosis and crest
    factor; harmonics spread over the PSD.
    """

    name: ClassVar[str] = "clipping"
    signature: ClassVar[str] = "flat tops, capped |x|, lower kurtosis"
    rules: ClassVar[dict[str, str]] = {"level_rms": "positive"}
    level_rms: float = 2.5

    def modify_record(self, x: np.ndarray, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        limit = self.level_rms * math.sqrt(float(np.mean(x**2)))
        return np.clip(x, -limit, limit)


# ---------------------------------------------------------------- effects the twin's library lacks


@dataclass(frozen=True)
class GearMesh(RigEffect):
    """A gear on the shaft (a gearbox load, a pump drive) meshing with its partner.

    The transmission error repeats once per tooth; the pinion's eccentricity modulates it once
    per revolution: (1 + m cos(theta)) [cos(z theta) + 0.5 cos(2 z theta)].

    Args:
        n_teeth: teeth z on the shaft's gear; the mesh frequency is z x shaft rate.
        level_db: RMS of the mesh line relative to the bearing signal's, dB.
        modulation_depth: m, the once-per-revolution amplitude modulation.

    Signature (PSD): lines at z and 2z x shaft rate, each with sidebands at +-1x shaft rate; the
    envelope of the mesh band shows the shaft rate, not a defect frequency.
    """

    name: ClassVar[str] = "gear_mesh"
    signature: ClassVar[str] = "PSD mesh lines with shaft-rate sidebands"
    in_twin_library: ClassVar[bool] = False
    rules: ClassVar[dict[str, str]] = {"n_teeth": "positive integer", "level_db": "finite",
                                       "modulation_depth": "in [0, 1]"}
    n_teeth: int = 29
    level_db: float = 0.0
    modulation_depth: float = 0.4

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        amplitude = context.line_amplitude(self.level_db)
        z = float(self.n_teeth)
        mesh = sum_of_lines(context.shaft_angle_rad, (z, 2.0 * z), (amplitude, 0.5 * amplitude), rng,
                            context.shaft_hz, context.fs)
        return mesh * (1.0 + self.modulation_depth * np.cos(context.shaft_angle_rad))


@dataclass(frozen=True)
class Rub(RigEffect):
    """A rotor rubbing on a seal or a guard once per revolution.

    While the high spot touches (``contact_fraction`` of a turn) friction excites the structure
    broadband: a burst of white noise under a smooth window fixed to the shaft angle.

    Args:
        level_db: RMS of the bursts over the record relative to the bearing signal's, dB.
        contact_fraction: share of a revolution the rub lasts.

    Signature (envelope spectrum, time statistics): broadband bursts once per revolution, so
    the envelope shows 1x shaft rate and its harmonics (not a defect frequency); kurtosis rises.
    """

    name: ClassVar[str] = "rub"
    signature: ClassVar[str] = "broadband bursts once per revolution: envelope lines at 1x"
    in_twin_library: ClassVar[bool] = False
    rules: ClassVar[dict[str, str]] = {"level_db": "finite", "contact_fraction": "in (0, 1)"}
    level_db: float = 0.0
    contact_fraction: float = 0.1

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        turn = np.mod(context.shaft_angle_rad - rng.uniform(0.0, 2.0 * math.pi), 2.0 * math.pi) / (2.0 * math.pi)
        window = np.where(turn < self.contact_fraction, np.sin(math.pi * turn / self.contact_fraction) ** 2, 0.0)
        return context.scaled_to(window * rng.standard_normal(context.n_samples), self.level_db)


@dataclass(frozen=True)
class AmInterference(RigEffect):
    """Electromagnetic pick-up from a drive: a switching carrier, amplitude-modulated.

    A frequency converter's PWM carrier couples into an unshielded cable; its amplitude follows
    the drive's output frequency: (1 + depth cos(2 pi modulation_hz t)) cos(2 pi carrier_hz t).

    Args:
        carrier_hz: carrier frequency (below the Nyquist frequency).
        modulation_hz: modulation frequency, unrelated to the shaft and the bearing.
        depth: modulation depth in [0, 1].
        level_db: RMS of the carrier relative to the bearing signal's, dB.

    Signature (PSD, envelope spectrum): a line at the carrier with sidebands at +-modulation_hz,
    and an envelope line at modulation_hz that matches no bearing frequency.
    """

    name: ClassVar[str] = "am_interference"
    signature: ClassVar[str] = "carrier with sidebands; envelope line at the modulation frequency"
    in_twin_library: ClassVar[bool] = False
    rules: ClassVar[dict[str, str]] = {"carrier_hz": "positive", "modulation_hz": "positive", "depth": "in [0, 1]",
                                       "level_db": "finite"}
    carrier_hz: float = 3300.0
    modulation_hz: float = 37.0
    depth: float = 0.8
    level_db: float = 0.0

    def component(self, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        if self.carrier_hz + self.modulation_hz >= context.fs / 2.0:
            self._fail("carrier_hz", f"lie below the Nyquist frequency {context.fs / 2.0} Hz less modulation_hz")
        phase = 2.0 * math.pi * context.t_s
        envelope = 1.0 + self.depth * np.cos(self.modulation_hz * phase + rng.uniform(0.0, 2.0 * math.pi))
        carrier = sum_of_lines(phase, (self.carrier_hz,), (context.line_amplitude(self.level_db),), rng, 1.0,
                               context.fs)
        return envelope * carrier


@dataclass(frozen=True)
class CableCrackle(RigEffect):
    """A loose connector or a broken cable shield: the signal drops out, and snaps back with a spike.

    Events arrive at random (Poisson, ``rate_per_s``); in each the contact is lost for a random
    time up to ``dropout_ms`` (the AC-coupled input reads zero) and a decaying spike of
    +-``spike_level_rms`` times the record's RMS marks the reconnection.

    Signature (time statistics): flat zero stretches and isolated spikes at random times, so the
    kurtosis rises while the envelope spectrum gains no line (the events are not periodic).
    """

    name: ClassVar[str] = "cable_crackle"
    signature: ClassVar[str] = "random dropouts and spikes: high kurtosis, no envelope line"
    in_twin_library: ClassVar[bool] = False
    rate_per_s: float = 4.0
    dropout_ms: float = 2.0
    spike_level_rms: float = 8.0

    rules: ClassVar[dict[str, str]] = {"rate_per_s": "positive", "dropout_ms": "positive",
                                       "spike_level_rms": "positive"}
    SPIKE_DECAY_S: ClassVar[float] = 1e-4

    def modify_record(self, x: np.ndarray, context: RigContext, rng: np.random.Generator) -> np.ndarray:
        n, fs = x.size, context.fs
        spike = self.spike_level_rms * math.sqrt(float(np.mean(x**2)))
        starts = np.sort(rng.integers(0, n, rng.poisson(self.rate_per_s * n / fs)))
        lengths = np.maximum(1, (rng.uniform(0.2, 1.0, starts.size) * self.dropout_ms * 1e-3 * fs).astype(int))
        signs = rng.choice([-1.0, 1.0], starts.size)
        decay = np.exp(-np.arange(int(10 * self.SPIKE_DECAY_S * fs) + 1) / (self.SPIKE_DECAY_S * fs))
        out = x.copy()
        for start, length, sign in zip(starts, lengths, signs):
            out[start:start + length] = 0.0
            tail = out[start + length:start + length + decay.size]
            tail += sign * spike * decay[:tail.size]
        return out


_CLASSES: tuple[type[RigEffect], ...] = (
    Resonance, SecondResonance, Slip, SpeedFluctuation, Noise, Tones, Lubrication, Unbalance, Misalignment,
    Looseness, LineFrequency, GearMesh, Rub, AmInterference, CableCrackle, Clipping,
)
"""Every effect, in the order the rig applies them within a stage (cable before the amplifier's clipping)."""

_BY_NAME = {cls.name: cls for cls in _CLASSES}

RIG_EFFECTS: dict[str, dict] = {cls.name: {f.name: f.default for f in fields(cls)} for cls in _CLASSES}
"""Every effect the rig can hide: name -> its default parameters."""

OUT_OF_LIBRARY: tuple[str, ...] = tuple(cls.name for cls in _CLASSES if not cls.in_twin_library)
"""The rig's effects the twin's effect library has no counterpart for."""


def build_rig_effects(effects: Mapping[str, Mapping] | None) -> list[RigEffect]:
    """Effect instances from ``{name: {parameter: value}}`` (missing parameters take their defaults).

    Returned in the rig's stage order, whatever the mapping's order, so a record does not depend
    on how the caller listed its effects.
    """
    effects = {} if effects is None else effects
    if not isinstance(effects, Mapping):
        raise BearingTwinError(f"effects must be a mapping of effect name to parameters, got {type(effects).__name__}")
    unknown = [name for name in effects if name not in _BY_NAME]
    if unknown:
        raise BearingTwinError(f"effects: {', '.join(map(repr, unknown))} is not a rig effect; "
                               f"choose from {', '.join(_BY_NAME)}")
    built = []
    for cls in _CLASSES:
        if cls.name not in effects:
            continue
        params = effects[cls.name] or {}
        if not isinstance(params, Mapping):
            raise BearingTwinError(f"effects.{cls.name} must be a mapping of parameters, got {params!r}")
        extra = [key for key in params if key not in RIG_EFFECTS[cls.name]]
        if extra:
            raise BearingTwinError(f"effects.{cls.name}.{extra[0]} is not a parameter of {cls.name}; "
                                   f"it has {', '.join(RIG_EFFECTS[cls.name])}")
        built.append(cls(**params))
    return built
